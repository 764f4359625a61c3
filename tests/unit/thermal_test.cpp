// 16-bit thermal frames (GRAY16_LE, GRAY16_BE): the warp at full depth in either byte
// order, nothing clipped or rescaled, motion estimated through the automatic gain, which
// stays put when a hot spot enters a still scene, and a low-contrast flight with hot spots
// stabilized as well as the 8-bit one.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "buffer_slot.hpp"
#include "jitter_metrics.hpp"
#include "estimate/luma_extractor.hpp"
#include "shaky_flight.hpp"
#include "thermal.hpp"
#include "render/frame_warper.hpp"
#include "estimate/motion_estimator.hpp"
#include "uavstab/stabilizer.hpp"

using namespace uavstab;
using synthetic::sample16;
using synthetic::setSample16;

namespace {

const PixelFormat k16BitFormats[] = {PixelFormat::Gray16LE, PixelFormat::Gray16BE};

// Every 16-bit value is possible: random samples over the whole range.
FrameBuffer noise16(PixelFormat format, int w, int h, unsigned seed, int padding = 0)
{
    FrameBuffer f = test::noiseFrame(format, w, h, seed, padding);  // random bytes, padding included
    return f;
}

// Bilinear of the input's samples at (sx, sy), in double precision, or nullopt when a tap
// leaves the frame.
std::optional<double> referenceBilinear(const FrameView &in, double sx, double sy)
{
    const double x0 = std::floor(sx), y0 = std::floor(sy);
    const int ix = int(x0), iy = int(y0);
    if (ix < 0 || iy < 0 || ix + 1 >= in.width || iy + 1 >= in.height)
        return std::nullopt;
    const double fx = sx - x0, fy = sy - y0;
    const double p00 = sample16(in, ix, iy), p01 = sample16(in, ix + 1, iy);
    const double p10 = sample16(in, ix, iy + 1), p11 = sample16(in, ix + 1, iy + 1);
    return (1 - fy) * ((1 - fx) * p00 + fx * p01) + fy * ((1 - fx) * p10 + fx * p11);
}

// A 16-bit ramp (bilinear reproduces a ramp), with a curve on top when `curved`.
double rampValue(double x, double y)
{
    return 1000.0 + 150.3 * x + 97.1 * y;
}

FrameBuffer gradient16(PixelFormat format, int w, int h, bool curved)
{
    FrameBuffer f(format, w, h, 6);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            setSample16(f.view(), x, y,
                        std::uint16_t(std::lround(rampValue(x, y) + (curved ? 800.0 * std::sin(0.05 * x * y / 7.0) : 0.0))));
    return f;
}

} // namespace

TEST(Thermal, FormatsAreNamedAsGStreamerNamesThemAndHoldTwoBytesPerSample)
{
    EXPECT_EQ(pixelFormatFromString("GRAY16_LE"), PixelFormat::Gray16LE);
    EXPECT_EQ(pixelFormatFromString("GRAY16_BE"), PixelFormat::Gray16BE);
    EXPECT_EQ(toString(PixelFormat::Gray16BE), "GRAY16_BE");
    const FrameBuffer f(PixelFormat::Gray16BE, 33, 7, 4);
    EXPECT_EQ(f.view().planeCount(), 1);
    EXPECT_EQ(f.view().planeRowBytes(0), 66);
    EXPECT_EQ(f.view().planes[0].stride, 70);
    EXPECT_TRUE(is16Bit(PixelFormat::Gray16LE));
    EXPECT_FALSE(is16Bit(PixelFormat::Gray8));
    EXPECT_FALSE(isYuv(PixelFormat::Gray16LE));
}

TEST(Thermal, IdentityWarpIsBitExactInBothByteOrders)
{
    for (PixelFormat format : k16BitFormats)
        for (BorderMode border : {BorderMode::Black, BorderMode::Replicate}) {
            const FrameBuffer in = noise16(format, 67, 41, 11, 5);  // odd size, padded rows
            FrameBuffer out(format, 67, 41, 3);
            FrameWarper(border).warp(in.view(), out.view(), Similarity::identity());
            for (int y = 0; y < 41; ++y)
                ASSERT_EQ(0, std::memcmp(in.row(0, y), out.row(0, y), 67 * 2)) << toString(format) << " row " << y;
        }
}

