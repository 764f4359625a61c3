// Metadata on the output: every buffer uavstabilize pushes carries a GstUavStabMeta that
// agrees with the frame's bus message and whose matrix is the warp; regions of interest
// (GstVideoRegionOfInterestMeta, e.g. a detector's boxes) follow the warp; the meta is
// copied as is and follows a scale.
#include <algorithm>
#include <array>
#include <optional>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "jitter_metrics.hpp"
#include "shaky_flight.hpp"
#include "test_support.hpp"
#include "uavstab_meta.h"

using namespace element_test;
using uavstab::Point2;
using uavstab::Similarity;

namespace {

GST_START_TEST(warm_up)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=2 post-messages=true"));
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    for (int i = 0; i < 3; ++i) {
        GstBuffer *buffer = makeFrame(info, i);
        gst_buffer_add_video_region_of_interest_meta(buffer, "warm-up", 1, 2, 10, 10);
        gst_harness_push(h, buffer);
    }
    gst_harness_push_event(h, gst_event_new_eos());
    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
    // The pipeline test's elements, whose class data lives on.
    for (const char *tail : {"videoscale ! video/x-raw,width=32,height=24", "videoflip video-direction=90r"}) {
        GstElement *pipeline = launchPipeline(std::string("videotestsrc num-buffers=2 ! video/x-raw,width=16,height=16 "
                                                          "! uavstabilize delay=1 ! ") + tail + " ! fakesink");
        gst_element_set_state(pipeline, GST_STATE_PLAYING);
        gst_message_unref(waitForMessage(pipeline, GST_MESSAGE_EOS));
        gst_element_set_state(pipeline, GST_STATE_NULL);
        gst_object_unref(pipeline);
    }
}
GST_END_TEST;

Similarity transformOf(const GstUavStabTransform &t)
{
    return {t.dx, t.dy, t.angle, t.scale};
}

Similarity similarityField(const GstStructure *s, const char *prefix)
{
    Similarity result;
    const std::string p(prefix);
    fail_unless(gst_structure_get_double(s, (p + "-dx").c_str(), &result.dx), "no %s-dx", prefix);
    fail_unless(gst_structure_get_double(s, (p + "-dy").c_str(), &result.dy), "no %s-dy", prefix);
    fail_unless(gst_structure_get_double(s, (p + "-angle").c_str(), &result.angle), "no %s-angle", prefix);
    fail_unless(gst_structure_get_double(s, (p + "-scale").c_str(), &result.scale), "no %s-scale", prefix);
    return result;
}

void checkSameSimilarity(const Similarity &meta, const Similarity &message, const char *what, int frame)
{
    // The message carries the same doubles: exact.
    fail_unless(meta.dx == message.dx && meta.dy == message.dy && meta.angle == message.angle &&
                    meta.scale == message.scale,
                "frame %d: %s differs: meta %g %g %g %g, message %g %g %g %g", frame, what, meta.dx, meta.dy,
                meta.angle, meta.scale, message.dx, message.dy, message.angle, message.scale);
}

const char *outcomeName(GstUavStabOutcome outcome)
{
    switch (outcome) {
    case GST_UAV_STAB_OUTCOME_WARPED:
        return "warped";
    case GST_UAV_STAB_OUTCOME_BYPASSED:
        return "bypassed";
    case GST_UAV_STAB_OUTCOME_PASSED_THROUGH:
        return "no-output";
    default:
        return "failed";
    }
}

// Pixel (centre) coordinates <-> the library's centred coordinates.
Point2 centred(Point2 p, int width, int height)
{
    return {p.x - (width - 1) * 0.5, p.y - (height - 1) * 0.5};
}
Point2 pixel(Point2 c, int width, int height)
{
    return {c.x + (width - 1) * 0.5, c.y + (height - 1) * 0.5};
}

Point2 outputToInput(const GstUavStabMeta *meta, Point2 p)
{
    Point2 q;
    gst_uav_stab_meta_output_to_input(meta, p.x, p.y, &q.x, &q.y);
    return q;
}

Point2 inputToOutput(const GstUavStabMeta *meta, Point2 p)
{
    Point2 q;
    fail_unless(gst_uav_stab_meta_input_to_output(meta, p.x, p.y, &q.x, &q.y));
    return q;
}

