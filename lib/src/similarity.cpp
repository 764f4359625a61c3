#include "uavstab/similarity.hpp"

#include <cmath>

namespace uavstab {

Point2 Similarity::apply(Point2 p) const
{
    const double c = scale * std::cos(angle);
    const double s = scale * std::sin(angle);
    return {c * p.x - s * p.y + dx, s * p.x + c * p.y + dy};
}

Similarity Similarity::inverse() const
{
    Similarity inv;
    inv.scale = 1.0 / scale;
    inv.angle = -angle;
    // p = R^-1 (q - t) / s
    const Point2 t = Similarity{0.0, 0.0, inv.angle, inv.scale}.apply({dx, dy});
    inv.dx = -t.x;
    inv.dy = -t.y;
    return inv;
}

bool Similarity::isIdentity(double eps) const
{
    return std::abs(dx) <= eps && std::abs(dy) <= eps && std::abs(angle) <= eps &&
           std::abs(scale - 1.0) <= eps;
}

std::array<double, 6> Similarity::pixelMatrix(int width, int height) const
{
    const double cx = (width - 1) * 0.5;
    const double cy = (height - 1) * 0.5;
    const double c = scale * std::cos(angle);
    const double s = scale * std::sin(angle);
    // q_pix = M (p_pix - centre) + t + centre
    return {c, -s, dx + cx - (c * cx - s * cy), s, c, dy + cy - (s * cx + c * cy)};
}

Similarity operator*(const Similarity &a, const Similarity &b)
{
    Similarity r;
    r.scale = a.scale * b.scale;
    r.angle = a.angle + b.angle;
    const Point2 t = a.apply({b.dx, b.dy});
    r.dx = t.x;
    r.dy = t.y;
    return r;
}

} // namespace uavstab
