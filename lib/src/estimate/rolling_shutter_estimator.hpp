// Rolling shutter: how the camera moved while a frame was read out, row by row.
//
// A CMOS sensor reads its rows one after another over most of the frame time. When the
// camera vibrates (propellers) each row sees it somewhere else, and the frame bends
// (wobble, "jello"). The estimator finds, from the tracked points alone, where each row
// of a frame sits relative to the image a global shutter would have taken at the frame's
// mid-exposure (its middle row); the warp then samples each output row through its own
// transform, so that the output is that mid-exposure image (frame_warper.hpp).
//
// How: after the frame-to-frame similarity is fitted, what is left of the tracks'
// motion is fitted by a smooth mixture of small per-band motions (a shift and a turn per
// horizontal band, Gaussian weights between bands, differences between neighbouring
// bands penalised: Grundmann, Kwatra, Castro, Essa, "Calibration-free rolling shutter
// removal", ICCP 2012). Those are differences between this frame's row offsets and the
// previous frame's at the same rows; the offsets are their leaky sum (so an error fades
// instead of staying for good), pinned to zero at the middle row. A camera moving at
// constant speed skews every frame alike and leaves no such difference: with the readout
// time known, that skew is added from the estimated mean speed.
//
// When: a camera's shutter does not change within a stream, so the decision is the
// stream's. With the readout time unknown, the correction is switched on once the bands,
// fitted on half the tracks, have explained the other half clearly better than the frame's
// one transform over several frames (and off again when they no longer do); tracks that
// stand still on the screen while the scene moves (a burned-in OSD) are left out. The
// readout time is estimated over the stream from how the rows' skew follows the camera's
// speed, and held once it is sure; a stream it is sure has a global shutter is never
// corrected. A known readout time (the settings) is used as it is, never estimated.
#pragma once

#include <vector>

#include "uavstab/frame_stats.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

class RollingShutterEstimator {
public:
    struct Settings {
        int bands = 12;
        // Share of the frame time over which rows are read, when known (0: unknown, only
        // the changes from frame to frame are corrected).
        double readout = 0.0;
        // Unknown readout (auto): no correction while the bands' residual motion stays
        // below `threshold` px RMS (at 640 px of width; it grows with the frame), full at
        // 1.5 times that. The residual is averaged over about `settle` frames.
        bool automatic = true;
        double threshold = 0.3;
        int settle = 15;
        // ...and the stream's correction is switched on only once the bands have explained
        // the tracks clearly better than the frame's one transform, over time: the share of
        // the residual the bands fitted on every other track remove from the rest,
        // averaged over up to 2 * `settle` frames, at least `evidence_on` after
        // `decide_frames` frames or more; it is switched off again below `evidence_off`.
        // Noise, an overlay or parallax fitted by bands does not carry over to the other
        // tracks (global-shutter flights with an OSD: single frames up to 0.75, the average
        // below 0; rolling-shutter flights: 0.8-0.97 from the first frame).
        int decide_frames = 5;
        double evidence_on = 0.5;
        double evidence_off = 0.2;
        // Tracks the frame's transform moves by more than `static_motion` px (at 640) that
        // stay within a quarter of that on the screen are an overlay: left out of the fit.
        double static_motion = 1.0;
        // Each frame keeps this share of the previous frame's offsets before adding its
        // own differences: an estimation error fades over some 20 frames. Higher follows a
        // vibration that beats slowly with the frame rate better (a 60 Hz flight read out
        // over 50 % of the frame time kept 0.52x of its wobble at 0.85, 0.31x at 0.93, 0.27x
        // at 0.95) but lets a bias that repeats from frame to frame build up, as parallax
        // does (held in check by the estimator's cap on the bend: rolling_shutter_estimator.cpp).
        double leak = 0.95;
        // Penalty on differences between neighbouring bands and on the size of each band's
        // motion, per tracked point (px^2 per px^2).
        double band_smoothness = 0.02;
        double band_ridge = 0.002;
        // Tracks off their bands' motion by twice this (px at 640 px of width) no longer
        // count (Tukey's biweight): an overlay or a moving object is not a shutter.
        double robust = 2.0;
    };

    explicit RollingShutterEstimator(const Settings &settings);
    RollingShutterEstimator() : RollingShutterEstimator(Settings{}) {}

    // One frame: the tracks' positions in the previous frame and this one (centred,
    // full resolution), and the motion fitted to them (this frame -> previous). Returns
    // this frame's row offsets: empty when no wobble is found or too few tracks. The
    // motion between the mid-exposures is then the fit repeated on the tracks moved by
    // RowMotion::toMidExposure (the motion estimator does that).
    RowMotion estimate(const std::vector<Point2> &previous, const std::vector<Point2> &current,
                       const Similarity &motion, int width, int height);
    // The next frame starts afresh (a scene cut): the stream's decision and readout stay.
    void reset();
    // A new stream (another camera, perhaps): everything starts afresh.
    void restartStream();
    void setSettings(const Settings &settings);
    // The residual level the automatic mode compares with its threshold (px at 640).
    double residualLevel() const { return level_; }
    // Whether the last frame's rows were moved (a known readout, or auto found a wobble).
    bool applied() const { return applied_; }
    // When the correction switched on at the last frame: the frame before's rows as it would
    // have corrected them (else empty), for the motion between the two mid-exposures.
    const RowMotion &previousRows() const { return previous_rows_; }
    // Auto: the averaged share of the held-out tracks' residual the bands explain.
    double evidence() const { return evidence_; }
    // The readout in use, as a share of the frame time: the known one (settings), else
    // the stream's estimate (0 until one is confident; it then holds), and how sure that
    // estimate is (0-1; 1 for a known readout).
    double readout() const;
    double readoutConfidence() const;

private:
    struct ReadoutFit {
        // Least squares of the bands' skew changes on the camera's speed changes, over
        // the stream (sums), and the value held once confident.
        double sxy = 0.0, sxx = 0.0, syy = 0.0;
        int samples = 0;
        double held = 0.0, confidence = 0.0;
        Similarity previous_motion;
        bool has_previous = false;
    };
    void updateReadout(const std::vector<double> &band_differences, const Similarity &motion, int band_count,
                       int height);

    Settings settings_;
    int width_ = 0, height_ = 0;
    // The previous frame's offsets, 3 per band (x, y, turn in px at half the width).
    std::vector<double> offsets_;
    Similarity mean_velocity_;  // known readout: the motion's leaky average
    double level_ = 0.0;
    double evidence_ = 0.0;
    int evidence_frames_ = 0;
    bool latched_ = false;  // auto: the stream's correction is on
    bool applied_ = false;
    RowMotion previous_rows_;
    int frames_ = 0;
    ReadoutFit readout_fit_;
};

} // namespace uavstab
