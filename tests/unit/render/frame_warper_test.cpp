#include <gtest/gtest.h>

#include <random>

#include "buffer_slot.hpp"
#include "format_conversion.hpp"
#include "shaky_flight.hpp"
#include "render/frame_warper.hpp"
#include "path/framing.hpp"

using namespace uavstab;
using test::noiseFrame;

namespace {

const PixelFormat kAllFormats[] = {PixelFormat::Gray8, PixelFormat::I420, PixelFormat::YV12, PixelFormat::NV12,
                                   PixelFormat::NV21,  PixelFormat::RGB,  PixelFormat::BGR,  PixelFormat::RGBA,
                                   PixelFormat::BGRA,  PixelFormat::RGBx, PixelFormat::BGRx};

} // namespace

TEST(FrameWarper, IdentityReproducesTheInputExactly)
{
    for (PixelFormat format : kAllFormats) {
        const FrameBuffer in = noiseFrame(format, 67, 41, 1, 5);  // odd size, padded rows
        FrameBuffer out(format, 67, 41, 3);
        FrameWarper().warp(in.view(), out.view(), Similarity::identity());
        for (int p = 0; p < in.view().planeCount(); ++p)
            for (int y = 0; y < in.view().planeHeight(p); ++y)
                ASSERT_EQ(0, std::memcmp(in.row(p, y), out.row(p, y), std::size_t(in.view().planeRowBytes(p))))
                    << toString(format) << " plane " << p << " row " << y;
    }
}

TEST(FrameWarper, TranslationMovesEveryPlaneOfEveryFormatByExactlyThatAmount)
{
    const int dx = 6, dy = -4;  // even, so chroma moves by whole samples too
    for (PixelFormat format : kAllFormats) {
        const FrameBuffer in = noiseFrame(format, 96, 64, 2, 7);
        FrameBuffer out(format, 96, 64);
        // out(q) = in(q + t)
        FrameWarper().warp(in.view(), out.view(), Similarity{double(dx), double(dy), 0.0, 1.0});
        for (int p = 0; p < in.view().planeCount(); ++p) {
            const PlaneLayout l = planeLayout(format, p);
            const int pdx = dx / l.subsample_x, pdy = dy / l.subsample_y;
            const int pw = in.view().planeWidth(p), ph = in.view().planeHeight(p);
            for (int y = 0; y < ph; ++y)
                for (int x = 0; x < pw; ++x) {
                    const int sx = x + pdx, sy = y + pdy;
                    if (sx < 0 || sy < 0 || sx >= pw || sy >= ph)
                        continue;
                    for (int c = 0; c < l.channels; ++c)
                        ASSERT_EQ(out.row(p, y)[x * l.channels + c], in.row(p, sy)[sx * l.channels + c])
                            << toString(format) << " plane " << p << " at " << x << "," << y;
                }
        }
    }
}

TEST(FrameWarper, UncoveredPixelsAreBlackOrReplicated)
{
    FrameBuffer in(PixelFormat::I420, 32, 32);
    in.fill(200);
    FrameBuffer out(PixelFormat::I420, 32, 32);
    FrameWarper(BorderMode::Black).warp(in.view(), out.view(), Similarity{-10, 0, 0, 1});
    EXPECT_EQ(out.row(0, 16)[0], 16);   // video-range black luma
    EXPECT_EQ(out.row(1, 8)[0], 128);   // neutral chroma
    EXPECT_EQ(out.row(0, 16)[20], 200);
    FrameWarper(BorderMode::Replicate).warp(in.view(), out.view(), Similarity{-10, 0, 0, 1});
    EXPECT_EQ(out.row(0, 16)[0], 200);
}

TEST(FrameWarper, StripesTogetherEqualTheWholeFrame)
{
    const FrameBuffer in = noiseFrame(PixelFormat::NV12, 128, 96, 3);
    FrameBuffer whole(PixelFormat::NV12, 128, 96), striped(PixelFormat::NV12, 128, 96);
    const Similarity m{1.3, -2.7, 0.02, 0.97};
    FrameWarper().warp(in.view(), whole.view(), m);
    for (int y = 0; y < 96; y += 32)
        FrameWarper().warpRows(in.view(), striped.view(), m, y, y + 32);
    for (int p = 0; p < 2; ++p)
        for (int y = 0; y < whole.view().planeHeight(p); ++y)
            ASSERT_EQ(0, std::memcmp(whole.row(p, y), striped.row(p, y), 128)) << "plane " << p << " row " << y;
}

TEST(FrameWarper, RejectsMismatchedOrOverlappingFrames)
{
    FrameBuffer a(PixelFormat::I420, 32, 32), b(PixelFormat::I420, 34, 32);
    EXPECT_THROW(FrameWarper().warp(a.view(), b.view(), {}), std::invalid_argument);
    EXPECT_THROW(FrameWarper().warp(a.view(), a.view(), {}), std::invalid_argument);
}

TEST(Framing, CropZoomsAndLimitsTheCorrectionToWhatItHides)
{
    const Framing none = frameOutput(Similarity::identity(), 640, 360, 0.08, true);
    EXPECT_NEAR(none.zoom, 1.0 / 0.92, 1e-12);
    EXPECT_DOUBLE_EQ(none.fraction, 1.0);
    EXPECT_TRUE(coversFrame(none.output_to_input, 640, 360));
    // A 10 px shift is hidden by a 4 % margin (25.6 px at 640).
    const Framing small = frameOutput({10, 0, 0, 1}, 640, 360, 0.08, true);
    EXPECT_DOUBLE_EQ(small.fraction, 1.0);
    // A 60 px shift is not: it is cut back until the output is all picture.
    const Framing big = frameOutput({60, 0, 0, 1}, 640, 360, 0.08, true);
    EXPECT_LT(big.fraction, 0.5);
    EXPECT_TRUE(coversFrame(big.output_to_input, 640, 360));
    const Framing unlimited = frameOutput({60, 0, 0, 1}, 640, 360, 0.08, false);
    EXPECT_DOUBLE_EQ(unlimited.fraction, 1.0);
    EXPECT_FALSE(coversFrame(unlimited.output_to_input, 640, 360));
}

