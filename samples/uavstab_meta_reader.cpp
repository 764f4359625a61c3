// Reads the GstUavStabMeta that uavstabilize attaches to every buffer it pushes, with a pad
// probe on the element's src pad, and prints one line per frame plus its 3x3 mapping.
//
//   uavstab-meta-reader                    a built-in synthetic shaky flight (appsrc)
//   uavstab-meta-reader 'PIPELINE'         any pipeline with a uavstabilize in it
//
// Example:
//   GST_PLUGIN_PATH=build/gst build/samples/uavstab-meta-reader
//       'filesrc location=flight.mp4 ! decodebin ! videoconvert ! uavstabilize ! fakesink'
//   (one command line)
//
// The only thing an application needs is the header gst/uavstab_meta.h (header-only: it
// finds the meta by name once the plugin is loaded).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include <gst/gst.h>
#include <gst/video/video.h>

#include "shaky_flight.hpp"
#include "uavstab_meta.h"

namespace {

const char *outcomeName(GstUavStabOutcome outcome)
{
    switch (outcome) {
    case GST_UAV_STAB_OUTCOME_WARPED:
        return "warped";
    case GST_UAV_STAB_OUTCOME_BYPASSED:
        return "bypassed";
    case GST_UAV_STAB_OUTCOME_PASSED_THROUGH:
        return "passed-through";
    case GST_UAV_STAB_OUTCOME_FAILED:
        return "failed";
    case GST_UAV_STAB_OUTCOME_AFFINE_META:
        return "affine-meta";
    }
    return "?";
}

GstPadProbeReturn printMeta(GstPad *, GstPadProbeInfo *info, gpointer)
{
    GstBuffer *buffer = GST_PAD_PROBE_INFO_BUFFER(info);
    const GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(buffer);
    if (!meta) {
        std::printf("%" GST_TIME_FORMAT "  no meta\n", GST_TIME_ARGS(GST_BUFFER_PTS(buffer)));
        return GST_PAD_PROBE_OK;
    }
    const double *m = meta->output_to_input;
    // Where the input frame's centre ends up in the output (header helper).
    double cx = 0, cy = 0;
    gst_uav_stab_meta_input_to_output(meta, (meta->width - 1) * 0.5, (meta->height - 1) * 0.5, &cx, &cy);
    std::printf("%" GST_TIME_FORMAT " #%-4" G_GINT64_FORMAT " %-8s correction %+7.2f %+7.2f px %+6.3f deg  zoom %.4f  "
                "%-10s %2d/%2d points%s%s  input centre -> (%.1f, %.1f)\n",
                GST_TIME_ARGS(GST_BUFFER_PTS(buffer)), meta->index, outcomeName(meta->outcome), meta->correction.dx,
                meta->correction.dy, meta->correction.angle * 180.0 / G_PI, meta->zoom,
                meta->model == GST_UAV_STAB_MODEL_SIMILARITY ? "similarity" : "rigid", meta->inliers, meta->points,
                meta->skipped ? "  skipped" : "", meta->segment_start ? "  segment-start" : "", cx, cy);
    std::printf("      output->input (%dx%d px): [%9.5f %9.5f %9.3f; %9.5f %9.5f %9.3f; %g %g %g]\n", meta->width,
                meta->height, m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8]);
    return GST_PAD_PROBE_OK;
}

GstElement *findStabilizer(GstElement *pipeline)
{
    GstElement *found = nullptr;
    GstIterator *it = gst_bin_iterate_recurse(GST_BIN(pipeline));
    GValue item = G_VALUE_INIT;
    while (!found && gst_iterator_next(it, &item) == GST_ITERATOR_OK) {
        GstElement *e = GST_ELEMENT(g_value_get_object(&item));
        GstElementFactory *f = gst_element_get_factory(e);
        if (f && !std::strcmp(GST_OBJECT_NAME(f), "uavstabilize"))
            found = GST_ELEMENT(gst_object_ref(e));
        g_value_reset(&item);
    }
    g_value_unset(&item);
    gst_iterator_free(it);
    return found;
}

