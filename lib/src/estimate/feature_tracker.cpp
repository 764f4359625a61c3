#include "estimate/feature_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "estimate/corner_detector.hpp"
#include "estimate/lucas_kanade.hpp"
#include "estimate/luma_extractor.hpp"
#include "estimate/overlay_strokes.hpp"

namespace uavstab {

namespace {

constexpr int kMaxPyramidLevel = 3;
constexpr double kQualityLevel = 0.01;
// Smallest side of the half-size pyramid level on which corners are still detected.
constexpr int kMinDetectionSide = 120;
// Mean absolute difference (grey levels) between a tracked patch and where LK put it.
// Real tracks stay far below; unrelated frames (noise, cuts, flashes) land near 85,
// where forward and backward tracking can still agree on a spurious zero motion.
constexpr float kMaxPatchError = 40.f;
// Levels of the pyramid left out of the first tracking pass, and the share of tracks failing
// it (1 in this many) beyond which all are tracked again (see FeatureTracker::Impl::match).
constexpr int kShallowLevels = 1;
constexpr std::size_t kMaxShallowFailures = 4;
// Tracks per chunk of shared tracking work (at most 50 tracks by default: 13 chunks).
constexpr std::size_t kChunkTracks = 4;

// Window and pyramid depth that fit the analysis image (tiny frames get small windows).
struct LkGeometry {
    cv::Size window;
    int levels;
};

LkGeometry lkGeometry(cv::Size size, int max_window)
{
    const int side = std::min(size.width, size.height);
    int win = std::clamp(side / 4, 5, max_window) | 1;
    int levels = 0;
    while (levels < kMaxPyramidLevel && (side >> (levels + 1)) >= 2 * win)
        ++levels;
    return {{win, win}, levels};
}

} // namespace

struct FeatureTracker::Impl {
    StabilizerConfig config;
    std::vector<RectF> auto_exclude;
    LumaExtractor luma;
    OverlayStrokes overlay;
    cv::Mat painted;  // the luma with an overlay painted over
    LucasKanadePyramid previous_pyramid, current_pyramid;
    std::vector<cv::Point2f> tracks;  // positions in the previous frame, analysis pixels
    std::vector<cv::Point2f> forward;
    std::vector<std::uint8_t> ok;            // tracks that passed the forward-backward checks
    std::vector<std::size_t> retry;          // tracks tracked again through the whole pyramid
    std::vector<cv::Point2f> retry_tracks, retry_forward;
    std::vector<std::uint8_t> retry_ok;
    // trackBoth's scratch, one per lane of shared work.
    struct Scratch {
        std::vector<cv::Point2f> from, to;  // a chunk's points, and where they went
        std::vector<std::size_t> kept;      // those that passed the forward checks
        std::vector<cv::Point2f> kept_forward, kept_backward;  // where they went, and back
        std::vector<uchar> status_forward, status_backward;
        std::vector<float> errors_forward;
    };
    Scratch scratch[kShareWorkLanes];
    ShareWork share;
    int track_age = 0;
    int detection_bands = 1;
    bool has_previous = false;
    int frame_width = 0, frame_height = 0;
    cv::Size analysis;
    LkGeometry lk{};

