#include "render/frame_warper.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "render/bilinear_warp.hpp"
#include "estimate/luma_extractor.hpp"

namespace uavstab {

namespace {

// What "black" means in each plane: video-range black for YUV, opaque black for RGB.
cv::Scalar blackFor(PixelFormat format, int plane)
{
    if (isYuv(format))
        return plane == 0 ? cv::Scalar(16) : cv::Scalar(128, 128);
    switch (format) {
    case PixelFormat::RGBA:
    case PixelFormat::BGRA:
    case PixelFormat::RGBx:
    case PixelFormat::BGRx:
        return {0, 0, 0, 255};
    default:
        return {0, 0, 0, 0};
    }
}

bool overlaps(const FrameView &a, const FrameView &b)
{
    for (int p = 0; p < a.planeCount(); ++p)
        for (int q = 0; q < b.planeCount(); ++q) {
            const auto *a0 = a.planes[p].data;
            const auto *a1 = a0 + std::size_t(a.planes[p].stride) * a.planeHeight(p);
            const auto *b0 = b.planes[q].data;
            const auto *b1 = b0 + std::size_t(b.planes[q].stride) * b.planeHeight(q);
            if (a0 < b1 && b0 < a1)
                return true;
        }
    return false;
}

std::array<std::uint8_t, 4> borderBytes(const cv::Scalar &black)
{
    return {std::uint8_t(black[0]), std::uint8_t(black[1]), std::uint8_t(black[2]), std::uint8_t(black[3])};
}

// Rows [y0, y1) of plane p through one matrix, as OpenCV's warpAffine draws them: the
// transforms the fast kernel does not handle and the 3- and 4-channel formats. 4-channel
// planes through warpPlaneBilinear4 (the same bytes in one pass) where this CPU has its
// kernel, the rest through OpenCV.
void warpGeneral(const FrameView &in, const FrameView &out, int p, int y0, int y1, const double plane_m[6],
                 BorderMode border_mode, const cv::Scalar &black)
{
    // 4-byte pixels: the same bytes OpenCV writes, from the one-pass kernel where there is one.
    if (planeLayout(in.format, p).channels == 4) {
        const std::array<std::uint8_t, 4> border_value = borderBytes(black);
        const PlaneSpan span{in.planes[p].data, in.planes[p].stride, in.planeWidth(p), in.planeHeight(p)};
        if (warpPlaneBilinear4(span, out.planes[p].data, out.planes[p].stride, out.planeWidth(p), y0, y1, plane_m,
                               border_mode == BorderMode::Replicate, border_value.data()))
            return;
    }
    // The stripe's first row is row y0 of the plane: shift the mapping.
    double m[6];
    std::copy(plane_m, plane_m + 6, m);
    const cv::Mat src = planeMat(in, p);
    cv::Mat dst = planeMat(out, p).rowRange(y0, y1);
    m[2] += m[1] * y0;
    m[5] += m[4] * y0;
    const cv::Mat matrix(2, 3, CV_64F, m);
    const int border = border_mode == BorderMode::Replicate ? cv::BORDER_REPLICATE : cv::BORDER_CONSTANT;
    cv::warpAffine(src, dst, matrix, dst.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, border, black);
}

// Whether planes p and p + 1 are 1-byte planes of one layout warped through equal meshes.
bool pairsWithNext(const FrameView &in, const std::vector<WarpMesh> &meshes, int p)
{
    const PlaneLayout a = planeLayout(in.format, p), b = planeLayout(in.format, p + 1);
    const WarpMesh &m = meshes[std::size_t(p)], &n = meshes[std::size_t(p + 1)];
    return a.channels == 1 && a.bytes_per_sample == 1 && b.channels == 1 && b.bytes_per_sample == 1 &&
           a.subsample_x == b.subsample_x && a.subsample_y == b.subsample_y && m.cell == n.cell &&
           m.columns == n.columns && m.rows == n.rows && m.x == n.x && m.y == n.y;
}

void checkFrames(const FrameView &in, const FrameView &out)
{
    if (!in.valid() || !out.valid() || !in.sameGeometry(out))
        throw std::invalid_argument("FrameWarper: input and output must be valid frames of one geometry");
    if (overlaps(in, out))
        throw std::invalid_argument("FrameWarper: input and output overlap");
}

// Plane rows [y0, y1) under luma rows [row_begin, row_end): chroma rows follow the luma
// rows they sit under, and the last stripe takes the plane's last row.
void planeRows(const FrameView &in, int plane, int row_begin, int row_end, int &y0, int &y1)
{
    const PlaneLayout layout = planeLayout(in.format, plane);
    y0 = row_begin / layout.subsample_y;
    y1 = row_end == in.height ? in.planeHeight(plane) : row_end / layout.subsample_y;
}

} // namespace

void FrameWarper::planeMatrix(const FrameView &frame, int plane, const Similarity &output_to_input, double m[6])
{
    planeMatrix(frame, plane, output_to_input.pixelMatrix(frame.width, frame.height), m);
}

void FrameWarper::planeMatrix(const FrameView &frame, int plane, const std::array<double, 6> &l, double m[6])
{
    const PlaneLayout layout = planeLayout(frame.format, plane);
    const double fx = layout.subsample_x, fy = layout.subsample_y;
    // Plane pixel c sits at luma position f*c + o, o = (f-1)/2. The plane transform is
    // S^-1 * L * S with S(c) = f*c + o.
    const double ox = (fx - 1) * 0.5, oy = (fy - 1) * 0.5;
    m[0] = l[0];
    m[1] = l[1] * fy / fx;
    m[2] = (l[0] * ox + l[1] * oy + l[2] - ox) / fx;
    m[3] = l[3] * fx / fy;
    m[4] = l[4];
    m[5] = (l[3] * ox + l[4] * oy + l[5] - oy) / fy;
}

void FrameWarper::warp(const FrameView &in, const FrameView &out, const Similarity &output_to_input) const
{
    warpRows(in, out, output_to_input, 0, in.height);
}

void FrameWarper::warpRows(const FrameView &in, const FrameView &out, const Similarity &output_to_input,
                           int row_begin, int row_end) const
{
    checkFrames(in, out);
    row_begin = std::clamp(row_begin, 0, in.height);
    row_end = std::clamp(row_end, row_begin, in.height);

    for (int p = 0; p < in.planeCount(); ++p) {
        const PlaneLayout layout = planeLayout(in.format, p);
        int y0, y1;
        planeRows(in, p, row_begin, row_end, y0, y1);
        if (y1 <= y0)
            continue;
        double m[6];
        planeMatrix(in, p, output_to_input, m);
        const cv::Scalar black = blackFor(in.format, p);
        const std::array<std::uint8_t, 4> border_value = borderBytes(black);
        const PlaneSpan span{in.planes[p].data, in.planes[p].stride, in.planeWidth(p), in.planeHeight(p)};
        if (layout.bytes_per_sample == 2) {
            // 16-bit samples at full depth, in their own byte order (black is 0).
            warpPlaneBilinear16(span, out.planes[p].data, out.planes[p].stride, out.planeWidth(p), y0, y1, m,
                                border_ == BorderMode::Replicate, 0, needsByteSwap(in.format));
            continue;
        }
        if (warpPlaneBilinear(span, out.planes[p].data, out.planes[p].stride, out.planeWidth(p), y0, y1,
                              layout.channels, m, border_ == BorderMode::Replicate, border_value.data()))
            continue;
        warpGeneral(in, out, p, y0, y1, m, border_, black);
    }
}

WarpMesh FrameWarper::planeMesh(const FrameView &frame, int plane,
                                const std::function<Point2(Point2)> &luma_output_to_input, int cell)
{
    const PlaneLayout layout = planeLayout(frame.format, plane);
    const double fx = layout.subsample_x, fy = layout.subsample_y;
    // Plane pixel c sits at luma position f*c + o, o = (f-1)/2 (as in planeMatrix).
    const double ox = (fx - 1) * 0.5, oy = (fy - 1) * 0.5;
    return makeWarpMesh(frame.planeWidth(plane), frame.planeHeight(plane), cell, [&](Point2 q) {
        const Point2 s = luma_output_to_input({fx * q.x + ox, fy * q.y + oy});
        return Point2{(s.x - ox) / fx, (s.y - oy) / fy};
    });
}

void FrameWarper::warpMeshRows(const FrameView &in, const FrameView &out, const std::vector<WarpMesh> &plane_meshes,
                               int row_begin, int row_end) const
{
    checkFrames(in, out);
    if (int(plane_meshes.size()) != in.planeCount())
        throw std::invalid_argument("FrameWarper: one mesh per plane");
    for (int p = 0; p < in.planeCount(); ++p)
        if (!plane_meshes[std::size_t(p)].covers(in.planeWidth(p), in.planeHeight(p)) ||
            plane_meshes[std::size_t(p)].cell % 16 != 0)
            throw std::invalid_argument("FrameWarper: a mesh does not cover its plane");
    row_begin = std::clamp(row_begin, 0, in.height);
    row_end = std::clamp(row_end, row_begin, in.height);
    const bool replicate = border_ == BorderMode::Replicate;

    for (int p = 0; p < in.planeCount(); ++p) {
        const PlaneLayout layout = planeLayout(in.format, p);
        int y0, y1;
        planeRows(in, p, row_begin, row_end, y0, y1);
        if (y1 <= y0)
            continue;
        const WarpMesh &mesh = plane_meshes[std::size_t(p)];
        const std::array<std::uint8_t, 4> border_value = borderBytes(blackFor(in.format, p));
        const PlaneSpan span{in.planes[p].data, in.planes[p].stride, in.planeWidth(p), in.planeHeight(p)};
        std::uint8_t *dst = out.planes[p].data;
        const int dst_stride = out.planes[p].stride, dst_width = out.planeWidth(p);
        if (p + 1 < in.planeCount() && pairsWithNext(in, plane_meshes, p)) {
            // The planar formats' two chroma planes: one plan for both.
            const std::array<std::uint8_t, 4> next_border = borderBytes(blackFor(in.format, p + 1));
            const MeshWarpPlane a{span, dst, dst_stride, border_value.data()};
            const MeshWarpPlane b{{in.planes[p + 1].data, in.planes[p + 1].stride, in.planeWidth(p + 1),
                                   in.planeHeight(p + 1)},
                                  out.planes[p + 1].data, out.planes[p + 1].stride, next_border.data()};
            warpPlanePairBilinearMesh(a, b, dst_width, y0, y1, mesh, replicate);
            ++p;
            continue;
        }
        // Each takes any mesh that covers its plane (checked above).
        if (layout.bytes_per_sample == 2)
            warpPlaneBilinear16Mesh(span, dst, dst_stride, dst_width, y0, y1, mesh, replicate, 0,
                                    needsByteSwap(in.format));
        else if (layout.channels == 4)
            warpPlaneBilinear4Mesh(span, dst, dst_stride, dst_width, y0, y1, mesh, replicate, border_value.data());
        else if (layout.channels == 3)
            warpPlaneBilinear3Mesh(span, dst, dst_stride, dst_width, y0, y1, mesh, replicate, border_value.data());
        else
            warpPlaneBilinearMesh(span, dst, dst_stride, dst_width, y0, y1, layout.channels, mesh, replicate,
                                  border_value.data());
    }
}

void FrameWarper::warp(const FrameView &in, const FrameView &out, const RowTransforms &output_to_input) const
{
    warpRows(in, out, output_to_input, 0, in.height);
}

void FrameWarper::warpRows(const FrameView &in, const FrameView &out, const RowTransforms &output_to_input,
                           int row_begin, int row_end) const
{
    if (output_to_input.isConstant()) {
        warpRows(in, out, output_to_input.first(), row_begin, row_end);
        return;
    }
    checkFrames(in, out);
    row_begin = std::clamp(row_begin, 0, in.height);
    row_end = std::clamp(row_end, row_begin, in.height);

    const RowMatrices luma(output_to_input, in.width, in.height);
    std::vector<std::array<double, 6>> rows;  // plane row y0 + i's matrix
    for (int p = 0; p < in.planeCount(); ++p) {
        const PlaneLayout layout = planeLayout(in.format, p);
        int y0, y1;
        planeRows(in, p, row_begin, row_end, y0, y1);
        if (y1 <= y0)
            continue;
        // Plane row c sits under luma row f*c + (f-1)/2 (as in planeMatrix).
        const double offset_y = (layout.subsample_y - 1) * 0.5;
        rows.resize(std::size_t(y1 - y0));
        for (int y = y0; y < y1; ++y)
            planeMatrix(in, p, luma.at(layout.subsample_y * y + offset_y), rows[std::size_t(y - y0)].data());
        const cv::Scalar black = blackFor(in.format, p);
        const std::array<std::uint8_t, 4> border_value = borderBytes(black);
        const bool replicate = border_ == BorderMode::Replicate;
        const PlaneSpan span{in.planes[p].data, in.planes[p].stride, in.planeWidth(p), in.planeHeight(p)};
        std::uint8_t *dst = out.planes[p].data;
        const int dst_stride = out.planes[p].stride, dst_width = out.planeWidth(p);
        if (layout.bytes_per_sample == 2) {
            warpPlaneBilinear16Rows(span, dst, dst_stride, dst_width, y0, y1, rows.data(), replicate, 0,
                                    needsByteSwap(in.format));
            continue;
        }
        // Each row as the single-transform warp would draw it with its matrix: runs of rows
        // the fast kernel handles in one call; the rest (large rotations or zooms, 3- and
        // 4-channel pixels) through OpenCV, one call per run of equal matrices.
        const auto matrix = [&](int y) -> const std::array<double, 6> & { return rows[std::size_t(y - y0)]; };
        const auto handled = [&](int y) { return warpPlaneBilinearHandles(span, layout.channels, matrix(y).data()); };
        for (int y = y0; y < y1;) {
            int end = y + 1;
            if (handled(y)) {
                while (end < y1 && handled(end))
                    ++end;
                warpPlaneBilinearRows(span, dst, dst_stride, dst_width, y, end, layout.channels,
                                      &rows[std::size_t(y - y0)], replicate, border_value.data());
            } else {
                while (end < y1 && matrix(end) == matrix(y) && !handled(end))
                    ++end;
                warpGeneral(in, out, p, y, end, matrix(y).data(), border_, black);
            }
            y = end;
        }
    }
}

} // namespace uavstab
