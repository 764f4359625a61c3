// Buffer pools on both sides of the element: the pool output frames are warped into
// (negotiated with downstream), and the pool proposed to upstream for input frames.
#pragma once

#include <gst/gst.h>
#include <gst/video/video.h>

namespace gstuavstab {

struct OutputAllocation {
    GstBufferPool *pool = nullptr;  // active, the caller's reference; null when not asked for
    // Downstream's answer lists GstVideoAffineTransformationMeta: it applies the meta when
    // it draws (glimagesink, glvideomixer).
    bool applies_affine_meta = false;
};

// Sends an ALLOCATION query for `caps` downstream from `srcpad` and, with `want_pool`,
// returns an active pool for output frames: downstream's if it takes our configuration,
// else a video buffer pool of our own. Call with nothing being pushed on `srcpad` but by
// the caller (serialized query). Throws std::runtime_error when no pool can be activated.
OutputAllocation negotiateOutputAllocation(GstPad *srcpad, GstCaps *caps, const GstVideoInfo &info, bool want_pool);

// Answers an ALLOCATION query from upstream: a video buffer pool of at least
// `min_buffers` (sources with fixed pools must not run dry while frames are held) and
// support for GstVideoMeta (padded strides are fine). False for unusable caps.
bool proposeInputAllocation(GstQuery *query, guint min_buffers);

// Answers upstream's ALLOCATION query with downstream's pool, when input buffers go
// downstream as they are (render=affine-meta): upstream then writes frames straight into
// downstream's buffers. For glupload that is a GL pool, whose buffers it passes through
// with their metas; system memory it copies into new buffers and drops the affine meta.
// The pool's minimum is raised to `min_buffers`. False (query untouched) when downstream
// offers no pool that can hold that many.
bool forwardInputAllocation(GstPad *srcpad, GstQuery *query, guint min_buffers);

} // namespace gstuavstab
