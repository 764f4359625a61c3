// Converting test pictures (packed BGR, as OpenCV loads them) into any supported pixel
// format and back, with BT.601 video-range YUV. For tests and the clip generator.
#pragma once

#include <opencv2/core.hpp>

#include "uavstab/frame_buffer.hpp"

namespace uavstab::synthetic {

// bgr: CV_8UC3 of the frame's size. Odd sizes are fine (the last chroma sample covers
// the leftover row/column).
void bgrToFrame(const cv::Mat &bgr, FrameBuffer &frame);
// The frame's luma (or RGB luminance) as CV_8UC1.
cv::Mat frameLuma(const FrameView &frame);
// Back to packed BGR (for writing previews).
cv::Mat frameToBgr(const FrameView &frame);

} // namespace uavstab::synthetic
