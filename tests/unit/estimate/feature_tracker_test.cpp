// Tracker + estimator against the synthetic flight's known motion.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "estimate/luma_extractor.hpp"
#include "worker_pool.hpp"
#include "shaky_flight.hpp"
#include "estimate/motion_estimator.hpp"

using namespace uavstab;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
}

struct Errors {
    double translation, rotation_deg;
    int skipped;
};

Errors estimateFlight(const synthetic::FlightOptions &options, const StabilizerConfig &config)
{
    const synthetic::ShakyFlight flight(options);
    MotionEstimator estimator(config);
    std::vector<double> translation, rotation;
    int skipped = 0;
    for (int i = 0; i < flight.frameCount(); ++i) {
        const MotionEstimate e = estimator.estimate(flight.render(i).view());
        if (i == 0) {
            EXPECT_TRUE(e.first);
            continue;
        }
        if (e.skipped) {
            ++skipped;
            continue;
        }
        const Similarity truth = flight.trueMotion(i);
        translation.push_back(std::hypot(e.motion.dx - truth.dx, e.motion.dy - truth.dy));
        rotation.push_back(std::abs(e.motion.angle - truth.angle) / kDeg);
    }
    return {median(translation), median(rotation), skipped};
}

} // namespace

TEST(FeatureTracker, EstimatesKnownMotionOfTheSyntheticFlight)
{
    synthetic::FlightOptions options;
    options.frames = 60;
    const Errors e = estimateFlight(options, StabilizerConfig{});
    EXPECT_LT(e.translation, 0.3);
    EXPECT_LT(e.rotation_deg, 0.05);
    EXPECT_EQ(e.skipped, 0);
}

TEST(FeatureTracker, DownscaledAnalysisScalesMotionBackToFullResolution)
{
    // Analysis at 640 px: 720p halves once, 1080p halves then resamples by 1.5.
    for (auto [w, h] : {std::pair{1280, 720}, {1920, 1080}}) {
        synthetic::FlightOptions options;
        options.width = w;
        options.height = h;
        options.frames = 20;
        options.band_px = 3.0 * w / 640;  // the same shake in analysis pixels
        const Errors e = estimateFlight(options, StabilizerConfig{});
        const double analysis_px = double(w) / 640;
        std::printf("%dx%d: median error %.3f px (%.3f analysis px), %.4f deg\n", w, h, e.translation,
                    e.translation / analysis_px, e.rotation_deg);
        EXPECT_LT(e.translation, 0.3 * analysis_px);
        EXPECT_LT(e.rotation_deg, 0.05);
    }
}

TEST(FeatureTracker, AnyTrackingWindowFollowsTheFlight)
{
    // The window trades tracking time for robustness on low texture; on the textured
    // flight every allowed size must still find the motion.
    for (int window : {7, 15, 41}) {
        synthetic::FlightOptions options;
        options.frames = 20;
        StabilizerConfig config;
        config.tracking_window = window;
        const Errors e = estimateFlight(options, config);
        EXPECT_LT(e.translation, 0.3) << "window " << window;
        EXPECT_LT(e.rotation_deg, 0.05) << "window " << window;
        EXPECT_EQ(e.skipped, 0) << "window " << window;
    }
    StabilizerConfig config;
    for (int bad : {5, 20, 43}) {
        config.tracking_window = bad;
        EXPECT_THROW(config.validate(), std::invalid_argument) << bad;
    }
}

