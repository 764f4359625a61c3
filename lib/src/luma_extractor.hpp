// Internal: the luma of a frame at analysis resolution, read straight from the Y plane
// (YUV/gray) or converted once from packed RGB, downscaled without copying the frame.
#pragma once

#include <deque>

#include <opencv2/core.hpp>

#include "uavstab/frame_view.hpp"

namespace uavstab {

class LumaExtractor {
public:
    // Size of the analysis image for a frame: width min(frame width, analysis_width),
    // height scaled to keep the aspect ratio.
    static cv::Size analysisSize(int width, int height, int analysis_width);

    // Returns the luma at analysis size. The result is owned by the extractor (reused from
    // frame to frame) or, when no resampling is needed, may view the frame's own Y plane.
    const cv::Mat &extract(const FrameView &frame, int analysis_width);

private:
    void downscale(const cv::Mat &src, cv::Mat &dst, cv::Size size);

    std::deque<cv::Mat> halvings_;  // intermediate halved images, reused (stable addresses)
    cv::Mat view_;          // wraps the caller's Y plane (never written)
    cv::Mat luma_;          // owned analysis image, reused from frame to frame
    cv::Mat packed_small_;
};

// Wraps one plane of a frame as a cv::Mat with the plane's stride (no copy).
cv::Mat planeMat(const FrameView &frame, int plane);

} // namespace uavstab
