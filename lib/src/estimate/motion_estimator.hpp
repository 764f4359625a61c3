// Motion estimation for one frame: tracked features -> hybrid model choice -> robust fit.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "uavstab/config.hpp"
#include "estimate/feature_tracker.hpp"
#include "uavstab/frame_stats.hpp"
#include "estimate/hybrid_selector.hpp"
#include "estimate/motion_model.hpp"
#include "estimate/rolling_shutter_estimator.hpp"
#include "lens/lens_view.hpp"

namespace uavstab {

struct MotionEstimate {
    // Camera motion from the previous frame to this one, as the transform taking this
    // frame's centred coordinates to the previous frame's. A camera panning right by
    // 5 px gives dx = +5.
    Similarity motion;
    MotionModel model = MotionModel::Rigid;
    int points = 0;      // tracks that survived the forward-backward check
    int inliers = 0;     // of those, the ones consistent with the fitted motion
    double rms = 0.0;    // RMS residual of the inliers, full-resolution pixels
    bool skipped = false;  // too few points or implausible motion: identity used
    // Enough tracks entered the frame but too few could be followed, or the motion was
    // implausible: the view changed (scene cut, flash, extreme motion). The camera path
    // should start afresh here rather than smooth across the change.
    bool lost = false;
    bool first = false;    // first frame of a sequence: nothing to compare with
    int screen_fixed = 0;  // exclude_static: tracks dropped as screen-fixed
    // The surviving tracks in this frame (full-resolution centred coordinates), each
    // flagged when it is an inlier of the fit.
    std::vector<TrackedPoint> tracks;
    // config.rolling_shutter: where this frame's rows sit relative to its mid-exposure
    // (empty: nowhere else); `motion` is then the motion between mid-exposures.
    RowMotion row_motion;
    // The sensor's readout as a share of the frame time (0: unknown) and how sure it is.
    double readout = 0.0;
    double readout_confidence = 0.0;
};

class ScreenFixedMap;

class MotionEstimator {
public:
    explicit MotionEstimator(const StabilizerConfig &config);
    ~MotionEstimator();
    MotionEstimator(const MotionEstimator &) = delete;
    MotionEstimator &operator=(const MotionEstimator &) = delete;

    MotionEstimate estimate(const FrameView &frame);
    void reset();
    void setConfig(const StabilizerConfig &config);
    // The time between frames in ms (0: unknown), for a known sensor readout time.
    void setFrameInterval(double milliseconds);
    // See FeatureTracker::setShareWork.
    void setShareWork(ShareWork share);
    // The lens the frames are seen through (null: none): the motion is then fitted to the
    // tracks undistorted, so that it is the motion of the lens's pinhole view.
    void setLens(std::shared_ptr<const LensView> lens);

private:
    RollingShutterEstimator::Settings rollingShutterSettings() const;
    StabilizerConfig trackerConfig() const;

    StabilizerConfig config_;
    FeatureTracker tracker_;
    HybridModelSelector selector_;
    std::uint32_t frame_count_ = 0;
    RollingShutterEstimator rolling_shutter_;
    RowMotion last_rows_;  // the previous frame's
    bool wide_detection_ = false;  // corners over the whole height (a wobble is corrected)
    double frame_interval_ms_ = 0.0;
    std::shared_ptr<const LensView> lens_;
    // exclude_static: where screen-fixed tracks were seen. Kept across reset() (an overlay
    // outlives a scene cut), cleared when the option is switched off.
    std::unique_ptr<ScreenFixedMap> screen_fixed_;
};

} // namespace uavstab
