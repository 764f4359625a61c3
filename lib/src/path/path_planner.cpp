#include "path/path_planner.hpp"

#include "path/l1_path_planner.hpp"
#include "path/optimal_path_planner.hpp"
#include "path/window_path_planner.hpp"

namespace uavstab {

std::unique_ptr<PathPlanner> makePathPlanner(const StabilizerConfig &config)
{
    switch (config.planner) {
    case PlannerKind::Gaussian:
        return std::make_unique<WindowPathPlanner>(SmootherKind::Gaussian, config.smoothing_radius, config.crop,
                                                   config.limit_to_crop);
    case PlannerKind::Box:
        return std::make_unique<WindowPathPlanner>(SmootherKind::Box, config.smoothing_radius, config.crop,
                                                   config.limit_to_crop);
    case PlannerKind::L1: {
        L1PathPlanner::Settings settings;
        settings.crop = config.crop;
        settings.keep_inside = config.limit_to_crop;
        settings.catch_up_threshold = config.planner_manoeuvre;
        return std::make_unique<L1PathPlanner>(settings);
    }
    case PlannerKind::Optimal:
        break;
    }
    OptimalPathPlanner::Settings settings;
    settings.crop = config.crop;
    settings.keep_inside = config.limit_to_crop;
    settings.adaptive_zoom = config.adaptive_zoom;
    settings.max_zoom = config.max_zoom;
    settings.zoom_speed = config.zoom_speed;
    settings.smoothness = config.planner_smoothness;
    settings.manoeuvre_threshold = config.planner_manoeuvre;
    return std::make_unique<OptimalPathPlanner>(settings);
}

} // namespace uavstab