#include <opencv2/imgproc.hpp>

#include "render/bilinear_warp.hpp"

TEST(FrameWarper, FastKernelAgreesWithOpenCvOnRotationAndZoom)
{
    // The fast kernel (1/64 px positions; whichever this CPU uses, all write the same bytes)
    // against cv::warpAffine (1/32 px) on noise, the hardest content: any misplaced tap or
    // channel shows as a large difference.
    const Similarity mappings[] = {{3.3, -1.7, 0.02, 1.0 / 1.087}, {-0.4, 2.2, -0.05, 0.97}, {0.5, 0.5, 0.0, 1.0}};
    for (int channels : {1, 2}) {
        const PixelFormat format = channels == 1 ? PixelFormat::Gray8 : PixelFormat::NV12;
        const FrameBuffer in = noiseFrame(format, 203, 119, 5, 3);
        const int plane = channels == 2 ? 1 : 0;
        const FrameView &v = in.view();
        const int w = v.planeWidth(plane), h = v.planeHeight(plane);
        for (const Similarity &s : mappings) {
            double m[6];
            FrameWarper::planeMatrix(v, plane, s, m);
            cv::Mat fast(h, w, CV_8UC(channels)), reference;
            const std::uint8_t border[4] = {16, 128, 128, 255};
            const bool used = warpPlaneBilinear({v.planes[plane].data, v.planes[plane].stride, w, h}, fast.data,
                                                int(fast.step), w, 0, h, channels, m, false, border);
            if (!used) {
                ADD_FAILURE() << "the fast kernel refused a mapping it handles";
                return;
            }
            const cv::Mat src(h, w, CV_8UC(channels), v.planes[plane].data, std::size_t(v.planes[plane].stride));
            cv::warpAffine(src, reference, cv::Mat(2, 3, CV_64F, m), src.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                           cv::BORDER_CONSTANT, cv::Scalar(16, 128, 128, 255));
            cv::Mat diff;
            cv::absdiff(fast, reference, diff);
            // Interior only: at the border the two differ by where "outside" starts.
            const cv::Mat inner = diff(cv::Rect(4, 4, w - 8, h - 8)).reshape(1);
            double max_diff = 0;
            cv::minMaxLoc(inner, nullptr, &max_diff);
            const double mean_diff = cv::mean(inner)[0];
            std::printf("%d channels: max %.0f mean %.3f\n", channels, max_diff, mean_diff);
            EXPECT_LE(max_diff, 12) << channels << " channels";  // noise: half a 1/32 px step of a 255 edge
            EXPECT_LT(mean_diff, 1.5) << channels << " channels";
        }
    }
}

#include <cstring>
#include <vector>

namespace {

const WarpKernel kWarpKernels[] = {WarpKernel::Scalar, WarpKernel::Simd128, WarpKernel::Avx2};

// The log says which warp kernel this machine uses, before any test runs.
class WarpKernelLog : public ::testing::Environment {
public:
    void SetUp() override
    {
        std::printf("warp kernel: %s (available:", warpKernelName(warpKernel()));
        for (WarpKernel k : kWarpKernels)
            if (warpKernelAvailable(k))
                std::printf(" %s", warpKernelName(k));
        std::printf(")\n");
        std::fflush(stdout);
    }
};
[[maybe_unused]] ::testing::Environment *const warp_kernel_log = ::testing::AddGlobalTestEnvironment(new WarpKernelLog);

} // namespace

TEST(WarpKernels, TheFastestAvailableIsChosen)
{
    RecordProperty("warp_kernel", warpKernelName(warpKernel()));
    EXPECT_TRUE(warpKernelAvailable(warpKernel()));
    EXPECT_TRUE(warpKernelAvailable(WarpKernel::Scalar));
    if (std::getenv("UAVSTAB_WARP_KERNEL") == nullptr) {
        const WarpKernel best = warpKernelAvailable(WarpKernel::Avx2)      ? WarpKernel::Avx2
                                : warpKernelAvailable(WarpKernel::Simd128) ? WarpKernel::Simd128
                                                                           : WarpKernel::Scalar;
        EXPECT_STREQ(warpKernelName(best), warpKernelName(warpKernel()));
    }
#if defined(__aarch64__)
    EXPECT_TRUE(warpKernelAvailable(WarpKernel::Simd128));  // NEON is part of AArch64
    EXPECT_STREQ("neon128", warpKernelName(WarpKernel::Simd128));
#endif
}

