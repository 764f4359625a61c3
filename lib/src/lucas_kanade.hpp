// Pyramidal Lucas-Kanade point tracking: the algorithm, fixed-point sampling and stopping
// rules of cv::calcOpticalFlowPyrLK, with the window sums vectorised with AVX2. OpenCV's
// build on Debian has only 128-bit code for it, and at the tracker's 21x21 window that was
// half of the estimator's time at 1080p.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace uavstab {

struct LucasKanadeParams {
    cv::Size window{21, 21};
    int max_level = 3;             // coarsest level used (0: the finest only)
    int max_iterations = 20;
    double epsilon = 0.03;         // a step shorter than this (pixels of the level) stops
    float min_eigen_threshold = 1e-4f;
};

enum class LucasKanadeKernel {
    Best,    // AVX2 where the CPU has it, else OpenCV's own implementation
    Scalar,  // the reference the AVX2 kernel matches bit for bit
    OpenCv,  // cv::calcOpticalFlowPyrLK
};

// Tracks `from` (pixels of level 0) from `previous` into `next`, pyramids as
// cv::buildOpticalFlowPyramid builds them with derivatives (image, derivatives, image, ...;
// `next`'s derivatives are not read). `to`, `status` and, when not null, `errors` (mean
// absolute difference of the final windows, grey levels) get one entry per point, as from
// cv::calcOpticalFlowPyrLK without an initial flow.
void trackLucasKanade(const std::vector<cv::Mat> &previous, const std::vector<cv::Mat> &next,
                      const std::vector<cv::Point2f> &from, std::vector<cv::Point2f> &to,
                      std::vector<std::uint8_t> &status, std::vector<float> *errors,
                      const LucasKanadeParams &params, LucasKanadeKernel kernel = LucasKanadeKernel::Best);

// Whether LucasKanadeKernel::Best runs the AVX2 kernel on this machine.
bool lucasKanadeHasAvx2();

} // namespace uavstab
