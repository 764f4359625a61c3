#include "thermal.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>

namespace uavstab::synthetic {

namespace {

bool storedBigEndian(PixelFormat format)
{
    if (!is16Bit(format))
        throw std::invalid_argument("not a 16-bit format");
    return isBigEndian(format);
}

} // namespace

std::uint16_t sample16(const FrameView &frame, int x, int y)
{
    const std::uint8_t *p = frame.planes[0].data + std::size_t(y) * frame.planes[0].stride + 2 * std::size_t(x);
    return storedBigEndian(frame.format) ? std::uint16_t(p[0] << 8 | p[1]) : std::uint16_t(p[1] << 8 | p[0]);
}

void setSample16(const FrameView &frame, int x, int y, std::uint16_t value)
{
    std::uint8_t *p = frame.planes[0].data + std::size_t(y) * frame.planes[0].stride + 2 * std::size_t(x);
    const std::uint8_t hi = std::uint8_t(value >> 8), lo = std::uint8_t(value & 0xff);
    if (storedBigEndian(frame.format)) {
        p[0] = hi;
        p[1] = lo;
    } else {
        p[0] = lo;
        p[1] = hi;
    }
}

void fill16(FrameBuffer &frame, std::uint16_t value)
{
    for (int y = 0; y < frame.height(); ++y)
        for (int x = 0; x < frame.width(); ++x)
            setSample16(frame.view(), x, y, value);
}

FrameBuffer thermalFrame(const cv::Mat &grey, const Similarity &world_from_frame, int index,
                         const ThermalOptions &options)
{
    if (grey.type() != CV_32FC1)
        throw std::invalid_argument("thermalFrame: need CV_32FC1");
    const int w = grey.cols, h = grey.rows;
    cv::Mat counts(h, w, CV_64FC1);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            counts.at<double>(y, x) = options.base + options.span * grey.at<float>(y, x) / 255.0;

    const Similarity frame_from_world = world_from_frame.inverse();
    const double cx = (w - 1) * 0.5, cy = (h - 1) * 0.5;
    for (const HotSpot &spot : options.hot_spots) {
        if (index < spot.appear || index >= spot.vanish)
            continue;
        const double t = index - spot.appear;
        const Point2 c = frame_from_world.apply({spot.world.x + spot.velocity.x * t, spot.world.y + spot.velocity.y * t});
        const double r = spot.radius * frame_from_world.scale;
        const double px = c.x + cx, py = c.y + cy;
        for (int y = std::max(0, int(std::floor(py - r - 1))); y <= std::min(h - 1, int(std::ceil(py + r + 1))); ++y)
            for (int x = std::max(0, int(std::floor(px - r - 1))); x <= std::min(w - 1, int(std::ceil(px + r + 1)));
                 ++x) {
                // Coverage of the pixel by the disc, linear over its last pixel (anti-aliased edge).
                const double d = std::hypot(x - px, y - py);
                const double cover = std::clamp(r + 0.5 - d, 0.0, 1.0);
                double &v = counts.at<double>(y, x);
                v += (spot.value - v) * cover;
            }
    }

    std::mt19937 rng(options.seed * 7919u + std::uint32_t(index));
    std::normal_distribution<double> noise(0.0, options.noise);
    FrameBuffer frame(options.format, w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double v = counts.at<double>(y, x) + (options.noise > 0 ? noise(rng) : 0.0);
            setSample16(frame.view(), x, y, std::uint16_t(std::clamp(std::lround(v), 0L, 65535L)));
        }
    return frame;
}

FrameBuffer renderThermal(const ShakyFlight &flight, int i, const ThermalOptions &options)
{
    const cv::Mat bgr = flight.renderBgr(i);
    cv::Mat grey(bgr.size(), CV_32FC1);
    for (int y = 0; y < bgr.rows; ++y)
        for (int x = 0; x < bgr.cols; ++x) {
            const cv::Vec3b &p = bgr.at<cv::Vec3b>(y, x);
            grey.at<float>(y, x) = float(0.299 * p[2] + 0.587 * p[1] + 0.114 * p[0]);
        }
    return thermalFrame(grey, flight.truePose(i), i, options);
}

std::pair<std::uint16_t, std::uint16_t> sampleRange(const FrameView &frame)
{
    std::uint16_t lo = 65535, hi = 0;
    for (int y = 0; y < frame.height; ++y)
        for (int x = 0; x < frame.width; ++x) {
            const std::uint16_t v = sample16(frame, x, y);
            lo = std::min(lo, v);
            hi = std::max(hi, v);
        }
    return {lo, hi};
}

} // namespace uavstab::synthetic
