#include "jitter_metrics.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace uavstab::synthetic {

Similarity outputToInput(const FrameStats &stats)
{
    return stats.correction.inverse() * Similarity{0.0, 0.0, 0.0, 1.0 / stats.zoom};
}

double cornerJitter(const std::vector<std::array<Point2, 4>> &corners, double sigma, std::size_t first)
{
    const std::size_t n = corners.size();
    if (n < 2 || first >= n)
        return 0.0;
    const int radius = int(std::ceil(3 * sigma));
    double sum2 = 0.0;
    for (std::size_t c = 0; c < 4; ++c) {
        for (std::size_t i = first; i < n; ++i) {
            // Gaussian-weighted local line: the Gaussian low-pass wherever the window is
            // whole, and no bias on a pan where the clip's ends cut it short.
            double s0 = 0, s1 = 0, s2 = 0, x0 = 0, x1 = 0, y0 = 0, y1 = 0;
            for (int k = -radius; k <= radius; ++k) {
                const long j = long(i) + k;
                if (j < 0 || j >= long(n))
                    continue;
                const double w = std::exp(-0.5 * k * k / (sigma * sigma));
                const Point2 &p = corners[std::size_t(j)][c];
                s0 += w;
                s1 += w * k;
                s2 += w * k * k;
                x0 += w * p.x;
                x1 += w * k * p.x;
                y0 += w * p.y;
                y1 += w * k * p.y;
            }
            const double det = s0 * s2 - s1 * s1;
            const bool line = det > 1e-9 * s0 * s0;
            const double lx = line ? (s2 * x0 - s1 * x1) / det : x0 / s0;
            const double ly = line ? (s2 * y0 - s1 * y1) / det : y0 / s0;
            const double ex = corners[i][c].x - lx, ey = corners[i][c].y - ly;
            sum2 += ex * ex + ey * ey;
        }
    }
    return std::sqrt(sum2 / (4.0 * double(n - first)));
}

namespace {
// Where the frame's four corners land under each pose of `path`, its first n poses.
std::vector<std::array<Point2, 4>> pathCorners(const std::vector<Similarity> &path, int width, int height,
                                               std::size_t n)
{
    const double hx = (width - 1) * 0.5, hy = (height - 1) * 0.5;
    const std::array<Point2, 4> frame_corners{{{-hx, -hy}, {hx, -hy}, {-hx, hy}, {hx, hy}}};
    std::vector<std::array<Point2, 4>> corners(std::min(n, path.size()));
    for (std::size_t i = 0; i < corners.size(); ++i)
        for (std::size_t c = 0; c < 4; ++c)
            corners[i][c] = path[i].apply(frame_corners[c]);
    return corners;
}
} // namespace

double residualJitter(const std::vector<Similarity> &path, int width, int height, double sigma, std::size_t first)
{
    return cornerJitter(pathCorners(path, width, height, path.size()), sigma, first);
}

double intendedPathError(const std::vector<Similarity> &output_path, const std::vector<Similarity> &intended_path,
                         int width, int height)
{
    const std::size_t n = std::min(output_path.size(), intended_path.size());
    if (n == 0)
        return 0.0;
    const double hx = (width - 1) * 0.5, hy = (height - 1) * 0.5;
    const std::array<Point2, 4> corners{{{-hx, -hy}, {hx, -hy}, {-hx, hy}, {hx, hy}}};
    double sum2 = 0.0;
    for (const Point2 &corner : corners) {
        std::vector<Point2> e(n);
        double mx = 0, my = 0;
        for (std::size_t i = 0; i < n; ++i) {
            e[i] = (intended_path[i].inverse() * output_path[i]).apply(corner);
            mx += e[i].x;
            my += e[i].y;
        }
        mx /= double(n);
        my /= double(n);
        for (const Point2 &p : e)
            sum2 += (p.x - mx) * (p.x - mx) + (p.y - my) * (p.y - my);
    }
    return std::sqrt(sum2 / (4.0 * double(n)));
}

namespace {
std::vector<Similarity> relativeToIntended(const std::vector<Similarity> &output_path,
                                          const std::vector<Similarity> &intended_path)
{
    std::vector<Similarity> e;
    for (std::size_t i = 0; i < std::min(output_path.size(), intended_path.size()); ++i)
        e.push_back(intended_path[i].inverse() * output_path[i]);
    return e;
}
} // namespace

double intendedPathJitter(const std::vector<Similarity> &output_path, const std::vector<Similarity> &intended_path,
                          int width, int height, std::size_t first)
{
    return residualJitter(relativeToIntended(output_path, intended_path), width, height, 8.0, first);
}

double intendedPathMaxDeviation(const std::vector<Similarity> &output_path,
                                const std::vector<Similarity> &intended_path, int width, int height)
{
    const std::vector<Similarity> e = relativeToIntended(output_path, intended_path);
    if (e.empty())
        return 0.0;
    const double hx = (width - 1) * 0.5, hy = (height - 1) * 0.5;
    double worst = 0.0;
    for (const Point2 corner : {Point2{-hx, -hy}, Point2{hx, -hy}, Point2{-hx, hy}, Point2{hx, hy}}) {
        double mx = 0, my = 0;
        for (const Similarity &s : e) {
            const Point2 p = s.apply(corner);
            mx += p.x / double(e.size());
            my += p.y / double(e.size());
        }
        for (const Similarity &s : e) {
            const Point2 p = s.apply(corner);
            worst = std::max(worst, std::hypot(p.x - mx, p.y - my));
        }
    }
    return worst;
}

namespace {
// The fastest step of any frame corner, each corner's track smoothed by a Gaussian of sigma
// frames, over frames [first, n).
double fastestCornerStep(const std::vector<std::array<Point2, 4>> &corners, std::size_t first, double sigma)
{
    const std::size_t n = corners.size();
    const int radius = int(std::ceil(3 * sigma));
    double fastest = 0.0;
    for (std::size_t c = 0; c < 4; ++c) {
        std::vector<Point2> smooth(n);
        for (std::size_t i = 0; i < n; ++i) {
            double sw = 0, sx = 0, sy = 0;
            for (int k = -radius; k <= radius; ++k) {
                const long j = long(i) + k;
                if (j < 0 || j >= long(n))
                    continue;
                const double w = std::exp(-0.5 * k * k / (sigma * sigma));
                sw += w;
                sx += w * corners[std::size_t(j)][c].x;
                sy += w * corners[std::size_t(j)][c].y;
            }
            smooth[i] = {sx / sw, sy / sw};
        }
        // Steps whose smoothing window lies whole inside the clip: a cut window bends the ends.
        for (std::size_t i = std::max<std::size_t>(first, std::size_t(radius) + 1); i + std::size_t(radius) < n; ++i)
            fastest = std::max(fastest, std::hypot(smooth[i].x - smooth[i - 1].x, smooth[i].y - smooth[i - 1].y));
    }
    return fastest;
}
} // namespace

double pathWhip(const std::vector<Similarity> &output_path, const std::vector<Similarity> &intended_path, int width,
                int height, std::size_t first, double sigma, double still)
{
    const std::size_t n = std::min(output_path.size(), intended_path.size());
    const double pilot = fastestCornerStep(pathCorners(intended_path, width, height, n), first, sigma);
    if (pilot < still)
        return 0.0;
    return fastestCornerStep(pathCorners(output_path, width, height, n), first, sigma) / pilot;
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
