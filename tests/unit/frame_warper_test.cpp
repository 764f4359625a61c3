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
    // The SIMD kernel (1/64 px positions) against cv::warpAffine (1/32 px) on noise, the
    // hardest content: any misplaced tap or channel shows as a large difference.
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
                std::printf("fast kernel not used on this CPU (no AVX2): nothing to compare\n");
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
