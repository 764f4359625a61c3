// The mesh warp (lens correction): a source position per node of a 16-px output grid,
// bilinear between nodes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "buffer_slot.hpp"
#include "estimate/luma_extractor.hpp"  // needsByteSwap
#include "render/bilinear_warp.hpp"
#include "render/frame_warper.hpp"
#include "render/warp_mesh.hpp"

using namespace uavstab;
using test::noiseFrame;

namespace {

constexpr WarpKernel kKernels[] = {WarpKernel::Scalar, WarpKernel::Simd128, WarpKernel::Avx2};

// A lens-like map about the centre of a width x height plane: radial distortion k (barrel
// < 0 < pincushion at the corners, r normalised by the half diagonal), then a rotation
// (cos, sin given: no libm in the inputs), a zoom and a shift.
struct LensMap {
    double cx, cy, norm2, k, cos_a, sin_a, scale, dx, dy;
    LensMap(int width, int height, double k_, double sin_a_, double scale_, double dx_, double dy_)
        : cx(0.5 * (width - 1)), cy(0.5 * (height - 1)), norm2(0.25 * (double(width) * width + double(height) * height)),
          k(k_), cos_a(1.0 - 0.5 * sin_a_ * sin_a_), sin_a(sin_a_), scale(scale_), dx(dx_), dy(dy_)
    {
    }
    Point2 operator()(Point2 p) const
    {
        const double ux = p.x - cx, uy = p.y - cy;
        const double f = scale * (1.0 + k * (ux * ux + uy * uy) / norm2);
        return {cx + dx + f * (cos_a * ux - sin_a * uy), cy + dy + f * (sin_a * ux + cos_a * uy)};
    }
};

// Bilinear in double at (sx, sy), channel c of `channels`: taps outside read `border` or,
// with replicate, the nearest edge sample. Samples of 1 or 2 bytes (native order).
double referenceSample(const PlaneSpan &src, int channels, int bytes, int c, double sx, double sy, bool replicate,
                       double border)
{
    if (std::isnan(sx) || std::isnan(sy))
        return border;
    sx = std::clamp(sx, -4.0, src.width + 4.0);
    sy = std::clamp(sy, -4.0, src.height + 4.0);
    const double fx0 = std::floor(sx), fy0 = std::floor(sy);
    const long ix = long(fx0), iy = long(fy0);
    const double fx = sx - fx0, fy = sy - fy0;
    const auto tap = [&](long x, long y) -> double {
        if (!(x >= 0 && y >= 0 && x < src.width && y < src.height)) {
            if (!replicate)
                return border;
            x = std::clamp(x, 0L, long(src.width) - 1);
            y = std::clamp(y, 0L, long(src.height) - 1);
        }
        const std::uint8_t *p = src.data + y * src.stride + (x * channels + c) * bytes;
        if (bytes == 1)
            return *p;
        std::uint16_t v;
        std::memcpy(&v, p, 2);
        return v;
    };
    const double t = tap(ix, iy) + (tap(ix + 1, iy) - tap(ix, iy)) * fx;
    const double b = tap(ix, iy + 1) + (tap(ix + 1, iy + 1) - tap(ix, iy + 1)) * fx;
    return t + (b - t) * fy;
}

// Smooth content: 128 + a sum of two waves of amplitude `amplitude` in all, neighbours at
// most ~0.5 amplitude apart. Channel c shifts the phase.
std::uint8_t smoothValue(int x, int y, int c, double amplitude)
{
    const double v = 128.0 + amplitude * (0.55 * std::sin(0.5 * x + 0.3 * y + 1.7 * c) +
                                          0.45 * std::cos(0.2 * x - 0.4 * y + 0.9 * c));
    return std::uint8_t(std::lround(v));
}

struct TestPlane {
    int width, height, channels, stride;
    std::vector<std::uint8_t> bytes;  // exactly as long as the last row: reads past it are out of bounds
    PlaneSpan span() const { return {bytes.data(), stride, width, height}; }
};

TestPlane noisePlane(std::mt19937 &rng, int width, int height, int channels, int padding)
{
    TestPlane p{width, height, channels, width * channels + padding, {}};
    p.bytes.resize(std::size_t(p.stride) * (height - 1) + std::size_t(width) * channels);
    for (std::uint8_t &b : p.bytes)
        b = std::uint8_t(rng());
    return p;
}

TestPlane smoothPlane(int width, int height, int channels, int padding, double amplitude)
{
    TestPlane p{width, height, channels, width * channels + padding, {}};
    p.bytes.resize(std::size_t(p.stride) * (height - 1) + std::size_t(width) * channels, 0);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            for (int c = 0; c < channels; ++c)
                p.bytes[std::size_t(y) * p.stride + std::size_t(x) * channels + c] = smoothValue(x, y, c, amplitude);
    return p;
}

} // namespace

