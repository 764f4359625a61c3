// The sink pad: input buffers (chain) and events, on the streaming thread. Each buffer is
// mapped without a copy and pushed into the stabilizer, which estimates its motion here;
// a "next frame" placeholder goes into the ordered output, where serialized events keep
// their place behind the frames that came before them.
#include <memory>
#include <stdexcept>

#include "output_pool.hpp"
#include "uavstabilize_element.hpp"

#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace gstuavstab {

namespace {

// Streaming thread: backpressure. Waits until few enough finalized frames, each with an
// output buffer, wait for the src task, or until flushing or downstream stopped taking
// data; returns the flow.
GstFlowReturn waitForOutputRoom(UavStabilizeState &s)
{
    return s.output.waitForRoom([&s] { return s.stabilizer->finalizedCount() <= s.max_finalized; });
}

// Streaming thread, with the output queue drained and the new caps pushed.
void negotiateOutputPool(GstUavStabilize *self, UavStabilizeState &s)
{
    // This negotiation answers any RECONFIGURE so far; the task answers later ones.
    gst_pad_check_reconfigure(self->srcpad);
    negotiateOutput(self, s, s.caps, s.info);
}

// ---------------------------------------------------------------------------------
// Data

// A source whose fixed pool holds fewer buffers than we keep (v4l2src with a handful of
// buffers, when it did not take up our allocation proposal) would starve waiting for
// buffers we only give back `delay` frames later. Its frames are copied instead, and its
// buffers go back at once. One copy per frame, only for such sources.
BufferPtr detachFromSmallPool(GstUavStabilize *self, UavStabilizeState &s, BufferPtr buffer)
{
    GstBufferPool *pool = buffer->pool;
    if (!pool)
        return buffer;
    const guint needed = currentDelay(self) + kExtraInputBuffers;
    if (pool != s.checked_pool || needed != s.checked_needed) {
        GstStructure *config = gst_buffer_pool_get_config(pool);
        guint min = 0, max = 0;
        gst_buffer_pool_config_get_params(config, nullptr, nullptr, &min, &max);
        gst_structure_free(config);
        s.checked_pool = pool;  // identity only; never dereferenced later
        s.checked_needed = needed;
        s.copy_from_pool = max != 0 && max < needed;
        if (s.copy_from_pool)
            GST_WARNING_OBJECT(self, "upstream pool %" GST_PTR_FORMAT " holds at most %u buffers but %u are held "
                               "here: copying its frames so that it never starves", pool, max, needed);
    }
    if (!s.copy_from_pool)
        return buffer;
    return BufferPtr(gst_buffer_copy_deep(buffer.get()));
}

// A buffer that does not hold a frame of the caps (too small, or it cannot be mapped) is
// dropped with a warning and the camera path restarts after it, as after a DISCONT; the
// frames held before it and the stream go on. Like GstVideoDecoder's max-errors, only a
// bad buffer after max-errors consecutive ones is an error (-1: never).
GstFlowReturn dropBadBuffer(GstUavStabilize *self, UavStabilizeState &s, gsize size, GstClockTime pts)
{
    ++s.bad_buffers;
    const int max_errors = maxErrors(self);
    const bool fatal = max_errors >= 0 && s.bad_buffers > max_errors;
    if (fatal) {
        GST_ELEMENT_ERROR(self, STREAM, FORMAT, ("buffer too small for caps, or unreadable"),
                          ("a %" G_GSIZE_FORMAT "-byte buffer (PTS %" GST_TIME_FORMAT ") cannot be read as a %dx%d %s "
                           "frame (%" G_GSIZE_FORMAT " bytes): %d bad buffers in a row, more than max-errors=%d",
                           size, GST_TIME_ARGS(pts), GST_VIDEO_INFO_WIDTH(&s.info), GST_VIDEO_INFO_HEIGHT(&s.info),
                           GST_VIDEO_INFO_NAME(&s.info), GST_VIDEO_INFO_SIZE(&s.info), s.bad_buffers, max_errors));
        return GST_FLOW_ERROR;
    }
    GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("buffer too small for caps, or unreadable: dropped"),
                        ("a %" G_GSIZE_FORMAT "-byte buffer (PTS %" GST_TIME_FORMAT ") cannot be read as a %dx%d %s "
                         "frame (%" G_GSIZE_FORMAT " bytes); dropped (%d in a row, max-errors=%d)",
                         size, GST_TIME_ARGS(pts), GST_VIDEO_INFO_WIDTH(&s.info), GST_VIDEO_INFO_HEIGHT(&s.info),
                         GST_VIDEO_INFO_NAME(&s.info), GST_VIDEO_INFO_SIZE(&s.info), s.bad_buffers, max_errors));
    s.stabilizer->markDiscontinuity();
    return GST_FLOW_OK;
}

