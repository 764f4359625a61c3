/* GstUavStabMeta: what uavstabilize did to a frame, attached to every buffer it pushes.
 *
 * A public, header-only C API: include this file (C or C++) and read the meta from any
 * buffer downstream of uavstabilize (pad probe, appsink, your own element). Nothing to
 * link but GStreamer: the meta is registered by the uavstabilize plugin when it loads,
 * and these inline functions find it by name, so they return NULL / 0 until the plugin
 * is loaded (it is once a uavstabilize element exists).
 *
 *   GstUavStabMeta *meta = gst_buffer_get_uav_stab_meta(buffer);
 *   if (meta && meta->outcome == GST_UAV_STAB_OUTCOME_WARPED) { ... }
 *
 * Coordinates
 * -----------
 * The 3x3 matrix `output_to_input` is in PIXEL coordinates of a `width` x `height` frame
 * (not the centred coordinates of the GstUavStabTransform fields): integer coordinates
 * are pixel centres, so pixel column x covers [x - 0.5, x + 0.5] (OpenCV's convention:
 * the matrix can be given to cv::warpAffine / cv::warpPerspective with
 * WARP_INVERSE_MAP). For top-left-corner coordinates, such as a
 * GstVideoRegionOfInterestMeta box's edges, subtract 0.5 before mapping and add 0.5
 * after. Row-major; the last row is 0 0 1:
 *
 *   [x_in, y_in, 1]^T = output_to_input * [x_out, y_out, 1]^T
 *
 * It is exactly what was drawn: output pixel (x, y) shows input point output_to_input(x,
 * y). For frames that were not warped (BYPASSED, PASSED_THROUGH, FAILED) the buffer is the
 * input, untouched, and the matrix is the identity. AFFINE_META frames are the input,
 * untouched, too, but the matrix is what a GL element draws with their
 * GstVideoAffineTransformationMeta: map the buffer's pixels through it as for a warped one. A video scaler downstream (videoscale,
 * videoconvertscale) rescales the matrix to the new size (and sets width, height); other
 * elements that change geometry (videoflip, videocrop, ...) drop the meta, as they drop
 * every meta tagged "orientation" or "size".
 *
 * The GstUavStabTransform fields are the element's own statistics, the same numbers as
 * its "uavstabilize" bus message (post-messages=true): similarities about the frame
 * centre in pixels of the frame the element stabilized (frame_width x frame_height;
 * centred coordinates: pixel (x, y) is (x - (W-1)/2, y - (H-1)/2)). They are what the
 * path planner computed for the frame even when it was not warped (bypass): the outcome
 * and the matrix say what was applied.
 */
#ifndef UAVSTAB_META_H
#define UAVSTAB_META_H

#include <gst/gst.h>

G_BEGIN_DECLS

/* Names of the meta API type and implementation (registered by the plugin). */
#define GST_UAV_STAB_META_API_NAME "GstUavStabMetaAPI"
#define GST_UAV_STAB_META_IMPL_NAME "GstUavStabMeta"
/* Bumped when fields or outcomes are added (fields at the end of the struct). */
#define GST_UAV_STAB_META_VERSION 4

/* A similarity about the frame centre: p' = scale * R(angle) * p + (dx, dy). */
typedef struct {
    gdouble dx;    /* translation, pixels */
    gdouble dy;
    gdouble angle; /* radians, counter-clockwise in image axes (y down) */
    gdouble scale;
} GstUavStabTransform;

typedef enum {
    GST_UAV_STAB_MODEL_RIGID = 0,      /* 3 DOF: translation + rotation */
    GST_UAV_STAB_MODEL_SIMILARITY = 1, /* 4 DOF: + scale */
} GstUavStabModel;

typedef enum {
    GST_UAV_STAB_OUTCOME_WARPED = 0,         /* the stabilized frame (a new buffer) */
    GST_UAV_STAB_OUTCOME_BYPASSED = 1,       /* bypass=true: the input, untouched */
    GST_UAV_STAB_OUTCOME_PASSED_THROUGH = 2, /* no output buffer to warp into: the input, uncorrected */
    GST_UAV_STAB_OUTCOME_FAILED = 3,         /* stabilization failed (warning posted): the input, uncorrected */
    /* version >= 3, render=affine-meta: the input, untouched, with a GstVideoAffineTransformationMeta
       that draws it stabilized; output_to_input is that mapping */
    GST_UAV_STAB_OUTCOME_AFFINE_META = 4,
} GstUavStabOutcome;

