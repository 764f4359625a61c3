#include "frame_statistics.hpp"

#include <string>

namespace gstuavstab {

namespace {

void setSimilarity(GstStructure *structure, const char *prefix, const uavstab::Similarity &s)
{
    const std::string p(prefix);
    gst_structure_set(structure, (p + "-dx").c_str(), G_TYPE_DOUBLE, s.dx, (p + "-dy").c_str(), G_TYPE_DOUBLE, s.dy,
                      (p + "-angle").c_str(), G_TYPE_DOUBLE, s.angle, (p + "-scale").c_str(), G_TYPE_DOUBLE, s.scale,
                      nullptr);
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
    case GST_UAV_STAB_OUTCOME_AFFINE_META:
        return "affine-meta";
    default:
        return "failed";
    }
}

} // namespace

GstStructure *frameStatistics(const uavstab::StabilizedFrame &frame, GstUavStabOutcome outcome, GstClockTime pts,
                              const GstSegment &segment)
{
    const uavstab::FrameStats &stats = frame.stats;
    GstStructure *structure = gst_structure_new(
        "uavstabilize", "timestamp", G_TYPE_UINT64, guint64(pts), "index", G_TYPE_INT64, gint64(stats.index), "zoom",
        G_TYPE_DOUBLE, stats.zoom, "correction-fraction", G_TYPE_DOUBLE, stats.correction_fraction, "model",
        G_TYPE_STRING, uavstab::toString(stats.model), "points", G_TYPE_INT, stats.points, "inliers", G_TYPE_INT,
        stats.inliers, "skipped", G_TYPE_BOOLEAN, gboolean(stats.skipped), "segment-start", G_TYPE_BOOLEAN,
        gboolean(stats.segment_start), "outcome", G_TYPE_STRING, outcomeName(outcome), "wobble", G_TYPE_DOUBLE,
        stats.row_motion.wobble, "rolling-shutter", G_TYPE_BOOLEAN,
        gboolean(outcome == GST_UAV_STAB_OUTCOME_WARPED && !stats.row_motion.empty()), "readout", G_TYPE_DOUBLE,
        stats.readout, "readout-confidence", G_TYPE_DOUBLE, stats.readout_confidence, nullptr);
    if (GST_CLOCK_TIME_IS_VALID(pts) && segment.format == GST_FORMAT_TIME) {
        const guint64 running_time = gst_segment_to_running_time(&segment, GST_FORMAT_TIME, pts);
        const guint64 stream_time = gst_segment_to_stream_time(&segment, GST_FORMAT_TIME, pts);
        if (GST_CLOCK_TIME_IS_VALID(running_time))
            gst_structure_set(structure, "running-time", G_TYPE_UINT64, running_time, nullptr);
        if (GST_CLOCK_TIME_IS_VALID(stream_time))
            gst_structure_set(structure, "stream-time", G_TYPE_UINT64, stream_time, nullptr);
    }
    setSimilarity(structure, "motion", stats.motion);
    setSimilarity(structure, "trajectory", stats.trajectory);
    setSimilarity(structure, "smoothed", stats.smoothed);
    setSimilarity(structure, "correction", stats.correction);
    return structure;
}

} // namespace gstuavstab
