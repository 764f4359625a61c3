// Scharr derivatives of a small region of a tracking pyramid level, computed when a
// Lucas-Kanade window needs them rather than stored for whole levels: the values of the
// derivative level cv::buildOpticalFlowPyramid would store (OpenCV's calcSharrDeriv, the
// image mirrored at its edges, zero outside it), without its memory (four bytes a pixel of
// every level of two pyramids).
#pragma once

#include <cstddef>
#include <cstdint>

#include <opencv2/core.hpp>

namespace uavstab {

// Derivatives (dx, dy), interleaved 16-bit, of the pixels [origin, origin + size) of
// `level`, an 8-bit image padded by at least one pixel mirrored (reflect-101) on every side
// (a pyramid level); pixels outside the image get zeros. Row r of the result starts at
// out + r * out_step (in int16 units). `vector`: false forces the scalar code.
void scharrRegion(const cv::Mat &level, cv::Point origin, cv::Size size, std::int16_t *out, std::size_t out_step,
                  bool vector = true);

} // namespace uavstab
