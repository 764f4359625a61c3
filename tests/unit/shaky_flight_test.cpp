// The synthetic flight generator: the default (Lissajous) profile is unchanged, and the
// manoeuvre profile hovers where it should, reaches its speeds with piecewise constant
// acceleration, and stays on the canvas with the default jitter. Rolling shutter and
// vibration: off, nothing changes; on, each row has its pose and the frames wobble.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shaky_flight.hpp"
#include "wobble_metric.hpp"

using namespace uavstab;
using namespace uavstab::synthetic;

namespace {

constexpr double kPi = 3.14159265358979323846;

FlightOptions manoeuvre(int width, int height, std::uint32_t seed = 1)
{
    FlightOptions o;
    o.width = width;
    o.height = height;
    o.seed = seed;
    o.profile = FlightProfile::Manoeuvre;
    return o;
}

// Equal to 1e-12 relative: the values were recorded on x86-64; on aarch64 (the cross build,
// .ci/cross-aarch64.sh) the same code gives them to within ~1e-15 relative but not within
// EXPECT_DOUBLE_EQ's 4 ulps (other libm paths and contractions). Any change to the flight
// itself moves them by far more.
void expectNearlyEqual(double actual, double expected)
{
    EXPECT_NEAR(actual, expected, 1e-12 * std::max(1.0, std::abs(expected)));
}

void expectPose(const Similarity &p, double dx, double dy, double angle, double scale)
{
    expectNearlyEqual(p.dx, dx);
    expectNearlyEqual(p.dy, dy);
    expectNearlyEqual(p.angle, angle);
    expectNearlyEqual(p.scale, scale);
}

} // namespace

// Poses written by uavstab-render-flight (--truth, 17 digits) before the profiles existed.
TEST(ShakyFlight, DefaultProfileIsTheLissajousFlightAsBefore)
{
    FlightOptions o;
    EXPECT_EQ(o.profile, FlightProfile::Lissajous);
    const ShakyFlight a(o);
    expectPose(a.truePose(0), -5.1402691787976682, -73.852991186674672, 0.025853994128454631, 1);
    expectPose(a.intendedPose(0), -3.0525020481253242, -72.169101697710573, 0.025162453429745244, 1);
    expectPose(a.truePose(99), 127.89626981674458, 29.449149524321069, 0.018768412359298527, 1);
    expectPose(a.intendedPose(299), 91.743523514896467, 171.8104424717981, -0.0089610251656359018, 1);

    o.width = 1280;
    o.height = 720;
    o.frames = 60;
    o.seed = 3;
    o.moving_objects = 3;
    o.zoom_amplitude = 0.05;
    const ShakyFlight b(o);
    expectPose(b.truePose(0), 140.82249721990212, -290.70899007072381, 0.020512266682450042, 0.97890699650727009);
    expectPose(b.intendedPose(58), 212.89888027482803, -254.61058920410031, 0.034184004199681373, 0.95262493509857549);
}

TEST(ShakyFlight, ManoeuvreHoversAreStill)
{
    const ShakyFlight f(manoeuvre(640, 360));
    const double fps = f.options().fps;
    int checked = 0;
    for (const ManoeuvreSegment &s : manoeuvrePlan()) {
        if (std::string(s.name) != "hover")
            continue;
        for (int i = int(std::ceil(s.from * fps)); i + 1 <= int(std::floor(s.to * fps)) && i + 1 < f.frameCount(); ++i) {
            const Similarity a = f.intendedPose(i), b = f.intendedPose(i + 1);
            EXPECT_NEAR(b.dx - a.dx, 0.0, 1e-9) << "frame " << i;
            EXPECT_NEAR(b.dy - a.dy, 0.0, 1e-9) << "frame " << i;
            EXPECT_NEAR(b.angle - a.angle, 0.0, 1e-12) << "frame " << i;
            EXPECT_NEAR(b.scale - a.scale, 0.0, 1e-12) << "frame " << i;
            ++checked;
        }
    }
    EXPECT_GT(checked, 60);
    // The hover before the first pan starts at frame 0.
    EXPECT_EQ(manoeuvrePlan().front().from, 0.0);
}