typedef struct {
    GstMeta meta;
    guint32 version;      /* GST_UAV_STAB_META_VERSION of the plugin that attached it */
    gint64 index;         /* frames since the stream started or was flushed (the bus message's "index") */
    gint frame_width;     /* the frame the element stabilized; the transforms below are in its pixels
                             (with lens-profile: in the lens's undistorted view, and with lens-output=original
                             the output is that view seen back through the lens, zoomed by `zoom`) */
    gint frame_height;
    GstUavStabTransform motion;     /* raw inter-frame camera motion (this frame -> previous frame) */
    GstUavStabTransform trajectory; /* accumulated camera path (raw) */
    GstUavStabTransform smoothed;   /* planned (smoothed) camera path, the one the output follows */
    GstUavStabTransform correction; /* input -> stabilized, before the crop zoom */
    gdouble zoom;                   /* crop zoom of the output (>= 1) */
    gdouble correction_fraction;    /* < 1 when the correction was limited to the crop */
    GstUavStabModel model;          /* motion model used for this frame */
    gint points;                    /* tracks that survived the forward-backward check */
    gint inliers;                   /* points consistent with the fitted motion */
    gboolean skipped;               /* no usable motion: identity was used for this frame */
    gboolean segment_start;         /* first frame of a new path segment (start, flush, gap, discont) */
    GstUavStabOutcome outcome;
    gint width;                     /* the frame `output_to_input` refers to (the buffer's size) */
    gint height;
    gdouble output_to_input[9];     /* row-major 3x3, pixel coordinates (see above) */
    /* version >= 2 */
    gdouble wobble;                 /* rolling shutter: RMS px by which the input's rows were bent and put
                                       back (each output row then has its own transform, near output_to_input);
                                       0 = not corrected */
    /* version >= 4 */
    gboolean rolling_shutter;       /* the input's rows were put back where its mid-exposure saw them (each
                                       output row has its own transform); FALSE: one transform, output_to_input */
    gdouble readout;                /* the sensor's readout time as a share of the frame time: the
                                       readout-time property's, else the stream's estimate (0 = not known yet) */
    gdouble readout_confidence;     /* 0-1: how sure the estimate is (1 when set by the property) */
} GstUavStabMeta;

/* The meta's API type, or 0 (G_TYPE_INVALID) while the plugin is not loaded. */
static inline GType gst_uav_stab_meta_api_get_type(void)
{
    return g_type_from_name(GST_UAV_STAB_META_API_NAME);
}
#define GST_UAV_STAB_META_API_TYPE (gst_uav_stab_meta_api_get_type())

/* The meta's implementation (for gst_buffer_add_meta or its transform function), or NULL
 * while the plugin is not loaded. */
static inline const GstMetaInfo *gst_uav_stab_meta_get_info(void)
{
    return gst_meta_get_info(GST_UAV_STAB_META_IMPL_NAME);
}

/* The buffer's GstUavStabMeta (the last uavstabilize's), or NULL. */
static inline GstUavStabMeta *gst_buffer_get_uav_stab_meta(GstBuffer *buffer)
{
    GType api = gst_uav_stab_meta_api_get_type();
    return api ? (GstUavStabMeta *)gst_buffer_get_meta(buffer, api) : NULL;
}

/* Output pixel (x, y) -> the input pixel it shows (pixel-centre coordinates). */
static inline void gst_uav_stab_meta_output_to_input(const GstUavStabMeta *meta, gdouble x, gdouble y, gdouble *in_x,
                                                     gdouble *in_y)
{
    const gdouble *m = meta->output_to_input;
    const gdouble w = m[6] * x + m[7] * y + m[8];
    *in_x = (m[0] * x + m[1] * y + m[2]) / w;
    *in_y = (m[3] * x + m[4] * y + m[5]) / w;
}

/* Input pixel (x, y) -> where it appears in the output (it may lie outside the output
 * frame); FALSE when the matrix cannot be inverted. */
static inline gboolean gst_uav_stab_meta_input_to_output(const GstUavStabMeta *meta, gdouble x, gdouble y,
                                                         gdouble *out_x, gdouble *out_y)
{
    const gdouble *m = meta->output_to_input;
    /* Inverse through the adjugate. */
    const gdouble a = m[4] * m[8] - m[5] * m[7], b = m[2] * m[7] - m[1] * m[8], c = m[1] * m[5] - m[2] * m[4];
    const gdouble d = m[5] * m[6] - m[3] * m[8], e = m[0] * m[8] - m[2] * m[6], f = m[2] * m[3] - m[0] * m[5];
    const gdouble g = m[3] * m[7] - m[4] * m[6], h = m[1] * m[6] - m[0] * m[7], k = m[0] * m[4] - m[1] * m[3];
    const gdouble det = m[0] * a + m[1] * d + m[2] * g;
    gdouble w;
    if (det == 0.0)
        return FALSE;
    w = g * x + h * y + k;
    if (w == 0.0)
        return FALSE;
    *out_x = (a * x + b * y + c) / w;
    *out_y = (d * x + e * y + f) / w;
    return TRUE;
}

G_END_DECLS

#endif /* UAVSTAB_META_H */
