// Transforms that vary down the frame, for rolling-shutter correction: a sensor that reads
// its rows one after another sees each row at a different moment, so each output row needs
// its own output -> input transform.
#pragma once

#include <array>
#include <vector>

#include "estimate/rolling_shutter_estimator.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

// K output -> input transforms anchored at output rows (luma rows, strictly increasing;
// fractional allowed), linearly interpolated between anchors as 2x3 pixel matrices (entry
// by entry) and held constant beyond the first and last anchor. No anchor is the identity;
// one anchor, or all transforms equal, is that single transform at every row.
class RowTransforms {
public:
    // Throws std::invalid_argument unless there is one transform per anchor and the anchors
    // are finite and strictly increasing. (No default constructor: FrameWarper::warp(in,
    // out, {}) stays the identity Similarity.)
    RowTransforms(std::vector<double> anchor_rows, std::vector<Similarity> transforms);
    explicit RowTransforms(const Similarity &single) : RowTransforms({0.0}, {single}) {}

    const std::vector<double> &anchorRows() const { return anchor_rows_; }
    const std::vector<Similarity> &transforms() const { return transforms_; }
    // The same transform at every row: fewer than two anchors, or all transforms equal.
    bool isConstant() const;
    // That transform (the identity without anchors); the first one if not constant.
    Similarity first() const;

private:
    std::vector<double> anchor_rows_;
    std::vector<Similarity> transforms_;
};

// A RowTransforms' pixel matrices for one frame size, to evaluate row by row.
class RowMatrices {
public:
    RowMatrices(const RowTransforms &rows, int width, int height);

    // The row-major 2x3 luma pixel matrix (output pixel -> input pixel) at output row y.
    // Fractional y: chroma rows sit between luma rows.
    std::array<double, 6> at(double y) const;

private:
    std::vector<double> anchor_rows_;
    std::vector<std::array<double, 6>> matrices_;
};

// The warp that also undoes a frame's rolling shutter: each output row samples the input
// where the frame captured the point the stabilizing transform maps it to (the row offset
// at that input row); anchored at 25 output rows, linear in between. Where a row's offset
// would make it read past the input's edge it is shortened (the crop room bounds it). A
// frame of width x height; empty `rows`: output_to_input at every row.
RowTransforms rollingShutterWarp(const Similarity &output_to_input, const RowMotion &rows, int width, int height);

} // namespace uavstab
