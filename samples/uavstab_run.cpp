// Runs a GStreamer pipeline that contains uavstabilize, prints the per-frame statistics
// the element posts on the bus, and a summary of how much shake was removed.
//
//   uavstab-run [--frames] [--truth TRUTH.csv] 'PIPELINE DESCRIPTION'
//
// --frames   one line per frame: timestamp, estimated motion, correction, model, points
// --truth    the true camera path (from uavstab-render-flight): report the true residual
//            jitter of input and output; without it, the stabilizer's own estimate is used
//
// Example:
//   uavstab-run --frames 'filesrc location=shaky.y4m ! y4mdec ! uavstabilize ! fakesink'
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gst/gst.h>

#include "jitter_metrics.hpp"
#include "truth_csv.hpp"

using uavstab::Similarity;

namespace {

Similarity readSimilarity(const GstStructure *s, const char *prefix)
{
    Similarity m;
    const std::string p(prefix);
    gst_structure_get_double(s, (p + "-dx").c_str(), &m.dx);
    gst_structure_get_double(s, (p + "-dy").c_str(), &m.dy);
    gst_structure_get_double(s, (p + "-angle").c_str(), &m.angle);
    gst_structure_get_double(s, (p + "-scale").c_str(), &m.scale);
    return m;
}


struct FrameRecord {
    Similarity trajectory, correction;
    double zoom = 1.0;
    bool skipped = false, segment_start = false;
};

// Residual jitter over the recorded frames, per segment of the camera path (a segment
// restarts at identity), combined as an RMS over all frames.
double jitterOf(const std::vector<Similarity> &path, const std::vector<FrameRecord> &frames, int w, int h)
{
    double sum2 = 0;
    std::size_t n = 0, begin = 0;
    for (std::size_t i = 1; i <= path.size(); ++i) {
        if (i == path.size() || frames[i].segment_start) {
            const std::vector<Similarity> part(path.begin() + long(begin), path.begin() + long(i));
            const double j = uavstab::synthetic::residualJitter(part, w, h);
            sum2 += j * j * double(part.size());
            n += part.size();
            begin = i;
        }
    }
    return n ? std::sqrt(sum2 / double(n)) : 0.0;
}

} // namespace