// Checks a buffer's meta against the frame's bus message, field by field, and its
// matrix against the mapping the message implies (correction and zoom) when warped,
// the identity otherwise. Returns the largest matrix disagreement, pixels.
double checkMetaAgainstMessage(GstBuffer *buffer, const GstStructure *s, int frame, int width, int height)
{
    GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(buffer);
    fail_unless(meta != nullptr, "frame %d has no GstUavStabMeta", frame);
    fail_unless_equals_int(meta->version, GST_UAV_STAB_META_VERSION);
    // Exactly one.
    int count = 0;
    gpointer state = nullptr;
    while (gst_buffer_iterate_meta_filtered(buffer, &state, GST_UAV_STAB_META_API_TYPE))
        ++count;
    fail_unless_equals_int(count, 1);

    guint64 timestamp = 0;
    gint64 index = -1;
    fail_unless(gst_structure_get_uint64(s, "timestamp", &timestamp));
    fail_unless_equals_uint64(timestamp, GST_BUFFER_PTS(buffer));
    fail_unless(gst_structure_get_int64(s, "index", &index));
    fail_unless_equals_int64(meta->index, index);
    fail_unless_equals_int(meta->frame_width, width);
    fail_unless_equals_int(meta->frame_height, height);
    fail_unless_equals_int(meta->width, width);
    fail_unless_equals_int(meta->height, height);
    checkSameSimilarity(transformOf(meta->motion), similarityField(s, "motion"), "motion", frame);
    checkSameSimilarity(transformOf(meta->trajectory), similarityField(s, "trajectory"), "trajectory", frame);
    checkSameSimilarity(transformOf(meta->smoothed), similarityField(s, "smoothed"), "smoothed", frame);
    const Similarity correction = similarityField(s, "correction");
    checkSameSimilarity(transformOf(meta->correction), correction, "correction", frame);
    double zoom = 0, fraction = 0;
    fail_unless(gst_structure_get_double(s, "zoom", &zoom));
    fail_unless(gst_structure_get_double(s, "correction-fraction", &fraction));
    fail_unless(meta->zoom == zoom, "frame %d: zoom %g vs %g", frame, meta->zoom, zoom);
    fail_unless(meta->correction_fraction == fraction);
    fail_unless_equals_string(gst_structure_get_string(s, "model"),
                              meta->model == GST_UAV_STAB_MODEL_SIMILARITY ? "similarity" : "rigid");
    int points = -1, inliers = -1;
    gboolean skipped = FALSE, segment_start = FALSE;
    fail_unless(gst_structure_get_int(s, "points", &points));
    fail_unless(gst_structure_get_int(s, "inliers", &inliers));
    fail_unless(gst_structure_get_boolean(s, "skipped", &skipped));
    fail_unless(gst_structure_get_boolean(s, "segment-start", &segment_start));
    fail_unless_equals_int(meta->points, points);
    fail_unless_equals_int(meta->inliers, inliers);
    fail_unless_equals_int(!!meta->skipped, !!skipped);
    fail_unless_equals_int(!!meta->segment_start, !!segment_start);
    fail_unless_equals_string(gst_structure_get_string(s, "outcome"), outcomeName(meta->outcome));

    // The matrix: output pixel -> input pixel. Warped: correction^-1 * zoom^-1 about the
    // centre (what the warper draws); otherwise the buffer is the input: identity.
    uavstab::FrameStats stats;
    stats.correction = correction;
    stats.zoom = zoom;
    const Similarity expected =
        meta->outcome == GST_UAV_STAB_OUTCOME_WARPED ? uavstab::synthetic::outputToInput(stats) : Similarity{};
    fail_unless(meta->output_to_input[6] == 0 && meta->output_to_input[7] == 0 && meta->output_to_input[8] == 1);
    double worst = 0;
    const double w1 = width - 1, h1 = height - 1;
    for (const Point2 p : {Point2{0, 0}, Point2{w1, 0}, Point2{0, h1}, Point2{w1, h1}, Point2{w1 / 2, h1 / 2},
                           Point2{17.25, 40.5}}) {
        const Point2 in = outputToInput(meta, p);
        const Point2 want = pixel(expected.apply(centred(p, width, height)), width, height);
        worst = std::max(worst, std::hypot(in.x - want.x, in.y - want.y));
        // And back, through the header's inverse.
        const Point2 back = inputToOutput(meta, in);
        worst = std::max(worst, std::hypot(back.x - p.x, back.y - p.y));
    }
    fail_unless(worst < 1e-6, "frame %d: the matrix is %g px off output_to_input", frame, worst);
    return worst;
}

