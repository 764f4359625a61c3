#include "uavstab_meta.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include <gst/video/video.h>

GST_DEBUG_CATEGORY_EXTERN(gst_uav_stabilize_debug);
#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace gstuavstab {

namespace {

void setIdentity(double m[9])
{
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    std::memcpy(m, identity, sizeof identity);
}

gboolean initMeta(GstMeta *meta, gpointer, GstBuffer *)
{
    auto *m = reinterpret_cast<GstUavStabMeta *>(meta);
    // Everything after the GstMeta header: a plain C struct, zero is a valid start.
    std::memset(reinterpret_cast<char *>(m) + sizeof(GstMeta), 0, sizeof(GstUavStabMeta) - sizeof(GstMeta));
    m->version = GST_UAV_STAB_META_VERSION;
    m->motion.scale = m->trajectory.scale = m->smoothed.scale = m->correction.scale = 1.0;
    m->zoom = 1.0;
    m->correction_fraction = 1.0;
    setIdentity(m->output_to_input);
    return TRUE;
}

void copyFields(GstUavStabMeta *to, const GstUavStabMeta *from)
{
    std::memcpy(reinterpret_cast<char *>(to) + sizeof(GstMeta), reinterpret_cast<const char *>(from) + sizeof(GstMeta),
                sizeof(GstUavStabMeta) - sizeof(GstMeta));
}

// 3x3 row-major product a * b.
std::array<double, 9> multiply(const double a[9], const double b[9])
{
    std::array<double, 9> r{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            r[i * 3 + j] = a[i * 3] * b[j] + a[i * 3 + 1] * b[3 + j] + a[i * 3 + 2] * b[6 + j];
    return r;
}

// The mapping of a frame scaled by (sx, sy): pixel edges scale, so pixel centres map as
// x' = (x + 0.5) sx - 0.5. Both ends of output_to_input are in the same frame, so
// M' = S M S^-1.
void rescale(GstUavStabMeta *meta, int width, int height)
{
    const double sx = double(width) / meta->width, sy = double(height) / meta->height;
    const double s[9] = {sx, 0, 0.5 * sx - 0.5, 0, sy, 0.5 * sy - 0.5, 0, 0, 1};
    const double s_inv[9] = {1 / sx, 0, 0.5 / sx - 0.5, 0, 1 / sy, 0.5 / sy - 0.5, 0, 0, 1};
    const std::array<double, 9> ms = multiply(meta->output_to_input, s_inv);
    const std::array<double, 9> result = multiply(s, ms.data());
    std::copy(result.begin(), result.end(), meta->output_to_input);
    meta->width = width;
    meta->height = height;
}

GstUavStabMeta *addMeta(GstBuffer *buffer)
{
    return reinterpret_cast<GstUavStabMeta *>(gst_buffer_add_meta(buffer, registerStabMeta(), nullptr));
}

// Copy: as is. Scale (videoscale): the matrix follows the new size. Anything else that
// changes geometry: dropped.
gboolean transformMeta(GstBuffer *dest, GstMeta *meta, GstBuffer *, GQuark type, gpointer data)
{
    const auto *from = reinterpret_cast<const GstUavStabMeta *>(meta);
    if (GST_META_TRANSFORM_IS_COPY(type)) {
        GstUavStabMeta *to = addMeta(dest);
        if (!to)
            return FALSE;
        copyFields(to, from);
        return TRUE;
    }
    if (GST_VIDEO_META_TRANSFORM_IS_SCALE(type)) {
        const auto *transform = static_cast<const GstVideoMetaTransform *>(data);
        if (!transform || !transform->in_info || !transform->out_info)
            return FALSE;
        const int in_width = GST_VIDEO_INFO_WIDTH(transform->in_info);
        const int in_height = GST_VIDEO_INFO_HEIGHT(transform->in_info);
        const int out_width = GST_VIDEO_INFO_WIDTH(transform->out_info);
        const int out_height = GST_VIDEO_INFO_HEIGHT(transform->out_info);
        if (in_width <= 0 || in_height <= 0 || out_width <= 0 || out_height <= 0 || from->width <= 0 ||
            from->height <= 0)
            return FALSE;
        GstUavStabMeta *to = addMeta(dest);
        if (!to)
            return FALSE;
        copyFields(to, from);
        // The scaler's input is the frame the meta describes, normally of the same size;
        // if not, its ratio is what scales.
        if (in_width != from->width || in_height != from->height)
            GST_DEBUG("meta describes %dx%d, scaler input is %dx%d", from->width, from->height, in_width, in_height);
        rescale(to, int(std::lround(double(from->width) * out_width / in_width)),
                int(std::lround(double(from->height) * out_height / in_height)));
        return TRUE;
    }
    return FALSE;
}

GstUavStabTransform transformOf(const uavstab::Similarity &s)
{
    return {s.dx, s.dy, s.angle, s.scale};
}

gboolean removeStabMeta(GstBuffer *, GstMeta **meta, gpointer)
{
    if ((*meta)->info->api == GST_UAV_STAB_META_API_TYPE)
        *meta = nullptr;  // removes it
    return TRUE;
}

} // namespace

const GstMetaInfo *registerStabMeta()
{
    static const GstMetaInfo *info = [] {
        static const gchar *tags[] = {GST_META_TAG_VIDEO_STR, GST_META_TAG_VIDEO_ORIENTATION_STR,
                                      GST_META_TAG_VIDEO_SIZE_STR, nullptr};
        const GType api = gst_meta_api_type_register(GST_UAV_STAB_META_API_NAME, tags);
        return gst_meta_register(api, GST_UAV_STAB_META_IMPL_NAME, sizeof(GstUavStabMeta), initMeta, nullptr,
                                 transformMeta);
    }();
    return info;
}

void pixelMatrix3x3(const uavstab::Similarity &s, int width, int height, double m[9])
{
    const std::array<double, 6> a = s.pixelMatrix(width, height);
    std::copy(a.begin(), a.end(), m);
    m[6] = 0;
    m[7] = 0;
    m[8] = 1;
}

GstUavStabOutcome outcomeOf(const uavstab::StabilizedFrame &frame, bool warped, bool affine_meta)
{
    if (warped)
        return GST_UAV_STAB_OUTCOME_WARPED;
    if (affine_meta)
        return GST_UAV_STAB_OUTCOME_AFFINE_META;
    switch (frame.outcome) {
    case uavstab::Outcome::Bypassed:
        return GST_UAV_STAB_OUTCOME_BYPASSED;
    case uavstab::Outcome::Failed:
        return GST_UAV_STAB_OUTCOME_FAILED;
    default:  // no output buffer (or, oddly, a warp with no buffer): the input, uncorrected
        return GST_UAV_STAB_OUTCOME_PASSED_THROUGH;
    }
}

GstBuffer *attachStabMeta(GstBuffer *buffer, const uavstab::StabilizedFrame &frame, int width, int height,
                          GstUavStabOutcome outcome)
{
    // An input that goes out again may still be referenced upstream (a tee, an
    // application): then this is a new GstBuffer over the same memory.
    buffer = gst_buffer_make_writable(buffer);
    gst_buffer_foreach_meta(buffer, removeStabMeta, nullptr);
    GstUavStabMeta *meta = addMeta(buffer);
    if (!meta) {
        GST_WARNING("cannot attach the stabilization meta");
        return buffer;
    }
    const uavstab::FrameStats &stats = frame.stats;
    meta->index = stats.index;
    meta->frame_width = width;
    meta->frame_height = height;
    meta->motion = transformOf(stats.motion);
    meta->trajectory = transformOf(stats.trajectory);
    meta->smoothed = transformOf(stats.smoothed);
    meta->correction = transformOf(stats.correction);
    meta->zoom = stats.zoom;
    meta->correction_fraction = stats.correction_fraction;
    meta->model = stats.model == uavstab::MotionModel::Similarity ? GST_UAV_STAB_MODEL_SIMILARITY
                                                                  : GST_UAV_STAB_MODEL_RIGID;
    meta->points = stats.points;
    meta->inliers = stats.inliers;
    meta->skipped = stats.skipped;
    meta->segment_start = stats.segment_start;
    meta->outcome = outcome;
    meta->width = width;
    meta->height = height;
    // An affine meta carries one transform: a wobble is not corrected that way.
    meta->wobble = outcome == GST_UAV_STAB_OUTCOME_WARPED ? stats.row_motion.wobble : 0.0;
    meta->rolling_shutter = outcome == GST_UAV_STAB_OUTCOME_WARPED && !stats.row_motion.empty();
    meta->readout = stats.readout;
    meta->readout_confidence = stats.readout_confidence;
    if (outcome == GST_UAV_STAB_OUTCOME_WARPED || outcome == GST_UAV_STAB_OUTCOME_AFFINE_META)
        pixelMatrix3x3(stats.output_to_input, width, height, meta->output_to_input);
    else
        setIdentity(meta->output_to_input);
    return buffer;
}

void mapRegionsOfInterest(GstBuffer *input, GstBuffer *output, const uavstab::Similarity &output_to_input, int width,
                          int height)
{
    const std::array<double, 6> m = output_to_input.inverse().pixelMatrix(width, height);
    gpointer state = nullptr;
    while (GstMeta *meta = gst_buffer_iterate_meta_filtered(input, &state, GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE)) {
        const auto *roi = reinterpret_cast<const GstVideoRegionOfInterestMeta *>(meta);
        // Box edges (top-left-corner coordinates) -> pixel centres (-0.5), through the
        // transform, and back (+0.5).
        const double x0 = double(roi->x) - 0.5, y0 = double(roi->y) - 0.5;
        const double x1 = x0 + roi->w, y1 = y0 + roi->h;
        double min_x = HUGE_VAL, min_y = HUGE_VAL, max_x = -HUGE_VAL, max_y = -HUGE_VAL;
        for (const auto &[x, y] : {std::pair{x0, y0}, {x1, y0}, {x0, y1}, {x1, y1}}) {
            const double ox = m[0] * x + m[1] * y + m[2] + 0.5, oy = m[3] * x + m[4] * y + m[5] + 0.5;
            min_x = std::min(min_x, ox);
            max_x = std::max(max_x, ox);
            min_y = std::min(min_y, oy);
            max_y = std::max(max_y, oy);
        }
        const long left = std::lround(std::clamp(min_x, 0.0, double(width)));
        const long right = std::lround(std::clamp(max_x, 0.0, double(width)));
        const long top = std::lround(std::clamp(min_y, 0.0, double(height)));
        const long bottom = std::lround(std::clamp(max_y, 0.0, double(height)));
        if (right <= left || bottom <= top) {
            GST_LOG("region of interest %s %u,%u %ux%u is outside the output: dropped", g_quark_to_string(roi->roi_type),
                    roi->x, roi->y, roi->w, roi->h);
            continue;
        }
        GstVideoRegionOfInterestMeta *mapped = gst_buffer_add_video_region_of_interest_meta_id(
            output, roi->roi_type, guint(left), guint(top), guint(right - left), guint(bottom - top));
        if (!mapped)
            continue;
        mapped->id = roi->id;
        mapped->parent_id = roi->parent_id;
        for (const GList *param = roi->params; param; param = param->next)
            gst_video_region_of_interest_meta_add_param(
                mapped, gst_structure_copy(static_cast<const GstStructure *>(param->data)));
    }
}

} // namespace gstuavstab