GstFlowReturn chainFrame(GstUavStabilize *self, UavStabilizeState &s, BufferPtr buffer)
{
    const GstFlowReturn flow = s.output.flow();
    if (flow != GST_FLOW_OK)
        return flow;
    s.timing.noteBuffer(buffer.get());
    if (!s.caps || !s.stabilizer) {
        GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, (nullptr), ("received a buffer before caps"));
        return GST_FLOW_NOT_NEGOTIATED;
    }
    applyChangedSettings(self, s);
    decideRendering(self, s, false);  // debug-overlay may have changed
    // A known sensor readout time is a share of this.
    const GstClockTime frame_duration = s.timing.frameDuration();
    s.stabilizer->setFrameInterval(GST_CLOCK_TIME_IS_VALID(frame_duration) ? double(frame_duration) / GST_MSECOND
                                                                            : 0.0);
    if (GST_BUFFER_IS_DISCONT(buffer.get()))
        s.stabilizer->markDiscontinuity();
    buffer = detachFromSmallPool(self, s, std::move(buffer));

    const gsize buffer_size = gst_buffer_get_size(buffer.get());
    const GstClockTime pts = GST_BUFFER_PTS(buffer.get());
    std::unique_ptr<GstFrameSlot> slot = GstFrameSlot::map(buffer.release(), s.info, s);
    if (!slot)
        return dropBadBuffer(self, s, buffer_size, pts);
    s.bad_buffers = 0;

    // The frame takes its place in the output order and its motion is estimated while
    // earlier frames are warped. Backpressure comes after that: the frame the delay lets
    // go of takes an output buffer (and its warp starts) only once few enough finalized
    // frames, each holding an input and an output buffer, wait for their warp or for the
    // task; so memory stays bounded when downstream is slower than the warps, and few
    // frames are in flight when it is not.
    const GstFlowReturn ret = s.output.queueFrameWhenRoom([] { return true; });
    if (ret != GST_FLOW_OK)
        return ret;
    s.stabilizer->pushHeld(std::move(slot));
    while (s.stabilizer->dueCount() > 0) {
        const GstFlowReturn room = waitForOutputRoom(s);
        if (room != GST_FLOW_OK)
            return room;  // the frame stays held: a flush drops it, a drain finalizes it
        s.stabilizer->finalizeDue();
    }
    return GST_FLOW_OK;
}

// ---------------------------------------------------------------------------------
// Events

// Serialized events wait behind the frames that came before them.
bool queueEvent(GstUavStabilize *self, UavStabilizeState &s, EventPtr event)
{
    switch (s.output.queueEvent(std::move(event))) {
    case OutputChannel::EventQueued::Refused:
        return false;
    case OutputChannel::EventQueued::QueuedAfterEos:
        startTask(self);
        return true;
    case OutputChannel::EventQueued::Queued:
        break;
    }
    return true;
}

bool handleCaps(GstUavStabilize *self, UavStabilizeState &s, EventPtr event)
{
    GstCaps *caps = nullptr;
    gst_event_parse_caps(event.get(), &caps);
    GstVideoInfo info;
    if (!gst_video_info_from_caps(&info, caps) || !pixelFormatFor(GST_VIDEO_INFO_FORMAT(&info))) {
        GST_WARNING_OBJECT(self, "unusable caps %" GST_PTR_FORMAT, caps);
        return false;
    }
    if (s.caps && gst_caps_is_equal(s.caps, caps))
        return queueEvent(self, s, std::move(event));

    // New caps: the frames held so far go out first, with the old caps, then the
    // stabilizer starts a new path for the new geometry.
    GST_DEBUG_OBJECT(self, "new caps %" GST_PTR_FORMAT, caps);
    if (!finalizeHeldFrames(s) || !s.output.waitUntilDrained())
        return false;
    if (s.stabilizer) {
        s.stabilizer->reset();
        try {
            s.stabilizer->checkFrameSize(GST_VIDEO_INFO_WIDTH(&info), GST_VIDEO_INFO_HEIGHT(&info));
        } catch (const std::exception &e) {
            GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, ("The lens profile is not for frames of %dx%d",
                                                       GST_VIDEO_INFO_WIDTH(&info), GST_VIDEO_INFO_HEIGHT(&info)),
                              ("%s", e.what()));
            return false;
        }
    }

    gst_caps_replace(&s.caps, caps);
    s.info = info;
    s.checked_pool = nullptr;  // new caps, new upstream pool
    const bool framerate_changed = s.timing.setFramerate(GST_VIDEO_INFO_FPS_N(&info), GST_VIDEO_INFO_FPS_D(&info));
    // The task is idle with the queue empty, so pushing from here keeps the order.
    const bool pushed = gst_pad_push_event(self->srcpad, event.release());
    negotiateOutputPool(self, s);
    if (framerate_changed)
        postLatencyChanged(self);
    return pushed;
}