TEST(WarpKernels, EveryKernelWritesTheSameBytesAsTheScalarReference)
{
    constexpr std::uint64_t kExpectedChecksum = 0xadcd788328c3a994ull;
    // Random warps near a similarity (rotation, zoom, sub-pixel shifts, anisotropic chroma
    // steps), odd widths and widths that are no multiple of the 16-pixel chunk, padded
    // strides, stripes of rows, constant and replicated borders, shifts that take taps off
    // every edge, and content from noise to saturated 0/255 stripes. Every available
    // kernel must write exactly the scalar reference's bytes, padding included.
    std::mt19937 rng(20261201);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    const auto integer = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    constexpr int kTrials = 1500;
    int used[3] = {}, taken = 0;
    long long bytes = 0;
    std::uint64_t checksum = 0xcbf29ce484222325ull;
    for (int trial = 0; trial < kTrials; ++trial) {
        const int channels = 1 + trial % 2;
        const int w = integer(18, 230), h = integer(2, 70);
        const int src_stride = w * channels + (trial % 3 == 0 ? 0 : integer(1, 40));
        // Exactly as long as the last row: a read past it is out of bounds.
        std::vector<std::uint8_t> src(std::size_t(src_stride) * (h - 1) + std::size_t(w) * channels);
        const int content = trial % 4;
        for (std::size_t i = 0; i < src.size(); ++i) {
            const int x = int(i % std::size_t(src_stride)), y = int(i / std::size_t(src_stride));
            src[i] = content == 0   ? std::uint8_t(rng())
                     : content == 1 ? std::uint8_t(((x / channels + y) / 3) % 2 ? 255 : 0)
                     : content == 2 ? std::uint8_t((x * 7 + y * 13) & 255)
                                    : std::uint8_t(rng() % 2 ? 255 : 0);
        }
        // Rotation and zoom without std::sin/cos, whose last bit may differ between C
        // libraries: the inputs, like the outputs, are the same on every machine.
        double m[6];
        const double turn = trial % 7 == 0 ? 0.0 : uniform(-0.06, 0.06);  // ~ sin(angle)
        const double scale = trial % 11 == 0 ? 1.0 : uniform(0.8, 1.25);
        const double aspect = trial % 5 == 0 ? uniform(0.5, 2.0) : 1.0;  // chroma plane steps
        m[0] = scale * (1.0 - 0.5 * turn * turn);
        m[1] = -scale * turn * aspect;
        m[3] = scale * turn / aspect;
        m[4] = m[0];
        const bool whole = trial % 13 == 0;  // integer shifts
        m[2] = whole ? integer(-w / 3, w / 3) : uniform(-0.3 * w, 0.3 * w);
        m[5] = whole ? integer(-h / 3, h / 3) : uniform(-0.3 * h, 0.3 * h);
        const int dst_width = integer(1, 260), dst_height = integer(1, 70);
        const int dst_stride = dst_width * channels + integer(0, 24);
        const int row_begin = integer(0, dst_height - 1), row_end = integer(row_begin, dst_height);
        const bool replicate = rng() % 2;
        const std::uint8_t border[4] = {std::uint8_t(rng()), std::uint8_t(rng()), std::uint8_t(rng()),
                                        std::uint8_t(rng())};
        const PlaneSpan span{src.data(), src_stride, w, h};

        std::vector<std::uint8_t> reference(std::size_t(dst_stride) * dst_height, 0xa5);
        const bool ref_used = warpPlaneBilinear(span, reference.data(), dst_stride, dst_width, row_begin, row_end,
                                                channels, m, replicate, border, WarpKernel::Scalar);
        taken += ref_used;
        for (std::uint8_t b : reference)
            checksum = (checksum ^ b) * 0x100000001b3ull;  // FNV-1a
        for (int k = 0; k < 3; ++k) {
            const WarpKernel kernel = kWarpKernels[k];
            if (!warpKernelAvailable(kernel))
                continue;
            std::vector<std::uint8_t> out(reference.size(), 0xa5);
            const bool ok = warpPlaneBilinear(span, out.data(), dst_stride, dst_width, row_begin, row_end, channels,
                                              m, replicate, border, kernel);
            ASSERT_EQ(ref_used, ok) << warpKernelName(kernel) << " trial " << trial;
            if (!ok)
                continue;
            ++used[k];
            bytes += (long long)out.size();
            const auto diff = std::mismatch(out.begin(), out.end(), reference.begin());
            if (diff.first != out.end()) {
                const std::size_t at = std::size_t(diff.first - out.begin());
                FAIL() << warpKernelName(kernel) << " differs from scalar in trial " << trial << " at row "
                       << at / dst_stride << " byte " << at % dst_stride << ": " << int(*diff.first) << " vs "
                       << int(*diff.second) << " (channels " << channels << ", src " << w << "x" << h << " stride "
                       << src_stride << ", dst width " << dst_width << ", m " << m[0] << " " << m[1] << " "
                       << m[2] << " " << m[3] << " " << m[4] << " " << m[5] << ")";
            }
        }
    }
    for (int k = 0; k < 3; ++k)
        if (warpKernelAvailable(kWarpKernels[k]))
            std::printf("%s: %d warps identical to scalar\n", warpKernelName(kWarpKernels[k]), used[k]);
    std::printf("%d of %d random warps taken by the fast path (%lld bytes compared), scalar output FNV-1a %016llx\n",
                taken, kTrials, bytes, (unsigned long long)checksum);
    EXPECT_GT(taken, kTrials * 3 / 4);
    // The same bytes on every architecture (x86-64 and aarch64 under qemu gave this): the
    // positions are computed in IEEE double without contraction into fused multiply-adds
    // (lib/meson.build builds the kernels with -ffp-contract=off).
    EXPECT_EQ(kExpectedChecksum, checksum) << std::hex << checksum;
}

TEST(WarpKernels, FrameWarperUsesTheChosenKernel)
{
    // The whole frame through FrameWarper equals the chosen kernel's planes, which every
    // test above compares with the scalar reference: one output on every machine.
    const FrameBuffer in = noiseFrame(PixelFormat::NV12, 203, 119, 5, 11);
    FrameBuffer out(PixelFormat::NV12, 203, 119), direct(PixelFormat::NV12, 203, 119);
    const Similarity s{2.3, -1.6, 0.03, 1.0 / 1.07};
    FrameWarper().warp(in.view(), out.view(), s);
    const FrameView &v = in.view();
    for (int p = 0; p < 2; ++p) {
        double m[6];
        FrameWarper::planeMatrix(v, p, s, m);
        const int w = v.planeWidth(p), h = v.planeHeight(p), c = p == 0 ? 1 : 2;
        const std::uint8_t border[4] = {std::uint8_t(p == 0 ? 16 : 128), 128, 0, 0};  // FrameWarper's black
        ASSERT_TRUE(warpPlaneBilinear({v.planes[p].data, v.planes[p].stride, w, h}, direct.view().planes[p].data,
                                      direct.view().planes[p].stride, w, 0, h, c, m, false, border,
                                      WarpKernel::Scalar));
        for (int y = 0; y < h; ++y)
            ASSERT_EQ(0, std::memcmp(out.row(p, y), direct.row(p, y), std::size_t(w * c))) << "plane " << p << " row " << y;
    }
}

// Transforms per output row (rolling-shutter correction).

#include "estimate/luma_extractor.hpp"  // needsByteSwap
#include "render/row_transforms.hpp"

