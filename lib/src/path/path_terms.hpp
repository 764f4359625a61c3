// Pieces the receding-horizon planners share. A planner works on one pose
// parameter at a time (x, y, angle, log scale) over a horizon of frames, with the frames
// it already output in front (the "past"), so that differences run on without a kink.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "path/box_qp.hpp"
#include "path/framing.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

// A pose as the four parameters planned.
enum PoseParam { kX, kY, kAngle, kLogScale };
using PoseParams = std::array<double, 4>;

PoseParams paramsOf(const Similarity &s);

// Adds weight/2 * sum of squared `order`-th differences (order 1..3) of z = past ++ x to the
// problem in x; row r (the difference ending at z[r + order]) is weighted by row_weights[r]
// when given. Rows that lie wholly in the past are constants and left out.
void addDifferences(BandedBoxQp &qp, const std::vector<double> &past, int order, double weight,
                    const std::vector<double> *row_weights = nullptr);

// The `order`-th differences of z = past ++ x, one per row as addDifferences numbers them
// (rows wholly in the past included, so the numbering is the same).
std::vector<double> differences(const std::vector<double> &past, const std::vector<double> &x, int order);

// Line through the newest `count` values of `values` (oldest first), extrapolated `ahead`
// steps past the newest. While fewer than `count` values are known (a young segment) the
// slope is pulled towards zero, by a prior worth `prior` squared frames that fades as values
// arrive: a slope fitted to a few shaken frames is mostly shake.
double extrapolate(const std::vector<double> &values, std::size_t count, int ahead, double prior);

// The shake's level in a camera path (oldest first): the RMS of its second differences over
// the newest `count` values. A manoeuvre's accelerations are a small fraction of a pixel per
// frame squared; shake's are of the order of its amplitude.
double shakeLevel(const std::vector<double> &values, std::size_t count);

// A fixed-lag smoother of the camera path c over the horizon: minimises sum_j (r_j - c_j)^2 +
// smoothness * sum Huber(D3 r), the differences running on from `past`; the Huber penalty
// (quadratic up to jerk_threshold, linear above) by `rounds` reweighted least-squares rounds.
// Follows where the camera means to go: a manoeuvre's few large jerks are kept, shake's
// many small ones smoothed away.
std::vector<double> smoothAxis(const std::vector<double> &camera, const std::vector<double> &past, double smoothness,
                               double jerk_threshold, int rounds);

// Manoeuvres: when the camera has kept to one side of a smoothed path for the newest `window`
// frames (the known look-ahead's, then the committed ones, `past_gaps` newest last: camera
// minus path), by a mean gap above `threshold` times the shake's level (shakeLevel of
// `series` over 30 frames), the path lags a deliberate move rather than riding out shake.
// Returns the share to scale the smoother's smoothness by so that it catches up,
// (threshold * shake / gap)^2 but at least min_share; 1 when nothing lags.
double catchUpShare(const std::vector<double> &camera, const std::vector<double> &path, std::size_t known,
                    const std::vector<double> &past_gaps, std::size_t window, double threshold,
                    const std::vector<double> &series, double min_share);

// The smallest, smoothest change delta to a reference path that keeps every frame's crop
// window inside it: minimises sum delta_j^2 + stiffness * sum (delta_j - delta_j-1)^2
// subject to lower_j <= reference_j + delta_j <= upper_j, running on from `past_change`.
// Zero where nothing binds; where the look-ahead shows a frame that needs it, the path
// starts to give way before that frame instead of jumping at it. All zeros when not
// `constrained`.
std::vector<double> fitAxis(const std::vector<double> &reference, const std::vector<double> &lower,
                            const std::vector<double> &upper, double past_change, double stiffness, bool constrained);

// Frame j's translation room as an upright box in planning axes (turned by `planning_turn`
// from the segment's axes). The room is a box in the frame's own axes (the crop window
// turned by `relative_angle` and scaled by `relative_scale` against the frame), and the
// frame is turned by `frame_turn` against the planning axes: the largest upright box of
// the same proportions inside it stands in for it. Scaled to segment pixels by
// `camera_scale`. Zero where nothing fits.
Point2 uprightTranslationRoom(const CropWindow &window, double relative_angle, double relative_scale,
                              double frame_turn, double camera_scale);

} // namespace uavstab
