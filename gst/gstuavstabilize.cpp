/**
 * SECTION:element-uavstabilize
 * @title: uavstabilize
 *
 * Real-time video stabilization for UAV footage (Lim et al., "Real-Time Optical
 * flow-based Video Stabilization for UAVs"): corners are tracked with pyramidal
 * Lucas-Kanade optical flow, a rigid or similarity motion is fitted per frame, the
 * camera path is smoothed over a window of frames and every frame is warped onto the
 * smoothed path, zoomed in by #GstUavStabilize:crop to hide the borders.
 *
 * The element holds #GstUavStabilize:delay frames so that the smoothing window can look
 * ahead; the LATENCY query reports delay × frame duration on top of upstream's latency.
 * With #GstUavStabilize:post-messages, an element message named `uavstabilize` is posted
 * per frame with the estimated motion, the camera path, the smoothed path and the applied
 * correction (angles in radians); frame_statistics.hpp lists the fields.
 *
 * ## Example launch lines
 * |[
 * gst-launch-1.0 filesrc location=flight.mp4 ! decodebin ! videoconvert ! uavstabilize ! videoconvert ! autovideosink
 * gst-launch-1.0 v4l2src ! video/x-raw,format=NV12 ! uavstabilize delay=10 crop=0.1 ! videoconvert ! autovideosink
 * gst-launch-1.0 -m filesrc location=flight.y4m ! y4mdec ! uavstabilize post-messages=true ! fakesink
 * ]|
 *
 * ## Design
 * A plain element, not a base transform: base transforms forward serialized events
 * ahead of the frames they hold and drop input on QoS. The sink pad's streaming thread
 * maps each input buffer (no copy) and pushes it into the uavstab::Stabilizer, which
 * estimates motion there and warps on its worker pool. An ordered output queue records
 * "next frame" placeholders and serialized events in arrival order; a task on the src
 * pad (like `queue`) pushes each frame as soon as its warp is done, and each event once
 * the frames before it are out.
 */
#include "gstuavstabilize.hpp"

#include <algorithm>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>

#include <gst/video/video.h>

#include "frame_statistics.hpp"
#include "gst_frame_slot.hpp"
#include "output_pool.hpp"
#include "output_queue.hpp"
#include "uavstab/stabilizer.hpp"
#include "uavstabilize_properties.hpp"
#include "uavstabilize_settings.hpp"

GST_DEBUG_CATEGORY(gst_uav_stabilize_debug);
#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace {

#define UAVSTABILIZE_CAPS                                                                                     \
    "video/x-raw, "                                                                                           \
    "format = (string) { I420, YV12, NV12, NV21, GRAY8, RGB, BGR, RGBA, BGRA, RGBx, BGRx }, "                \
    "width = (int) [ 16, MAX ], height = (int) [ 16, MAX ], framerate = (fraction) [ 0/1, MAX ], "              \
    "interlace-mode = (string) progressive"

GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(UAVSTABILIZE_CAPS));
GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(UAVSTABILIZE_CAPS));

constexpr const char *kDescription =
    "Stabilizes shaky aerial (UAV) video in real time: tracks corners with pyramidal Lucas-Kanade "
    "optical flow, fits a rigid or similarity motion per frame, smooths the camera path over a "
    "window of frames and warps every frame onto the smoothed path, zoomed in by 'crop' to hide "
    "the borders. Output is 'delay' frames late (reported as latency) so the smoothing window can "
    "look ahead. With post-messages=true an element message 'uavstabilize' is posted per frame "
    "(motion, trajectory, smoothed path, correction; angles in radians).\n"
    "\n"
    "Example launch lines:\n"
    "  gst-launch-1.0 filesrc location=flight.mp4 ! decodebin ! videoconvert ! uavstabilize ! "
    "videoconvert ! autovideosink\n"
    "  gst-launch-1.0 v4l2src ! video/x-raw,format=NV12 ! uavstabilize delay=10 crop=0.1 ! "
    "videoconvert ! autovideosink\n"
    "  gst-launch-1.0 -m filesrc location=flight.y4m ! y4mdec ! uavstabilize post-messages=true ! "
    "fakesink";

// Input buffers we may hold beyond `delay`: being estimated, being warped, being pushed.
constexpr guint kExtraInputBuffers = 4;
// Frame duration assumed for the latency when neither caps nor buffers tell.
constexpr GstClockTime kFallbackFrameDuration = GST_SECOND / 30;
// Distinct warp/estimation errors reported as warnings; later ones only go to the log.
constexpr std::size_t kMaxReportedErrors = 32;

