// What the stabilizer did to one frame: for plots, trackers downstream, and tests.
//
// Public API: the per-frame results (FrameStats). Fields keep their meaning; new ones are
// added at the end.
#pragma once

#include <cstdint>
#include <vector>

#include "uavstab/similarity.hpp"

namespace uavstab {

// Where the rows of one frame sit relative to its mid-exposure image.
struct RowMotion {
    // Centred luma rows of the band centres (ascending) and, per band, the transform from
    // the mid-exposure image to this frame at that row (a small shift and turn). Empty:
    // every row is where a global shutter would have put it.
    std::vector<double> rows;
    std::vector<Similarity> offsets;
    // RMS over bands of the offset's shift (px): how much the frame is bent.
    double wobble = 0.0;

    bool empty() const { return rows.empty(); }
    // The offset at centred row y, linearly interpolated between band centres (held
    // beyond the first and last).
    Similarity at(double y) const;
    // Where the mid-exposure image has the point this frame captured at p.
    Point2 toMidExposure(Point2 p) const { return empty() ? p : at(p.y).inverse().apply(p); }
};

// A track that survived into a frame (forward-backward check passed, not excluded).
struct TrackedPoint {
    Point2 position;      // in the frame, full-resolution centred coordinates (similarity.hpp)
    bool inlier = false;  // consistent with the fitted motion (false for every point of a skipped frame)
};

struct FrameStats {
    std::int64_t index = 0;   // frames since construction or reset()
    Similarity motion;        // estimated camera motion from the previous frame (raw)
    Similarity trajectory;    // accumulated camera pose (raw path)
    Similarity smoothed;      // smoothed camera pose (the path the output follows)
    Similarity correction;    // applied to the frame: input -> stabilized (before zoom)
    double zoom = 1.0;        // crop zoom of the output
    // What the warper drew: output pixel -> input pixel, centred coordinates
    // (correction^-1 * zoom^-1), so consumers need not rebuild it. With a lens profile,
    // motion, paths, correction and this are in the lens's undistorted (pinhole) view; with
    // lens_output original the crop zoom is applied to the lens's picture instead
    // (lib/src/lens/lens_view.hpp has the whole chain).
    Similarity output_to_input;
    double correction_fraction = 1.0;  // < 1 when the correction was limited to the crop
    MotionModel model = MotionModel::Rigid;
    int points = 0;           // tracks that survived the forward-backward check
    int inliers = 0;          // points consistent with the fitted motion
    bool skipped = false;     // no usable motion for this frame: identity was used
    bool segment_start = false;  // first frame after a start, reset or discontinuity
    // The `points` tracks of this frame with their inlier flags (for debug overlays and
    // analysis; input-frame coordinates: map them with output_to_input.inverse()).
    std::vector<TrackedPoint> tracks;
    // Rolling shutter: where the input's rows sat relative to its mid-exposure, as the
    // warp undid it (empty: not bent). row_motion.wobble is the size.
    RowMotion row_motion;
    // The sensor's readout time as a share of the frame time: the known one
    // (StabilizerConfig::readout_time), else auto's estimate for the stream (0 until it is
    // sure; it then holds), and how sure (0-1; 1 when known).
    double readout = 0.0;
    double readout_confidence = 0.0;
};

} // namespace uavstab