namespace {

const PixelFormat kAllFormatsAnd16Bit[] = {PixelFormat::Gray8, PixelFormat::I420,     PixelFormat::YV12,
                                           PixelFormat::NV12,  PixelFormat::NV21,     PixelFormat::RGB,
                                           PixelFormat::BGR,   PixelFormat::RGBA,     PixelFormat::BGRA,
                                           PixelFormat::RGBx,  PixelFormat::BGRx,     PixelFormat::Gray16LE,
                                           PixelFormat::Gray16BE};

// What a rolling shutter asks for: translation varying by +-3 px, rotation by +-0.2 degree
// and scale by +-0.5 % down the frame (rows 0 and height - 1 are the extremes, one more
// anchor in between), about `base`.
RowTransforms shutterWobble(const Similarity &base, int height)
{
    const double deg = 3.14159265358979 / 180.0;
    const auto at = [&](double k) {
        return Similarity{base.dx + 3.0 * k, base.dy - 3.0 * k, base.angle + 0.2 * deg * k, base.scale * (1.0 + 0.005 * k)};
    };
    return RowTransforms({0.0, 0.4 * (height - 1), double(height - 1)}, {at(-1.0), at(0.3), at(1.0)});
}

void expectSameFrames(const FrameBuffer &a, const FrameBuffer &b, const std::string &what)
{
    const FrameView &v = a.view();
    for (int p = 0; p < v.planeCount(); ++p)
        for (int y = 0; y < v.planeHeight(p); ++y)
            ASSERT_EQ(0, std::memcmp(a.row(p, y), b.row(p, y), std::size_t(v.planeRowBytes(p))))
                << what << " plane " << p << " row " << y;
}

// Every plane row's matrix for rows [y0, y1) of plane `plane`, as FrameWarper computes them.
std::vector<std::array<double, 6>> planeRowMatrices(const FrameView &v, int plane, const RowTransforms &rows, int y0,
                                                    int y1)
{
    const RowMatrices luma(rows, v.width, v.height);
    const int f = planeLayout(v.format, plane).subsample_y;
    std::vector<std::array<double, 6>> m(std::size_t(std::max(0, y1 - y0)));
    for (int y = y0; y < y1; ++y)
        FrameWarper::planeMatrix(v, plane, luma.at(f * y + (f - 1) * 0.5), m[std::size_t(y - y0)].data());
    return m;
}

} // namespace

TEST(RowTransforms, InterpolatesBetweenAnchorsAndHoldsBeyond)
{
    const Similarity a{1.0, -2.0, 0.01, 1.0}, b{5.0, 2.0, -0.01, 1.02};
    const RowTransforms rows({10.0, 30.0}, {a, b});
    EXPECT_FALSE(rows.isConstant());
    const RowMatrices m(rows, 64, 48);
    const auto ma = a.pixelMatrix(64, 48), mb = b.pixelMatrix(64, 48);
    EXPECT_EQ(ma, m.at(-5.0));
    EXPECT_EQ(ma, m.at(10.0));
    EXPECT_EQ(mb, m.at(30.0));
    EXPECT_EQ(mb, m.at(100.0));
    const auto mid = m.at(25.0);
    for (int k = 0; k < 6; ++k)
        EXPECT_NEAR(mid[k], 0.25 * ma[k] + 0.75 * mb[k], 1e-12) << k;
    // No anchor: the identity; one, or all equal: constant.
    EXPECT_EQ(Similarity::identity().pixelMatrix(64, 48), RowMatrices(RowTransforms({}, {}), 64, 48).at(7.0));
    EXPECT_TRUE(RowTransforms(a).isConstant());
    EXPECT_TRUE(RowTransforms({0.0, 5.0}, {a, a}).isConstant());
    EXPECT_THROW(RowTransforms({0.0, 5.0}, {a}), std::invalid_argument);
    EXPECT_THROW(RowTransforms({5.0, 5.0}, {a, b}), std::invalid_argument);
    EXPECT_THROW(RowTransforms({0.0, std::nan("")}, {a, b}), std::invalid_argument);
}

TEST(FrameWarperPerRow, EqualRowTransformsWriteTheSingleTransformsBytes)
{
    // Anchors whose transforms are equal over the whole frame but not before it: the
    // per-row path (not the constant shortcut) with every row's matrix the single one.
    // Mappings the fast kernel takes and one it does not (a large rotation: OpenCV).
    const Similarity mappings[] = {{1.3, -2.7, 0.02, 0.97}, {-6.0, 4.0, 0.0, 1.0}, {2.0, 1.0, 0.4, 1.1}};
    for (PixelFormat format : kAllFormatsAnd16Bit)
        for (const auto &size : {std::pair<int, int>{67, 41}, std::pair<int, int>{203, 119}})
            for (const Similarity &s : mappings) {
                const int w = size.first, h = size.second;
                const FrameBuffer in = noiseFrame(format, w, h, 9, 3);
                FrameBuffer single(format, w, h, 1), per_row(format, w, h, 1);
                const RowTransforms rows({-20.0, -1.0, 30.0}, {Similarity{9.0, 9.0, 0.1, 1.3}, s, s});
                ASSERT_FALSE(rows.isConstant());
                FrameWarper().warp(in.view(), single.view(), s);
                FrameWarper().warp(in.view(), per_row.view(), rows);
                expectSameFrames(single, per_row, std::string(toString(format)) + " " + std::to_string(w));
            }
}