struct BufferUnref {
    void operator()(GstBuffer *buffer) const { gst_buffer_unref(buffer); }
};
using BufferPtr = std::unique_ptr<GstBuffer, BufferUnref>;

} // namespace

// Per-stream state, created with the element, filled at READY->PAUSED and caps time.
struct UavStabilizeState final : OutputBufferSource {
    // Streaming thread only (under the sink pad's stream lock), except that the task
    // thread uses `stabilizer` (tryPop) while the pads are active.
    std::unique_ptr<uavstab::Stabilizer> stabilizer;
    GstCaps *caps = nullptr;
    GstVideoInfo info{};
    std::size_t max_finalized = 0;  // chain backpressure: finalized frames not yet popped
    int bad_buffers = 0;                 // consecutive input buffers dropped as unreadable
    const void *checked_pool = nullptr;  // the upstream pool last looked at...
    guint checked_needed = 0;            // ...and the buffers we needed then
    bool copy_from_pool = false;         // its buffers are too few to hold: copy frames

    // Task thread only (or with the task stopped).
    GstSegment output_segment{};
    std::set<std::string> reported_errors;

    // Shared between the streaming thread, the task, the workers' ready callback and
    // flushing threads, under `mutex`. `changed` is signalled on every change.
    std::mutex mutex;
    std::condition_variable changed;
    OutputQueue queue;
    bool flushing = true;
    bool pushing = false;     // the task is pushing an item it took off the queue
    bool eos_queued = false;  // upstream sent EOS: no chain call will see a flow error
    GstFlowReturn last_flow = GST_FLOW_OK;  // what downstream last returned, if not OK
    GstBufferPool *pool = nullptr;          // output buffers, negotiated with downstream
    gint fps_n = 0;
    gint fps_d = 1;
    GstClockTime last_duration = GST_CLOCK_TIME_NONE;

    ~UavStabilizeState() override;
    GstBuffer *acquireOutputBuffer() override;
};

struct _GstUavStabilize {
    GstElement parent;
    GstPad *sinkpad;
    GstPad *srcpad;
    UavStabilizeSettings *settings;  // under the object lock
    UavStabilizeState *state;
};

G_DEFINE_TYPE_WITH_CODE(GstUavStabilize, gst_uav_stabilize, GST_TYPE_ELEMENT,
                        GST_DEBUG_CATEGORY_INIT(gst_uav_stabilize_debug, "uavstabilize", 0,
                                                "UAV video stabilizer"));
GST_ELEMENT_REGISTER_DEFINE(uavstabilize, "uavstabilize", GST_RANK_NONE, GST_TYPE_UAV_STABILIZE);

UavStabilizeState::~UavStabilizeState()
{
    // Normally empty already (PAUSED->READY drops everything).
    stabilizer.reset();
    queue.clear();
    if (pool) {
        gst_buffer_pool_set_active(pool, FALSE);
        gst_object_unref(pool);
    }
    if (caps)
        gst_caps_unref(caps);
}

GstBuffer *UavStabilizeState::acquireOutputBuffer()
{
    GstBufferPool *current;
    {
        std::lock_guard<std::mutex> lock(mutex);
        if (flushing || !pool)
            return nullptr;
        current = GST_BUFFER_POOL(gst_object_ref(pool));
    }
    // May block until downstream returns a buffer; FLUSH_START sets the pool flushing.
    GstBuffer *buffer = nullptr;
    const GstFlowReturn ret = gst_buffer_pool_acquire_buffer(current, &buffer, nullptr);
    gst_object_unref(current);
    if (ret != GST_FLOW_OK) {
        GST_DEBUG("no output buffer: %s", gst_flow_get_name(ret));
        return nullptr;
    }
    return buffer;
}

