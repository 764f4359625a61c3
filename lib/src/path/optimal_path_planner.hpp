// The optimal planner (planner=optimal): for every frame it solves for the output path over the whole
// look-ahead and commits the first frame (a receding horizon, as in model-predictive
// control), in two stages per pose parameter (x, y, angle, log scale):
//
// 1. Where the camera means to go. A fixed-lag smoother of the camera path c over the
//    horizon: minimise  sum_j (r_j - c_j)^2 + smoothness * sum_j rho(D3 r_j),  with D3 the
//    third difference running on from the frames already output, so the path continues
//    without a kink. rho is quadratic for small jerk and linear for large (Huber, solved by
//    a few reweighted least-squares rounds), so that a manoeuvre's start and stop (a few
//    large jerks) are kept while shake (many small ones) is smoothed away: piecewise
//    constant-acceleration paths, which is what pilots fly, pass unbent. (Grundmann et
//    al., CVPR 2011, use L1 norms for the same reason.)
// 2. Where the crop window can go. The smallest and smoothest change d to r that keeps
//    every known frame's crop window inside that frame:  minimise  sum_j d_j^2 +
//    stiffness * sum_j (d_j - d_j-1)^2  subject to the window of frame j inside frame j.
//    d is zero wherever nothing binds; where the look-ahead shows a frame that needs it,
//    the path starts to give way before that frame instead of jumping at it (which is what
//    the window planners' per-frame clamp does). Scale is fitted first, then the angle with
//    a reserve kept for translation, then the translation with what the rotation left.
//
// Adaptive zoom (an option) plans the zoom before stage 2 from how far stage 1's path
// strays from the camera's over the known look-ahead.
//
// The horizon is the known look-ahead plus `extension` frames of the camera path
// extrapolated along a line fitted to its last frames, so the plan ends heading where the
// camera heads: no lag on a steady pan even at delay 0.
//
// Solver: each stage is a quadratic program with bounds only and a banded matrix, solved
// exactly by a small active-set method (box_qp.hpp) in microseconds, deterministically.
// An LP/QP package (CLP, GLPK, OSQP) would add a dependency and cost more than the whole
// frame's estimation for these 1-60 variables; an exact L1 objective would need one.
#pragma once

#include <array>
#include <deque>

#include "path/path_planner.hpp"

namespace uavstab {

class OptimalPathPlanner : public PathPlanner {
public:
    struct Settings {
        double crop = 0.08;            // share of width and height hidden by the zoom
        // Stage 2 on: no border ever shows. Off (limit-to-crop=false): the output follows
        // stage 1 and borders may show.
        bool keep_inside = true;
        double smoothness = 100000.0;  // stage 1: weight of the jerk penalty
        // Stage 1: jerk (px per frame^3) above which the penalty turns linear, as a share
        // of the frame's diagonal; and the reweighting rounds that approximate it.
        double jerk_threshold = 1e-6;
        int reweighting_rounds = 5;
        double stiffness = 1.0;        // stage 2: how far a change spreads to its neighbours
        // Share of the crop margin kept for translation when the angle is fitted.
        double translation_reserve = 0.5;
        // Share of the crop zoom's log that a scale difference may use (0.12: 1 % at crop 0.08,
        // so zoom and scale together stay under 1.10).
        double scale_share = 0.12;
        // Adaptive zoom: beyond the crop's zoom, zoom in as far and as early as the look-ahead
        // shows stage 1's path needs (so stage 2 need not bend it), up to max_zoom, changing
        // by at most zoom_speed per frame in and a quarter of that out.
        bool adaptive_zoom = false;
        double max_zoom = 1.25;
        double zoom_speed = 0.001;
        int extension = 20;            // extrapolated frames after the look-ahead
        int prediction_frames = 20;    // frames the extrapolation is fitted to
        // Pull of the extrapolation's slope towards zero at a segment's start (squared
        // frames), fading out over its first prediction_frames frames.
        double young_slope_prior = 30.0;
        // Manoeuvres: when the camera has kept to one side of stage 1's path for the last
        // manoeuvre_window frames (their mean gap above manoeuvre_threshold times the
        // shake's level), the path is lagging a deliberate move, not riding out shake:
        // stage 1 is solved again with its smoothness scaled down by (threshold * shake /
        // gap)^2, at least min_smoothness_share. 0 turns it off. Only while the look-ahead
        // is at most manoeuvre_max_lookahead frames: a longer one sees a manoeuvre coming
        // and does not trail it, and there the catching up would only follow a handheld
        // camera's sway (real clips lose ~0.4 dB of ITF at delay 20 with it).
        double manoeuvre_threshold = 0.7;
        int manoeuvre_window = 8;
        double min_smoothness_share = 0.01;
        int manoeuvre_max_lookahead = 8;
    };
    static constexpr int kHistory = 3;  // frames the differences run on from

    explicit OptimalPathPlanner(const Settings &settings);
    PlannedFrame plan(const PlanRequest &request) override;

private:
    using Params = std::array<double, 4>;  // x, y, angle, log scale
    double planZoom(const PlanRequest &request, const std::array<std::vector<double>, 4> &camera,
                    const std::array<std::vector<double>, 4> &reference, const Params &origin);

    Settings settings_;
    std::deque<Params> past_reference_;  // stage 1's committed values, newest last
    std::deque<Params> past_camera_;     // newest last
    std::deque<Params> past_gap_;        // camera minus committed stage 1 value, newest last
    Params past_change_{};               // stage 2's committed change
    double past_zoom_ = 0.0;             // 0: none yet in this segment
};

} // namespace uavstab