TEST(WarpMesh, CoversThePlaneWithNodesEverySixteenPixels)
{
    const auto identity = [](Point2 p) { return p; };
    const WarpMesh a = makeWarpMesh(67, 41, 16, identity);
    EXPECT_EQ(6, a.columns);  // ceil(66 / 16) + 1
    EXPECT_EQ(4, a.rows);     // ceil(40 / 16) + 1
    EXPECT_EQ(2, makeWarpMesh(1, 1, 16, identity).columns);
    EXPECT_EQ(2, makeWarpMesh(17, 17, 16, identity).columns);  // the last pixel is node 1
    EXPECT_EQ(3, makeWarpMesh(18, 18, 16, identity).columns);
    EXPECT_EQ(121, makeWarpMesh(1920, 1080, 16, identity).columns);
    EXPECT_EQ(69, makeWarpMesh(1920, 1080, 16, identity).rows);
    EXPECT_EQ(4, makeWarpMesh(67, 41, 32, identity).columns);  // ceil(66 / 32) + 1
    EXPECT_TRUE(a.covers(67, 41));
    EXPECT_FALSE(a.covers(100, 41));
    EXPECT_THROW(makeWarpMesh(67, 41, 24, identity), std::invalid_argument);
    EXPECT_THROW(makeWarpMesh(67, 41, 0, identity), std::invalid_argument);
    EXPECT_THROW(makeWarpMesh(0, 41, 16, identity), std::invalid_argument);
}

TEST(WarpMesh, AtReproducesTheNodesAndIsLinearAlongARowInsideACell)
{
    const LensMap lens(203, 77, -0.2, 0.03, 1.05, 2.5, -1.5);
    const WarpMesh mesh = makeWarpMesh(203, 77, 16, lens);
    for (int j = 0; j < mesh.rows; ++j)
        for (int i = 0; i < mesh.columns; ++i) {
            const Point2 n = lens({16.0 * i, 16.0 * j});
            const Point2 at = mesh.at(16.0 * i, 16.0 * j);
            EXPECT_EQ(n.x, at.x) << i << "," << j;  // exactly
            EXPECT_EQ(n.y, at.y) << i << "," << j;
        }
    std::vector<double> row_x(std::size_t(mesh.columns)), row_y(row_x.size());
    double largest_bend = 0.0;  // between cells: the mesh follows the lens' curve
    for (int y : {0, 5, 16, 37, 76}) {
        mesh.rowAt(y, row_x.data(), row_y.data());
        for (int x = 0; x + 2 < 203; ++x) {
            const Point2 a = mesh.at(x, y), b = mesh.at(x + 1, y), c = mesh.at(x + 2, y);
            const Point2 along = mesh.alongRow(row_x.data(), row_y.data(), x);
            ASSERT_EQ(a.x, along.x);  // the kernels' row of nodes gives at()'s very doubles
            ASSERT_EQ(a.y, along.y);
            const double bend = std::hypot(a.x - 2 * b.x + c.x, a.y - 2 * b.y + c.y);
            if (x / 16 == (x + 2) / 16)
                ASSERT_LT(bend, 1e-9) << "not linear inside the cell at " << x << "," << y;
            else
                largest_bend = std::max(largest_bend, bend);
        }
    }
    EXPECT_GT(largest_bend, 1e-4);  // the test sees a bend where there is one
    // Down a column inside a cell: linear too; the mesh between nodes is near the lens.
    for (int y = 0; y + 2 < 16; ++y) {
        const Point2 a = mesh.at(40.0, y), b = mesh.at(40.0, y + 1), c = mesh.at(40.0, y + 2);
        EXPECT_LT(std::hypot(a.x - 2 * b.x + c.x, a.y - 2 * b.y + c.y), 1e-9);
    }
    const Point2 mid = mesh.at(100.5, 40.5), exact = lens({100.5, 40.5});
    EXPECT_LT(std::hypot(mid.x - exact.x, mid.y - exact.y), 0.05);
}

TEST(WarpMesh, RefinedMeshHasTheCoarseMeshsPositionsAtItsNodes)
{
    const LensMap lens(1921, 1081, -0.2, 0.03, 1.05, 12.0, -7.0);
    const WarpMesh coarse = makeWarpMesh(1921, 1081, 32, lens);
    const WarpMesh fine = refineWarpMesh(coarse, 1921, 1081, 16);
    EXPECT_EQ(makeWarpMesh(1921, 1081, 16, lens).columns, fine.columns);
    EXPECT_EQ(makeWarpMesh(1921, 1081, 16, lens).rows, fine.rows);
    EXPECT_TRUE(fine.covers(1921, 1081));
    for (int j = 0; j < fine.rows; ++j)
        for (int i = 0; i < fine.columns; ++i) {
            const Point2 want = coarse.at(16.0 * i, 16.0 * j);
            ASSERT_EQ(want.x, fine.x[std::size_t(j) * fine.columns + i]) << i << "," << j;  // exactly
            ASSERT_EQ(want.y, fine.y[std::size_t(j) * fine.columns + i]) << i << "," << j;
        }
    EXPECT_THROW(refineWarpMesh(coarse, 1921, 1081, 24), std::invalid_argument);
}

