#include <gtest/gtest.h>

#include <cmath>

#include "buffer_slot.hpp"
#include "jitter_metrics.hpp"
#include "shaky_flight.hpp"
#include "path/trajectory.hpp"
#include "path/trajectory_smoother.hpp"

using namespace uavstab;

namespace {

// Runs the whole stabilizer over a flight and returns (input jitter, output jitter).
std::pair<double, double> stabilizeFlight(const synthetic::FlightOptions &options, const StabilizerConfig &config,
                                          std::vector<FrameStats> *all_stats = nullptr)
{
    const synthetic::ShakyFlight flight(options);
    Stabilizer stabilizer(config);
    std::vector<Similarity> input_path, output_path;
    auto collect = [&](StabilizedFrame f) {
        const int id = test::BufferSlot::of(f).id();
        EXPECT_EQ(id, int(output_path.size()));
        input_path.push_back(flight.truePose(id));
        output_path.push_back(flight.truePose(id) * synthetic::outputToInput(f.stats));
        // The mapping the warper used is the correction undone, zoomed.
        const Similarity rebuilt = synthetic::outputToInput(f.stats), used = f.stats.output_to_input;
        EXPECT_NEAR(rebuilt.dx, used.dx, 1e-9);
        EXPECT_NEAR(rebuilt.angle, used.angle, 1e-12);
        EXPECT_NEAR(rebuilt.scale, used.scale, 1e-12);
        if (all_stats)
            all_stats->push_back(f.stats);
    };
    for (int i = 0; i < flight.frameCount(); ++i) {
        stabilizer.push(test::BufferSlot::make(flight.render(i), i));
        while (auto f = stabilizer.tryPop())
            collect(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        collect(std::move(*f));
    EXPECT_EQ(int(output_path.size()), flight.frameCount());
    return {synthetic::residualJitter(input_path, options.width, options.height),
            synthetic::residualJitter(output_path, options.width, options.height)};
}

std::vector<Similarity> pan(int n)
{
    std::vector<Similarity> poses;
    for (int i = 0; i < n; ++i)
        poses.push_back({2.0 * i, -1.0 * i, 0.001 * i, std::exp(0.0005 * i)});
    return poses;
}

} // namespace

TEST(TrajectorySmoother, ConstantVelocityPanIsLeftUnchanged)
{
    const std::vector<Similarity> poses = pan(60);
    for (SmootherKind kind : {SmootherKind::Box, SmootherKind::Gaussian}) {
        const auto smoother = makeSmoother(kind, 10);
        for (int i = 0; i < 60; ++i) {
            // Centred windows away from the ends, truncated ones at the ends, causal ones.
            for (int lookahead : {10, 3, 0}) {
                const int lo = std::max(0, i - 10), hi = std::min(59, i + lookahead);
                const std::vector<Similarity> window(poses.begin() + lo, poses.begin() + hi + 1);
                const Similarity s = smoother->smooth(window, std::size_t(i - lo));
                const Similarity correction = s.inverse() * poses[std::size_t(i)];
                EXPECT_TRUE(correction.isIdentity(1e-9)) << "frame " << i << " lookahead " << lookahead;
            }
        }
    }
}

TEST(TrajectorySmoother, CentredBoxWindowIsThePapersMovingAverage)
{
    std::vector<Similarity> window;
    double sum = 0;
    for (int k = 0; k < 21; ++k) {
        const double x = std::sin(k * 1.7) * 5;  // arbitrary
        window.push_back({x, 0, 0, 1});
        sum += x;
    }
    const Similarity s = makeSmoother(SmootherKind::Box, 10)->smooth(window, 10);
    EXPECT_NEAR(s.dx, sum / 21, 1e-12);
}

TEST(Trajectory, WindowsStopAtSegmentBoundaries)
{
    Trajectory t;
    for (int i = 0; i < 10; ++i)
        t.append({1, 0, 0, 1}, i == 0);
    for (int i = 0; i < 10; ++i)
        t.append({1, 0, 0, 1}, i == 0);  // frame 10 starts a new segment
    std::size_t centre = 0;
    EXPECT_EQ(t.window(8, 5, &centre).size(), 7u);  // frames 3..9
    EXPECT_EQ(centre, 5u);
    EXPECT_EQ(t.window(11, 5, &centre).size(), 7u);  // frames 10..16
    EXPECT_EQ(centre, 1u);
    EXPECT_DOUBLE_EQ(t.pose(10).dx, 0.0);
    EXPECT_DOUBLE_EQ(t.pose(12).dx, 2.0);
    t.dropBefore(15);
    EXPECT_THROW(t.pose(14), std::out_of_range);
    EXPECT_DOUBLE_EQ(t.pose(15).dx, 5.0);
}

TEST(TrajectorySmoother, RemovesMostOfTheJitterOfTheSyntheticFlight)
{
    synthetic::FlightOptions options;
    options.frames = 240;
    StabilizerConfig config;  // the paper's: delay 20, box radius 10
    config.planner = PlannerKind::Box;
    config.smoothing_radius = 10;
    const auto [input, output] = stabilizeFlight(options, config);
    RecordProperty("input_jitter", std::to_string(input));
    RecordProperty("output_jitter", std::to_string(output));
    std::printf("residual jitter: input %.3f px, output %.3f px (%.1f %%)\n", input, output, 100 * output / input);
    EXPECT_GT(input, 2.0);
    EXPECT_LE(output, 0.25 * input);
}

TEST(TrajectorySmoother, CausalDelayZeroStillReducesJitter)
{
    synthetic::FlightOptions options;
    options.frames = 150;
    StabilizerConfig config;
    config.delay = 0;
    const auto [input, output] = stabilizeFlight(options, config);
    std::printf("delay 0: input %.3f px, output %.3f px (%.1f %%)\n", input, output, 100 * output / input);
    EXPECT_LT(output, 0.8 * input);
}

TEST(TrajectorySmoother, GaussianBeatsThePapersBox)
{
    synthetic::FlightOptions options;
    options.frames = 150;
    options.seed = 3;
    StabilizerConfig gaussian;  // Gaussian over the whole look-ahead
    gaussian.planner = PlannerKind::Gaussian;
    ASSERT_EQ(gaussian.smoothing_radius, gaussian.delay);
    StabilizerConfig box;
    box.planner = PlannerKind::Box;
    box.smoothing_radius = 10;
    const auto [input, with_gaussian] = stabilizeFlight(options, gaussian);
    const auto [input_again, with_box] = stabilizeFlight(options, box);
    std::printf("seed 3: input %.3f px, gaussian r20 %.3f px, box r10 %.3f px\n", input, with_gaussian, with_box);
    EXPECT_LE(with_gaussian, 0.25 * input);
    EXPECT_LT(with_gaussian, with_box);
}