TEST(ShakyFlight, ManoeuvreReachesItsSpeedsWithConstantAcceleration)
{
    const ShakyFlight f(manoeuvre(640, 360));
    ASSERT_EQ(f.manoeuvreShrink(), 1.0);  // nothing shrunk at 640x360
    const int n = f.frameCount();
    std::vector<double> speed(std::size_t(n), 0.0);
    for (int i = 1; i < n; ++i) {
        const Similarity a = f.intendedPose(i - 1), b = f.intendedPose(i);
        speed[std::size_t(i)] = std::hypot(b.dx - a.dx, b.dy - a.dy);
    }
    auto peak = [&](double from, double to) {
        double m = 0;
        for (int i = int(from * 30) + 1; i <= int(to * 30); ++i)
            m = std::max(m, speed[std::size_t(i)]);
        return m;
    };
    EXPECT_NEAR(peak(1.0, 3.5), 3.5, 1e-9);                                // first pan cruise
    EXPECT_NEAR(peak(5.7, 7.5), std::hypot(125.0, 50.0) / (1.4 * 30), 1e-9);  // second pan, ~3.2
    EXPECT_GT(peak(5.7, 7.5), 3.0);
    // First pan: cruising at 3.5 px/frame for 1.5 s, reached at 0.23 px/frame^2 (constant
    // acceleration: the speed grows by the same step each frame of the ramp).
    for (int i = 46; i <= 90; ++i)
        EXPECT_NEAR(speed[std::size_t(i)], 3.5, 1e-9) << "frame " << i;
    for (int i = 32; i <= 44; ++i)
        EXPECT_NEAR(speed[std::size_t(i + 1)] - speed[std::size_t(i)], 3.5 / 15, 1e-9) << "frame " << i;
    // No jumps anywhere: the speed changes by at most one ramp step per frame (the second
    // pan's ramps are the steepest: 3.2 px/frame in 12 frames).
    for (int i = 2; i < n; ++i)
        EXPECT_LE(std::abs(speed[std::size_t(i)] - speed[std::size_t(i) - 1]), 0.27) << "frame " << i;
    // Turn and climb arrive where planned and stay there.
    const Similarity end = f.intendedPose(n - 1);
    EXPECT_NEAR(end.angle, 25.0 * kPi / 180, 1e-12);
    EXPECT_NEAR(end.scale, 1.12, 1e-12);
    EXPECT_NEAR(end.dx, -105.0 + 210.0 - 125.0, 1e-9);
    EXPECT_NEAR(end.dy, 30.0 - 50.0, 1e-9);
    // The yaw turns smoothly: no more than ~1 degree per frame.
    for (int i = 1; i < n; ++i)
        EXPECT_LE(std::abs(f.intendedPose(i).angle - f.intendedPose(i - 1).angle), 1.0 * kPi / 180);
}

TEST(ShakyFlight, ManoeuvreHasTheSameShakeAsTheDefaultProfile)
{
    FlightOptions o;
    o.seed = 4;
    const ShakyFlight lissajous(o);
    o.profile = FlightProfile::Manoeuvre;
    const ShakyFlight flight(o);
    for (int i : {0, 17, 150, 299}) {
        const Similarity a = lissajous.intendedPose(i).inverse() * lissajous.truePose(i);
        const Similarity b = flight.intendedPose(i).inverse() * flight.truePose(i);
        EXPECT_NEAR(a.dx, b.dx, 1e-9);
        EXPECT_NEAR(a.dy, b.dy, 1e-9);
        EXPECT_NEAR(a.angle, b.angle, 1e-12);
        EXPECT_NEAR(b.scale, 1.0, 1e-12);
    }
}

TEST(ShakyFlight, ManoeuvreStaysOnTheCanvas)
{
    struct Size {
        int w, h;
        bool unshrunk;
    };
    for (const Size s : {Size{640, 360, true}, Size{1280, 720, true}, Size{480, 480, false}}) {
        for (std::uint32_t seed : {1u, 2u, 3u}) {
            const ShakyFlight f(manoeuvre(s.w, s.h, seed));
            if (s.unshrunk) {
                EXPECT_EQ(f.manoeuvreShrink(), 1.0) << s.w << "x" << s.h;
            } else {
                EXPECT_LT(f.manoeuvreShrink(), 1.0) << s.w << "x" << s.h;
            }
            const double cx = (f.canvasSize().width - 1) * 0.5, cy = (f.canvasSize().height - 1) * 0.5;
            const double hx = (s.w - 1) * 0.5, hy = (s.h - 1) * 0.5;
            double closest = 1e9;  // canvas px between a corner and the canvas edge
            for (int i = 0; i < f.frameCount(); ++i)
                for (const Point2 c : {Point2{-hx, -hy}, Point2{hx, -hy}, Point2{-hx, hy}, Point2{hx, hy}}) {
                    const Point2 p = f.worldToCanvas().apply(f.truePose(i).apply(c));
                    closest = std::min({closest, cx - std::abs(p.x), cy - std::abs(p.y)});
                }
            EXPECT_GE(closest, 0.0) << s.w << "x" << s.h << " seed " << seed;
            std::printf("%dx%d seed %u: shrink %.3f, closest corner %.1f canvas px from the edge\n", s.w, s.h, seed,
                        f.manoeuvreShrink(), closest);
        }
    }
}