TEST(MeshWarpKernels, EveryKernelWritesTheSameBytesAsTheScalarReference)
{
    // Random barrel / pincushion meshes with rotation, zoom and shifts that take parts of the
    // frame off every edge; odd sizes, widths no multiple of 16, padded strides, stripes of
    // rows, constant and replicated borders, noise and saturated content. Every available
    // kernel must write exactly the scalar reference's bytes, padding included.
    std::mt19937 rng(20261207);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    const auto integer = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    constexpr int kTrials = 600;
    int compared[3] = {};
    for (int trial = 0; trial < kTrials; ++trial) {
        const int channels = 1 + trial % 2;
        const int w = integer(18, 230), h = integer(2, 70);
        TestPlane src = noisePlane(rng, w, h, channels, trial % 3 == 0 ? 0 : integer(1, 40));
        if (trial % 4 == 1)
            for (std::uint8_t &b : src.bytes)
                b = b % 2 ? 255 : 0;
        const int dst_width = integer(1, 260), dst_height = integer(1, 70);
        const double scale = uniform(0.8, 1.2) * (trial % 5 == 0 ? uniform(0.5, 2.0) : 1.0);
        const LensMap lens(dst_width, dst_height, uniform(-0.25, 0.25), trial % 7 == 0 ? 0.0 : uniform(-0.06, 0.06),
                           scale, uniform(-0.3, 0.3) * w, uniform(-0.3, 0.3) * h);
        WarpMesh mesh = makeWarpMesh(dst_width, dst_height, trial % 9 == 0 ? 32 : 16, lens);
        if (trial % 10 == 3)  // a node the map could not place (the border there)
            mesh.x[std::size_t(integer(0, int(mesh.x.size()) - 1))] = std::nan("");
        const int dst_stride = dst_width * channels + integer(0, 24);
        const int row_begin = integer(0, dst_height - 1), row_end = integer(row_begin, dst_height);
        const bool replicate = rng() % 2;
        const std::uint8_t border[4] = {std::uint8_t(rng()), std::uint8_t(rng()), 0, 0};
        std::vector<std::uint8_t> reference(std::size_t(dst_stride) * dst_height, 0xa5);
        ASSERT_TRUE(warpPlaneBilinearMesh(src.span(), reference.data(), dst_stride, dst_width, row_begin, row_end,
                                          channels, mesh, replicate, border, WarpKernel::Scalar));
        for (int k = 1; k < 3; ++k) {
            if (!warpKernelAvailable(kKernels[k]))
                continue;
            std::vector<std::uint8_t> out(reference.size(), 0xa5);
            ASSERT_TRUE(warpPlaneBilinearMesh(src.span(), out.data(), dst_stride, dst_width, row_begin, row_end,
                                              channels, mesh, replicate, border, kKernels[k]));
            ++compared[k];
            const auto diff = std::mismatch(out.begin(), out.end(), reference.begin());
            if (diff.first != out.end()) {
                const std::size_t at = std::size_t(diff.first - out.begin());
                FAIL() << warpKernelName(kKernels[k]) << " differs from scalar in trial " << trial << " at row "
                       << at / dst_stride << " byte " << at % dst_stride << ": " << int(*diff.first) << " vs "
                       << int(*diff.second) << " (channels " << channels << ", src " << w << "x" << h << ", dst "
                       << dst_width << "x" << dst_height << ")";
            }
        }
    }
    for (int k = 1; k < 3; ++k)
        if (warpKernelAvailable(kKernels[k]))
            std::printf("%s: %d mesh warps identical to scalar\n", warpKernelName(kKernels[k]), compared[k]);
}

TEST(MeshWarpKernels, WideRowsWriteTheSameBytesAsTheScalarReference)
{
    // Rows of more chunks than a kernel plans at once (64), with an odd tail.
    std::mt19937 rng(99);
    for (int channels : {1, 2}) {
        const int w = 1500, h = 40, dst_width = 1437, dst_height = 37;
        const TestPlane src = noisePlane(rng, w, h, channels, 7);
        const LensMap lens(dst_width, dst_height, -0.15, 0.01, 1.02, 20.0, 1.0);
        const WarpMesh mesh = makeWarpMesh(dst_width, dst_height, 16, lens);
        const std::uint8_t border[4] = {16, 128, 0, 0};
        std::vector<std::uint8_t> reference(std::size_t(dst_width * channels) * dst_height);
        ASSERT_TRUE(warpPlaneBilinearMesh(src.span(), reference.data(), dst_width * channels, dst_width, 0, dst_height,
                                          channels, mesh, false, border, WarpKernel::Scalar));
        for (WarpKernel kernel : {WarpKernel::Simd128, WarpKernel::Avx2}) {
            if (!warpKernelAvailable(kernel))
                continue;
            std::vector<std::uint8_t> out(reference.size());
            ASSERT_TRUE(warpPlaneBilinearMesh(src.span(), out.data(), dst_width * channels, dst_width, 0, dst_height,
                                              channels, mesh, false, border, kernel));
            EXPECT_TRUE(out == reference) << warpKernelName(kernel) << " channels " << channels;
        }
    }
}

