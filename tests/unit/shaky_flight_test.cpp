// The synthetic flight generator: the default (Lissajous) profile is unchanged, and the
// manoeuvre profile hovers where it should, reaches its speeds with piecewise constant
// acceleration, and stays on the canvas with the default jitter.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "shaky_flight.hpp"

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
