// Pyramidal Lucas-Kanade point tracking: the algorithm, fixed-point sampling and stopping
// rules of cv::calcOpticalFlowPyrLK, with the window sums vectorised with AVX2 and the
// image derivatives computed per window instead of stored per level. OpenCV's build on
// Debian has only 128-bit code for it (at the tracker's 21x21 window that was half of the
// estimator's time at 1080p), and two pyramids of stored derivatives are 3.8 MB at
// 640x480.
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

// Levels as cv::buildOpticalFlowPyramid builds them (each padded by the window, mirrored):
// images only, or image, derivatives, image... (where OpenCV's LK will run).
struct LucasKanadePyramid {
    std::vector<cv::Mat> levels;
    bool derivatives = false;

    const cv::Mat &image(int level) const { return levels[std::size_t(derivatives ? 2 * level : level)]; }
    int levelCount() const { return int(levels.size()) / (derivatives ? 2 : 1); }
    bool empty() const { return levels.empty(); }
};

enum class LucasKanadeKernel {
    Best,    // AVX2 where the CPU has it (see lucasKanadeRunsAvx2), else OpenCV's own implementation
    Scalar,  // the reference the AVX2 kernel matches bit for bit
    OpenCv,  // cv::calcOpticalFlowPyrLK
};

// Builds (reusing its buffers) the pyramid of `image` (8-bit grey) for tracking with
// `window` through `max_level` levels above the finest (fewer if the image gets too small),
// with stored derivatives only where LucasKanadeKernel::Best runs OpenCV's LK.
void buildLucasKanadePyramid(const cv::Mat &image, LucasKanadePyramid &pyramid, cv::Size window, int max_level);

// Tracks `from` (pixels of level 0) from `previous` into `next`. `to`, `status` and, when
// not null, `errors` (mean absolute difference of the final windows, grey levels) get one
// entry per point, as from cv::calcOpticalFlowPyrLK without an initial flow.
void trackLucasKanade(const LucasKanadePyramid &previous, const LucasKanadePyramid &next,
                      const std::vector<cv::Point2f> &from, std::vector<cv::Point2f> &to,
                      std::vector<std::uint8_t> &status, std::vector<float> *errors,
                      const LucasKanadeParams &params, LucasKanadeKernel kernel = LucasKanadeKernel::Best);

// Whether LucasKanadeKernel::Best runs the AVX2 kernel here: the CPU has AVX2 and the
// environment does not say UAVSTAB_LK_KERNEL=opencv (which runs OpenCV's LK, as on ARM).
bool lucasKanadeRunsAvx2();

} // namespace uavstab
