#include "estimate/overlay_strokes.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace uavstab {

namespace {

constexpr std::size_t kSamples = 6;  // frames compared
constexpr double kSampleSpacing = 6.0;  // analysis px the camera moves between samples
constexpr int kRebuildEvery = 3;        // samples between two rebuilds of the mask
// The samples' positions must spread this far (analysis px, RMS) across their main direction
// too: along a straight pan, a scene's edges parallel to it stay the same.
constexpr double kMinCrossSpread = 3.0;
constexpr int kStillRange = 10;   // luma levels a pixel may vary over the samples and still be "the same"
constexpr int kStandOut = 12;     // luma levels from its neighbourhood's mean (7x7) to be a stroke
constexpr int kGrow = 2;          // px the mask is grown by (a stroke's soft edge)
constexpr int kPaintRadius = 8;  // px: the neighbourhood a painted pixel takes its value from

cv::Size paintWindow()
{
    return {2 * kPaintRadius + 1, 2 * kPaintRadius + 1};
}

} // namespace

void OverlayStrokes::reset()
{
    samples_.clear();
    position_ = {0.0, 0.0};
    pending_.release();
    mask_.release();
}

void OverlayStrokes::motionUnknown()
{
    pending_.release();
    samples_.clear();  // the next positions cannot be related to theirs
    position_ = {0.0, 0.0};
}

void OverlayStrokes::cameraMoved(const Similarity &current_to_previous, double scale)
{
    position_.x += current_to_previous.dx / scale;
    position_.y += current_to_previous.dy / scale;
    if (pending_.empty())
        return;
    if (!samples_.empty()) {
        const Point2 &last = samples_.back().position;
        if (std::hypot(position_.x - last.x, position_.y - last.y) < kSampleSpacing) {
            pending_.release();  // the frame's buffer is not ours to keep
            return;
        }
        if (samples_.back().luma.size() != pending_.size())
            samples_.clear();
    }
    if (samples_.size() == kSamples) {
        // The oldest sample's buffer takes the new one.
        Sample oldest = std::move(samples_.front());
        samples_.erase(samples_.begin());
        pending_.copyTo(oldest.luma);
        oldest.position = position_;
        samples_.push_back(std::move(oldest));
    } else {
        samples_.push_back({pending_.clone(), position_});
    }
    pending_.release();
    // The mask is rebuilt every few samples: an overlay stays, and the streaming thread's
    // time is the element's throughput.
    if (++samples_since_rebuild_ >= kRebuildEvery) {
        samples_since_rebuild_ = 0;
        rebuildMask();
    }
}

bool OverlayStrokes::samplesSpreadInTwoDirections() const
{
    if (samples_.size() < kSamples)
        return false;
    double mx = 0, my = 0;
    for (const Sample &s : samples_) {
        mx += s.position.x;
        my += s.position.y;
    }
    mx /= double(samples_.size());
    my /= double(samples_.size());
    double xx = 0, xy = 0, yy = 0;
    for (const Sample &s : samples_) {
        const double dx = s.position.x - mx, dy = s.position.y - my;
        xx += dx * dx;
        xy += dx * dy;
        yy += dy * dy;
    }
    xx /= double(samples_.size());
    xy /= double(samples_.size());
    yy /= double(samples_.size());
    // The smaller eigenvalue of the positions' covariance: the spread across the main direction.
    const double half_trace = 0.5 * (xx + yy);
    const double minor = half_trace - std::sqrt(std::max(0.0, half_trace * half_trace - (xx * yy - xy * xy)));
    return minor >= kMinCrossSpread * kMinCrossSpread;
}

void OverlayStrokes::rebuildMask()
{
    // A mask is only rebuilt from samples it can trust; until then the last one holds
    // (an overlay does not leave the frame because the camera pans).
    if (!samplesSpreadInTwoDirections())
        return;
    const cv::Mat &newest = samples_.back().luma;
    newest.copyTo(low_);
    newest.copyTo(high_);
    for (std::size_t i = 0; i + 1 < samples_.size(); ++i) {
        cv::min(low_, samples_[i].luma, low_);
        cv::max(high_, samples_[i].luma, high_);
    }
    cv::Mat range, still, neighbourhood, stand_out;
    cv::subtract(high_, low_, range);
    cv::compare(range, kStillRange, still, cv::CMP_LE);
    cv::blur(newest, neighbourhood, cv::Size(7, 7));
    cv::absdiff(newest, neighbourhood, stand_out);
    cv::compare(stand_out, kStandOut, stand_out, cv::CMP_GE);
    cv::bitwise_and(still, stand_out, mask_);
    if (cv::countNonZero(mask_) == 0) {
        mask_.release();
        return;
    }
    cv::dilate(mask_, mask_, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * kGrow + 1, 2 * kGrow + 1)));
    // What the painting needs of the mask alone, once per mask rather than per frame: the
    // area it touches, the scene's weights there and their blur.
    const cv::Rect box = cv::boundingRect(mask_);
    const int margin = kPaintRadius;
    paint_area_ = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
                  cv::Rect(0, 0, mask_.cols, mask_.rows);
    cv::Mat scene;
    cv::bitwise_not(mask_(paint_area_), scene);
    scene.convertTo(weight_, CV_32F, 1.0 / 255.0);
    cv::boxFilter(weight_, blurred_weight_, -1, paintWindow());
    cv::max(blurred_weight_, 1e-3f, blurred_weight_);
}

const cv::Mat &OverlayStrokes::paint(const cv::Mat &luma, cv::Mat &painted)
{
    // Not copied: the estimator tells cameraMoved() this frame's motion before the next
    // frame's luma is extracted into the same buffer, and a sample is copied there.
    pending_ = luma;
    if (mask_.empty() || mask_.size() != luma.size())
        return luma;
    // Each overlay pixel takes the mean of the scene around it (a normalised convolution:
    // the blur of the scene's pixels over the blur of their weights).
    const cv::Rect &area = paint_area_;
    luma(area).convertTo(blurred_, CV_32F);
    cv::multiply(blurred_, weight_, blurred_);
    cv::boxFilter(blurred_, blurred_, -1, paintWindow());
    cv::divide(blurred_, blurred_weight_, blurred_);
    luma.copyTo(painted);
    blurred_.convertTo(fill_, CV_8U);
    fill_.copyTo(painted(area), mask_(area));
    return painted;
}

} // namespace uavstab
