#include "path/trajectory_smoother.hpp"

#include <array>
#include <cmath>

namespace uavstab {

WeightedTrajectorySmoother::WeightedTrajectorySmoother(SmootherKind kind, int radius)
    : kind_(kind), radius_(radius < 0 ? 0 : radius)
{
}

double WeightedTrajectorySmoother::weight(long offset) const
{
    if (kind_ == SmootherKind::Box || radius_ == 0)
        return 1.0;
    const double sigma = 0.5 * radius_;
    return std::exp(-0.5 * double(offset * offset) / (sigma * sigma));
}

Similarity WeightedTrajectorySmoother::smooth(const std::vector<Similarity> &window, std::size_t centre) const
{
    if (window.empty())
        return Similarity::identity();
    const long first = -long(centre);
    const long last = long(window.size()) - 1 - long(centre);
    // Sums for a weighted line p(t) = a + b t, t = offset from the centre frame.
    double s0 = 0, s1 = 0, s2 = 0;
    std::array<double, 4> t0{}, t1{};
    for (long t = first; t <= last; ++t) {
        const Similarity &p = window[std::size_t(t - first)];
        const double w = weight(t);
        const std::array<double, 4> v{p.dx, p.dy, p.angle, std::log(p.scale)};
        s0 += w;
        s1 += w * t;
        s2 += w * t * t;
        for (int k = 0; k < 4; ++k) {
            t0[k] += w * v[k];
            t1[k] += w * t * v[k];
        }
    }
    std::array<double, 4> value{};
    const double det = s0 * s2 - s1 * s1;
    const bool symmetric = first == -last;
    for (int k = 0; k < 4; ++k) {
        if (symmetric || det <= 1e-12 * s0 * s0)
            value[k] = t0[k] / s0;  // the moving average (s1 = 0 when symmetric)
        else
            value[k] = (s2 * t0[k] - s1 * t1[k]) / det;
    }
    return {value[0], value[1], value[2], std::exp(value[3])};
}

std::unique_ptr<TrajectorySmoother> makeSmoother(SmootherKind kind, int radius)
{
    return std::make_unique<WeightedTrajectorySmoother>(kind, radius);
}

} // namespace uavstab
