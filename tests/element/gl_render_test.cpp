// render=affine-meta and render=auto in front of GStreamer's GL elements, under whatever
// OpenGL the machine has (Mesa's software renderer on CI, in an Xvfb started here when
// there is no display): the input buffer goes out untouched with a
// GstVideoAffineTransformationMeta, and a GL element that applies the meta (glvideomixer)
// draws the same picture the CPU warp does. Skipped (exit 77) where no GL context can be
// made. Not under the leaks tracer: the GL library keeps its display and contexts alive.
//
// The pipelines are `appsrc (I420) ! videoconvert ! RGBA ! uavstabilize ! glupload ! ...`:
// videoconvert writes into the buffers uavstabilize proposes, which in affine-meta mode are
// glupload's GL buffers; glupload passes those through with their metas (GStreamer 1.22
// copies system memory into new buffers and drops the affine meta on the way).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <vector>

#include <gst/app/app.h>

#include "shaky_flight.hpp"
#include "test_support.hpp"
#include "uavstab_meta.h"

using namespace element_test;

namespace {

constexpr int kWidth = 640, kHeight = 360, kFrames = 40;
constexpr double kMinPsnr = 35.0;
// Uncovered borders may differ by interpolation at the very edge (GL clamps, the warp
// paints black); the comparison leaves this many pixels out on each side.
constexpr int kMargin = 8;

GPid xvfb_pid = 0;

// A display for the GL library: the one we have, or an Xvfb of our own.
bool ensureDisplay(std::string &why)
{
    if (g_getenv("DISPLAY") && *g_getenv("DISPLAY"))
        return true;
    gchar *argv[] = {g_strdup("Xvfb"), g_strdup("-displayfd"), g_strdup("1"), g_strdup("-screen"), g_strdup("0"),
                     g_strdup("1280x720x24"), g_strdup("-nolisten"), g_strdup("tcp"), nullptr};
    gint out = -1;
    GError *error = nullptr;
    const bool spawned = g_spawn_async_with_pipes(nullptr, argv, nullptr, GSpawnFlags(G_SPAWN_SEARCH_PATH),
                                                  nullptr, nullptr, &xvfb_pid, nullptr, &out, nullptr, &error);
    for (gchar *arg : argv)
        g_free(arg);
    if (!spawned) {
        why = std::string("no DISPLAY and Xvfb cannot be started: ") + error->message;
        g_error_free(error);
        return false;
    }
    // Xvfb writes the display number once it accepts connections.
    std::string number;
    char c;
    while (read(out, &c, 1) == 1 && c != '\n')
        number += c;
    close(out);
    if (number.empty()) {
        why = "Xvfb started but reported no display";
        return false;
    }
    g_setenv("DISPLAY", (":" + number).c_str(), TRUE);
    g_print("gl_render: started Xvfb on :%s\n", number.c_str());
    return true;
}

void stopXvfb()
{
    if (xvfb_pid) {
        kill(xvfb_pid, SIGTERM);
        g_spawn_close_pid(xvfb_pid);
        xvfb_pid = 0;
    }
}

// Runs a one-frame GL pipeline: false (and why) when no GL context can be made.
bool glWorks(std::string &why)
{
    GError *error = nullptr;
    GstElement *pipeline =
        gst_parse_launch("videotestsrc num-buffers=1 ! glupload ! glcolorconvert ! gldownload ! fakesink", &error);
    if (!pipeline) {
        why = std::string("the GL elements are missing (gstreamer1.0-gl): ") + (error ? error->message : "?");
        if (error)
            g_error_free(error);
        return false;
    }
    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    GstBus *bus = gst_element_get_bus(pipeline);
    GstMessage *message =
        gst_bus_timed_pop_filtered(bus, 30 * GST_SECOND, GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    bool ok = message && GST_MESSAGE_TYPE(message) == GST_MESSAGE_EOS;
    if (!ok) {
        why = "no GL context";
        if (message) {
            GError *gl_error = nullptr;
            gchar *debug = nullptr;
            gst_message_parse_error(message, &gl_error, &debug);
            why += std::string(": ") + gl_error->message + (debug ? std::string(" (") + debug + ")" : "");
            g_error_free(gl_error);
            g_free(debug);
        }
    }
    if (message)
        gst_message_unref(message);
    gst_object_unref(bus);
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(pipeline);
    return ok;
}

std::vector<GstBuffer *> renderFlight(double readout)
{
    uavstab::synthetic::FlightOptions options;
    options.width = kWidth;
    options.height = kHeight;
    options.frames = kFrames;
    if (readout > 0) {
        // A rolling shutter on a vibrating camera, as rolling_shutter_test.cpp's.
        options.readout = readout;
        options.vibration_hz = 47.0;
        options.vibration_px = 2.0;
        options.vibration_deg = 0.1;
    }
    uavstab::synthetic::ShakyFlight flight(options);
    {
        GstCaps *caps = videoCaps("I420", kWidth, kHeight);
        const GstVideoInfo info = videoInfo(caps);
        gst_caps_unref(caps);
        std::vector<GstBuffer *> result;
        for (int i = 0; i < kFrames; ++i) {
            GstBuffer *buffer = makeFrame(info, flight.render(i).view());
            stampFrame(buffer, i);
            result.push_back(buffer);
        }
        return result;
    }
}

std::vector<GstBuffer *> *flight_frames = nullptr;  // what runFlight() pushes

const std::vector<GstBuffer *> &flightFrames()
{
    static std::vector<GstBuffer *> frames = renderFlight(0.0);
    return flight_frames ? *flight_frames : frames;
}

struct Outcome {
    GstClockTime pts;
    int outcome;
    bool affine_meta;
    bool input_memory;  // the buffer's memory is the memory uavstabilize was given
    double wobble;
};

struct Run {
    std::vector<GstBuffer *> out;  // what the appsink got
    std::vector<Outcome> outcomes; // what left uavstabilize
    ~Run()
    {
        for (GstBuffer *b : out)
            gst_buffer_unref(b);
    }
};

struct Probes {
    std::mutex mutex;
    std::vector<GstMemory *> inputs;
    std::vector<Outcome> *outcomes;
};

GstPadProbeReturn recordInput(GstPad *, GstPadProbeInfo *info, gpointer data)
{
    auto *probes = static_cast<Probes *>(data);
    std::lock_guard<std::mutex> lock(probes->mutex);
    probes->inputs.push_back(gst_buffer_peek_memory(GST_PAD_PROBE_INFO_BUFFER(info), 0));
    return GST_PAD_PROBE_OK;
}

GstPadProbeReturn recordOutput(GstPad *, GstPadProbeInfo *info, gpointer data)
{
    auto *probes = static_cast<Probes *>(data);
    GstBuffer *buffer = GST_PAD_PROBE_INFO_BUFFER(info);
    const GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(buffer);
    std::lock_guard<std::mutex> lock(probes->mutex);
    const std::size_t index = probes->outcomes->size();
    probes->outcomes->push_back({GST_BUFFER_PTS(buffer), meta ? int(meta->outcome) : -1,
                                 gst_buffer_get_video_affine_transformation_meta(buffer) != nullptr,
                                 index < probes->inputs.size() &&
                                     gst_buffer_peek_memory(buffer, 0) == probes->inputs[index],
                                 meta ? meta->wobble : 0.0});
    return GST_PAD_PROBE_OK;
}

// appsrc (the flight, I420) ! videoconvert ! RGBA ! uavstabilize PROPS ! TAIL ! appsink
void runFlight(const std::string &props, const std::string &tail, Run &run)
{
    const std::string description =
        "appsrc name=src format=time ! videoconvert ! video/x-raw,format=RGBA ! uavstabilize name=stab delay=5 " +
        props + " ! " + tail + " ! appsink name=sink sync=false";
    GstElement *pipeline = launchPipeline(description);
    GstElement *src = gst_bin_get_by_name(GST_BIN(pipeline), "src");
    GstElement *stab = gst_bin_get_by_name(GST_BIN(pipeline), "stab");
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), "sink");
    GstCaps *caps = videoCaps("I420", kWidth, kHeight);
    g_object_set(src, "caps", caps, nullptr);
    gst_caps_unref(caps);

