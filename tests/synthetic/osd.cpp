#include "osd.hpp"

#include <cstdio>
#include <string>

#include <opencv2/imgproc.hpp>

namespace uavstab::synthetic {

cv::Mat hazy(const cv::Mat &bgr, double contrast, double blur)
{
    cv::Mat out;
    cv::GaussianBlur(bgr, out, cv::Size(0, 0), blur);
    out.convertTo(out, -1, contrast, 128.0 * (1.0 - contrast));
    return out;
}

namespace {

// White with a black outline, as OSDs draw so that they read on any background.
void outlinedLine(cv::Mat &img, cv::Point a, cv::Point b)
{
    cv::line(img, a, b, cv::Scalar(0, 0, 0), 4);
    cv::line(img, a, b, cv::Scalar(255, 255, 255), 2);
}

void outlinedText(cv::Mat &img, const std::string &text, cv::Point at, double scale)
{
    cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 4);
    cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255), 1);
}

void draw640x360(cv::Mat &img, int frame, const OsdStyle &style)
{
    const int w = img.cols, h = img.rows, cx = w / 2, cy = h / 2;
    char text[128];
    std::snprintf(text, sizeof text, "2026-12-01 12:34:%02d.%02d  REC", 10 + frame / 30, (frame % 30) * 3);
    outlinedText(img, text, {12, 24}, 0.6);
    outlinedText(img, "GPS 14  BAT 87%  LINK -62dBm", {w - 300, 24}, 0.5);
    cv::rectangle(img, cv::Rect(0, h - 30, w, 30), cv::Scalar(0, 0, 0), cv::FILLED);
    outlinedText(img, "N 47.3977  E 8.5456  HDG 271  MODE POS", {12, h - 10}, 0.5);
    for (int side = 0; side < 2; ++side) {  // speed (left) and altitude (right) boxes
        const int x = side == 0 ? 30 : w - 100;
        cv::rectangle(img, cv::Rect(x, cy - 14, 70, 28), cv::Scalar(255, 255, 255), 2);
        std::snprintf(text, sizeof text, side == 0 ? "%4.1f" : "%4.0fm", side == 0 ? 12.3 : 120.0);
        outlinedText(img, text, {x + 8, cy + 7}, 0.55);
        for (int t = -3; t <= 3; ++t)  // tape ticks
            outlinedLine(img, {side == 0 ? x + 74 : x - 12, cy + 30 * t}, {side == 0 ? x + 84 : x - 2, cy + 30 * t});
    }
    // Crosshair.
    outlinedLine(img, {cx - 40, cy}, {cx - 8, cy});
    outlinedLine(img, {cx + 8, cy}, {cx + 40, cy});
    outlinedLine(img, {cx, cy - 30}, {cx, cy - 8});
    outlinedLine(img, {cx, cy + 8}, {cx, cy + 30});
    cv::circle(img, {cx, cy}, 3, cv::Scalar(255, 255, 255), cv::FILLED);
    // Pitch ladder: rungs every 45 px with their degrees, dashed below the horizon.
    for (int k = -2; k <= 2; ++k) {
        if (k == 0)
            continue;
        const int y = cy + 45 * k;
        for (int s = -1; s <= 1; s += 2) {
            const int x0 = cx + s * 55, x1 = cx + s * 110;
            if (k < 0) {
                outlinedLine(img, {x0, y}, {x1, y});
            } else {
                outlinedLine(img, {x0, y}, {(x0 + x1) / 2 - s * 4, y});
                outlinedLine(img, {(x0 + x1) / 2 + s * 4, y}, {x1, y});
            }
            outlinedLine(img, {x1, y}, {x1, y + (k < 0 ? 8 : -8)});
        }
        std::snprintf(text, sizeof text, "%d", -10 * k);
        outlinedText(img, text, {cx + 118, y + 5}, 0.45);
        outlinedText(img, text, {cx - 145, y + 5}, 0.45);
    }
    if (style.full) {
        // Heading tape: ticks every 20 px with a label every 100, and its pointer.
        const int y = 44;
        outlinedLine(img, {120, y}, {w - 120, y});
        for (int x = 120; x <= w - 120; x += 20)
            outlinedLine(img, {x, y}, {x, y - ((x - 120) % 100 == 0 ? 9 : 5)});
        for (int x = 120, hdg = 250; x <= w - 120; x += 100, hdg += 10) {
            std::snprintf(text, sizeof text, "%03d", hdg);
            outlinedText(img, text, {x - 12, y + 16}, 0.4);
        }
        outlinedLine(img, {cx - 6, y + 20}, {cx, y + 12});
        outlinedLine(img, {cx + 6, y + 20}, {cx, y + 12});
        // Frame border with corner brackets.
        cv::rectangle(img, cv::Rect(4, 4, w - 8, h - 38), cv::Scalar(255, 255, 255), 1);
        for (int c = 0; c < 4; ++c) {
            const int x = c % 2 ? w - 12 : 12, yy = c / 2 ? h - 42 : 12, sx = c % 2 ? -1 : 1, sy = c / 2 ? -1 : 1;
            outlinedLine(img, {x, yy}, {x + 24 * sx, yy});
            outlinedLine(img, {x, yy}, {x, yy + 24 * sy});
        }
    }
}

} // namespace

void burnOsd(cv::Mat &bgr, int frame, const OsdStyle &style)
{
    if (bgr.cols == 640 && bgr.rows == 360) {
        draw640x360(bgr, frame, style);
        return;
    }
    // Drawn at 640x360 over the frame scaled down, then put back at the frame's size where
    // the OSD drew: the strokes scale with the frame, the scene keeps its resolution.
    cv::Mat small, osd(360, 640, CV_8UC3, cv::Scalar(0, 0, 255)), mask;
    cv::resize(bgr, small, {640, 360}, 0, 0, cv::INTER_AREA);
    draw640x360(small, frame, style);
    cv::Mat drawn = small.clone();
    cv::Mat before;
    cv::resize(bgr, before, {640, 360}, 0, 0, cv::INTER_AREA);
    cv::Mat diff;
    cv::absdiff(drawn, before, diff);
    cv::cvtColor(diff, mask, cv::COLOR_BGR2GRAY);
    mask = mask > 0;
    cv::Mat big_drawn, big_mask;
    cv::resize(drawn, big_drawn, bgr.size(), 0, 0, cv::INTER_LINEAR);
    cv::resize(mask, big_mask, bgr.size(), 0, 0, cv::INTER_NEAREST);
    big_drawn.copyTo(bgr, big_mask);
}

} // namespace uavstab::synthetic