namespace {

FlightOptions vibrating(double readout)
{
    FlightOptions o;
    o.readout = readout;
    o.vibration_hz = 47.0;
    o.vibration_px = 2.0;
    o.vibration_deg = 0.1;
    return o;
}

cv::Mat luma(const cv::Mat &bgr)
{
    cv::Mat grey;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    return grey;
}

double meanWobbleOfFlight(const ShakyFlight &f, int frames)
{
    WobbleMeter meter;
    for (int i = 0; i < frames; ++i)
        meter.add(f.renderBgr(i));
    EXPECT_EQ(meter.pairs(), frames - 1);
    return meter.mean();
}

} // namespace

// Without a rolling shutter or vibration the frames are the single warp they always were:
// the canvas warped once with truePose(i), as renderBgr did before rows had poses.
TEST(ShakyFlight, GlobalShutterRendersAsBefore)
{
    FlightOptions o;
    o.frames = 30;
    o.vibration_hz = 47.0;  // no amplitude: no vibration, nothing drawn
    const ShakyFlight f(o);
    const cv::Mat canvas = cv::imread(defaultCanvasPath(), cv::IMREAD_COLOR);
    ASSERT_FALSE(canvas.empty());
    const double ccx = (canvas.cols - 1) * 0.5, ccy = (canvas.rows - 1) * 0.5;
    const double cx = (o.width - 1) * 0.5, cy = (o.height - 1) * 0.5;
    for (int i : {0, 13, 29}) {
        const Similarity world_to_canvas{ccx, ccy, 0.0, f.worldToCanvas().scale};
        const auto m = (world_to_canvas * f.truePose(i)).pixelMatrix(o.width, o.height);
        double matrix[6] = {m[0], m[1], m[2] - cx, m[3], m[4], m[5] - cy};
        cv::Mat expected;
        cv::warpAffine(canvas, expected, cv::Mat(2, 3, CV_64F, matrix), cv::Size(o.width, o.height),
                       cv::INTER_CUBIC | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT_101);
        const cv::Mat rendered = f.renderBgr(i);
        ASSERT_EQ(rendered.size(), expected.size());
        EXPECT_EQ(cv::norm(rendered, expected, cv::NORM_INF), 0.0) << "frame " << i;
    }
    // The poses are those of a flight that never heard of vibration.
    FlightOptions without;
    without.frames = o.frames;
    const ShakyFlight plain(without);
    for (int i : {0, 13, 29}) {
        const Similarity a = f.truePose(i), b = plain.truePose(i);
        EXPECT_EQ(a.dx, b.dx);
        EXPECT_EQ(a.dy, b.dy);
        EXPECT_EQ(a.angle, b.angle);
        EXPECT_EQ(a.scale, b.scale);
    }
}

TEST(ShakyFlight, VibrationLeavesTheOtherDrawsAlone)
{
    const ShakyFlight plain{FlightOptions{}};
    const ShakyFlight shaken(vibrating(0.0));
    double largest = 0.0;
    for (int i = 0; i < plain.frameCount(); ++i) {
        const Similarity a = plain.intendedPose(i), b = shaken.intendedPose(i);
        EXPECT_EQ(a.dx, b.dx);
        EXPECT_EQ(a.dy, b.dy);
        EXPECT_EQ(a.angle, b.angle);
        // The shake differs by the vibration only: a few px, never more.
        const Similarity d = plain.truePose(i).inverse() * shaken.truePose(i);
        largest = std::max(largest, std::hypot(d.dx, d.dy));
    }
    EXPECT_GT(largest, 2.0);
    EXPECT_LT(largest, 12.0);
}