namespace {

UavStabilizeState &stateOf(GstUavStabilize *self)
{
    return *self->state;
}

void startTask(GstUavStabilize *self);

// ---------------------------------------------------------------------------------
// Settings

uavstab::StabilizerConfig takeConfig(GstUavStabilize *self)
{
    GST_OBJECT_LOCK(self);
    const uavstab::StabilizerConfig config = self->settings->stabilizer;
    self->settings->dirty = false;
    GST_OBJECT_UNLOCK(self);
    return config;
}

guint currentDelay(GstUavStabilize *self)
{
    GST_OBJECT_LOCK(self);
    const guint delay = guint(self->settings->stabilizer.delay);
    GST_OBJECT_UNLOCK(self);
    return delay;
}

int maxErrors(GstUavStabilize *self)
{
    GST_OBJECT_LOCK(self);
    const int max_errors = self->settings->max_errors;
    GST_OBJECT_UNLOCK(self);
    return max_errors;
}

bool postMessagesEnabled(GstUavStabilize *self)
{
    GST_OBJECT_LOCK(self);
    const bool enabled = self->settings->post_messages;
    GST_OBJECT_UNLOCK(self);
    return enabled;
}

// Streaming thread: hands properties changed since the last frame to the stabilizer.
void applyChangedSettings(GstUavStabilize *self, UavStabilizeState &s)
{
    GST_OBJECT_LOCK(self);
    const bool dirty = self->settings->dirty;
    GST_OBJECT_UNLOCK(self);
    if (!dirty)
        return;
    const uavstab::StabilizerConfig config = takeConfig(self);
    try {
        s.stabilizer->setConfig(config);
    } catch (const std::invalid_argument &e) {
        GST_ELEMENT_WARNING(self, LIBRARY, SETTINGS, ("Invalid stabilizer settings; keeping the previous ones"),
                            ("%s", e.what()));
    }
}

void postLatencyChanged(GstUavStabilize *self)
{
    gst_element_post_message(GST_ELEMENT(self), gst_message_new_latency(GST_OBJECT(self)));
}

// Under s.mutex.
GstClockTime frameDuration(GstUavStabilize *self, const UavStabilizeState &s)
{
    if (s.fps_n > 0 && s.fps_d > 0)
        return gst_util_uint64_scale_int(GST_SECOND, s.fps_d, s.fps_n);
    if (GST_CLOCK_TIME_IS_VALID(s.last_duration) && s.last_duration > 0)
        return s.last_duration;
    GST_WARNING_OBJECT(self, "no framerate and no buffer duration known; assuming 30 fps for the latency");
    return kFallbackFrameDuration;
}

// ---------------------------------------------------------------------------------
// Flushing, draining, output pool

void startFlushing(UavStabilizeState &s)
{
    std::lock_guard<std::mutex> lock(s.mutex);
    s.flushing = true;
    // Wakes a chain blocked in acquireOutputBuffer().
    if (s.pool && gst_buffer_pool_is_active(s.pool))
        gst_buffer_pool_set_flushing(s.pool, TRUE);
    s.changed.notify_all();
}

// Streaming thread: backpressure. Waits (with s.mutex held by `lock`) until few enough
// finalized frames, each with an output buffer, wait for the src task, or until flushing
// or downstream stopped taking data.
void waitForOutputRoom(UavStabilizeState &s, std::unique_lock<std::mutex> &lock)
{
    s.changed.wait(lock, [&] {
        return s.flushing || s.last_flow != GST_FLOW_OK || s.stabilizer->finalizedCount() <= s.max_finalized;
    });
}

// Streaming thread: finalizes every held frame (end of stream, caps change, drain), one
// at a time with the chain's backpressure, so that draining never takes more output
// buffers at once than streaming does. False when flushing or downstream stopped.
bool finalizeHeldFrames(UavStabilizeState &s)
{
    if (!s.stabilizer)
        return true;
    for (;;) {
        {
            std::unique_lock<std::mutex> lock(s.mutex);
            waitForOutputRoom(s, lock);
            if (s.flushing || s.last_flow != GST_FLOW_OK)
                return false;
        }
        if (!s.stabilizer->flushOne())
            return true;
    }
}

// Streaming thread: waits until every queued item is pushed and the task is idle. False
// when flushing or when downstream stopped taking data.
bool waitUntilDrained(UavStabilizeState &s)
{
    std::unique_lock<std::mutex> lock(s.mutex);
    s.changed.wait(lock, [&] { return s.flushing || s.last_flow != GST_FLOW_OK || (s.queue.empty() && !s.pushing); });
    return !s.flushing && s.last_flow == GST_FLOW_OK;
}

// Installs `pool` (may be null) as the output pool and retires the previous one.
void replaceOutputPool(UavStabilizeState &s, GstBufferPool *pool)
{
    GstBufferPool *old;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        old = s.pool;
        s.pool = pool;
    }
    if (old) {
        gst_buffer_pool_set_active(old, FALSE);
        gst_object_unref(old);
    }
}

// Streaming thread, with the output queue drained and the new caps pushed.
void negotiateOutputPool(GstUavStabilize *self, UavStabilizeState &s)
{
    replaceOutputPool(s, gstuavstab::negotiateOutputPool(self->srcpad, s.caps, s.info));
}

