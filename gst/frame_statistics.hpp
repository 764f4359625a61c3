// The per-frame element message (post-messages=true): what the stabilizer measured and
// did, named "uavstabilize". Angles are in radians, translations in pixels.
//
// Fields: timestamp (guint64, the frame's PTS), running-time and stream-time (guint64,
// with a TIME segment), index (gint64, frames since start or flush), motion-*,
// trajectory-*, smoothed-*, correction-* (each -dx, -dy, -angle, -scale: doubles), zoom,
// correction-fraction (double), model ("rigid" or "similarity"), points, inliers (int),
// skipped, segment-start (boolean), outcome ("warped", "bypassed", "no-output", "failed",
// "affine-meta").
#pragma once

#include <gst/gst.h>

#include "uavstab/stabilizer.hpp"
#include "uavstab_meta.h"

namespace gstuavstab {

// `outcome`: what went downstream (the meta's outcome).
GstStructure *frameStatistics(const uavstab::StabilizedFrame &frame, GstUavStabOutcome outcome, GstClockTime pts,
                              const GstSegment &segment);

} // namespace gstuavstab
