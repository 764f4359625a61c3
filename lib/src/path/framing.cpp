#include "path/framing.hpp"

#include <algorithm>
#include <cmath>

namespace uavstab {

namespace {
constexpr int kBisectionSteps = 14;  // 1/16384 of the correction
constexpr double kMaxAngle = 0.7;    // radians; no crop leaves room for more
}

double zoomForCrop(double crop)
{
    return 1.0 / (1.0 - crop);
}

Similarity scaleCorrection(const Similarity &c, double t)
{
    return {c.dx * t, c.dy * t, c.angle * t, std::pow(c.scale, t)};
}

bool coversFrame(const Similarity &output_to_input, int width, int height)
{
    const double hx = (width - 1) * 0.5, hy = (height - 1) * 0.5;
    const double tolerance = 1e-6;
    for (const Point2 corner : {Point2{-hx, -hy}, Point2{hx, -hy}, Point2{-hx, hy}, Point2{hx, hy}}) {
        const Point2 p = output_to_input.apply(corner);
        if (std::abs(p.x) > hx + tolerance || std::abs(p.y) > hy + tolerance)
            return false;
    }
    return true;
}

Framing frameOutput(const Similarity &correction, int width, int height, double crop, bool limit_to_crop)
{
    Framing f;
    f.zoom = zoomForCrop(crop);
    const Similarity unzoom{0.0, 0.0, 0.0, 1.0 / f.zoom};
    auto mapping = [&](const Similarity &c) { return c.inverse() * unzoom; };

    f.applied = correction;
    f.output_to_input = mapping(correction);
    if (!limit_to_crop || coversFrame(f.output_to_input, width, height))
        return f;

    // Largest share of the correction whose output is still all picture.
    f.fraction = largestCoveredShare(correction, f.zoom, [&](const Similarity &output_to_input) {
        return coversFrame(output_to_input, width, height);
    });
    f.applied = scaleCorrection(correction, f.fraction);
    f.output_to_input = mapping(f.applied);
    return f;
}

double largestCoveredShare(const Similarity &correction, double zoom,
                           const std::function<bool(const Similarity &output_to_input)> &covers)
{
    const Similarity unzoom{0.0, 0.0, 0.0, 1.0 / zoom};
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < kBisectionSteps; ++i) {
        const double mid = 0.5 * (lo + hi);
        (covers(scaleCorrection(correction, mid).inverse() * unzoom) ? lo : hi) = mid;
    }
    return lo;
}

CropWindow::CropWindow(int width, int height, double zoom)
    : hx((width - 1) * 0.5), hy((height - 1) * 0.5), wx(hx / zoom), wy(hy / zoom)
{
}

Point2 CropWindow::translationRoom(double angle, double scale) const
{
    const double c = std::abs(std::cos(angle)), s = std::abs(std::sin(angle));
    return {hx - scale * (wx * c + wy * s), hy - scale * (wx * s + wy * c)};
}

double CropWindow::angleRoom(double scale, double reserve) const
{
    // The window's extent along x, scale * (wx cos a + wy sin a) = scale * R cos(a - phi),
    // grows with a up to phi = atan2(wy, wx) (and likewise along y), which is far beyond
    // any crop: the largest angle is where the first extent reaches what the reserve leaves.
    auto largest = [scale](double along, double across, double limit) {
        const double r = std::hypot(along, across);
        const double allowed = limit / scale;
        if (allowed < along)
            return 0.0;  // not even the unrotated window fits
        if (allowed >= r)
            return kMaxAngle;
        return std::min(kMaxAngle, std::atan2(across, along) - std::acos(allowed / r));
    };
    const double limit_x = hx - reserve * std::max(0.0, hx - wx);
    const double limit_y = hy - reserve * std::max(0.0, hy - wy);
    return std::min(largest(wx, wy, limit_x), largest(wy, wx, limit_y));
}

} // namespace uavstab