TEST(MeshWarpKernels, APairOfPlanesWritesEachPlanesOwnBytes)
{
    // Two 1-byte planes through one mesh in one call (I420's chroma): each gets exactly the
    // bytes the scalar single-plane warp writes, in every kernel; strides and borders of
    // their own, rows wider than one plan (64 chunks), meshes partly off the frame.
    std::mt19937 rng(2026);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    const auto integer = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    for (int trial = 0; trial < 200; ++trial) {
        const int w = integer(18, trial % 10 == 0 ? 1300 : 230), h = integer(2, 60);
        const TestPlane src_a = noisePlane(rng, w, h, 1, integer(0, 20)), src_b = noisePlane(rng, w, h, 1, integer(0, 20));
        const int dst_width = integer(1, w + 40), dst_height = integer(1, 60);
        const LensMap lens(dst_width, dst_height, uniform(-0.25, 0.25), uniform(-0.06, 0.06), uniform(0.7, 1.3),
                           uniform(-0.3, 0.3) * w, uniform(-0.3, 0.3) * h);
        WarpMesh mesh = makeWarpMesh(dst_width, dst_height, trial % 9 == 0 ? 32 : 16, lens);
        if (trial % 10 == 3)
            mesh.x[std::size_t(integer(0, int(mesh.x.size()) - 1))] = std::nan("");
        const int stride_a = dst_width + integer(0, 9), stride_b = dst_width + integer(0, 9);
        const int row_begin = integer(0, dst_height - 1), row_end = integer(row_begin, dst_height);
        const bool replicate = rng() % 2;
        const std::uint8_t border_a[4] = {std::uint8_t(rng()), 0, 0, 0}, border_b[4] = {std::uint8_t(rng()), 0, 0, 0};
        std::vector<std::uint8_t> want_a(std::size_t(stride_a) * dst_height, 0xa5), want_b(std::size_t(stride_b) * dst_height, 0x5a);
        ASSERT_TRUE(warpPlaneBilinearMesh(src_a.span(), want_a.data(), stride_a, dst_width, row_begin, row_end, 1, mesh,
                                          replicate, border_a, WarpKernel::Scalar));
        ASSERT_TRUE(warpPlaneBilinearMesh(src_b.span(), want_b.data(), stride_b, dst_width, row_begin, row_end, 1, mesh,
                                          replicate, border_b, WarpKernel::Scalar));
        for (WarpKernel kernel : kKernels) {
            if (!warpKernelAvailable(kernel))
                continue;
            std::vector<std::uint8_t> a(want_a.size(), 0xa5), b(want_b.size(), 0x5a);
            ASSERT_TRUE(warpPlanePairBilinearMesh({src_a.span(), a.data(), stride_a, border_a},
                                                  {src_b.span(), b.data(), stride_b, border_b}, dst_width, row_begin,
                                                  row_end, mesh, replicate, kernel));
            ASSERT_TRUE(a == want_a) << warpKernelName(kernel) << " trial " << trial << " (first plane)";
            ASSERT_TRUE(b == want_b) << warpKernelName(kernel) << " trial " << trial << " (second plane)";
        }
    }
    // Sources of two sizes are refused.
    std::mt19937 rng2(1);
    const TestPlane a = noisePlane(rng2, 40, 20, 1, 0), b = noisePlane(rng2, 41, 20, 1, 0);
    std::vector<std::uint8_t> out(40 * 20);
    const std::uint8_t border[4] = {};
    const WarpMesh mesh = makeWarpMesh(40, 20, 16, [](Point2 p) { return p; });
    EXPECT_FALSE(warpPlanePairBilinearMesh({a.span(), out.data(), 40, border}, {b.span(), out.data(), 40, border}, 40, 0,
                                           20, mesh, false));
}