std::vector<GstStructure *> popReports(GstBus *bus)
{
    std::vector<GstStructure *> reports;
    while (GstMessage *message = gst_bus_pop_filtered(bus, GST_MESSAGE_ELEMENT)) {
        const GstStructure *s = gst_message_get_structure(message);
        if (gst_structure_has_name(s, "uavstabilize"))
            reports.push_back(gst_structure_copy(s));
        gst_message_unref(message);
    }
    return reports;
}

void freeReports(std::vector<GstStructure *> &reports)
{
    for (GstStructure *s : reports)
        gst_structure_free(s);
    reports.clear();
}

uavstab::synthetic::FlightOptions flightOptions(int width, int height, int frames)
{
    uavstab::synthetic::FlightOptions options;
    options.width = width;
    options.height = height;
    options.frames = frames;
    options.format = uavstab::PixelFormat::I420;
    return options;
}

// A pool handing out buffers too small for any frame: the output cannot be mapped, so
// every frame passes through uncorrected (Outcome::Failed).
GstFlowReturn allocTinyBuffer(GstBufferPool *, GstBuffer **buffer, GstBufferPoolAcquireParams *)
{
    *buffer = gst_buffer_new_allocate(nullptr, 16, nullptr);
    return GST_FLOW_OK;
}

GType tinyPoolType()
{
    static const GType type = g_type_register_static_simple(
        GST_TYPE_BUFFER_POOL, "UavStabilizeMetaTestTinyPool", sizeof(GstBufferPoolClass),
        [](gpointer klass, gpointer) { GST_BUFFER_POOL_CLASS(klass)->alloc_buffer = allocTinyBuffer; },
        sizeof(GstBufferPool), nullptr, GTypeFlags(0));
    return type;
}

gboolean proposeTinyPool(GstPad *pad, GstObject *parent, GstQuery *query)
{
    if (GST_QUERY_TYPE(query) != GST_QUERY_ALLOCATION)
        return gst_pad_query_default(pad, parent, query);
    auto *pool = GST_BUFFER_POOL(gst_object_ref_sink(g_object_new(tinyPoolType(), nullptr)));
    gst_query_add_allocation_pool(query, pool, 16, 0, 0);
    gst_object_unref(pool);
    return TRUE;
}

// A flight through uavstabilize (post-messages=true + `properties`); every output buffer
// is checked against its bus message. Returns the outcomes seen.
std::vector<GstUavStabOutcome> checkFlight(const std::string &properties, bool tiny_pool = false)
{
    const uavstab::synthetic::ShakyFlight flight(flightOptions(320, 180, 60));
    const int width = flight.options().width, height = flight.options().height;
    GstHarness *h = makeHarness(makeStabilizer("threads=2 post-messages=true " + properties));
    if (tiny_pool)
        gst_pad_set_query_function(h->sinkpad, proposeTinyPool);
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    GstCaps *caps = videoCaps("I420", width, height);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad, true);
    for (int i = 0; i < flight.frameCount(); ++i) {
        GstBuffer *buffer = makeFrame(info, flight.render(i).view());
        stampFrame(buffer, i);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), flight.frameCount());
    std::vector<GstStructure *> reports = popReports(bus);
    fail_unless_equals_int(int(reports.size()), flight.frameCount());
    std::vector<GstUavStabOutcome> outcomes;
    double worst = 0;
    for (int i = 0; i < flight.frameCount(); ++i) {
        worst = std::max(worst, checkMetaAgainstMessage(buffers[i].buffer, reports[i], i, width, height));
        outcomes.push_back(gst_buffer_get_uav_stab_meta(buffers[i].buffer)->outcome);
    }
    g_print("'%s'%s: %d buffers, each with a meta agreeing with its message; matrix within %.2g px\n",
            properties.c_str(), tiny_pool ? " (tiny pool)" : "", flight.frameCount(), worst);
    freeReports(reports);
    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
    return outcomes;
}

bool all(const std::vector<GstUavStabOutcome> &outcomes, GstUavStabOutcome outcome)
{
    return std::all_of(outcomes.begin(), outcomes.end(), [outcome](GstUavStabOutcome o) { return o == outcome; });
}

} // namespace

