// KLV telemetry kept in sync through samples/ts_klv_stabilize.sh. The test makes a drone-like
// MPEG-TS itself: the synthetic shaky flight (320x240, 30 fps) encoded to H.264, plus a KLV
// stream (meta/x-klv) with one MISB ST 0601 packet per frame, stamped with that frame's PTS
// and carrying its number. The sample stabilizes it (uavstabilize holds 20 frames) and
// remuxes the KLV; the output, demuxed and decoded, must hold every frame and every KLV
// packet, unchanged, and the packet of frame k must have frame k's timestamp.
// Also: sparse KLV (one packet every 5 s: the muxer must not stall the demuxer while it
// waits for the next one), an MPEG-2 TS without KLV (video alone), wrong arguments.
// Skips (exit 77) when a GStreamer element or tool it needs is missing.
#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include <gst/app/gstappsrc.h>
#include <glib/gstdio.h>
#include <unistd.h>

#include "shaky_flight.hpp"
#include "test_support.hpp"

#ifndef SOURCE_DIR
#error "SOURCE_DIR must name the project's source directory"
#endif

using namespace element_test;

namespace {

constexpr int kFps = 30;
// One tick of the TS 90 kHz clock: the muxers round each timestamp to a tick.
constexpr GstClockTimeDiff kTick = GST_SECOND / 90000 + 1;

// ---- KLV (MISB ST 0601 UAS Datalink Local Set) ----

const guint8 kUasLsKey[16] = {0x06, 0x0E, 0x2B, 0x34, 0x02, 0x0B, 0x01, 0x01,
                              0x0E, 0x01, 0x03, 0x01, 0x01, 0x00, 0x00, 0x00};

// ST 0601's checksum: a 16-bit running sum of the packet as big-endian 16-bit words, from
// the key to the checksum's own length byte.
guint16 klvChecksum(const guint8 *data, std::size_t size)
{
    guint16 sum = 0;
    for (std::size_t i = 0; i < size; ++i)
        sum = guint16(sum + (data[i] << (8 * ((i + 1) % 2))));
    return sum;
}

// Key, BER length, then the local set: tag 2 precision timestamp (microseconds since 1970,
// 8 bytes), tag 3 mission ID "frame NNNNNN" (the frame number), tag 65 LS version, tag 1
// checksum (last, as the standard wants).
std::vector<guint8> makeKlv(int frame, GstClockTime pts)
{
    std::vector<guint8> set;
    auto item = [&set](guint8 tag, const std::vector<guint8> &value) {
        set.push_back(tag);
        set.push_back(guint8(value.size()));
        set.insert(set.end(), value.begin(), value.end());
    };
    const guint64 micros = 1'700'000'000'000'000ull + pts / 1000;
    std::vector<guint8> stamp;
    for (int shift = 56; shift >= 0; shift -= 8)
        stamp.push_back(guint8(micros >> shift));
    item(2, stamp);
    char mission[32];
    std::snprintf(mission, sizeof mission, "frame %06d", frame);
    item(3, std::vector<guint8>(mission, mission + std::strlen(mission)));
    item(65, {17});
    std::vector<guint8> packet(kUasLsKey, kUasLsKey + 16);
    packet.push_back(guint8(set.size() + 4));  // short-form BER: < 128 bytes
    packet.insert(packet.end(), set.begin(), set.end());
    packet.push_back(1);
    packet.push_back(2);
    const guint16 sum = klvChecksum(packet.data(), packet.size());
    packet.push_back(guint8(sum >> 8));
    packet.push_back(guint8(sum & 0xff));
    return packet;
}

// The frame number of a packet made by makeKlv, or -1 if it is not a valid ST 0601
// packet (key, BER length, local set, checksum) with a "frame N" mission ID.
int klvFrameNumber(const std::vector<guint8> &p)
{
    if (p.size() < 17 || std::memcmp(p.data(), kUasLsKey, 16) != 0)
        return -1;
    std::size_t pos = 16, length = p[pos++];
    if (length & 0x80) {  // long-form BER
        const std::size_t bytes = length & 0x7f;
        if (bytes == 0 || bytes > 4 || pos + bytes > p.size())
            return -1;
        length = 0;
        for (std::size_t i = 0; i < bytes; ++i)
            length = (length << 8) | p[pos++];
    }
    if (pos + length != p.size())
        return -1;
    int frame = -1;
    bool checksum_ok = false;
    while (pos + 2 <= p.size()) {
        const guint8 tag = p[pos], size = p[pos + 1];
        if (tag & 0x80 || size & 0x80 || pos + 2 + size > p.size())
            return -1;
        const guint8 *value = p.data() + pos + 2;
        if (tag == 3) {
            const std::string text(reinterpret_cast<const char *>(value), size);
            if (text.rfind("frame ", 0) == 0)
                frame = std::atoi(text.c_str() + 6);
        } else if (tag == 1 && size == 2 && pos + 4 == p.size()) {
            checksum_ok = klvChecksum(p.data(), pos + 2) == guint16((value[0] << 8) | value[1]);
        }
        pos += 2 + size;
    }
    return pos == p.size() && checksum_ok ? frame : -1;
}

// ---- the input TS ----

enum class Codec { H264, Mpeg2 };

struct MadeTs {
    std::vector<GstClockTime> pts;  // of frame k, as pushed
    std::map<int, std::vector<guint8>> klv;  // frame -> packet, as pushed
};

struct Size {
    int width = 320, height = 240;
};

// The synthetic flight, `frames` frames, as H.264 (or MPEG-2) in a TS, with a KLV packet on
// every `klv_every`-th frame (0: no KLV stream), stamped like its frame.
MadeTs makeInputTs(const std::string &path, int frames, int klv_every, Codec codec = Codec::H264, Size size = {})
{
    const std::string encoder = codec == Codec::H264
                                    ? "x264enc speed-preset=veryfast key-int-max=30 ! h264parse"
                                    : "mpeg2enc format=3 ! mpegvideoparse";
    std::string description = "appsrc name=video format=time caps=video/x-raw,format=I420,width=" +
                              std::to_string(size.width) + ",height=" + std::to_string(size.height) + ",framerate=" +
                              std::to_string(kFps) + "/1 ! " + encoder + " ! mpegtsmux name=mux ! filesink location=" +
                              path;
    if (klv_every > 0)
        description += " appsrc name=klv format=time caps=meta/x-klv,parsed=true ! mux.";
    GstElement *pipeline = launchPipeline(description);
    GstElement *video = gst_bin_get_by_name(GST_BIN(pipeline), "video");
    GstElement *klv = klv_every > 0 ? gst_bin_get_by_name(GST_BIN(pipeline), "klv") : nullptr;
    fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);

