// The rolling-shutter estimator on synthetic point tracks: a camera whose pose is known at
// every instant, world points seen by a sensor that reads its rows over `readout` of the
// frame time, and the tracks those give from frame to frame.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "estimate/motion_model.hpp"
#include "estimate/rolling_shutter_estimator.hpp"
#include "render/row_transforms.hpp"

using namespace uavstab;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kWidth = 1280, kHeight = 720;

// A hovering camera with propeller vibration (and optionally a pan): pose at time t (frames),
// frame centred coordinates -> world.
struct VibratingCamera {
    double hz = 47.0, fps = 30.0;
    double amplitude_px = 2.0 * std::sqrt(2.0);  // 2 px RMS
    double amplitude_rad = 0.1 * std::sqrt(2.0) * kPi / 180.0;
    double pan_px = 0.0;  // px per frame

    Similarity pose(double t) const
    {
        const double w = 2.0 * kPi * hz / fps;
        return {pan_px * t + amplitude_px * std::sin(w * t + 0.3), amplitude_px * std::sin(1.07 * w * t + 1.9),
                amplitude_rad * std::sin(0.93 * w * t + 4.0), 1.0};
    }
};

// Where a sensor reading rows over `readout` of the frame time sees world point X in frame k:
// u = pose(k + readout * u.y / H)^-1 (X), solved by fixed-point iteration.
Point2 capture(const VibratingCamera &camera, double readout, int k, Point2 world)
{
    Point2 u = camera.pose(k).inverse().apply(world);
    for (int it = 0; it < 8; ++it)
        u = camera.pose(k + readout * u.y / kHeight).inverse().apply(world);
    return u;
}

// The true offset at point u0 of frame k's mid-exposure image: where frame k captured it.
Point2 trueOffset(const VibratingCamera &camera, double readout, int k, Point2 u0)
{
    const Point2 world = camera.pose(k).apply(u0);
    const Point2 u = capture(camera, readout, k, world);
    return {u.x - u0.x, u.y - u0.y};
}

// RMS over a grid of the non-rigid part of a displacement field (the best similarity
// removed): what no frame-to-frame similarity can express.
double nonRigidRms(const std::vector<Point2> &at, const std::vector<Point2> &displacement)
{
    std::vector<Point2> moved(at.size());
    for (std::size_t i = 0; i < at.size(); ++i)
        moved[i] = {at[i].x + displacement[i].x, at[i].y + displacement[i].y};
    const Similarity fit = fitLeastSquares(MotionModel::Similarity, at, moved);
    double sum = 0.0;
    for (std::size_t i = 0; i < at.size(); ++i) {
        const Point2 p = fit.apply(at[i]);
        sum += std::pow(p.x - moved[i].x, 2) + std::pow(p.y - moved[i].y, 2);
    }
    return std::sqrt(sum / double(at.size()));
}

std::vector<Point2> grid()
{
    std::vector<Point2> g;
    for (int y = 0; y < 12; ++y)
        for (int x = 0; x < 16; ++x)
            g.push_back({(x + 0.5) * kWidth / 16.0 - kWidth / 2.0, (y + 0.5) * kHeight / 12.0 - kHeight / 2.0});
    return g;
}

struct TrackingRun {
    double truth = 0.0;  // mean non-rigid RMS of the true offsets
    double error = 0.0;  // mean non-rigid RMS of estimated minus true offsets
    double wobble = 0.0; // mean reported wobble
    int corrected = 0;   // frames with a non-empty RowMotion
    double readout = 0.0, confidence = 0.0;  // the estimator's after the last frame
    int readout_changes = 0;  // frames whose reported readout differs from the frame before's
};

