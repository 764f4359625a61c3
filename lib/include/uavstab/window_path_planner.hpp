// The first wave's planners behind the planner interface: a weighted window over the
// camera path (Gaussian, or the paper's box average) gives the smoothed pose, then each
// frame's correction is shrunk on its own until no border shows (framing.hpp). Kept so
// the benchmark can compare them with the optimal planner; their output is unchanged.
#pragma once

#include <deque>

#include "uavstab/path_planner.hpp"
#include "uavstab/trajectory_smoother.hpp"

namespace uavstab {

class WindowPathPlanner : public PathPlanner {
public:
    // kind: Gaussian or Box; radius: frames i - radius .. i + radius, as far as known.
    WindowPathPlanner(SmootherKind kind, int radius, double crop, bool limit_to_crop);
    PlannedFrame plan(const PlanRequest &request) override;

private:
    WeightedTrajectorySmoother smoother_;
    int radius_;
    double crop_;
    bool limit_to_crop_;
    std::deque<Similarity> past_;  // raw poses of the frames before, this segment, newest last
    std::vector<Similarity> window_;
};

} // namespace uavstab
