// The default planner: a still view wherever the crop margin allows, and steady motion
// where the camera moves further than the margin. For every frame it plans the output path
// over the whole look-ahead and commits the first frame (a receding horizon).
//
// Per pose parameter (log scale, angle, then x and y, each in the room the previous one
// left), in two stages:
//
// 1. The L1 path. It minimises
//
//        w1 sum |D1 p| + w2 sum |D2 p| + w3 sum |D3 p| + ws/2 sum (D1 p)^2
//
//    (Grundmann, Kwatra, Essa, "Auto-directed video stabilization with robust L1 optimal
//    camera paths", CVPR 2011; their weights 10 : 1 : 100), the differences running on from
//    the frames already output. L1 norms make the path exactly still where it can be, then
//    constant-velocity, then constant-acceleration: what a viewer reads as a tripod or a
//    dolly, not a camera that floats after the shake. The last term (`speed_weight`) is
//    there because L1 norms charge a move by its length alone: standing still until the
//    crop forces a move and then rushing after the camera costs them what moving with it
//    from the start does; the speed's square prefers the latter. There is no pull towards
//    the camera: sway and drift that fit in the crop margin are removed, not followed.
//    Where it may go: within a tube around where the camera means to go (the followed
//    path, a smoother of the camera path that keeps a manoeuvre's few large jerks:
//    smoothAxis in path_terms.hpp), as wide as the crop room less `shake_margin` times the
//    shake's level. Riding the edge of the crop room itself would follow the shake there;
//    the tube's edge is smooth, and it leaves the room that the shake needs.
// 2. The crop. The smallest, smoothest change to the L1 path that keeps every known frame's
//    crop window inside that frame (fitAxis in path_terms.hpp): no border ever shows.
//
// Strong shake. Where three times the shake's RMS is more than the crop leaves, no path can
// hold still inside it; the crop then takes over the room the scale correction had
// (`shake_crop`), over three seconds, so that the zoom never passes what a scale correction
// already reaches (1.098 at crop 0.08) and does not pump.
//
// Deliberate moves. A steady move (the followed path's velocity over its newest second,
// the look-ahead included, far above its spread: a drift, a pan, a slow yaw) is followed,
// not ridden: the path is pulled towards the followed path (an L1 pull, `steady_pull`),
// so that it does not trail the move at the tube's edge and then kink where the move
// turns. Handheld sway and walking are not steady, and keep the still path. At short delays, where the look-ahead cannot
// see a move coming, the followed path catches up with a move the camera keeps to one side
// of (catchUpShare in path_terms.hpp) and the tube narrows to `short_tube` of the room, so
// that the path neither trails nor overruns a move by a whole room.
//
// The horizon ends with `extension` frames of the camera path extrapolated along a line
// fitted to its newest frames; the crop binds them only softly (stage 1's edge cost).
//
// What each term earns: uavstab-bench-path (perfect estimates, 3 seeds), the means of
// jitter against the intended path with the term and without it:
//   steady_pull     hover and strong shake (0.5x, 1x), delay 20: 0.21 px, 0.45 without
//                   (it costs the manoeuvre flights 1.88 px against 1.47)
//   speed_weight    manoeuvre flights, delay 20: 1.88 px and 30 px of lag, 2.94 and 33
//                   without (it costs the sway flights 6.58 px against 6.30)
//   catch-up        hover and strong shake, delay 0: 0.65 px, 0.75 without; manoeuvres 3.27, 3.83
//   short_tube      hover and strong shake, delay 0: 0.65 px, 0.76 with the whole room
//   extension       delay 0: 0.65 px, 34 without (the horizon of one frame cannot see a move)
//   shake_margin    the drone case at 2x, delay 5: 3.36 px, 3.85 without; manoeuvres at
//                   delay 20: 1.88, 2.44 (it costs the sway flights 6.58 px against 5.53)
//   shake_crop      strong shake (strong720 1x / 2x, delay 20): 0.89 / 9.80 px, 1.28 / 11.16
//                   without; delay 5: 1.23 / 10.01, 1.52 / 11.33; the drone case at 2x, delay
//                   20: 2.02, 2.84 (it costs the manoeuvre flights at 2x, delay 5, 4 px of
//                   lag: 41.1 against 36.9); where the shake fits the crop nothing changes
//
// Solver: iteratively reweighted least squares (each |u| majorised by u^2 / 2|u0| +
// |u0| / 2; each round a banded quadratic program with the tube as bounds, box_qp.hpp),
// warm-started from the previous frame's plan, `rounds` rounds a frame. A general LP
// solver (CLP, GLPK) would solve stage 1 exactly, but as an LP of some 40 variables and
// 250 rows per parameter per frame, a dependency and a simplex for what a few banded
// solves do in microseconds, deterministically. The reweighting's floor (`epsilon` px)
// leaves motions of a few thousandths of a pixel where an exact LP would have none.
#pragma once