TEST(WarpKernels, PerRowTransformsWriteTheSameBytesInEveryKernel)
{
    // Genuinely varying rows (translation, rotation and scale changing down the frame, so
    // the lane steps change too) through every kernel: the scalar reference's bytes, and
    // row by row the bytes of the single-transform warp with that row's matrix.
    std::mt19937 rng(20260421);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    int compared = 0;
    for (int trial = 0; trial < 60; ++trial) {
        const PixelFormat format = trial % 3 == 0 ? PixelFormat::Gray8 : PixelFormat::NV12;
        const int w = 150 + int(rng() % 120), h = 60 + int(rng() % 80);
        const FrameBuffer in = noiseFrame(format, w, h, unsigned(trial), int(rng() % 9));
        const FrameView &v = in.view();
        const Similarity base{uniform(-8, 8), uniform(-8, 8), uniform(-0.03, 0.03), uniform(0.93, 1.05)};
        const RowTransforms rows = shutterWobble(base, h);
        for (int p = 0; p < v.planeCount(); ++p) {
            const int channels = planeLayout(format, p).channels;
            const int pw = v.planeWidth(p), ph = v.planeHeight(p);
            const int y0 = trial % 4 == 0 ? int(rng() % unsigned(ph)) : 0, y1 = trial % 4 == 0 ? ph - 3 : ph;
            const auto m = planeRowMatrices(v, p, rows, y0, y1);
            const PlaneSpan span{v.planes[p].data, v.planes[p].stride, pw, ph};
            const bool replicate = trial % 2;
            const std::uint8_t border[4] = {16, 128, 128, 255};
            const int stride = pw * channels + 5;
            std::vector<std::uint8_t> reference(std::size_t(stride) * ph, 0xa5);
            ASSERT_TRUE(warpPlaneBilinearRows(span, reference.data(), stride, pw, y0, y1, channels, m.data(),
                                              replicate, border, WarpKernel::Scalar));
            // Row by row, the single-transform warp with the row's matrix.
            std::vector<std::uint8_t> single(reference.size(), 0xa5);
            for (int y = y0; y < y1; ++y)
                ASSERT_TRUE(warpPlaneBilinear(span, single.data(), stride, pw, y, y + 1, channels,
                                              m[std::size_t(y - y0)].data(), replicate, border, WarpKernel::Scalar));
            ASSERT_TRUE(single == reference) << "trial " << trial << " plane " << p;
            for (WarpKernel kernel : kWarpKernels) {
                if (!warpKernelAvailable(kernel))
                    continue;
                std::vector<std::uint8_t> out(reference.size(), 0xa5);
                ASSERT_TRUE(warpPlaneBilinearRows(span, out.data(), stride, pw, y0, y1, channels, m.data(), replicate,
                                                  border, kernel));
                const auto diff = std::mismatch(out.begin(), out.end(), reference.begin());
                ASSERT_TRUE(diff.first == out.end())
                    << warpKernelName(kernel) << " differs from scalar in trial " << trial << " plane " << p
                    << " at row " << (diff.first - out.begin()) / stride << " byte "
                    << (diff.first - out.begin()) % stride;
                ++compared;
            }
        }
    }
    std::printf("%d per-row warps identical to the scalar reference\n", compared);
    // A row the fast kernels do not handle: nothing written, the caller takes it.
    const FrameBuffer in = noiseFrame(PixelFormat::Gray8, 64, 32, 1);
    std::vector<std::array<double, 6>> m(32, {1.0, 0.0, 0.0, 0.0, 1.0, 0.0});
    m[17] = {0.9, -0.4, 0.0, 0.4, 0.9, 0.0};
    std::vector<std::uint8_t> out(64 * 32, 0xa5);
    const std::uint8_t border[4] = {};
    EXPECT_FALSE(warpPlaneBilinearRows({in.view().planes[0].data, in.view().planes[0].stride, 64, 32}, out.data(), 64,
                                       64, 0, 32, 1, m.data(), false, border));
    EXPECT_TRUE(std::all_of(out.begin(), out.end(), [](std::uint8_t b) { return b == 0xa5; }));
}

TEST(WarpKernels, PerRowTransformsAtSixteenBitsWriteTheSingleTransformsRows)
{
    for (PixelFormat format : {PixelFormat::Gray16LE, PixelFormat::Gray16BE})
        for (int trial = 0; trial < 6; ++trial) {
            const int w = 97 + 13 * trial, h = 51 + 7 * trial;
            const FrameBuffer in = noiseFrame(format, w, h, unsigned(trial), trial);
            const FrameView &v = in.view();
            const RowTransforms rows = shutterWobble({1.5 * trial - 4.0, 2.0 - trial, 0.01 * (trial - 3), 0.98}, h);
            const auto m = planeRowMatrices(v, 0, rows, 0, h);
            const PlaneSpan span{v.planes[0].data, v.planes[0].stride, w, h};
            const bool swap = needsByteSwap(format), replicate = trial % 2 == 1;
            std::vector<std::uint8_t> per_row(std::size_t(w) * 2 * h), single(per_row.size());
            warpPlaneBilinear16Rows(span, per_row.data(), w * 2, w, 0, h, m.data(), replicate, 7, swap);
            for (int y = 0; y < h; ++y)
                warpPlaneBilinear16(span, single.data(), w * 2, w, y, y + 1, m[std::size_t(y)].data(), replicate, 7,
                                    swap);
            ASSERT_TRUE(per_row == single) << toString(format) << " trial " << trial;
        }
}

TEST(FrameWarperPerRow, ShearMovesEachRowByItsOwnAmount)
{
    // dx(y) = y (anchors 0 and 64: the interpolation weights are exact in binary), so row y
    // of the output is row y of the input moved left by exactly y pixels: whole pixels, so
    // the bilinear taps give the input bytes exactly. Luma planes through the fast kernel,
    // 16-bit samples and 4-channel pixels through OpenCV, a call per row.
    const int w = 160, h = 64;
    for (PixelFormat format :
         {PixelFormat::Gray8, PixelFormat::I420, PixelFormat::NV12, PixelFormat::Gray16LE, PixelFormat::BGRx}) {
        const FrameBuffer in = noiseFrame(format, w, h, 4, 2);
        FrameBuffer out(format, w, h);
        const RowTransforms shear({0.0, 64.0}, {Similarity{0.0, 0.0, 0.0, 1.0}, Similarity{64.0, 0.0, 0.0, 1.0}});
        FrameWarper().warp(in.view(), out.view(), shear);
        const int bytes = planeLayout(format, 0).bytes_per_sample * planeLayout(format, 0).channels;
        int checked = 0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x + y < w; ++x) {
                ASSERT_EQ(0, std::memcmp(out.row(0, y) + x * bytes, in.row(0, y) + (x + y) * bytes, std::size_t(bytes)))
                    << toString(format) << " at " << x << "," << y;
                ++checked;
            }
        EXPECT_GT(checked, w * h / 2);
    }
}

