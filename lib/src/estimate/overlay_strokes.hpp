// The pixels of a screen-fixed overlay (a flight OSD's text, crosshair, ladders, a logo),
// found in the analysis luma itself, and the luma with them painted over by their
// surroundings before the tracking pyramid is built.
//
// Why the pixels and not only the tracks: Lucas-Kanade's coarse levels see a wide window,
// and an overlay's strokes, sharp and still over a faint scene that moves, pull every
// window that touches them towards "no motion". Excluding the overlay's corners does not
// help then (the hazy OSD flight at 3x the shake, 640x360: ~25 of 50 tracks lost each
// frame and 5-10 frames skipped, even with the overlay's boxes excluded by hand); painting
// its strokes over does (the same flight with them painted over tracks as if there were
// no overlay).
//
// A pixel is taken for an overlay when it stays the same in frames the camera saw from
// positions spread in two directions (a scene's edge changes in one of them at least)
// and stands out from its neighbourhood (a flat patch of scene stays the same too).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "uavstab/similarity.hpp"

namespace uavstab {

class OverlayStrokes {
public:
    // The camera's motion from the previous frame to this one, as the estimator found it
    // (frame-to-previous similarity, full-resolution centred coordinates), `scale` full
    // resolution px per analysis px; skipped (unknown) motion ends the chain of samples.
    void cameraMoved(const Similarity &current_to_previous, double scale);
    void motionUnknown();
    // Returns the luma (analysis resolution) to track on: `luma` itself when no overlay is
    // known, else `painted` with the overlay's pixels painted over. The frame is kept as a
    // sample if the motion cameraMoved() then gives has taken the camera far enough from
    // the last one: `luma` must stay unchanged until then.
    const cv::Mat &paint(const cv::Mat &luma, cv::Mat &painted);
    // The current overlay mask (255 = overlay), empty when none is known.
    const cv::Mat &mask() const { return mask_; }
    void reset();

private:
    struct Sample {
        cv::Mat luma;
        Point2 position;  // the camera's position when it was taken (analysis px)
    };
    void rebuildMask();
    bool samplesSpreadInTwoDirections() const;

    std::vector<Sample> samples_;
    Point2 position_{0.0, 0.0};  // the camera's accumulated translation (analysis px)
    cv::Mat pending_;            // the last frame's luma (not a copy), a sample once its motion is known
    int samples_since_rebuild_ = 0;
    cv::Mat low_, high_;         // per-pixel range over the samples
    cv::Mat mask_;
    // Of the mask, for the painting: the area it touches (the mask's box grown by the
    // painting's radius), the scene's weights there and their box filter.
    cv::Rect paint_area_;
    cv::Mat weight_, blurred_weight_;
    cv::Mat blurred_, fill_;  // the painting's scratch
};

} // namespace uavstab