TEST(Thermal, SubPixelWarpOfAGradientMatchesADoublePrecisionReference)
{
    const int w = 203, h = 119;
    const Similarity mappings[] = {{0.37, -0.81, 0.0, 1.0}, {3.3, -1.7, 0.02, 1.0 / 1.087}, {-0.4, 2.2, -0.05, 0.97}};
    for (PixelFormat format : k16BitFormats)
        for (bool curved : {false, true}) {
        const FrameBuffer in = gradient16(format, w, h, curved);
        for (const Similarity &s : mappings) {
            FrameBuffer out(format, w, h);
            FrameWarper().warp(in.view(), out.view(), s);
            const auto m = s.pixelMatrix(w, h);
            double worst = 0, worst_true = 0;
            long compared = 0;
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    const double sx = m[0] * x + m[1] * y + m[2], sy = m[3] * x + m[4] * y + m[5];
                    const auto expected = referenceBilinear(in.view(), sx, sy);
                    if (!expected)
                        continue;
                    const double got = sample16(out.view(), x, y);
                    worst = std::max(worst, std::abs(got - *expected));
                    // The plain ramp against its formula: off by the rounding of the input
                    // samples and of the result, at most.
                    if (!curved)
                        worst_true = std::max(worst_true, std::abs(got - rampValue(sx, sy)));
                    ++compared;
                }
            std::printf("%s %s (%.2f, %.2f, %.3f, %.4f): %ld px, worst %.3f from the reference, %.3f from the ramp\n",
                        std::string(toString(format)).c_str(), curved ? "curve" : "ramp", s.dx, s.dy, s.angle, s.scale,
                        compared, worst, worst_true);
            EXPECT_GT(compared, long(w) * h * 8 / 10);
            EXPECT_LE(worst, 0.5 + 1e-6) << toString(format);  // rounded to the nearest count, nothing else
            EXPECT_LE(worst_true, 1.0 + 1e-6) << toString(format);
        }
        }
}

TEST(Thermal, BigEndianWarpIsTheLittleEndianWarpByteSwapped)
{
    const int w = 96, h = 64;
    const FrameBuffer le = noise16(PixelFormat::Gray16LE, w, h, 4);
    FrameBuffer be(PixelFormat::Gray16BE, w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            setSample16(be.view(), x, y, sample16(le.view(), x, y));
    for (BorderMode border : {BorderMode::Black, BorderMode::Replicate}) {
        FrameBuffer out_le(PixelFormat::Gray16LE, w, h), out_be(PixelFormat::Gray16BE, w, h);
        const Similarity s{5.3, -7.1, 0.1, 0.9};
        FrameWarper(border).warp(le.view(), out_le.view(), s);
        FrameWarper(border).warp(be.view(), out_be.view(), s);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                ASSERT_EQ(sample16(out_le.view(), x, y), sample16(out_be.view(), x, y)) << x << "," << y;
                ASSERT_EQ(out_le.row(0, y)[2 * x], out_be.row(0, y)[2 * x + 1]);
            }
    }
}

TEST(Thermal, StripesTogetherEqualTheWholeFrame)
{
    const FrameBuffer in = noise16(PixelFormat::Gray16BE, 128, 96, 3);
    FrameBuffer whole(PixelFormat::Gray16BE, 128, 96), striped(PixelFormat::Gray16BE, 128, 96);
    const Similarity m{1.3, -2.7, 0.02, 0.97};
    FrameWarper().warp(in.view(), whole.view(), m);
    for (int y = 0; y < 96; y += 32)
        FrameWarper().warpRows(in.view(), striped.view(), m, y, y + 32);
    for (int y = 0; y < 96; ++y)
        ASSERT_EQ(0, std::memcmp(whole.row(0, y), striped.row(0, y), 256)) << "row " << y;
}