void releaseOutputPool(UavStabilizeState &s)
{
    replaceOutputPool(s, nullptr);
}

// ---------------------------------------------------------------------------------
// Src pad task: pushes the output queue in order

void postStatistics(GstUavStabilize *self, const UavStabilizeState &s, const uavstab::StabilizedFrame &frame,
                    GstClockTime pts)
{
    GstStructure *structure = gstuavstab::frameStatistics(frame, pts, s.output_segment);
    gst_element_post_message(GST_ELEMENT(self), gst_message_new_element(GST_OBJECT(self), structure));
}

// A frame the library could not stabilize goes out uncorrected; say so once per error.
void reportFailedFrame(GstUavStabilize *self, UavStabilizeState &s, const std::string &error)
{
    if (s.reported_errors.count(error) || s.reported_errors.size() >= kMaxReportedErrors) {
        GST_DEBUG_OBJECT(self, "frame passed through uncorrected: %s", error.c_str());
        return;
    }
    s.reported_errors.insert(error);
    GST_ELEMENT_WARNING(self, STREAM, FAILED, ("A frame could not be stabilized and was passed through uncorrected"),
                        ("%s", error.c_str()));
}

GstFlowReturn pushFrame(GstUavStabilize *self, UavStabilizeState &s, uavstab::StabilizedFrame &frame)
{
    auto &slot = static_cast<GstFrameSlot &>(*frame.slot);
    GstBuffer *buffer = nullptr;
    switch (frame.outcome) {
    case uavstab::Outcome::Warped:
        buffer = slot.releaseOutput();
        break;
    case uavstab::Outcome::Bypassed:
        break;
    case uavstab::Outcome::NoOutput: {
        std::lock_guard<std::mutex> lock(s.mutex);
        if (s.flushing)
            return GST_FLOW_OK;  // dropped with the slot: nobody wants it any more
        break;
    }
    case uavstab::Outcome::Failed:
        reportFailedFrame(self, s, frame.error);
        break;
    }
    if (!buffer)
        buffer = slot.releaseInput();  // bypass or pass-through: the input, untouched
    if (postMessagesEnabled(self))
        postStatistics(self, s, frame, GST_BUFFER_PTS(buffer));
    frame.slot.reset();  // unmaps and lets go of the input before it goes downstream
    return gst_pad_push(self->srcpad, buffer);
}

void runOutputStep(GstUavStabilize *self, UavStabilizeState &s)
{
    std::optional<uavstab::StabilizedFrame> frame;
    EventPtr event;
    {
        std::unique_lock<std::mutex> lock(s.mutex);
        s.changed.wait(lock, [&] {
            if (s.flushing || s.queue.frontIsEvent())
                return true;
            if (!s.queue.frontIsFrame() || !s.stabilizer)
                return false;
            frame = s.stabilizer->tryPop();
            return frame.has_value();
        });
        if (s.flushing) {
            lock.unlock();
            GST_DEBUG_OBJECT(self, "flushing: pausing the output task");
            gst_pad_pause_task(self->srcpad);
            return;
        }
        if (frame)
            s.queue.popFrame();
        else
            event = s.queue.popEvent();
        s.pushing = true;
    }

    GstFlowReturn ret = GST_FLOW_OK;
    if (frame) {
        ret = pushFrame(self, s, *frame);
    } else {
        const GstEventType type = GST_EVENT_TYPE(event.get());
        if (type == GST_EVENT_SEGMENT)
            gst_event_copy_segment(event.get(), &s.output_segment);
        GST_LOG_OBJECT(self, "pushing %" GST_PTR_FORMAT, event.get());
        gst_pad_push_event(self->srcpad, event.release());
        if (type == GST_EVENT_EOS)
            ret = GST_FLOW_EOS;  // nothing follows EOS until FLUSH_STOP or STREAM_START
    }

    bool eos_queued;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        s.pushing = false;
        if (ret != GST_FLOW_OK && !s.flushing)
            s.last_flow = ret;
        eos_queued = s.eos_queued;
        s.changed.notify_all();
    }
    if (ret == GST_FLOW_OK)
        return;

    GST_DEBUG_OBJECT(self, "pausing the output task: %s", gst_flow_get_name(ret));
    // Like queue: once upstream has sent EOS no chain call can report the error, so
    // tell the application and end the stream here.
    if (eos_queued && ret != GST_FLOW_EOS && (ret == GST_FLOW_NOT_LINKED || ret < GST_FLOW_EOS)) {
        GST_ELEMENT_FLOW_ERROR(self, ret);
        gst_pad_push_event(self->srcpad, gst_event_new_eos());
    }
    gst_pad_pause_task(self->srcpad);
}