    uavstab::synthetic::FlightOptions options;
    options.width = size.width;
    options.height = size.height;
    options.frames = frames;
    options.fps = kFps;
    const uavstab::synthetic::ShakyFlight flight(options);
    GstCaps *caps = videoCaps("I420", size.width, size.height, kFps);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);

    MadeTs made;
    for (int k = 0; k < frames; ++k) {
        const GstClockTime pts = gst_util_uint64_scale(k, GST_SECOND, kFps);
        const GstClockTime duration = gst_util_uint64_scale(k + 1, GST_SECOND, kFps) - pts;
        GstBuffer *frame = makeFrame(info, flight.render(k).view());
        GST_BUFFER_PTS(frame) = pts;
        GST_BUFFER_DURATION(frame) = duration;
        fail_unless_equals_int(gst_app_src_push_buffer(GST_APP_SRC(video), frame), GST_FLOW_OK);
        made.pts.push_back(pts);
        if (klv && k % klv_every == 0) {
            std::vector<guint8> packet = makeKlv(k, pts);
            GstBuffer *buffer = gst_buffer_new_memdup(packet.data(), packet.size());
            GST_BUFFER_PTS(buffer) = pts;
            GST_BUFFER_DURATION(buffer) = duration;
            fail_unless_equals_int(gst_app_src_push_buffer(GST_APP_SRC(klv), buffer), GST_FLOW_OK);
            made.klv[k] = std::move(packet);
        }
    }
    gst_app_src_end_of_stream(GST_APP_SRC(video));
    if (klv)
        gst_app_src_end_of_stream(GST_APP_SRC(klv));
    gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_EOS, 60 * GST_SECOND));
    gst_element_set_state(pipeline, GST_STATE_NULL);
    if (klv)
        gst_object_unref(klv);
    gst_object_unref(video);
    gst_object_unref(pipeline);
    return made;
}

// ---- reading a TS back ----

struct KlvSeen {
    GstClockTime pts;
    std::vector<guint8> bytes;
};

