// The warp's meshes for frames seen through a lens (lens/lens_view.hpp): one per plane,
// output pixel -> input pixel through the whole chain, for FrameWarper's mesh warp. Where a
// node sits in the undistorted view depends on the lens and the crop zoom only, so it is
// worked out once per stream (an undistortion is a Newton solve); each frame then costs one
// matrix and one distortion per node: 2 700 nodes at 1080p I420 (a node every 32 px, the
// warp's 16-px mesh interpolated from them).
#pragma once

#include <array>
#include <memory>
#include <vector>

#include "lens/lens_view.hpp"
#include "render/row_transforms.hpp"
#include "render/warp_mesh.hpp"
#include "uavstab/frame_view.hpp"

namespace uavstab {

class LensMeshes {
public:
    explicit LensMeshes(std::shared_ptr<const LensView> lens);

    const std::shared_ptr<const LensView> &lens() const { return lens_; }

    // One mesh per plane of a frame of `frame`'s geometry (the lens's size), for the luma
    // output_to_input pixel matrix in the undistorted view: `rows` at each output row
    // (rolling shutter) or, without, `single` everywhere.
    std::vector<WarpMesh> meshes(const FrameView &frame, double zoom, const RowMatrices *rows,
                                 const std::array<double, 6> &single);

private:
    std::shared_ptr<const LensView> lens_;
    // Per plane: the nodes' places in the undistorted view, luma pixels; for this zoom and format.
    double zoom_ = 0.0;
    PixelFormat format_ = PixelFormat::I420;
    std::vector<WarpMesh> view_nodes_;
};

} // namespace uavstab