TEST(Thermal, AFlatFrameComesOutUnchangedAndBordersAreZeroOrReplicated)
{
    for (PixelFormat format : k16BitFormats) {
        FrameBuffer in(format, 64, 48);
        synthetic::fill16(in, 51234);
        FrameBuffer out(format, 64, 48);
        const Similarity s{-10.4, 3.3, 0.05, 0.95};
        FrameWarper(BorderMode::Black).warp(in.view(), out.view(), s);
        const auto m = s.pixelMatrix(64, 48);
        int covered = 0;
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x) {
                const double sx = m[0] * x + m[1] * y + m[2], sy = m[3] * x + m[4] * y + m[5];
                if (sx >= 0 && sy >= 0 && sx <= 63 && sy <= 47) {
                    ASSERT_EQ(sample16(out.view(), x, y), 51234) << x << "," << y;
                    ++covered;
                } else if (sx < -1 || sy < -1 || sx > 64 || sy > 48) {
                    ASSERT_EQ(sample16(out.view(), x, y), 0) << x << "," << y;  // black
                }
            }
        EXPECT_GT(covered, 64 * 48 / 2);
        FrameWarper(BorderMode::Replicate).warp(in.view(), out.view(), s);
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x)
                ASSERT_EQ(sample16(out.view(), x, y), 51234) << x << "," << y;
    }
}

TEST(Thermal, TheStabilizerPassesAFlatFrameThroughAt51234)
{
    // No texture: nothing to track, so the frames are only zoomed by the crop.
    Stabilizer stabilizer(StabilizerConfig{});
    for (int i = 0; i < 5; ++i) {
        FrameBuffer f(PixelFormat::Gray16BE, 96, 64, 2);
        synthetic::fill16(f, 51234);
        stabilizer.push(test::BufferSlot::make(std::move(f), i));
    }
    stabilizer.flush();
    int frames = 0;
    while (auto f = stabilizer.waitPop()) {
        ASSERT_EQ(f->outcome, Outcome::Warped);
        const FrameBuffer &out = test::BufferSlot::of(*f).outputBuffer();
        EXPECT_EQ(synthetic::sampleRange(out.view()), (std::pair<std::uint16_t, std::uint16_t>(51234, 51234)));
        ++frames;
    }
    EXPECT_EQ(frames, 5);
}

// --- The automatic gain -------------------------------------------------------------

namespace {

cv::Mat flat16(int w, int h, std::uint16_t value)
{
    return cv::Mat(h, w, CV_16UC1, cv::Scalar(value));
}

// A still low-contrast scene (frame 0 of the flight, 320x240) with fresh noise per frame.
synthetic::FlightOptions stillScene()
{
    synthetic::FlightOptions o;
    o.width = 320;
    o.height = 240;
    o.frames = 1;
    return o;
}

} // namespace

TEST(Thermal, AutoGainStartsAtThePercentilesAndIgnoresNoise)
{
    AutoGain gain;
    cv::Mat image(200, 300, CV_16UC1);
    cv::randu(image, cv::Scalar(30000), cv::Scalar(30400));
    const AutoGain::Limits first = gain.update(image);
    EXPECT_NEAR(first.low, 30004, 4);
    EXPECT_NEAR(first.high, 30396, 4);
    // Another draw of the same scene: the percentiles wobble, the limits do not move.
    for (int i = 0; i < 10; ++i) {
        cv::randu(image, cv::Scalar(30000), cv::Scalar(30400));
        const AutoGain::Limits l = gain.update(image);
        EXPECT_EQ(l.low, first.low);
        EXPECT_EQ(l.high, first.high);
    }
    // A frame one row high and far wider than a sampling step is still sampled.
    AutoGain thin;
    EXPECT_NEAR(thin.update(flat16(100000, 1, 20000)).low, 20000 - AutoGain::kMinSpan / 2, 1e-9);
    // A flat frame is not stretched beyond kMinSpan counts over 256 levels.
    AutoGain flat;
    const AutoGain::Limits f = flat.update(flat16(50, 40, 51234));
    EXPECT_DOUBLE_EQ(f.high - f.low, AutoGain::kMinSpan);
    EXPECT_DOUBLE_EQ(0.5 * (f.high + f.low), 51234);
}

