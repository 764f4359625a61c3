// Bad input and hostile use: timestamps that are missing, repeated, going
// backwards or jumping; caps changing every frame; tiny and huge frames; an upstream
// pool with few buffers; properties changed from another thread while playing; storms
// of flushing seeks. Each: no crash, no hang, every frame out once, in order, no leak.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "test_support.hpp"

using namespace element_test;

namespace {

GstHarness *harnessWithCaps(const std::string &properties, GstCaps *caps)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 " + properties));
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    return h;
}

// Pushes `count` frames of `format` WxH, then EOS, and checks they all came out in order.
void roundTrip(const char *format, int width, int height, int count, const std::string &properties)
{
    GstCaps *caps = videoCaps(format, width, height);
    const GstVideoInfo info = videoInfo(caps);
    GstHarness *h = harnessWithCaps(properties, caps);
    StreamLog log(h->sinkpad);
    for (int i = 0; i < count; ++i)
        fail_unless_equals_int(gst_harness_push(h, makeFrame(info, i)), GST_FLOW_OK);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos(), "no EOS for %s %dx%d", format, width, height);
    const auto buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), count);
    for (int i = 0; i < count; ++i)
        fail_unless_equals_uint64(buffers[std::size_t(i)].offset, guint64(i));
    gst_harness_teardown(h);
}

int envOr(const char *name, int fallback)
{
    const char *value = g_getenv(name);
    return value ? std::atoi(value) : fallback;
}

} // namespace

GST_START_TEST(warm_up)
{
    roundTrip("I420", 64, 48, 3, "delay=1");
}
GST_END_TEST;

ELEMENT_TEST(odd_timestamps_pass_through_in_order)
{
    GstCaps *caps = videoCaps("I420", 96, 64);
    const GstVideoInfo info = videoInfo(caps);
    GstHarness *h = harnessWithCaps("delay=5", caps);
    StreamLog log(h->sinkpad);
    const GstClockTime d = frameDuration();
    std::vector<GstClockTime> sent;
    for (int i = 0; i < 40; ++i) {
        GstBuffer *buffer = makeFrame(info, i);
        GstClockTime pts = i * d;
        if (i % 7 == 3)
            pts = GST_CLOCK_TIME_NONE;  // missing
        else if (i == 10)
            pts = 9 * d;  // repeated
        else if (i == 15)
            pts = 5 * d;  // backwards
        else if (i >= 20)
            pts = GST_SECOND * 3600 + i * d;  // an hour-long gap
        GST_BUFFER_PTS(buffer) = pts;
        GST_BUFFER_DTS(buffer) = GST_CLOCK_TIME_NONE;
        if (i == 20 || i == 30)
            GST_BUFFER_FLAG_SET(buffer, GST_BUFFER_FLAG_DISCONT);
        sent.push_back(pts);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const auto buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 40);
    for (int i = 0; i < 40; ++i) {
        fail_unless_equals_uint64(buffers[std::size_t(i)].offset, guint64(i));
        fail_unless_equals_uint64(buffers[std::size_t(i)].pts, sent[std::size_t(i)]);
        fail_unless_equals_uint64(buffers[std::size_t(i)].dts, GST_CLOCK_TIME_NONE);
    }
    fail_unless(buffers[20].flags & GST_BUFFER_FLAG_DISCONT);
    gst_harness_teardown(h);
}

