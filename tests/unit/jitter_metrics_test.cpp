// Quality measures of tests/synthetic: the error against the intended path.
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
