// Every tunable of the stabilizer, with the paper's defaults (Lim et al., "Real-Time
// Optical flow-based Video Stabilization for UAVs"). Each field's range and description
// are in the parameter table (config_params.hpp, one row per field), from which both
// validate() and the GStreamer element's properties are made.
//
// Public API: the fields' names and meanings hold from version to version; defaults and
// ranges may be tuned (config_params.hpp has the ranges in force).
#pragma once

#include <string>
#include <vector>

namespace uavstab {

// A rectangle in fractions of the frame's width and height: (0, 0) is the top-left
// corner, (1, 1) the bottom-right one.
struct RectF {
    double x = 0.0;
    double y = 0.0;
    double w = 0.0;
    double h = 0.0;
    bool operator==(const RectF &o) const { return x == o.x && y == o.y && w == o.w && h == o.h; }
};

enum class ModelChoice {
    Hybrid,      // paper: rigid or similarity, re-chosen every `dwell` frames by RMS error
    Rigid,       // 3 DOF: dx, dy, angle
    Similarity,  // 4 DOF: dx, dy, angle, scale
};

// How the output path is planned from the camera path (path_planner.hpp).
enum class PlannerKind {
    Optimal,   // a smooth path that follows the camera's motion over the look-ahead, inside the crop (optimal_path_planner.hpp)
    Gaussian,  // Gaussian window (sigma = radius / 2), then each frame clamped to the crop
    Box,       // paper: moving average over the window, then each frame clamped to the crop
    L1,        // still where the crop allows, steady motion where it must move (l1_path_planner.hpp)
};

enum class RollingShutter {
    Auto,  // bend each frame back where the footage shows a rolling shutter's wobble
    Off,   // every frame is taken as one picture of one instant
};

// What a stream calibrated by a lens profile gets back (StabilizerConfig::lens_profile).
enum class LensOutput {
    Original,   // the stabilized picture through the same lens: what that camera's footage looks like
    Rectified,  // the stabilized picture as a pinhole camera with the lens's camera matrix sees it
};

enum class BorderMode {
    Black,      // uncovered output pixels are black
    Replicate,  // uncovered output pixels repeat the nearest edge pixel
};

struct StabilizerConfig {
    // Frames held back so that the planner can look ahead (the latency, in frames). 0 is
    // causal: the optimal planner then relies on the crop margin and an extrapolation.
    int delay = 20;

    // Default: the L1 planner, which holds the view still wherever the crop margin allows
    // and moves at steady speed only where the camera moves further than the margin. It
    // departs from the paper's moving average (here as `box`, with smoothing_radius 10):
    // a window follows every slow sway and drift, bends deliberate manoeuvres and clamps
    // each frame to the crop on its own (tests/bench/REPORT.md compares them at delays 0-20).
    PlannerKind planner = PlannerKind::L1;
    // Window planners: half-width of the window, frames i-r .. i+r where known.
    int smoothing_radius = 20;
    // Optimal planner: weight of the jerk penalty against following the camera path;
    // larger is smoother and bends deliberate motion more.
    double planner_smoothness = 100000.0;
    // At delays up to 7 (l1 and optimal planners): the path the output follows gives up
    // smoothness to catch up with a deliberate move when the camera has kept to one side of
    // it for 8 frames by more than this many times the shake's level (0 = never; lower
    // catches up sooner).
    double planner_manoeuvre = 0.7;

    // Shi-Tomasi corners tracked per frame (paper: 50; at most 200).
    int max_corners = 50;
    // Corners are detected only in the central `roi` fraction of width and height
    // (paper: a reduced region of interest; edge points tend to leave the frame).
    double roi = 0.8;
    // Tracks are re-detected every `redetect_interval` frames (paper: 5), and sooner
    // when fewer than half of max_corners survive.
    int redetect_interval = 5;
    // Forward-backward check: a track is kept when tracking it back lands within this
    // many analysis pixels of where it started.
    double fb_threshold = 1.0;
    // Side of the Lucas-Kanade window in analysis pixels (odd, 7..41; small frames get a
    // smaller one). Tracking time grows with its area: 19 instead of 21 takes about a
    // quarter less, at a small cost on low-texture input (thermal), where big windows
    // follow better; 21 is the quality default (see tests/bench/REPORT.md).
    int tracking_window = 21;

