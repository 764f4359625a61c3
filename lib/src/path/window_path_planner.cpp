#include "path/window_path_planner.hpp"

#include <algorithm>

#include "path/framing.hpp"

namespace uavstab {

WindowPathPlanner::WindowPathPlanner(SmootherKind kind, int radius, double crop, bool limit_to_crop)
    : smoother_(kind, radius), radius_(std::max(0, radius)), crop_(crop), limit_to_crop_(limit_to_crop)
{
}

PlannedFrame WindowPathPlanner::plan(const PlanRequest &request)
{
    if (request.segment_start)
        past_.clear();
    const std::size_t ahead = std::min(request.lookahead.size(), std::size_t(radius_) + 1);
    window_.assign(past_.begin(), past_.end());
    window_.insert(window_.end(), request.lookahead.begin(), request.lookahead.begin() + long(ahead));
    const std::size_t centre = past_.size();

    PlannedFrame planned;
    const Similarity &camera = request.lookahead.front();
    planned.smoothed = smoother_.smooth(window_, centre);
    const Framing framing = frameOutput(planned.smoothed.inverse() * camera, request.width, request.height, crop_,
                                        limit_to_crop_);
    planned.correction = framing.applied;
    planned.output_to_input = framing.output_to_input;
    planned.zoom = framing.zoom;
    planned.correction_fraction = framing.fraction;

    past_.push_back(camera);
    while (past_.size() > std::size_t(radius_))
        past_.pop_front();
    return planned;
}

} // namespace uavstab
