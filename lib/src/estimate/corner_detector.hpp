// Shi-Tomasi corners, the corners cv::goodFeaturesToTrack picks (block 3,
// gradient 3, minimum eigenvalue) to the last bit, with a fraction of its scratch.
//
// goodFeaturesToTrack allocates five images of the input's size on every call (both
// derivatives, their three products, the eigenvalues and their dilation): about three
// frames' worth for a 640x480 I420 stream, in use while the stabilizer already holds its
// delay's frames. Here OpenCV computes the eigenvalues in strips of columns, and the
// candidates are taken from each strip as it is made: no image of the input's size.
#pragma once

#include <functional>
#include <vector>

#include <opencv2/core.hpp>

namespace uavstab {

// cv::goodFeaturesToTrack(image, corners, max_corners, quality_level, min_distance, mask):
// the same corners in the same order. `image` is 8-bit, one channel, and may be a region
// of a larger image (the derivatives then read the pixels around it, as OpenCV's do).
void detectGoodCorners(const cv::Mat &image, std::vector<cv::Point2f> &corners, int max_corners,
                       double quality_level, double min_distance, const cv::Mat &mask = cv::Mat());

// The minimum-eigenvalue image cv::cornerMinEigenVal(image, eig, 3, 3) writes, computed in
// strips of `strip_columns` columns (a multiple of 8), left to right: `visit` gets each
// strip's eigenvalues, where column 0 is the image's column `left`, exact for the image's
// columns [begin - 1, end + 1) (within the image).
using EigenvalueStripVisitor = std::function<void(const cv::Mat &eig, int left, int begin, int end)>;
void forEachEigenvalueStrip(const cv::Mat &image, int strip_columns, const EigenvalueStripVisitor &visit);

} // namespace uavstab