TEST(MeshWarpKernels, FourBytePixelsWriteTheSameBytesInEveryKernel)
{
    // The 4-byte AVX2 mesh kernel against the per-pixel reference: random meshes partly off
    // the frame, odd widths, stripes, both borders, a NaN node now and then.
    if (!warpKernelAvailable(WarpKernel::Avx2))
        GTEST_SKIP() << "no AVX2 here: the scalar path is the only one";
    EXPECT_FALSE(warpPlaneBilinear4Mesh({nullptr, 0, 1, 1}, nullptr, 0, 1, 0, 1, makeWarpMesh(1, 1, 16, [](Point2 p) {
        return p;
    }), false, nullptr, WarpKernel::Simd128));
    std::mt19937 rng(4444);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    const auto integer = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    for (int trial = 0; trial < 300; ++trial) {
        const int w = integer(2, 150), h = integer(2, 60);
        const TestPlane src = noisePlane(rng, w, h, 4, trial % 2 ? 0 : integer(1, 12));
        const int dst_width = integer(1, 170), dst_height = integer(1, 50);
        const LensMap lens(dst_width, dst_height, uniform(-0.25, 0.25), uniform(-0.06, 0.06), uniform(0.7, 1.3),
                           uniform(-0.3, 0.3) * w, uniform(-0.3, 0.3) * h);
        WarpMesh mesh = makeWarpMesh(dst_width, dst_height, trial % 7 == 0 ? 32 : 16, lens);
        if (trial % 10 == 3)
            mesh.y[std::size_t(integer(0, int(mesh.y.size()) - 1))] = std::nan("");
        const int dst_stride = dst_width * 4 + integer(0, 9);
        const int row_begin = integer(0, dst_height - 1), row_end = integer(row_begin, dst_height);
        const bool replicate = rng() % 2;
        const std::uint8_t border[4] = {std::uint8_t(rng()), std::uint8_t(rng()), std::uint8_t(rng()), 255};
        std::vector<std::uint8_t> reference(std::size_t(dst_stride) * dst_height, 0xa5), out(reference.size(), 0xa5);
        ASSERT_TRUE(warpPlaneBilinear4Mesh(src.span(), reference.data(), dst_stride, dst_width, row_begin, row_end,
                                           mesh, replicate, border, WarpKernel::Scalar));
        ASSERT_TRUE(warpPlaneBilinear4Mesh(src.span(), out.data(), dst_stride, dst_width, row_begin, row_end, mesh,
                                           replicate, border, WarpKernel::Avx2));
        const auto diff = std::mismatch(out.begin(), out.end(), reference.begin());
        ASSERT_TRUE(diff.first == out.end()) << "trial " << trial << " byte " << (diff.first - out.begin()) << ": "
                                             << int(*diff.first) << " vs " << int(*diff.second);
    }
}

TEST(MeshWarpKernels, AnAffineMeshWritesTheMatrixWarpsBytes)
{
    // A mesh sampled from a matrix whose entries are multiples of 2^-12 (and nodes at
    // integers < 2^12): every node, the interpolation down to a row (t a multiple of 1/16)
    // and the chunk's m0 = (B - A) / 16 and m2 = A - m0 x_A are exact in double, so each
    // chunk's position is the matrix warp's own double and the bytes are the same, exactly,
    // in every kernel. (A matrix with arbitrary entries gets the same bytes except where a
    // position lies within ~1e-12 px of a 1/1024 step.)
    std::mt19937 rng(7);
    const auto dyadic = [&](double lo, double hi) {
        return std::round(std::uniform_real_distribution<double>(lo, hi)(rng) * 4096.0) / 4096.0;
    };
    int fast = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const int channels = 1 + trial % 2;
        const int w = 40 + int(rng() % 200), h = 3 + int(rng() % 60);
        const TestPlane src = noisePlane(rng, w, h, channels, int(rng() % 9));
        const double turn = trial % 5 == 0 ? 0.0 : dyadic(-0.05, 0.05), scale = dyadic(0.85, 1.2);
        const double m[6] = {scale, -turn, dyadic(-0.2, 0.2) * w, turn, scale, dyadic(-0.2, 0.2) * h};
        const int dst_width = 1 + int(rng() % 250), dst_height = 1 + int(rng() % 60);
        const WarpMesh mesh = makeWarpMesh(dst_width, dst_height, 16, [&](Point2 p) {
            return Point2{m[0] * p.x + m[1] * p.y + m[2], m[3] * p.x + m[4] * p.y + m[5]};
        });
        const bool replicate = trial % 3 == 0;
        const std::uint8_t border[4] = {16, 128, 0, 0};
        const int dst_stride = dst_width * channels;
        std::vector<std::uint8_t> matrix_out(std::size_t(dst_stride) * dst_height, 0xa5);
        ASSERT_TRUE(warpPlaneBilinear(src.span(), matrix_out.data(), dst_stride, dst_width, 0, dst_height, channels,
                                      m, replicate, border, WarpKernel::Scalar));
        for (WarpKernel kernel : kKernels) {
            if (!warpKernelAvailable(kernel))
                continue;
            std::vector<std::uint8_t> mesh_out(matrix_out.size(), 0x5a);
            ASSERT_TRUE(warpPlaneBilinearMesh(src.span(), mesh_out.data(), dst_stride, dst_width, 0, dst_height,
                                              channels, mesh, replicate, border, kernel));
            ASSERT_TRUE(mesh_out == matrix_out) << warpKernelName(kernel) << " trial " << trial;
        }
        fast += dst_width >= 16;
    }
    EXPECT_GT(fast, 150);
}

