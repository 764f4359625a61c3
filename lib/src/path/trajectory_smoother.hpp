// Smoothing of the camera path (the paper's motion compensation stage): the smoothed
// pose of a frame from the poses of the frames around it. A pure function of a window,
// so the online stabilizer can run it on a worker and tests can call it alone.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "uavstab/config.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

// The window planners' weights (window_path_planner.hpp).
enum class SmootherKind {
    Box,       // paper: moving average of the accumulated trajectory
    Gaussian,  // Gaussian-weighted average over the same window, sigma = radius / 2
};

class TrajectorySmoother {
public:
    virtual ~TrajectorySmoother() = default;
    // window[k] is the pose of consecutive frames; returns the smoothed pose of window[centre].
    virtual Similarity smooth(const std::vector<Similarity> &window, std::size_t centre) const = 0;
};

// Smooths each pose parameter (dx, dy, angle, log scale) with a weighted window.
//
// Where the window is centred this is the weighted moving average (the paper's box
// average for Box). Where it is cut short on one side (start and end of a stream, or a
// look-ahead shorter than the radius, down to the causal delay-0 case) a plain average
// would lag behind any pan and pull the frame off-centre; there we fit a weighted
// straight line through the window and take its value at the frame. On a centred
// window the two are identical, so nothing changes where the paper's filter applies.
class WeightedTrajectorySmoother : public TrajectorySmoother {
public:
    WeightedTrajectorySmoother(SmootherKind kind, int radius);
    Similarity smooth(const std::vector<Similarity> &window, std::size_t centre) const override;

private:
    double weight(long offset) const;

    SmootherKind kind_;
    int radius_;
};

std::unique_ptr<TrajectorySmoother> makeSmoother(SmootherKind kind, int radius);

} // namespace uavstab
