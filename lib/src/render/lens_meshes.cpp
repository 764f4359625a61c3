#include "render/lens_meshes.hpp"

#include <algorithm>
#include <cmath>

#include "render/frame_warper.hpp"

namespace uavstab {

namespace {

// The kernels are fastest with a node every 16 px (their chunk).
constexpr int kWarpCell = 16;

// Output pixels between the nodes the chain is evaluated at. Interpolating the lens's chain
// bilinearly errs by about cell^2 / width: the 150-degree fisheye of the tests
// (tests/synthetic) with a typical correction, worst over the frame: 640x360 cell 16
// 0.0034 px, 1920x1080 cell 16 0.0012, 32 0.0046, 48 0.0104. 16 * round(sqrt(width / 640))
// keeps it below 0.005 px, far below the warp's 1/64-px positions, with a quarter of the
// nodes (each a Newton solve once per stream and a distortion every frame) at 1080p; the
// warp's 16-px mesh is then interpolated from them. A rectified output bends far more
// between nodes (the lens's squeeze, at the pinhole view's edges): 0.030 px at 1080p with
// 16, 0.119 with 32; it keeps 16.
int chainCellFor(int width, LensOutput output)
{
    if (output == LensOutput::Rectified)
        return kWarpCell;
    return kWarpCell * std::max(1, int(std::lround(std::sqrt(width / 640.0))));
}

} // namespace

LensMeshes::LensMeshes(std::shared_ptr<const LensView> lens) : lens_(std::move(lens)) {}

std::vector<WarpMesh> LensMeshes::meshes(const FrameView &frame, double zoom, const RowMatrices *rows,
                                         const std::array<double, 6> &single)
{
    const int planes = frame.planeCount();
    if (zoom != zoom_ || frame.format != format_ || int(view_nodes_.size()) != planes) {
        view_nodes_.clear();
        for (int p = 0; p < planes; ++p) {
            // planeMesh hands the nodes over in luma pixels and stores what comes back in
            // the plane's pixels: taken back to luma pixels below.
            const PlaneLayout layout = planeLayout(frame.format, p);
            const double fx = layout.subsample_x, fy = layout.subsample_y;
            const double ox = (fx - 1) * 0.5, oy = (fy - 1) * 0.5;
            WarpMesh nodes = FrameWarper::planeMesh(
                frame, p, [&](Point2 q) { return lens_->outputToView(q, zoom); }, chainCellFor(frame.width, lens_->output()));
            for (std::size_t k = 0; k < nodes.x.size(); ++k) {
                nodes.x[k] = fx * nodes.x[k] + ox;
                nodes.y[k] = fy * nodes.y[k] + oy;
            }
            view_nodes_.push_back(std::move(nodes));
        }
        zoom_ = zoom;
        format_ = frame.format;
    }

    std::vector<WarpMesh> out;
    out.reserve(std::size_t(planes));
    for (int p = 0; p < planes; ++p) {
        const PlaneLayout layout = planeLayout(frame.format, p);
        // I420's second chroma plane is laid out as its first: the same mesh.
        if (p > 0 && view_nodes_[std::size_t(p)].columns == view_nodes_[std::size_t(p - 1)].columns &&
            view_nodes_[std::size_t(p)].rows == view_nodes_[std::size_t(p - 1)].rows &&
            layout.subsample_x == planeLayout(frame.format, p - 1).subsample_x &&
            layout.subsample_y == planeLayout(frame.format, p - 1).subsample_y) {
            out.push_back(out.back());
            continue;
        }
        const double fx = layout.subsample_x, fy = layout.subsample_y;
        const double ox = (fx - 1) * 0.5, oy = (fy - 1) * 0.5;
        const WarpMesh &nodes = view_nodes_[std::size_t(p)];
        WarpMesh mesh = nodes;
        for (std::size_t k = 0; k < nodes.x.size(); ++k) {
            const Point2 v{nodes.x[k], nodes.y[k]};
            // Rolling shutter: the matrix of the row where the node lies in the view.
            const Point2 s = lens_->viewToInput(v, rows ? rows->at(v.y) : single);
            mesh.x[k] = (s.x - ox) / fx;
            mesh.y[k] = (s.y - oy) / fy;
        }
        out.push_back(mesh.cell == kWarpCell ? std::move(mesh)
                                             : refineWarpMesh(mesh, frame.planeWidth(p), frame.planeHeight(p), kWarpCell));
    }
    return out;
}

} // namespace uavstab
