#include "render/debug_overlay.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace uavstab {

namespace {

const OverlayColor kInlier{0, 255, 0, 255};
const OverlayColor kRejected{255, 0, 0, 0};
const OverlayColor kExcluded{255, 255, 0, 255};
const OverlayColor kFrameEdge{0, 128, 255, 0};
constexpr int kPointRadius = 3;

std::uint8_t clampByte(double v)
{
    return std::uint8_t(std::clamp(std::lround(v), 0L, 255L));
}

// BT.601 video range, as the rest of the project converts.
void toYuv(const OverlayColor &c, std::uint8_t &y, std::uint8_t &u, std::uint8_t &v)
{
    const double r = c.r, g = c.g, b = c.b;
    y = clampByte(16.0 + (65.481 * r + 128.553 * g + 24.966 * b) / 255.0);
    u = clampByte(128.0 + (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0);
    v = clampByte(128.0 + (112.0 * r - 93.786 * g - 18.214 * b) / 255.0);
}

} // namespace

void putOverlayPixel(const FrameView &f, int x, int y, const OverlayColor &c)
{
    if (x < 0 || y < 0 || x >= f.width || y >= f.height)
        return;
    auto at = [&](int plane, int, int py) {
        return f.planes[std::size_t(plane)].data + std::ptrdiff_t(py) * f.planes[std::size_t(plane)].stride;
    };
    switch (f.format) {
    case PixelFormat::Gray8:
        at(0, x, y)[x] = c.gray;
        return;
    case PixelFormat::Gray16LE:
    case PixelFormat::Gray16BE: {
        std::uint8_t *p = at(0, x, y) + 2 * x;
        p[0] = p[1] = c.gray;  // gray * 257: the same byte in either order
        return;
    }
    case PixelFormat::I420:
    case PixelFormat::YV12:
    case PixelFormat::NV12:
    case PixelFormat::NV21: {
        std::uint8_t yy, u, v;
        toYuv(c, yy, u, v);
        at(0, x, y)[x] = yy;
        const int cx = x / 2, cy = y / 2;
        if (f.format == PixelFormat::I420 || f.format == PixelFormat::YV12) {
            const int up = f.format == PixelFormat::I420 ? 1 : 2, vp = 3 - up;
            at(up, cx, cy)[cx] = u;
            at(vp, cx, cy)[cx] = v;
        } else {
            std::uint8_t *p = at(1, cx, cy) + 2 * cx;
            p[0] = f.format == PixelFormat::NV12 ? u : v;
            p[1] = f.format == PixelFormat::NV12 ? v : u;
        }
        return;
    }
    default: {
        const RgbOrder order = rgbOrder(f.format);
        const int channels = planeLayout(f.format, 0).channels;
        std::uint8_t *p = at(0, x, y) + channels * x;
        p[order.r] = c.r;
        p[order.g] = c.g;
        p[order.b] = c.b;
        return;
    }
    }
}

void drawOverlayLine(const FrameView &f, double x0, double y0, double x1, double y1, const OverlayColor &c)
{
    if (!std::isfinite(x0) || !std::isfinite(y0) || !std::isfinite(x1) || !std::isfinite(y1))
        return;
    // Clip in integer pixels first (the ends may lie far outside the frame).
    const double far = 4.0 * (f.width + f.height) + 16.0;
    cv::Point a(int(std::lround(std::clamp(x0, -far, far))), int(std::lround(std::clamp(y0, -far, far))));
    cv::Point b(int(std::lround(std::clamp(x1, -far, far))), int(std::lround(std::clamp(y1, -far, far))));
    if (!cv::clipLine(cv::Size(f.width, f.height), a, b))
        return;
    const int steps = std::max(std::abs(b.x - a.x), std::abs(b.y - a.y));
    for (int k = 0; k <= steps; ++k) {
        const double t = steps ? double(k) / steps : 0.0;
        putOverlayPixel(f, int(std::lround(a.x + t * (b.x - a.x))), int(std::lround(a.y + t * (b.y - a.y))), c);
    }
}

void drawDebugOverlay(const FrameView &output, const FrameStats &stats, const std::vector<RectF> &exclude)
{
    if (!output.valid())
        return;
    const int w = output.width, h = output.height;
    const double cx = (w - 1) * 0.5, cy = (h - 1) * 0.5;
    const Similarity input_to_output = stats.output_to_input.inverse();
    // Input pixel (pixel-centre coordinates) -> output pixel.
    auto map = [&](double x, double y) {
        const Point2 q = input_to_output.apply({x - cx, y - cy});
        return cv::Point2d(q.x + cx, q.y + cy);
    };
    // A quadrilateral of input pixel coordinates, in the output.
    auto outline = [&](double x0, double y0, double x1, double y1, const OverlayColor &c) {
        const cv::Point2d p[4] = {map(x0, y0), map(x1, y0), map(x1, y1), map(x0, y1)};
        for (int k = 0; k < 4; ++k)
            drawOverlayLine(output, p[k].x, p[k].y, p[(k + 1) % 4].x, p[(k + 1) % 4].y, c);
    };

    outline(-0.5, -0.5, w - 0.5, h - 0.5, kFrameEdge);
    for (const RectF &r : exclude)
        outline(r.x * w - 0.5, r.y * h - 0.5, (r.x + r.w) * w - 0.5, (r.y + r.h) * h - 0.5, kExcluded);
    for (const TrackedPoint &t : stats.tracks) {
        const cv::Point2d p = map(t.position.x + cx, t.position.y + cy);
        if (!std::isfinite(p.x) || !std::isfinite(p.y))
            continue;
        const int px = int(std::lround(p.x)), py = int(std::lround(p.y));
        const OverlayColor &c = t.inlier ? kInlier : kRejected;
        for (int d = -kPointRadius; d <= kPointRadius; ++d) {  // a small square
            putOverlayPixel(output, px + d, py - kPointRadius, c);
            putOverlayPixel(output, px + d, py + kPointRadius, c);
            putOverlayPixel(output, px - kPointRadius, py + d, c);
            putOverlayPixel(output, px + kPointRadius, py + d, c);
        }
    }
}

} // namespace uavstab