void srcLoop(gpointer user_data)
{
    auto *self = GST_UAV_STABILIZE(user_data);
    UavStabilizeState &s = stateOf(self);
    try {
        runOutputStep(self, s);
    } catch (const std::exception &e) {
        GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Internal error while pushing stabilized frames"), ("%s", e.what()));
        {
            std::lock_guard<std::mutex> lock(s.mutex);
            s.pushing = false;
            s.last_flow = GST_FLOW_ERROR;
            s.changed.notify_all();
        }
        gst_pad_pause_task(self->srcpad);
    }
}

void startTask(GstUavStabilize *self)
{
    if (GST_PAD_MODE(self->srcpad) != GST_PAD_MODE_PUSH)
        return;  // not active (shutting down): the next activation starts it
    gst_pad_start_task(self->srcpad, srcLoop, self, nullptr);
}

// A C++ exception at a pad boundary: a frame or event may be missing from the ordered
// output, so the stream stops the way a downstream error stops it.
void failStream(GstUavStabilize *self, UavStabilizeState &s, const char *what, const std::exception &e)
{
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("%s", what), ("%s", e.what()));
    std::lock_guard<std::mutex> lock(s.mutex);
    s.last_flow = GST_FLOW_ERROR;
    s.changed.notify_all();
}

// ---------------------------------------------------------------------------------
// Sink pad: data

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
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        if (s.flushing)
            return GST_FLOW_FLUSHING;
        if (s.last_flow != GST_FLOW_OK)
            return s.last_flow;
        if (GST_BUFFER_DURATION_IS_VALID(buffer.get()))
            s.last_duration = GST_BUFFER_DURATION(buffer.get());
    }
    if (!s.caps || !s.stabilizer) {
        GST_ELEMENT_ERROR(self, CORE, NEGOTIATION, (nullptr), ("received a buffer before caps"));
        return GST_FLOW_NOT_NEGOTIATED;
    }
    applyChangedSettings(self, s);
    if (GST_BUFFER_IS_DISCONT(buffer.get()))
        s.stabilizer->markDiscontinuity();
    buffer = detachFromSmallPool(self, s, std::move(buffer));

    const gsize buffer_size = gst_buffer_get_size(buffer.get());
    const GstClockTime pts = GST_BUFFER_PTS(buffer.get());
    std::unique_ptr<GstFrameSlot> slot = GstFrameSlot::map(buffer.release(), s.info, s);
    if (!slot)
        return dropBadBuffer(self, s, buffer_size, pts);
    s.bad_buffers = 0;

    {
        // Backpressure: when downstream is slower than the warps, finalized frames (each
        // with an output buffer) pile up; wait here so memory stays bounded.
        std::unique_lock<std::mutex> lock(s.mutex);
        waitForOutputRoom(s, lock);
        if (s.flushing)
            return GST_FLOW_FLUSHING;
        if (s.last_flow != GST_FLOW_OK)
            return s.last_flow;
        s.queue.pushFrame();
    }
    s.stabilizer->push(std::move(slot));
    return GST_FLOW_OK;
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

// ---------------------------------------------------------------------------------
// Sink pad: events

// Serialized events wait behind the frames that came before them.
bool queueEvent(GstUavStabilize *self, UavStabilizeState &s, EventPtr event)
{
    const GstEventType type = GST_EVENT_TYPE(event.get());
    bool restart = false;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        if (s.flushing)
            return false;
        if (s.last_flow == GST_FLOW_EOS && (type == GST_EVENT_STREAM_START || type == GST_EVENT_SEGMENT)) {
            // A new stream after EOS: data may flow again.
            s.last_flow = GST_FLOW_OK;
            s.eos_queued = false;
            restart = true;
        } else if (s.last_flow != GST_FLOW_OK) {
            GST_DEBUG_OBJECT(self, "refusing %" GST_PTR_FORMAT ": downstream returned %s", event.get(),
                             gst_flow_get_name(s.last_flow));
            return false;
        }
        if (type == GST_EVENT_EOS)
            s.eos_queued = true;
        s.queue.pushEvent(std::move(event));
        s.changed.notify_all();
    }
    if (restart)
        startTask(self);
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
    if (!finalizeHeldFrames(s) || !waitUntilDrained(s))
        return false;
    if (s.stabilizer)
        s.stabilizer->reset();

    gst_caps_replace(&s.caps, caps);
    s.info = info;
    s.checked_pool = nullptr;  // new caps, new upstream pool
    bool framerate_changed;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        framerate_changed = s.fps_n != GST_VIDEO_INFO_FPS_N(&info) || s.fps_d != GST_VIDEO_INFO_FPS_D(&info);
        s.fps_n = GST_VIDEO_INFO_FPS_N(&info);
        s.fps_d = GST_VIDEO_INFO_FPS_D(&info);
    }
    // The task is idle with the queue empty, so pushing from here keeps the order.
    const bool pushed = gst_pad_push_event(self->srcpad, event.release());
    negotiateOutputPool(self, s);
    if (framerate_changed)
        postLatencyChanged(self);
    return pushed;
}

