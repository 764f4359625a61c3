// The banded Shi-Tomasi detector against cv::goodFeaturesToTrack: the same corners, bit for
// bit, on noise (the widest spread of derivative values), the synthetic flight's frames,
// regions of larger images, masks and odd sizes.
#include <gtest/gtest.h>

#include <cstring>

#include <opencv2/imgproc.hpp>

#include "estimate/corner_detector.hpp"
#include "shaky_flight.hpp"

using namespace uavstab;

namespace {

cv::Mat noise(cv::Size size, int seed, int blur)
{
    cv::Mat image(size, CV_8UC1);
    cv::RNG rng{std::uint64_t(seed) + 1};
    rng.fill(image, cv::RNG::UNIFORM, 0, 256);
    if (blur > 1)
        cv::GaussianBlur(image, image, cv::Size(blur, blur), 0);
    return image;
}

// The strips' kept columns put together; `neighbours_differ` counts the strips whose
// columns next to those they keep (which the local maxima read) differ from `whole`'s.
cv::Mat eigenvaluesInStrips(const cv::Mat &image, int strip_columns, const cv::Mat &whole, int &neighbours_differ)
{
    cv::Mat kept(image.size(), CV_32FC1, cv::Scalar(-1.f));
    int previous_end = 0;
    neighbours_differ = 0;
    forEachEigenvalueStrip(image, strip_columns, [&](const cv::Mat &eig, int left, int begin, int end) {
        EXPECT_EQ(begin, previous_end);
        previous_end = end;
        eig.colRange(begin - left, end - left).copyTo(kept.colRange(begin, end));
        const int lo = std::max(0, begin - 1), hi = std::min(image.cols, end + 1);
        if (cv::norm(eig.colRange(lo - left, hi - left), whole.colRange(lo, hi), cv::NORM_INF) != 0)
            ++neighbours_differ;
    });
    EXPECT_EQ(previous_end, image.cols);
    return kept;
}

bool sameBits(const cv::Mat &a, const cv::Mat &b)
{
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0 &&
           std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

void expectSameCorners(const cv::Mat &image, int max_corners, double quality, double min_distance,
                       const cv::Mat &mask = cv::Mat())
{
    std::vector<cv::Point2f> expected, got;
    cv::goodFeaturesToTrack(image, expected, max_corners, quality, min_distance, mask);
    detectGoodCorners(image, got, max_corners, quality, min_distance, mask);
    ASSERT_EQ(got.size(), expected.size());
    for (std::size_t i = 0; i < got.size(); ++i) {
        EXPECT_EQ(got[i].x, expected[i].x) << "corner " << i;
        EXPECT_EQ(got[i].y, expected[i].y) << "corner " << i;
    }
}

} // namespace

TEST(CornerDetector, EigenvaluesInStripsAreTheWholeImagesBitForBit)
{
    int checked = 0;
    for (const cv::Size size : {cv::Size(256, 192), cv::Size(257, 181), cv::Size(97, 640), cv::Size(203, 9),
                                cv::Size(35, 333), cv::Size(640, 480)})
        for (int seed = 0; seed < 3; ++seed)
            for (int blur : {1, 3, 9}) {
                const cv::Mat image = noise(size, seed * 7 + blur, blur);
                cv::Mat whole, banded;
                cv::cornerMinEigenVal(image, whole, 3, 3);
                for (int strip_columns : {8, 16, 24, 64}) {
                    int neighbours_differ = -1;
                    banded = eigenvaluesInStrips(image, strip_columns, whole, neighbours_differ);
                    EXPECT_TRUE(sameBits(whole, banded)) << size << " seed " << seed << " blur " << blur << " strips "
                                                         << strip_columns;
                    EXPECT_EQ(neighbours_differ, 0);
                    ++checked;
                }
            }
    EXPECT_EQ(checked, 6 * 3 * 3 * 4);
}

TEST(CornerDetector, ARegionsEigenvaluesReadThePixelsAroundIt)
{
    const cv::Mat image = noise({400, 300}, 11, 5);
    const cv::Mat region = image(cv::Rect(40, 30, 320, 240));
    cv::Mat whole, isolated;
    cv::cornerMinEigenVal(region, whole, 3, 3);
    int neighbours_differ = -1;
    const cv::Mat banded = eigenvaluesInStrips(region, 16, whole, neighbours_differ);
    EXPECT_EQ(neighbours_differ, 0);
    EXPECT_TRUE(sameBits(whole, banded));
    // The check has teeth: the same pixels as an image of their own differ at the edges.
    cv::cornerMinEigenVal(region.clone(), isolated, 3, 3);
    EXPECT_FALSE(sameBits(whole, isolated));
}

TEST(CornerDetector, PicksGoodFeaturesToTracksCornersOnNoise)
{
    for (int seed = 0; seed < 4; ++seed)
        for (int blur : {1, 5}) {
            const cv::Mat image = noise({320, 240}, 100 + seed, blur);
            expectSameCorners(image, 50, 0.01, 12.0);
            expectSameCorners(image, 200, 0.05, 2.0);
            expectSameCorners(image, 0, 0.01, 7.5);  // no limit
            expectSameCorners(image, 30, 0.01, 0.5);  // no spacing
            // At quality 1 the threshold is the largest eigenvalue itself, which OpenCV's
            // threshold (strictly above) sets to zero too: no corners.
            expectSameCorners(image, 30, 1.0, 5.0);
        }
}

TEST(CornerDetector, PicksGoodFeaturesToTracksCornersOnTheFlightWithMasksAndRegions)
{
    synthetic::FlightOptions options;
    options.width = 640;
    options.height = 480;
    const synthetic::ShakyFlight flight(options);
    for (int i = 0; i < 30; i += 7) {
        cv::Mat grey;
        cv::cvtColor(flight.renderBgr(i), grey, cv::COLOR_BGR2GRAY);
        cv::Mat half;
        cv::pyrDown(grey, half);
        const cv::Mat region = half(cv::Rect(32, 24, 256, 192));
        expectSameCorners(region, 50, 0.01, 10.0);
        cv::Mat mask(region.size(), CV_8UC1, cv::Scalar(255));
        mask(cv::Rect(100, 20, 80, 150)).setTo(0);
        expectSameCorners(region, 50, 0.01, 10.0, mask);
        expectSameCorners(grey, 400, 0.001, 3.0);
    }
}

TEST(CornerDetector, TiesComeInOpenCvsOrder)
{
    // A checkerboard: every inner crossing has the same eigenvalue, so the order among
    // equals and the spacing decide which are kept.
    cv::Mat board(200, 300, CV_8UC1);
    for (int y = 0; y < board.rows; ++y)
        for (int x = 0; x < board.cols; ++x)
            board.at<std::uint8_t>(y, x) = ((x / 10 + y / 10) % 2) ? 220 : 30;
    expectSameCorners(board, 50, 0.01, 5.0);
    expectSameCorners(board, 0, 0.01, 15.0);
    expectSameCorners(board, 0, 0.3, 0.0);
    cv::Mat mask(board.size(), CV_8UC1, cv::Scalar(0));
    mask(cv::Rect(55, 45, 120, 90)).setTo(255);
    expectSameCorners(board, 20, 0.01, 12.0, mask);
}

TEST(CornerDetector, FlatAndTinyImagesGiveWhatOpenCvGives)
{
    expectSameCorners(cv::Mat(120, 160, CV_8UC1, cv::Scalar(0)), 50, 0.01, 5.0);
    expectSameCorners(cv::Mat(120, 160, CV_8UC1, cv::Scalar(200)), 50, 0.01, 5.0);
    expectSameCorners(noise({3, 3}, 1, 1), 50, 0.01, 2.0);
    expectSameCorners(noise({5, 80}, 2, 1), 50, 0.01, 2.0);
    expectSameCorners(noise({80, 5}, 3, 1), 50, 0.01, 2.0);
    const cv::Mat textured = noise({300, 200}, 4, 3);
    expectSameCorners(textured, 50, 0.01, 5.0, cv::Mat(textured.size(), CV_8UC1, cv::Scalar(0)));  // all masked
    std::vector<cv::Point2f> corners{{1.f, 2.f}};
    detectGoodCorners(cv::Mat(), corners, 50, 0.01, 2.0);
    EXPECT_TRUE(corners.empty());
}
