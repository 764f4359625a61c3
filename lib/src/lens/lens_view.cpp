#include "lens/lens_view.hpp"

#include <algorithm>
#include <cmath>

namespace uavstab {

namespace {
// Points along each edge of the output checked for coverage: a lens bends the edges, so
// the corners alone do not bound them.
constexpr int kEdgeSamples = 32;
constexpr double kTolerance = 1e-6;
} // namespace

LensView::LensView(const LensModel &lens, LensOutput output, int width, int height)
    : lens_(lens), output_(output), width_(width), height_(height), cx_((width - 1) * 0.5), cy_((height - 1) * 0.5)
{
}

Point2 LensView::undistortCentred(Point2 p) const
{
    const Point2 u = lens_.undistort({p.x + cx_, p.y + cy_});
    return {u.x - cx_, u.y - cy_};
}

Point2 LensView::outputToView(Point2 q, double zoom) const
{
    if (output_ == LensOutput::Rectified)
        return q;
    // The crop zoom in the lens's picture, then into the pinhole view, and the zoom undone
    // there again: output_to_input brings it back.
    const Point2 d{cx_ + (q.x - cx_) / zoom, cy_ + (q.y - cy_) / zoom};
    const Point2 u = lens_.undistort(d);
    return {cx_ + (u.x - cx_) * zoom, cy_ + (u.y - cy_) * zoom};
}

Point2 LensView::viewToInput(Point2 v, const std::array<double, 6> &m) const
{
    return lens_.distort({m[0] * v.x + m[1] * v.y + m[2], m[3] * v.x + m[4] * v.y + m[5]});
}

std::vector<Point2> LensView::edgeInView(double zoom) const
{
    const double w1 = width_ - 1.0, h1 = height_ - 1.0;
    std::vector<Point2> edge;
    edge.reserve(4 * (kEdgeSamples + 1));
    for (int i = 0; i <= kEdgeSamples; ++i) {
        const double t = double(i) / kEdgeSamples;
        for (const Point2 q : {Point2{t * w1, 0.0}, Point2{t * w1, h1}, Point2{0.0, t * h1}, Point2{w1, t * h1}})
            edge.push_back(outputToView(q, zoom));
    }
    return edge;
}

bool LensView::coversFrame(const Similarity &output_to_input, const std::vector<Point2> &edge_in_view) const
{
    const std::array<double, 6> m = output_to_input.pixelMatrix(width_, height_);
    const double w1 = width_ - 1.0, h1 = height_ - 1.0;
    for (const Point2 &v : edge_in_view) {
        const Point2 p = viewToInput(v, m);
        if (!(p.x >= -kTolerance && p.y >= -kTolerance && p.x <= w1 + kTolerance && p.y <= h1 + kTolerance))
            return false;
    }
    return true;
}

} // namespace uavstab
