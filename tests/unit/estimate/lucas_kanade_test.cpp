// The point tracker's Lucas-Kanade: the AVX2 kernel against the scalar reference (bit for
// bit), and both against cv::calcOpticalFlowPyrLK, whose algorithm they follow (on a
// pyramid without stored derivatives it computes them itself).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "estimate/lucas_kanade.hpp"
#include "shaky_flight.hpp"

using namespace uavstab;

namespace {

struct Pair {
    LucasKanadePyramid previous, next;
    std::vector<cv::Point2f> points;
};

// Two frames of a shaky flight, their pyramids as the tracker builds them, and points to
// track: corners, plus points on and beyond the image's edges and corners (the windows
// there reach into the pyramid's padding, where the vector kernel falls back to scalar).
Pair makePair(cv::Size window, int levels, std::uint32_t seed)
{
    synthetic::FlightOptions options;
    options.width = 640;
    options.height = 360;
    options.frames = 4;
    options.seed = seed;
    const synthetic::ShakyFlight flight(options);
    Pair pair;
    cv::Mat a, b;
    cv::cvtColor(flight.renderBgr(1), a, cv::COLOR_BGR2GRAY);
    cv::cvtColor(flight.renderBgr(2), b, cv::COLOR_BGR2GRAY);
    buildLucasKanadePyramid(a, pair.previous, window, levels);
    buildLucasKanadePyramid(b, pair.next, window, levels);
    cv::goodFeaturesToTrack(a, pair.points, 200, 0.01, 8);
    const float w = float(a.cols - 1), h = float(a.rows - 1);
    for (const cv::Point2f p : {cv::Point2f(0.f, 0.f), cv::Point2f(w, h), cv::Point2f(w, 0.f), cv::Point2f(0.f, h),
                                cv::Point2f(w - 0.3f, h * 0.5f), cv::Point2f(w * 0.5f, h - 0.7f),
                                cv::Point2f(-3.f, 10.f), cv::Point2f(w + 5.f, h + 5.f), cv::Point2f(w + 40.f, 3.f)})
        pair.points.push_back(p);
    return pair;
}

struct Result {
    std::vector<cv::Point2f> to;
    std::vector<std::uint8_t> status;
    std::vector<float> errors;
};

Result track(const Pair &pair, const LucasKanadeParams &params, LucasKanadeKernel kernel)
{
    Result r;
    trackLucasKanade(pair.previous, pair.next, pair.points, r.to, r.status, &r.errors, params, kernel);
    return r;
}

struct Case {
    int window;
    int levels;
};

class LucasKanade : public ::testing::TestWithParam<Case> {};

TEST_P(LucasKanade, VectorKernelMatchesScalarBitForBit)
{
    if (!lucasKanadeRunsAvx2()) {
        std::printf("[  NOTE    ] the AVX2 kernel does not run here (no AVX2, or UAVSTAB_LK_KERNEL=opencv): "
                    "nothing to compare\n");
        return;
    }
    const Case c = GetParam();
    LucasKanadeParams params;
    params.window = {c.window, c.window};
    params.max_level = c.levels;
    for (std::uint32_t seed : {1u, 2u}) {
        const Pair pair = makePair(params.window, c.levels, seed);
        const Result vector = track(pair, params, LucasKanadeKernel::Best);
        const Result scalar = track(pair, params, LucasKanadeKernel::Scalar);
        ASSERT_EQ(vector.to.size(), pair.points.size());
        for (std::size_t i = 0; i < pair.points.size(); ++i) {
            EXPECT_EQ(vector.status[i], scalar.status[i]) << "point " << i;
            EXPECT_EQ(vector.to[i].x, scalar.to[i].x) << "point " << i;
            EXPECT_EQ(vector.to[i].y, scalar.to[i].y) << "point " << i;
            EXPECT_EQ(vector.errors[i], scalar.errors[i]) << "point " << i;
        }
    }
}

TEST_P(LucasKanade, FollowsOpenCvsAlgorithm)
{
    const Case c = GetParam();
    LucasKanadeParams params;
    params.window = {c.window, c.window};
    params.max_level = c.levels;
    int compared = 0, close = 0, status_differs = 0;
    for (std::uint32_t seed : {1u, 2u, 3u}) {
        const Pair pair = makePair(params.window, c.levels, seed);
        const Result ours = track(pair, params, LucasKanadeKernel::Scalar);
        const Result reference = track(pair, params, LucasKanadeKernel::OpenCv);
        for (std::size_t i = 0; i < pair.points.size(); ++i) {
            if (ours.status[i] != reference.status[i]) {
                ++status_differs;
                continue;
            }
            if (!ours.status[i])
                continue;
            ++compared;
            // Same fixed-point sampling; only the order of the float sums differs.
            if (cv::norm(ours.to[i] - reference.to[i]) < 0.01 &&
                std::abs(ours.errors[i] - reference.errors[i]) < 0.05f)
                ++close;
        }
    }
    ASSERT_GT(compared, 100);
    EXPECT_LE(status_differs, 2) << compared << " tracked by both";
    EXPECT_GE(close, compared * 98 / 100) << close << " of " << compared << " within 0.01 px";
}

TEST(LucasKanadeTracking, RecoversAKnownShift)
{
    // A textured image shifted by (2.6, -1.3) px: every tracked corner moves by that much.
    cv::Mat a(240, 320, CV_8UC1), b;
    cv::RNG rng(5);
    rng.fill(a, cv::RNG::UNIFORM, 0, 255);
    cv::GaussianBlur(a, a, cv::Size(0, 0), 2.0);
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 2.6, 0, 1, -1.3);
    cv::warpAffine(a, b, shift, a.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
    LucasKanadePyramid pa, pb;
    buildLucasKanadePyramid(a, pa, cv::Size(21, 21), 2);
    buildLucasKanadePyramid(b, pb, cv::Size(21, 21), 2);
    std::vector<cv::Point2f> points, to;
    cv::goodFeaturesToTrack(a(cv::Rect(30, 30, 260, 180)), points, 60, 0.01, 10);
    for (auto &p : points)
        p += cv::Point2f(30.f, 30.f);
    std::vector<std::uint8_t> status;
    LucasKanadeParams params;
    params.max_level = 2;
    trackLucasKanade(pa, pb, points, to, status, nullptr, params);
    ASSERT_GE(points.size(), 30u);
    int good = 0;
    for (std::size_t i = 0; i < points.size(); ++i)
        good += status[i] && cv::norm(to[i] - points[i] - cv::Point2f(2.6f, -1.3f)) < 0.1;
    EXPECT_GE(good, int(points.size()) * 9 / 10);
}

INSTANTIATE_TEST_SUITE_P(Windows, LucasKanade,
                         ::testing::Values(Case{21, 3}, Case{21, 0}, Case{15, 2}, Case{7, 1}, Case{41, 2}),
                         [](const ::testing::TestParamInfo<Case> &info) {
                             return "win" + std::to_string(info.param.window) + "_levels" +
                                    std::to_string(info.param.levels);
                         });

} // namespace
