#include "plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace bench {

namespace {

const cv::Scalar kWhite(255, 255, 255), kBlack(0, 0, 0), kGrid(225, 225, 225), kAxis(90, 90, 90);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

struct Frame {
    cv::Rect area;  // plotting area in the image
    double x0, x1, y0, y1;
    cv::Point map(double x, double y) const
    {
        const double fx = (x - x0) / (x1 - x0), fy = (y - y0) / (y1 - y0);
        return {area.x + int(std::lround(fx * area.width)), area.y + area.height - int(std::lround(fy * area.height))};
    }
};

// "Nice" tick step for a range, about `target` ticks.
double niceStep(double range, int target)
{
    if (!(range > 0))
        return 1.0;
    const double raw = range / target;
    const double mag = std::pow(10.0, std::floor(std::log10(raw)));
    const double f = raw / mag;
    const double nice = f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10;
    return nice * mag;
}

std::string tickLabel(double v, double step)
{
    char buf[64];
    const int decimals = step >= 1 ? 0 : int(std::ceil(-std::log10(step) - 1e-9));
    std::snprintf(buf, sizeof buf, "%.*f", std::min(decimals, 6), std::abs(v) < step * 1e-6 ? 0.0 : v);
    return buf;
}

void text(cv::Mat &img, const std::string &s, cv::Point at, double scale = 0.45, cv::Scalar color = kBlack,
          int thickness = 1)
{
    cv::putText(img, s, at, kFont, scale, color, thickness, cv::LINE_AA);
}

cv::Size textSize(const std::string &s, double scale = 0.45, int thickness = 1)
{
    int base = 0;
    return cv::getTextSize(s, kFont, scale, thickness, &base);
}

// Draws title, grid, ticks and labels; returns the frame mapping data to pixels.
Frame axes(cv::Mat &img, const std::string &title, const std::string &x_label, const std::string &y_label, double x0,
           double x1, double y0, double y1, int legend_rows, bool x_ticks = true)
{
    const int left = 80, right = 20, top = 38 + 20 * legend_rows, bottom = x_ticks ? 52 : 80;
    Frame f{cv::Rect(left, top, img.cols - left - right, img.rows - top - bottom), x0, x1, y0, y1};
    text(img, title, {left, 22}, 0.55, kBlack, 1);
    const double ys = niceStep(y1 - y0, 6);
    for (double v = std::ceil(y0 / ys) * ys; v <= y1 + 1e-9 * ys; v += ys) {
        const cv::Point p = f.map(x0, v);
        cv::line(img, {f.area.x, p.y}, {f.area.x + f.area.width, p.y}, kGrid, 1);
        const std::string l = tickLabel(v, ys);
        text(img, l, {f.area.x - 6 - textSize(l, 0.4).width, p.y + 4}, 0.4, kAxis);
    }
    if (x_ticks) {
        const double xs = niceStep(x1 - x0, 10);
        for (double v = std::ceil(x0 / xs) * xs; v <= x1 + 1e-9 * xs; v += xs) {
            const cv::Point p = f.map(v, y0);
            cv::line(img, {p.x, f.area.y}, {p.x, f.area.y + f.area.height}, kGrid, 1);
            const std::string l = tickLabel(v, xs);
            text(img, l, {p.x - textSize(l, 0.4).width / 2, f.area.y + f.area.height + 16}, 0.4, kAxis);
        }
        text(img, x_label, {f.area.x + f.area.width / 2 - textSize(x_label).width / 2, img.rows - 10}, 0.45, kAxis);
    }
    cv::rectangle(img, f.area, kAxis, 1);
    // Y label, written vertically: draw on a strip and rotate it.
    const cv::Size ts = textSize(y_label);
    cv::Mat strip(ts.height + 8, ts.width + 4, CV_8UC3, kWhite);
    text(strip, y_label, {2, ts.height + 2}, 0.45, kAxis);
    cv::Mat rotated;
    cv::rotate(strip, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int ry = std::max(0, f.area.y + f.area.height / 2 - rotated.rows / 2);
    if (ry + rotated.rows <= img.rows && rotated.cols + 4 <= left)
        rotated.copyTo(img(cv::Rect(4, ry, rotated.cols, rotated.rows)));
    return f;
}

int legendEntryWidth(const std::string &label)
{
    return 26 + textSize(label, 0.42).width + 18;
}

// Rows of legend entries needed between the title and the plot area.
int legendRows(const std::vector<std::string> &labels, int width)
{
    int rows = 1, x = 80;
    for (const auto &l : labels) {
        const int w = legendEntryWidth(l);
        if (x + w > width - 10 && x > 80) {
            ++rows;
            x = 80;
        }
        x += w;
    }
    return rows;
}

void legend(cv::Mat &img, const Frame &f, const std::vector<std::string> &labels, const std::vector<cv::Scalar> &colors,
            bool boxes)
{
    const int rows = legendRows(labels, img.cols);
    int x = f.area.x, y = f.area.y - 12 - 20 * (rows - 1);
    for (std::size_t i = 0; i < labels.size(); ++i) {
        const int w = legendEntryWidth(labels[i]);
        if (x + w > img.cols - 10 && x > f.area.x) {
            x = f.area.x;
            y += 20;
        }
        if (boxes)
            cv::rectangle(img, {x, y - 5}, {x + 20, y + 5}, colors[i], cv::FILLED);
        else
            cv::line(img, {x, y}, {x + 20, y}, colors[i], 2, cv::LINE_AA);
        text(img, labels[i], {x + 26, y + 5}, 0.42);
        x += w;
    }
}

} // namespace

cv::Scalar paletteColor(int i)
{
    static const cv::Scalar colors[] = {
        {60, 60, 60},     // dark grey
        {180, 119, 31},   // blue
        {14, 127, 255},   // orange
        {44, 160, 44},    // green
        {40, 39, 214},    // red
        {189, 103, 148},  // purple
        {75, 86, 140},    // brown
        {194, 119, 227},  // pink
        {34, 189, 188},   // olive
        {207, 190, 23},   // cyan
        {150, 150, 150},  // light grey
        {120, 200, 255},  // light orange
        {232, 199, 174},  // light blue
        {138, 223, 152},  // light green
        {150, 152, 255},  // light red
        {213, 176, 197},  // light purple
    };
    return colors[std::size_t(i) % (sizeof colors / sizeof colors[0])];
}

cv::Mat linePlot(const std::string &title, const std::string &x_label, const std::string &y_label,
                 const std::vector<Series> &series, cv::Size size)
{
    double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
    for (const Series &s : series)
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
            if (!std::isfinite(s.y[i]))
                continue;
            x0 = std::min(x0, s.x[i]);
            x1 = std::max(x1, s.x[i]);
            y0 = std::min(y0, s.y[i]);
            y1 = std::max(y1, s.y[i]);
        }
    if (!std::isfinite(x0)) {
        x0 = 0;
        x1 = 1;
        y0 = 0;
        y1 = 1;
    }
    if (y1 - y0 < 1e-12) {
        y0 -= 1;
        y1 += 1;
    }
    const double my = 0.06 * (y1 - y0);
    y0 -= my;
    y1 += my;
    if (x1 <= x0)
        x1 = x0 + 1;
    cv::Mat img(size, CV_8UC3, kWhite);
    std::vector<std::string> labels;
    std::vector<cv::Scalar> colors;
    for (const Series &s : series)
        labels.push_back(s.label);
    const Frame f = axes(img, title, x_label, y_label, x0, x1, y0, y1, legendRows(labels, img.cols));
    labels.clear();
    for (const Series &s : series) {
        std::vector<cv::Point> pts;
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
            if (std::isfinite(s.y[i]))
                pts.push_back(f.map(s.x[i], s.y[i]));
        if (pts.size() >= 2)
            cv::polylines(img, pts, false, s.color, s.thickness, cv::LINE_AA);
        labels.push_back(s.label);
        colors.push_back(s.color);
    }
    legend(img, f, labels, colors, false);
    return img;
}