bool handleFlushStop(GstUavStabilize *self, UavStabilizeState &s, EventPtr event)
{
    // The task sees the flag (set by FLUSH_START, or here for a FLUSH_STOP without one)
    // and pauses itself; wait for that before throwing frames away. It is done here and
    // not at FLUSH_START: a FLUSH_STOP of another flush may come in while a FLUSH_START is
    // still being handled, and a pause there would then stop the task this FLUSH_STOP
    // restarts (or wait for it forever while no data comes).
    s.output.startFlushing();
    gst_pad_pause_task(self->srcpad);
    // Drops every held frame and restarts the path; not under the output's mutex, since
    // resetting waits for warps whose ready callback takes it.
    if (s.stabilizer)
        s.stabilizer->reset();
    // Sticky events still queued (STREAM_START, CAPS, TAG) will not come again from
    // upstream: stored on the src pad, they go out before the next data.
    for (const EventPtr &sticky : s.output.stopFlushing())
        gst_pad_store_sticky_event(self->srcpad, sticky.get());
    gst_segment_init(&s.output_segment, GST_FORMAT_UNDEFINED);
    s.bad_buffers = 0;
    const bool pushed = gst_pad_push_event(self->srcpad, event.release());
    startTask(self);
    return pushed;
}

bool handleSinkEvent(GstUavStabilize *self, UavStabilizeState &s, EventPtr event)
{
    GST_LOG_OBJECT(self, "sink event %" GST_PTR_FORMAT, event.get());
    switch (GST_EVENT_TYPE(event.get())) {
    case GST_EVENT_FLUSH_START:
        // Stops the chain and the task (a push in progress returns: downstream is
        // flushing too); FLUSH_STOP waits for the task to have paused.
        s.output.startFlushing();
        return gst_pad_push_event(self->srcpad, event.release());
    case GST_EVENT_FLUSH_STOP:
        return handleFlushStop(self, s, std::move(event));
    case GST_EVENT_CAPS:
        return handleCaps(self, s, std::move(event));
    case GST_EVENT_EOS:
        // Every held frame goes out (truncated smoothing window), then EOS. If a flush
        // interrupts the drain, EOS is dropped with the frames, as a flush does.
        if (!finalizeHeldFrames(s) && s.output.flushing())
            return false;
        return queueEvent(self, s, std::move(event));
    case GST_EVENT_GAP:
    case GST_EVENT_STREAM_START:
        // No motion is estimated across a gap or into a new stream.
        if (s.stabilizer)
            s.stabilizer->markDiscontinuity();
        return queueEvent(self, s, std::move(event));
    default:
        if (GST_EVENT_IS_SERIALIZED(event.get()))
            return queueEvent(self, s, std::move(event));
        return gst_pad_push_event(self->srcpad, event.release());
    }
}

} // namespace

bool finalizeHeldFrames(UavStabilizeState &s)
{
    if (!s.stabilizer)
        return true;
    // A drain (EOS, new caps) may go on while downstream holds on to a frame (a sink
    // prerolling, a blocked push): it keeps up to max_drain_finalized frames in flight, so
    // that an event behind a short delay does not wait for downstream.
    for (;;) {
        if (s.output.waitForRoom([&s] { return s.stabilizer->finalizedCount() <= s.max_drain_finalized; }) !=
            GST_FLOW_OK)
            return false;
        if (!s.stabilizer->flushOne())
            return true;
    }
}

void failStream(GstUavStabilize *self, UavStabilizeState &s, const char *what, const std::exception &e)
{
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s", what), ("%s", e.what()));
    s.output.recordError();
}

GstFlowReturn sinkChain(GstPad *, GstObject *parent, GstBuffer *buffer)
{
    auto *self = GST_UAV_STABILIZE(parent);
    try {
        return chainFrame(self, stateOf(self), BufferPtr(buffer));
    } catch (const std::exception &e) {
        failStream(self, stateOf(self), "Stabilizing a frame failed", e);
        return GST_FLOW_ERROR;
    }
}

gboolean sinkEvent(GstPad *, GstObject *parent, GstEvent *event)
{
    auto *self = GST_UAV_STABILIZE(parent);
    EventPtr owned(event);
    try {
        return handleSinkEvent(self, stateOf(self), std::move(owned));
    } catch (const std::exception &e) {
        failStream(self, stateOf(self), "Handling an event failed", e);
        return FALSE;
    }
}

} // namespace gstuavstab
