// Image composition: draws the stabilized frame by resampling every plane of the input
// through one transform (chroma planes through the same transform at chroma scale), or
// through a transform per output row (rolling-shutter correction), or through a mesh per
// plane (lens correction).
#pragma once

#include <functional>
#include <type_traits>
#include <vector>

#include "uavstab/config.hpp"
#include "uavstab/frame_view.hpp"
#include "render/row_transforms.hpp"
#include "render/warp_mesh.hpp"
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

    // Through a mesh per plane (lens correction: a non-linear map sampled on a coarse grid,
    // bilinear between nodes), one pass per plane. plane_meshes[p] is in plane p's pixels
    // and covers that plane (planeMesh builds them). Throws std::invalid_argument when there
    // is not one mesh per plane or a mesh does not cover its plane. Every pixel format:
    // 8-bit luma and chroma planes through warpPlaneBilinearMesh, 4-byte pixels through
    // warpPlaneBilinear4Mesh, 3-byte pixels and 16-bit samples per pixel (slower).
    // (Templates only so that warp(in, out, {}) stays the identity Similarity: a braced list
    // deduces no Meshes.)
    template <class Meshes, std::enable_if_t<std::is_same_v<Meshes, std::vector<WarpMesh>>, int> = 0>
    void warp(const FrameView &in, const FrameView &out, const Meshes &plane_meshes) const
    {
        warpMeshRows(in, out, plane_meshes, 0, in.height);
    }
    template <class Meshes, std::enable_if_t<std::is_same_v<Meshes, std::vector<WarpMesh>>, int> = 0>
    void warpRows(const FrameView &in, const FrameView &out, const Meshes &plane_meshes, int row_begin,
                  int row_end) const
    {
        warpMeshRows(in, out, plane_meshes, row_begin, row_end);
    }
    // Plane `plane`'s mesh for a map of luma pixels (output -> input), accounting for chroma
    // subsampling as planeMatrix does (chroma sample centres between their luma samples).
    static WarpMesh planeMesh(const FrameView &frame, int plane,
                              const std::function<Point2(Point2)> &luma_output_to_input, int cell = 16);

    // A plane's transform (row-major 2x3, output pixel -> input pixel) for a frame's
    // luma transform, accounting for chroma subsampling (chroma sample centres assumed
    // centred between their luma samples).
    static void planeMatrix(const FrameView &frame, int plane, const Similarity &output_to_input, double m[6]);
    // The same from the luma transform's pixel matrix (Similarity::pixelMatrix).
    static void planeMatrix(const FrameView &frame, int plane, const std::array<double, 6> &luma, double m[6]);

private:
    void warpMeshRows(const FrameView &in, const FrameView &out, const std::vector<WarpMesh> &plane_meshes,
                      int row_begin, int row_end) const;

    BorderMode border_;
};

} // namespace uavstab
