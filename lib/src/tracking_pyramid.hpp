// The image pyramid the point tracker works on: per level the image and its Scharr
// derivatives, both padded by the tracking window, byte for byte what
// cv::buildOpticalFlowPyramid(image, pyramid, window, max_level, true, BORDER_REFLECT_101,
// BORDER_CONSTANT, false) builds, with the derivatives computed with AVX2 where the CPU has
// it (OpenCV's build has only 128-bit code for them).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace uavstab {

// Fills `pyramid` with image, derivatives, image, derivatives... (8-bit grey, then 16-bit
// (dx, dy) pairs), reusing its buffers when the sizes match. Returns the number of levels
// above the finest actually built (fewer than max_level when the image gets too small).
int buildTrackingPyramid(const cv::Mat &image, std::vector<cv::Mat> &pyramid, cv::Size window, int max_level);

// Scharr derivatives of an 8-bit grey image (rows and columns mirrored at the edges) as
// interleaved 16-bit (dx, dy): OpenCV's calcSharrDeriv. `dst` must have src's size and type
// CV_16SC2. `vector`: false forces the scalar code (the reference in tests).
void scharrDerivatives(const cv::Mat &src, cv::Mat &dst, bool vector = true);

} // namespace uavstab