TEST(Thermal, AutoGainFollowsAHotObjectSlowlyAndANewSceneFast)
{
    AutoGain gain;
    cv::Mat image(200, 300, CV_16UC1);
    cv::randu(image, cv::Scalar(30000), cv::Scalar(30400));
    gain.update(image);
    // 5 % of the frame at 60000: the 99th percentile jumps; the limits creep.
    image(cv::Rect(0, 0, 30, 100)).setTo(60000);
    AutoGain::Limits previous = gain.limits();
    for (int i = 0; i < 30; ++i) {
        const AutoGain::Limits l = gain.update(image);
        const double span = previous.high - previous.low;
        EXPECT_LE(std::abs(l.high - previous.high), AutoGain::kMaxRate * span + 1e-9) << i;
        EXPECT_LE(std::abs(l.low - previous.low), AutoGain::kMaxRate * span + 1e-9) << i;
        previous = l;
    }
    EXPECT_GT(previous.high, 30400 + 60);  // it does follow
    // The camera turns to a scene 5000 counts hotter: everything clips, the limits jump
    // there in a few frames (fast until less than a quarter of the frame clips, then
    // they creep the rest of the way).
    cv::randu(image, cv::Scalar(35000), cv::Scalar(35400));
    int frames = 0;
    while (gain.lastMeasurement().clipped_share >= AutoGain::kLostShare || frames == 0) {
        gain.update(image);
        ASSERT_LT(++frames, 100);
    }
    std::printf("a 5000-count hotter scene: limits %.0f..%.0f after %d frames (%.0f %% clipped)\n", gain.limits().low,
                gain.limits().high, frames, 100 * gain.lastMeasurement().clipped_share);
    EXPECT_LE(frames, 8);
    EXPECT_NEAR(gain.limits().low, 35004, 100);
    EXPECT_NEAR(gain.limits().high, 35396, 100);
    // reset(): the next frame sets the limits directly.
    gain.reset();
    EXPECT_FALSE(gain.initialized());
    cv::randu(image, cv::Scalar(1000), cv::Scalar(1400));
    EXPECT_NEAR(gain.update(image).low, 1004, 4);
}

TEST(Thermal, AHotSpotEnteringAStillSceneIsNotMotion)
{
    const synthetic::ShakyFlight scene(stillScene());
    // Three hot spots (6 % of the frame together) appear at once at frame 8; one more
    // drives in from the left edge from frame 14.
    synthetic::ThermalOptions thermal;
    thermal.format = PixelFormat::Gray16LE;
    for (const Point2 p : {Point2{-80, -50}, Point2{70, 40}, Point2{20, -70}})
        thermal.hot_spots.push_back({p, {0, 0}, 20.0, 8});
    thermal.hot_spots.push_back({{-175, 10}, {3, 0}, 12.0, 14});
    const Similarity pose = scene.truePose(0);

    const cv::Mat bgr = scene.renderBgr(0);
    cv::Mat grey(bgr.size(), CV_32FC1);
    for (int y = 0; y < bgr.rows; ++y)
        for (int x = 0; x < bgr.cols; ++x) {
            const cv::Vec3b &p = bgr.at<cv::Vec3b>(y, x);
            grey.at<float>(y, x) = float(0.299 * p[2] + 0.587 * p[1] + 0.114 * p[0]);
        }

    StabilizerConfig config;
    MotionEstimator estimator(config);
    double worst = 0;
    int estimated = 0;
    for (int i = 0; i < 40; ++i) {
        const FrameBuffer frame = synthetic::thermalFrame(grey, pose, i, thermal);
        const MotionEstimate e = estimator.estimate(frame.view());
        if (e.first)
            continue;
        EXPECT_FALSE(e.skipped) << "frame " << i << ": " << e.points << " points";
        if (e.skipped)
            continue;
        ++estimated;
        // Largest displacement of a frame corner under the estimated motion.
        double corner = 0;
        for (const Point2 c : {Point2{-159.5, -119.5}, Point2{159.5, -119.5}, Point2{-159.5, 119.5}, Point2{159.5, 119.5}}) {
            const Point2 m = e.motion.apply(c);
            corner = std::max(corner, std::hypot(m.x - c.x, m.y - c.y));
        }
        worst = std::max(worst, corner);
        EXPECT_LT(corner, 0.2) << "frame " << i << ": motion " << e.motion.dx << ", " << e.motion.dy << ", "
                               << e.motion.angle << ", " << e.motion.scale;
    }
    std::printf("still scene, hot spots entering: %d estimates, largest corner motion %.4f px\n", estimated, worst);
    RecordProperty("hot_spot_motion_px", std::to_string(worst));
    EXPECT_EQ(estimated, 39);
}