// (a) Warped, bypassed and passed-through frames all carry the meta, equal to the message.
ELEMENT_TEST(every_buffer_carries_the_meta_of_its_bus_message)
{
    fail_unless(all(checkFlight(""), GST_UAV_STAB_OUTCOME_WARPED));
    fail_unless(all(checkFlight("delay=0 model=similarity"), GST_UAV_STAB_OUTCOME_WARPED));
    fail_unless(all(checkFlight("bypass=true"), GST_UAV_STAB_OUTCOME_BYPASSED));
    fail_unless(all(checkFlight("delay=2", true), GST_UAV_STAB_OUTCOME_FAILED));
}

// A bypassed buffer held elsewhere too (tee, application) still gets the meta: a new
// GstBuffer over the same memory, nothing copied; the input keeps no meta.
ELEMENT_TEST(a_shared_input_gets_the_meta_without_a_pixel_copy)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=1 bypass=true"));
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad, true);
    std::vector<GstBuffer *> inputs;
    for (int i = 0; i < 4; ++i) {
        inputs.push_back(makeFrame(info, i));
        fail_unless_equals_int(gst_harness_push(h, gst_buffer_ref(inputs.back())), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 4);
    for (int i = 0; i < 4; ++i) {
        fail_unless(gst_buffer_get_uav_stab_meta(inputs[i]) == nullptr);
        const GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(buffers[i].buffer);
        fail_unless(meta != nullptr && meta->outcome == GST_UAV_STAB_OUTCOME_BYPASSED);
        fail_unless(gst_buffer_peek_memory(buffers[i].buffer, 0) == gst_buffer_peek_memory(inputs[i], 0));
        gst_buffer_unref(inputs[i]);
    }
    gst_harness_teardown(h);
}

