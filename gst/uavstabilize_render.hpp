// render=warp|affine-meta|auto: whether the element warps frames or sends the input
// downstream untouched with a GstVideoAffineTransformationMeta for a GL element to apply.
#pragma once

#include <gst/gst.h>
#include <gst/video/video.h>

#include "uavstab/similarity.hpp"

namespace gstuavstab {

// The GstVideoAffineTransformationMeta matrix that draws a frame as the warp with
// `output_to_input` (centred similarity of a width x height frame) would.
//
// GStreamer's GL elements (gst_gl_get_affine_transformation_meta_as_ndc) take the meta's
// 4x4 column-major matrix as mapping input positions to output positions in [0, 1]
// coordinates of the frame: u = (x + 0.5) / width, v = (y + 0.5) / height for pixel
// centre (x, y), origin at the top-left corner, v down the rows (checked with glvideomixer
// under Mesa: a translation of +0.25 in matrix[13] moves the picture down by a quarter of
// its height; tests/element/gl_render_test.cpp compares the whole picture with the warp).
void affineMetaMatrix(const uavstab::Similarity &output_to_input, int width, int height, float matrix[16]);

// Adds the meta to `buffer` (writable). An affine meta already there (an upstream element
// transforming its texture) is composed with ours.
void addAffineTransformationMeta(GstBuffer *buffer, const uavstab::Similarity &output_to_input, int width, int height);

} // namespace gstuavstab