TEST(FrameWarperPerRow, RowsOnEitherSideOfAStepGetTheirSingleTransformsBytes)
{
    // Transform a down to luma row 40 and b from row 41 on (the interpolation between equal
    // anchors is exact): those rows are the single-transform warps' rows. b is a rotation
    // the fast kernel does not take, so OpenCV draws the lower rows.
    const Similarity a{1.3, -2.7, 0.02, 0.97}, b{-2.0, 3.0, 0.4, 1.05};
    const RowTransforms step({0.0, 40.0, 41.0, 95.0}, {a, a, b, b});
    for (PixelFormat format : kAllFormatsAnd16Bit) {
        const int w = 131, h = 96;
        const FrameBuffer in = noiseFrame(format, w, h, 12, 4);
        FrameBuffer per_row(format, w, h), single_a(format, w, h), single_b(format, w, h);
        FrameWarper().warp(in.view(), per_row.view(), step);
        FrameWarper().warp(in.view(), single_a.view(), a);
        FrameWarper().warp(in.view(), single_b.view(), b);
        const FrameView &v = in.view();
        for (int p = 0; p < v.planeCount(); ++p) {
            const int f = planeLayout(format, p).subsample_y;
            for (int y = 0; y < v.planeHeight(p); ++y) {
                const double luma_row = f * y + (f - 1) * 0.5;
                if (luma_row > 40.0 && luma_row < 41.0)
                    continue;  // interpolated: neither
                const FrameBuffer &expected = luma_row <= 40.0 ? single_a : single_b;
                ASSERT_EQ(0, std::memcmp(per_row.row(p, y), expected.row(p, y), std::size_t(v.planeRowBytes(p))))
                    << toString(format) << " plane " << p << " row " << y;
            }
        }
    }
}

TEST(FrameWarperPerRow, StripesTogetherEqualTheWholeFrame)
{
    // Stripe edges at odd rows too; rotation growing down the frame past what the fast
    // kernel takes, so that fast and OpenCV rows alternate within a plane.
    for (PixelFormat format : {PixelFormat::NV12, PixelFormat::I420, PixelFormat::BGRx, PixelFormat::Gray16BE}) {
        const int w = 128, h = 96;
        const FrameBuffer in = noiseFrame(format, w, h, 3);
        for (const RowTransforms &rows :
             {shutterWobble({1.3, -2.7, 0.02, 0.97}, h),
              RowTransforms({0.0, 50.0, 95.0}, {Similarity{1.0, 2.0, 0.0, 1.0}, Similarity{-2.0, 1.0, 0.15, 1.0},
                                                Similarity{0.0, 0.0, -0.01, 1.01}})}) {
            FrameBuffer whole(format, w, h), striped(format, w, h);
            FrameWarper().warp(in.view(), whole.view(), rows);
            const int edges[] = {0, 30, 37, 64, 96};
            for (int i = 0; i + 1 < 5; ++i)
                FrameWarper().warpRows(in.view(), striped.view(), rows, edges[i], edges[i + 1]);
            expectSameFrames(whole, striped, std::string(toString(format)));
        }
    }
}

// 4-byte pixels (BGRx, RGBA...): the kernels write the bytes OpenCV's warpAffine writes.
namespace {

// What FrameWarper's general path does for rows [row_begin, row_end) of a plane: OpenCV on
// the stripe, its matrix shifted to the stripe's first row.
void openCvStripe(const PlaneSpan &src, std::uint8_t *dst, int dst_stride, int dst_width, int row_begin,
                  int row_end, const double plane_m[6], bool replicate, const std::uint8_t border[4])
{
    const cv::Mat in(src.height, src.width, CV_8UC4, const_cast<std::uint8_t *>(src.data), std::size_t(src.stride));
    cv::Mat out = cv::Mat(row_end, dst_width, CV_8UC4, dst, std::size_t(dst_stride)).rowRange(row_begin, row_end);
    double m[6];
    std::copy(plane_m, plane_m + 6, m);
    m[2] += m[1] * row_begin;
    m[5] += m[4] * row_begin;
    cv::warpAffine(in, out, cv::Mat(2, 3, CV_64F, m), out.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                   replicate ? cv::BORDER_REPLICATE : cv::BORDER_CONSTANT,
                   cv::Scalar(border[0], border[1], border[2], border[3]));
}

} // namespace

