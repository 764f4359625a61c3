#include <gtest/gtest.h>

#include <random>

#include "format_conversion.hpp"
#include "shaky_flight.hpp"
#include "uavstab/frame_warper.hpp"
#include "uavstab/framing.hpp"

using namespace uavstab;

namespace {

const PixelFormat kAllFormats[] = {PixelFormat::Gray8, PixelFormat::I420, PixelFormat::YV12, PixelFormat::NV12,
                                   PixelFormat::NV21,  PixelFormat::RGB,  PixelFormat::BGR,  PixelFormat::RGBA,
                                   PixelFormat::BGRA,  PixelFormat::RGBx, PixelFormat::BGRx};

// Random texture in every byte of every plane (not a plausible picture, which makes a
// misplaced plane or channel show).
FrameBuffer noiseFrame(PixelFormat format, int w, int h, unsigned seed, int padding = 0)
{
    FrameBuffer f(format, w, h, padding);
    std::mt19937 rng(seed);
    for (int p = 0; p < f.view().planeCount(); ++p)
        for (int y = 0; y < f.view().planeHeight(p); ++y)
            for (int x = 0; x < f.view().planeRowBytes(p); ++x)
                f.row(p, y)[x] = std::uint8_t(rng());
    return f;
}

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
