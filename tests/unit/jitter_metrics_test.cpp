// Quality measures of tests/synthetic: the error against the intended path, residual jitter.
#include <gtest/gtest.h>

#include <cmath>

#include "jitter_metrics.hpp"
#include "shaky_flight.hpp"

using namespace uavstab;
using namespace uavstab::synthetic;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A path that pans, turns and zooms.
std::vector<Similarity> movingPath(int n)
{
    std::vector<Similarity> p;
    for (int i = 0; i < n; ++i)
        p.push_back({3.0 * i + 0.02 * i * i, -1.5 * i, 0.004 * i, 1.0 + 0.001 * i});
    return p;
}

} // namespace

TEST(IntendedPathError, ZeroForAConstantOffsetAndZoom)
{
    const std::vector<Similarity> intended = movingPath(120);
    std::vector<Similarity> out;
    const Similarity crop{7.0, -3.0, 0.01, 1.0 / 1.087};  // fixed offset, tilt and crop zoom
    for (const Similarity &p : intended)
        out.push_back(p * crop);
    EXPECT_NEAR(intendedPathError(out, intended, 640, 360), 0.0, 1e-9);
    EXPECT_NEAR(intendedPathError(intended, intended, 640, 360), 0.0, 1e-9);
}

TEST(IntendedPathError, ASinusoidCostsItsRms)
{
    const std::vector<Similarity> intended = movingPath(120);
    // 4 px amplitude, 5 whole periods over 120 frames: RMS 4 / sqrt(2), the mean is zero.
    for (const Similarity &crop : {Similarity{}, Similarity{5.0, 2.0, 0.0, 1.0 / 1.087}}) {
        std::vector<Similarity> out;
        for (int i = 0; i < 120; ++i)
            out.push_back(intended[std::size_t(i)] * Similarity{4.0 * std::sin(2 * kPi * 5 * i / 120.0), 0, 0, 1} *
                          crop);  // shake in the intended frame's pixels, on top of a fixed crop
        EXPECT_NEAR(intendedPathError(out, intended, 640, 360), 4.0 / std::sqrt(2.0), 1e-9);
    }
}

TEST(IntendedPathError, ARotationSinusoidCostsItsCornerRms)
{
    const std::vector<Similarity> intended = movingPath(100);
    std::vector<Similarity> out;
    const double a = 0.002;  // radians: corners of a 640x360 frame move by ~a * 367 px
    for (int i = 0; i < 100; ++i)
        out.push_back(intended[std::size_t(i)] * Similarity{0, 0, a * std::sin(2 * kPi * 4 * i / 100.0), 1});
    const double radius = std::hypot(319.5, 179.5);
    EXPECT_NEAR(intendedPathError(out, intended, 640, 360), radius * a / std::sqrt(2.0), 0.01);
}

TEST(IntendedPathError, LaggingAStopCostsButFollowingTheManoeuvreDoesNot)
{
    FlightOptions o;
    o.profile = FlightProfile::Manoeuvre;
    const ShakyFlight flight(o);
    std::vector<Similarity> intended, lagging;
    for (int i = 0; i < flight.frameCount(); ++i) {
        intended.push_back(flight.intendedPose(i));
        lagging.push_back(flight.intendedPose(std::max(0, i - 10)));  // 1/3 s behind
    }
    EXPECT_NEAR(intendedPathError(intended, intended, 640, 360), 0.0, 1e-9);
    EXPECT_GT(intendedPathError(lagging, intended, 640, 360), 5.0);
}

// Leaving out the first frames measures the steady state: a kink in the first frames
// counts over the whole path and not at all once they are left out (the low-pass of the
// frames kept, 3 sigma wide, does not reach it), while the shake everywhere still counts.
TEST(ResidualJitter, LeavingOutTheFirstFramesDropsTheStartUpOnly)
{
    const int n = 150, first = 30;
    std::vector<Similarity> steady, kinked;
    for (int i = 0; i < n; ++i) {
        const double shake = 2.0 * std::sin(2.0 * kPi * i / 6.0);
        const double kink = i < 6 ? 12.0 * std::sin(kPi * i / 6.0) : 0.0;
        steady.push_back({2.0 * i + shake, 0.5 * shake, 0.0, 1.0});
        kinked.push_back({2.0 * i + shake + kink, 0.5 * shake, 0.0, 1.0});
    }
    const double steady_all = residualJitter(steady, 640, 360);
    const double kinked_all = residualJitter(kinked, 640, 360);
    EXPECT_GT(kinked_all, 1.2 * steady_all);
    EXPECT_NEAR(residualJitter(kinked, 640, 360, 8.0, first), residualJitter(steady, 640, 360, 8.0, first), 1e-9);
    EXPECT_GT(residualJitter(steady, 640, 360, 8.0, first), 0.5 * steady_all);
    EXPECT_DOUBLE_EQ(residualJitter(kinked, 640, 360, 8.0, 0), kinked_all);
    EXPECT_EQ(residualJitter(kinked, 640, 360, 8.0, std::size_t(n)), 0.0);
}

// The whip: a path that stands still and then makes up the pilot's move at twice the
// pilot's speed scores 2; following the move exactly scores 1, and through shake of a few
// pixels still about 1 (the light smoothing); a hover has no speed to compare.
TEST(PathWhip, CatchingUpAtTwiceThePilotsSpeedScoresTwo)
{
    const int n = 200;
    std::vector<Similarity> intended, follower, catch_up, shaky, still;
    for (int i = 0; i < n; ++i) {
        const double x = i < 50 ? 0.0 : i < 150 ? 2.0 * (i - 50) : 200.0;  // a 2 px/frame pan
        const double late = i < 100 ? 0.0 : i < 150 ? 4.0 * (i - 100) : 200.0;  // 4 px/frame, late
        intended.push_back({x, 0.0, 0.0, 1.0});
        follower.push_back({x, 0.0, 0.0, 1.0});
        catch_up.push_back({late, 0.0, 0.0, 1.0});
        shaky.push_back({x + 1.5 * std::sin(2.0 * kPi * i / 4.0), 0.0, 0.0, 1.0});
        still.push_back({0.0, 0.0, 0.0, 1.0});
    }
    EXPECT_NEAR(pathWhip(follower, intended, 640, 360), 1.0, 1e-9);
    EXPECT_NEAR(pathWhip(catch_up, intended, 640, 360), 2.0, 0.05);
    EXPECT_NEAR(pathWhip(shaky, intended, 640, 360), 1.0, 0.15);
    EXPECT_EQ(pathWhip(shaky, still, 640, 360), 0.0);
}