// The default source: a synthetic shaky flight (tests/synthetic), 640x360 I420, pushed
// into appsrc up front (through its action signals: no libgstapp needed).
void feedFlight(GstElement *appsrc, int frames)
{
    uavstab::synthetic::FlightOptions options;
    options.width = 640;
    options.height = 360;
    options.frames = frames;
    const uavstab::synthetic::ShakyFlight flight(options);
    GstVideoInfo info;
    gst_video_info_set_format(&info, GST_VIDEO_FORMAT_I420, guint(options.width), guint(options.height));
    info.fps_n = 30;
    info.fps_d = 1;
    GstCaps *caps = gst_video_info_to_caps(&info);
    g_object_set(appsrc, "caps", caps, "format", GST_FORMAT_TIME, "max-bytes", guint64(0), nullptr);
    gst_caps_unref(caps);
    for (int i = 0; i < frames; ++i) {
        const uavstab::FrameBuffer frame = flight.render(i);
        GstBuffer *buffer = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&info), nullptr);
        GstVideoFrame out;
        if (!gst_video_frame_map(&out, &info, buffer, GST_MAP_WRITE)) {
            gst_buffer_unref(buffer);
            break;
        }
        const uavstab::FrameView view = frame.view();
        for (guint p = 0; p < GST_VIDEO_FRAME_N_PLANES(&out); ++p) {
            const int rows = GST_VIDEO_FRAME_COMP_HEIGHT(&out, p), bytes = GST_VIDEO_FRAME_COMP_WIDTH(&out, p);
            auto *dst = static_cast<guint8 *>(GST_VIDEO_FRAME_PLANE_DATA(&out, p));
            for (int y = 0; y < rows; ++y)
                std::memcpy(dst + y * GST_VIDEO_FRAME_PLANE_STRIDE(&out, p),
                            view.planes[p].data + std::ptrdiff_t(y) * view.planes[p].stride, std::size_t(bytes));
        }
        gst_video_frame_unmap(&out);
        GST_BUFFER_PTS(buffer) = gst_util_uint64_scale_int(GST_SECOND, i, 30);
        GST_BUFFER_DURATION(buffer) = gst_util_uint64_scale_int(GST_SECOND, 1, 30);
        GstFlowReturn ret = GST_FLOW_OK;
        g_signal_emit_by_name(appsrc, "push-buffer", buffer, &ret);
        gst_buffer_unref(buffer);  // the signal takes its own reference
    }
    GstFlowReturn ret = GST_FLOW_OK;
    g_signal_emit_by_name(appsrc, "end-of-stream", &ret);
}

} // namespace

int main(int argc, char **argv)
{
    gst_init(&argc, &argv);
    std::string description;
    for (int i = 1; i < argc; ++i)
        description += std::string(description.empty() ? "" : " ") + argv[i];
    const bool synthetic = description.empty();
    if (synthetic)
        description = "appsrc name=flight ! uavstabilize ! fakesink";

    GError *error = nullptr;
    GstElement *pipeline = gst_parse_launch(description.c_str(), &error);
    if (!pipeline) {
        std::fprintf(stderr, "uavstab-meta-reader: %s\n", error ? error->message : "cannot build the pipeline");
        g_clear_error(&error);
        return 2;
    }
    g_clear_error(&error);
    GstElement *stabilizer = findStabilizer(pipeline);
    if (!stabilizer) {
        std::fprintf(stderr, "uavstab-meta-reader: the pipeline has no uavstabilize element\n");
        gst_object_unref(pipeline);
        return 2;
    }
    GstPad *src = gst_element_get_static_pad(stabilizer, "src");
    gst_pad_add_probe(src, GST_PAD_PROBE_TYPE_BUFFER, printMeta, nullptr, nullptr);
    gst_object_unref(src);
    gst_object_unref(stabilizer);
    if (synthetic) {
        GstElement *appsrc = gst_bin_get_by_name(GST_BIN(pipeline), "flight");
        feedFlight(appsrc, 90);
        gst_object_unref(appsrc);
    }

    int status = 0;
    GstBus *bus = gst_element_get_bus(pipeline);
    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    GstMessage *msg = gst_bus_timed_pop_filtered(bus, GST_CLOCK_TIME_NONE,
                                                 GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
        GError *err = nullptr;
        gchar *debug = nullptr;
        gst_message_parse_error(msg, &err, &debug);
        std::fprintf(stderr, "uavstab-meta-reader: error from %s: %s\n%s\n", GST_OBJECT_NAME(GST_MESSAGE_SRC(msg)),
                     err->message, debug ? debug : "");
        g_clear_error(&err);
        g_free(debug);
        status = 1;
    }
    gst_message_unref(msg);
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(bus);
    gst_object_unref(pipeline);
    return status;
}
