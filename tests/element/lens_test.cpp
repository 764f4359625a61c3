// A lens profile (lens-profile): a fisheye flight loses its shake at the frame's corners
// with the profile, which it keeps without; a file the element cannot use stops the
// pipeline with an error that names the file and the field before any frame goes out;
// frames of another aspect ratio than the profile's are refused at negotiation.
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "jitter_metrics.hpp"
#include "lens/lens_view.hpp"
#include "lens_profile_file.hpp"
#include "shaky_flight.hpp"
#include "test_support.hpp"
#include "uavstab_meta.h"

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

// A fisheye flight through the element; the shake left at the output frame's corners in px
// of the output picture: each corner followed through the frame's meta (and the lens's
// chain when the element has the profile) back into the flight's pinhole view and the
// world, high-passed (synthetic::cornerJitter after the first second), over the corner's
// magnification (world px per output px for a still camera).
double cornerShake(bool with_profile, uavstab::LensOutput output = uavstab::LensOutput::Original)
{
    uavstab::synthetic::FlightOptions options;
    options.width = 640;
    options.height = 360;
    options.frames = 90;
    options.noise_px *= 2.0;
    options.band_px *= 2.0;
    options.lens = uavstab::synthetic::fisheyeLens(options.width, options.height);
    const uavstab::synthetic::ShakyFlight flight(options);
    const int w = options.width, h = options.height;
    const uavstab::LensModel &lens = flight.options().lens;
    const std::string profile = uavstab::synthetic::writeLensProfile(lens, "/tmp/uavstab_lens_test_fisheye.json");
    const uavstab::LensView view(lens, output, w, h);
    const std::string properties =
        output == uavstab::LensOutput::Rectified ? "lens-output=rectified" : "";

    GstHarness *harness = makeHarness(
        makeStabilizer("threads=2 delay=10 " + properties + (with_profile ? " lens-profile=" + profile : "")));
    GstCaps *caps = videoCaps("I420", w, h);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(harness, caps);
    gst_harness_set_drop_buffers(harness, TRUE);
    StreamLog log(harness->sinkpad, true);
    for (int i = 0; i < flight.frameCount(); ++i) {
        GstBuffer *buffer = makeFrame(info, flight.render(i).view());
        stampFrame(buffer, i);
        fail_unless_equals_int(gst_harness_push(harness, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(harness, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), flight.frameCount());

    const double cx = 0.5 * (w - 1), cy = 0.5 * (h - 1);
    const std::array<uavstab::Point2, 4> corners{uavstab::Point2{0.0, 0.0}, uavstab::Point2{w - 1.0, 0.0},
                                                 uavstab::Point2{0.0, h - 1.0}, uavstab::Point2{w - 1.0, h - 1.0}};
    auto toInput = [&](const std::array<double, 6> &m, double zoom, uavstab::Point2 q) {
        if (with_profile)
            return view.viewToInput(view.outputToView(q, zoom), m);
        return uavstab::Point2{m[0] * q.x + m[1] * q.y + m[2], m[3] * q.x + m[4] * q.y + m[5]};
    };
    std::array<std::vector<std::array<uavstab::Point2, 4>>, 4> world;
    double zoom = 1.0;
    for (std::size_t i = 0; i < buffers.size(); ++i) {
        fail_unless_equals_uint64(GST_BUFFER_PTS(buffers[i].buffer), GstClockTime(i) * frameDuration());
        const GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(buffers[i].buffer);
        fail_unless(meta != nullptr);
        const double *t = meta->output_to_input;
        const std::array<double, 6> m{t[0], t[1], t[2], t[3], t[4], t[5]};
        zoom = meta->zoom;
        for (std::size_t c = 0; c < 4; ++c) {
            const uavstab::Point2 u = lens.undistort(toInput(m, meta->zoom, corners[c]));
            const uavstab::Point2 p = flight.truePose(int(i)).apply({u.x - cx, u.y - cy});
            world[c].push_back({p, p, p, p});
        }
    }
    const std::array<double, 6> still =
        uavstab::Similarity{0.0, 0.0, 0.0, 1.0 / zoom}.pixelMatrix(w, h);
    double sum = 0.0;
    for (std::size_t c = 0; c < 4; ++c) {
        const uavstab::Point2 q = corners[c];
        const double sx = c % 2 ? -0.5 : 0.5, sy = c / 2 ? -0.5 : 0.5;
        const uavstab::Point2 a = lens.undistort(toInput(still, zoom, q));
        const uavstab::Point2 bx = lens.undistort(toInput(still, zoom, {q.x + sx, q.y}));
        const uavstab::Point2 by = lens.undistort(toInput(still, zoom, {q.x, q.y + sy}));
        const double g = std::sqrt(std::abs((bx.x - a.x) / sx * (by.y - a.y) / sy - (by.x - a.x) / sy * (bx.y - a.y) / sx));
        const double j = uavstab::synthetic::cornerJitter(world[c], 8.0, 30) / g;
        sum += j * j;
    }
    gst_harness_teardown(harness);
    const double shake = std::sqrt(sum / 4.0);
    g_print("fisheye flight, %s%s: %.3f px of shake left at the corners\n", properties.c_str(),
            with_profile ? " with the lens profile" : " without a lens profile", shake);
    return shake;
}

GST_START_TEST(warm_up)
{
    int frames = 0;
    (void)firstError("videotestsrc num-buffers=2 ! video/x-raw,format=I420,width=64,height=48",
                     "lens-profile=/nonexistent/warm_up.json", &frames);
}
GST_END_TEST;

ELEMENT_TEST(a_fisheye_flight_loses_its_shake_at_the_corners_with_its_profile)
{
    const double without = cornerShake(false);
    const double with = cornerShake(true);
    fail_unless(with <= 0.5, "%.3f px of shake left at the corners with the profile", with);
    fail_unless(with <= 0.25 * without, "%.3f px with the profile against %.3f px without", with, without);
    const double rectified = cornerShake(true, uavstab::LensOutput::Rectified);
    // In the pinhole view's px: its corners are not squeezed as the lens squeezes them.
    fail_unless(rectified <= 1.0 && rectified <= 0.25 * without, "lens-output=rectified: %.3f px of shake left at the corners", rectified);
}

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
    tcase_add_test(tc, a_fisheye_flight_loses_its_shake_at_the_corners_with_its_profile);
    tcase_add_test(tc, a_missing_profile_stops_the_pipeline_naming_the_file);
    tcase_add_test(tc, frames_of_another_aspect_ratio_are_refused_at_negotiation);
    suite_add_tcase(suite, tc);
    return runSuite(suite) == 0 ? 0 : 1;
}