TEST(FeatureTracker, AnalysisWidthOrWindowChangedMidStreamKeepsMotionAtFullResolution)
{
    // The element lets both change while playing. The next frame must be analysed at the
    // new size, with motion still scaled back to full-resolution pixels.
    synthetic::FlightOptions options;
    options.width = 1280;
    options.height = 720;
    options.frames = 30;
    options.band_px = 6.0;
    const synthetic::ShakyFlight flight(options);
    StabilizerConfig config;
    MotionEstimator estimator(config);
    std::vector<double> after;
    for (int i = 0; i < flight.frameCount(); ++i) {
        if (i == 10) {
            config.analysis_width = 320;
            estimator.setConfig(config);
        }
        if (i == 20) {
            config.tracking_window = 11;
            estimator.setConfig(config);
        }
        const MotionEstimate e = estimator.estimate(flight.render(i).view());
        if (i <= 10 || i == 20 || e.skipped)
            continue;  // the frame after a change starts tracking afresh
        const Similarity truth = flight.trueMotion(i);
        after.push_back(std::hypot(e.motion.dx - truth.dx, e.motion.dy - truth.dy));
    }
    ASSERT_GE(after.size(), 15u);
    // 320-wide analysis of 1280: an analysis pixel is 4 px here.
    EXPECT_LT(median(after), 0.3 * 4);
    EXPECT_LT(*std::max_element(after.begin(), after.end()), 3.0);
}

TEST(FeatureTracker, MovingObjectsDoNotPullTheEstimate)
{
    synthetic::FlightOptions options;
    options.frames = 60;
    options.moving_objects = 4;
    options.seed = 5;
    const Errors e = estimateFlight(options, StabilizerConfig{});
    EXPECT_LT(e.translation, 0.3);
    EXPECT_LT(e.rotation_deg, 0.05);
}

TEST(FeatureTracker, RgbFormatsReadLumaToo)
{
    synthetic::FlightOptions options;
    options.frames = 20;
    options.format = PixelFormat::BGRx;
    const Errors e = estimateFlight(options, StabilizerConfig{});
    EXPECT_LT(e.translation, 0.3);
}

TEST(FeatureTracker, RedetectsOnScheduleAndKeepsAboutMaxCorners)
{
    synthetic::FlightOptions options;
    options.frames = 16;
    const synthetic::ShakyFlight flight(options);
    StabilizerConfig config;
    config.redetect_interval = 5;
    FeatureTracker tracker(config);
    std::vector<int> redetected;
    for (int i = 0; i < flight.frameCount(); ++i) {
        const PointMatches m = tracker.track(flight.render(i).view());
        if (m.redetected)
            redetected.push_back(i);
        if (i > 0) {
            EXPECT_LE(m.detected, config.max_corners);
            EXPECT_GE(int(m.current.size()), config.max_corners / 2) << "frame " << i;
        }
    }
    EXPECT_EQ(redetected, (std::vector<int>{1, 6, 11}));
}

TEST(FeatureTracker, DetectionBandsLeaveNoBandOfRowsWithoutCorners)
{
    // The flight's picture with the lower half's contrast cut to a tenth: detected at once,
    // the corners gather in the upper half; in bands, each band gets its share.
    synthetic::FlightOptions options;
    options.frames = 2;
    const synthetic::ShakyFlight flight(options);
    auto faintBelow = [](FrameBuffer frame) {
        for (int y = frame.height() / 2; y < frame.height(); ++y) {
            std::uint8_t *row = frame.row(0, y);
            for (int x = 0; x < frame.width(); ++x)
                row[x] = std::uint8_t(128 + (int(row[x]) - 128) / 10);
        }
        return frame;
    };
    auto cornersBelow = [&](int bands) {
        StabilizerConfig config;
        config.roi = 0.95;
        config.max_corners = 100;
        FeatureTracker tracker(config);
        tracker.setDetectionBands(bands);
        const FrameBuffer first = faintBelow(flight.render(0)), second = faintBelow(flight.render(1));
        tracker.track(first.view());
        const PointMatches m = tracker.track(second.view());
        EXPECT_TRUE(m.redetected);
        EXPECT_LE(m.detected, config.max_corners + bands);
        int below = 0;
        for (const Point2 &p : m.previous)
            below += p.y > 0.0 ? 1 : 0;  // centred coordinates: the lower half
        return std::pair<int, int>{below, m.detected};
    };
    const auto [below_at_once, detected_at_once] = cornersBelow(1);
    const auto [below_in_bands, detected_in_bands] = cornersBelow(12);
    EXPECT_LT(below_at_once, detected_at_once / 5) << "the faint half should lose out without bands";
    EXPECT_GT(below_in_bands, detected_in_bands / 3);
}

