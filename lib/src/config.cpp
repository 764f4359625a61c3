#include "uavstab/config.hpp"

#include <stdexcept>
#include <string>
#include <thread>

namespace uavstab {

namespace {
void require(bool ok, const char *what)
{
    if (!ok)
        throw std::invalid_argument(std::string("StabilizerConfig: ") + what);
}
} // namespace

void StabilizerConfig::validate() const
{
    require(delay >= 0 && delay <= 1000, "delay must be in [0, 1000]");
    require(smoothing_radius >= 0 && smoothing_radius <= 1000, "smoothing_radius must be in [0, 1000]");
    require(max_corners >= 4 && max_corners <= 200, "max_corners must be in [4, 200]");
    require(roi > 0.05 && roi <= 1.0, "roi must be in (0.05, 1]");
    require(redetect_interval >= 1, "redetect_interval must be >= 1");
    require(fb_threshold > 0.0, "fb_threshold must be > 0");
    require(tracking_window >= 7 && tracking_window <= 41 && tracking_window % 2 == 1,
            "tracking_window must be odd and in [7, 41]");
    require(dwell >= 1, "dwell must be >= 1");
    require(min_points >= 2, "min_points must be >= 2");
    require(crop >= 0.0 && crop <= 0.5, "crop must be in [0, 0.5]");
    require(max_zoom >= 1.0 && max_zoom <= 4.0, "max_zoom must be in [1, 4]");
    require(zoom_speed > 0.0 && zoom_speed <= 0.1, "zoom_speed must be in (0, 0.1]");
    require(planner_smoothness >= 1.0 && planner_smoothness <= 1e7, "planner_smoothness must be in [1, 1e7]");
    require(analysis_width >= 16, "analysis_width must be >= 16");
    require(threads >= 0 && threads <= 64, "threads must be in [0, 64]");
}

int StabilizerConfig::resolvedThreads() const
{
    if (threads > 0)
        return threads;
    const unsigned n = std::thread::hardware_concurrency();
    return n > 0 ? int(n) : 2;
}

const char *toString(ModelChoice m)
{
    switch (m) {
    case ModelChoice::Rigid:
        return "rigid";
    case ModelChoice::Similarity:
        return "similarity";
    default:
        return "hybrid";
    }
}

const char *toString(SmootherKind s)
{
    return s == SmootherKind::Gaussian ? "gaussian" : "box";
}

const char *toString(PlannerKind p)
{
    switch (p) {
    case PlannerKind::Gaussian:
        return "gaussian";
    case PlannerKind::Box:
        return "box";
    default:
        return "optimal";
    }
}

const char *toString(BorderMode b)
{
    return b == BorderMode::Replicate ? "replicate" : "black";
}

} // namespace uavstab