ELEMENT_TEST(caps_change_every_frame)
{
    struct Shape {
        const char *format;
        int width, height;
    };
    const Shape shapes[] = {{"I420", 64, 48}, {"NV12", 80, 60}, {"BGRx", 72, 40}, {"GRAY8", 33, 17}};
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=4"));
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad);
    const int frames = 40;
    for (int i = 0; i < frames; ++i) {
        const Shape &shape = shapes[i % 4];
        GstCaps *caps = videoCaps(shape.format, shape.width, shape.height);
        const GstVideoInfo info = videoInfo(caps);
        gst_harness_set_src_caps(h, caps);
        fail_unless_equals_int(gst_harness_push(h, makeFrame(info, i)), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const auto buffers = log.buffers();
    const auto caps = log.caps();
    fail_unless_equals_int(int(buffers.size()), frames);
    for (int i = 0; i < frames; ++i) {
        const LoggedItem &b = buffers[std::size_t(i)];
        fail_unless_equals_uint64(b.offset, guint64(i));
        // Each frame went out under the caps it came in with.
        fail_unless(b.caps_index >= 0);
        const GstVideoInfo out = videoInfo(caps[std::size_t(b.caps_index)]);
        const Shape &shape = shapes[i % 4];
        fail_unless_equals_int(GST_VIDEO_INFO_WIDTH(&out), shape.width);
        fail_unless_equals_int(GST_VIDEO_INFO_HEIGHT(&out), shape.height);
        fail_unless_equals_uint64(b.size, GST_VIDEO_INFO_SIZE(&out));
    }
    gst_harness_teardown(h);
}

ELEMENT_TEST(tiny_odd_and_huge_frames)
{
    for (const char *format : {"I420", "NV21", "RGB", "GRAY8"}) {
        roundTrip(format, 16, 16, 30, "delay=5");
        roundTrip(format, 17, 17, 30, "delay=5");
        roundTrip(format, 641, 359, 12, "delay=5");
    }
    roundTrip("I420", 7680, 4320, 5, "delay=2");
}

ELEMENT_TEST(frames_smaller_than_16_pixels_are_refused_at_negotiation)
{
    GstElement *element = makeStabilizer();
    GstPad *sink = gst_element_get_static_pad(element, "sink");
    for (auto [w, h] : {std::pair{1, 1}, {15, 64}, {64, 15}}) {
        GstCaps *caps = videoCaps("I420", w, h);
        fail_if(gst_pad_query_accept_caps(sink, caps), "%dx%d accepted", w, h);
        gst_caps_unref(caps);
    }
    GstCaps *ok = videoCaps("I420", 16, 16);
    fail_unless(gst_pad_query_accept_caps(sink, ok));
    gst_caps_unref(ok);
    gst_object_unref(sink);
    gst_object_unref(element);
}

ELEMENT_TEST(interlaced_video_is_refused_at_negotiation)
{
    // Warping a frame of two fields would mix them: interlaced caps are refused so that the
    // pipeline fails to link (or upstream picks progressive) instead of combing the output.
    GstElement *element = makeStabilizer();
    GstPad *sink = gst_element_get_static_pad(element, "sink");
    for (const char *mode : {"interleaved", "mixed", "alternate", "fields"}) {
        GstCaps *caps = videoCaps("I420", 64, 48);
        gst_caps_set_simple(caps, "interlace-mode", G_TYPE_STRING, mode, nullptr);
        fail_if(gst_pad_query_accept_caps(sink, caps), "interlace-mode %s accepted", mode);
        gst_caps_unref(caps);
    }
    GstCaps *progressive = videoCaps("I420", 64, 48);
    fail_unless(gst_pad_query_accept_caps(sink, progressive), "caps without interlace-mode refused");
    gst_caps_set_simple(progressive, "interlace-mode", G_TYPE_STRING, "progressive", nullptr);
    fail_unless(gst_pad_query_accept_caps(sink, progressive), "progressive caps refused");
    gst_caps_unref(progressive);
    // Upstream asking what we take is told: progressive only.
    GstCaps *offered = gst_pad_query_caps(sink, nullptr);
    fail_unless(gst_caps_get_size(offered) > 0);
    for (guint i = 0; i < gst_caps_get_size(offered); ++i) {
        const char *mode = gst_structure_get_string(gst_caps_get_structure(offered, i), "interlace-mode");
        fail_unless(mode && std::string(mode) == "progressive", "caps query offers %s", mode ? mode : "any");
    }
    gst_caps_unref(offered);
    gst_object_unref(sink);
    gst_object_unref(element);
}

ELEMENT_TEST(upstream_pool_with_few_buffers_never_starves)
{
    // A source with a fixed pool of 4 buffers (fewer than the 20 held): its frames are
    // copied, so its buffers come back at once instead of after 20 frames.
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    GstBufferPool *pool = gst_video_buffer_pool_new();
    GstStructure *config = gst_buffer_pool_get_config(pool);
    gst_buffer_pool_config_set_params(config, caps, guint(GST_VIDEO_INFO_SIZE(&info)), 2, 4);
    fail_unless(gst_buffer_pool_set_config(pool, config));
    fail_unless(gst_buffer_pool_set_active(pool, TRUE));

    GstHarness *h = harnessWithCaps("delay=20", caps);
    StreamLog log(h->sinkpad);
    for (int i = 0; i < 60; ++i) {
        GstBuffer *buffer = nullptr;
        GstBufferPoolAcquireParams params{};
        params.flags = GST_BUFFER_POOL_ACQUIRE_FLAG_DONTWAIT;
        fail_unless_equals_int(gst_buffer_pool_acquire_buffer(pool, &buffer, &params), GST_FLOW_OK);
        GstBuffer *content = makeFrame(info, i);
        GstMapInfo map;
        fail_unless(gst_buffer_map(buffer, &map, GST_MAP_WRITE));
        gst_buffer_extract(content, 0, map.data, map.size);
        gst_buffer_unmap(buffer, &map);
        gst_buffer_copy_into(buffer, content, GST_BUFFER_COPY_METADATA, 0, -1);
        gst_buffer_unref(content);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    fail_unless_equals_int(int(log.buffers().size()), 60);
    gst_harness_teardown(h);
    gst_buffer_pool_set_active(pool, FALSE);
    gst_object_unref(pool);
}

ELEMENT_TEST(property_changes_from_another_thread_while_playing)
{
    const int frames = 400;
    GstElement *pipeline = launchPipeline(
        "videotestsrc pattern=ball num-buffers=" + std::to_string(frames) +
        " ! video/x-raw,format=I420,width=160,height=120,framerate=30/1 ! uavstabilize name=stab threads=2 "
        "! fakesink name=sink sync=false signal-handoffs=true");
    GstElement *stab = gst_bin_get_by_name(GST_BIN(pipeline), "stab");
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), "sink");
    struct Seen {
        std::mutex mutex;
        std::vector<GstClockTime> pts;
    } seen;
    g_signal_connect(sink, "handoff", G_CALLBACK(+[](GstElement *, GstBuffer *b, GstPad *, gpointer data) {
                         auto *s = static_cast<Seen *>(data);
                         std::lock_guard<std::mutex> lock(s->mutex);
                         s->pts.push_back(GST_BUFFER_PTS(b));
                     }),
                     &seen);
    fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);

    std::atomic<bool> stop{false};
    std::thread twiddler([&] {
        std::mt19937 rng(4);
        const char *models[] = {"hybrid", "rigid", "similarity"};
        for (int k = 0; !stop; ++k) {
            switch (k % 5) {
            case 0:
                g_object_set(stab, "delay", guint(rng() % 31), nullptr);
                break;
            case 1:
                g_object_set(stab, "bypass", gboolean(rng() % 2), nullptr);
                break;
            case 2:
                gst_util_set_object_arg(G_OBJECT(stab), "model", models[rng() % 3]);
                break;
            case 3:
                g_object_set(stab, "crop", double(rng() % 20) / 100.0, nullptr);
                break;
            default:
                gst_util_set_object_arg(G_OBJECT(stab), "planner", rng() % 3 == 0 ? "gaussian" : rng() % 2 ? "box" : "optimal");
                break;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
    });
    // Every delay change posts a latency message; the pipeline must reach EOS regardless.
    GstBus *bus = gst_element_get_bus(pipeline);
    int latency_messages = 0;
    for (bool eos = false; !eos;) {
        GstMessage *m = gst_bus_timed_pop_filtered(
            bus, 60 * GST_SECOND, GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR | GST_MESSAGE_LATENCY));
        fail_unless(m != nullptr, "timed out: no EOS while properties changed");
        fail_if(GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR, "error while properties changed");
        latency_messages += GST_MESSAGE_TYPE(m) == GST_MESSAGE_LATENCY;
        eos = GST_MESSAGE_TYPE(m) == GST_MESSAGE_EOS;
        gst_message_unref(m);
    }
    stop = true;
    twiddler.join();
    gst_element_set_state(pipeline, GST_STATE_NULL);
    fail_unless(latency_messages > 0, "no latency message for the delay changes");
    fail_unless_equals_int(int(seen.pts.size()), frames);
    for (std::size_t i = 1; i < seen.pts.size(); ++i)
        fail_unless(seen.pts[i] > seen.pts[i - 1], "frame %zu out of order", i);
    gst_object_unref(bus);
    gst_object_unref(sink);
    gst_object_unref(stab);
    gst_object_unref(pipeline);
}

