// Buffer pools on both sides of the element: the pool output frames are warped into
// (negotiated with downstream), and the pool proposed to upstream for input frames.
#pragma once

#include <gst/gst.h>
#include <gst/video/video.h>

namespace gstuavstab {

// Sends an ALLOCATION query for `caps` downstream from `srcpad` and returns an active
// pool for output frames: downstream's if it takes our configuration, else a video
// buffer pool of our own. Call with nothing being pushed on `srcpad` (serialized
// query). Throws std::runtime_error when no pool can be activated.
GstBufferPool *negotiateOutputPool(GstPad *srcpad, GstCaps *caps, const GstVideoInfo &info);

// Answers an ALLOCATION query from upstream: a video buffer pool of at least
// `min_buffers` (sources with fixed pools must not run dry while frames are held) and
// support for GstVideoMeta (padded strides are fine). False for unusable caps.
bool proposeInputAllocation(GstQuery *query, guint min_buffers);

} // namespace gstuavstab