struct ReadTs {
    std::vector<GstClockTime> video;  // decoded frames, in presentation order
    std::vector<KlvSeen> klv;         // in stream order
};

GstPadProbeReturn recordVideo(GstPad *, GstPadProbeInfo *info, gpointer user_data)
{
    static_cast<ReadTs *>(user_data)->video.push_back(GST_BUFFER_PTS(GST_PAD_PROBE_INFO_BUFFER(info)));
    return GST_PAD_PROBE_OK;
}

GstPadProbeReturn recordKlv(GstPad *, GstPadProbeInfo *info, gpointer user_data)
{
    GstBuffer *buffer = GST_PAD_PROBE_INFO_BUFFER(info);
    KlvSeen seen{GST_BUFFER_PTS(buffer), std::vector<guint8>(gst_buffer_get_size(buffer))};
    gst_buffer_extract(buffer, 0, seen.bytes.data(), seen.bytes.size());
    static_cast<ReadTs *>(user_data)->klv.push_back(std::move(seen));
    return GST_PAD_PROBE_OK;
}

// Demuxes a TS and decodes its video (of `video_type`). `with_klv`: it has a KLV stream.
ReadTs readTs(const std::string &path, bool with_klv, const char *video_type = "video/x-h264")
{
    std::string description = "filesrc location=" + path + " ! tsdemux name=d d. ! " + video_type +
                              " ! queue ! decodebin ! fakesink name=video sync=false";
    if (with_klv)
        description += " d. ! meta/x-klv ! queue ! fakesink name=klv sync=false";
    GstElement *pipeline = launchPipeline(description);
    ReadTs read;
    const char *names[] = {"video", "klv"};
    for (int i = 0; i < (with_klv ? 2 : 1); ++i) {
        GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), names[i]);
        GstPad *pad = gst_element_get_static_pad(sink, "sink");
        gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, i == 0 ? recordVideo : recordKlv, &read, nullptr);
        gst_object_unref(pad);
        gst_object_unref(sink);
    }
    fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
    gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_EOS, 60 * GST_SECOND));
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(pipeline);
    return read;
}

// ---- the sample ----

struct ScriptRun {
    int status = -1;
    std::string output;
};

ScriptRun runSample(const std::vector<std::string> &args)
{
    // `timeout`: a hang (the muxer waiting forever) fails here, not at the test's timeout.
    std::vector<std::string> words = {"timeout", "60", "bash", std::string(SOURCE_DIR) + "/samples/ts_klv_stabilize.sh"};
    words.insert(words.end(), args.begin(), args.end());
    std::vector<char *> argv;
    for (auto &w : words)
        argv.push_back(w.data());
    argv.push_back(nullptr);
    ScriptRun run;
    gchar *out = nullptr, *err = nullptr;
    GError *error = nullptr;
    const gboolean spawned = g_spawn_sync(nullptr, argv.data(), nullptr, G_SPAWN_SEARCH_PATH, nullptr, nullptr, &out,
                                          &err, &run.status, &error);
    fail_unless(spawned, "cannot run the sample: %s", error ? error->message : "?");
    run.output = std::string(out ? out : "") + (err ? err : "");
    g_free(out);
    g_free(err);
    if (g_spawn_check_wait_status(run.status, nullptr))
        run.status = 0;
    else if (run.status == 0)
        run.status = -1;
    return run;
}

std::string tempDir()
{
    gchar *dir = g_dir_make_tmp("uavstab-klv-XXXXXX", nullptr);
    fail_unless(dir != nullptr);
    std::string path(dir);
    g_free(dir);
    return path;
}

void removeDir(const std::string &dir, const std::vector<std::string> &files)
{
    for (const auto &f : files)
        g_remove((dir + "/" + f).c_str());
    g_rmdir(dir.c_str());
}

GstClockTimeDiff diff(GstClockTime a, GstClockTime b) { return GstClockTimeDiff(a) - GstClockTimeDiff(b); }

