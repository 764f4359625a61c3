#include "uavstab/config_params.hpp"

#include <cmath>
#include <sstream>

#include "estimate/exclude_regions.hpp"

namespace uavstab {

namespace {

using C = StabilizerConfig;

std::string excludeText(const C &c)
{
    return formatRects(c.exclude);
}

bool setExcludeText(C &c, const std::string &text, std::string *error)
{
    return parseRects(text, c.exclude, error);
}

std::string checkExclude(const C &c)
{
    return checkRects(c.exclude);
}

std::string lensProfileText(const C &c)
{
    return c.lens_profile;
}

bool setLensProfileText(C &c, const std::string &text, std::string *)
{
    c.lens_profile = text;
    return true;
}

// The file is read (and its fields checked) when the Stabilizer is built.
std::string checkLensProfile(const C &)
{
    return "";
}

std::vector<ConfigParam> makeTable()
{
    // One row per StabilizerConfig field, in declaration order. Defaults are the field
    // initializers in config.hpp; ranges are inclusive.
    return {
        param<&C::delay>("delay", "Delay",
                         "Frames held back so the smoothing window can look ahead (adds delay x frame duration "
                         "of latency; 0 = causal smoothing)",
                         0, 1000),
        param<&C::planner>("planner", "Planner",
                           "How the output path is planned: l1 (holds the view still wherever the crop margin "
                           "allows and moves at steady speed only where the camera moves further; for hover, sway "
                           "and manoeuvres alike), optimal (a smooth path that follows the camera's motion inside "
                           "the crop), gaussian (a Gaussian window, each frame then clamped to the crop) or box "
                           "(the paper's moving average, clamped likewise)",
                           PlannerKind::Optimal, PlannerKind::L1),
        param<&C::smoothing_radius>("smoothing_radius", "Smoothing radius",
                                    "Window planners (gaussian, box): half-width of the window, in frames", 0, 1000),
        param<&C::planner_smoothness>("planner_smoothness", "Planner smoothness",
                                      "Optimal planner: weight of the jerk penalty against following the camera "
                                      "path; larger is smoother and bends deliberate motion more",
                                      1.0, 1e7),
        param<&C::planner_manoeuvre>("planner_manoeuvre", "Planner manoeuvre threshold",
                                     "At delays up to 7 (l1 and optimal planners): the path the output follows "
                                     "gives up smoothness to catch up with a deliberate move when the camera has kept "
                                     "to one side of it for 8 frames by more than this many times the shake's level "
                                     "(0 = never; lower catches up sooner)",
                                     0.0, 100.0),
        param<&C::max_corners>("max_corners", "Max corners", "Corners tracked per frame", 4, 200),
        param<&C::roi>("roi", "Region of interest", "Central share of width and height where corners are detected",
                       0.1, 1.0),
        param<&C::redetect_interval>("redetect_interval", "Redetect interval",
                                     "Frames between corner re-detections (sooner when tracks are lost)", 1, 1000),
        param<&C::fb_threshold>("fb_threshold", "Forward-backward threshold",
                                "A track is kept when tracking it back lands within this many analysis pixels",
                                0.01, 100.0),
        param<&C::tracking_window>("tracking_window", "Tracking window",
                                   "Side of the Lucas-Kanade window in analysis pixels (odd; the element rounds an "
                                   "even value up). Smaller is faster (19: about a quarter less tracking time), "
                                   "larger follows low-texture scenes better",
                                   7, 41, kParamOdd),
        param<&C::model>("model", "Motion model", "Motion model fitted to the tracks", ModelChoice::Hybrid,
                         ModelChoice::Similarity),
        param<&C::dwell>("dwell", "Dwell", "Frames a hybrid model choice is kept before it is re-evaluated", 1,
                         100000),
        param<&C::min_points>("min_points", "Min points",
                              "Fewer surviving tracks than this: the frame gets no correction", 2, 200),
        param<&C::crop>("crop", "Crop",
                        "Share of width/height hidden by the zoom (split between opposite edges; zoom = 1 / (1 - "
                        "crop)); under shake stronger than it can hold, planner=l1 grows the zoom slowly into the "
                        "room of its scale correction (zoom^1.12: 1.098 at 0.08)",
                        0.0, 0.5),
        flag<&C::limit_to_crop>("limit_to_crop", "Limit to crop",
                                "Keep the output covered by picture: the l1 and optimal planners plan the path "
                                "inside the crop, the window planners shrink each frame's correction; off, borders "
                                "may show"),
        flag<&C::adaptive_zoom>("adaptive_zoom", "Adaptive zoom",
                                "Optimal planner only (planner=optimal): zoom in beyond 'crop' as far and as early "
                                "as the look-ahead shows the path needs, up to max-zoom, and out again slowly"),
        param<&C::max_zoom>("max_zoom", "Max zoom", "Adaptive zoom: the largest zoom", 1.0, 4.0),
        param<&C::zoom_speed>("zoom_speed", "Zoom speed",
                              "Adaptive zoom: largest change of the zoom per frame when zooming in (out: a quarter)",
                              0.0001, 0.1),
        param<&C::border>("border", "Border", "What uncovered output pixels show", BorderMode::Black,
                          BorderMode::Replicate),
        textParam("exclude", "Excluded regions",
                  "Screen-fixed overlays to ignore (OSD, HUD, timestamp): rectangles x,y,w,h in fractions of the "
                  "frame, separated by ';' (e.g. \"0,0,1,0.1;0.45,0.45,0.1,0.1\"); no corners are detected there "
                  "and tracks inside are not used for the motion fit. Empty: none",
                  &excludeText, &setExcludeText, &checkExclude),
        flag<&C::exclude_static>("exclude_static", "Exclude static",
                                 "Find screen-fixed overlays automatically: tracks that stay put while the rest of "
                                 "the picture moves are not used, no corners are detected where they keep "
                                 "showing up (for a while), and strokes that stay the same while the camera moves "
                                 "are painted over before tracking"),
        param<&C::rolling_shutter>("rolling_shutter", "Rolling shutter",
                                   "auto: where the footage shows a rolling shutter's wobble (jello: a CMOS sensor "
                                   "reads its rows one after another while the camera vibrates), every row is put "
                                   "back where the frame's mid-exposure saw it; footage without wobble is left as "
                                   "it is. off: every frame is taken as one instant",
                                   RollingShutter::Auto, RollingShutter::Off),
        param<&C::readout_time>("readout_time", "Readout time",
                                "The camera sensor's readout time in ms, when known (0 = unknown, estimated from "
                                "the footage). Known, the skew of a moving camera is corrected too",
                                0.0, 1000.0),
        textParam("lens_profile", "Lens profile",
                  "A lens calibration file: a Gyroflow lens profile (JSON) or an OpenCV calibration (YAML, XML "
                  "or JSON with camera_matrix and distortion_coefficients). Motion is estimated in the lens's "
                  "undistorted view and each frame is warped through the lens in one pass; the profile's readout "
                  "time and shutter type are used unless readout-time or rolling-shutter are set. Empty: none",
                  &lensProfileText, &setLensProfileText, &checkLensProfile, kParamAtStartOnly),
        param<&C::lens_output>("lens_output", "Lens output",
                               "With a lens profile: original (the stabilized picture through the same lens) or "
                               "rectified (as a pinhole camera sees it)",
                               LensOutput::Original, LensOutput::Rectified, kParamAtStartOnly),
        param<&C::analysis_width>("analysis_width", "Analysis width",
                                  "Motion is estimated on luma downscaled to this width (full size when smaller)", 16,
                                  16384),
        param<&C::threads>("threads", "Threads", "Worker threads that plan and warp, and lend a hand to the motion estimation when idle (0 = one per core)", 0, 64, kParamAtStartOnly),
        flag<&C::bypass>("bypass", "Bypass",
                         "Pass frames through untouched, with the same delay (toggling never reorders frames)"),
        flag<&C::debug_overlay>("debug_overlay", "Debug overlay",
                                "Draw on each stabilized frame the tracked points (inliers green, rejected red), the "
                                "excluded regions (yellow) and the input frame's edges (the crop window's room, blue)"),
    };
}

std::string formatNumber(double value)
{
    std::ostringstream out;
    out << value;
    return out.str();
}

} // namespace

bool ConfigParam::accepts(double value) const
{
    if (kind == ParamKind::String)
        return true;  // no number to check: checkText() checks the field
    if (!(value >= min && value <= max))  // NaN fails too
        return false;
    if (kind == ParamKind::Double)
        return true;
    if (value != std::floor(value))
        return false;
    return !odd() || std::fmod(value, 2.0) != 0.0;
}

std::string ConfigParam::rangeText() const
{
    std::string text = "in [" + formatNumber(min) + ", " + formatNumber(max) + "]";
    if (odd())
        text += " and odd";
    return text;
}

const std::vector<ConfigParam> &configParams()
{
    static const std::vector<ConfigParam> table = makeTable();
    return table;
}

const ConfigParam *findConfigParam(const std::string &name)
{
    for (const ConfigParam &p : configParams())
        if (name == p.name)
            return &p;
    return nullptr;
}

} // namespace uavstab