bool handleFlushStop(GstUavStabilize *self, UavStabilizeState &s, EventPtr event)
{
    bool was_flushing;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        was_flushing = s.flushing;
    }
    if (!was_flushing) {
        // FLUSH_STOP without FLUSH_START: stop the task before throwing frames away.
        startFlushing(s);
        gst_pad_pause_task(self->srcpad);
    }
    // Drops every held frame and restarts the path; not under s.mutex, since resetting
    // waits for warps whose ready callback takes it.
    if (s.stabilizer)
        s.stabilizer->reset();
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        s.queue.clear();
        s.flushing = false;
        s.pushing = false;
        s.eos_queued = false;
        s.last_flow = GST_FLOW_OK;
        if (s.pool && gst_buffer_pool_is_active(s.pool))
            gst_buffer_pool_set_flushing(s.pool, FALSE);
    }
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
    case GST_EVENT_FLUSH_START: {
        startFlushing(s);
        const bool pushed = gst_pad_push_event(self->srcpad, event.release());
        // Waits for the task to leave its loop (downstream is flushing too, so a push
        // in progress returns).
        gst_pad_pause_task(self->srcpad);
        return pushed;
    }
    case GST_EVENT_FLUSH_STOP:
        return handleFlushStop(self, s, std::move(event));
    case GST_EVENT_CAPS:
        return handleCaps(self, s, std::move(event));
    case GST_EVENT_EOS:
        // Every held frame goes out (truncated smoothing window), then EOS. If a flush
        // interrupts the drain, EOS is dropped with the frames, as a flush does.
        if (!finalizeHeldFrames(s)) {
            std::lock_guard<std::mutex> lock(s.mutex);
            if (s.flushing)
                return false;
        }
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

// ---------------------------------------------------------------------------------
// Queries

// Caps without an interlace-mode field are progressive (GstVideoInfo reads them so); the
// template names the field, so add it before comparing.
GstCaps *withInterlaceMode(GstCaps *caps)
{
    GstCaps *copy = gst_caps_copy(caps);
    for (guint i = 0; i < gst_caps_get_size(copy); ++i) {
        GstStructure *structure = gst_caps_get_structure(copy, i);
        if (!gst_structure_has_field(structure, "interlace-mode"))
            gst_structure_set(structure, "interlace-mode", G_TYPE_STRING, "progressive", nullptr);
    }
    return copy;
}

bool acceptCaps(GstUavStabilize *self, GstPad *pad, GstQuery *query)
{
    GstCaps *caps = nullptr;
    gst_query_parse_accept_caps(query, &caps);
    GstCaps *templ = gst_pad_get_pad_template_caps(pad);
    // Interlaced frames are refused: warping a frame of two fields moves each field's lines
    // into the other's, so the output would comb. A deinterlacer in front fixes that.
    GstCaps *normalized = withInterlaceMode(caps);
    bool accepted = gst_caps_is_subset(normalized, templ);
    gst_caps_unref(normalized);
    gst_caps_unref(templ);
    if (!accepted)
        GST_INFO_OBJECT(self, "refusing %" GST_PTR_FORMAT " (the template takes the listed formats, 16x16 and "
                        "up, progressive only: interlaced video needs a deinterlacer in front)", caps);
    // Output caps are the input caps, so downstream must take them too.
    if (accepted && gst_pad_is_linked(self->srcpad))
        accepted = gst_pad_peer_query_accept_caps(self->srcpad, caps);
    gst_query_set_accept_caps_result(query, accepted);
    return true;
}

