#include "estimate/corner_detector.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <opencv2/imgproc.hpp>

namespace uavstab {

// Why the strips give the same bits as one call on the whole image:
// - the derivatives (Sobel) of a strip that is a region of the image read the pixels
//   around it, as on the whole image, and each is a fixed sum of its neighbours;
// - boxFilter sums the products over 3 columns, pixel by pixel, then down each column with
//   a running sum from the top row. Rounding makes a running sum depend on where it
//   started (rows in bands of their own differ in the last bit), but a strip keeps every
//   row, so each column is summed as on the whole image. A strip computes 4 columns more
//   on each side than it keeps (boxFilter reflects at a strip's own edges), so the
//   columns next to the kept ones are exact too;
// - the eigenvalue step treats a strip as one long row, vector lanes first and the last
//   (pixels % lanes) in scalar code, which may round differently where the vector code
//   fuses a multiply-add (NEON). Strips but the last are a multiple of 4 columns wide, so
//   they have no such tail, and the last starts a multiple of 8 columns before the
//   image's end, so its tail is the image's.
void forEachEigenvalueStrip(const cv::Mat &image, int strip_columns, const EigenvalueStripVisitor &visit)
{
    CV_Assert(image.type() == CV_8UC1 && strip_columns > 0 && strip_columns % 8 == 0);
    const int columns = image.cols;
    cv::Mat strip_eig;
    if (columns <= 2 * strip_columns) {
        cv::cornerMinEigenVal(image, strip_eig, 3, 3);
        visit(strip_eig, 0, 0, columns);
        return;
    }
    for (int begin = 0; begin < columns; begin += strip_columns) {
        // A remainder narrower than 8 columns joins the last strip (its margins need room).
        const bool last = columns - begin < strip_columns + 8;
        const int end = last ? columns : begin + strip_columns;
        const int left = begin == 0 ? 0 : begin - (last ? 8 : 4);
        const int right = last ? columns : end + 4;
        cv::cornerMinEigenVal(image.colRange(left, right), strip_eig, 3, 3);
        visit(strip_eig, left, begin, end);
        if (last)
            break;
    }
}

namespace {

// Columns of eigenvalues kept per call of cornerMinEigenVal: its scratch (derivatives,
// their products and the eigenvalues, 24 bytes a pixel) is then a strip of 72 columns, not
// the image. Narrower strips cost more calls (about 30 us each at the detection's sizes).
constexpr int kStripColumns = 64;

struct Candidate {
    float value;
    int y, x;
};

// One strip's share of the pass: the largest eigenvalue under the mask, and the raw local
// maxima above zero of the columns [begin, end) (in the image's columns; the strip's
// column 0 is the image's `left`), away from the image's border.
void scanStrip(const cv::Mat &eig, int left, int begin, int end, int image_columns, const cv::Mat &mask,
               double &max_allowed, bool &any_allowed, std::vector<Candidate> &candidates,
               std::vector<float> &neighbourhood_max)
{
    const int rows = eig.rows;
    neighbourhood_max.resize(std::size_t(eig.cols));
    const int first = begin - left, last = end - left;  // kept columns, in the strip
    // OpenCV's own maximum (vectorised); a strip with nothing under the mask has none.
    const cv::Mat kept = eig.colRange(first, last);
    const cv::Mat kept_mask = mask.empty() ? cv::Mat() : mask.colRange(begin, end);
    if (kept_mask.empty() || cv::countNonZero(kept_mask) > 0) {
        double largest = 0;
        cv::minMaxLoc(kept, nullptr, &largest, nullptr, nullptr, kept_mask);
        max_allowed = any_allowed ? std::max(max_allowed, largest) : largest;
        any_allowed = true;
    }
    for (int y = 1; y < rows - 1; ++y) {
        const float *row = eig.ptr<float>(y);
        // The mask's row, indexed like the strip's.
        const std::uint8_t *allowed = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y) + left;
        // The largest of each 3x3 neighbourhood first (a loop without branches, which the
        // compiler vectorises), then the few pixels equal to theirs.
        const float *above = eig.ptr<float>(y - 1), *below = eig.ptr<float>(y + 1);
        const int from = std::max(first, 1 - left), to = std::min(last, image_columns - 1 - left);
        for (int i = from; i < to; ++i) {
            const float a = std::max(std::max(above[i - 1], above[i]), above[i + 1]);
            const float b = std::max(std::max(row[i - 1], row[i]), row[i + 1]);
            const float c = std::max(std::max(below[i - 1], below[i]), below[i + 1]);
            neighbourhood_max[std::size_t(i)] = std::max(std::max(a, b), c);
        }
        for (int i = from; i < to; ++i) {
            const float v = row[i];
            if (v > 0.f && v == neighbourhood_max[std::size_t(i)] && (!allowed || allowed[i]))
                candidates.push_back({v, y, i + left});
        }
    }
}

} // namespace

