// The tracker's pyramid against cv::buildOpticalFlowPyramid, byte for byte (padding
// included), and the Scharr derivatives' vector code against their scalar code.
#include <gtest/gtest.h>

#include <cstring>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "tracking_pyramid.hpp"

using namespace uavstab;

namespace {

cv::Mat texture(cv::Size size, int seed)
{
    cv::Mat m(size, CV_8UC1);
    cv::RNG rng{std::uint64_t(seed)};
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
    return m;
}

// The whole padded buffer a pyramid level is the interior of.
cv::Mat padded(const cv::Mat &level)
{
    cv::Size whole;
    cv::Point offset;
    level.locateROI(whole, offset);
    cv::Mat m = level;
    m.adjustROI(offset.y, whole.height - level.rows - offset.y, offset.x, whole.width - level.cols - offset.x);
    return m;
}

bool identical(const cv::Mat &a, const cv::Mat &b)
{
    if (a.size() != b.size() || a.type() != b.type())
        return false;
    for (int y = 0; y < a.rows; ++y)
        if (std::memcmp(a.ptr(y), b.ptr(y), std::size_t(a.cols) * a.elemSize()) != 0)
            return false;
    return true;
}

TEST(TrackingPyramid, MatchesOpenCvsPyramidByteForByte)
{
    struct Case {
        cv::Size size, window;
        int levels;
    };
    for (const Case &c : {Case{{640, 360}, {21, 21}, 3}, Case{{637, 359}, {21, 21}, 3}, Case{{200, 150}, {15, 15}, 4},
                          Case{{45, 31}, {7, 7}, 3}, Case{{60, 50}, {21, 21}, 2}, Case{{9, 5}, {3, 3}, 1}}) {
        std::vector<cv::Mat> ours, reference;
        // Twice: the second build reuses the first one's buffers.
        for (int pass = 0; pass < 2; ++pass) {
            const cv::Mat frame = texture(c.size, c.size.width + pass);
            const int built = buildTrackingPyramid(frame, ours, c.window, c.levels);
            const int expected = cv::buildOpticalFlowPyramid(frame, reference, c.window, c.levels, true,
                                                             cv::BORDER_REFLECT_101, cv::BORDER_CONSTANT, false);
            ASSERT_EQ(built, expected) << c.size;
            ASSERT_EQ(ours.size(), reference.size()) << c.size;
            for (std::size_t i = 0; i < ours.size(); ++i) {
                EXPECT_TRUE(identical(ours[i], reference[i])) << c.size << " entry " << i;
                EXPECT_TRUE(identical(padded(ours[i]), padded(reference[i]))) << c.size << " entry " << i << " padded";
            }
        }
    }
}

TEST(TrackingPyramid, ScharrVectorCodeMatchesScalar)
{
    for (const cv::Size size : {cv::Size(1, 1), cv::Size(2, 3), cv::Size(17, 4), cv::Size(33, 9), cv::Size(640, 12)}) {
        const cv::Mat image = texture(size, 3);
        cv::Mat vector(size, CV_16SC2), scalar(size, CV_16SC2);
        scharrDerivatives(image, vector, true);
        scharrDerivatives(image, scalar, false);
        EXPECT_TRUE(identical(vector, scalar)) << size;
    }
}

} // namespace