    Probes probes;
    probes.outcomes = &run.outcomes;
    GstPad *stab_sink = gst_element_get_static_pad(stab, "sink");
    GstPad *stab_src = gst_element_get_static_pad(stab, "src");
    gst_pad_add_probe(stab_sink, GST_PAD_PROBE_TYPE_BUFFER, recordInput, &probes, nullptr);
    gst_pad_add_probe(stab_src, GST_PAD_PROBE_TYPE_BUFFER, recordOutput, &probes, nullptr);

    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    for (GstBuffer *frame : flightFrames())
        fail_unless_equals_int(gst_app_src_push_buffer(GST_APP_SRC(src), gst_buffer_ref(frame)), GST_FLOW_OK);
    gst_app_src_end_of_stream(GST_APP_SRC(src));
    while (GstSample *sample = gst_app_sink_try_pull_sample(GST_APP_SINK(sink), 60 * GST_SECOND)) {
        run.out.push_back(gst_buffer_ref(gst_sample_get_buffer(sample)));
        gst_sample_unref(sample);
    }
    gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_EOS));
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(stab_sink);
    gst_object_unref(stab_src);
    gst_object_unref(src);
    gst_object_unref(stab);
    gst_object_unref(sink);
    gst_object_unref(pipeline);
}

double psnr(GstBuffer *a, GstBuffer *b)
{
    GstMapInfo ma, mb;
    fail_unless(gst_buffer_map(a, &ma, GST_MAP_READ) && gst_buffer_map(b, &mb, GST_MAP_READ));
    double sum = 0;
    long count = 0;
    for (int y = kMargin; y < kHeight - kMargin; ++y)
        for (int x = kMargin; x < kWidth - kMargin; ++x)
            for (int c = 0; c < 3; ++c) {
                const std::size_t i = (std::size_t(y) * kWidth + x) * 4 + c;
                const double d = double(ma.data[i]) - double(mb.data[i]);
                sum += d * d;
                ++count;
            }
    gst_buffer_unmap(a, &ma);
    gst_buffer_unmap(b, &mb);
    const double mse = sum / double(count);
    return mse == 0 ? 99.0 : 10 * std::log10(255.0 * 255.0 / mse);
}

