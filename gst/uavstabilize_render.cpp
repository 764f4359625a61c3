// Rendering decisions (render=auto|warp|affine-meta), the output negotiation they follow
// from, and the frames of affine-meta mode: their meta, or a warp after all.
#include "uavstabilize_render.hpp"

#include <array>
#include <utility>
#include <vector>

#include "output_pool.hpp"
#include "render/frame_warper.hpp"
#include "render/row_transforms.hpp"
#include "uavstab_meta.hpp"
#include "uavstabilize_element.hpp"

#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace gstuavstab {

namespace {

const char *renderName(RenderMode mode)
{
    switch (mode) {
    case RenderMode::Warp:
        return "warp";
    case RenderMode::AffineMeta:
        return "affine-meta";
    default:
        return "auto";
    }
}

} // namespace

void affineMetaMatrix(const uavstab::Similarity &output_to_input, int width, int height, float matrix[16])
{
    // Input pixel -> output pixel: p_out = A p_in + t.
    const std::array<double, 6> m = output_to_input.inverse().pixelMatrix(width, height);
    // In [0, 1] coordinates u = D (p + c), D = diag(1/width, 1/height), c = (0.5, 0.5):
    // u_out = D A D^-1 u_in + D (t + c - A c).
    const double w = width, h = height;
    for (int i = 0; i < 16; ++i)
        matrix[i] = 0.0f;
    matrix[0] = float(m[0]);          // column 0, row 0
    matrix[1] = float(m[3] * w / h);  // column 0, row 1
    matrix[4] = float(m[1] * h / w);  // column 1, row 0
    matrix[5] = float(m[4]);          // column 1, row 1
    matrix[10] = 1.0f;
    matrix[12] = float((m[2] + 0.5 - 0.5 * (m[0] + m[1])) / w);
    matrix[13] = float((m[5] + 0.5 - 0.5 * (m[3] + m[4])) / h);
    matrix[15] = 1.0f;
}

void addAffineTransformationMeta(GstBuffer *buffer, const uavstab::Similarity &output_to_input, int width, int height)
{
    float matrix[16];
    affineMetaMatrix(output_to_input, width, height, matrix);
    if (GstVideoAffineTransformationMeta *meta = gst_buffer_get_video_affine_transformation_meta(buffer)) {
        gst_video_affine_transformation_meta_apply_matrix(meta, matrix);
        return;
    }
    GstVideoAffineTransformationMeta *meta = gst_buffer_add_video_affine_transformation_meta(buffer);
    if (!meta) {
        GST_WARNING("cannot attach the affine transformation meta");
        return;
    }
    std::copy(matrix, matrix + 16, meta->matrix);
}

void decideRendering(GstUavStabilize *self, UavStabilizeState &s, bool negotiated)
{
    GST_OBJECT_LOCK(self);
    const RenderMode mode = self->settings->render;
    const bool overlay = self->settings->stabilizer.debug_overlay;
    const bool lens = !self->settings->stabilizer.lens_profile.empty();
    GST_OBJECT_UNLOCK(self);
    const bool downstream_applies = s.downstream_applies_affine_meta.load();
    // The overlay is drawn into the warped frame, so auto warps while it is on. A lens maps
    // the picture through a mesh, which one affine transform cannot carry: always warped.
    const bool affine =
        !lens && (mode == RenderMode::AffineMeta || (mode == RenderMode::Auto && downstream_applies && !overlay));
    if (lens && mode == RenderMode::AffineMeta && negotiated)
        GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("render=affine-meta cannot carry a lens profile's warp"),
                            ("frames are warped on the CPU instead"));
    s.render_mode.store(int(mode));
    const bool changed = s.render_affine_meta.exchange(affine) != affine;
    if (negotiated || changed)
        GST_INFO_OBJECT(self, "render=%s: %s (downstream %s GstVideoAffineTransformationMeta%s)", renderName(mode),
                        affine ? "frames go out unwarped with an affine meta" : "frames are warped",
                        downstream_applies ? "applies" : "does not list",
                        overlay && mode == RenderMode::Auto ? "; debug-overlay needs the warp" : "");
}

void negotiateOutput(GstUavStabilize *self, UavStabilizeState &s, GstCaps *caps, const GstVideoInfo &info)
{
    GST_OBJECT_LOCK(self);
    // render=affine-meta never warps (no output buffers at all), unless a lens makes it.
    const bool want_pool =
        self->settings->render != RenderMode::AffineMeta || !self->settings->stabilizer.lens_profile.empty();
    GST_OBJECT_UNLOCK(self);
    const OutputAllocation allocation = negotiateOutputAllocation(self->srcpad, caps, info, want_pool);
    s.output.replacePool(allocation.pool);
    s.downstream_applies_affine_meta.store(allocation.applies_affine_meta);
    decideRendering(self, s, true);
}

void renegotiateOutput(GstUavStabilize *self, UavStabilizeState &s)
{
    GstCaps *caps = gst_pad_get_current_caps(self->srcpad);
    if (!caps)
        return;
    GstVideoInfo info;
    if (gst_video_info_from_caps(&info, caps)) {
        GST_DEBUG_OBJECT(self, "downstream asked to reconfigure: asking for its allocation again");
        negotiateOutput(self, s, caps, info);
    }
    gst_caps_unref(caps);
}

bool warpsLeftUnwarpedFrame(const UavStabilizeState &s, const uavstab::StabilizedFrame &frame)
{
    // A wobble needs a transform per row, which one affine meta cannot carry.
    return RenderMode(s.render_mode.load()) == RenderMode::Auto && !frame.stats.row_motion.empty();
}

GstBuffer *warpLeftUnwarpedFrame(GstUavStabilize *self, UavStabilizeState &s, uavstab::StabilizedFrame &frame)
{
    auto &slot = static_cast<GstFrameSlot &>(*frame.slot);
    GstBuffer *buffer = s.output.acquireBuffer();
    if (!buffer)
        return nullptr;
    GST_OBJECT_LOCK(self);
    const uavstab::BorderMode border = self->settings->stabilizer.border;
    GST_OBJECT_UNLOCK(self);
    const uavstab::FrameView in = slot.input();
    const uavstab::FrameView out = slot.adoptOutput(buffer);
    uavstab::FrameWarper(border).warp(
        in, out, uavstab::rollingShutterWarp(frame.stats.output_to_input, frame.stats.row_motion, in.width, in.height));
    GstBuffer *warped = slot.releaseOutput();
    mapRegionsOfInterest(slot.inputBuffer(), warped, frame.stats.output_to_input, in.width, in.height);
    return warped;
}

} // namespace gstuavstab