TEST(WarpKernels, FourChannelKernelsWriteOpenCvsBytes)
{
    // Random warps from near-identity to large rotations, zooms, flips and shears, odd
    // widths, padded strides, stripes, both borders, shifts far off every edge: every
    // 4-channel kernel available here writes exactly cv::warpAffine's bytes, padding untouched.
    std::mt19937 rng(20261202);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    const auto integer = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    constexpr int kTrials = 1200;
    int used[3] = {};
    for (int trial = 0; trial < kTrials; ++trial) {
        const int w = integer(1, 150), h = integer(1, 60);
        const int src_stride = w * 4 + (trial % 3 == 0 ? 0 : integer(1, 40));
        std::vector<std::uint8_t> src(std::size_t(src_stride) * (h - 1) + std::size_t(w) * 4);
        const int content = trial % 3;
        for (std::size_t i = 0; i < src.size(); ++i)
            src[i] = content == 0 ? std::uint8_t(rng())
                     : content == 1 ? std::uint8_t(((int(i % std::size_t(src_stride)) / 4 + int(i / std::size_t(src_stride))) / 2) % 2 ? 255 : 0)
                                    : std::uint8_t((i * 7) & 255);
        double m[6];
        const int kind = trial % 6;
        const double turn = kind == 0 ? 0.0 : kind == 5 ? uniform(-0.8, 0.8) : uniform(-0.06, 0.06);
        const double scale = kind == 1 ? 1.0 : kind == 5 ? uniform(0.3, 3.0) : uniform(0.8, 1.25);
        m[0] = scale * (1.0 - 0.5 * turn * turn) * (kind == 4 ? -1.0 : 1.0);
        m[1] = -scale * turn + (kind == 3 ? uniform(-0.3, 0.3) : 0.0);
        m[3] = scale * turn;
        m[4] = scale * (1.0 - 0.5 * turn * turn);
        const bool whole = trial % 13 == 0;
        m[2] = whole ? integer(-w / 2, w / 2) : uniform(-0.5 * w, 0.5 * w) + (kind == 4 ? w : 0);
        m[5] = whole ? integer(-h / 2, h / 2) : uniform(-0.5 * h, 0.5 * h);
        if (trial % 17 == 0)  // halfway between 1/32 px steps: the rounding's ties
            m[2] = std::round(m[2] * 32.0) / 32.0 + 1.0 / 64.0;
        const int dst_width = integer(1, 170), dst_height = integer(1, 60);
        const int dst_stride = dst_width * 4 + integer(0, 24);
        const int row_begin = integer(0, dst_height - 1), row_end = integer(row_begin + 1, dst_height);
        const bool replicate = rng() % 2;
        const std::uint8_t border[4] = {std::uint8_t(rng()), std::uint8_t(rng()), std::uint8_t(rng()),
                                        std::uint8_t(rng())};
        const PlaneSpan span{src.data(), src_stride, w, h};
        std::vector<std::uint8_t> reference(std::size_t(dst_stride) * dst_height, 0xa5);
        openCvStripe(span, reference.data(), dst_stride, dst_width, row_begin, row_end, m, replicate, border);
        for (int k = 0; k < 3; ++k) {
            const WarpKernel kernel = kWarpKernels[k];
            std::vector<std::uint8_t> out(reference.size(), 0xa5);
            if (!warpPlaneBilinear4(span, out.data(), dst_stride, dst_width, row_begin, row_end, m, replicate, border,
                                    kernel))
                continue;
            ++used[k];
            const auto diff = std::mismatch(out.begin(), out.end(), reference.begin());
            if (diff.first != out.end()) {
                const std::size_t at = std::size_t(diff.first - out.begin());
                FAIL() << warpKernelName(kernel) << " differs from OpenCV in trial " << trial << " at row "
                       << at / dst_stride << " byte " << at % dst_stride << ": " << int(*diff.first) << " vs "
                       << int(*diff.second) << " (src " << w << "x" << h << " stride " << src_stride
                       << ", dst width " << dst_width << ", rows " << row_begin << "-" << row_end << ", m " << m[0]
                       << " " << m[1] << " " << m[2] << " " << m[3] << " " << m[4] << " " << m[5] << ")";
            }
        }
    }
    for (int k = 0; k < 3; ++k)
        std::printf("%s: %d 4-channel warps identical to OpenCV\n", warpKernelName(kWarpKernels[k]), used[k]);
    EXPECT_EQ(kTrials, used[0]);  // the scalar kernel takes every one of these
    if (warpKernelAvailable(WarpKernel::Avx2)) {
        EXPECT_EQ(kTrials, used[2]);
    }
}

TEST(WarpKernels, FourChannelFramesWarpAsOpenCvWarpsThem)
{
    // BGRx and RGBA through FrameWarper, whole frame and stripes: the bytes OpenCV writes
    // with the plane's matrix.
    for (PixelFormat format : {PixelFormat::BGRx, PixelFormat::RGBA}) {
        const FrameBuffer in = noiseFrame(format, 197, 103, 3, 7);
        for (int t = 0; t < 3; ++t) {
            const Similarity s = t == 0   ? Similarity{2.3, -1.6, 0.03, 1.0 / 1.07}
                                 : t == 1 ? Similarity{-40.0, 25.0, -0.4, 1.3}
                                          : Similarity{0.25, 0.5, 0.0, 1.0};
            for (bool replicate : {false, true}) {
                const FrameWarper warper(replicate ? BorderMode::Replicate : BorderMode::Black);
                FrameBuffer out(format, 197, 103), striped(format, 197, 103), expected(format, 197, 103),
                    whole(format, 197, 103);
                warper.warp(in.view(), out.view(), s);
                for (int r = 0; r < 103; r += 29)
                    warper.warpRows(in.view(), striped.view(), s, r, std::min(103, r + 29));
                double m[6];
                FrameWarper::planeMatrix(in.view(), 0, s, m);
                const std::uint8_t black[4] = {0, 0, 0, 255};  // FrameWarper's black for both
                const FrameView &v = in.view();
                openCvStripe({v.planes[0].data, v.planes[0].stride, 197, 103}, whole.view().planes[0].data,
                             whole.view().planes[0].stride, 197, 0, 103, m, replicate, black);
                for (int r = 0; r < 103; r += 29)
                    openCvStripe({v.planes[0].data, v.planes[0].stride, 197, 103}, expected.view().planes[0].data,
                                 expected.view().planes[0].stride, 197, r, std::min(103, r + 29), m, replicate, black);
                for (int y = 0; y < 103; ++y) {
                    ASSERT_EQ(0, std::memcmp(striped.row(0, y), expected.row(0, y), 197 * 4)) << "row " << y;
                    ASSERT_EQ(0, std::memcmp(out.row(0, y), whole.row(0, y), 197 * 4)) << "row " << y;
                }
            }
        }
    }
}