    void detect(const LucasKanadePyramid &pyramid);
    // LK from the previous pyramid into the current one and back, on `levels` levels above
    // the finest: `to` where each point went, `passed` set where the forward checks
    // (status, patch error, inside the image) and the forward-backward distance held.
    // Chunks of the points may be tracked at once on another thread (`share`): each point
    // is tracked on its own, so the results are the same.
    void trackBoth(const std::vector<cv::Point2f> &from, std::vector<cv::Point2f> &to,
                   std::vector<std::uint8_t> &passed, int levels);
    // trackBoth for points [begin, end).
    void trackChunk(const std::vector<cv::Point2f> &from, std::size_t begin, std::size_t end,
                    std::vector<cv::Point2f> &to, std::vector<std::uint8_t> &passed, int levels, Scratch &scratch);
    // Tracks `tracks` from the previous pyramid into the current one (re-detecting first
    // when due or when `redetect`), forward-backward checked and outside excluded regions.
    PointMatches match(bool redetect);
    // config.exclude in pixels of an image of `size` (the analysis image or a pyramid
    // level), each grown by `margin` pixels and clipped to the image.
    std::vector<cv::Rect> excluded(cv::Size size, int margin) const;
    // Margin around excluded rectangles, analysis pixels: half the LK window, so that no
    // kept track's window sees the overlay.
    int excludeMargin() const { return lk.window.width / 2; }
    Point2 toFrame(cv::Point2f p) const;
};

FeatureTracker::FeatureTracker(const StabilizerConfig &config)
    : impl_(std::make_unique<Impl>())
{
    impl_->config = config;
}

FeatureTracker::~FeatureTracker() = default;

void FeatureTracker::reset()
{
    impl_->has_previous = false;
    impl_->tracks.clear();
    impl_->track_age = 0;
    impl_->luma.reset();  // 16-bit frames: the automatic gain starts afresh too
}

void FeatureTracker::setConfig(const StabilizerConfig &config)
{
    // A new analysis size or window needs pyramids built for it: start tracking afresh.
    const bool rebuild = config.analysis_width != impl_->config.analysis_width ||
                         config.tracking_window != impl_->config.tracking_window;
    impl_->config = config;
    if (rebuild) {
        reset();
        impl_->frame_width = impl_->frame_height = 0;  // recompute the geometry at the next frame
    }
}

void FeatureTracker::setAutoExclude(std::vector<RectF> regions)
{
    impl_->auto_exclude = std::move(regions);
}

void FeatureTracker::dropTracks(const std::vector<std::uint8_t> &drop)
{
    std::vector<cv::Point2f> &tracks = impl_->tracks;
    if (drop.size() != tracks.size())
        return;  // not the last result's tracks (re-detected or reset since): nothing to do
    std::size_t k = 0;
    for (std::size_t i = 0; i < tracks.size(); ++i)
        if (!drop[i])
            tracks[k++] = tracks[i];
    tracks.resize(k);
}

void FeatureTracker::Impl::detect(const LucasKanadePyramid &pyramid)
{
    // Corners are found on the half-size level when it is big enough: a quarter of the
    // pixels for the eigenvalue map, and LK follows whatever point it is given anyway.
    const int level =
        pyramid.levelCount() > 1 && std::min(pyramid.image(1).cols, pyramid.image(1).rows) >= kMinDetectionSide ? 1 : 0;
    const cv::Mat &image = pyramid.image(level);
    const double margin = (1.0 - config.roi) * 0.5;
    const cv::Rect roi(int(image.cols * margin), int(image.rows * margin),
                       std::max(1, int(std::lround(image.cols * config.roi))),
                       std::max(1, int(std::lround(image.rows * config.roi))));
    const cv::Rect region = roi & cv::Rect(0, 0, image.cols, image.rows);
    tracks.clear();
    track_age = 0;
    if (region.width < 3 || region.height < 3)
        return;
    // Spread the corners: about one per (region area / max_corners), but not too sparse.
    const double spacing = std::sqrt(double(region.area()) / config.max_corners) * 0.5;
    cv::Mat mask;  // excluded regions: no corners there (nor in the quality level's maximum)
    if (!config.exclude.empty() || !auto_exclude.empty()) {
        mask = cv::Mat(region.size(), CV_8UC1, cv::Scalar(255));
        for (const cv::Rect &r : excluded(image.size(), (excludeMargin() + (1 << level) - 1) >> level)) {
            const cv::Rect inside = (r & region) - region.tl();
            if (!inside.empty())
                mask(inside).setTo(0);
        }
        if (cv::countNonZero(mask) == 0)
            return;
    }
    if (detection_bands <= 1 || region.height < 3 * detection_bands) {
        detectGoodCorners(image(region), tracks, config.max_corners, kQualityLevel, std::clamp(spacing, 2.0, 30.0),
                          mask);
    } else {
        const int per_band = (config.max_corners + detection_bands - 1) / detection_bands;
        std::vector<cv::Point2f> found;
        for (int b = 0; b < detection_bands; ++b) {
            const int y0 = region.height * b / detection_bands, y1 = region.height * (b + 1) / detection_bands;
            const cv::Rect band(0, y0, region.width, y1 - y0);
            const cv::Mat band_mask = mask.empty() ? cv::Mat() : mask(band);
            if (!band_mask.empty() && cv::countNonZero(band_mask) == 0)
                continue;
            detectGoodCorners(image(region)(band), found, per_band, kQualityLevel, std::clamp(spacing, 2.0, 30.0),
                              band_mask);
            for (const cv::Point2f &p : found)
                tracks.push_back({p.x, p.y + float(y0)});
        }
    }
    const float scale = float(1 << level), offset = 0.5f * (scale - 1.0f);  // level pixel -> level 0
    for (auto &p : tracks) {
        p.x = (p.x + float(region.x)) * scale + offset;
        p.y = (p.y + float(region.y)) * scale + offset;
    }
}

std::vector<cv::Rect> FeatureTracker::Impl::excluded(cv::Size size, int margin) const
{
    std::vector<cv::Rect> rects;
    const cv::Rect image(0, 0, size.width, size.height);
    for (const std::vector<RectF> *list : {&config.exclude, &auto_exclude})
        for (const RectF &f : *list) {
            const int x0 = int(std::floor(f.x * size.width)) - margin;
            const int y0 = int(std::floor(f.y * size.height)) - margin;
            const int x1 = int(std::ceil((f.x + f.w) * size.width)) + margin;
            const int y1 = int(std::ceil((f.y + f.h) * size.height)) + margin;
            const cv::Rect r = cv::Rect(x0, y0, x1 - x0, y1 - y0) & image;
            if (!r.empty())
                rects.push_back(r);
        }
    return rects;
}

Point2 FeatureTracker::Impl::toFrame(cv::Point2f p) const
{
    // Pixel centres map through the resampling: x_full + 0.5 = (x_analysis + 0.5) * sx.
    const double sx = double(frame_width) / analysis.width;
    const double sy = double(frame_height) / analysis.height;
    return {(p.x + 0.5) * sx - 0.5 - (frame_width - 1) * 0.5, (p.y + 0.5) * sy - 0.5 - (frame_height - 1) * 0.5};
}

void FeatureTracker::Impl::trackBoth(const std::vector<cv::Point2f> &from, std::vector<cv::Point2f> &to,
                                     std::vector<std::uint8_t> &passed, int levels)
{
    const std::size_t n = from.size();
    to.resize(n);
    passed.assign(n, 0);
    const int chunks = int((n + kChunkTracks - 1) / kChunkTracks);
    runShared(share, chunks, [&](int chunk, int lane) {
        const std::size_t begin = std::size_t(chunk) * kChunkTracks;
        trackChunk(from, begin, std::min(n, begin + kChunkTracks), to, passed, levels, scratch[lane]);
    });
}

void FeatureTracker::Impl::trackChunk(const std::vector<cv::Point2f> &from_all, std::size_t begin, std::size_t end,
                                      std::vector<cv::Point2f> &to_all, std::vector<std::uint8_t> &passed,
                                      int levels, Scratch &s)
{
    LucasKanadeParams params;
    params.window = lk.window;
    params.max_level = levels;
    s.from.assign(from_all.begin() + std::ptrdiff_t(begin), from_all.begin() + std::ptrdiff_t(end));
    const std::vector<cv::Point2f> &from = s.from;
    std::vector<cv::Point2f> &to = s.to;
    trackLucasKanade(previous_pyramid, current_pyramid, from, to, s.status_forward, &s.errors_forward, params);
    std::copy(to.begin(), to.end(), to_all.begin() + std::ptrdiff_t(begin));
    // Only tracks that passed the forward checks go back: the rest are dropped anyway.
    const cv::Rect2f inside(0.f, 0.f, float(analysis.width - 1), float(analysis.height - 1));
    s.kept.clear();
    s.kept_forward.clear();
    for (std::size_t i = 0; i < from.size(); ++i) {
        if (s.status_forward[i] && !(s.errors_forward[i] > kMaxPatchError) && inside.contains(to[i])) {
            s.kept.push_back(i);
            s.kept_forward.push_back(to[i]);
        }
    }
    if (s.kept.empty())
        return;
    // No patch error for the way back: only the forward one is checked, and the tracker
    // skips a window resampling per point when it is not asked for.
    trackLucasKanade(current_pyramid, previous_pyramid, s.kept_forward, s.kept_backward, s.status_backward, nullptr,
                     params);
    const float limit2 = float(config.fb_threshold * config.fb_threshold);
    for (std::size_t k = 0; k < s.kept.size(); ++k) {
        const std::size_t i = s.kept[k];
        const cv::Point2f e = s.kept_backward[k] - from[i];
        passed[begin + i] = s.status_backward[k] && e.dot(e) <= limit2;
    }
}

PointMatches FeatureTracker::Impl::match(bool redetect)
{
    PointMatches matches;
    const std::size_t min_live = std::size_t(std::max(config.min_points, config.max_corners / 2));
    if (redetect || track_age >= config.redetect_interval || tracks.size() < min_live) {
        detect(previous_pyramid);
        matches.redetected = true;
    }
    matches.detected = int(tracks.size());
    if (!tracks.empty()) {
        // Shake moves a track a few analysis pixels: the pyramid's coarsest level, there for
        // fast motion, is left out at first, and the tracks that fail the checks are
        // tracked again through the whole pyramid (a motion beyond the shallow pyramid's reach
        // fails them). When many fail, the frame moved far: every track is tracked again, so
        // that none is kept from a shallow pass that may have locked onto a repeating
        // texture's neighbouring period.
        const int shallow = std::max(0, lk.levels - kShallowLevels);
        trackBoth(tracks, forward, ok, shallow);
        if (shallow < lk.levels) {
            retry.clear();
            for (std::size_t i = 0; i < tracks.size(); ++i)
                if (!ok[i])
                    retry.push_back(i);
            if (retry.size() * kMaxShallowFailures > tracks.size()) {
                retry.resize(tracks.size());
                for (std::size_t i = 0; i < tracks.size(); ++i)
                    retry[i] = i;
            }
            if (!retry.empty()) {
                retry_tracks.clear();
                for (const std::size_t i : retry)
                    retry_tracks.push_back(tracks[i]);
                trackBoth(retry_tracks, retry_forward, retry_ok, lk.levels);
                for (std::size_t k = 0; k < retry.size(); ++k) {
                    forward[retry[k]] = retry_forward[k];
                    ok[retry[k]] = retry_ok[k];
                }
            }
        }
        std::vector<cv::Point2f> survivors;
        survivors.reserve(tracks.size());
        // Tracks that come near an excluded region (a screen-fixed overlay) are dropped:
        // their window would see the overlay, which does not move with the scene.
        const std::vector<cv::Rect> excluded_rects = excluded(analysis, excludeMargin());
        auto isExcluded = [&](cv::Point2f p) {
            return std::any_of(excluded_rects.begin(), excluded_rects.end(), [&](const cv::Rect &r) {
                return p.x >= float(r.x) && p.y >= float(r.y) && p.x < float(r.x + r.width) &&
                       p.y < float(r.y + r.height);
            });
        };
        for (std::size_t i = 0; i < tracks.size(); ++i) {
            if (!ok[i])
                continue;
            if (!excluded_rects.empty() && (isExcluded(forward[i]) || isExcluded(tracks[i])))
                continue;
            matches.previous.push_back(toFrame(tracks[i]));
            matches.current.push_back(toFrame(forward[i]));
            survivors.push_back(forward[i]);
        }
        tracks.swap(survivors);
        ++track_age;
    }
    return matches;
}

PointMatches FeatureTracker::track(const FrameView &frame)
{
    Impl &d = *impl_;
    if (frame.width != d.frame_width || frame.height != d.frame_height) {
        reset();
        d.frame_width = frame.width;
        d.frame_height = frame.height;
        d.analysis = LumaExtractor::analysisSize(frame.width, frame.height, d.config.analysis_width);
        d.lk = lkGeometry(d.analysis, d.config.tracking_window);
        d.overlay.reset();
    }

    const cv::Mat &extracted = d.luma.extract(frame, d.config.analysis_width);
    const cv::Mat &luma = d.config.exclude_static ? d.overlay.paint(extracted, d.painted) : extracted;
    // The pyramid is built once per frame and serves the forward track into this frame
    // and, next frame, the backward check and the track out of it. It copies the luma,
    // so the caller's frame need not outlive this call.
    buildLucasKanadePyramid(luma, d.current_pyramid, d.lk.window, d.lk.levels);

    PointMatches matches;
    matches.first = !d.has_previous;
    if (d.has_previous)
        matches = d.match(false);
    d.has_previous = true;
    std::swap(d.previous_pyramid, d.current_pyramid);
    return matches;
}

void FeatureTracker::setDetectionBands(int bands)
{
    impl_->detection_bands = std::max(1, bands);
}

void FeatureTracker::cameraMoved(const Similarity &current_to_previous)
{
    if (impl_->config.exclude_static && impl_->frame_width > 0)
        impl_->overlay.cameraMoved(current_to_previous, double(impl_->frame_width) / impl_->analysis.width);
}

void FeatureTracker::motionUnknown()
{
    impl_->overlay.motionUnknown();
}

void FeatureTracker::setShareWork(ShareWork share)
{
    impl_->luma.setShareWork(share);
    impl_->share = std::move(share);
}

PointMatches FeatureTracker::retrack()
{
    Impl &d = *impl_;
    PointMatches matches;
    if (!d.has_previous || d.previous_pyramid.empty() || d.current_pyramid.empty())
        return matches;
    // track() swapped the pyramids: put the last frame's back as the current one.
    std::swap(d.previous_pyramid, d.current_pyramid);
    matches = d.match(true);
    std::swap(d.previous_pyramid, d.current_pyramid);
    return matches;
}

} // namespace uavstab