TEST(FeatureTracker, UniformAndNoiseFramesGiveNoMatches)
{
    StabilizerConfig config;
    FeatureTracker tracker(config);
    FrameBuffer black(PixelFormat::I420, 320, 240);
    black.fill(0);
    for (int i = 0; i < 3; ++i)
        EXPECT_TRUE(tracker.track(black.view()).current.empty());
}

TEST(FeatureTracker, VeryLargeFramesAreAnalysedAtTheAnalysisWidth)
{
    // 4K and 8K halve repeatedly down to the analysis width; a shifted texture is found.
    for (auto [w, h] : {std::pair{3840, 2160}, {7680, 4320}}) {
        FrameBuffer a(PixelFormat::Gray8, w, h), b(PixelFormat::Gray8, w, h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                auto texture = [](int u, int v) {
                    return std::uint8_t(128 + 60 * std::sin(u * 0.011) * std::cos(v * 0.013) + 40 * std::sin((u + 2 * v) * 0.0041));
                };
                a.row(0, y)[x] = texture(x, y);
                b.row(0, y)[x] = texture(x + 24, y - 12);  // the camera moved right 24, up 12
            }
        MotionEstimator estimator{StabilizerConfig{}};
        estimator.estimate(a.view());
        const MotionEstimate e = estimator.estimate(b.view());
        ASSERT_FALSE(e.skipped) << w << "x" << h;
        EXPECT_NEAR(e.motion.dx, 24.0, 0.3 * w / 640) << w << "x" << h;
        EXPECT_NEAR(e.motion.dy, -12.0, 0.3 * w / 640) << w << "x" << h;
    }
}

TEST(LumaExtractor, BoxDownscaleIsTheRoundedMeanOfEachBlock)
{
    // Widths that leave the vector loops a tail, 1 and 4 channels, a stride wider than the
    // row (a view into a bigger image), extremes (all 255: no overflow of the sums).
    cv::RNG rng(5);
    std::vector<std::uint16_t> scratch;
    for (const int channels : {1, 4})
        for (const int out_width : {1, 5, 16, 17, 37, 640})
            for (const bool saturated : {false, true}) {
                const int out_height = 7;
                cv::Mat big(out_height * 3 + 2, out_width * 3 + 5, CV_8UC(channels));
                if (saturated)
                    big.setTo(cv::Scalar::all(255));
                else
                    rng.fill(big, cv::RNG::UNIFORM, 0, 256);
                const cv::Mat src = big(cv::Rect(1, 1, out_width * 3 + 2, out_height * 3));
                cv::Mat dst;
                boxDownscale3(src, dst, scratch);
                ASSERT_EQ(dst.size(), cv::Size(out_width, out_height));
                ASSERT_EQ(dst.type(), src.type());
                for (int y = 0; y < out_height; ++y)
                    for (int x = 0; x < out_width; ++x)
                        for (int c = 0; c < channels; ++c) {
                            int sum = 0;
                            for (int v = 0; v < 3; ++v)
                                for (int u = 0; u < 3; ++u)
                                    sum += src.ptr<std::uint8_t>(3 * y + v)[(3 * x + u) * channels + c];
                            ASSERT_EQ(int(dst.ptr<std::uint8_t>(y)[x * channels + c]), (sum + 4) / 9)
                                << channels << " channels, width " << out_width << " at " << x << "," << y;
                        }
            }
}

