#include "format_conversion.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace uavstab::synthetic {

namespace {

std::uint8_t clip(double v)
{
    return std::uint8_t(std::clamp(std::lround(v), 0L, 255L));
}

struct Yuv {
    double y, u, v;
};

Yuv toYuv(const cv::Vec3b &bgr)
{
    const double b = bgr[0], g = bgr[1], r = bgr[2];
    return {16.0 + (65.481 * r + 128.553 * g + 24.966 * b) / 255.0,
            128.0 + (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0,
            128.0 + (112.0 * r - 93.786 * g - 18.214 * b) / 255.0};
}

cv::Vec3b toBgr(double y, double u, double v)
{
    const double c = (y - 16.0) * 255.0 / 219.0, d = u - 128.0, e = v - 128.0;
    return {clip(c + 2.018 * d), clip(c - 0.391 * d - 0.813 * e), clip(c + 1.596 * e)};
}

} // namespace

void bgrToFrame(const cv::Mat &bgr, FrameBuffer &frame)
{
    if (bgr.type() != CV_8UC3 || bgr.cols != frame.width() || bgr.rows != frame.height())
        throw std::invalid_argument("bgrToFrame: need CV_8UC3 of the frame's size");
    const PixelFormat format = frame.format();
    if (is16Bit(format))
        throw std::invalid_argument("bgrToFrame: 16-bit frames are rendered by thermal.hpp");
    const int w = frame.width(), h = frame.height();

    if (format == PixelFormat::Gray8 || isYuv(format)) {
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                frame.row(0, y)[x] = clip(toYuv(bgr.at<cv::Vec3b>(y, x)).y);
        if (format == PixelFormat::Gray8)
            return;
        const FrameView &v = frame.view();
        for (int cy = 0; cy < v.planeHeight(1); ++cy)
            for (int cx = 0; cx < v.planeWidth(1); ++cx) {
                double u = 0, vv = 0;
                int n = 0;
                for (int dy = 0; dy < 2; ++dy)
                    for (int dx = 0; dx < 2; ++dx) {
                        const int x = std::min(2 * cx + dx, w - 1), y = std::min(2 * cy + dy, h - 1);
                        const Yuv c = toYuv(bgr.at<cv::Vec3b>(y, x));
                        u += c.u;
                        vv += c.v;
                        ++n;
                    }
                const std::uint8_t U = clip(u / n), V = clip(vv / n);
                switch (format) {
                case PixelFormat::I420:
                    frame.row(1, cy)[cx] = U;
                    frame.row(2, cy)[cx] = V;
                    break;
                case PixelFormat::YV12:
                    frame.row(1, cy)[cx] = V;
                    frame.row(2, cy)[cx] = U;
                    break;
                case PixelFormat::NV12:
                    frame.row(1, cy)[2 * cx] = U;
                    frame.row(1, cy)[2 * cx + 1] = V;
                    break;
                default:  // NV21
                    frame.row(1, cy)[2 * cx] = V;
                    frame.row(1, cy)[2 * cx + 1] = U;
                    break;
                }
            }
        return;
    }

    const RgbOrder order = rgbOrder(format);
    const int channels = planeLayout(format, 0).channels;
    for (int y = 0; y < h; ++y) {
        std::uint8_t *row = frame.row(0, y);
        for (int x = 0; x < w; ++x) {
            const cv::Vec3b &p = bgr.at<cv::Vec3b>(y, x);
            std::uint8_t *px = row + x * channels;
            px[order.r] = p[2];
            px[order.g] = p[1];
            px[order.b] = p[0];
            if (channels == 4)
                px[3] = 255;
        }
    }
}

cv::Mat frameLuma(const FrameView &frame)
{
    if (is16Bit(frame.format))
        throw std::invalid_argument("frameLuma: not for 16-bit frames");
    const int channels = planeLayout(frame.format, 0).channels;
    cv::Mat plane(frame.height, frame.width, CV_8UC(channels), frame.planes[0].data, std::size_t(frame.planes[0].stride));
    if (channels == 1)
        return plane.clone();
    const bool bgr = rgbOrder(frame.format).b == 0;
    cv::Mat gray;
    cv::cvtColor(plane, gray, channels == 3 ? (bgr ? cv::COLOR_BGR2GRAY : cv::COLOR_RGB2GRAY)
                                            : (bgr ? cv::COLOR_BGRA2GRAY : cv::COLOR_RGBA2GRAY));
    return gray;
}

cv::Mat frameToBgr(const FrameView &frame)
{
    if (is16Bit(frame.format))
        throw std::invalid_argument("frameToBgr: not for 16-bit frames");
    cv::Mat out(frame.height, frame.width, CV_8UC3);
    const auto at = [&](int plane, int x, int y) {
        return frame.planes[plane].data[std::size_t(y) * frame.planes[plane].stride + x];
    };
    for (int y = 0; y < frame.height; ++y)
        for (int x = 0; x < frame.width; ++x) {
            cv::Vec3b &o = out.at<cv::Vec3b>(y, x);
            switch (frame.format) {
            case PixelFormat::Gray8: {
                const std::uint8_t g = at(0, x, y);
                o = {g, g, g};
                break;
            }
            case PixelFormat::I420:
                o = toBgr(at(0, x, y), at(1, x / 2, y / 2), at(2, x / 2, y / 2));
                break;
            case PixelFormat::YV12:
                o = toBgr(at(0, x, y), at(2, x / 2, y / 2), at(1, x / 2, y / 2));
                break;
            case PixelFormat::NV12:
                o = toBgr(at(0, x, y), at(1, x / 2 * 2, y / 2), at(1, x / 2 * 2 + 1, y / 2));
                break;
            case PixelFormat::NV21:
                o = toBgr(at(0, x, y), at(1, x / 2 * 2 + 1, y / 2), at(1, x / 2 * 2, y / 2));
                break;
            default: {
                const RgbOrder order = rgbOrder(frame.format);
                const int ch = planeLayout(frame.format, 0).channels;
                o = {at(0, x * ch + order.b, y), at(0, x * ch + order.g, y), at(0, x * ch + order.r, y)};
                break;
            }
            }
        }
    return out;
}

} // namespace uavstab::synthetic
