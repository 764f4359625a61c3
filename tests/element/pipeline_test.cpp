// The element in real pipelines: state changes while streaming (no deadlock, no leak),
// pausing keeps every frame, and a live pipeline's latency includes the delay.
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "test_support.hpp"

using namespace element_test;

namespace {

int stateCycles()
{
    const char *value = g_getenv("UAVSTABILIZE_STATE_CYCLES");
    return value ? std::atoi(value) : 50;
}

struct HandoffLog {
    std::mutex mutex;
    std::vector<GstClockTime> timestamps;
};

void onHandoff(GstElement *, GstBuffer *buffer, GstPad *, gpointer user_data)
{
    auto *log = static_cast<HandoffLog *>(user_data);
    std::lock_guard<std::mutex> lock(log->mutex);
    log->timestamps.push_back(GST_BUFFER_PTS(buffer));
}

const char *const kBallPipeline = "videotestsrc pattern=ball is-live=false num-buffers=40 ! "
                                  "video/x-raw,format=I420,width=160,height=120,framerate=30/1 ! "
                                  "uavstabilize threads=2 delay=5 ! fakesink sync=false";

} // namespace

GST_START_TEST(warm_up)
{
    GstElement *pipeline = launchPipeline(kBallPipeline);
    fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
    gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_EOS));
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(pipeline);
}
GST_END_TEST;

ELEMENT_TEST(playing_to_null_cycles_neither_deadlock_nor_leak)
{
    GstElement *pipeline = launchPipeline(kBallPipeline);
    const int cycles = stateCycles();
    for (int c = 0; c < cycles; ++c) {
        fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
        switch (c % 4) {
        case 0:  // straight back down, frames in flight
            break;
        case 1:  // once prerolled
            gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_ASYNC_DONE));
            break;
        case 2:  // after the whole stream
            gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_EOS));
            break;
        default:  // somewhere in the middle
            std::this_thread::sleep_for(std::chrono::milliseconds(3 * c % 17));
            break;
        }
        // (In NULL the pipeline flushes its bus: no message of this cycle is left.)
        fail_unless_equals_int(gst_element_set_state(pipeline, GST_STATE_NULL), GST_STATE_CHANGE_SUCCESS);
    }
    gst_object_unref(pipeline);
}

ELEMENT_TEST(pausing_keeps_every_frame)
{
    constexpr int kFrames = 60;
    GstElement *pipeline = launchPipeline("videotestsrc pattern=ball is-live=false num-buffers=60 ! "
                                  "video/x-raw,format=NV12,width=160,height=120,framerate=100/1 ! "
                                  "uavstabilize threads=2 delay=10 ! fakesink name=sink sync=true signal-handoffs=true");
    HandoffLog log;
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), "sink");
    g_signal_connect(sink, "handoff", G_CALLBACK(onHandoff), &log);
    gst_object_unref(sink);

    fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
    for (int i = 0; i < 3; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(120));
        fail_unless(gst_element_set_state(pipeline, GST_STATE_PAUSED) != GST_STATE_CHANGE_FAILURE);
        fail_unless(gst_element_get_state(pipeline, nullptr, nullptr, 10 * GST_SECOND) != GST_STATE_CHANGE_FAILURE);
        std::this_thread::sleep_for(std::chrono::milliseconds(80));
        fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
    }
    gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_EOS));
    {
        std::lock_guard<std::mutex> lock(log.mutex);
        fail_unless_equals_int(int(log.timestamps.size()), kFrames);
        for (int i = 0; i < kFrames; ++i)
            fail_unless_equals_uint64(log.timestamps[i], i * 10 * GST_MSECOND);
    }
    fail_unless_equals_int(gst_element_set_state(pipeline, GST_STATE_NULL), GST_STATE_CHANGE_SUCCESS);
    gst_object_unref(pipeline);
}

