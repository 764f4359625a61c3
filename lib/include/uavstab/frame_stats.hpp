// What the stabilizer did to one frame: for plots, trackers downstream, and tests.
#pragma once

#include <cstdint>

#include "uavstab/motion_model.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

struct FrameStats {
    std::int64_t index = 0;   // frames since construction or reset()
    Similarity motion;        // estimated camera motion from the previous frame (raw)
    Similarity trajectory;    // accumulated camera pose (raw path)
    Similarity smoothed;      // smoothed camera pose (the path the output follows)
    Similarity correction;    // applied to the frame: input -> stabilized (before zoom)
    double zoom = 1.0;        // crop zoom of the output
    // What the warper drew: output pixel -> input pixel, centred coordinates
    // (correction^-1 * zoom^-1), so consumers need not rebuild it.
    Similarity output_to_input;
    double correction_fraction = 1.0;  // < 1 when the correction was limited to the crop
    MotionModel model = MotionModel::Rigid;
    int points = 0;           // tracks that survived the forward-backward check
    int inliers = 0;          // points consistent with the fitted motion
    bool skipped = false;     // no usable motion for this frame: identity was used
    bool segment_start = false;  // first frame after a start, reset or discontinuity
};

} // namespace uavstab
