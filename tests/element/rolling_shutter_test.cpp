// Rolling shutter: a synthetic flight seen by a sensor that reads its rows over 80 % of the
// frame time, on a camera with propeller vibration, goes through the element. The wobble
// (non-rigid motion between consecutive frames, tests/synthetic/wobble_metric.hpp) must
// mostly go with the default settings, stay with rolling-shutter=off, and footage from a
// global shutter must come out as it did without the correction.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "jitter_metrics.hpp"
#include "shaky_flight.hpp"
#include "test_support.hpp"
#include "uavstab_meta.h"
#include "wobble_metric.hpp"

using namespace element_test;

namespace {

uavstab::synthetic::FlightOptions vibratingFlight(double readout, double hz = 47.0, double px = 2.0,
                                                  double deg = 0.1)
{
    uavstab::synthetic::FlightOptions options;
    options.width = 640;
    options.height = 360;
    options.frames = 90;
    options.format = uavstab::PixelFormat::I420;
    options.readout = readout;
    options.vibration_hz = hz;
    options.vibration_px = px;
    options.vibration_deg = deg;
    return options;
}

struct Result {
    double wobble_in = 0.0, wobble_out = 0.0;
    double reported = 0.0;  // mean "wobble" of the bus messages
    double coverage_min = 1.0;
    // Frames the messages say were corrected ("rolling-shutter"), and the same from the
    // buffers' GstUavStabMeta; the messages' "readout" and "readout-confidence" (last frame,
    // and whether it ever changed after the first frame it was known on).
    int rows_moved = 0, rows_moved_meta = 0;
    double readout = 0.0, readout_confidence = 0.0;
    int readout_changes = 0;
    std::vector<std::vector<unsigned char>> luma;  // output frames' luma, for comparisons
};

cv::Mat lumaOf(const uavstab::FrameView &view)
{
    return cv::Mat(view.height, view.width, CV_8UC1, const_cast<std::uint8_t *>(view.planes[0].data),
                   std::size_t(view.planes[0].stride));
}

Result stabilize(const uavstab::synthetic::FlightOptions &options, const std::string &properties)
{
    const uavstab::synthetic::ShakyFlight flight(options);
    GstHarness *h = makeHarness(makeStabilizer("threads=2 post-messages=true " + properties));
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    GstCaps *caps = videoCaps("I420", options.width, options.height);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad, true);

    Result r;
    uavstab::synthetic::WobbleMeter in, out;
    for (int i = 0; i < flight.frameCount(); ++i) {
        const uavstab::FrameBuffer frame = flight.render(i);
        in.add(lumaOf(frame.view()));
        GstBuffer *buffer = makeFrame(info, frame.view());
        stampFrame(buffer, i);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), flight.frameCount());
    for (const LoggedItem &item : buffers) {
        MappedFrame mapped(info, item.buffer);
        fail_unless(mapped.ok());
        const cv::Mat luma = lumaOf(mapped.view());
        out.add(luma);
        // Black (video range 16) shows where the output reads outside the input: the
        // photograph has none of it.
        const double black = double(cv::countNonZero(luma == 16)) / double(luma.total());
        r.coverage_min = std::min(r.coverage_min, 1.0 - black);
        r.luma.emplace_back(luma.clone().reshape(1, 1));
        const GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(item.buffer);
        fail_unless(meta != nullptr);
        r.rows_moved_meta += meta->rolling_shutter ? 1 : 0;
        fail_unless(!meta->rolling_shutter || meta->wobble > 0.0);
    }
    int reports = 0;
    while (GstMessage *message = gst_bus_pop_filtered(bus, GST_MESSAGE_ELEMENT)) {
        const GstStructure *s = gst_message_get_structure(message);
        double wobble = -1.0;
        if (gst_structure_has_name(s, "uavstabilize")) {
            fail_unless(gst_structure_get_double(s, "wobble", &wobble), "no wobble in the message");
            fail_unless(wobble >= 0.0);
            r.reported += wobble;
            gboolean moved = FALSE;
            double readout = -1.0, confidence = -1.0;
            fail_unless(gst_structure_get_boolean(s, "rolling-shutter", &moved));
            fail_unless(gst_structure_get_double(s, "readout", &readout));
            fail_unless(gst_structure_get_double(s, "readout-confidence", &confidence));
            fail_unless(readout >= 0.0 && readout <= 1.0 && confidence >= 0.0 && confidence <= 1.0);
            r.rows_moved += moved ? 1 : 0;
            if (reports > 0 && readout != r.readout)
                ++r.readout_changes;
            r.readout = readout;
            r.readout_confidence = confidence;
            ++reports;
        }
        gst_message_unref(message);
    }
    fail_unless_equals_int(reports, flight.frameCount());
    r.reported /= reports;
    r.wobble_in = in.mean();
    r.wobble_out = out.mean();
    fail_unless_equals_int(r.rows_moved, r.rows_moved_meta);
    g_print("readout %.1f, %s: wobble in %.3f px, out %.3f px (%.0f %%); reported %.3f px; coverage min %.4f; "
            "rows moved in %d frames; readout reported %.3f (confidence %.2f, %d changes)\n",
            options.readout, properties.c_str(), r.wobble_in, r.wobble_out, 100.0 * r.wobble_out / r.wobble_in,
            r.reported, r.coverage_min, r.rows_moved, r.readout, r.readout_confidence, r.readout_changes);

    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
    return r;
}

} // namespace

