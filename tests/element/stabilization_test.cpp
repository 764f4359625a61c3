// The element stabilizes: a synthetic shaky flight with a known camera path goes through
// it, and the path the output follows (reconstructed from the per-frame statistics the
// element posts) keeps at most a quarter of the input's jitter.
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "jitter_metrics.hpp"
#include "shaky_flight.hpp"
#include "test_support.hpp"

using namespace element_test;

namespace {

uavstab::Similarity similarityField(const GstStructure *s, const char *prefix)
{
    uavstab::Similarity result;
    const std::string p(prefix);
    fail_unless(gst_structure_get_double(s, (p + "-dx").c_str(), &result.dx), "no %s-dx", prefix);
    fail_unless(gst_structure_get_double(s, (p + "-dy").c_str(), &result.dy), "no %s-dy", prefix);
    fail_unless(gst_structure_get_double(s, (p + "-angle").c_str(), &result.angle), "no %s-angle", prefix);
    fail_unless(gst_structure_get_double(s, (p + "-scale").c_str(), &result.scale), "no %s-scale", prefix);
    return result;
}

struct FrameReport {
    uavstab::FrameStats stats;
    GstClockTime timestamp = GST_CLOCK_TIME_NONE;
};

FrameReport parseReport(const GstStructure *s)
{
    FrameReport report;
    guint64 timestamp = 0, running_time = 0;
    gint64 index = -1;
    gboolean skipped = FALSE;
    fail_unless(gst_structure_get_uint64(s, "timestamp", &timestamp));
    fail_unless(gst_structure_get_uint64(s, "running-time", &running_time));
    fail_unless(gst_structure_get_int64(s, "index", &index));
    fail_unless(gst_structure_get_double(s, "zoom", &report.stats.zoom));
    fail_unless(gst_structure_get_int(s, "points", &report.stats.points));
    fail_unless(gst_structure_get_int(s, "inliers", &report.stats.inliers));
    fail_unless(gst_structure_get_boolean(s, "skipped", &skipped));
    const gchar *model = gst_structure_get_string(s, "model");
    fail_unless(model && (g_str_equal(model, "rigid") || g_str_equal(model, "similarity")), "model %s", model);
    report.timestamp = timestamp;
    report.stats.index = index;
    report.stats.skipped = skipped;
    report.stats.motion = similarityField(s, "motion");
    report.stats.trajectory = similarityField(s, "trajectory");
    report.stats.smoothed = similarityField(s, "smoothed");
    report.stats.correction = similarityField(s, "correction");
    return report;
}

} // namespace

GST_START_TEST(warm_up)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=2 post-messages=true"));
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    for (int i = 0; i < 3; ++i)
        gst_harness_push(h, makeFrame(info, i));
    gst_harness_push_event(h, gst_event_new_eos());
    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
}
GST_END_TEST;

namespace {

struct Jitter {
    double input = 0, output = 0;
    // Against the intended (shake-free) path, after the first second.
    double input_vs_intended = 0, output_vs_intended = 0;
    // The same over the first second alone (a start-up: the planner knows no past).
    double input_first_second = 0, output_first_second = 0;
};

uavstab::synthetic::FlightOptions driftingFlight()
{
    uavstab::synthetic::FlightOptions options;
    options.width = 640;
    options.height = 360;
    options.frames = 150;
    options.format = uavstab::PixelFormat::I420;
    return options;
}

// Pushes the synthetic flight through uavstabilize with `properties`, checks every frame
// and its report come out, and measures the residual jitter of the output's camera path.
Jitter stabilizeFlight(const std::string &properties,
                       const uavstab::synthetic::FlightOptions &options = driftingFlight())
{
    const uavstab::synthetic::ShakyFlight flight(options);

    GstHarness *h = makeHarness(makeStabilizer("threads=2 post-messages=true " + properties));
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    GstCaps *caps = videoCaps("I420", options.width, options.height);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad);

    for (int i = 0; i < flight.frameCount(); ++i) {
        GstBuffer *buffer = makeFrame(info, flight.render(i).view());
        stampFrame(buffer, i);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    fail_unless_equals_int(int(log.buffers().size()), flight.frameCount());

    // One report per frame, in output order, each naming its frame by timestamp.
    std::vector<FrameReport> reports;
    while (GstMessage *message = gst_bus_pop_filtered(bus, GST_MESSAGE_ELEMENT)) {
        const GstStructure *s = gst_message_get_structure(message);
        if (gst_structure_has_name(s, "uavstabilize"))
            reports.push_back(parseReport(s));
        gst_message_unref(message);
    }
    fail_unless_equals_int(int(reports.size()), flight.frameCount());
    std::vector<uavstab::Similarity> input_path, output_path, intended_path;
    for (int i = 0; i < int(reports.size()); ++i) {
        fail_unless_equals_uint64(reports[i].timestamp, i * frameDuration());
        fail_unless_equals_int(int(reports[i].stats.index), i);
        input_path.push_back(flight.truePose(i));
        intended_path.push_back(flight.intendedPose(i));
        output_path.push_back(flight.truePose(i) * uavstab::synthetic::outputToInput(reports[i].stats));
        // Never a border: the output frame reads from inside the input frame everywhere.
        fail_unless(uavstab::synthetic::coverage(uavstab::synthetic::outputToInput(reports[i].stats), options.width,
                                                 options.height) == 1.0,
                    "frame %d shows border", i);
    }
    Jitter jitter;
    jitter.input = uavstab::synthetic::residualJitter(input_path, options.width, options.height);
    jitter.output = uavstab::synthetic::residualJitter(output_path, options.width, options.height);
    const std::size_t second = std::size_t(std::lround(options.fps));
    jitter.input_vs_intended = uavstab::synthetic::intendedPathJitter(input_path, intended_path, options.width,
                                                                      options.height, second);
    jitter.output_vs_intended = uavstab::synthetic::intendedPathJitter(output_path, intended_path, options.width,
                                                                       options.height, second);
    auto head = [&](const std::vector<uavstab::Similarity> &path) {
        return std::vector<uavstab::Similarity>(path.begin(), path.begin() + long(second));
    };
    jitter.input_first_second = uavstab::synthetic::intendedPathJitter(head(input_path), head(intended_path),
                                                                       options.width, options.height);
    jitter.output_first_second = uavstab::synthetic::intendedPathJitter(head(output_path), head(intended_path),
                                                                        options.width, options.height);
    g_print("%s: residual jitter: input %.3f px, output %.3f px (%.0f %%); against the intended path after the "
            "first second: input %.3f px, output %.3f px; in the first second: input %.3f px, output %.3f px\n",
            properties.c_str(), jitter.input, jitter.output, 100.0 * jitter.output / jitter.input,
            jitter.input_vs_intended, jitter.output_vs_intended, jitter.input_first_second,
            jitter.output_first_second);
    fail_unless(jitter.input > 1.0, "the synthetic flight is not shaky (%.3f)", jitter.input);

    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
    return jitter;
}

} // namespace

