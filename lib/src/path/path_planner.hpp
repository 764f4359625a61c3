// The camera-path planner (the paper's motion compensation stage): from the raw camera
// path, the path the output follows, and so each frame's correction.
//
// A planner is stateful and sees the frames strictly in order: for frame i it is given
// the raw camera poses of frames i .. i + delay that are known (fewer at the end of a
// stream or of a path segment) and remembers what it needs of the past itself. It must
// return an output pose whose crop window stays inside frame i (rotation and scale
// included). Planners are swapped and tested alone, like OpenCV videostab's
// IMotionStabilizer; the stabilizer runs one on its worker pool, one frame at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "uavstab/config.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

struct PlanRequest {
    std::int64_t index = 0;
    // Frame `index` starts a new path (start, reset, scene cut, gap): forget the past.
    bool segment_start = false;
    // Raw camera poses (frame -> its segment's first frame) of frames index, index + 1, ...
    // as far as they are known; lookahead[0] is frame `index`'s own. Never empty.
    std::vector<Similarity> lookahead;
    int width = 0;
    int height = 0;
};

struct PlannedFrame {
    Similarity smoothed;         // the output (virtual camera) pose
    Similarity correction;       // applied to the frame: input -> stabilized, before the zoom
    Similarity output_to_input;  // what the warper draws (centred coordinates)
    double zoom = 1.0;
    double correction_fraction = 1.0;  // < 1 when the correction had to be shrunk to fit
};

class PathPlanner {
public:
    virtual ~PathPlanner() = default;
    virtual PlannedFrame plan(const PlanRequest &request) = 0;
};

// The planner `config.planner` names, set up from the config.
std::unique_ptr<PathPlanner> makePathPlanner(const StabilizerConfig &config);

} // namespace uavstab