TEST(LumaExtractor, ExactThirdsAreBlockMeansOfTheLuma)
{
    // 1080p (a third) and 4K (a halving, then a third) to the default 640x360.
    for (auto [w, h] : {std::pair{1920, 1080}, {3840, 2160}}) {
        FrameBuffer frame(PixelFormat::I420, w, h);
        cv::Mat y(h, w, CV_8UC1, frame.row(0, 0), std::size_t(frame.view().planes[0].stride));
        cv::RNG(11).fill(y, cv::RNG::UNIFORM, 0, 256);
        LumaExtractor extractor;
        const cv::Mat luma = extractor.extract(frame.view(), 640).clone();
        ASSERT_EQ(luma.size(), cv::Size(640, 360));
        const int f = w / 640;
        for (int r = 0; r < 360; r += 7)
            for (int c = 0; c < 640; c += 5) {
                double sum = 0.0;
                for (int v = 0; v < f; ++v)
                    for (int u = 0; u < f; ++u)
                        sum += y.at<std::uint8_t>(f * r + v, f * c + u);
                // 4K: the halving rounds once more.
                EXPECT_NEAR(luma.at<std::uint8_t>(r, c), sum / (f * f), f == 3 ? 0.5 : 1.0) << w << " " << r << "," << c;
            }
    }
}

namespace {

// Runs the estimator twice over a flight, alone and sharing its work through `share`, and
// expects the same estimates to the last bit.
void expectSameEstimatesWhenShared(int width, int height, const ShareWork &share)
{
    synthetic::FlightOptions options;
    options.width = width;
    options.height = height;
    options.frames = 16;
    const synthetic::ShakyFlight flight(options);
    MotionEstimator alone{StabilizerConfig{}}, sharing{StabilizerConfig{}};
    sharing.setShareWork(share);
    for (int i = 0; i < flight.frameCount(); ++i) {
        const FrameBuffer frame = flight.render(i);
        const MotionEstimate a = alone.estimate(frame.view()), b = sharing.estimate(frame.view());
        ASSERT_EQ(a.points, b.points) << width << "x" << height << " frame " << i;
        EXPECT_EQ(a.inliers, b.inliers) << "frame " << i;
        EXPECT_EQ(a.motion.dx, b.motion.dx) << "frame " << i;
        EXPECT_EQ(a.motion.dy, b.motion.dy) << "frame " << i;
        EXPECT_EQ(a.motion.angle, b.motion.angle) << "frame " << i;
        EXPECT_EQ(a.motion.scale, b.motion.scale) << "frame " << i;
        ASSERT_EQ(a.tracks.size(), b.tracks.size()) << "frame " << i;
        for (std::size_t k = 0; k < a.tracks.size(); ++k) {
            EXPECT_EQ(a.tracks[k].position.x, b.tracks[k].position.x) << "frame " << i << " track " << k;
            EXPECT_EQ(a.tracks[k].position.y, b.tracks[k].position.y) << "frame " << i << " track " << k;
            EXPECT_EQ(a.tracks[k].inlier, b.tracks[k].inlier) << "frame " << i << " track " << k;
        }
    }
}

} // namespace

TEST(MotionEstimator, SharedWorkInAnyOrderAndOnAnyLaneGivesTheSameEstimates)
{
    // Chunks run last to first, on alternating lanes (each lane has its own scratch): a
    // chunk that wrote another's output or used the wrong scratch shows here, without threads.
    int chunks_run = 0;
    const ShareWork reversed = [&](int chunks, const std::function<void(int, int)> &work) {
        for (int c = chunks - 1; c >= 0; --c, ++chunks_run)
            work(c, c % kShareWorkLanes);
    };
    // 1920x1080: the luma's downscale by 3 is shared in bands of rows; 1280x720: the tracking only.
    expectSameEstimatesWhenShared(1920, 1080, reversed);
    expectSameEstimatesWhenShared(1280, 720, reversed);
    EXPECT_GT(chunks_run, 16 * 2);
}

TEST(MotionEstimator, SharedWorkWithAWorkerThreadGivesTheSameEstimates)
{
    WorkerPool pool(2);
    std::atomic<int> by_worker{0};
    const ShareWork share = [&](int chunks, const std::function<void(int, int)> &work) {
        pool.share(chunks, [&](int c, int lane) {
            by_worker += lane == 1;
            work(c, lane);
        });
    };
    expectSameEstimatesWhenShared(1920, 1080, share);
    std::printf("chunks the worker ran: %d\n", by_worker.load());
    pool.waitIdle();
}
