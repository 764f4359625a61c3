#include "estimate/motion_estimator.hpp"

#include <algorithm>
#include <cmath>

#include "estimate/screen_fixed.hpp"

namespace uavstab {

namespace {

// Residual (analysis pixels) beyond which a track counts as an outlier of the fit.
constexpr double kInlierThresholdAnalysisPx = 1.5;
// Inter-frame motions beyond these are not camera shake but a failed estimate.
constexpr double kMaxAngle = 0.35;  // 20 degrees
constexpr double kMaxLogScale = 0.2;
// While a rolling shutter's wobble is being corrected, corners are detected over this share
// of the frame at least: the top and bottom rows bend most, and the band fit needs tracks
// there (the wobble left on a 640x360 flight: 29 % of the input's with the default region,
// 17 % with this one).
constexpr double kRollingShutterRoi = 0.95;
// ...and this many corners at least: the bands fit three unknowns each, and 50 tracks over
// 12 bands left the fit to its smoothing (the motion between mid-exposures on 640x360
// flights read out over 80 % of the frame time with 47 Hz vibration: 0.85 px RMS error with
// 50 corners and the earlier settings, 0.28 with 100 and 0.21 with 150 now; each corner
// costs two LK tracks, and 150 cost a third more CPU per frame at 1080p than
// rolling_shutter=off).
constexpr int kRollingShutterCorners = 100;
// ...in as many horizontal bands as the band fit has, each with its share of the corners:
// detected at once over the whole height, they gather where the picture is most textured
// and leave bands to the fit's smoothing (1280x720 flight read out over 80 % of the frame
// time with 47 Hz vibration, delay 20: 1.66 -> 1.52 px of shake left at its rows; over the
// benchmark's 45 rolling-shutter flights the shake left against the global-shutter twin,
// mean 1.69x -> 1.59x, worst 5.74x -> 5.28x).
constexpr int kRollingShutterDetectionBands = RollingShutterEstimator::Settings{}.bands;
// ...and the motion between mid-exposures is fitted on the tracks within this share of the
// height above and below the middle row (1.40 px of shake left on a 1280x720 flight read out
// over 80 % of the frame time, 1.58 px fitted on every track; with 150 corners the motion's
// error on the 640x360 flights above is 0.29 px at 0.25, 0.24 at 0.15, 0.21 at 0.1).
constexpr double kMiddleRows = 0.1;

bool plausible(const Similarity &m, int width, int height)
{
    return std::abs(m.angle) <= kMaxAngle && std::abs(std::log(m.scale)) <= kMaxLogScale &&
           std::abs(m.dx) <= width && std::abs(m.dy) <= height;
}

// The largest distance between where two motions put the frame's corners (px).
double cornerDistance(const Similarity &a, const Similarity &b, int width, int height)
{
    double largest = 0.0;
    for (int corner = 0; corner < 4; ++corner) {
        const Point2 p{(corner % 2 ? 0.5 : -0.5) * width, (corner / 2 ? 0.5 : -0.5) * height};
        const Point2 q = a.apply(p), r = b.apply(p);
        largest = std::max(largest, std::hypot(q.x - r.x, q.y - r.y));
    }
    return largest;
}

} // namespace

MotionEstimator::MotionEstimator(const StabilizerConfig &config)
    : config_(config), tracker_(config), selector_(config.model, config.dwell),
      screen_fixed_(std::make_unique<ScreenFixedMap>())
{
}

MotionEstimator::~MotionEstimator() = default;

void MotionEstimator::reset()
{
    tracker_.reset();
    selector_.reset();
    rolling_shutter_.reset();
    last_rows_ = {};
}

StabilizerConfig MotionEstimator::trackerConfig() const
{
    StabilizerConfig c = config_;
    if (wide_detection_) {
        c.roi = std::max(c.roi, kRollingShutterRoi);
        c.max_corners = std::max(c.max_corners, kRollingShutterCorners);
    }
    return c;
}

RollingShutterEstimator::Settings MotionEstimator::rollingShutterSettings() const
{
    RollingShutterEstimator::Settings s;
    if (config_.readout_time > 0.0 && frame_interval_ms_ > 0.0)
        s.readout = std::min(1.0, config_.readout_time / frame_interval_ms_);
    return s;
}

void MotionEstimator::setShareWork(ShareWork share)
{
    tracker_.setShareWork(std::move(share));
}

void MotionEstimator::setLens(std::shared_ptr<const LensView> lens)
{
    lens_ = std::move(lens);
}

void MotionEstimator::setFrameInterval(double milliseconds)
{
    const double interval = milliseconds > 0.0 && std::isfinite(milliseconds) ? milliseconds : 0.0;
    if (interval == frame_interval_ms_)
        return;  // the element tells it every frame
    frame_interval_ms_ = interval;
    rolling_shutter_.setSettings(rollingShutterSettings());
}

void MotionEstimator::setConfig(const StabilizerConfig &config)
{
    if (!config.exclude_static && config_.exclude_static) {
        screen_fixed_->clear();
        tracker_.setAutoExclude({});
    }
    if (config.rolling_shutter != config_.rolling_shutter || config.readout_time != config_.readout_time) {
        rolling_shutter_.restartStream();
        last_rows_ = {};
        wide_detection_ = false;
        tracker_.setDetectionBands(1);
    }
    config_ = config;
    tracker_.setConfig(trackerConfig());
    selector_.setChoice(config.model, config.dwell);
    rolling_shutter_.setSettings(rollingShutterSettings());
}

namespace {

// The motion between two frames' mid-exposures: the tracks of both frames put where their
// mid-exposures saw them (this frame's rows, the previous frame's), the fit again.
RobustFit fitBetweenMidExposures(MotionModel model, const std::vector<Point2> &from, const std::vector<Point2> &to,
                                 const RowMotion &rows, const RowMotion &last_rows, double threshold,
                                 std::uint32_t seed, int height, int min_points)
{
    std::vector<Point2> mid_from(from.size()), mid_to(to.size());
    for (std::size_t i = 0; i < from.size(); ++i) {
        mid_from[i] = rows.toMidExposure(from[i]);
        mid_to[i] = last_rows.toMidExposure(to[i]);
    }
    RobustFit fit = fitRobust(model, mid_from, mid_to, threshold, seed);
    // The middle rows were read at the mid-exposure: their tracks moved least and the band
    // fit's errors, which grow away from the middle, touch them least. The motion is fitted
    // on them where there are enough, robustly on its own: where the bands are off by more
    // than the threshold, the consensus of the whole frame can be a band away from the
    // middle (up to 4-7 px of error in a few frames of the 47 Hz flights, 0.58 -> 0.38 px RMS).
    std::vector<Point2> middle_from, middle_to;
    for (std::size_t i = 0; i < from.size(); ++i)
        if (std::abs(mid_from[i].y) < kMiddleRows * height) {
            middle_from.push_back(mid_from[i]);
            middle_to.push_back(mid_to[i]);
        }
    if (int(middle_from.size()) >= min_points) {
        const RobustFit middle = fitRobust(model, middle_from, middle_to, threshold, seed);
        if (middle.inlier_count >= min_points)
            fit.motion = middle.motion;
    }
    return fit;
}

} // namespace

MotionEstimate MotionEstimator::estimate(const FrameView &frame)
{
    MotionEstimate result;
    if (config_.rolling_shutter != RollingShutter::Off) {
        // What it knows before this frame (a frame it cannot use changes nothing).
        result.readout = rolling_shutter_.readout();
        result.readout_confidence = rolling_shutter_.readoutConfidence();
    }
    PointMatches matches = tracker_.track(frame);
    const double scale = std::max(1.0, double(frame.width) / std::min(frame.width, config_.analysis_width));
    if (config_.exclude_static && !matches.first) {
        std::vector<std::uint8_t> dropped;
        result.screen_fixed =
            screen_fixed_->filter(matches, frame.width, frame.height, scale, frame_count_ + 1, dropped);
        if (result.screen_fixed)
            tracker_.dropTracks(dropped);
        const std::vector<RectF> regions = screen_fixed_->regions();
        tracker_.setAutoExclude(regions);  // evidence decays: every frame
        if (result.screen_fixed && int(matches.current.size()) < config_.min_points) {
            // Most corners sat on an overlay (its edges outshine a hazy scene): detect
            // afresh around it (where it was seen in this frame too) and match this frame
            // again, rather than skip it.
            tracker_.setAutoExclude(screen_fixed_->suspectRegions());
            PointMatches again = tracker_.retrack();
            tracker_.setAutoExclude(regions);
            if (again.current.size() > matches.current.size())
                matches = std::move(again);
        }
    }
    auto reportTracks = [&]() {
        result.points = int(matches.current.size());
        result.tracks.clear();
        result.tracks.reserve(matches.current.size());
        for (const Point2 &p : matches.current)
            result.tracks.push_back({p, false});
    };
    reportTracks();
    if (matches.first) {
        result.first = true;
        return result;
    }
    if (result.points < config_.min_points) {
        result.skipped = true;
        tracker_.motionUnknown();
        result.lost = matches.detected >= config_.min_points;
        return result;
    }

    const double threshold = kInlierThresholdAnalysisPx * scale;
    const std::uint32_t seed = ++frame_count_;
    // The motion maps this frame's points onto the previous frame's: in the lens's
    // undistorted view where there is a lens, since the picture moves as a similarity there.
    std::vector<Point2> undistorted_from, undistorted_to;
    const std::vector<Point2> *from_points = &matches.current;
    const std::vector<Point2> *to_points = &matches.previous;
    RobustFit fit;
    MotionModel model;
    auto preparePoints = [&]() {
        from_points = &matches.current;
        to_points = &matches.previous;
        if (lens_) {
            undistorted_from.clear();
            undistorted_to.clear();
            for (const Point2 &p : matches.current)
                undistorted_from.push_back(lens_->undistortCentred(p));
            for (const Point2 &p : matches.previous)
                undistorted_to.push_back(lens_->undistortCentred(p));
            from_points = &undistorted_from;
            to_points = &undistorted_to;
        }
    };
    auto fitPoints = [&]() {
        if (config_.model == ModelChoice::Hybrid) {
            // The permissive fit finds the inliers both models are compared on.
            RobustFit similarity = fitRobust(MotionModel::Similarity, *from_points, *to_points, threshold, seed);
            model = selector_.select(*from_points, *to_points, &similarity.inliers);
            fit = model == MotionModel::Similarity
                      ? std::move(similarity)
                      : fitRobust(MotionModel::Rigid, *from_points, *to_points, threshold, seed);
        } else {
            model = selector_.select(*from_points, *to_points);
            fit = fitRobust(model, *from_points, *to_points, threshold, seed);
        }
    };
    const HybridModelSelector selector_before_fit = selector_;
    preparePoints();
    fitPoints();
    if (fit.inlier_count < config_.min_points) {
        // Too few of the tracks agree on one motion (in a hazy scene most corners sit on an
        // overlay's strokes until overlay_strokes.hpp has learnt them): twice as many
        // corners, detected afresh, are matched and fitted once more, and where that fit
        // confirms the first (the frame's corners within the inlier threshold) it stands
        // on its inliers. The hazy OSD flight at x2 shake (delay 5, seed 1) lost its frame
        // 6 with 9 agreeing tracks of the 10 needed, and kept 1.03 px of jitter against
        // 0.77 px without the OSD; confirmed by 31 of 62 fresh tracks, 0.78 px. A fit that
        // does not confirm the first is no better evidence: the frame stays skipped (the
        // thermal clip's frame 93: 5 of 10 tracks, then 11 of 27 on a motion 5 px away).
        StabilizerConfig denser = trackerConfig();
        denser.max_corners *= 2;
        tracker_.setConfig(denser);
        PointMatches again = tracker_.retrack();
        tracker_.setConfig(trackerConfig());
        if (int(again.current.size()) >= config_.min_points) {
            std::swap(matches, again);
            preparePoints();
            const RobustFit first_fit = fit;
            const MotionModel first_model = model;
            const HybridModelSelector selector_after_first_fit = selector_;
            selector_ = selector_before_fit;  // one selection a frame
            fitPoints();
            const bool confirmed = fit.inlier_count >= config_.min_points &&
                                   cornerDistance(fit.motion, first_fit.motion, frame.width, frame.height) <= threshold;
            if (!confirmed) {
                std::swap(matches, again);
                preparePoints();
                fit = first_fit;
                model = first_model;
                selector_ = selector_after_first_fit;
            } else {
                reportTracks();
            }
        }
    }
    const std::vector<Point2> &from = *from_points;
    const std::vector<Point2> &to = *to_points;

    // Rolling shutter: the rows of both frames put where their mid-exposures saw them, the
    // fit again. Without that, a wobble of a few px leaves few inliers within the threshold.
    if (config_.rolling_shutter != RollingShutter::Off && plausible(fit.motion, frame.width, frame.height)) {
        // The band fit works on what the frame's one transform leaves, and that transform,
        // fitted on every row of a bent frame, took up part of the bend (the part a
        // similarity can express: a stretch, a turn). The motion between the mid-exposures
        // is then fitted again, and the bands once more against it, from the state the
        // frame found: that part is theirs again (the 47 Hz flight read out over 80 % of
        // the frame time kept 0.19x of its wobble with one pass, 0.15x with two, and
        // 2.18 -> 1.56 px of shake at its rows; a third pass changes nothing).
        const RollingShutterEstimator before_frame = rolling_shutter_;
        const RowMotion last_rows_before_frame = last_rows_;
        const RobustFit plain_fit = fit;
        RowMotion rows = rolling_shutter_.estimate(to, from, fit.motion, frame.width, frame.height);
        for (int pass = 0; pass < 2; ++pass) {
            if (last_rows_.empty())
                last_rows_ = rolling_shutter_.previousRows();
            if (rows.empty() && last_rows_.empty()) {
                fit = plain_fit;  // the second pass found no bend after all
                break;
            }
            fit = fitBetweenMidExposures(model, from, to, rows, last_rows_, threshold, seed, frame.height,
                                         config_.min_points);
            // A frame whose rows stay put (no rolling shutter found) is fitted once.
            if (pass > 0 || rows.empty())
                break;
            rolling_shutter_ = before_frame;
            last_rows_ = last_rows_before_frame;
            rows = rolling_shutter_.estimate(to, from, fit.motion, frame.width, frame.height);
        }
        result.row_motion = rows;
        result.readout = rolling_shutter_.readout();
        result.readout_confidence = rolling_shutter_.readoutConfidence();
        last_rows_ = std::move(rows);
        if (last_rows_.empty() == wide_detection_) {
            wide_detection_ = !wide_detection_;
            tracker_.setConfig(trackerConfig());
            tracker_.setDetectionBands(wide_detection_ ? kRollingShutterDetectionBands : 1);
        }
    }

    result.model = model;
    result.inliers = fit.inlier_count;
    result.rms = fit.rms;
    for (std::size_t i = 0; i < result.tracks.size() && i < fit.inliers.size(); ++i)
        result.tracks[i].inlier = fit.inliers[i] != 0;
    if (fit.inlier_count < config_.min_points || !plausible(fit.motion, frame.width, frame.height)) {
        result.skipped = true;
        for (TrackedPoint &t : result.tracks)
            t.inlier = false;
        result.lost = true;
        result.row_motion = {};
        rolling_shutter_.reset();
        last_rows_ = {};
        tracker_.motionUnknown();
        return result;
    }
    result.motion = fit.motion;
    tracker_.cameraMoved(fit.motion);
    return result;
}

} // namespace uavstab