TEST(WarpKernels, WideRowsWriteTheSameBytesAsTheScalarReference)
{
    // Rows of more than 1024 pixels (the AVX2 kernel plans a row's chunks 64 at a time),
    // through every kernel, with one matrix and with a matrix per row.
    std::mt19937 rng(20261203);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    const auto integer = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    for (int trial = 0; trial < 60; ++trial) {
        const int channels = 1 + trial % 2;
        const int w = integer(1030, 2400), h = integer(8, 24);
        const int src_stride = w * channels + integer(0, 33);
        std::vector<std::uint8_t> src(std::size_t(src_stride) * (h - 1) + std::size_t(w) * channels);
        for (auto &b : src)
            b = std::uint8_t(rng());
        const double turn = uniform(-0.004, 0.004), scale = uniform(0.85, 1.2);
        std::vector<std::array<double, 6>> rows(static_cast<std::size_t>(h));
        for (int y = 0; y < h; ++y) {
            double *m = rows[std::size_t(y)].data();
            m[0] = scale * (1.0 - 0.5 * turn * turn);
            m[1] = -scale * turn;
            m[3] = scale * turn;
            m[4] = m[0];
            m[2] = uniform(-0.1 * w, 0.1 * w) * (trial % 3 == 0 ? 0.0 : 1.0) + (trial % 4 == 0 ? 0.5 * y : 0.0);
            m[5] = uniform(-2.0, 2.0);
            if (trial % 2 == 0 && y > 0)
                rows[std::size_t(y)] = rows[0];
        }
        const int dst_width = w + integer(-20, 20), dst_stride = dst_width * channels + integer(0, 16);
        const bool replicate = rng() % 2;
        const std::uint8_t border[4] = {16, 128, 0, 0};
        const PlaneSpan span{src.data(), src_stride, w, h};
        std::vector<std::uint8_t> reference(std::size_t(dst_stride) * h, 0xa5), single_ref(reference);
        ASSERT_TRUE(warpPlaneBilinearRows(span, reference.data(), dst_stride, dst_width, 0, h, channels, rows.data(),
                                          replicate, border, WarpKernel::Scalar));
        ASSERT_TRUE(warpPlaneBilinear(span, single_ref.data(), dst_stride, dst_width, 0, h, channels, rows[0].data(),
                                      replicate, border, WarpKernel::Scalar));
        for (WarpKernel kernel : kWarpKernels) {
            if (!warpKernelAvailable(kernel))
                continue;
            std::vector<std::uint8_t> out(reference.size(), 0xa5), single(reference.size(), 0xa5);
            ASSERT_TRUE(warpPlaneBilinearRows(span, out.data(), dst_stride, dst_width, 0, h, channels, rows.data(),
                                              replicate, border, kernel));
            ASSERT_TRUE(warpPlaneBilinear(span, single.data(), dst_stride, dst_width, 0, h, channels, rows[0].data(),
                                          replicate, border, kernel));
            ASSERT_TRUE(out == reference) << warpKernelName(kernel) << " per row, trial " << trial;
            ASSERT_TRUE(single == single_ref) << warpKernelName(kernel) << " one matrix, trial " << trial;
        }
    }
}

TEST(WarpKernels, ChunksAtTheEdgesOfTheFastPathWriteTheSameBytesAsTheScalarReference)
{
    // The vector kernels test only the chunks near the frame's edges and take the ones in
    // between as they are: shifts swept across every edge in steps that are no multiple of
    // a pixel, so that chunks fall just inside and just outside each test, through every
    // kernel. The source ends with its last row, so a read past it is out of bounds.
    std::mt19937 rng(20261204);
    int compared = 0;
    for (int channels = 1; channels <= 2; ++channels) {
        const int w = 300, h = 40, src_stride = w * channels;
        std::vector<std::uint8_t> src(std::size_t(src_stride) * h);
        for (auto &b : src)
            b = std::uint8_t(rng());
        const PlaneSpan span{src.data(), src_stride, w, h};
        const std::uint8_t border[4] = {16, 128, 0, 0};
        for (double turn : {-0.03, 0.0, 0.021})
            for (double scale : {0.93, 1.0, 1.07})
                for (double shift_x = -24.0; shift_x <= 24.0; shift_x += 24.0 / 7.0 + 0.013)
                    for (double shift_y = -2.5; shift_y <= 2.5; shift_y += 0.37) {
                        const double m[6] = {scale, -scale * turn, shift_x, scale * turn, scale, shift_y};
                        std::vector<std::uint8_t> reference(src.size(), 0xa5);
                        ASSERT_TRUE(warpPlaneBilinear(span, reference.data(), src_stride, w, 0, h, channels, m, false,
                                                      border, WarpKernel::Scalar));
                        for (WarpKernel kernel : kWarpKernels) {
                            if (kernel == WarpKernel::Scalar || !warpKernelAvailable(kernel))
                                continue;
                            std::vector<std::uint8_t> out(src.size(), 0xa5);
                            ASSERT_TRUE(warpPlaneBilinear(span, out.data(), src_stride, w, 0, h, channels, m, false,
                                                          border, kernel));
                            const auto diff = std::mismatch(out.begin(), out.end(), reference.begin());
                            ASSERT_TRUE(diff.first == out.end())
                                << warpKernelName(kernel) << " differs at byte " << (diff.first - out.begin())
                                << " (channels " << channels << ", turn " << turn << ", scale " << scale
                                << ", shift " << shift_x << ", " << shift_y << ")";
                            ++compared;
                        }
                    }
    }
    std::printf("%d edge sweeps identical to scalar\n", compared);
}

TEST(WarpKernels, FourChannelRowsWiderThanAColumnBlockWriteOpenCvsBytes)
{
    // Rows of more than 2048 pixels (the AVX2 4-channel kernel rounds its column steps in
    // blocks of 2048 columns): still cv::warpAffine's bytes.
    std::mt19937 rng(20261204);
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    for (int trial = 0; trial < 6; ++trial) {
        const int w = 2040 + 1111 * trial, h = 9;
        const int stride = w * 4 + 12;
        std::vector<std::uint8_t> src(std::size_t(stride) * h);
        for (auto &b : src)
            b = std::uint8_t(rng());
        const double turn = uniform(-0.003, 0.003), scale = uniform(0.9, 1.1);
        const double m[6] = {scale, -scale * turn, uniform(-30, 30), scale * turn, scale, uniform(-2, 2)};
        const std::uint8_t border[4] = {0, 0, 0, 255};
        const PlaneSpan span{src.data(), stride, w, h};
        for (bool replicate : {false, true}) {
            std::vector<std::uint8_t> reference(src.size(), 0xa5), out(src.size(), 0xa5);
            openCvStripe(span, reference.data(), stride, w, 2, h, m, replicate, border);
            for (WarpKernel kernel : kWarpKernels) {
                std::fill(out.begin(), out.end(), 0xa5);
                if (warpPlaneBilinear4(span, out.data(), stride, w, 2, h, m, replicate, border, kernel)) {
                    ASSERT_TRUE(out == reference) << warpKernelName(kernel) << " trial " << trial;
                }
            }
        }
    }
}
