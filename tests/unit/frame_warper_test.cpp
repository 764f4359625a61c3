#include <gtest/gtest.h>

#include <random>

#include "buffer_slot.hpp"
#include "format_conversion.hpp"
#include "shaky_flight.hpp"
#include "uavstab/frame_warper.hpp"
#include "uavstab/framing.hpp"

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

#include "bilinear_warp.hpp"

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
    // (GCC in ISO C++ mode, -std=c++17, does not contract).
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