TEST(MeshWarpKernels, AnAffineMeshWithArbitraryEntriesWritesNearlyTheMatrixWarpsBytes)
{
    // Non-dyadic entries: the chunk's matrix differs from the warp's in the last bits, so a
    // position a hair from a 1/1024 step may fall in the next; on noise such a byte may move
    // by up to 255/64 levels; so may one where the chunk's lane offsets (m0 rounded to 2^-25,
    // m3 to 2^-19) round a hair differently from the warp's. Measured: 73 in 1080000.
    std::mt19937 rng(8);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    long long bytes = 0, differing = 0;
    for (int trial = 0; trial < 100; ++trial) {
        const int channels = 1 + trial % 2;
        const int w = 120, h = 60;
        const TestPlane src = noisePlane(rng, w, h, channels, 3);
        const double turn = uniform(-0.05, 0.05), scale = uniform(0.85, 1.2);
        const double m[6] = {scale, -turn, uniform(-10, 10), turn, scale, uniform(-10, 10)};
        const WarpMesh mesh = makeWarpMesh(w, h, 16, [&](Point2 p) {
            return Point2{m[0] * p.x + m[1] * p.y + m[2], m[3] * p.x + m[4] * p.y + m[5]};
        });
        const std::uint8_t border[4] = {16, 128, 0, 0};
        std::vector<std::uint8_t> a(std::size_t(w * channels) * h), b(a.size());
        ASSERT_TRUE(warpPlaneBilinear(src.span(), a.data(), w * channels, w, 0, h, channels, m, false, border));
        ASSERT_TRUE(warpPlaneBilinearMesh(src.span(), b.data(), w * channels, w, 0, h, channels, mesh, false, border));
        for (std::size_t i = 0; i < a.size(); ++i) {
            differing += a[i] != b[i];
            ASSERT_LE(std::abs(int(a[i]) - int(b[i])), 4) << "trial " << trial << " byte " << i;
        }
        bytes += (long long)a.size();
    }
    std::printf("%lld of %lld bytes differ from the matrix warp's\n", differing, bytes);
    EXPECT_LE(differing * 10000, bytes);  // at most 1 in 10^4
}

TEST(MeshWarpKernels, StayWithinOneLevelOfADoublePrecisionBilinearAtTheMeshPositions)
{
    // Smooth content (neighbours at most ~6 levels apart, the constant border inside the
    // content's range, at most 11 from any sample): a kernel's position lies within
    // 1/64 + 1/1024 + 1/2048 px of mesh.at() on each axis (1/64 px steps, lane offsets
    // rounded to 1/1024, the chunk's start truncated to 1/1024), which moves a bilinear value
    // by at most 11 * 2 * 0.0171 = 0.38 level; its roundings add at most 0.5 + 1/128. So
    // every byte is within 0.9 of the exact value. A tap one pixel off shows: ~6 levels.
    const LensMap lenses[] = {{201, 75, -0.22, 0.04, 1.02, 3.3, -2.1},
                              {201, 75, 0.18, -0.05, 0.9, -12.0, 6.0},  // parts outside
                              {201, 75, -0.1, 0.0, 1.0, 0.0, 0.0}};
    int pixels = 0, inexact = 0;
    for (int channels : {1, 2}) {
        const TestPlane src = smoothPlane(187, 71, channels, 5, 11.0);
        for (const LensMap &lens : lenses) {
            const WarpMesh mesh = makeWarpMesh(201, 75, 16, lens);
            for (bool replicate : {false, true}) {
                const std::uint8_t border[4] = {128, 128, 0, 0};
                for (WarpKernel kernel : kKernels) {
                    if (!warpKernelAvailable(kernel))
                        continue;
                    const int dst_stride = 201 * channels + 3;
                    std::vector<std::uint8_t> out(std::size_t(dst_stride) * 75);
                    // In three stripes, as FrameWarper's workers draw a frame.
                    for (int y = 0; y < 75; y += 25)
                        ASSERT_TRUE(warpPlaneBilinearMesh(src.span(), out.data(), dst_stride, 201, y, y + 25,
                                                          channels, mesh, replicate, border, kernel));
                    for (int y = 0; y < 75; ++y)
                        for (int x = 0; x < 201; ++x) {
                            const Point2 s = mesh.at(x, y);
                            for (int c = 0; c < channels; ++c) {
                                const double want =
                                    referenceSample(src.span(), channels, 1, c, s.x, s.y, replicate, border[c]);
                                const int got = out[std::size_t(y) * dst_stride + x * channels + c];
                                ASSERT_LT(std::abs(got - want), 0.9)
                                    << warpKernelName(kernel) << " at " << x << "," << y << " channel " << c
                                    << (replicate ? " replicate" : " constant");
                                ++pixels;
                                inexact += std::abs(got - want) > 0.5;
                            }
                        }
                }
            }
        }
    }
    std::printf("%d of %d samples more than half a level from the exact value\n", inexact, pixels);
}

// ---- FrameWarper with a mesh per plane ----------------------------------------------------

