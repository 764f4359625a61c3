#include "estimate/screen_fixed.hpp"

#include <algorithm>
#include <cmath>

#include "estimate/motion_model.hpp"

namespace uavstab {

namespace {

constexpr double kMovingPx = 1.5;       // analysis px: "moved clearly"
constexpr double kStillShare = 0.2;     // moved less than this share of what the scene did: stayed put
constexpr double kInlierPx = 1.5;       // the fit of the moving tracks, as the estimator's
constexpr int kMinMoving = 3;           // moving inliers needed to trust their motion
constexpr double kMinSpread = 0.25;     // share of width and height they must span
constexpr double kMinAgreeing = 0.6;    // share of the moving tracks that must agree
// 1.1 degrees per frame: a shaky camera turns that much (at 0.6 the hazy OSD flight's first
// frames, turning 0.6-0.7 degrees, were refused and kept their estimate pinned to the OSD:
// 0.95 px against 0.46 without the OSD on one seed at delay 5).
constexpr double kMaxAngle = 0.02;
constexpr double kMaxLogScale = 0.004;  // 0.4 % per frame (objects moving apart look like a zoom)
constexpr float kEvidenceCap = 10.f;
constexpr float kMaskedAt = 2.f;        // evidence that makes a cell excluded
constexpr float kDecayPerFrame = 0.02f; // a cell is freed 400 frames after the last sighting

double distance(const Point2 &a, const Point2 &b)
{
    return std::hypot(a.x - b.x, a.y - b.y);
}

} // namespace

void ScreenFixedMap::clear()
{
    score_.fill(0.f);
}

int ScreenFixedMap::filter(PointMatches &m, int width, int height, double scale, std::uint32_t seed,
                           std::vector<std::uint8_t> &drop)
{
    drop.assign(m.current.size(), 0);
    if (width != width_ || height != height_) {
        clear();
        width_ = width;
        height_ = height;
    }
    for (float &s : score_)
        s = std::max(0.f, s - kDecayPerFrame);

    // The motion the clearly moving tracks agree on...
    const std::size_t n = m.current.size();
    std::vector<Point2> moving_from, moving_to;
    std::vector<double> moved(n);
    for (std::size_t i = 0; i < n; ++i) {
        moved[i] = distance(m.current[i], m.previous[i]);
        if (moved[i] > kMovingPx * scale) {
            moving_from.push_back(m.current[i]);
            moving_to.push_back(m.previous[i]);
        }
    }
    if (int(moving_from.size()) < kMinMoving || moving_from.size() == n)
        return 0;
    const RobustFit fit = fitRobust(MotionModel::Similarity, moving_from, moving_to, kInlierPx * scale, seed);
    // Most of the moving tracks must agree, on a motion a camera makes between two frames
    // (objects moving each their own way do not).
    if (fit.inlier_count < kMinMoving || fit.inlier_count < kMinAgreeing * double(moving_from.size()) ||
        std::abs(fit.motion.angle) > kMaxAngle || std::abs(std::log(fit.motion.scale)) > kMaxLogScale)
        return 0;
    // The camera moved only if the agreeing tracks are spread over the picture: a compact
    // group is more likely an object moving before a camera that holds still (the still
    // tracks are then the scene, not an overlay).
    double x0 = width, x1 = -width, y0 = height, y1 = -height;
    for (std::size_t k = 0; k < moving_from.size(); ++k)
        if (fit.inliers[k]) {
            x0 = std::min(x0, moving_from[k].x);
            x1 = std::max(x1, moving_from[k].x);
            y0 = std::min(y0, moving_from[k].y);
            y1 = std::max(y1, moving_from[k].y);
        }
    if (x1 - x0 < kMinSpread * width || y1 - y0 < kMinSpread * height)
        return 0;

    // ... would have moved these clearly, but they (nearly) stayed put.
    int dropped = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const Point2 &p = m.current[i];
        const double expected = distance(fit.motion.apply(p), p);
        if (expected <= kMovingPx * scale || moved[i] > kStillShare * expected)
            continue;
        drop[i] = 1;
        ++dropped;
        // Centred full-resolution coordinates -> cell.
        const int cx = std::clamp(int((p.x / width + 0.5) * kCols), 0, kCols - 1);
        const int cy = std::clamp(int((p.y / height + 0.5) * kRows), 0, kRows - 1);
        float &s = score_[std::size_t(cy * kCols + cx)];
        // A cell taken for an overlay is kept for a while (kEvidenceCap / kDecayPerFrame
        // frames after its last sighting), not dropped as soon as its score slips.
        s = s + 1.f >= kMaskedAt ? kEvidenceCap : s + 1.f;
    }
    if (dropped) {
        std::size_t k = 0;
        for (std::size_t i = 0; i < n; ++i)
            if (!drop[i]) {
                m.previous[k] = m.previous[i];
                m.current[k] = m.current[i];
                ++k;
            }
        m.previous.resize(k);
        m.current.resize(k);
    }
    return dropped;
}

std::vector<RectF> ScreenFixedMap::regions() const
{
    return regionsFrom(kMaskedAt);
}

std::vector<RectF> ScreenFixedMap::suspectRegions() const
{
    return regionsFrom(kMaskedAt - 1.f);
}

std::vector<RectF> ScreenFixedMap::regionsFrom(float at) const
{
    std::vector<RectF> rects;
    for (int y = 0; y < kRows; ++y)
        for (int x = 0; x < kCols;) {
            if (score_[std::size_t(y * kCols + x)] < at) {
                ++x;
                continue;
            }
            int end = x + 1;
            while (end < kCols && score_[std::size_t(y * kCols + end)] >= at)
                ++end;
            rects.push_back({double(x) / kCols, double(y) / kRows, double(end - x) / kCols, 1.0 / kRows});
            x = end;
        }
    return rects;
}

} // namespace uavstab