// glvideomixer applies the meta when it draws (glcolorscale in GStreamer 1.22 does not: it
// is a passthrough at the same size and drops the meta when it scales).
const std::string kGlTail = "glupload ! glvideomixer ! video/x-raw(memory:GLMemory),width=640,height=360 ! "
                            "gldownload ! video/x-raw,format=RGBA";

void checkEveryFrameInOrder(const Run &run, const char *what)
{
    fail_unless_equals_int(int(run.outcomes.size()), kFrames);
    fail_unless_equals_int(int(run.out.size()), kFrames);
    for (int i = 0; i < kFrames; ++i) {
        // Exactly the input's out of uavstabilize; glvideomixer stamps its own output from
        // its frame rate (100000000 ns where the input said 99999999).
        fail_unless_equals_uint64(run.outcomes[i].pts, GST_BUFFER_PTS(flightFrames()[i]));
        const GstClockTimeDiff off = GST_CLOCK_DIFF(GST_BUFFER_PTS(flightFrames()[i]), GST_BUFFER_PTS(run.out[i]));
        fail_unless(std::llabs(off) <= 1000, "%s: frame %d has PTS %" GST_TIME_FORMAT, what, i,
                    GST_TIME_ARGS(GST_BUFFER_PTS(run.out[i])));
    }
}

GST_START_TEST(affine_meta_draws_what_the_warp_draws)
{
    Run warp, affine, unapplied;
    runFlight("render=warp", kGlTail, warp);
    runFlight("render=affine-meta", kGlTail, affine);
    // glcolorscale at the same size passes buffers through: the meta is not applied, so
    // this is the input as it came, to show that the comparison above can fail.
    runFlight("render=affine-meta", "glupload ! glcolorscale ! gldownload ! video/x-raw,format=RGBA", unapplied);
    fail_unless_equals_int(int(unapplied.out.size()), kFrames);
    checkEveryFrameInOrder(warp, "warp");
    checkEveryFrameInOrder(affine, "affine-meta");
    double worst = 1e9, sum = 0, unapplied_sum = 0;
    for (int i = 0; i < kFrames; ++i) {
        fail_unless_equals_int(warp.outcomes[i].outcome, GST_UAV_STAB_OUTCOME_WARPED);
        fail_unless_equals_int(affine.outcomes[i].outcome, GST_UAV_STAB_OUTCOME_AFFINE_META);
        fail_unless(affine.outcomes[i].affine_meta, "frame %d has no affine meta", i);
        fail_unless(affine.outcomes[i].input_memory, "frame %d: not the input's memory", i);
        const double p = psnr(warp.out[i], affine.out[i]);
        worst = std::min(worst, p);
        sum += p;
        fail_unless(p >= kMinPsnr, "frame %d: PSNR %.2f dB between the warp and the affine meta", i, p);
        unapplied_sum += psnr(warp.out[i], unapplied.out[i]);
    }
    g_print("gl_render: affine-meta vs warp over %d frames (%dx%d, %d px margin): PSNR min %.2f dB, mean %.2f dB; "
            "the unwarped input vs warp: mean %.2f dB\n",
            kFrames, kWidth, kHeight, kMargin, worst, sum / kFrames, unapplied_sum / kFrames);
    fail_unless(unapplied_sum / kFrames < kMinPsnr - 10, "the warp hardly changes the picture: no test");
}
GST_END_TEST;

