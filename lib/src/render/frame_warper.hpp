// Image composition: draws the stabilized frame by resampling every plane of the input
// through one transform (chroma planes through the same transform at chroma scale), or
// through a transform per output row (rolling-shutter correction).
#pragma once

#include "uavstab/config.hpp"
#include "uavstab/frame_view.hpp"
#include "render/row_transforms.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

class FrameWarper {
public:
    explicit FrameWarper(BorderMode border = BorderMode::Black) : border_(border) {}

    // out(q) = in(output_to_input(q)) for every pixel q, bilinear. `out` has `in`'s
    // geometry, is written in place (no allocation) and must not overlap `in`. 4-byte
    // formats (BGRx, RGBA...) get the bytes OpenCV's warpAffine writes.
    void warp(const FrameView &in, const FrameView &out, const Similarity &output_to_input) const;

    // Rows [row_begin, row_end) of every plane's luma-scaled extent, so that several
    // workers can share one frame. Chroma rows follow the luma rows they sit under.
    void warpRows(const FrameView &in, const FrameView &out, const Similarity &output_to_input,
                  int row_begin, int row_end) const;

    // The same with a transform per output row, in one pass: every plane row is warped by
    // the luma transform at the luma row it sits under, and gets the bytes the
    // single-transform warp would write there with that transform. A constant
    // RowTransforms is the single-transform warp. Allocates a matrix per plane row.
    void warp(const FrameView &in, const FrameView &out, const RowTransforms &output_to_input) const;
    void warpRows(const FrameView &in, const FrameView &out, const RowTransforms &output_to_input, int row_begin,
                  int row_end) const;

    // A plane's transform (row-major 2x3, output pixel -> input pixel) for a frame's
    // luma transform, accounting for chroma subsampling (chroma sample centres assumed
    // centred between their luma samples).
    static void planeMatrix(const FrameView &frame, int plane, const Similarity &output_to_input, double m[6]);
    // The same from the luma transform's pixel matrix (Similarity::pixelMatrix).
    static void planeMatrix(const FrameView &frame, int plane, const std::array<double, 6> &luma, double m[6]);

private:
    BorderMode border_;
};

} // namespace uavstab
