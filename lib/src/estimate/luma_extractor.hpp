// The luma of a frame at analysis resolution, read straight from the Y plane
// (YUV/gray) or converted once from packed RGB, downscaled without copying the frame.
// 16-bit frames (thermal) are brought to 8 bits by an automatic gain (AutoGain) whose
// state follows the stream: it is reset with the tracker.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include <opencv2/core.hpp>

#include "uavstab/frame_view.hpp"
#include "share_work.hpp"

namespace uavstab {

// Automatic gain for 16-bit frames: the 8-bit analysis image is
//     v8 = saturate(255 * (v - low) / (high - low))
// with [low, high] a robust stretch of the scene (the 1st and 99th percentiles of a
// subsample of the frame) that is kept stable from frame to frame, so that the tracker
// compares like with like:
//  - hysteresis: a measured limit within `dead band` (5 % of the span) of the current one
//    moves nothing, so a static scene is mapped with exactly the same gain frame after
//    frame (sensor noise and sampling noise of the percentiles stay inside the band);
//  - beyond the band a limit follows the measured one exponentially (a tenth of the
//    remaining distance per frame) and by at most 1 % of the span per frame, so a hot
//    object entering the scene (which moves the 99th percentile at once when it covers
//    more than 1 % of the frame) changes the 8-bit picture by at most about 2.5 grey
//    levels (offset) or 2 % (gain) from one frame to the next;
//  - when the current limits clip more than a quarter of the frame (the camera turned to
//    a much hotter or colder scene: the 8-bit picture is mostly saturated and useless to
//    the tracker), the limits follow fast (half the distance per frame, no rate limit).
// The first frame after construction or reset() takes its measured limits as they are.
class AutoGain {
public:
    struct Limits {
        double low = 0.0, high = 0.0;  // 16-bit sample values mapped to 0 and 255
    };
    struct Measurement {
        Limits percentiles;            // 1st and 99th percentiles of the subsample
        double clipped_share = 0.0;    // share of the subsample outside the current limits
    };

    static constexpr double kLowPercentile = 0.01;
    static constexpr double kHighPercentile = 0.99;
    static constexpr int kSampleTarget = 16384;  // about this many pixels are sampled
    static constexpr double kMinSpan = 64.0;     // never stretch fewer counts to 256 levels
    static constexpr double kDeadBand = 0.05;    // share of the span
    static constexpr double kFollow = 0.1;       // share of the distance per frame
    static constexpr double kMaxRate = 0.01;     // share of the span per frame, per limit
    static constexpr double kLostShare = 0.25;   // clipped share beyond which limits follow fast
    static constexpr double kFastFollow = 0.5;

    // Measures `image` (CV_16UC1, host byte order), moves the limits and returns them:
    // the limits to map this frame with.
    Limits update(const cv::Mat &image);
    void reset() { initialized_ = false; }
    bool initialized() const { return initialized_; }
    const Limits &limits() const { return limits_; }
    const Measurement &lastMeasurement() const { return measurement_; }

private:
    std::vector<std::uint16_t> samples_;
    Limits limits_;
    Measurement measurement_;
    bool initialized_ = false;
};

class LumaExtractor {
public:
    // Size of the analysis image for a frame: width min(frame width, analysis_width),
    // height scaled to keep the aspect ratio.
    static cv::Size analysisSize(int width, int height, int analysis_width);

    // Returns the luma at analysis size. The result is owned by the extractor (reused from
    // frame to frame) or, when no resampling is needed, may view the frame's own Y plane.
    // 16-bit frames go through the automatic gain (which this call advances).
    const cv::Mat &extract(const FrameView &frame, int analysis_width);

    // Where a downscale by 3 may share its rows (unset: all on the caller's thread).
    void setShareWork(ShareWork share) { share_ = std::move(share); }

    // Starts the automatic gain afresh (a new stream, a seek, a scene cut).
    void reset() { gain_.reset(); }
    const AutoGain &gain() const { return gain_; }

private:
    void downscale(const cv::Mat &src, cv::Mat &dst, cv::Size size);
    const cv::Mat &extract16(const FrameView &frame, cv::Size size);

    std::deque<cv::Mat> halvings_;  // intermediate halved images, reused (stable addresses)
    cv::Mat view_;          // wraps the caller's Y plane (never written)
    cv::Mat luma_;          // owned analysis image, reused from frame to frame
    cv::Mat packed_small_;
    cv::Mat swapped_;       // 16-bit big-endian frames in host byte order
    cv::Mat luma16_;        // 16-bit analysis image before the gain
    std::vector<std::uint16_t> row_sums_[kShareWorkLanes];  // boxDownscale3's scratch, per lane
    ShareWork share_;
    AutoGain gain_;
};

// Averages 3x3 blocks of an 8-bit image of 1 or 4 channels (each output sample the
// rounded mean of its block, vector and scalar paths alike) into an image a third of its
// size (rows and columns beyond a multiple of 3 ignored). `row_sums` is scratch.
void boxDownscale3(const cv::Mat &src, cv::Mat &dst, std::vector<std::uint16_t> &row_sums);

// Wraps one plane of a frame as a cv::Mat with the plane's stride (no copy). 16-bit
// planes are CV_16U, in the frame's byte order.
cv::Mat planeMat(const FrameView &frame, int plane);

// True when 16-bit samples of this format are stored in the other byte order than the
// host's.
bool needsByteSwap(PixelFormat format);

} // namespace uavstab
