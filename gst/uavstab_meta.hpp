// The plugin's side of GstUavStabMeta (the public, read-only side is uavstab_meta.h):
// registering it, filling it from the stabilizer's statistics, and keeping region of
// interest metas consistent with the warp.
#pragma once

#include <gst/gst.h>

#include "uavstab/stabilizer.hpp"
#include "uavstab_meta.h"

namespace gstuavstab {

// Registers the meta's API type and implementation (once; at plugin load).
const GstMetaInfo *registerStabMeta();

// The pixel-coordinate 3x3 matrix (row-major) of a centred similarity on a width x height
// frame.
void pixelMatrix3x3(const uavstab::Similarity &s, int width, int height, double m[9]);

// What went downstream for `frame`: the library's outcome, told apart by what the element
// did with it (`warped`: the buffer holds the warped frame; `affine_meta`: the input with
// an affine meta).
GstUavStabOutcome outcomeOf(const uavstab::StabilizedFrame &frame, bool warped, bool affine_meta);

// Attaches this element's meta for `frame` to `buffer` (the buffer that goes out; made
// writable, so the result may be another GstBuffer sharing the same memory, and any
// GstUavStabMeta of an earlier uavstabilize is replaced). The matrix is the frame's
// mapping for WARPED and AFFINE_META, else the identity (the input, untouched).
// Takes over the reference to `buffer` and returns the reference to push.
GstBuffer *attachStabMeta(GstBuffer *buffer, const uavstab::StabilizedFrame &frame, int width, int height,
                          GstUavStabOutcome outcome);

// Adds to `output` every GstVideoRegionOfInterestMeta of `input`, its box mapped into the
// warped frame: the bounding box of its four corners through the inverse of
// `output_to_input` (centred similarity of a width x height frame), rounded and clipped
// to the frame; a box that ends up empty (entirely outside the output) is left out. Type,
// id, parent_id and params are kept.
void mapRegionsOfInterest(GstBuffer *input, GstBuffer *output, const uavstab::Similarity &output_to_input, int width,
                          int height);

} // namespace gstuavstab
