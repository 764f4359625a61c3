#include "render/row_transforms.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace uavstab {

namespace {

bool equal(const Similarity &a, const Similarity &b)
{
    return a.dx == b.dx && a.dy == b.dy && a.angle == b.angle && a.scale == b.scale;
}

} // namespace

RowTransforms::RowTransforms(std::vector<double> anchor_rows, std::vector<Similarity> transforms)
    : anchor_rows_(std::move(anchor_rows)), transforms_(std::move(transforms))
{
    if (anchor_rows_.size() != transforms_.size())
        throw std::invalid_argument("RowTransforms: one transform per anchor row");
    for (std::size_t i = 0; i < anchor_rows_.size(); ++i)
        if (!std::isfinite(anchor_rows_[i]) || (i > 0 && !(anchor_rows_[i] > anchor_rows_[i - 1])))
            throw std::invalid_argument("RowTransforms: anchor rows must be finite and strictly increasing");
}

bool RowTransforms::isConstant() const
{
    return std::all_of(transforms_.begin(), transforms_.end(),
                       [&](const Similarity &t) { return equal(t, transforms_.front()); });
}

Similarity RowTransforms::first() const
{
    return transforms_.empty() ? Similarity::identity() : transforms_.front();
}

RowMatrices::RowMatrices(const RowTransforms &rows, int width, int height) : anchor_rows_(rows.anchorRows())
{
    if (rows.transforms().empty()) {
        anchor_rows_ = {0.0};
        matrices_ = {Similarity::identity().pixelMatrix(width, height)};
        return;
    }
    matrices_.reserve(rows.transforms().size());
    for (const Similarity &t : rows.transforms())
        matrices_.push_back(t.pixelMatrix(width, height));
}

std::array<double, 6> RowMatrices::at(double y) const
{
    // First anchor above y: y lies between anchors i - 1 and i.
    const std::size_t i = std::size_t(std::upper_bound(anchor_rows_.begin(), anchor_rows_.end(), y) -
                                      anchor_rows_.begin());
    if (i == 0)
        return matrices_.front();
    if (i == anchor_rows_.size())
        return matrices_.back();
    const double t = (y - anchor_rows_[i - 1]) / (anchor_rows_[i] - anchor_rows_[i - 1]);
    const std::array<double, 6> &a = matrices_[i - 1], &b = matrices_[i];
    // a + t (b - a), not (1 - t) a + t b: entries equal at both anchors stay exactly equal.
    std::array<double, 6> m;
    for (int k = 0; k < 6; ++k)
        m[k] = a[k] + t * (b[k] - a[k]);
    return m;
}

RowTransforms rollingShutterWarp(const Similarity &output_to_input, const RowMotion &rows, int width, int height)
{
    if (rows.empty() || height < 2)
        return RowTransforms(output_to_input);
    constexpr int kAnchors = 24;  // intervals: the offsets vary smoothly over 12 bands
    std::vector<double> anchors;
    std::vector<Similarity> transforms;
    const double half_w = 0.5 * (width - 1), half_h = 0.5 * (height - 1);
    // Whether both ends of output row y (centred) read inside the input frame.
    const auto inside = [&](const Similarity &t, double y) {
        for (double x : {-half_w, half_w}) {
            const Point2 p = t.apply({x, y});
            if (std::abs(p.x) > half_w || std::abs(p.y) > half_h)
                return false;
        }
        return true;
    };
    for (int j = 0; j <= kAnchors; ++j) {
        const double y = (height - 1) * double(j) / kAnchors;
        const double input_row = output_to_input.apply({0.0, y - half_h}).y;
        const Similarity offset = rows.at(input_row);
        const auto scaled = [&](double f) {
            return Similarity{f * offset.dx, f * offset.dy, f * offset.angle, 1.0} * output_to_input;
        };
        // The crop room bounds the correction as it bounds the stabilizing one: a row
        // offset that would read past the input's edge is shortened until it does not.
        Similarity t = scaled(1.0);
        if (!inside(t, y - half_h) && inside(output_to_input, y - half_h)) {
            double lo = 0.0, hi = 1.0;
            for (int k = 0; k < 12; ++k) {
                const double mid = 0.5 * (lo + hi);
                (inside(scaled(mid), y - half_h) ? lo : hi) = mid;
            }
            t = scaled(lo);
        }
        anchors.push_back(y);
        transforms.push_back(t);
    }
    return RowTransforms(std::move(anchors), std::move(transforms));
}

} // namespace uavstab