ELEMENT_TEST(shaky_flight_loses_three_quarters_of_its_jitter)
{
    const Jitter j = stabilizeFlight("");
    fail_unless(j.output <= 0.25 * j.input, "output jitter %.3f px is more than a quarter of the input's %.3f px",
                j.output, j.input);
}

// The live user's delays, judged after the first second (a causal planner cannot know the
// drift it starts in); in the first second the output must be no shakier than the input.
ELEMENT_TEST(short_delays_still_remove_most_of_the_jitter)
{
    for (const auto &[delay, share] : {std::pair<int, double>{5, 0.12}, {0, 0.15}}) {
        const Jitter j = stabilizeFlight("delay=" + std::to_string(delay));
        fail_unless(j.output_vs_intended <= share * j.input_vs_intended,
                    "delay %d: %.3f px of jitter left after the first second, more than %.0f %% of %.3f px", delay,
                    j.output_vs_intended, 100 * share, j.input_vs_intended);
        fail_unless(j.output_first_second <= j.input_first_second,
                    "delay %d: the first second is shakier than the input (%.3f px, input %.3f px)", delay,
                    j.output_first_second, j.input_first_second);
    }
}

// A drone holding station under UAV shake (no drift, no yaw): the default planner keeps the
// view still where the crop allows, at the live user's delays too.
ELEMENT_TEST(a_hover_comes_out_still_at_every_delay)
{
    uavstab::synthetic::FlightOptions options = driftingFlight();
    options.pan_speed = 0.0;
    options.rotation_amplitude_deg = 0.0;
    for (int delay : {0, 5, 20}) {
        const Jitter j = stabilizeFlight("delay=" + std::to_string(delay), options);
        const Jitter optimal = stabilizeFlight("planner=optimal delay=" + std::to_string(delay), options);
        // The optimal planner (the default before) leaves 0.07-0.23 px here.
        fail_unless(j.output_vs_intended <= 0.05, "delay %d: %.3f px of jitter left (optimal planner %.3f px)", delay,
                    j.output_vs_intended, optimal.output_vs_intended);
    }
}

// The drifting flight under strong shake (the benchmark's strong720, at 640x360: about 8.7 px
// RMS a corner and 0.5 deg of roll, against 25 x 14 px of crop room a side). Most of the
// shake goes at every live delay, and from the first frames on: the look-ahead shows the
// drift, so the output follows it from the start instead of riding the crop's edge behind
// it until the past proves it steady.
ELEMENT_TEST(strong_shake_on_a_drift_is_removed_at_every_delay)
{
    uavstab::synthetic::FlightOptions options = driftingFlight();
    options.noise_px = 1.5;
    options.band_px = 5.5;
    options.rotation_noise_deg = 0.1;
    options.rotation_band_deg = 0.5;
    struct Limit {
        int delay;
        double after_first_second, first_second;  // shares of the input's jitter
    };
    for (const Limit &limit : {Limit{0, 0.10, 0.40}, Limit{5, 0.075, 0.25}, Limit{20, 0.05, 0.06}}) {
        const Jitter j = stabilizeFlight("delay=" + std::to_string(limit.delay), options);
        fail_unless(j.output_vs_intended <= limit.after_first_second * j.input_vs_intended,
                    "delay %d: %.3f px of jitter left after the first second, more than %.1f %% of %.3f px",
                    limit.delay, j.output_vs_intended, 100 * limit.after_first_second, j.input_vs_intended);
        fail_unless(j.output_first_second <= limit.first_second * j.input_first_second,
                    "delay %d: %.3f px of jitter left in the first second, more than %.0f %% of %.3f px", limit.delay,
                    j.output_first_second, 100 * limit.first_second, j.input_first_second);
    }
}

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *s = suite_create("uavstabilize-stabilization");
    TCase *tc = makeTestCase("stabilization");
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, shaky_flight_loses_three_quarters_of_its_jitter);
    tcase_add_test(tc, short_delays_still_remove_most_of_the_jitter);
    tcase_add_test(tc, a_hover_comes_out_still_at_every_delay);
    tcase_add_test(tc, strong_shake_on_a_drift_is_removed_at_every_delay);
    return runSuite(s) == 0 ? 0 : 1;
}
