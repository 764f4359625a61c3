#include "gst_frame_slot.hpp"

#include <stdexcept>

GST_DEBUG_CATEGORY_EXTERN(gst_uav_stabilize_debug);
#define GST_CAT_DEFAULT gst_uav_stabilize_debug

std::optional<uavstab::PixelFormat> pixelFormatFor(GstVideoFormat format)
{
    if (format == GST_VIDEO_FORMAT_UNKNOWN || format == GST_VIDEO_FORMAT_ENCODED)
        return std::nullopt;
    // The library spells formats the way GStreamer does.
    return uavstab::pixelFormatFromString(gst_video_format_to_string(format));
}

std::optional<uavstab::FrameView> frameViewOf(const GstVideoFrame &frame)
{
    const std::optional<uavstab::PixelFormat> format = pixelFormatFor(GST_VIDEO_FRAME_FORMAT(&frame));
    if (!format)
        return std::nullopt;
    uavstab::FrameView view;
    view.format = *format;
    view.width = GST_VIDEO_FRAME_WIDTH(&frame);
    view.height = GST_VIDEO_FRAME_HEIGHT(&frame);
    if (view.planeCount() != int(GST_VIDEO_FRAME_N_PLANES(&frame)))
        return std::nullopt;
    // Plane order is the same in both (YV12: Y, V, U; NV21: Y, VU), and strides may be
    // padded (video meta), so every plane is taken as GStreamer lays it out.
    for (int p = 0; p < view.planeCount(); ++p) {
        view.planes[p].data = static_cast<std::uint8_t *>(GST_VIDEO_FRAME_PLANE_DATA(&frame, p));
        view.planes[p].stride = GST_VIDEO_FRAME_PLANE_STRIDE(&frame, p);
    }
    if (!view.valid())
        return std::nullopt;
    return view;
}

namespace {

// gst_video_frame_map checks the buffer's size against the caps only for a buffer without
// a video meta. With one, it maps the memory that holds each plane's first byte and takes
// the meta's offsets and strides on trust: a short buffer with a meta would be read past
// its end. Every row of every plane must lie inside what was mapped.
bool planesInsideMappedMemory(const GstVideoFrame &frame, const uavstab::FrameView &view)
{
    if (!frame.meta)
        return true;
    for (int p = 0; p < view.planeCount(); ++p) {
        const GstMapInfo &map = frame.map[p];
        const std::uint8_t *data = view.planes[p].data;
        if (data < map.data || view.planes[p].stride <= 0)
            return false;
        const std::size_t end = std::size_t(data - map.data) +
                                std::size_t(view.planes[p].stride) * std::size_t(view.planeHeight(p) - 1) +
                                std::size_t(view.planeRowBytes(p));
        if (end > map.size)
            return false;
    }
    return true;
}

} // namespace

std::unique_ptr<GstFrameSlot> GstFrameSlot::map(GstBuffer *buffer, const GstVideoInfo &info,
                                                OutputBufferSource &outputs)
{
    std::unique_ptr<GstFrameSlot> slot(new GstFrameSlot(buffer, info, outputs));
    // gst_video_frame_map checks the buffer (or its video meta) against the caps, and
    // planesInsideMappedMemory what it does not, so a short buffer is refused here
    // instead of being read out of bounds later.
    GstVideoInfo caps_info = info;
    if (!gst_video_frame_map(&slot->input_frame_, &caps_info, buffer, GST_MAP_READ))
        return nullptr;
    slot->input_mapped_ = true;
    const std::optional<uavstab::FrameView> view = frameViewOf(slot->input_frame_);
    if (!view || !planesInsideMappedMemory(slot->input_frame_, *view))
        return nullptr;
    slot->input_view_ = *view;
    return slot;
}

GstFrameSlot::~GstFrameSlot()
{
    if (output_mapped_)
        gst_video_frame_unmap(&output_frame_);
    if (output_)
        gst_buffer_unref(output_);
    if (input_mapped_)
        gst_video_frame_unmap(&input_frame_);
    if (input_)
        gst_buffer_unref(input_);
}

std::optional<uavstab::FrameView> GstFrameSlot::acquireOutput()
{
    if (output_)
        throw std::logic_error("output acquired twice");
    if (outputs_.leavesFramesUnwarped()) {
        left_unwarped_ = true;
        return std::nullopt;
    }
    GstBuffer *buffer = outputs_.acquireOutputBuffer();
    if (!buffer)
        return std::nullopt;
    return adoptOutput(buffer);
}

uavstab::FrameView GstFrameSlot::adoptOutput(GstBuffer *buffer)
{
    if (output_) {
        gst_buffer_unref(buffer);
        throw std::logic_error("output acquired twice");
    }
    output_ = buffer;
    GstVideoInfo caps_info = caps_info_;
    if (!gst_video_frame_map(&output_frame_, &caps_info, output_, GST_MAP_WRITE))
        throw std::runtime_error("the output buffer cannot be mapped for writing");
    output_mapped_ = true;
    const std::optional<uavstab::FrameView> view = frameViewOf(output_frame_);
    if (!view)
        throw std::runtime_error("the output buffer does not hold a frame of the input's format");
    return *view;
}

GstBuffer *GstFrameSlot::releaseInput()
{
    if (input_mapped_) {
        gst_video_frame_unmap(&input_frame_);
        input_mapped_ = false;
    }
    GstBuffer *buffer = input_;
    input_ = nullptr;
    return buffer;
}

namespace {

// Metas that only describe content (no tags, or just "video"/"colorspace") stay true
// after a geometric transform; anything tied to memory, size or orientation does not.
// (Regions of interest are mapped through the warp instead, and an earlier
// GstUavStabMeta replaced: uavstab_meta.cpp, from the src pad task.)
gboolean copySafeMeta(GstBuffer *input, GstMeta **meta, gpointer user_data)
{
    auto *output = static_cast<GstBuffer *>(user_data);
    const GstMetaInfo *info = (*meta)->info;
    if (!info->transform_func || info->api == GST_VIDEO_META_API_TYPE)
        return TRUE;
    const gchar *const *tags = gst_meta_api_type_get_tags(info->api);
    static const GQuark video = g_quark_from_static_string(GST_META_TAG_VIDEO_STR);
    static const GQuark colorspace = g_quark_from_static_string(GST_META_TAG_VIDEO_COLORSPACE_STR);
    for (const gchar *const *tag = tags; tag && *tag; ++tag) {
        const GQuark quark = g_quark_from_string(*tag);
        if (quark != video && quark != colorspace)
            return TRUE;
    }
    GstMetaTransformCopy copy = {FALSE, 0, gsize(-1)};
    if (!info->transform_func(output, *meta, input, _gst_meta_transform_copy, &copy))
        GST_DEBUG("could not copy meta %s", g_type_name(info->api));
    return TRUE;
}

} // namespace

GstBuffer *GstFrameSlot::releaseOutput()
{
    if (!output_)
        return nullptr;
    if (output_mapped_) {
        gst_video_frame_unmap(&output_frame_);
        output_mapped_ = false;
    }
    GstBuffer *output = output_;
    output_ = nullptr;
    // Our reference is the only one now, so the buffer is writable.
    gst_buffer_copy_into(output, input_, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0,
                         gsize(-1));
    gst_buffer_foreach_meta(input_, copySafeMeta, output);
    return output;
}