bool handleSinkQuery(GstUavStabilize *self, UavStabilizeState &s, GstPad *pad, GstQuery *query)
{
    switch (GST_QUERY_TYPE(query)) {
    case GST_QUERY_CAPS:
        return gst_pad_proxy_query_caps(pad, query);
    case GST_QUERY_ACCEPT_CAPS:
        return acceptCaps(self, pad, query);
    case GST_QUERY_ALLOCATION:
        // Upstream's pool must cover the frames we hold.
        return gstuavstab::proposeInputAllocation(query, currentDelay(self) + kExtraInputBuffers);
    case GST_QUERY_DRAIN:
        // Everything held goes out before the answer.
        if (!finalizeHeldFrames(s) || !waitUntilDrained(s))
            return false;
        gst_pad_peer_query(self->srcpad, query);
        return true;
    default:
        return gst_pad_query_default(pad, GST_OBJECT(self), query);
    }
}

gboolean sinkQuery(GstPad *pad, GstObject *parent, GstQuery *query)
{
    auto *self = GST_UAV_STABILIZE(parent);
    try {
        return handleSinkQuery(self, stateOf(self), pad, query);
    } catch (const std::exception &e) {
        failStream(self, stateOf(self), "Handling a query failed", e);
        return FALSE;
    }
}

bool handleLatency(GstUavStabilize *self, UavStabilizeState &s, GstQuery *query)
{
    if (!gst_pad_peer_query(self->sinkpad, query))
        return false;
    gboolean live = FALSE;
    GstClockTime min = 0, max = GST_CLOCK_TIME_NONE;
    gst_query_parse_latency(query, &live, &min, &max);
    GstClockTime duration;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        duration = frameDuration(self, s);
    }
    const GstClockTime added = currentDelay(self) * duration;
    GST_DEBUG_OBJECT(self, "upstream latency %" GST_TIME_FORMAT " - %" GST_TIME_FORMAT ", adding %" GST_TIME_FORMAT,
                     GST_TIME_ARGS(min), GST_TIME_ARGS(max), GST_TIME_ARGS(added));
    min += added;
    if (GST_CLOCK_TIME_IS_VALID(max))
        max += added;
    gst_query_set_latency(query, live, min, max);
    return true;
}

gboolean srcQuery(GstPad *pad, GstObject *parent, GstQuery *query)
{
    auto *self = GST_UAV_STABILIZE(parent);
    try {
        switch (GST_QUERY_TYPE(query)) {
        case GST_QUERY_LATENCY:
            return handleLatency(self, stateOf(self), query);
        case GST_QUERY_CAPS:
            return gst_pad_proxy_query_caps(pad, query);
        default:
            return gst_pad_query_default(pad, parent, query);
        }
    } catch (const std::exception &e) {
        GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Handling a query failed"), ("%s", e.what()));
        return FALSE;
    }
}

// ---------------------------------------------------------------------------------
// Pad activation and state changes

gboolean srcActivateMode(GstPad *pad, GstObject *parent, GstPadMode mode, gboolean active)
{
    auto *self = GST_UAV_STABILIZE(parent);
    UavStabilizeState &s = stateOf(self);
    if (mode != GST_PAD_MODE_PUSH)
        return FALSE;
    if (active) {
        {
            std::lock_guard<std::mutex> lock(s.mutex);
            s.flushing = false;
            s.pushing = false;
            s.eos_queued = false;
            s.last_flow = GST_FLOW_OK;
        }
        return gst_pad_start_task(pad, srcLoop, self, nullptr);
    }
    // Wakes the task and a blocked chain; the task then pauses itself and is joined.
    startFlushing(s);
    return gst_pad_stop_task(pad);
}

gboolean sinkActivateMode(GstPad *, GstObject *parent, GstPadMode mode, gboolean active)
{
    if (mode != GST_PAD_MODE_PUSH)
        return FALSE;
    if (!active)
        startFlushing(stateOf(GST_UAV_STABILIZE(parent)));  // a chain may be waiting
    return TRUE;
}

bool startStream(GstUavStabilize *self, UavStabilizeState &s)
{
    const uavstab::StabilizerConfig config = takeConfig(self);
    try {
        s.stabilizer = std::make_unique<uavstab::Stabilizer>(config);
    } catch (const std::exception &e) {
        GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Cannot create the stabilizer"), ("%s", e.what()));
        return false;
    }
    // Runs on a worker thread: only signal, under our mutex so that a waiter between its
    // check and its wait cannot miss it.
    s.stabilizer->setReadyCallback([&s] {
        std::lock_guard<std::mutex> lock(s.mutex);
        s.changed.notify_all();
    });
    s.max_finalized = std::size_t(config.resolvedThreads()) + 2;
    gst_segment_init(&s.output_segment, GST_FORMAT_UNDEFINED);
    return true;
}