namespace {

const PixelFormat kAllFormats[] = {PixelFormat::Gray8, PixelFormat::I420, PixelFormat::YV12,    PixelFormat::NV12,
                                   PixelFormat::NV21,  PixelFormat::RGB,  PixelFormat::BGR,     PixelFormat::RGBA,
                                   PixelFormat::BGRA,  PixelFormat::RGBx, PixelFormat::BGRx,    PixelFormat::Gray16LE,
                                   PixelFormat::Gray16BE};

FrameBuffer smoothFrame(PixelFormat format, int w, int h, double amplitude)
{
    FrameBuffer f(format, w, h, 3);
    const FrameView &v = f.view();
    for (int p = 0; p < v.planeCount(); ++p) {
        const PlaneLayout l = planeLayout(format, p);
        for (int y = 0; y < v.planeHeight(p); ++y)
            for (int x = 0; x < v.planeWidth(p); ++x)
                for (int c = 0; c < l.channels; ++c) {
                    std::uint8_t *s = f.row(p, y) + (x * l.channels + c) * l.bytes_per_sample;
                    if (l.bytes_per_sample == 1) {
                        *s = smoothValue(x, y, c + 3 * p, amplitude);
                        continue;
                    }
                    // 16 bits: the same wave at 256 times the scale plus a fine ripple.
                    std::uint16_t value = std::uint16_t(smoothValue(x, y, c, amplitude) * 256 + (x * 37 + y * 11) % 256);
                    if (needsByteSwap(format))
                        value = std::uint16_t((value >> 8) | (value << 8));
                    std::memcpy(s, &value, 2);
                }
    }
    return f;
}

std::vector<WarpMesh> frameMeshes(const FrameView &v, const std::function<Point2(Point2)> &luma)
{
    std::vector<WarpMesh> meshes;
    for (int p = 0; p < v.planeCount(); ++p)
        meshes.push_back(FrameWarper::planeMesh(v, p, luma));
    return meshes;
}

} // namespace

TEST(FrameWarperMesh, EveryFormatStaysWithinOneLevelOfThePerPixelReference)
{
    // I420, NV12, BGRx, 16-bit and every other format: each plane against the double
    // bilinear at its mesh's positions. 8-bit planes: as in the kernels' test (the 3- and
    // 4-byte path rounds positions to 1/32 px: at most 11 * 2 * (1/64 + 1/2048) + 0.5 + 1/2048
    // = 0.86). 16-bit: the same double positions and arithmetic, so only the rounding to the
    // nearest count.
    const int w = 203, h = 117;
    const LensMap lens(w, h, -0.2, 0.03, 1.04, 4.0, -3.0);
    for (PixelFormat format : kAllFormats) {
        if (needsByteSwap(format))
            continue;  // below: the little-endian twin's bytes, swapped
        const FrameBuffer in = smoothFrame(format, w, h, 11.0);
        FrameBuffer out(format, w, h, 1);
        const std::vector<WarpMesh> meshes = frameMeshes(in.view(), lens);
        for (BorderMode mode : {BorderMode::Black, BorderMode::Replicate}) {
            FrameWarper(mode).warp(in.view(), out.view(), meshes);
            const FrameView &v = in.view();
            for (int p = 0; p < v.planeCount(); ++p) {
                const PlaneLayout l = planeLayout(format, p);
                const PlaneSpan span{v.planes[p].data, v.planes[p].stride, v.planeWidth(p), v.planeHeight(p)};
                // FrameWarper's black: its border is within the smooth content only for YUV
                // chroma (128) and, with replicate, everywhere; elsewhere skip the pixels
                // whose taps reach off the frame.
                const double black = l.bytes_per_sample == 2 ? 0.0
                                     : isYuv(format)         ? (p == 0 ? 16.0 : 128.0)
                                                             : 0.0;
                const bool border_near_content = mode == BorderMode::Replicate || (isYuv(format) && p > 0);
                int checked = 0;
                for (int y = 0; y < v.planeHeight(p); ++y)
                    for (int x = 0; x < v.planeWidth(p); ++x) {
                        const Point2 s = meshes[std::size_t(p)].at(x, y);
                        // A margin for the kernels' position roundings (< 0.02 px), which decide whether a tap is off.
                        const bool inside = s.x >= 0.05 && s.y >= 0.05 && s.x < span.width - 1.05 &&
                                            s.y < span.height - 1.05;
                        if (!inside && !border_near_content)
                            continue;
                        for (int c = 0; c < l.channels; ++c) {
                            const double alpha_black = (c == 3 && !isYuv(format)) ? 255.0 : black;
                            double want = referenceSample(span, l.channels, l.bytes_per_sample, c, s.x, s.y,
                                                          mode == BorderMode::Replicate, alpha_black);
                            const std::uint8_t *o = out.row(p, y) + (x * l.channels + c) * l.bytes_per_sample;
                            double got = *o;
                            if (l.bytes_per_sample == 2) {
                                std::uint16_t raw;
                                std::memcpy(&raw, o, 2);
                                got = raw;
                            }
                            ASSERT_LT(std::abs(got - want), l.bytes_per_sample == 2 ? 0.5 + 1e-6 : 0.9)
                                << toString(format) << " plane " << p << " at " << x << "," << y << " channel " << c
                                << (mode == BorderMode::Replicate ? " replicate" : " black");
                            ++checked;
                        }
                    }
                EXPECT_GT(checked, v.planeWidth(p) * v.planeHeight(p) / 2) << toString(format) << " plane " << p;
            }
        }
    }
}