ELEMENT_TEST(flush_storm_of_seeks)
{
    // A seek every 10 frames; after each, no frame from before the flush comes out.
    const int seeks = envOr("UAVSTABILIZE_SEEKS", 1000);
    GstElement *pipeline = launchPipeline(
        "videotestsrc pattern=ball ! video/x-raw,format=I420,width=96,height=72,framerate=30/1 "
        "! uavstabilize threads=2 delay=5 ! fakesink name=sink sync=false signal-handoffs=true");
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), "sink");
    struct Seen {
        std::mutex mutex;
        std::condition_variable changed;
        int since_seek = 0;
        GstClockTime floor = 0;  // every frame after the latest seek starts here or later
        int stale = 0;
    } seen;
    g_signal_connect(sink, "handoff", G_CALLBACK(+[](GstElement *, GstBuffer *b, GstPad *, gpointer data) {
                         auto *s = static_cast<Seen *>(data);
                         std::lock_guard<std::mutex> lock(s->mutex);
                         if (GST_BUFFER_PTS(b) < s->floor)
                             ++s->stale;
                         ++s->since_seek;
                         s->changed.notify_all();
                     }),
                     &seen);
    fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
    gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_ASYNC_DONE));
    for (int k = 0; k < seeks; ++k) {
        {
            std::unique_lock<std::mutex> lock(seen.mutex);
            fail_unless(seen.changed.wait_for(lock, std::chrono::seconds(20), [&] { return seen.since_seek >= 10; }),
                        "no frames after seek %d: stalled", k);
        }
        // A frame boundary, computed as videotestsrc stamps its frames.
        const GstClockTime position = gst_util_uint64_scale(guint64((k * 37) % 300), GST_SECOND, 30);
        {
            // The new segment's first frames may come out before seek_simple returns: until
            // then, frames of either segment are fine.
            std::lock_guard<std::mutex> lock(seen.mutex);
            seen.floor = std::min(seen.floor, position);
        }
        fail_unless(gst_element_seek_simple(pipeline, GST_FORMAT_TIME,
                                            GstSeekFlags(GST_SEEK_FLAG_FLUSH | GST_SEEK_FLAG_ACCURATE), position),
                    "seek %d refused", k);
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.since_seek = 0;
        seen.floor = position;
    }
    gst_element_set_state(pipeline, GST_STATE_NULL);
    fail_unless_equals_int(seen.stale, 0);
    std::printf("flush storm: %d flushing seeks survived\n", seeks);
    gst_object_unref(sink);
    gst_object_unref(pipeline);
}

namespace {

Suite *robustnessSuite()
{
    Suite *s = suite_create("uavstabilize-robustness");
    TCase *tc = makeTestCase("robustness", 240);
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, odd_timestamps_pass_through_in_order);
    tcase_add_test(tc, caps_change_every_frame);
    tcase_add_test(tc, tiny_odd_and_huge_frames);
    tcase_add_test(tc, frames_smaller_than_16_pixels_are_refused_at_negotiation);
    tcase_add_test(tc, interlaced_video_is_refused_at_negotiation);
    tcase_add_test(tc, upstream_pool_with_few_buffers_never_starves);
    tcase_add_test(tc, property_changes_from_another_thread_while_playing);
    tcase_add_test(tc, flush_storm_of_seeks);
    return s;
}

} // namespace

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    return runSuite(robustnessSuite()) == 0 ? 0 : 1;
}