cv::Mat barChart(const std::string &title, const std::string &y_label, const std::vector<std::string> &categories,
                 const std::vector<std::string> &series_labels, const std::vector<std::vector<double>> &values,
                 const std::vector<cv::Scalar> &colors, cv::Size size)
{
    double y1 = 0;
    for (const auto &s : values)
        for (double v : s)
            if (std::isfinite(v))
                y1 = std::max(y1, v);
    y1 = y1 > 0 ? y1 * 1.08 : 1.0;  // room for the value labels
    cv::Mat img(size, CV_8UC3, kWhite);
    const double n = double(std::max<std::size_t>(1, categories.size()));
    Frame f = axes(img, title, "", y_label, 0, n, 0, y1, legendRows(series_labels, img.cols), false);
    const std::size_t ns = std::max<std::size_t>(1, series_labels.size());
    for (std::size_t c = 0; c < categories.size(); ++c) {
        const double group = 0.8, bar = group / double(ns);
        for (std::size_t s = 0; s < ns && s < values.size(); ++s) {
            if (c >= values[s].size() || !std::isfinite(values[s][c]))
                continue;
            const double xa = double(c) + 0.1 + bar * double(s), xb = xa + bar * 0.9;
            const cv::Point a = f.map(xa, 0), b = f.map(xb, values[s][c]);
            cv::rectangle(img, {a.x, b.y}, {b.x, a.y}, colors[s % colors.size()], cv::FILLED);
            char buf[32];
            std::snprintf(buf, sizeof buf, values[s][c] < 10 ? "%.2f" : "%.1f", values[s][c]);
            const cv::Size ts = textSize(buf, 0.32);
            if (ts.width <= b.x - a.x + 14)
                text(img, buf, {(a.x + b.x) / 2 - ts.width / 2, b.y - 3}, 0.32, kAxis);
        }
        // Category label, up to two lines split at " / ".
        const std::string &label = categories[c];
        const std::size_t cut = label.find(" / ");
        const std::vector<std::string> lines =
            cut == std::string::npos ? std::vector<std::string>{label}
                                     : std::vector<std::string>{label.substr(0, cut), label.substr(cut + 3)};
        const int cx = f.map(double(c) + 0.5, 0).x;
        for (std::size_t l = 0; l < lines.size(); ++l)
            text(img, lines[l], {cx - textSize(lines[l], 0.42).width / 2, f.area.y + f.area.height + 18 + 17 * int(l)},
                 0.42, kAxis);
    }
    legend(img, f, series_labels, colors, true);
    return img;
}

cv::Mat stackVertically(const std::vector<cv::Mat> &images)
{
    int width = 0, height = 0;
    for (const cv::Mat &m : images) {
        width = std::max(width, m.cols);
        height += m.rows;
    }
    cv::Mat out(std::max(height, 1), std::max(width, 1), CV_8UC3, kWhite);
    int y = 0;
    for (const cv::Mat &m : images) {
        m.copyTo(out(cv::Rect(0, y, m.cols, m.rows)));
        y += m.rows;
    }
    return out;
}

bool writePng(const std::string &path, const cv::Mat &image)
{
    return cv::imwrite(path, image, {cv::IMWRITE_PNG_COMPRESSION, 9});
}

} // namespace bench
