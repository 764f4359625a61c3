#include "luma_extractor.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace uavstab {

cv::Mat planeMat(const FrameView &frame, int plane)
{
    // (16-bit: the stride must be even, as cv::Mat requires; see LumaExtractor::extract16.)
    const PlaneLayout layout = planeLayout(frame.format, plane);
    const int depth = layout.bytes_per_sample == 2 ? CV_16U : CV_8U;
    return cv::Mat(frame.planeHeight(plane), frame.planeWidth(plane), CV_MAKETYPE(depth, layout.channels),
                   frame.planes[plane].data, std::size_t(frame.planes[plane].stride));
}

bool needsByteSwap(PixelFormat format)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    return format == PixelFormat::Gray16LE;
#else
    return format == PixelFormat::Gray16BE;
#endif
}

AutoGain::Limits AutoGain::update(const cv::Mat &image)
{
    CV_Assert(image.type() == CV_16UC1 && !image.empty());
    // A regular grid of about kSampleTarget pixels (every pixel of a small image).
    const double area = double(image.rows) * image.cols;
    const int step = std::max(1, int(std::floor(std::sqrt(area / kSampleTarget))));
    samples_.clear();
    // (Starting inside the image even when it is thinner than a step.)
    for (int y = std::min(step / 2, image.rows - 1); y < image.rows; y += step) {
        const std::uint16_t *row = image.ptr<std::uint16_t>(y);
        for (int x = std::min(step / 2, image.cols - 1); x < image.cols; x += step)
            samples_.push_back(row[x]);
    }
    const std::size_t n = samples_.size();
    const auto rank = [n](double q) { return std::min(n - 1, std::size_t(std::lround(q * double(n - 1)))); };
    const std::size_t low_rank = rank(kLowPercentile), high_rank = rank(kHighPercentile);
    std::nth_element(samples_.begin(), samples_.begin() + std::ptrdiff_t(high_rank), samples_.end());
    const double high = samples_[high_rank];
    std::nth_element(samples_.begin(), samples_.begin() + std::ptrdiff_t(low_rank),
                     samples_.begin() + std::ptrdiff_t(high_rank));
    const double low = samples_[low_rank];
    measurement_.percentiles = {low, high};

    const auto withMinSpan = [](Limits l) {
        if (l.high - l.low < kMinSpan) {
            const double centre = 0.5 * (l.low + l.high);
            l = {centre - 0.5 * kMinSpan, centre + 0.5 * kMinSpan};
        }
        return l;
    };
    if (!initialized_) {
        limits_ = withMinSpan(measurement_.percentiles);
        measurement_.clipped_share = 0.0;
        initialized_ = true;
        return limits_;
    }

    std::size_t clipped = 0;
    for (const std::uint16_t v : samples_)
        clipped += v < limits_.low || v > limits_.high;
    measurement_.clipped_share = double(clipped) / double(n);

    const double span = limits_.high - limits_.low;
    const bool lost = measurement_.clipped_share > kLostShare;
    const auto follow = [&](double current, double measured) {
        const double error = measured - current;
        if (lost)
            return current + kFastFollow * error;
        if (std::abs(error) <= kDeadBand * span)
            return current;  // hysteresis: the same mapping as the previous frame
        const double limit = kMaxRate * span;
        return current + std::clamp(kFollow * error, -limit, limit);
    };
    limits_ = withMinSpan({follow(limits_.low, low), follow(limits_.high, high)});
    return limits_;
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

const cv::Mat &LumaExtractor::extract16(const FrameView &frame, cv::Size size)
{
    const Plane &plane = frame.planes[0];
    const bool swap = needsByteSwap(frame.format);
    const bool aligned =
        plane.stride % 2 == 0 && reinterpret_cast<std::uintptr_t>(plane.data) % alignof(std::uint16_t) == 0;
    cv::Mat samples;
    if (swap || !aligned) {
        // Samples in the other byte order, or not at 16-bit boundaries (an odd stride):
        // copied once, in host order, to an aligned image.
        swapped_.create(frame.height, frame.width, CV_16UC1);
        for (int y = 0; y < frame.height; ++y) {
            const std::uint8_t *in = plane.data + std::size_t(y) * std::size_t(plane.stride);
            std::uint16_t *out = swapped_.ptr<std::uint16_t>(y);
            std::memcpy(out, in, std::size_t(frame.width) * 2);
            if (swap)
                for (int x = 0; x < frame.width; ++x)
                    out[x] = std::uint16_t((out[x] >> 8) | (out[x] << 8));
        }
        samples = swapped_;
    } else {
        samples = planeMat(frame, 0);
    }
    if (samples.size() != size) {
        downscale(samples, luma16_, size);
        samples = luma16_;
    }
    // The gain is measured and moved on this frame, then maps it to 8 bits (rounded,
    // saturated at both ends).
    const AutoGain::Limits limits = gain_.update(samples);
    const double gain = 255.0 / (limits.high - limits.low);
    samples.convertTo(luma_, CV_8U, gain, -limits.low * gain);
    return luma_;
}

const cv::Mat &LumaExtractor::extract(const FrameView &frame, int analysis_width)
{
    if (!frame.valid())
        throw std::invalid_argument("LumaExtractor: invalid frame");
    const cv::Size size = analysisSize(frame.width, frame.height, analysis_width);
    if (is16Bit(frame.format))
        return extract16(frame, size);
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