GST_START_TEST(auto_uses_the_meta_only_where_downstream_applies_it)
{
    Run gl;
    runFlight("render=auto", kGlTail, gl);
    checkEveryFrameInOrder(gl, "auto in front of glvideomixer");
    for (int i = 0; i < kFrames; ++i) {
        fail_unless_equals_int(gl.outcomes[i].outcome, GST_UAV_STAB_OUTCOME_AFFINE_META);
        fail_unless(gl.outcomes[i].input_memory, "frame %d was warped into another buffer", i);
    }
    Run plain;
    runFlight("render=auto", "identity", plain);
    checkEveryFrameInOrder(plain, "auto in front of appsink");
    for (int i = 0; i < kFrames; ++i) {
        fail_unless_equals_int(plain.outcomes[i].outcome, GST_UAV_STAB_OUTCOME_WARPED);
        fail_unless(!plain.outcomes[i].affine_meta && !plain.outcomes[i].input_memory);
    }
}
GST_END_TEST;

// One affine meta cannot bend rows: auto warps the frames with a wobble to correct (on the
// src task) and sends the others with the meta.
GST_START_TEST(auto_warps_frames_with_a_wobble)
{
    std::vector<GstBuffer *> frames = renderFlight(0.8);
    flight_frames = &frames;
    Run run;
    runFlight("render=auto", kGlTail, run);
    flight_frames = nullptr;
    checkEveryFrameInOrder(run, "auto, rolling shutter");
    int warped = 0, affine = 0;
    for (const Outcome &o : run.outcomes) {
        fail_unless(o.outcome == GST_UAV_STAB_OUTCOME_WARPED || o.outcome == GST_UAV_STAB_OUTCOME_AFFINE_META);
        fail_unless(o.outcome == GST_UAV_STAB_OUTCOME_WARPED ? (o.wobble > 0 && !o.affine_meta && !o.input_memory)
                                                             : (o.affine_meta && o.input_memory));
        (o.outcome == GST_UAV_STAB_OUTCOME_WARPED ? warped : affine)++;
    }
    g_print("gl_render: rolling-shutter flight, auto: %d frames warped (wobble corrected), %d with the affine meta\n",
            warped, affine);
    fail_unless(warped > 0, "no frame had a wobble corrected");
    for (GstBuffer *frame : frames)
        gst_buffer_unref(frame);
}
GST_END_TEST;

GST_START_TEST(auto_warps_in_front_of_fakesink)
{
    GstElement *pipeline = launchPipeline("videotestsrc num-buffers=10 pattern=ball ! video/x-raw,width=160,height=120 "
                                          "! uavstabilize name=stab delay=2 ! fakesink name=sink");
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), "sink");
    GstPad *pad = gst_element_get_static_pad(sink, "sink");
    std::vector<Outcome> outcomes;
    Probes probes;
    probes.outcomes = &outcomes;
    gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, recordOutput, &probes, nullptr);
    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_EOS));
    gst_element_set_state(pipeline, GST_STATE_NULL);
    fail_unless_equals_int(int(outcomes.size()), 10);
    for (const Outcome &o : outcomes)
        fail_unless(o.outcome == GST_UAV_STAB_OUTCOME_WARPED && !o.affine_meta);
    gst_object_unref(pad);
    gst_object_unref(sink);
    gst_object_unref(pipeline);
}
GST_END_TEST;

} // namespace

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    std::string why;
    if (!ensureDisplay(why) || !glWorks(why)) {
        g_print("gl_render: SKIPPED: %s\n", why.c_str());
        stopXvfb();
        return 77;
    }
    Suite *s = suite_create("uavstabilize-gl-render");
    TCase *tc = tcase_create("gl_render");
    tcase_set_timeout(tc, 300);
    suite_add_tcase(s, tc);
    tcase_add_test(tc, affine_meta_draws_what_the_warp_draws);
    tcase_add_test(tc, auto_uses_the_meta_only_where_downstream_applies_it);
    tcase_add_test(tc, auto_warps_frames_with_a_wobble);
    tcase_add_test(tc, auto_warps_in_front_of_fakesink);
    SRunner *runner = srunner_create(s);
    srunner_set_fork_status(runner, CK_NOFORK);
    srunner_run_all(runner, CK_ENV);
    const int failed = srunner_ntests_failed(runner);
    srunner_free(runner);
    for (GstBuffer *frame : flightFrames())
        gst_buffer_unref(frame);
    stopXvfb();
    std::fflush(stdout);
    _exit(failed == 0 ? 0 : 1);  // no gst_deinit: the GL library's threads may live on
}