TEST(Thermal, BigEndianFramesGiveTheSameMotionAsLittleEndian)
{
    synthetic::FlightOptions options;
    options.width = 320;
    options.height = 240;
    options.frames = 12;
    const synthetic::ShakyFlight flight(options);
    synthetic::ThermalOptions le, be;
    be.format = PixelFormat::Gray16BE;
    MotionEstimator a{StabilizerConfig{}}, b{StabilizerConfig{}};
    for (int i = 0; i < options.frames; ++i) {
        const MotionEstimate ea = a.estimate(synthetic::renderThermal(flight, i, le).view());
        const MotionEstimate eb = b.estimate(synthetic::renderThermal(flight, i, be).view());
        EXPECT_EQ(ea.points, eb.points);
        EXPECT_EQ(ea.motion.dx, eb.motion.dx);
        EXPECT_EQ(ea.motion.dy, eb.motion.dy);
        EXPECT_EQ(ea.motion.angle, eb.motion.angle);
        if (i > 0) {
            EXPECT_FALSE(ea.skipped) << i;
        }
    }
}

// --- A thermal flight ---------------------------------------------------------------

TEST(Thermal, ALowContrastFlightWithHotSpotsIsStabilizedWithoutTouchingTheValues)
{
    synthetic::FlightOptions options;
    options.frames = 150;
    const synthetic::ShakyFlight flight(options);
    // The picture in 400 counts over 30000, 2 counts of noise; hot spots at 60000: two
    // driving across, one parked that appears mid-clip, one that leaves.
    synthetic::ThermalOptions thermal;
    thermal.format = PixelFormat::Gray16LE;
    thermal.hot_spots = {
        {{-200, -60}, {2.5, 0.4}, 10.0},
        {{150, 90}, {-1.5, -1.0}, 8.0},
        {{40, -30}, {0, 0}, 14.0, 60},
        {{-60, 100}, {0.5, -0.5}, 9.0, 0, 100},
    };

    StabilizerConfig config;
    Stabilizer stabilizer(config);
    std::vector<Similarity> input_path, output_path;
    std::vector<std::pair<std::uint16_t, std::uint16_t>> input_ranges;
    int outside_range = 0, skipped = 0;
    auto collect = [&](StabilizedFrame f) {
        const auto &slot = test::BufferSlot::of(f);
        const int id = slot.id();
        ASSERT_EQ(id, int(output_path.size()));
        ASSERT_EQ(f.outcome, Outcome::Warped);
        input_path.push_back(flight.truePose(id));
        output_path.push_back(flight.truePose(id) * synthetic::outputToInput(f.stats));
        skipped += f.stats.skipped;
        const auto in = input_ranges[std::size_t(id)];
        const auto out = synthetic::sampleRange(slot.outputBuffer().view());
        if (out.first < in.first || out.second > in.second) {
            ++outside_range;
            ADD_FAILURE() << "frame " << id << ": output " << out.first << ".." << out.second << " outside the input's "
                          << in.first << ".." << in.second;
        }
    };
    for (int i = 0; i < flight.frameCount(); ++i) {
        FrameBuffer frame = synthetic::renderThermal(flight, i, thermal);
        input_ranges.push_back(synthetic::sampleRange(frame.view()));
        stabilizer.push(test::BufferSlot::make(std::move(frame), i));
        while (auto f = stabilizer.tryPop())
            collect(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        collect(std::move(*f));
    ASSERT_EQ(int(output_path.size()), flight.frameCount());
    const double input = synthetic::residualJitter(input_path, options.width, options.height);
    const double output = synthetic::residualJitter(output_path, options.width, options.height);
    std::printf("16-bit flight: residual jitter input %.3f px, output %.3f px (%.1f %%), %d skipped, %d frames "
                "outside the input's range\n",
                input, output, 100 * output / input, skipped, outside_range);
    RecordProperty("input_jitter", std::to_string(input));
    RecordProperty("output_jitter", std::to_string(output));
    EXPECT_GT(input, 2.0);
    EXPECT_LE(output, 0.25 * input);
    EXPECT_EQ(outside_range, 0);
}