TEST(FrameWarperMesh, BigEndianSixteenBitWarpsAsItsLittleEndianTwin)
{
    const int w = 99, h = 61;
    const LensMap lens(w, h, 0.15, -0.02, 0.97, -5.0, 2.0);
    const FrameBuffer le = smoothFrame(PixelFormat::Gray16LE, w, h, 11.0), be = smoothFrame(PixelFormat::Gray16BE, w, h, 11.0);
    FrameBuffer le_out(PixelFormat::Gray16LE, w, h), be_out(PixelFormat::Gray16BE, w, h);
    FrameWarper().warp(le.view(), le_out.view(), frameMeshes(le.view(), lens));
    FrameWarper().warp(be.view(), be_out.view(), frameMeshes(be.view(), lens));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            ASSERT_EQ(le_out.row(0, y)[2 * x], be_out.row(0, y)[2 * x + 1]) << x << "," << y;
            ASSERT_EQ(le_out.row(0, y)[2 * x + 1], be_out.row(0, y)[2 * x]) << x << "," << y;
        }
}

TEST(FrameWarperMesh, PlaneMeshPlacesChromaNodesAsPlaneMatrixDoes)
{
    // An affine luma map: every plane's mesh nodes are where planeMatrix's plane transform
    // takes them (chroma sample centres between their luma samples).
    const Similarity s{3.5, -2.25, 0.04, 1.07};
    for (PixelFormat format : {PixelFormat::I420, PixelFormat::NV12, PixelFormat::BGRx, PixelFormat::Gray16LE}) {
        const FrameBuffer frame(format, 101, 63);
        const FrameView &v = frame.view();
        const std::array<double, 6> l = s.pixelMatrix(v.width, v.height);
        const auto luma = [&](Point2 p) { return Point2{l[0] * p.x + l[1] * p.y + l[2], l[3] * p.x + l[4] * p.y + l[5]}; };
        for (int p = 0; p < v.planeCount(); ++p) {
            double m[6];
            FrameWarper::planeMatrix(v, p, s, m);
            const WarpMesh mesh = FrameWarper::planeMesh(v, p, luma);
            EXPECT_TRUE(mesh.covers(v.planeWidth(p), v.planeHeight(p)));
            for (int j = 0; j < mesh.rows; ++j)
                for (int i = 0; i < mesh.columns; ++i) {
                    const double x = 16.0 * i, y = 16.0 * j;
                    const std::size_t k = std::size_t(j) * mesh.columns + i;
                    ASSERT_NEAR(m[0] * x + m[1] * y + m[2], mesh.x[k], 1e-9) << toString(format) << " plane " << p;
                    ASSERT_NEAR(m[3] * x + m[4] * y + m[5], mesh.y[k], 1e-9) << toString(format) << " plane " << p;
                }
        }
    }
}

TEST(FrameWarperMesh, StripesTogetherEqualTheWholeFrame)
{
    const int w = 131, h = 90;
    const LensMap lens(w, h, -0.18, 0.02, 1.03, 1.5, -2.5);
    for (PixelFormat format : {PixelFormat::I420, PixelFormat::NV12, PixelFormat::BGRx, PixelFormat::RGB,
                               PixelFormat::Gray16LE}) {
        const FrameBuffer in = noiseFrame(format, w, h, 4, 2);
        FrameBuffer whole(format, w, h), striped(format, w, h);
        const std::vector<WarpMesh> meshes = frameMeshes(in.view(), lens);
        FrameWarper().warp(in.view(), whole.view(), meshes);
        for (int y = 0; y < h; y += 30)
            FrameWarper().warpRows(in.view(), striped.view(), meshes, y, y + 30);
        const FrameView &v = whole.view();
        for (int p = 0; p < v.planeCount(); ++p)
            for (int y = 0; y < v.planeHeight(p); ++y)
                ASSERT_EQ(0, std::memcmp(whole.row(p, y), striped.row(p, y), std::size_t(v.planeRowBytes(p))))
                    << toString(format) << " plane " << p << " row " << y;
    }
}

TEST(FrameWarperMesh, AnIdentityMeshReproducesTheInputExactly)
{
    for (PixelFormat format : kAllFormats) {
        const FrameBuffer in = noiseFrame(format, 67, 41, 1, 5);
        FrameBuffer out(format, 67, 41, 3);
        FrameWarper().warp(in.view(), out.view(), frameMeshes(in.view(), [](Point2 p) { return p; }));
        for (int p = 0; p < in.view().planeCount(); ++p)
            for (int y = 0; y < in.view().planeHeight(p); ++y)
                ASSERT_EQ(0, std::memcmp(in.row(p, y), out.row(p, y), std::size_t(in.view().planeRowBytes(p))))
                    << toString(format) << " plane " << p << " row " << y;
    }
}

TEST(FrameWarperMesh, RejectsMissingOrTooSmallMeshes)
{
    const FrameBuffer in(PixelFormat::I420, 64, 48);
    FrameBuffer out(PixelFormat::I420, 64, 48);
    const auto identity = [](Point2 p) { return p; };
    std::vector<WarpMesh> meshes = frameMeshes(in.view(), identity);
    meshes.pop_back();
    EXPECT_THROW(FrameWarper().warp(in.view(), out.view(), meshes), std::invalid_argument);
    meshes.push_back(makeWarpMesh(16, 16, 16, identity));  // chroma is 32 x 24
    EXPECT_THROW(FrameWarper().warp(in.view(), out.view(), meshes), std::invalid_argument);
}