namespace {

struct RoiRun {
    double worst_distance = 0;  // world point from the output box's centre, px
    double worst_size_error = 0;  // output box side vs the box's side through the transform, px
    int min_side = 1 << 30, max_side = 0;
    double input_jitter = 0, output_jitter = 0;  // RMS second difference of the point's position
    int corner_boxes = 0;
};

GstVideoRegionOfInterestMeta *findRoi(GstBuffer *buffer, const char *type)
{
    gpointer state = nullptr;
    GstVideoRegionOfInterestMeta *found = nullptr;
    int count = 0;
    while (GstMeta *meta = gst_buffer_iterate_meta_filtered(buffer, &state, GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE)) {
        auto *roi = reinterpret_cast<GstVideoRegionOfInterestMeta *>(meta);
        if (roi->roi_type == g_quark_from_string(type)) {
            found = roi;
            ++count;
        }
    }
    fail_unless(count <= 1, "%d boxes of type %s", count, type);
    return found;
}

// A box (top-left-corner coordinates) through the meta's input -> output mapping: the
// bounding box of its corners, rounded and clipped to the frame; none when empty.
std::optional<std::array<guint, 4>> expectedBox(const GstUavStabMeta *meta, guint x, guint y, guint w, guint h,
                                                int width, int height)
{
    double min_x = HUGE_VAL, min_y = HUGE_VAL, max_x = -HUGE_VAL, max_y = -HUGE_VAL;
    for (const Point2 corner : {Point2{double(x), double(y)}, Point2{double(x + w), double(y)},
                                Point2{double(x), double(y + h)}, Point2{double(x + w), double(y + h)}}) {
        const Point2 q = inputToOutput(meta, {corner.x - 0.5, corner.y - 0.5});
        min_x = std::min(min_x, q.x + 0.5);
        max_x = std::max(max_x, q.x + 0.5);
        min_y = std::min(min_y, q.y + 0.5);
        max_y = std::max(max_y, q.y + 0.5);
    }
    const long left = std::lround(std::clamp(min_x, 0.0, double(width)));
    const long right = std::lround(std::clamp(max_x, 0.0, double(width)));
    const long top = std::lround(std::clamp(min_y, 0.0, double(height)));
    const long bottom = std::lround(std::clamp(max_y, 0.0, double(height)));
    if (right <= left || bottom <= top)
        return std::nullopt;
    return std::array<guint, 4>{guint(left), guint(top), guint(right - left), guint(bottom - top)};
}

double rmsSecondDifference(const std::vector<Point2> &track)
{
    double sum = 0;
    for (std::size_t i = 1; i + 1 < track.size(); ++i) {
        const double ax = track[i + 1].x - 2 * track[i].x + track[i - 1].x;
        const double ay = track[i + 1].y - 2 * track[i].y + track[i - 1].y;
        sum += ax * ax + ay * ay;
    }
    return track.size() > 2 ? std::sqrt(sum / double(track.size() - 2)) : 0.0;
}

constexpr int kBox = 40;

// The synthetic flight with a marked object: a fixed world point (the centre of the
// middle frame), its true 40x40 box attached to every input frame as region of interest
// "object" (id 7, parent 3, a "detection" param); plus a 4x4 box "corner" in the input's
// top-left corner, which the crop hides.
RoiRun runRoiFlight(const std::string &properties)
{
    const uavstab::synthetic::ShakyFlight flight(flightOptions(640, 360, 120));
    const int width = flight.options().width, height = flight.options().height;
    const Point2 world = flight.truePose(flight.frameCount() / 2).apply({0, 0});

    GstHarness *h = makeHarness(makeStabilizer("threads=2 " + properties));
    GstCaps *caps = videoCaps("I420", width, height);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad, true);
    std::vector<Point2> input_points;  // the world point in each input frame (pixel centres)
    std::vector<std::array<guint, 2>> input_boxes;
    for (int i = 0; i < flight.frameCount(); ++i) {
        const Point2 p = pixel(flight.truePose(i).inverse().apply(world), width, height);
        input_points.push_back(p);
        // Box edges are top-left-corner coordinates: the pixel centre p is at p + 0.5.
        const long x = std::lround(p.x + 0.5 - kBox / 2), y = std::lround(p.y + 0.5 - kBox / 2);
        fail_unless(x >= 0 && y >= 0 && x + kBox <= width && y + kBox <= height, "frame %d: box off the frame", i);
        input_boxes.push_back({guint(x), guint(y)});
        GstBuffer *buffer = makeFrame(info, flight.render(i).view());
        stampFrame(buffer, i);
        GstVideoRegionOfInterestMeta *roi =
            gst_buffer_add_video_region_of_interest_meta(buffer, "object", guint(x), guint(y), kBox, kBox);
        roi->id = 7;
        roi->parent_id = 3;
        gst_video_region_of_interest_meta_add_param(
            roi, gst_structure_new("detection", "confidence", G_TYPE_DOUBLE, 0.75, "frame", G_TYPE_INT, i, nullptr));
        gst_buffer_add_video_region_of_interest_meta(buffer, "corner", 0, 0, 4, 4);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), flight.frameCount());

    RoiRun run;
    std::vector<Point2> output_points;
    for (int i = 0; i < flight.frameCount(); ++i) {
        GstBuffer *buffer = buffers[i].buffer;
        const GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(buffer);
        fail_unless(meta != nullptr);
        GstVideoRegionOfInterestMeta *roi = findRoi(buffer, "object");
        fail_unless(roi != nullptr, "frame %d lost its region of interest", i);
        fail_unless_equals_int(roi->id, 7);
        fail_unless_equals_int(roi->parent_id, 3);
        const GstStructure *param = gst_video_region_of_interest_meta_get_param(roi, "detection");
        fail_unless(param != nullptr, "frame %d: the box lost its params", i);
        double confidence = 0;
        int frame = -1;
        fail_unless(gst_structure_get_double(param, "confidence", &confidence) && confidence == 0.75);
        fail_unless(gst_structure_get_int(param, "frame", &frame) && frame == i);
        fail_unless(roi->x + roi->w <= guint(width) && roi->y + roi->h <= guint(height));

        // Where the world point is in the output: the input point through the inverse of
        // the output-to-input mapping the meta reports.
        const Point2 q = inputToOutput(meta, input_points[i]);
        output_points.push_back(q);
        const double ex = q.x + 0.5, ey = q.y + 0.5;  // top-left-corner coordinates
        fail_unless(ex >= roi->x && ex <= roi->x + roi->w && ey >= roi->y && ey <= roi->y + roi->h,
                    "frame %d: the object at %.1f,%.1f is outside its box %u,%u %ux%u", i, ex, ey, roi->x, roi->y,
                    roi->w, roi->h);
        run.worst_distance =
            std::max(run.worst_distance, std::hypot(ex - (roi->x + roi->w / 2.0), ey - (roi->y + roi->h / 2.0)));
        // The box's side through the transform: a 40 px square scaled by the input ->
        // output scale and turned, whose bounding box is side * (|cos| + |sin|).
        const double a = meta->output_to_input[0], b = meta->output_to_input[3];
        const double scale = 1.0 / std::hypot(a, b), angle = std::atan2(b, a);
        const double side = kBox * scale * (std::abs(std::cos(angle)) + std::abs(std::sin(angle)));
        if (meta->outcome == GST_UAV_STAB_OUTCOME_WARPED) {
            run.worst_size_error = std::max({run.worst_size_error, std::abs(roi->w - side), std::abs(roi->h - side)});
        } else {
            fail_unless(roi->x == input_boxes[i][0] && roi->y == input_boxes[i][1] && roi->w == guint(kBox) &&
                            roi->h == guint(kBox),
                        "frame %d: a frame that was not warped changed its box", i);
        }
        run.min_side = std::min({run.min_side, int(roi->w), int(roi->h)});
        run.max_side = std::max({run.max_side, int(roi->w), int(roi->h)});

        // Both boxes are exactly the bounding box of their corners through the meta's
        // mapping, rounded and clipped; the corner box only where some of it shows.
        const std::optional<std::array<guint, 4>> object_box = expectedBox(meta, input_boxes[i][0], input_boxes[i][1], kBox, kBox, width, height);
        fail_unless(object_box && (*object_box)[0] == roi->x && (*object_box)[1] == roi->y &&
                        (*object_box)[2] == roi->w && (*object_box)[3] == roi->h,
                    "frame %d: the box is not the mapped input box", i);
        const GstVideoRegionOfInterestMeta *corner = findRoi(buffer, "corner");
        const std::optional<std::array<guint, 4>> corner_box = expectedBox(meta, 0, 0, 4, 4, width, height);
        fail_unless(corner_box.has_value() == (corner != nullptr), "frame %d: corner box %s", i,
                    corner ? "kept outside the output" : "dropped inside the output");
        if (corner)
            fail_unless((*corner_box)[0] == corner->x && (*corner_box)[1] == corner->y &&
                        (*corner_box)[2] == corner->w && (*corner_box)[3] == corner->h);
        run.corner_boxes += corner != nullptr;
    }
    run.input_jitter = rmsSecondDifference(input_points);
    run.output_jitter = rmsSecondDifference(output_points);
    gst_harness_teardown(h);
    return run;
}

} // namespace

