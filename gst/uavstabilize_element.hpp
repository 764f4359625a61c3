// The uavstabilize element's insides, shared by the files that implement it, one job
// each:
//
//   gstuavstabilize.cpp          GObject glue: class, instance, pads, properties, pad
//                                activation and state changes
//   uavstabilize_settings.cpp    the properties as the streaming thread and queries see them
//   uavstabilize_sink.cpp        the sink pad: chain (input buffers) and events
//   uavstabilize_src_task.cpp    the src pad task: pushes the output in order
//   uavstabilize_queries.cpp     queries on both pads
//   uavstabilize_render.cpp      render=auto|warp|affine-meta: the output negotiation and
//                                what frames left unwarped get
//   output_channel.cpp           the state those threads share: the ordered output queue,
//                                the output pool and the flow flags, under one mutex
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <memory>
#include <set>
#include <string>

#include <gst/gst.h>
#include <gst/video/video.h>

#include "frame_timing.hpp"
#include "gst_frame_slot.hpp"
#include "gstuavstabilize.hpp"
#include "output_channel.hpp"
#include "uavstab/stabilizer.hpp"
#include "uavstabilize_settings.hpp"

GST_DEBUG_CATEGORY_EXTERN(gst_uav_stabilize_debug);

// Per-stream state, created with the element, filled at READY->PAUSED and caps time.
struct UavStabilizeState final : OutputBufferSource {
    explicit UavStabilizeState(GstObject *owner) : output(owner) {}
    ~UavStabilizeState() override;
    GstBuffer *acquireOutputBuffer() override { return output.acquireBuffer(); }
    bool leavesFramesUnwarped() override { return render_affine_meta.load(); }

    // Shared between the streaming thread, the task, the workers' ready callback,
    // flushing threads and state changes; thread-safe (OutputChannel's mutex).
    OutputChannel output;
    // Written by the streaming thread, read by LATENCY queries; thread-safe.
    FrameTiming timing;
    // Rendering, decided at each output negotiation (caps on the streaming thread,
    // RECONFIGURE on the task) and setting change; read by both threads.
    std::atomic<bool> downstream_applies_affine_meta{false};
    std::atomic<bool> render_affine_meta{false};       // frames go out unwarped, with an affine meta
    std::atomic<int> render_mode{int(RenderMode::Auto)};  // the `render` setting it was decided under

    // Streaming thread only (under the sink pad's stream lock), except that the task
    // thread uses `stabilizer` (tryPop) while the pads are active.
    std::unique_ptr<uavstab::Stabilizer> stabilizer;
    GstCaps *caps = nullptr;
    GstVideoInfo info{};
    std::size_t max_finalized = 0;       // chain backpressure: finalized frames not yet popped
    std::size_t max_drain_finalized = 0; // the same for a drain (EOS, new caps)
    int bad_buffers = 0;                 // consecutive input buffers dropped as unreadable
    const void *checked_pool = nullptr;  // the upstream pool last looked at...
    guint checked_needed = 0;            // ...and the buffers we needed then
    bool copy_from_pool = false;         // its buffers are too few to hold: copy frames

    // Task thread only (or with the task stopped).
    GstSegment output_segment{};
    std::set<std::string> reported_errors;
};

struct _GstUavStabilize {
    GstElement parent;
    GstPad *sinkpad;
    GstPad *srcpad;
    UavStabilizeSettings *settings;  // under the object lock
    UavStabilizeState *state;
};

namespace gstuavstab {

// Input buffers we may hold beyond `delay`: being estimated, being warped, being pushed.
constexpr guint kExtraInputBuffers = 4;

// Chain backpressure (max_finalized): the frame the delay lets go of is finalized, takes an
// output buffer and starts its warp only once fewer finalized frames than the warp threads
// (each holding an input and an output buffer) wait for their warp or for the task. So every
// warp thread can have a frame while the next one is estimated, and no more is in flight;
// with one thread the output pool holds two buffers (one being warped, one being pushed).
// tests/bench/uavstab-bench-memory: 1080p heap peak 36.6 frames when threads + 2 finalized
// frames could wait (and the wait came before estimation), 28.6 with none.
inline std::size_t maxFinalizedFor(int threads)
{
    return std::size_t(std::max(1, threads) - 1);
}

struct BufferUnref {
    void operator()(GstBuffer *buffer) const { gst_buffer_unref(buffer); }
};
using BufferPtr = std::unique_ptr<GstBuffer, BufferUnref>;

inline UavStabilizeState &stateOf(GstUavStabilize *self)
{
    return *self->state;
}

// --- Settings (uavstabilize_settings.cpp): each a read under the object lock.

// The stabilizer's config; the settings count as applied from now on.
uavstab::StabilizerConfig takeConfig(GstUavStabilize *self);
guint currentDelay(GstUavStabilize *self);
bool postMessagesEnabled(GstUavStabilize *self);
int maxErrors(GstUavStabilize *self);
// Streaming thread: hands properties changed since the last frame to the stabilizer.
void applyChangedSettings(GstUavStabilize *self, UavStabilizeState &s);
void postLatencyChanged(GstUavStabilize *self);

// --- Sink pad (uavstabilize_sink.cpp)

GstFlowReturn sinkChain(GstPad *pad, GstObject *parent, GstBuffer *buffer);
gboolean sinkEvent(GstPad *pad, GstObject *parent, GstEvent *event);
// Streaming thread: finalizes every held frame (end of stream, caps change, drain), one
// at a time with the chain's backpressure. False when flushing or downstream stopped.
bool finalizeHeldFrames(UavStabilizeState &s);
// A C++ exception at a pad boundary: a frame or event may be missing from the ordered
// output, so the stream stops the way a downstream error stops it.
void failStream(GstUavStabilize *self, UavStabilizeState &s, const char *what, const std::exception &e);

// --- Src pad task (uavstabilize_src_task.cpp)

void srcLoop(gpointer user_data);
// (Re)starts the task if the src pad is active.
void startTask(GstUavStabilize *self);

// --- Rendering (uavstabilize_render.cpp)

// Sets render_affine_meta from the `render` and debug-overlay settings and downstream's
// last answer; logs the decision when `negotiated` or when it changed.
void decideRendering(GstUavStabilize *self, UavStabilizeState &s, bool negotiated);
// Asks downstream for its allocation for `caps` (output pool unless render=affine-meta)
// and decides the rendering. Nothing else may push on the src pad meanwhile.
void negotiateOutput(GstUavStabilize *self, UavStabilizeState &s, GstCaps *caps, const GstVideoInfo &info);
// The same for the src pad's current caps (the task, on RECONFIGURE).
void renegotiateOutput(GstUavStabilize *self, UavStabilizeState &s);
// render=auto: a frame left unwarped that needs the warp after all (a rolling-shutter
// wobble to correct).
bool warpsLeftUnwarpedFrame(const UavStabilizeState &s, const uavstab::StabilizedFrame &frame);
// Warps such a frame here (the task thread) as the stabilizer would have; returns the
// warped buffer, stamped and with its regions of interest mapped, or null when there is
// no output buffer (flushing).
GstBuffer *warpLeftUnwarpedFrame(GstUavStabilize *self, UavStabilizeState &s, uavstab::StabilizedFrame &frame);

// --- Queries (uavstabilize_queries.cpp)

gboolean sinkQuery(GstPad *pad, GstObject *parent, GstQuery *query);
gboolean srcQuery(GstPad *pad, GstObject *parent, GstQuery *query);

} // namespace gstuavstab
