#include "wobble_metric.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "estimate/motion_model.hpp"

namespace uavstab::synthetic {

namespace {

constexpr int kGridStep = 16;
constexpr int kMargin = 16;
// A track that does not come back to within this of where it started is dropped.
constexpr double kForwardBackwardPx = 0.5;
constexpr int kMinPointsPerBand = 3;

double median(std::vector<double> v)
{
    const std::size_t mid = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(mid), v.end());
    const double upper = v[mid];
    if (v.size() % 2 == 1)
        return upper;
    return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + std::ptrdiff_t(mid)));
}

} // namespace

WobbleMeasurement measureWobble(const cv::Mat &prev_luma, const cv::Mat &cur_luma, int bands)
{
    if (prev_luma.type() != CV_8UC1 || cur_luma.type() != CV_8UC1 || prev_luma.size() != cur_luma.size())
        throw std::invalid_argument("measureWobble: two 8-bit luma frames of the same size");
    if (bands < 1)
        throw std::invalid_argument("measureWobble: bands must be positive");
    WobbleMeasurement result;
    result.wobble = std::numeric_limits<double>::quiet_NaN();
    const int width = prev_luma.cols, height = prev_luma.rows;

    std::vector<cv::Point2f> grid;
    for (int y = kMargin; y < height - kMargin; y += kGridStep)
        for (int x = kMargin; x < width - kMargin; x += kGridStep)
            grid.emplace_back(float(x), float(y));
    if (grid.size() < 8)
        return result;

    const cv::Size window(21, 21);
    const int levels = 3;
    const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
    std::vector<cv::Point2f> forward, backward;
    std::vector<unsigned char> ok_forward, ok_backward;
    std::vector<float> error;
    cv::calcOpticalFlowPyrLK(prev_luma, cur_luma, grid, forward, ok_forward, error, window, levels, stop);
    cv::calcOpticalFlowPyrLK(cur_luma, prev_luma, forward, backward, ok_backward, error, window, levels, stop);

    // Centred coordinates, the library's convention for similarities.
    const double cx = (width - 1) * 0.5, cy = (height - 1) * 0.5;
    std::vector<Point2> from, to;
    for (std::size_t k = 0; k < grid.size(); ++k) {
        if (!ok_forward[k] || !ok_backward[k])
            continue;
        const cv::Point2f back = backward[k] - grid[k];
        if (std::hypot(back.x, back.y) > kForwardBackwardPx)
            continue;
        from.push_back({grid[k].x - cx, grid[k].y - cy});
        to.push_back({forward[k].x - cx, forward[k].y - cy});
    }
    result.tracked = int(from.size());
    if (from.size() < 8)
        return result;

    // Generous enough to keep the wobble itself (several px) among the inliers, tight enough
    // to leave out most moving objects and failed tracks.
    const double inlier_px = std::max(2.0, 0.01 * std::hypot(width, height));
    const RobustFit fit = fitRobust(MotionModel::Similarity, from, to, inlier_px);
    result.inliers = fit.inlier_count;

    std::vector<std::vector<double>> band_x(static_cast<std::size_t>(bands)), band_y(static_cast<std::size_t>(bands));
    for (std::size_t k = 0; k < from.size(); ++k) {
        if (!fit.inliers[k])
            continue;
        const Point2 expected = fit.motion.apply(from[k]);
        const int band = std::clamp(int((from[k].y + cy) * bands / height), 0, bands - 1);
        band_x[std::size_t(band)].push_back(to[k].x - expected.x);
        band_y[std::size_t(band)].push_back(to[k].y - expected.y);
    }
    double sum2 = 0.0;
    for (int b = 0; b < bands; ++b) {
        if (int(band_x[std::size_t(b)].size()) < kMinPointsPerBand)
            continue;
        const double mx = median(band_x[std::size_t(b)]), my = median(band_y[std::size_t(b)]);
        sum2 += mx * mx + my * my;
        ++result.bands;
    }
    // One band alone cannot tell a bend from a shift.
    if (result.bands >= std::min(2, bands))
        result.wobble = std::sqrt(sum2 / result.bands);
    return result;
}

double wobble(const cv::Mat &prev_luma, const cv::Mat &cur_luma, int bands)
{
    return measureWobble(prev_luma, cur_luma, bands).wobble;
}

double meanWobble(const std::vector<cv::Mat> &frames, int bands)
{
    WobbleMeter meter(bands);
    for (const cv::Mat &frame : frames)
        meter.add(frame);
    return meter.mean();
}

void WobbleMeter::add(const cv::Mat &frame)
{
    cv::Mat luma;
    if (frame.type() == CV_8UC3)
        cv::cvtColor(frame, luma, cv::COLOR_BGR2GRAY);
    else if (frame.type() == CV_8UC1)
        luma = frame.clone();
    else
        throw std::invalid_argument("WobbleMeter: 8-bit luma or BGR frames");
    if (!prev_.empty()) {
        const double w = wobble(prev_, luma, bands_);
        if (std::isfinite(w)) {
            sum_ += w;
            ++pairs_;
        } else {
            ++skipped_;
        }
    }
    prev_ = luma;
}

} // namespace uavstab::synthetic
