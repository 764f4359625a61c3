// A lens profile (lens-profile): a file the element cannot use stops the pipeline with an
// error that names the file and the field before any frame goes out; frames of another
// aspect ratio than the profile's are refused at negotiation.
#include <string>

#include "test_support.hpp"

using namespace element_test;

namespace {

const std::string kFisheye720 = std::string(UAVSTAB_TEST_DATA_DIR) + "/lens/gyroflow_old_layout_fisheye_1280x720.json";

// Runs `source ! uavstabilize <properties> ! fakesink` and returns the first error's text
// (message and debug string), failing when the pipeline ends without one.
std::string firstError(const std::string &source, const std::string &properties, int *frames_out)
{
    GstElement *pipeline =
        launchPipeline(source + " ! uavstabilize name=s threads=1 delay=2 " + properties +
                       " ! fakesink name=out signal-handoffs=true");
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), "out");
    *frames_out = 0;
    g_signal_connect(sink, "handoff", G_CALLBACK(+[](GstElement *, GstBuffer *, GstPad *, gpointer count) {
                         ++*static_cast<int *>(count);
                     }),
                     frames_out);
    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    GstBus *bus = gst_element_get_bus(pipeline);
    GstMessage *message = popMessage(bus, GstMessageType(GST_MESSAGE_ERROR | GST_MESSAGE_EOS), 30 * GST_SECOND);
    fail_unless(message != nullptr, "neither an error nor EOS");
    fail_unless(GST_MESSAGE_TYPE(message) == GST_MESSAGE_ERROR, "the stream ended without an error");
    GError *error = nullptr;
    gchar *debug = nullptr;
    gst_message_parse_error(message, &error, &debug);
    const std::string text = std::string(error->message) + " | " + (debug ? debug : "");
    g_clear_error(&error);
    g_free(debug);
    gst_message_unref(message);
    gst_object_unref(bus);
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(sink);
    gst_object_unref(pipeline);
    return text;
}

} // namespace

GST_START_TEST(warm_up)
{
    int frames = 0;
    (void)firstError("videotestsrc num-buffers=2 ! video/x-raw,format=I420,width=64,height=48",
                     "lens-profile=/nonexistent/warm_up.json", &frames);
}
GST_END_TEST;

ELEMENT_TEST(a_missing_profile_stops_the_pipeline_naming_the_file)
{
    int frames = 0;
    const std::string text = firstError("videotestsrc num-buffers=5 ! video/x-raw,format=I420,width=320,height=180",
                                        "lens-profile=/nonexistent/drone_fisheye.json", &frames);
    fail_unless(text.find("/nonexistent/drone_fisheye.json") != std::string::npos, "error: %s", text.c_str());
    fail_unless_equals_int(frames, 0);
}

ELEMENT_TEST(frames_of_another_aspect_ratio_are_refused_at_negotiation)
{
    int frames = 0;
    const std::string text = firstError("videotestsrc num-buffers=5 ! video/x-raw,format=I420,width=320,height=240",
                                        "lens-profile=" + kFisheye720, &frames);
    fail_unless(text.find("calib_dimension") != std::string::npos, "error: %s", text.c_str());
    fail_unless(text.find(kFisheye720) != std::string::npos, "error: %s", text.c_str());
    fail_unless_equals_int(frames, 0);
}

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *suite = suite_create("lens");
    TCase *tc = makeTestCase("lens", 300);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, a_missing_profile_stops_the_pipeline_naming_the_file);
    tcase_add_test(tc, frames_of_another_aspect_ratio_are_refused_at_negotiation);
    suite_add_tcase(suite, tc);
    return runSuite(suite) == 0 ? 0 : 1;
}
