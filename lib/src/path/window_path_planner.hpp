// The window planners (planner=gaussian, planner=box): a weighted window over the camera
// path (Gaussian, or the paper's box average) gives the smoothed pose, then each frame's
// correction is shrunk on its own until no border shows (framing.hpp). The paper's
// smoothing, and the reference the other planners are measured against.
#pragma once

#include <deque>

#include "path/path_planner.hpp"
#include "path/trajectory_smoother.hpp"

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
