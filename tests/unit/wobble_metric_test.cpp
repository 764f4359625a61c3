// The wobble metric: nothing for motion a similarity explains, the expected value for a
// known row-dependent shift.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "estimate/motion_model.hpp"
#include "wobble_metric.hpp"

using namespace uavstab;
using namespace uavstab::synthetic;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kWidth = 640, kHeight = 360;

cv::Mat aerialLuma()
{
    cv::Mat grey = cv::imread(std::string(UAVSTAB_TEST_DATA_DIR) + "/aero1.jpg", cv::IMREAD_GRAYSCALE);
    EXPECT_FALSE(grey.empty());
    return grey;
}

// A kWidth x kHeight view of the photograph through camera pose `pose` (view centred
// pixel -> photograph pixel about the photograph's centre).
cv::Mat view(const cv::Mat &photo, const Similarity &pose)
{
    const Similarity to_photo{(photo.cols - 1) * 0.5, (photo.rows - 1) * 0.5, 0.0, 1.0};
    const auto m = (to_photo * pose).pixelMatrix(kWidth, kHeight);
    const double cx = (kWidth - 1) * 0.5, cy = (kHeight - 1) * 0.5;
    double matrix[6] = {m[0], m[1], m[2] - cx, m[3], m[4], m[5] - cy};
    cv::Mat out;
    cv::warpAffine(photo, out, cv::Mat(2, 3, CV_64F, matrix), cv::Size(kWidth, kHeight),
                   cv::INTER_CUBIC | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT_101);
    return out;
}

// `frame` with each row y shifted right by shift(y): a point at (x, y) moves to (x + shift(y), y).
template <typename Shift>
cv::Mat shiftRows(const cv::Mat &frame, Shift shift)
{
    cv::Mat map_x(frame.size(), CV_32F), map_y(frame.size(), CV_32F);
    for (int y = 0; y < frame.rows; ++y)
        for (int x = 0; x < frame.cols; ++x) {
            map_x.at<float>(y, x) = float(x - shift(y));
            map_y.at<float>(y, x) = float(y);
        }
    cv::Mat out;
    cv::remap(frame, out, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
    return out;
}

// The metric's definition applied to the true displacement field (every 16 px inside a
// 16 px margin, no tracking): what a perfect tracker would give.
template <typename Shift>
double expectedWobble(Shift shift, int bands = 10)
{
    const double cx = (kWidth - 1) * 0.5, cy = (kHeight - 1) * 0.5;
    std::vector<Point2> from, to;
    for (int y = 16; y < kHeight - 16; y += 16)
        for (int x = 16; x < kWidth - 16; x += 16) {
            from.push_back({x - cx, y - cy});
            to.push_back({x + shift(y) - cx, y - cy});
        }
    const Similarity fit = fitLeastSquares(MotionModel::Similarity, from, to);
    std::vector<std::vector<double>> rx(static_cast<std::size_t>(bands)), ry(static_cast<std::size_t>(bands));
    for (std::size_t k = 0; k < from.size(); ++k) {
        const Point2 e = fit.apply(from[k]);
        const std::size_t b = std::size_t((from[k].y + cy) * bands / kHeight);
        rx[b].push_back(to[k].x - e.x);
        ry[b].push_back(to[k].y - e.y);
    }
    auto median = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        const std::size_t n = v.size();
        return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    };
    double sum2 = 0;
    for (int b = 0; b < bands; ++b) {
        const double mx = median(rx[std::size_t(b)]), my = median(ry[std::size_t(b)]);
        sum2 += mx * mx + my * my;
    }
    return std::sqrt(sum2 / bands);
}

} // namespace

TEST(Wobble, NothingForAShiftOrARotation)
{
    const cv::Mat photo = aerialLuma();
    const Similarity start{3.0, -4.0, 0.01, 0.8};
    const cv::Mat a = view(photo, start);
    for (const Similarity move : {Similarity{5.3, -2.7, 0.0, 1.0}, Similarity{0.0, 0.0, 0.02, 1.0},
                                  Similarity{-7.4, 3.1, -0.015, 1.01}}) {
        const WobbleMeasurement m = measureWobble(a, view(photo, start * move));
        std::printf("move (%.1f, %.1f, %.3f rad, x%.2f): wobble %.4f px, %d tracked, %d inliers, %d bands\n",
                    move.dx, move.dy, move.angle, move.scale, m.wobble, m.tracked, m.inliers, m.bands);
        EXPECT_LT(m.wobble, 0.05);
        EXPECT_EQ(m.bands, 10);
        EXPECT_GT(m.inliers, 500);
    }
    EXPECT_LT(wobble(a, a), 1e-3);
}

// A smooth row-dependent sideways shift, as a rolling shutter makes of a vibration.
TEST(Wobble, ASmoothShearCostsWhatItShouldBe)
{
    const cv::Mat a = view(aerialLuma(), {2.0, 5.0, 0.0, 0.8});
    for (const double amplitude : {1.0, 3.0}) {
        auto shift = [&](double y) { return amplitude * std::sin(2 * kPi * 1.25 * y / kHeight + 0.7); };
        const double expected = expectedWobble(shift);
        const double measured = wobble(a, shiftRows(a, shift));
        std::printf("sinusoidal shear %.1f px: wobble %.3f px, expected %.3f px\n", amplitude, measured, expected);
        EXPECT_GT(expected, 0.4 * amplitude);
        EXPECT_NEAR(measured, expected, 0.1 * expected);
    }
}

// Every band shifted sideways by its own amount (steps at the band boundaries).
TEST(Wobble, APerBandShearCostsWhatItShouldBe)
{
    const cv::Mat a = view(aerialLuma(), {-4.0, 1.0, 0.0, 0.8});
    const double by_band[10] = {0.0, 1.5, 2.5, 1.0, -1.0, -2.0, -1.5, 0.5, 2.0, 0.5};
    auto shift = [&](double y) { return by_band[std::min(9, int(y * 10 / kHeight))]; };
    const double expected = expectedWobble(shift);
    const double measured = wobble(a, shiftRows(a, shift));
    std::printf("per-band shear: wobble %.3f px, expected %.3f px\n", measured, expected);
    EXPECT_GT(expected, 1.0);
    EXPECT_NEAR(measured, expected, 0.15 * expected);
}

TEST(Wobble, MeanOverAClip)
{
    const cv::Mat photo = aerialLuma();
    std::vector<cv::Mat> frames;
    for (int i = 0; i < 5; ++i)
        frames.push_back(view(photo, {1.5 * i, -0.5 * i, 0.002 * i, 0.8}));
    EXPECT_LT(meanWobble(frames), 0.05);
    auto shift = [](double y) { return 2.0 * std::sin(2 * kPi * y / kHeight); };
    const std::vector<cv::Mat> bent{frames[0], shiftRows(frames[0], shift), frames[0]};
    WobbleMeter meter;
    for (const cv::Mat &f : bent)
        meter.add(f);
    EXPECT_EQ(meter.pairs(), 2);
    EXPECT_NEAR(meter.mean(), expectedWobble(shift), 0.15 * expectedWobble(shift));
    EXPECT_EQ(meanWobble({}), 0.0);
}