// The whole check: the input as made, the input as demuxed, the output as demuxed.
void checkKlvInSync(int frames, int klv_every, Size size = {})
{
    const std::string dir = tempDir(), in = dir + "/in.ts", out = dir + "/out.ts";
    const gint64 start = g_get_monotonic_time();
    const MadeTs made = makeInputTs(in, frames, klv_every, Codec::H264, size);
    const gint64 made_at = g_get_monotonic_time();
    const std::size_t packets = made.klv.size();

    // The input: every frame, every packet, frame k at the pushed PTS plus the muxer's offset.
    const ReadTs input = readTs(in, true);
    fail_unless_equals_int(int(input.video.size()), frames);
    fail_unless_equals_int(int(input.klv.size()), int(packets));
    const GstClockTimeDiff in_offset = diff(input.video[0], made.pts[0]);
    for (int k = 0; k < frames; ++k)
        fail_unless(std::abs(diff(input.video[k], made.pts[k]) - in_offset) <= kTick,
                    "input frame %d at %" GST_TIME_FORMAT, k, GST_TIME_ARGS(input.video[k]));

    const gint64 sample_start = g_get_monotonic_time();
    const ScriptRun run = runSample({in, out, "delay=20", "threads=2"});
    const gint64 sample_end = g_get_monotonic_time();
    fail_unless(run.status == 0, "the sample failed (wait status %d):\n%s", run.status, run.output.c_str());

    const ReadTs output = readTs(out, true);
    // Every frame, in order, each at its input PTS (plus the new muxer's constant offset).
    fail_unless_equals_int(int(output.video.size()), frames);
    const GstClockTimeDiff offset = diff(output.video[0], input.video[0]);
    GstClockTimeDiff worst_video = 0, worst_klv = 0;
    for (int k = 0; k < frames; ++k) {
        const GstClockTimeDiff error = diff(output.video[k], input.video[k]) - offset;
        worst_video = std::max(worst_video, std::abs(error));
        fail_unless(std::abs(error) <= kTick, "output frame %d at %" GST_TIME_FORMAT ", input at %" GST_TIME_FORMAT, k,
                    GST_TIME_ARGS(output.video[k]), GST_TIME_ARGS(input.video[k]));
    }
    // Every KLV packet exactly once, byte for byte as made, at its frame's output PTS.
    fail_unless_equals_int(int(output.klv.size()), int(packets));
    std::map<int, int> count;
    for (const KlvSeen &seen : output.klv) {
        const int k = klvFrameNumber(seen.bytes);
        fail_unless(k >= 0 && k < frames, "an invalid KLV packet (%d bytes) in the output", int(seen.bytes.size()));
        fail_unless(made.klv.count(k) == 1, "a KLV packet for frame %d, which had none", k);
        fail_unless(seen.bytes == made.klv.at(k), "the KLV packet of frame %d changed", k);
        fail_unless_equals_int(++count[k], 1);
        const GstClockTimeDiff error = diff(seen.pts, output.video[k]);
        worst_klv = std::max(worst_klv, std::abs(error));
        fail_unless(std::abs(error) <= kTick, "KLV of frame %d at %" GST_TIME_FORMAT ", frame %d at %" GST_TIME_FORMAT,
                    k, GST_TIME_ARGS(seen.pts), k, GST_TIME_ARGS(output.video[k]));
    }
    fail_unless_equals_int(int(count.size()), int(packets));
    std::printf("%dx%d, %d frames, %d KLV packets (every %d): output frame k at input PTS %+.3f ms (worst %.1f us off), "
                "KLV k at output frame k's PTS (worst %.1f us off); making the TS %.1f s, the sample %.1f s, "
                "all %.1f s\n",
                size.width, size.height, frames, int(packets), klv_every, double(offset) / 1e6, double(worst_video) / 1e3,
                double(worst_klv) / 1e3, double(made_at - start) / 1e6, double(sample_end - sample_start) / 1e6,
                double(g_get_monotonic_time() - start) / 1e6);
    removeDir(dir, {"in.ts", "out.ts"});
}

} // namespace

GST_START_TEST(klv_packets_keep_their_frames)
{
    checkKlvInSync(75, 1);
}
GST_END_TEST;

// One packet every 5 s: while the muxer waits for the next one, encoded video piles up in
// front of it; without the sample's unbounded video queue there the whole video chain backs
// up to the demuxer, which then never reaches that packet (a gap of 4 s already hangs).
GST_START_TEST(sparse_klv_does_not_stall_the_muxer)
{
    checkKlvInSync(160, 150, {160, 120});
}
GST_END_TEST;

