// Wobble: the non-rigid motion between consecutive frames, in px. A rolling shutter on a
// vibrating camera bends each frame differently (jello); a stabilizer that only corrects a
// similarity per frame cannot remove that. Usable on synthetic and real clips alike (it needs
// no truth).
//
// Definition: LK tracks a regular grid of points (every 16 px inside a 16 px margin,
// forward-backward checked) from the previous frame to the current one; the best similarity
// (robust fit, then least squares on its inliers) is removed; the inliers' residual vectors
// are split into horizontal bands by row; per band the median residual (x and y medians
// apart); wobble = RMS over the bands of the length of that median vector.
//
// What it sees: motion that depends on the row (shear, row-wise wiggle). What it cannot see:
// anything a similarity explains - a uniform shift, rotation or zoom costs nothing however
// large, and a perfectly linear skew is in part absorbed by the rotation. Parallax and moving
// objects raise it a little (the band medians keep most of them out).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace uavstab::synthetic {

struct WobbleMeasurement {
    double wobble = 0.0;  // px; NaN when too little could be tracked to measure
    int tracked = 0;      // grid points that passed the forward-backward check
    int inliers = 0;      // of those, inliers of the similarity
    int bands = 0;        // bands with enough inliers to take a median
};

// Two consecutive 8-bit luma frames (CV_8UC1, the same size).
WobbleMeasurement measureWobble(const cv::Mat &prev_luma, const cv::Mat &cur_luma, int bands = 10);
double wobble(const cv::Mat &prev_luma, const cv::Mat &cur_luma, int bands = 10);

// Clip-level wobble: the mean over consecutive frame pairs (frame pairs that could not be
// measured are left out; 0 when none could). Frames are 8-bit luma (CV_8UC1) or BGR (CV_8UC3).
double meanWobble(const std::vector<cv::Mat> &frames, int bands = 10);

// The same with the frames fed one at a time (a decoder, a renderer).
class WobbleMeter {
public:
    explicit WobbleMeter(int bands = 10) : bands_(bands) {}
    // An 8-bit luma frame (CV_8UC1) or a BGR one (CV_8UC3, converted).
    void add(const cv::Mat &frame);
    double mean() const { return pairs_ > 0 ? sum_ / pairs_ : 0.0; }
    int pairs() const { return pairs_; }        // frame pairs measured
    int unmeasured() const { return skipped_; }  // frame pairs left out

private:
    int bands_;
    cv::Mat prev_;
    double sum_ = 0.0;
    int pairs_ = 0, skipped_ = 0;
};

} // namespace uavstab::synthetic
