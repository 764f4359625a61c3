// Shi-Tomasi corners in a reduced region of interest, tracked from frame to frame with
// pyramidal Lucas-Kanade, re-detected every few frames, and weeded by a forward-backward
// consistency check (the paper's sections 3.1-3.2).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "uavstab/config.hpp"
#include "uavstab/frame_view.hpp"
#include "share_work.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

// Where the surviving tracks were in the previous frame and are in this one, in
// full-resolution centred coordinates (see similarity.hpp).
struct PointMatches {
    std::vector<Point2> previous;
    std::vector<Point2> current;
    int detected = 0;         // tracks that entered this frame (before weeding)
    bool redetected = false;  // corners were detected afresh on the previous frame
    bool first = false;       // no previous frame to track from
};

class FeatureTracker {
public:
    explicit FeatureTracker(const StabilizerConfig &config);
    ~FeatureTracker();
    FeatureTracker(const FeatureTracker &) = delete;
    FeatureTracker &operator=(const FeatureTracker &) = delete;

    // Tracks features of the previous frame into `frame`. The first frame after
    // construction or reset(), or a frame of another size, yields no matches.
    PointMatches track(const FrameView &frame);
    void reset();
    void setConfig(const StabilizerConfig &config);
    // Regions excluded on top of config.exclude (found by the estimator: exclude_static),
    // fractions of the frame; they apply from the next frame.
    void setAutoExclude(std::vector<RectF> regions);
    // Stops following the tracks of the last track() result flagged in `drop` (one flag
    // per match, in order); fewer live tracks bring the next re-detection forward.
    void dropTracks(const std::vector<std::uint8_t> &drop);
    // Matches the last frame track() saw again from the frame before it, on corners
    // detected afresh there (outside the excluded regions as they are now): for when most
    // of the last result's tracks turned out to sit on a screen-fixed overlay.
    PointMatches retrack();
    // Corners are detected in this many horizontal bands of the region (1, the default:
    // the whole region at once), each with its share of max_corners and its own quality
    // threshold, so that no band of rows is left without tracks where the picture is
    // fainter there than elsewhere. Applies from the next detection.
    void setDetectionBands(int bands);
    // The camera's motion into the last frame track() saw, as the estimator fitted it
    // (full-resolution px), or that it could not: with config.exclude_static, an
    // overlay's pixels are found from it (overlay_strokes.hpp) and painted over before
    // tracking.
    void cameraMoved(const Similarity &current_to_previous);
    void motionUnknown();
    // Where the luma's downscale and the tracking may share their work (unset, the
    // default: all of it on the caller's thread).
    void setShareWork(ShareWork share);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace uavstab