// With the pads deactivated (task stopped, no chain running): drops everything.
void stopStream(UavStabilizeState &s)
{
    s.stabilizer.reset();  // waits for warps in flight; releases every held buffer
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        s.queue.clear();
        s.pushing = false;
        s.fps_n = 0;
        s.fps_d = 1;
        s.last_duration = GST_CLOCK_TIME_NONE;
    }
    releaseOutputPool(s);
    gst_caps_replace(&s.caps, nullptr);
    gst_video_info_init(&s.info);
    s.reported_errors.clear();
    s.bad_buffers = 0;
}

GstStateChangeReturn changeState(GstElement *element, GstStateChange transition)
{
    auto *self = GST_UAV_STABILIZE(element);
    UavStabilizeState &s = stateOf(self);
    if (transition == GST_STATE_CHANGE_READY_TO_PAUSED && !startStream(self, s))
        return GST_STATE_CHANGE_FAILURE;

    const GstStateChangeReturn ret = GST_ELEMENT_CLASS(gst_uav_stabilize_parent_class)->change_state(element, transition);

    if (transition == GST_STATE_CHANGE_PAUSED_TO_READY ||
        (transition == GST_STATE_CHANGE_READY_TO_PAUSED && ret == GST_STATE_CHANGE_FAILURE))
        stopStream(s);
    return ret;
}

// ---------------------------------------------------------------------------------
// Properties

void setProperty(GObject *object, guint id, const GValue *value, GParamSpec *pspec)
{
    auto *self = GST_UAV_STABILIZE(object);
    GST_OBJECT_LOCK(self);
    const int old_delay = self->settings->stabilizer.delay;
    const bool known = gstuavstab::setProperty(*self->settings, id, value);
    const bool delay_changed = self->settings->stabilizer.delay != old_delay;
    GST_OBJECT_UNLOCK(self);
    if (!known)
        G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
    if (delay_changed)
        postLatencyChanged(self);
}

void getProperty(GObject *object, guint id, GValue *value, GParamSpec *pspec)
{
    auto *self = GST_UAV_STABILIZE(object);
    GST_OBJECT_LOCK(self);
    const bool known = gstuavstab::getProperty(*self->settings, id, value);
    GST_OBJECT_UNLOCK(self);
    if (!known)
        G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
}

void finalize(GObject *object)
{
    auto *self = GST_UAV_STABILIZE(object);
    delete self->state;
    delete self->settings;
    self->state = nullptr;
    self->settings = nullptr;
    G_OBJECT_CLASS(gst_uav_stabilize_parent_class)->finalize(object);
}

} // namespace

static void gst_uav_stabilize_class_init(GstUavStabilizeClass *klass)
{
    auto *gobject_class = G_OBJECT_CLASS(klass);
    auto *element_class = GST_ELEMENT_CLASS(klass);
    gobject_class->set_property = setProperty;
    gobject_class->get_property = getProperty;
    gobject_class->finalize = finalize;
    gstuavstab::installProperties(gobject_class);

    gst_element_class_add_static_pad_template(element_class, &sink_template);
    gst_element_class_add_static_pad_template(element_class, &src_template);
    gst_element_class_set_static_metadata(element_class, "UAV video stabilizer", "Filter/Effect/Video",
                                          kDescription, "uavstabilize contributors");
    element_class->change_state = changeState;

    gstuavstab::markEnumTypesAsPluginApi();
}

static void gst_uav_stabilize_init(GstUavStabilize *self)
{
    self->settings = new UavStabilizeSettings();
    self->state = new UavStabilizeState();
    gst_video_info_init(&self->state->info);

    self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
    gst_pad_set_chain_function(self->sinkpad, sinkChain);
    gst_pad_set_event_function(self->sinkpad, sinkEvent);
    gst_pad_set_query_function(self->sinkpad, sinkQuery);
    gst_pad_set_activatemode_function(self->sinkpad, sinkActivateMode);
    GST_PAD_SET_PROXY_CAPS(self->sinkpad);
    gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);

    self->srcpad = gst_pad_new_from_static_template(&src_template, "src");
    gst_pad_set_query_function(self->srcpad, srcQuery);
    gst_pad_set_activatemode_function(self->srcpad, srcActivateMode);
    GST_PAD_SET_PROXY_CAPS(self->srcpad);
    gst_element_add_pad(GST_ELEMENT(self), self->srcpad);
}