#include <array>
#include <cstddef>
#include <deque>
#include <vector>

#include "path/path_planner.hpp"

namespace uavstab {

class L1PathPlanner : public PathPlanner {
public:
    struct Settings {
        double crop = 0.08;  // share of width and height hidden by the zoom
        // Strong shake: while the shake needs more room than `crop` leaves (room_per_shake
        // times its RMS per axis), the scale correction's room (scale_share) goes to the crop
        // instead, so the zoom never exceeds what a scale correction could already reach
        // (1.098 at crop 0.08). In over shake_crop_frames (three seconds at 30 fps: a zoom
        // that creeps is not seen, one that pumps is), out four times slower.
        bool shake_crop = true;
        double room_per_shake = 3.0;
        int shake_crop_frames = 90;
        // Stage 2 on: no border ever shows. Off (limit-to-crop=false): the output follows
        // stage 1, which keeps to the crop only by paying for leaving it, and borders may show.
        bool keep_inside = true;
        // Stage 1's L1 weights of velocity, acceleration and jerk (px per frame^k; angle and
        // log scale are taken in px at the frame's half-diagonal).
        double velocity_weight = 10.0;
        double acceleration_weight = 1.0;
        double jerk_weight = 100.0;
        // Stage 1's weight of the squared velocity (speed_weight/2 * sum (D1 p)^2, px^2).
        double speed_weight = 10.0;
        // Stage 1's cost per px of leaving the crop room (stage 2 makes the room hard).
        double edge_weight = 10.0;
        double epsilon = 0.01;  // px: the reweighting's floor
        int rounds = 4;         // reweighting rounds per frame (warm-started)
        int start_rounds = 25;  // at a segment's first frame
        // The followed path: smoothAxis's smoothness, and its catching up with a move the
        // camera keeps to one side of, at look-aheads up to catch_up_max_lookahead.
        double follow_smoothness = 100000.0;
        double catch_up_threshold = 0.7;
        int catch_up_window = 8;
        int catch_up_max_lookahead = 8;
        // The tube: the crop room less shake_margin times the shake's RMS (camera minus
        // followed path); at most short_tube of the room at a look-ahead of one frame,
        // widening to the whole room at full_tube_lookahead frames.
        double shake_margin = 1.5;
        double short_tube = 0.5;
        int full_tube_lookahead = 20;
        // Steady moves: the L1 pull towards the followed path, in full where the
        // steadiness (|mean velocity| / (spread + steady_floor px at 640 px of width),
        // velocities over 10 frames, the newest steady_window frames of the committed past
        // and the look-ahead) reaches steady_full, none below steady_from.
        double steady_pull = 10.0;
        double steady_from = 3.0;
        double steady_full = 6.0;
        double steady_floor = 0.05;
        int steady_window = 30;
        // Share of the crop margin kept for translation when the angle is planned, and the
        // share of the crop zoom's log a scale difference may use.
        double translation_reserve = 0.5;
        double scale_share = 0.12;
        // Stage 2: how far a change spreads to its neighbours. Where the crop binds (strong
        // shake), a stiff change carries one frame's push over several and passes more shake
        // on: uavstab-bench-path, strong720 at 1x / 2x, delay 20: 1.36 / 11.54 px at 1,
        // 1.28 / 11.16 at 0.1 (no further gain at 0.03 or 0.01); rendered (bench quality,
        // 3 seeds) 1.21 -> 1.17 px and 12.03 -> 11.65; real clips within 0.07 dB; the
        // manoeuvre flights at 2x, delay 0, 1 % worse; elsewhere the crop does not bind.
        double stiffness = 0.1;
        int extension = 20;            // extrapolated frames after the look-ahead
        int prediction_frames = 20;    // frames the extrapolation is fitted to
        double young_slope_prior = 30.0;
    };
    static constexpr int kHistory = 3;  // frames the differences run on from

    explicit L1PathPlanner(const Settings &settings);
    PlannedFrame plan(const PlanRequest &request) override;

private:
    using Params = std::array<double, 4>;  // x, y, angle, log scale

    void restart();

    Settings settings_;
    std::deque<Params> past_camera_;     // newest last (segment coordinates)
    std::deque<Params> past_reference_;  // stage 1's committed poses
    std::deque<Params> past_follow_;     // the followed path's committed poses
    std::deque<Params> past_follow_gap_;  // camera minus followed path
    Params past_change_{};               // stage 2's committed change
    Params shake_variance_{};            // per parameter, px^2
    double shake_crop_ = 0.0;            // share of the scale's room given to the crop now
    int shake_frames_ = 0;
    std::size_t longest_lookahead_ = 0;  // in this segment
    std::array<std::vector<double>, 4> last_plan_;  // the previous frame's stage 1 plan
};

} // namespace uavstab