// Not H.264 and no KLV: the sample decodes any video (decodebin) and, with no KLV stream to
// wait for, stabilizes the video alone (and says so).
GST_START_TEST(an_mpeg2_ts_without_klv_is_stabilized_alone)
{
    const std::string dir = tempDir(), in = dir + "/in.ts", out = dir + "/out.ts";
    const int frames = 30;
    const gint64 start = g_get_monotonic_time();
    makeInputTs(in, frames, 0, Codec::Mpeg2);
    const gint64 made_at = g_get_monotonic_time();
    const ScriptRun run = runSample({in, out});
    const gint64 sample_end = g_get_monotonic_time();
    fail_unless(run.status == 0, "the sample failed (wait status %d):\n%s", run.status, run.output.c_str());
    fail_unless(run.output.find("no KLV stream") != std::string::npos, "the sample did not say there is no KLV: %s",
                run.output.c_str());
    const ReadTs input = readTs(in, false, "video/mpeg"), output = readTs(out, false);
    fail_unless_equals_int(int(input.video.size()), frames);
    fail_unless_equals_int(int(output.video.size()), frames);
    const GstClockTimeDiff offset = diff(output.video[0], input.video[0]);
    for (int k = 0; k < frames; ++k)
        fail_unless(std::abs(diff(output.video[k], input.video[k]) - offset) <= kTick, "output frame %d moved", k);
    std::printf("MPEG-2 without KLV: %d frames in, %d H.264 frames out, frame k at input PTS %+.3f ms; making the TS "
                "%.1f s, the sample %.1f s, all %.1f s\n",
                int(input.video.size()), int(output.video.size()), double(offset) / 1e6, double(made_at - start) / 1e6,
                double(sample_end - made_at) / 1e6, double(g_get_monotonic_time() - start) / 1e6);
    removeDir(dir, {"in.ts", "out.ts"});
}
GST_END_TEST;

GST_START_TEST(wrong_arguments_print_the_usage)
{
    const gint64 start = g_get_monotonic_time();
    const ScriptRun none = runSample({});
    fail_unless(none.status != 0 && none.output.find("usage:") != std::string::npos, "%s", none.output.c_str());
    const ScriptRun bad = runSample({"/nonexistent.ts", "/tmp/x.ts"});
    fail_unless(bad.status != 0 && bad.output.find("cannot read") != std::string::npos, "%s", bad.output.c_str());
    const ScriptRun not_a_property = runSample({"/dev/null", "/tmp/x.ts", "delay"});
    fail_unless(not_a_property.status != 0 && not_a_property.output.find("usage:") != std::string::npos, "%s",
                not_a_property.output.c_str());
    std::printf("wrong arguments: refused with a message, %.1f s\n", double(g_get_monotonic_time() - start) / 1e6);
}
GST_END_TEST;

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    // Skip (meson's 77) when something the sample or the test needs is not installed.
    std::string missing;
    for (const char *element : {"uavstabilize", "x264enc", "h264parse", "avdec_h264", "mpeg2enc", "avdec_mpeg2video",
                                "mpegvideoparse", "tsdemux", "mpegtsmux", "decodebin", "appsrc"}) {
        GstElementFactory *factory = gst_element_factory_find(element);
        if (!factory)
            missing += std::string(" ") + element;
        else
            gst_object_unref(factory);
    }
    for (const char *program : {"bash", "timeout", "gst-launch-1.0", "gst-discoverer-1.0"}) {
        gchar *found = g_find_program_in_path(program);
        if (!found)
            missing += std::string(" ") + program;
        g_free(found);
    }
    if (!missing.empty()) {
        std::printf("element_klv skipped: missing%s (gstreamer1.0-plugins-bad/-ugly, gstreamer1.0-libav, "
                    "gstreamer1.0-plugins-base-apps)\n", missing.c_str());
        return 77;
    }
    Suite *s = suite_create("uavstabilize-klv");
    TCase *tc = tcase_create("klv");
    tcase_set_timeout(tc, 150);
    suite_add_tcase(s, tc);
    tcase_add_test(tc, klv_packets_keep_their_frames);
    tcase_add_test(tc, sparse_klv_does_not_stall_the_muxer);
    tcase_add_test(tc, an_mpeg2_ts_without_klv_is_stabilized_alone);
    tcase_add_test(tc, wrong_arguments_print_the_usage);
    SRunner *runner = srunner_create(s);
    srunner_run_all(runner, CK_ENV);
    const int failed = srunner_ntests_failed(runner);
    srunner_free(runner);
    return failed == 0 ? 0 : 1;
}