    ModelChoice model = ModelChoice::Hybrid;
    // Frames a hybrid model choice is kept before it is re-evaluated (paper: 20).
    int dwell = 20;
    // Fewer surviving points than this: no correction for the frame (identity motion,
    // flagged as skipped).
    int min_points = 10;

    // Share of width and height hidden by zooming in, split evenly between opposite
    // edges: zoom = 1 / (1 - crop). 0.08 hides 4 % at each edge (zoom 1.087). Under shake
    // stronger than that can hold, the l1 planner grows the zoom slowly into the room its
    // scale correction had (up to zoom^1.12: 1.098 at 0.08).
    double crop = 0.08;
    // Shrink a correction that would show more border than the crop hides, so that
    // the output stays covered by picture.
    bool limit_to_crop = true;
    // Optimal planner only: zoom in beyond `crop` as far and as early as the look-ahead
    // shows the path needs, up to max_zoom, by at most zoom_speed per frame (out at a quarter).
    bool adaptive_zoom = false;
    double max_zoom = 1.25;
    double zoom_speed = 0.001;
    BorderMode border = BorderMode::Black;

    // Screen-fixed overlays to ignore (a burned-in OSD, a HUD, a timestamp): no corners are
    // detected inside these rectangles, and tracks that fall inside are not used for the
    // motion fit. Fractions of the frame; as text "x,y,w,h;x,y,w,h" (exclude_regions.hpp).
    std::vector<RectF> exclude;
    // Find such overlays by themselves: tracks that stay put while the others agree the
    // camera moved are dropped from the fit, and where they keep showing up no corners
    // are detected for a while (lib/src/estimate/screen_fixed.hpp); the overlay's strokes
    // are painted over in the luma the tracker sees (overlay_strokes.hpp). On by default: on seven real
    // clips it changes the output's ITF by at most 0.006 dB, and it keeps a burned-in OSD
    // from pinning the estimate (tests/unit/exclude_test.cpp).
    bool exclude_static = true;

    // Rolling shutter (CMOS sensors read rows one after another; vibration bends the
    // frame): auto estimates from the tracks how each frame's rows moved during readout
    // and samples every output row at the frame's mid-exposure, only where such a wobble
    // is found (rolling_shutter.hpp); off takes every frame as one instant.
    RollingShutter rolling_shutter = RollingShutter::Auto;
    // The sensor's readout time in ms, when known (0: unknown). Known, the skew of a
    // moving camera is corrected too, and the correction is always applied (needs the
    // frame rate: Stabilizer::setFrameInterval).
    double readout_time = 0.0;

    // A lens calibration file: a Gyroflow lens profile (JSON) or an OpenCV calibration
    // (cv::FileStorage YAML, XML or JSON; lens.hpp, readLensProfile). Motion is then
    // estimated and the path planned in the lens's undistorted (pinhole) view, and each
    // frame is warped through the lens in one pass. Its readout time and shutter type
    // feed the rolling-shutter settings where those are left at their defaults (readout_time
    // 0, rolling_shutter auto). Read when the Stabilizer is built: a file it cannot use
    // throws LensProfileError there. Empty: no lens (a pinhole view).
    std::string lens_profile;
    LensOutput lens_output = LensOutput::Original;

    // Motion is estimated on luma downscaled to this width (full size when smaller);
    // the motion is scaled back to full resolution.
    int analysis_width = 640;

    // Worker threads that smooth and warp; 0 = one per core.
    int threads = 0;

    // Pass frames through untouched (same delay, so toggling never reorders frames).
    bool bypass = false;

    // Draw on each warped output frame what the estimator saw (debug_overlay.hpp): the
    // tracked points (inliers green, rejected red), the excluded rectangles and where the
    // input frame's edges (the room of the crop window) fall.
    bool debug_overlay = false;

    // Throws std::invalid_argument naming the first field out of its range (the parameter
    // table's, config_params.hpp) and that range.
    void validate() const;
    // Worker threads this config resolves to on this machine.
    int resolvedThreads() const;
};

const char *toString(ModelChoice m);
const char *toString(BorderMode b);
const char *toString(RollingShutter r);
const char *toString(LensOutput o);
const char *toString(PlannerKind p);

} // namespace uavstab