ELEMENT_TEST(live_pipeline_latency_includes_the_delay)
{
    GstElement *pipeline = launchPipeline("videotestsrc is-live=true ! "
                                  "video/x-raw,format=I420,width=160,height=120,framerate=30/1 ! "
                                  "uavstabilize threads=2 delay=20 ! fakesink sync=true processing-deadline=0");
    fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
    fail_unless(gst_element_get_state(pipeline, nullptr, nullptr, 10 * GST_SECOND) == GST_STATE_CHANGE_SUCCESS);
    GstQuery *query = gst_query_new_latency();
    fail_unless(gst_element_query(pipeline, query));
    gboolean live = FALSE;
    GstClockTime min = 0, max = 0;
    gst_query_parse_latency(query, &live, &min, &max);
    gst_query_unref(query);
    fail_unless(live);
    // videotestsrc adds one frame; the element adds 20.
    fail_unless_equals_uint64(min, 21 * gst_util_uint64_scale_int(GST_SECOND, 1, 30));
    fail_unless_equals_int(gst_element_set_state(pipeline, GST_STATE_NULL), GST_STATE_CHANGE_SUCCESS);
    gst_object_unref(pipeline);
}

int teardownRuns()
{
    const char *value = g_getenv("UAVSTABILIZE_TEARDOWN_RUNS");
    return value ? std::atoi(value) : 100;
}

// The harness: appsrc pushes 10 good 320x240 I420 frames, then one buffer half the
// size its caps say (an error with max-errors=0, else dropped with a warning), and the
// pipeline is torn down at once, with warps still queued on the workers (a single worker
// and delay 0, so they queue up). Before the fix this crashed in Stabilizer::startWarp
// through a nulled pool about one run in six.
ELEMENT_TEST(teardown_with_warps_in_flight_after_a_bad_buffer)
{
    GstCaps *caps = videoCaps("I420", 320, 240);
    const GstVideoInfo info = videoInfo(caps);
    const int runs = teardownRuns();
    for (int run = 0; run < runs; ++run) {
        // Odd runs: the bad buffer is an error (max-errors=0, the old behaviour); even runs:
        // it is dropped with a warning and the stream goes on.
        GstElement *pipeline = launchPipeline(std::string("appsrc name=src format=time ! uavstabilize threads=1 "
                                                          "delay=0 max-errors=") +
                                              (run % 2 ? "0" : "10") +
                                              " ! appsink name=sink sync=false drop=true max-buffers=1");
        GstElement *src = gst_bin_get_by_name(GST_BIN(pipeline), "src");
        g_object_set(src, "caps", caps, nullptr);
        fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
        for (int i = 0; i < 11; ++i) {
            GstBuffer *buffer;
            if (i < 10) {
                buffer = makeFrame(info, i);
            } else {
                buffer = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&info) / 2, nullptr);
                stampFrame(buffer, i);
            }
            GstFlowReturn ret = GST_FLOW_OK;
            g_signal_emit_by_name(src, "push-buffer", buffer, &ret);
            gst_buffer_unref(buffer);
        }
        gst_object_unref(src);
        // Whatever the element said about the bad buffer, tear down now: a different
        // moment each run, from "frames still queued in appsrc" to "error posted".
        if (run % 3 != 0)
            std::this_thread::sleep_for(std::chrono::milliseconds(run % 7));
        fail_unless_equals_int(gst_element_set_state(pipeline, GST_STATE_NULL), GST_STATE_CHANGE_SUCCESS);
        gst_object_unref(pipeline);
    }
    gst_caps_unref(caps);
}

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *s = suite_create("uavstabilize-pipeline");
    TCase *tc = makeTestCase("pipeline", 240);
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, playing_to_null_cycles_neither_deadlock_nor_leak);
    tcase_add_test(tc, pausing_keeps_every_frame);
    tcase_add_test(tc, live_pipeline_latency_includes_the_delay);
    tcase_add_test(tc, teardown_with_warps_in_flight_after_a_bad_buffer);
    return runSuite(s) == 0 ? 0 : 1;
}
