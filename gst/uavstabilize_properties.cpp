#include "uavstabilize_properties.hpp"

#include <gst/gst.h>

#include "uavstabilize_enums.hpp"

namespace gstuavstab {

namespace {

enum Property {
    PROP_0,
    PROP_DELAY,
    PROP_SMOOTHING_RADIUS,
    PROP_SMOOTHER,
    PROP_MAX_CORNERS,
    PROP_ROI,
    PROP_REDETECT_INTERVAL,
    PROP_FB_THRESHOLD,
    PROP_TRACKING_WINDOW,
    PROP_MODEL,
    PROP_DWELL,
    PROP_MIN_POINTS,
    PROP_CROP,
    PROP_LIMIT_TO_CROP,
    PROP_BORDER,
    PROP_ANALYSIS_WIDTH,
    PROP_THREADS,
    PROP_BYPASS,
    PROP_POST_MESSAGES,
};

constexpr GParamFlags kPlaying =
    GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
constexpr GParamFlags kReady = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);

} // namespace

void installProperties(GObjectClass *gobject_class)
{
    const uavstab::StabilizerConfig d;  // the library's defaults are the element's
    auto install = [gobject_class](Property id, GParamSpec *spec) {
        g_object_class_install_property(gobject_class, id, spec);
    };
    install(PROP_DELAY, g_param_spec_uint("delay", "Delay",
                                          "Frames held back so the smoothing window can look ahead (adds delay x "
                                          "frame duration of latency; 0 = causal smoothing)",
                                          0, 1000, guint(d.delay), kPlaying));
    install(PROP_SMOOTHING_RADIUS,
            g_param_spec_uint("smoothing-radius", "Smoothing radius",
                              "Half-width of the camera path smoothing window, in frames", 0, 1000,
                              guint(d.smoothing_radius), kPlaying));
    install(PROP_SMOOTHER, g_param_spec_enum("smoother", "Smoother", "How the camera path is smoothed",
                                             UAVSTABILIZE_TYPE_SMOOTHER, int(d.smoother), kPlaying));
    install(PROP_MAX_CORNERS, g_param_spec_uint("max-corners", "Max corners", "Corners tracked per frame", 4, 200,
                                                guint(d.max_corners), kPlaying));
    install(PROP_ROI, g_param_spec_double("roi", "Region of interest",
                                          "Central share of width and height where corners are detected", 0.1,
                                          1.0, d.roi, kPlaying));
    install(PROP_REDETECT_INTERVAL,
            g_param_spec_uint("redetect-interval", "Redetect interval",
                              "Frames between corner re-detections (sooner when tracks are lost)", 1, 1000,
                              guint(d.redetect_interval), kPlaying));
    install(PROP_FB_THRESHOLD,
            g_param_spec_double("fb-threshold", "Forward-backward threshold",
                                "A track is kept when tracking it back lands within this many analysis pixels",
                                0.01, 100.0, d.fb_threshold, kPlaying));
    install(PROP_TRACKING_WINDOW,
            g_param_spec_uint("tracking-window", "Tracking window",
                              "Side of the Lucas-Kanade window in analysis pixels (odd; an even value is rounded "
                              "up). Smaller is faster (19: about a quarter less tracking time), larger follows "
                              "low-texture scenes better",
                              7, 41, guint(d.tracking_window), kPlaying));
    install(PROP_MODEL, g_param_spec_enum("model", "Motion model", "Motion model fitted to the tracks",
                                          UAVSTABILIZE_TYPE_MODEL, int(d.model), kPlaying));
    install(PROP_DWELL, g_param_spec_uint("dwell", "Dwell",
                                          "Frames a hybrid model choice is kept before it is re-evaluated", 1,
                                          100000, guint(d.dwell), kPlaying));
    install(PROP_MIN_POINTS,
            g_param_spec_uint("min-points", "Min points",
                              "Fewer surviving tracks than this: the frame gets no correction", 2, 200,
                              guint(d.min_points), kPlaying));
    install(PROP_CROP, g_param_spec_double("crop", "Crop",
                                           "Share of width/height hidden by the zoom (split between opposite "
                                           "edges; zoom = 1 / (1 - crop))",
                                           0.0, 0.5, d.crop, kPlaying));
    install(PROP_LIMIT_TO_CROP,
            g_param_spec_boolean("limit-to-crop", "Limit to crop",
                                 "Shrink corrections that would show more border than the crop hides",
                                 d.limit_to_crop, kPlaying));
    install(PROP_BORDER, g_param_spec_enum("border", "Border", "What uncovered output pixels show",
                                           UAVSTABILIZE_TYPE_BORDER, int(d.border), kPlaying));
    install(PROP_ANALYSIS_WIDTH,
            g_param_spec_uint("analysis-width", "Analysis width",
                              "Motion is estimated on luma downscaled to this width (full size when smaller)", 16,
                              16384, guint(d.analysis_width), kPlaying));
    install(PROP_THREADS, g_param_spec_uint("threads", "Threads", "Warp worker threads (0 = one per core)", 0, 64,
                                            guint(d.threads), kReady));
    install(PROP_BYPASS, g_param_spec_boolean("bypass", "Bypass",
                                              "Pass frames through untouched, with the same delay (toggling "
                                              "never reorders frames)",
                                              d.bypass, kPlaying));
    install(PROP_POST_MESSAGES,
            g_param_spec_boolean("post-messages", "Post messages",
                                 "Post an element message 'uavstabilize' per frame with the motion, path and "
                                 "correction (angles in radians)",
                                 FALSE, kPlaying));
}

