#include "luma_extractor.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace uavstab {

cv::Mat planeMat(const FrameView &frame, int plane)
{
    const int channels = planeLayout(frame.format, plane).channels;
    return cv::Mat(frame.planeHeight(plane), frame.planeWidth(plane), CV_8UC(channels),
                   frame.planes[plane].data, std::size_t(frame.planes[plane].stride));
}

void LumaExtractor::downscale(const cv::Mat &src, cv::Mat &dst, cv::Size size)
{
    // OpenCV's area resampling is fast for an exact halving and slow for other factors
    // (1080p -> 640: 0.84 ms, against 0.06 ms for 1920 -> 960). So halve while the
    // result stays at least the target size, then bilinear for the last factor (< 2,
    // where bilinear still reads every source pixel).
    const cv::Mat *level = &src;
    std::size_t k = 0;
    while (level->cols / 2 >= size.width && level->rows / 2 >= size.height) {
        if (halvings_.size() <= k)
            halvings_.emplace_back();
        cv::resize(*level, halvings_[k], cv::Size(level->cols / 2, level->rows / 2), 0, 0, cv::INTER_AREA);
        level = &halvings_[k++];
    }
    if (level->size() == size)
        level->copyTo(dst);
    else
        cv::resize(*level, dst, size, 0, 0, cv::INTER_LINEAR);
}

cv::Size LumaExtractor::analysisSize(int width, int height, int analysis_width)
{
    const int w = std::min(width, std::max(analysis_width, 1));
    const int h = std::max(1, int(std::lround(double(height) * w / width)));
    return {w, w == width ? height : h};
}

const cv::Mat &LumaExtractor::extract(const FrameView &frame, int analysis_width)
{
    if (!frame.valid())
        throw std::invalid_argument("LumaExtractor: invalid frame");
    const cv::Size size = analysisSize(frame.width, frame.height, analysis_width);
    const bool resample = size.width != frame.width || size.height != frame.height;
    const cv::Mat packed = planeMat(frame, 0);

    if (isYuv(frame.format) || frame.format == PixelFormat::Gray8) {
        if (!resample) {
            view_ = packed;  // the Y plane itself; the caller copies what it keeps
            return view_;
        }
        downscale(packed, luma_, size);
        return luma_;
    }

    // Packed RGB: shrink first (fewer pixels to convert), then convert once.
    const RgbOrder order = rgbOrder(frame.format);
    const bool bgr = order.b == 0;
    const int channels = planeLayout(frame.format, 0).channels;
    const int code = channels == 3 ? (bgr ? cv::COLOR_BGR2GRAY : cv::COLOR_RGB2GRAY)
                                   : (bgr ? cv::COLOR_BGRA2GRAY : cv::COLOR_RGBA2GRAY);
    if (resample) {
        downscale(packed, packed_small_, size);
        cv::cvtColor(packed_small_, luma_, code);
    } else {
        cv::cvtColor(packed, luma_, code);
    }
    return luma_;
}

} // namespace uavstab