GST_START_TEST(warm_up)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=2"));
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    for (int i = 0; i < 3; ++i)
        gst_harness_push(h, makeFrame(info, i));
    gst_harness_push_event(h, gst_event_new_eos());
    gst_harness_teardown(h);
}
GST_END_TEST;

ELEMENT_TEST(the_wobble_of_a_rolling_shutter_is_removed_at_every_delay)
{
    for (int delay : {0, 5, 20}) {
        const std::string d = "delay=" + std::to_string(delay);
        const Result on = stabilize(vibratingFlight(0.8), d);
        const Result off = stabilize(vibratingFlight(0.8), d + " rolling-shutter=off");
        fail_unless(on.wobble_in > 2.0, "the flight does not wobble (%.3f px)", on.wobble_in);
        fail_unless(on.wobble_out <= 0.3 * on.wobble_in, "delay %d: wobble %.3f px of %.3f px left", delay,
                    on.wobble_out, on.wobble_in);
        fail_unless(on.reported > 1.0, "delay %d: the messages report %.3f px of wobble", delay, on.reported);
        fail_unless(on.coverage_min >= 0.995, "delay %d: border shows (coverage %.4f)", delay, on.coverage_min);
        // Without the correction the wobble stays (what this element did before).
        fail_unless(off.wobble_out > 0.7 * off.wobble_in, "delay %d: off removed wobble (%.3f of %.3f px)", delay,
                    off.wobble_out, off.wobble_in);
        fail_unless(off.reported == 0.0);
        fail_unless(on.rows_moved >= 80, "delay %d: rows moved in %d frames only", delay, on.rows_moved);
        fail_unless_equals_int(off.rows_moved, 0);
    }
}

// Propellers near twice the frame rate: each frame is bent almost as the one before, the
// bend drifting with a slow beat, and a point sits on other rows from frame to frame as the
// camera moves.
ELEMENT_TEST(a_vibration_that_beats_slowly_with_the_frame_rate_is_removed)
{
    uavstab::synthetic::FlightOptions flight = vibratingFlight(0.9, 60.0, 3.0, 0.15);
    flight.frames = 120;
    const Result on = stabilize(flight, "delay=5");
    fail_unless(on.wobble_in > 0.8, "the flight does not wobble (%.3f px)", on.wobble_in);
    fail_unless(on.wobble_out <= 0.3 * on.wobble_in, "wobble %.3f px of %.3f px left", on.wobble_out, on.wobble_in);
    fail_unless(on.coverage_min >= 0.995, "border shows (coverage %.4f)", on.coverage_min);
}

// A camera whose readout time is known: the same, with the correction applied from the start.
ELEMENT_TEST(a_known_readout_time_removes_the_wobble_too)
{
    // 80 % of a 30 fps frame.
    const Result known = stabilize(vibratingFlight(0.8), "readout-time=26.7");
    fail_unless(known.wobble_out <= 0.3 * known.wobble_in, "wobble %.3f px of %.3f px left", known.wobble_out,
                known.wobble_in);
    fail_unless(known.coverage_min >= 0.995, "border shows (coverage %.4f)", known.coverage_min);
    // The readout is the property's on every frame (never estimated), and always applied.
    fail_unless(std::abs(known.readout - 26.7 / (1000.0 / 30.0)) < 1e-6, "readout %.4f reported", known.readout);
    fail_unless_equals_int(known.readout_changes, 0);
    fail_unless(known.readout_confidence == 1.0);
    fail_unless(known.rows_moved >= 89, "rows moved in %d frames", known.rows_moved);
}

ELEMENT_TEST(footage_without_wobble_comes_out_as_without_the_correction)
{
    const Result on = stabilize(vibratingFlight(0.0), "");
    const Result off = stabilize(vibratingFlight(0.0), "rolling-shutter=off");
    fail_unless(on.reported == 0.0, "a global shutter was corrected (%.3f px reported)", on.reported);
    fail_unless_equals_int(on.rows_moved, 0);
    fail_unless_equals_int(int(on.luma.size()), int(off.luma.size()));
    for (std::size_t i = 0; i < on.luma.size(); ++i)
        fail_unless(on.luma[i] == off.luma[i], "frame %d differs with rolling-shutter=auto", int(i));
}

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *suite = suite_create("rolling_shutter");
    TCase *tc = makeTestCase("rolling_shutter", 600);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, the_wobble_of_a_rolling_shutter_is_removed_at_every_delay);
    tcase_add_test(tc, a_vibration_that_beats_slowly_with_the_frame_rate_is_removed);
    tcase_add_test(tc, a_known_readout_time_removes_the_wobble_too);
    tcase_add_test(tc, footage_without_wobble_comes_out_as_without_the_correction);
    suite_add_tcase(suite, tc);
    return runSuite(suite) == 0 ? 0 : 1;
}