bool setProperty(UavStabilizeSettings &settings, guint id, const GValue *value)
{
    uavstab::StabilizerConfig &c = settings.stabilizer;
    switch (Property(id)) {
    case PROP_DELAY:
        c.delay = int(g_value_get_uint(value));
        break;
    case PROP_SMOOTHING_RADIUS:
        c.smoothing_radius = int(g_value_get_uint(value));
        break;
    case PROP_SMOOTHER:
        c.smoother = uavstab::SmootherKind(g_value_get_enum(value));
        break;
    case PROP_MAX_CORNERS:
        c.max_corners = int(g_value_get_uint(value));
        break;
    case PROP_ROI:
        c.roi = g_value_get_double(value);
        break;
    case PROP_REDETECT_INTERVAL:
        c.redetect_interval = int(g_value_get_uint(value));
        break;
    case PROP_FB_THRESHOLD:
        c.fb_threshold = g_value_get_double(value);
        break;
    case PROP_TRACKING_WINDOW:
        c.tracking_window = int(g_value_get_uint(value)) | 1;  // the window has a centre pixel
        break;
    case PROP_MODEL:
        c.model = uavstab::ModelChoice(g_value_get_enum(value));
        break;
    case PROP_DWELL:
        c.dwell = int(g_value_get_uint(value));
        break;
    case PROP_MIN_POINTS:
        c.min_points = int(g_value_get_uint(value));
        break;
    case PROP_CROP:
        c.crop = g_value_get_double(value);
        break;
    case PROP_LIMIT_TO_CROP:
        c.limit_to_crop = g_value_get_boolean(value);
        break;
    case PROP_BORDER:
        c.border = uavstab::BorderMode(g_value_get_enum(value));
        break;
    case PROP_ANALYSIS_WIDTH:
        c.analysis_width = int(g_value_get_uint(value));
        break;
    case PROP_THREADS:
        c.threads = int(g_value_get_uint(value));
        break;
    case PROP_BYPASS:
        c.bypass = g_value_get_boolean(value);
        break;
    case PROP_POST_MESSAGES:
        settings.post_messages = g_value_get_boolean(value);
        break;
    default:
        return false;
    }
    settings.dirty = true;
    return true;
}

bool getProperty(const UavStabilizeSettings &settings, guint id, GValue *value)
{
    const uavstab::StabilizerConfig &c = settings.stabilizer;
    switch (Property(id)) {
    case PROP_DELAY:
        g_value_set_uint(value, guint(c.delay));
        break;
    case PROP_SMOOTHING_RADIUS:
        g_value_set_uint(value, guint(c.smoothing_radius));
        break;
    case PROP_SMOOTHER:
        g_value_set_enum(value, int(c.smoother));
        break;
    case PROP_MAX_CORNERS:
        g_value_set_uint(value, guint(c.max_corners));
        break;
    case PROP_ROI:
        g_value_set_double(value, c.roi);
        break;
    case PROP_REDETECT_INTERVAL:
        g_value_set_uint(value, guint(c.redetect_interval));
        break;
    case PROP_FB_THRESHOLD:
        g_value_set_double(value, c.fb_threshold);
        break;
    case PROP_TRACKING_WINDOW:
        g_value_set_uint(value, guint(c.tracking_window));
        break;
    case PROP_MODEL:
        g_value_set_enum(value, int(c.model));
        break;
    case PROP_DWELL:
        g_value_set_uint(value, guint(c.dwell));
        break;
    case PROP_MIN_POINTS:
        g_value_set_uint(value, guint(c.min_points));
        break;
    case PROP_CROP:
        g_value_set_double(value, c.crop);
        break;
    case PROP_LIMIT_TO_CROP:
        g_value_set_boolean(value, c.limit_to_crop);
        break;
    case PROP_BORDER:
        g_value_set_enum(value, int(c.border));
        break;
    case PROP_ANALYSIS_WIDTH:
        g_value_set_uint(value, guint(c.analysis_width));
        break;
    case PROP_THREADS:
        g_value_set_uint(value, guint(c.threads));
        break;
    case PROP_BYPASS:
        g_value_set_boolean(value, c.bypass);
        break;
    case PROP_POST_MESSAGES:
        g_value_set_boolean(value, settings.post_messages);
        break;
    default:
        return false;
    }
    return true;
}

} // namespace gstuavstab