// Tracks `points` world points (re-drawn where they leave the frame) through `frames`
// frames; scores frames from `first` on.
TrackingRun run(const VibratingCamera &camera, double readout, RollingShutterEstimator::Settings settings, int points,
        double noise_px, int frames = 90, int first = 30, std::uint32_t seed = 3)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(-0.48 * kWidth, 0.48 * kWidth), uy(-0.48 * kHeight, 0.48 * kHeight);
    std::normal_distribution<double> noise(0.0, noise_px);
    std::vector<Point2> world(static_cast<std::size_t>(points), Point2{});
    for (Point2 &w : world)
        w = camera.pose(0).apply({ux(rng), uy(rng)});

    RollingShutterEstimator estimator(settings);
    const std::vector<Point2> g = grid();
    TrackingRun r;
    int scored = 0;
    std::vector<Point2> previous;
    for (int k = 0; k < frames; ++k) {
        std::vector<Point2> current(world.size());
        for (std::size_t i = 0; i < world.size(); ++i) {
            const Point2 u = capture(camera, readout, k, world[i]);
            current[i] = {u.x + noise(rng), u.y + noise(rng)};
        }
        if (k == 0) {
            previous = current;
            continue;
        }
        const Similarity motion = fitLeastSquares(MotionModel::Similarity, current, previous);
        const RowMotion rows = estimator.estimate(previous, current, motion, kWidth, kHeight);
        r.corrected += rows.empty() ? 0 : 1;
        if (k > 1 && estimator.readout() != r.readout)
            ++r.readout_changes;
        r.readout = estimator.readout();
        r.confidence = estimator.readoutConfidence();
        if (k >= first) {
            std::vector<Point2> truth(g.size()), error(g.size());
            for (std::size_t i = 0; i < g.size(); ++i) {
                truth[i] = trueOffset(camera, readout, k, g[i]);
                const Point2 e = rows.at(g[i].y).apply(g[i]);
                error[i] = {e.x - g[i].x - truth[i].x, e.y - g[i].y - truth[i].y};
            }
            r.truth += nonRigidRms(g, truth);
            r.error += nonRigidRms(g, error);
            r.wobble += rows.wobble;
            ++scored;
        }
        previous = current;
    }
    r.truth /= scored;
    r.error /= scored;
    r.wobble /= scored;
    return r;
}

} // namespace

TEST(RollingShutter, RecoversTheRowMotionOfAVibratingCamera)
{
    const VibratingCamera camera;
    for (double readout : {0.5, 0.8}) {
        const TrackingRun r = run(camera, readout, {}, 200, 0.05);
        EXPECT_GT(r.truth, 0.5) << "readout " << readout << ": the test's camera must bend its frames";
        EXPECT_LT(r.error, 0.3 * r.truth) << "readout " << readout << " truth " << r.truth;
        // On for the stream once the evidence is in (frame `decide_frames` of the 89 pairs),
        // and on for good.
        EXPECT_GE(r.corrected, 90 - RollingShutterEstimator::Settings{}.decide_frames) << "readout " << readout;
        // As few tracks as the tracker's default keeps, and noisier.
        const TrackingRun few = run(camera, readout, {}, 40, 0.1);
        EXPECT_LT(few.error, 0.3 * few.truth) << "readout " << readout << " truth " << few.truth;
    }
}

TEST(RollingShutter, SaysNoneOnAGlobalShutter)
{
    VibratingCamera camera;
    camera.pan_px = 3.0;
    const TrackingRun r = run(camera, 0.0, {}, 200, 0.05);
    EXPECT_EQ(0, r.corrected) << "mean wobble reported " << r.wobble;
}

TEST(RollingShutter, AKnownReadoutAlsoRemovesTheSkewOfAPan)
{
    VibratingCamera camera;
    camera.amplitude_px = camera.amplitude_rad = 0.0;
    camera.pan_px = 12.0;
    RollingShutterEstimator::Settings known;
    known.readout = 0.8;
    const TrackingRun with = run(camera, 0.8, known, 200, 0.05);
    const TrackingRun without = run(camera, 0.8, {}, 200, 0.05);
    EXPECT_GT(with.truth, 1.0);
    EXPECT_LT(with.error, 0.1 * with.truth);
    // Unknown readout: a steady skew changes nothing from frame to frame, and is left.
    EXPECT_EQ(0, without.corrected);
}

TEST(RollingShutter, FewTracksOrNoneGiveNoCorrectionAndNoCrash)
{
    RollingShutterEstimator estimator;
    const Similarity motion{1.0, 0.0, 0.0, 1.0};
    EXPECT_TRUE(estimator.estimate({}, {}, motion, kWidth, kHeight).empty());
    const std::vector<Point2> a{{0, 0}, {10, 10}}, b{{1, 0}, {11, 10}};
    EXPECT_TRUE(estimator.estimate(a, b, motion, kWidth, kHeight).empty());
    EXPECT_TRUE(estimator.estimate(a, b, motion, 4, 2).empty());
}