// (b) The test: the world point stays inside its box, which keeps its size.
ELEMENT_TEST(regions_of_interest_follow_the_warp)
{
    const RoiRun run = runRoiFlight("");
    g_print("regions of interest: the world point at most %.2f px from its box's centre; sides %d..%d px (the 40 px "
            "box through the transform: within %.2f px); point jitter input %.3f, output %.3f px/frame^2; corner box "
            "kept on %d frames\n",
            run.worst_distance, run.min_side, run.max_side, run.worst_size_error, run.input_jitter, run.output_jitter,
            run.corner_boxes);
    fail_unless(run.worst_distance <= 1.5, "the box is off its object by %.2f px", run.worst_distance);
    fail_unless(run.worst_size_error <= 1.0, "box size off by %.2f px", run.worst_size_error);
    fail_unless(run.min_side >= kBox - 2 && run.max_side <= kBox + 6, "box sides %d..%d", run.min_side,
                run.max_side);
    fail_unless_equals_int(run.corner_boxes, 0);
    // The boxes are stabilized too: the object moves smoothly in the output.
    fail_unless(run.output_jitter < 0.5 * run.input_jitter, "output jitter %.3f vs input %.3f", run.output_jitter,
                run.input_jitter);
}

ELEMENT_TEST(bypassed_frames_keep_their_boxes)
{
    const RoiRun run = runRoiFlight("bypass=true");
    fail_unless_equals_int(run.min_side, kBox);
    fail_unless_equals_int(run.max_side, kBox);
    fail_unless_equals_int(run.corner_boxes, 120);
}

