// Window derivatives against the derivative levels cv::buildOpticalFlowPyramid stores
// (padding included: zeros outside the image), and the vector code against the scalar.
#include <gtest/gtest.h>

#include <vector>

#include <opencv2/video/tracking.hpp>

#include "estimate/scharr_derivatives.hpp"

using namespace uavstab;

namespace {

TEST(ScharrDerivatives, RegionsMatchOpenCvsDerivativeLevels)
{
    struct Case {
        cv::Size size, window;
        int levels;
    };
    int regions = 0;
    for (const Case &c : {Case{{640, 360}, {21, 21}, 3}, Case{{637, 359}, {21, 21}, 2}, Case{{45, 31}, {7, 7}, 2},
                          Case{{9, 5}, {3, 3}, 1}}) {
        cv::Mat image(c.size, CV_8UC1);
        cv::RNG rng{std::uint64_t(c.size.width)};
        rng.fill(image, cv::RNG::UNIFORM, 0, 256);
        std::vector<cv::Mat> with, without;
        const int built = cv::buildOpticalFlowPyramid(image, with, c.window, c.levels, true, cv::BORDER_REFLECT_101,
                                                      cv::BORDER_CONSTANT, false);
        cv::buildOpticalFlowPyramid(image, without, c.window, c.levels, false, cv::BORDER_REFLECT_101,
                                    cv::BORDER_CONSTANT, false);
        for (int level = 0; level <= built; ++level) {
            const cv::Mat &img = without[std::size_t(level)];
            const cv::Mat &deriv = with[std::size_t(2 * level + 1)];
            // Regions inside, across every edge and corner, and wholly in the padding.
            for (int k = 0; k < 40; ++k) {
                const cv::Size size(1 + rng.uniform(0, 2 * c.window.width + 2), 1 + rng.uniform(0, c.window.height + 2));
                const cv::Point origin(rng.uniform(-c.window.width, img.cols + c.window.width - size.width + 1),
                                       rng.uniform(-c.window.height, img.rows + c.window.height - size.height + 1));
                for (const bool vector : {true, false}) {
                    const std::size_t step = 2 * std::size_t(size.width) + 3;
                    std::vector<std::int16_t> out(step * std::size_t(size.height), 12345);
                    scharrRegion(img, origin, size, out.data(), step, vector);
                    for (int r = 0; r < size.height; ++r)
                        for (int x = 0; x < size.width; ++x)
                            for (int ch = 0; ch < 2; ++ch) {
                                const int expected = deriv.ptr<std::int16_t>(origin.y + r)[2 * (origin.x + x) + ch];
                                ASSERT_EQ(out[std::size_t(r) * step + std::size_t(2 * x + ch)], expected)
                                    << c.size << " level " << level << " region " << origin << " " << size << " at "
                                    << x << "," << r << (vector ? " vector" : " scalar");
                            }
                }
                ++regions;
            }
        }
    }
    EXPECT_GT(regions, 300);
}

} // namespace
