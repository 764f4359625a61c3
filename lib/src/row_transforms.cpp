#include "uavstab/row_transforms.hpp"

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

RowTransforms rollingShutterWarp(const Similarity &output_to_input, const RowMotion &rows, int height)
{
    if (rows.empty() || height < 2)
        return RowTransforms(output_to_input);
    constexpr int kAnchors = 24;  // intervals: the offsets vary smoothly over 12 bands
    std::vector<double> anchors;
    std::vector<Similarity> transforms;
    const double centre = 0.5 * (height - 1);
    for (int j = 0; j <= kAnchors; ++j) {
        const double y = (height - 1) * double(j) / kAnchors;
        const double input_row = output_to_input.apply({0.0, y - centre}).y;
        anchors.push_back(y);
        transforms.push_back(rows.at(input_row) * output_to_input);
    }
    return RowTransforms(std::move(anchors), std::move(transforms));
}

} // namespace uavstab