namespace {

// A meta on a new buffer with a known mapping on a width x height frame.
GstUavStabMeta *addTestMeta(GstBuffer *buffer, const Similarity &output_to_input, int width, int height)
{
    const GstMetaInfo *info = gst_uav_stab_meta_get_info();
    fail_unless(info != nullptr, "the meta is not registered");
    auto *meta = reinterpret_cast<GstUavStabMeta *>(gst_buffer_add_meta(buffer, info, nullptr));
    fail_unless(meta != nullptr);
    fail_unless(meta->zoom == 1.0 && meta->output_to_input[0] == 1.0 && meta->output_to_input[4] == 1.0);
    meta->index = 42;
    meta->frame_width = meta->width = width;
    meta->frame_height = meta->height = height;
    meta->correction = {1.5, -2.5, 0.02, 1.0};
    meta->zoom = 1.1;
    meta->points = 48;
    meta->inliers = 45;
    meta->model = GST_UAV_STAB_MODEL_SIMILARITY;
    meta->segment_start = TRUE;
    meta->outcome = GST_UAV_STAB_OUTCOME_WARPED;
    const std::array<double, 6> m = output_to_input.pixelMatrix(width, height);
    std::copy(m.begin(), m.end(), meta->output_to_input);
    return meta;
}

bool sameFields(const GstUavStabMeta *a, const GstUavStabMeta *b)
{
    return std::memcmp(reinterpret_cast<const char *>(a) + sizeof(GstMeta),
                       reinterpret_cast<const char *>(b) + sizeof(GstMeta),
                       sizeof(GstUavStabMeta) - sizeof(GstMeta)) == 0;
}

// Scales from in_w x in_h to out_w x out_h through the meta's transform function and
// checks the new matrix maps every scaled output pixel to the scaled input pixel.
void checkScale(GstBuffer *source, GstUavStabMeta *meta, int out_w, int out_h)
{
    GstVideoInfo in_info, out_info;
    gst_video_info_set_format(&in_info, GST_VIDEO_FORMAT_I420, guint(meta->width), guint(meta->height));
    gst_video_info_set_format(&out_info, GST_VIDEO_FORMAT_I420, guint(out_w), guint(out_h));
    GstVideoMetaTransform transform = {&in_info, &out_info};
    GstBuffer *scaled = gst_buffer_new();
    fail_unless(meta->meta.info->transform_func(scaled, &meta->meta, source, gst_video_meta_transform_scale_get_quark(),
                                                &transform));
    const GstUavStabMeta *result = gst_buffer_get_uav_stab_meta(scaled);
    fail_unless(result != nullptr);
    fail_unless_equals_int(result->width, out_w);
    fail_unless_equals_int(result->height, out_h);
    fail_unless_equals_int(result->frame_width, meta->frame_width);  // the statistics' frame
    fail_unless(result->zoom == meta->zoom && result->correction.dx == meta->correction.dx &&
                result->index == meta->index && result->outcome == meta->outcome);
    const double sx = double(out_w) / meta->width, sy = double(out_h) / meta->height;
    double worst = 0;
    for (const Point2 p : {Point2{0, 0}, Point2{out_w - 1.0, 0}, Point2{0, out_h - 1.0},
                           Point2{out_w - 1.0, out_h - 1.0}, Point2{out_w / 3.0, out_h / 2.0}}) {
        // The scaled frame's pixel p shows the original's (p + 0.5) / s - 0.5.
        Point2 original{(p.x + 0.5) / sx - 0.5, (p.y + 0.5) / sy - 0.5};
        const Point2 in = outputToInput(meta, original);
        const Point2 want{(in.x + 0.5) * sx - 0.5, (in.y + 0.5) * sy - 0.5};
        const Point2 got = outputToInput(result, p);
        worst = std::max(worst, std::hypot(got.x - want.x, got.y - want.y));
    }
    fail_unless(worst < 1e-9, "scaled matrix off by %g px", worst);
    gst_buffer_unref(scaled);
}

} // namespace

// (c) Copy as is; scale: the matrix follows the new size; any other transform: dropped.
ELEMENT_TEST(the_meta_is_copied_and_scaled)
{
    GstBuffer *buffer = gst_buffer_new_allocate(nullptr, 64, nullptr);
    const Similarity mapping{3.0, -2.0, 0.05, 1.0 / 1.1};
    GstUavStabMeta *meta = addTestMeta(buffer, mapping, 320, 180);

    GstBuffer *copy = gst_buffer_copy(buffer);
    const GstUavStabMeta *copied = gst_buffer_get_uav_stab_meta(copy);
    fail_unless(copied != nullptr && copied != meta);
    fail_unless(sameFields(copied, meta), "the copy differs");
    gst_buffer_unref(copy);

    checkScale(buffer, meta, 640, 360);  // 2x
    checkScale(buffer, meta, 160, 240);  // 0.5 x 1.33
    checkScale(buffer, meta, 320, 180);  // same size: unchanged
    {
        GstVideoInfo info;
        gst_video_info_set_format(&info, GST_VIDEO_FORMAT_I420, 320, 180);
        GstVideoMetaTransform transform = {&info, &info};
        GstBuffer *other = gst_buffer_new();
        fail_if(meta->meta.info->transform_func(other, &meta->meta, buffer,
                                                g_quark_from_static_string("uavstab-test-rotate"), &transform));
        fail_unless(gst_buffer_get_uav_stab_meta(other) == nullptr);
        gst_buffer_unref(other);
    }
    gst_buffer_unref(buffer);
}

