#include "jitter_metrics.hpp"

#include <array>
#include <cmath>

namespace uavstab::synthetic {

Similarity outputToInput(const FrameStats &stats)
{
    return stats.correction.inverse() * Similarity{0.0, 0.0, 0.0, 1.0 / stats.zoom};
}

double residualJitter(const std::vector<Similarity> &path, int width, int height, double sigma)
{
    const std::size_t n = path.size();
    if (n < 2)
        return 0.0;
    const double hx = (width - 1) * 0.5, hy = (height - 1) * 0.5;
    const std::array<Point2, 4> corners{{{-hx, -hy}, {hx, -hy}, {-hx, hy}, {hx, hy}}};
    const int radius = int(std::ceil(3 * sigma));
    double sum2 = 0.0;
    for (const Point2 &corner : corners) {
        std::vector<Point2> track(n);
        for (std::size_t i = 0; i < n; ++i)
            track[i] = path[i].apply(corner);
        for (std::size_t i = 0; i < n; ++i) {
            double wsum = 0, x = 0, y = 0;
            for (int k = -radius; k <= radius; ++k) {
                const long j = long(i) + k;
                if (j < 0 || j >= long(n))
                    continue;  // truncated and renormalised at the ends
                const double w = std::exp(-0.5 * k * k / (sigma * sigma));
                wsum += w;
                x += w * track[std::size_t(j)].x;
                y += w * track[std::size_t(j)].y;
            }
            const double ex = track[i].x - x / wsum, ey = track[i].y - y / wsum;
            sum2 += ex * ex + ey * ey;
        }
    }
    return std::sqrt(sum2 / (4.0 * n));
}

double coverage(const Similarity &output_to_input, int width, int height)
{
    constexpr int kGrid = 64;
    const double hx = (width - 1) * 0.5, hy = (height - 1) * 0.5;
    int inside = 0;
    for (int gy = 0; gy < kGrid; ++gy)
        for (int gx = 0; gx < kGrid; ++gx) {
            const Point2 q{-hx + 2 * hx * (gx + 0.5) / kGrid, -hy + 2 * hy * (gy + 0.5) / kGrid};
            const Point2 p = output_to_input.apply(q);
            inside += std::abs(p.x) <= hx + 0.5 && std::abs(p.y) <= hy + 0.5;
        }
    return double(inside) / (kGrid * kGrid);
}

} // namespace uavstab::synthetic
