// Fitting a rigid (3 DOF) or similarity (4 DOF) motion to matched points, with
// outlier rejection, and the RMS reprojection error used to compare the two.
#pragma once

#include <cstdint>
#include <vector>

#include "uavstab/similarity.hpp"

namespace uavstab {

// Closed-form least squares (Umeyama without reflection) mapping from[i] to to[i].
// `use`, when given, selects the points that take part (non-zero = used).
Similarity fitLeastSquares(MotionModel model, const std::vector<Point2> &from,
                           const std::vector<Point2> &to,
                           const std::vector<std::uint8_t> *use = nullptr);

// Root mean square of |motion(from[i]) - to[i]| over the selected points (0 if none).
double rmsError(const Similarity &motion, const std::vector<Point2> &from,
                const std::vector<Point2> &to, const std::vector<std::uint8_t> *use = nullptr);

struct RobustFit {
    Similarity motion;
    std::vector<std::uint8_t> inliers;  // one flag per point
    int inlier_count = 0;
    double rms = 0.0;                   // over the inliers
};

// RANSAC over minimal two-point samples (deterministic for a given seed), then least
// squares refined twice on the inliers: points off by more than `inlier_threshold`
// pixels (moving objects, bad tracks) do not pull the fit.
RobustFit fitRobust(MotionModel model, const std::vector<Point2> &from, const std::vector<Point2> &to,
                    double inlier_threshold, std::uint32_t seed = 1);

} // namespace uavstab