int main(int argc, char **argv)
{
    gst_init(&argc, &argv);
    bool print_frames = false;
    std::string truth_path, description;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--frames"))
            print_frames = true;
        else if (!std::strcmp(argv[i], "--truth") && i + 1 < argc)
            truth_path = argv[++i];
        else
            description += std::string(description.empty() ? "" : " ") + argv[i];
    }
    if (description.empty()) {
        std::fprintf(stderr, "usage: uavstab-run [--frames] [--truth TRUTH.csv] 'PIPELINE'\n");
        return 2;
    }

    GError *error = nullptr;
    GstElement *pipeline = gst_parse_launch(description.c_str(), &error);
    if (!pipeline) {
        std::fprintf(stderr, "uavstab-run: %s\n", error ? error->message : "cannot build the pipeline");
        g_clear_error(&error);
        return 2;
    }
    // Ask every uavstabilize in the pipeline for its statistics.
    int width = 0, height = 0;
    GstIterator *it = gst_bin_iterate_recurse(GST_BIN(pipeline));
    GValue item = G_VALUE_INIT;
    std::vector<GstElement *> stabilizers;
    while (gst_iterator_next(it, &item) == GST_ITERATOR_OK) {
        GstElement *e = GST_ELEMENT(g_value_get_object(&item));
        GstElementFactory *f = gst_element_get_factory(e);
        if (f && !std::strcmp(GST_OBJECT_NAME(f), "uavstabilize")) {
            g_object_set(e, "post-messages", TRUE, nullptr);
            stabilizers.push_back(e);
        }
        g_value_reset(&item);
    }
    g_value_unset(&item);
    gst_iterator_free(it);
    if (stabilizers.empty()) {
        std::fprintf(stderr, "uavstab-run: the pipeline has no uavstabilize element\n");
        gst_object_unref(pipeline);
        return 2;
    }

    std::vector<FrameRecord> frames;
    int status = 0;
    GstBus *bus = gst_element_get_bus(pipeline);
    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    for (bool done = false; !done;) {
        GstMessage *msg = gst_bus_timed_pop(bus, GST_CLOCK_TIME_NONE);
        switch (GST_MESSAGE_TYPE(msg)) {
        case GST_MESSAGE_ELEMENT: {
            const GstStructure *s = gst_message_get_structure(msg);
            if (!gst_structure_has_name(s, "uavstabilize") || GST_MESSAGE_SRC(msg) != GST_OBJECT(stabilizers[0]))
                break;
            FrameRecord r;
            r.trajectory = readSimilarity(s, "trajectory");
            r.correction = readSimilarity(s, "correction");
            gst_structure_get_double(s, "zoom", &r.zoom);
            gboolean b = FALSE;
            gst_structure_get_boolean(s, "skipped", &b);
            r.skipped = b;
            gst_structure_get_boolean(s, "segment-start", &b);
            r.segment_start = b || frames.empty();
            if (print_frames) {
                guint64 pts = 0;
                gst_structure_get_uint64(s, "timestamp", &pts);
                const Similarity motion = readSimilarity(s, "motion");
                const char *model = gst_structure_get_string(s, "model");
                int points = 0;
                gst_structure_get_int(s, "points", &points);
                std::printf("%6zu %" GST_TIME_FORMAT " motion %+7.2f %+7.2f %+7.4f x%.4f  correction %+7.2f %+7.2f "
                            "%+7.4f  %-10s %3d points%s\n",
                            frames.size(), GST_TIME_ARGS(pts), motion.dx, motion.dy, motion.angle, motion.scale,
                            r.correction.dx, r.correction.dy, r.correction.angle, model ? model : "?", points,
                            r.skipped ? "  skipped" : "");
            }
            frames.push_back(r);
            break;
        }
        case GST_MESSAGE_STREAM_START:
        case GST_MESSAGE_ASYNC_DONE: {
            if (width == 0) {
                GstPad *pad = gst_element_get_static_pad(stabilizers[0], "src");
                if (GstCaps *caps = gst_pad_get_current_caps(pad)) {
                    GstStructure *st = gst_caps_get_structure(caps, 0);
                    gst_structure_get_int(st, "width", &width);
                    gst_structure_get_int(st, "height", &height);
                    gst_caps_unref(caps);
                }
                gst_object_unref(pad);
            }
            break;
        }
        case GST_MESSAGE_ERROR: {
            GError *err = nullptr;
            gchar *debug = nullptr;
            gst_message_parse_error(msg, &err, &debug);
            std::fprintf(stderr, "uavstab-run: error from %s: %s\n%s\n", GST_OBJECT_NAME(GST_MESSAGE_SRC(msg)),
                         err->message, debug ? debug : "");
            g_clear_error(&err);
            g_free(debug);
            status = 1;
            done = true;
            break;
        }
        case GST_MESSAGE_WARNING: {
            GError *err = nullptr;
            gst_message_parse_warning(msg, &err, nullptr);
            std::fprintf(stderr, "uavstab-run: warning from %s: %s\n", GST_OBJECT_NAME(GST_MESSAGE_SRC(msg)),
                         err->message);
            g_clear_error(&err);
            break;
        }
        case GST_MESSAGE_EOS:
            done = true;
            break;
        default:
            break;
        }
        gst_message_unref(msg);
    }
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(bus);
    gst_object_unref(pipeline);
    if (status != 0)
        return status;

    std::size_t skipped = 0;
    for (const auto &f : frames)
        skipped += f.skipped;
    std::printf("%zu frames stabilized (%zu without usable motion)\n", frames.size(), skipped);
    if (frames.size() < 3 || width == 0)
        return 0;
    std::vector<Similarity> in, out;
    const std::vector<Similarity> truth = truth_path.empty() ? std::vector<Similarity>{} : uavstab::synthetic::readTruthCsv(truth_path);
    const bool have_truth = truth.size() >= frames.size();
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const Similarity pose = have_truth ? truth[i] : frames[i].trajectory;
        uavstab::FrameStats stats;
        stats.correction = frames[i].correction;
        stats.zoom = frames[i].zoom;
        in.push_back(pose);
        out.push_back(pose * uavstab::synthetic::outputToInput(stats));
    }
    const double a = jitterOf(in, frames, width, height), b = jitterOf(out, frames, width, height);
    std::printf("%s residual jitter: input %.2f px, output %.2f px: %.0f %% of the shake removed\n",
                have_truth ? "true" : "estimated", a, b, a > 0 ? 100.0 * (1.0 - b / a) : 0.0);
    return 0;
}
