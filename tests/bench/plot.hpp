// Small chart drawing with OpenCV (lines, bars, axes, ticks, legend) for the report's PNGs,
// so that the benchmark needs no plotting package.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace bench {

struct Series {
    std::string label;
    std::vector<double> x, y;
    cv::Scalar color;
    int thickness = 1;
};

// A line chart; x/y ranges from the data (with a margin), nice ticks.
cv::Mat linePlot(const std::string &title, const std::string &x_label, const std::string &y_label,
                 const std::vector<Series> &series, cv::Size size = {1200, 360});

// Grouped bars: values[s][c] for series s in category c (NaN = no bar).
cv::Mat barChart(const std::string &title, const std::string &y_label, const std::vector<std::string> &categories,
                 const std::vector<std::string> &series_labels, const std::vector<std::vector<double>> &values,
                 const std::vector<cv::Scalar> &colors, cv::Size size = {1200, 480});

// Stacks images vertically (widths padded to the widest, white).
cv::Mat stackVertically(const std::vector<cv::Mat> &images);

// A distinct colour per index (BGR).
cv::Scalar paletteColor(int i);

bool writePng(const std::string &path, const cv::Mat &image);

} // namespace bench