namespace {

struct ProbeLog {
    std::vector<GstBuffer *> buffers;
};

GstPadProbeReturn keepBuffer(GstPad *, GstPadProbeInfo *info, gpointer data)
{
    static_cast<ProbeLog *>(data)->buffers.push_back(gst_buffer_ref(GST_PAD_PROBE_INFO_BUFFER(info)));
    return GST_PAD_PROBE_OK;
}

// Runs `description` (ending in "fakesink name=sink") and returns what reached the sink.
ProbeLog runPipeline(const std::string &description)
{
    GstElement *pipeline = launchPipeline(description);
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), "sink");
    GstPad *pad = gst_element_get_static_pad(sink, "sink");
    ProbeLog log;
    gst_pad_add_probe(pad, GST_PAD_PROBE_TYPE_BUFFER, keepBuffer, &log, nullptr);
    gst_object_unref(pad);
    gst_object_unref(sink);
    fail_unless(gst_element_set_state(pipeline, GST_STATE_PLAYING) != GST_STATE_CHANGE_FAILURE);
    GstMessage *eos = waitForMessage(pipeline, GST_MESSAGE_EOS);
    gst_message_unref(eos);
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(pipeline);
    return log;
}

} // namespace

// In a pipeline: videoscale rescales the meta; videoflip (geometry) drops it.
ELEMENT_TEST(scalers_rescale_the_meta_and_flips_drop_it)
{
    const std::string source = "videotestsrc num-buffers=12 pattern=smpte ! video/x-raw,format=I420,width=160,height=120 "
                               "! uavstabilize threads=1 delay=2 ! ";
    ProbeLog scaled = runPipeline(source + "videoscale ! video/x-raw,width=320,height=180 ! fakesink name=sink");
    fail_unless_equals_int(int(scaled.buffers.size()), 12);
    for (GstBuffer *buffer : scaled.buffers) {
        const GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(buffer);
        fail_unless(meta != nullptr, "videoscale dropped the meta");
        fail_unless_equals_int(meta->width, 320);
        fail_unless_equals_int(meta->height, 180);
        fail_unless_equals_int(meta->frame_width, 160);
        // Near the centre still (scaled pixel centres: x' = (x + 0.5) * 2 - 0.5, y' = (y + 0.5) * 1.5 - 0.5).
        Point2 c;
        gst_uav_stab_meta_output_to_input(meta, 159.5, 89.5, &c.x, &c.y);
        fail_unless(std::abs(c.x - 159.5) < 40 && std::abs(c.y - 89.5) < 40);
        gst_buffer_unref(buffer);
    }
    ProbeLog flipped = runPipeline(source + "videoflip video-direction=90r ! fakesink name=sink");
    fail_unless_equals_int(int(flipped.buffers.size()), 12);
    for (GstBuffer *buffer : flipped.buffers) {
        fail_unless(gst_buffer_get_uav_stab_meta(buffer) == nullptr, "videoflip kept the meta");
        gst_buffer_unref(buffer);
    }
}

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *s = suite_create("uavstabilize-meta");
    TCase *tc = makeTestCase("meta", 300);
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, every_buffer_carries_the_meta_of_its_bus_message);
    tcase_add_test(tc, a_shared_input_gets_the_meta_without_a_pixel_copy);
    tcase_add_test(tc, regions_of_interest_follow_the_warp);
    tcase_add_test(tc, bypassed_frames_keep_their_boxes);
    tcase_add_test(tc, the_meta_is_copied_and_scaled);
    tcase_add_test(tc, scalers_rescale_the_meta_and_flips_drop_it);
    return runSuite(s) == 0 ? 0 : 1;
}