TEST(RollingShutter, TheWarpSamplesEachRowWhereItsInputRowWasCaptured)
{
    // Rows bent by a shift that grows down the frame; a stabilizing transform that zooms in
    // (0.9) and moves the picture down by 10 px.
    RowMotion rows;
    for (int b = 0; b < 4; ++b) {
        rows.rows.push_back(-270.0 + 180.0 * b);
        rows.offsets.push_back({0.5 * b, 0.0, 0.0, 1.0});
    }
    const Similarity stabilizing{0.0, 10.0, 0.0, 0.9};
    const RowTransforms warp = rollingShutterWarp(stabilizing, rows, kWidth, kHeight);
    ASSERT_FALSE(warp.isConstant());
    const RowMatrices matrices(warp, kWidth, kHeight);
    const double cx = 0.5 * (kWidth - 1), cy = 0.5 * (kHeight - 1);
    for (double y : {0.0, 100.0, 359.5, 600.0, 719.0}) {
        const double input_row = 0.9 * (y - cy) + 10.0;  // centred
        const std::array<double, 6> m = matrices.at(y);
        // The middle column: the offset at the input row (to within the anchors' linear
        // interpolation), on the row the stabilizing transform reads.
        EXPECT_NEAR(m[0] * cx + m[1] * y + m[2], cx + rows.at(input_row).dx, 0.01) << "row " << y;
        EXPECT_NEAR(m[3] * cx + m[4] * y + m[5], cy + input_row, 1e-9) << "row " << y;
    }
    EXPECT_TRUE(rollingShutterWarp(stabilizing, RowMotion{}, kWidth, kHeight).isConstant());
}

TEST(RollingShutter, TheWarpKeepsEveryRowInsideTheInput)
{
    // An offset far larger than the crop room: every anchor row still reads inside.
    RowMotion rows;
    rows.rows = {-300.0, 300.0};
    rows.offsets = {{-100.0, 0.0, 0.0, 1.0}, {100.0, 40.0, 0.0, 1.0}};
    const Similarity zoom{0.0, 0.0, 0.0, 0.92};
    const RowTransforms warp = rollingShutterWarp(zoom, rows, kWidth, kHeight);
    const RowMatrices matrices(warp, kWidth, kHeight);
    for (double y : warp.anchorRows()) {
        const std::array<double, 6> m = matrices.at(y);
        for (double x : {0.0, double(kWidth - 1)}) {
            const double sx = m[0] * x + m[1] * y + m[2], sy = m[3] * x + m[4] * y + m[5];
            EXPECT_GE(sx, -1e-6) << "row " << y;
            EXPECT_LE(sx, kWidth - 1 + 1e-6) << "row " << y;
            EXPECT_GE(sy, -1e-6) << "row " << y;
            EXPECT_LE(sy, kHeight - 1 + 1e-6) << "row " << y;
        }
    }
    // ...and a shortened offset still bends the rows (towards the room's edge).
    EXPECT_FALSE(warp.isConstant());
}

// The readout time as the stream shows it: the skew of each frame's rows grows with the
// camera's speed. A camera shaking at a few Hz (no propeller vibration) read out over 50 or
// 80 % of the frame time, and a global shutter.
TEST(RollingShutter, EstimatesTheReadoutOfAStreamAndHoldsIt)
{
    VibratingCamera shake;
    shake.hz = 3.0;
    shake.amplitude_px = 6.0;
    shake.amplitude_rad = 0.0;
    for (double readout : {0.0, 0.5, 0.8}) {
        const TrackingRun r = run(shake, readout, {}, 200, 0.05, 240);
        std::printf("readout %.1f: estimated %.3f (confidence %.2f)\n", readout, r.readout, r.confidence);
        EXPECT_GE(r.confidence, 0.8) << "readout " << readout;
        EXPECT_NEAR(r.readout, readout, 0.1) << "readout " << readout;
        // Unknown (0) until sure, then held: it changes once at most.
        EXPECT_LE(r.readout_changes, 1) << "readout " << readout;
    }
}

// A readout set by the settings is the one used and reported on every frame: nothing is
// estimated, whatever the footage shows.
TEST(RollingShutter, AKnownReadoutIsNeverReestimated)
{
    VibratingCamera shake;
    shake.hz = 3.0;
    shake.amplitude_px = 6.0;
    RollingShutterEstimator::Settings known;
    known.readout = 0.3;
    const TrackingRun r = run(shake, 0.8, known, 200, 0.05, 150);
    EXPECT_EQ(r.readout, 0.3);
    EXPECT_EQ(r.confidence, 1.0);
    EXPECT_EQ(r.readout_changes, 0);
    EXPECT_EQ(r.corrected, 149);  // a known readout is always applied
}
