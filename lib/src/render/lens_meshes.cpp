#include "render/lens_meshes.hpp"

#include "render/frame_warper.hpp"

namespace uavstab {

namespace {
constexpr int kCell = 16;  // output pixels between nodes (the kernels' chunk)
} // namespace

LensMeshes::LensMeshes(std::shared_ptr<const LensView> lens) : lens_(std::move(lens)) {}

std::vector<WarpMesh> LensMeshes::meshes(const FrameView &frame, double zoom, const RowMatrix &row_matrix)
{
    const int planes = frame.planeCount();
    if (zoom != zoom_ || frame.format != format_ || int(view_nodes_.size()) != planes) {
        view_nodes_.clear();
        for (int p = 0; p < planes; ++p) {
            // planeMesh hands the nodes over in luma pixels and takes back plane pixels:
            // the view's luma position goes in as a "plane" position and is read back below.
            const PlaneLayout layout = planeLayout(frame.format, p);
            const double fx = layout.subsample_x, fy = layout.subsample_y;
            const double ox = (fx - 1) * 0.5, oy = (fy - 1) * 0.5;
            WarpMesh nodes = FrameWarper::planeMesh(frame, p, [&](Point2 q) {
                const Point2 v = lens_->outputToView(q, zoom);
                return Point2{(v.x - ox) / fx, (v.y - oy) / fy};
            }, kCell);
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
        std::array<double, 6> m{};
        double m_row = -1e300;
        for (int j = 0; j < nodes.rows; ++j)
            for (int i = 0; i < nodes.columns; ++i) {
                const std::size_t k = std::size_t(j) * std::size_t(nodes.columns) + std::size_t(i);
                const Point2 v{nodes.x[k], nodes.y[k]};
                // The row's matrix where the node's view row lies (rolling shutter: per row).
                if (v.y != m_row) {
                    m = row_matrix(v.y);
                    m_row = v.y;
                }
                const Point2 s = lens_->viewToInput(v, m);
                mesh.x[k] = (s.x - ox) / fx;
                mesh.y[k] = (s.y - oy) / fy;
            }
        out.push_back(std::move(mesh));
    }
    return out;
}

} // namespace uavstab