TEST(ShakyFlight, RollingShutterGivesEachRowItsPose)
{
    const ShakyFlight f(vibrating(0.8));
    const ShakyFlight global(vibrating(0.0));
    const double middle = (f.options().height - 1) * 0.5, bottom = f.options().height - 1;
    double top_offset = 0.0, bottom_offset = 0.0;
    for (int i : {0, 1, 57, 150, 299}) {
        const Similarity mid = f.truePoseAtRow(i, middle), pose = f.truePose(i);
        EXPECT_EQ(mid.dx, pose.dx) << "frame " << i;
        EXPECT_EQ(mid.dy, pose.dy) << "frame " << i;
        EXPECT_EQ(mid.angle, pose.angle) << "frame " << i;
        EXPECT_EQ(mid.scale, pose.scale) << "frame " << i;
        // The readout moves the rows in time, not the camera's path.
        const Similarity g = global.truePose(i);
        EXPECT_EQ(pose.dx, g.dx);
        EXPECT_EQ(pose.angle, g.angle);
        EXPECT_DOUBLE_EQ(f.rowTime(i, 0), i - 0.4);
        EXPECT_DOUBLE_EQ(f.rowTime(i, bottom), i + 0.4);
        const Similarity top_pose = f.truePoseAtRow(i, 0), bottom_pose = f.truePoseAtRow(i, bottom);
        top_offset = std::max(top_offset, std::hypot(top_pose.dx - pose.dx, top_pose.dy - pose.dy));
        bottom_offset = std::max(bottom_offset, std::hypot(bottom_pose.dx - pose.dx, bottom_pose.dy - pose.dy));
        // The pose is continuous in time, across frame boundaries too (the white noise is
        // interpolated, not held).
        for (double t : {i + 1e-7, i + 0.5, i + 1.0 - 1e-7}) {
            const Similarity p = f.truePoseAt(t), q = f.truePoseAt(t + 1e-7);
            EXPECT_LT(std::hypot(p.dx - q.dx, p.dy - q.dy), 1e-4) << "time " << t;
        }
    }
    EXPECT_GT(top_offset, 1.0);
    EXPECT_GT(bottom_offset, 1.0);
    // Between frames the white noise is interpolated: halfway, half of each frame's draw.
    FlightOptions quiet;
    quiet.band_px = 0.0;
    quiet.rotation_band_deg = 0.0;
    const ShakyFlight noise_only(quiet);
    const Similarity a = noise_only.intendedPoseAt(10.5).inverse() * noise_only.truePoseAt(10.5);
    const Similarity b = noise_only.intendedPose(10).inverse() * noise_only.truePose(10);
    const Similarity c = noise_only.intendedPose(11).inverse() * noise_only.truePose(11);
    EXPECT_NEAR(a.angle, 0.5 * (b.angle + c.angle), 1e-12);
}

TEST(ShakyFlight, RollingShutterStaysOnTheCanvas)
{
    for (std::uint32_t seed : {1u, 2u, 3u}) {
        FlightOptions o = vibrating(0.8);
        o.seed = seed;
        const ShakyFlight f(o);
        const double cx = (f.canvasSize().width - 1) * 0.5, cy = (f.canvasSize().height - 1) * 0.5;
        const double hx = (o.width - 1) * 0.5, hy = (o.height - 1) * 0.5;
        double closest = 1e9;
        for (int i = 0; i < f.frameCount(); ++i)
            for (const Point2 c : {Point2{-hx, -hy}, Point2{hx, -hy}, Point2{-hx, hy}, Point2{hx, hy}}) {
                const Point2 p = f.worldToCanvas().apply(f.truePoseAtRow(i, c.y + hy).apply(c));
                closest = std::min({closest, cx - std::abs(p.x), cy - std::abs(p.y)});
            }
        EXPECT_GE(closest, 0.0) << "seed " << seed;
    }
}

// The jello the rolling shutter makes of the vibration is what the wobble metric measures;
// with a global shutter the same vibration only moves whole frames.
TEST(ShakyFlight, RollingShutterWobbles)
{
    FlightOptions o = vibrating(0.8);
    o.frames = 12;
    const double rolling = meanWobbleOfFlight(ShakyFlight(o), o.frames);
    o.readout = 0.0;
    const double global = meanWobbleOfFlight(ShakyFlight(o), o.frames);
    std::printf("wobble at 640x360, 47 Hz 2 px 0.1 deg: readout 0.8 %.3f px, global shutter %.3f px\n", rolling,
                global);
    EXPECT_GT(rolling, 0.5);
    EXPECT_LT(global, 0.1);
    // One frame pair, measured directly, agrees.
    const ShakyFlight f(vibrating(0.8));
    EXPECT_GT(wobble(luma(f.renderBgr(3)), luma(f.renderBgr(4))), 0.5);
}
