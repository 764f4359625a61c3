#include "uavstab/framing.hpp"

#include <cmath>

namespace uavstab {

namespace {
constexpr int kBisectionSteps = 14;  // 1/16384 of the correction
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
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < kBisectionSteps; ++i) {
        const double mid = 0.5 * (lo + hi);
        (coversFrame(mapping(scaleCorrection(correction, mid)), width, height) ? lo : hi) = mid;
    }
    f.fraction = lo;
    f.applied = scaleCorrection(correction, lo);
    f.output_to_input = mapping(f.applied);
    return f;
}

} // namespace uavstab