void detectGoodCorners(const cv::Mat &image, std::vector<cv::Point2f> &corners, int max_corners,
                       double quality_level, double min_distance, const cv::Mat &mask)
{
    CV_Assert(quality_level > 0 && min_distance >= 0 && max_corners >= 0);
    CV_Assert(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == image.size()));
    corners.clear();
    if (image.empty())
        return;
    // OpenCV keeps a pixel whose eigenvalue v, set to 0 at or below the threshold, equals
    // the largest of its 3x3 neighbourhood (a dilation), away from the image's border. For
    // a threshold >= 0 that is v > threshold and v >= each raw neighbour (one at or below
    // the threshold is below v anyway). So one pass over the strips collects the raw local
    // maxima and the largest eigenvalue under the mask, and the threshold comes after.
    std::vector<Candidate> candidates;
    double max_allowed = 0;
    bool any_allowed = false;
    std::vector<float> neighbourhood_max;  // one strip row's, reused
    forEachEigenvalueStrip(image, kStripColumns, [&](const cv::Mat &eig, int left, int begin, int end) {
        scanStrip(eig, left, begin, end, image.cols, mask, max_allowed, any_allowed, candidates, neighbourhood_max);
    });
    if (!any_allowed)
        return;  // OpenCV's threshold is then 0, and no candidate is under the mask
    if (max_allowed < 0) {
        // A negative threshold (every eigenvalue under the mask rounded below zero): rare
        // enough to leave to OpenCV.
        cv::goodFeaturesToTrack(image, corners, max_corners, quality_level, min_distance, mask);
        return;
    }
    // cv::threshold compares in float.
    const float threshold = float(max_allowed * quality_level);
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                    [threshold](const Candidate &c) { return !(c.value > threshold); }),
                     candidates.end());
    // OpenCV sorts them all: stronger first, equal ones later in the image first (it sorts
    // pointers into its eigenvalue image, address last). A strict order, so taking them one
    // at a time from a heap gives the same sequence, and most are never needed.
    const auto after = [](const Candidate &a, const Candidate &b) {
        if (a.value != b.value)
            return a.value < b.value;
        return a.y != b.y ? a.y < b.y : a.x < b.x;
    };
    std::make_heap(candidates.begin(), candidates.end(), after);
    const auto next = [&candidates, &after]() {
        std::pop_heap(candidates.begin(), candidates.end(), after);
        const Candidate c = candidates.back();
        candidates.pop_back();
        return c;
    };

    if (min_distance < 1) {
        while (!candidates.empty()) {
            const Candidate c = next();
            corners.emplace_back(float(c.x), float(c.y));
            if (max_corners > 0 && int(corners.size()) == max_corners)
                break;
        }
        return;
    }
    // Keep a candidate unless an earlier kept one lies closer than min_distance: kept
    // corners are filed in cells of min_distance, so only the 3x3 cells around are read.
    const int cell = cvRound(min_distance);
    const int grid_width = (image.cols + cell - 1) / cell, grid_height = (image.rows + cell - 1) / cell;
    std::vector<std::vector<cv::Point2f>> grid(std::size_t(grid_width) * std::size_t(grid_height));
    const double min_distance2 = min_distance * min_distance;
    while (!candidates.empty()) {
        const Candidate c = next();
        const int cx = c.x / cell, cy = c.y / cell;
        bool far = true;
        for (int gy = std::max(0, cy - 1); far && gy <= std::min(grid_height - 1, cy + 1); ++gy)
            for (int gx = std::max(0, cx - 1); far && gx <= std::min(grid_width - 1, cx + 1); ++gx)
                for (const cv::Point2f &kept : grid[std::size_t(gy) * std::size_t(grid_width) + std::size_t(gx)]) {
                    // In float, as OpenCV (integers here, so exact either way).
                    const float dx = float(c.x) - kept.x, dy = float(c.y) - kept.y;
                    if (dx * dx + dy * dy < min_distance2) {
                        far = false;
                        break;
                    }
                }
        if (!far)
            continue;
        const cv::Point2f corner(float(c.x), float(c.y));
        grid[std::size_t(cy) * std::size_t(grid_width) + std::size_t(cx)].push_back(corner);
        corners.push_back(corner);
        if (max_corners > 0 && int(corners.size()) == max_corners)
            break;
    }
}

} // namespace uavstab
