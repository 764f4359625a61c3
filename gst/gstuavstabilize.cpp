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
 * correction (angles in radians).
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

#include "gst_frame_slot.hpp"
#include "output_queue.hpp"
#include "uavstab/stabilizer.hpp"
#include "uavstabilize_enums.hpp"
#include "uavstabilize_settings.hpp"

GST_DEBUG_CATEGORY(gst_uav_stabilize_debug);
#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace {

#define UAVSTABILIZE_CAPS                                                                                     \
    "video/x-raw, "                                                                                           \
    "format = (string) { I420, YV12, NV12, NV21, GRAY8, RGB, BGR, RGBA, BGRA, RGBx, BGRx }, "                \
    "width = (int) [ 16, MAX ], height = (int) [ 16, MAX ], framerate = (fraction) [ 0/1, MAX ]"

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

enum Property {
    PROP_0,
    PROP_DELAY,
    PROP_SMOOTHING_RADIUS,
    PROP_SMOOTHER,
    PROP_MAX_CORNERS,
    PROP_ROI,
    PROP_REDETECT_INTERVAL,
    PROP_FB_THRESHOLD,
    PROP_MODEL,
    PROP_DWELL,
    PROP_MIN_POINTS,
    PROP_CROP,
    PROP_LIMIT_TO_CROP,
    PROP_BORDER,
    PROP_ANALYSIS_WIDTH,
    PROP_THREADS,
    PROP_BYPASS,
    PROP_POST_MESSAGES,
};

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

// Streaming thread: waits until every queued item is pushed and the task is idle. False
// when flushing or when downstream stopped taking data.
bool waitUntilDrained(UavStabilizeState &s)
{
    std::unique_lock<std::mutex> lock(s.mutex);
    s.changed.wait(lock, [&] { return s.flushing || s.last_flow != GST_FLOW_OK || (s.queue.empty() && !s.pushing); });
    return !s.flushing && s.last_flow == GST_FLOW_OK;
}

bool configurePool(GstBufferPool *pool, GstCaps *caps, guint size, guint min, guint max, GstAllocator *allocator,
                   const GstAllocationParams &params, bool video_meta)
{
    GstStructure *config = gst_buffer_pool_get_config(pool);
    gst_buffer_pool_config_set_params(config, caps, size, min, max);
    gst_buffer_pool_config_set_allocator(config, allocator, &params);
    if (video_meta && gst_buffer_pool_has_option(pool, GST_BUFFER_POOL_OPTION_VIDEO_META))
        gst_buffer_pool_config_add_option(config, GST_BUFFER_POOL_OPTION_VIDEO_META);
    if (gst_buffer_pool_set_config(pool, config))
        return true;
    // The pool may have adjusted the config; take it if it still fits.
    config = gst_buffer_pool_get_config(pool);
    if (!gst_buffer_pool_config_validate_params(config, caps, size, min, max)) {
        gst_structure_free(config);
        return false;
    }
    return gst_buffer_pool_set_config(pool, config);
}

// Streaming thread, with the output queue drained and the new caps pushed: picks the
// pool output buffers come from (downstream's if it offers one that takes our config,
// else our own video pool).
void negotiateOutputPool(GstUavStabilize *self, UavStabilizeState &s)
{
    GstQuery *query = gst_query_new_allocation(s.caps, TRUE);
    if (!gst_pad_peer_query(self->srcpad, query))
        GST_DEBUG_OBJECT(self, "downstream did not answer the ALLOCATION query");

    GstBufferPool *pool = nullptr;
    guint size = 0, min = 0, max = 0;
    if (gst_query_get_n_allocation_pools(query) > 0)
        gst_query_parse_nth_allocation_pool(query, 0, &pool, &size, &min, &max);
    GstAllocator *allocator = nullptr;
    GstAllocationParams params;
    gst_allocation_params_init(&params);
    if (gst_query_get_n_allocation_params(query) > 0)
        gst_query_parse_nth_allocation_param(query, 0, &allocator, &params);
    const bool video_meta = gst_query_find_allocation_meta(query, GST_VIDEO_META_API_TYPE, nullptr);
    gst_query_unref(query);

    const guint frame_size = guint(GST_VIDEO_INFO_SIZE(&s.info));
    if (pool && !configurePool(pool, s.caps, std::max(size, frame_size), min, max, allocator, params, video_meta)) {
        GST_DEBUG_OBJECT(self, "downstream's pool refused our config; using our own");
        gst_object_unref(pool);
        pool = nullptr;
    }
    if (!pool) {
        pool = gst_video_buffer_pool_new();
        if (!configurePool(pool, s.caps, frame_size, 0, 0, allocator, params, false)) {
            gst_object_unref(pool);
            pool = nullptr;
        }
    }
    if (allocator)
        gst_object_unref(allocator);
    if (!pool || !gst_buffer_pool_set_active(pool, TRUE)) {
        if (pool)
            gst_object_unref(pool);
        throw std::runtime_error("no usable output buffer pool");
    }
    GST_DEBUG_OBJECT(self, "output buffers from %" GST_PTR_FORMAT, pool);

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

void releaseOutputPool(UavStabilizeState &s)
{
    GstBufferPool *old;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        old = s.pool;
        s.pool = nullptr;
    }
    if (old) {
        gst_buffer_pool_set_active(old, FALSE);
        gst_object_unref(old);
    }
}

// ---------------------------------------------------------------------------------
// Src pad task: pushes the output queue in order

void setSimilarity(GstStructure *structure, const char *prefix, const uavstab::Similarity &s)
{
    const std::string p(prefix);
    gst_structure_set(structure, (p + "-dx").c_str(), G_TYPE_DOUBLE, s.dx, (p + "-dy").c_str(), G_TYPE_DOUBLE, s.dy,
                      (p + "-angle").c_str(), G_TYPE_DOUBLE, s.angle, (p + "-scale").c_str(), G_TYPE_DOUBLE, s.scale,
                      nullptr);
}

const char *outcomeName(uavstab::Outcome outcome)
{
    switch (outcome) {
    case uavstab::Outcome::Warped:
        return "warped";
    case uavstab::Outcome::Bypassed:
        return "bypassed";
    case uavstab::Outcome::NoOutput:
        return "no-output";
    default:
        return "failed";
    }
}

void postStatistics(GstUavStabilize *self, const UavStabilizeState &s, const uavstab::StabilizedFrame &frame,
                    GstClockTime pts)
{
    const uavstab::FrameStats &stats = frame.stats;
    GstStructure *structure = gst_structure_new(
        "uavstabilize", "timestamp", G_TYPE_UINT64, guint64(pts), "index", G_TYPE_INT64, gint64(stats.index), "zoom",
        G_TYPE_DOUBLE, stats.zoom, "correction-fraction", G_TYPE_DOUBLE, stats.correction_fraction, "model",
        G_TYPE_STRING, uavstab::toString(stats.model), "points", G_TYPE_INT, stats.points, "inliers", G_TYPE_INT,
        stats.inliers, "skipped", G_TYPE_BOOLEAN, gboolean(stats.skipped), "segment-start", G_TYPE_BOOLEAN,
        gboolean(stats.segment_start), "outcome", G_TYPE_STRING, outcomeName(frame.outcome), nullptr);
    if (GST_CLOCK_TIME_IS_VALID(pts) && s.output_segment.format == GST_FORMAT_TIME) {
        const guint64 running_time = gst_segment_to_running_time(&s.output_segment, GST_FORMAT_TIME, pts);
        const guint64 stream_time = gst_segment_to_stream_time(&s.output_segment, GST_FORMAT_TIME, pts);
        if (GST_CLOCK_TIME_IS_VALID(running_time))
            gst_structure_set(structure, "running-time", G_TYPE_UINT64, running_time, nullptr);
        if (GST_CLOCK_TIME_IS_VALID(stream_time))
            gst_structure_set(structure, "stream-time", G_TYPE_UINT64, stream_time, nullptr);
    }
    setSimilarity(structure, "motion", stats.motion);
    setSimilarity(structure, "trajectory", stats.trajectory);
    setSimilarity(structure, "smoothed", stats.smoothed);
    setSimilarity(structure, "correction", stats.correction);
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

// ---------------------------------------------------------------------------------
// Sink pad: data

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

    const gsize buffer_size = gst_buffer_get_size(buffer.get());
    std::unique_ptr<GstFrameSlot> slot = GstFrameSlot::map(buffer.release(), s.info, s);
    if (!slot) {
        GST_ELEMENT_ERROR(self, STREAM, FORMAT, ("buffer too small for caps"),
                          ("a %" G_GSIZE_FORMAT "-byte buffer cannot hold a %dx%d %s frame (%" G_GSIZE_FORMAT
                           " bytes)",
                           buffer_size, GST_VIDEO_INFO_WIDTH(&s.info), GST_VIDEO_INFO_HEIGHT(&s.info),
                           GST_VIDEO_INFO_NAME(&s.info), GST_VIDEO_INFO_SIZE(&s.info)));
        return GST_FLOW_ERROR;
    }

    {
        // Backpressure: when downstream is slower than the warps, finalized frames (each
        // with an output buffer) pile up; wait here so memory stays bounded.
        std::unique_lock<std::mutex> lock(s.mutex);
        s.changed.wait(lock, [&] {
            return s.flushing || s.last_flow != GST_FLOW_OK || s.stabilizer->finalizedCount() <= s.max_finalized;
        });
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
        GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Stabilizing a frame failed"), ("%s", e.what()));
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
    if (s.stabilizer)
        s.stabilizer->flush();
    if (!waitUntilDrained(s))
        return false;
    if (s.stabilizer)
        s.stabilizer->reset();

    gst_caps_replace(&s.caps, caps);
    s.info = info;
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
        // Every held frame goes out (truncated smoothing window), then EOS.
        if (s.stabilizer)
            s.stabilizer->flush();
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
        GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Handling an event failed"), ("%s", e.what()));
        return FALSE;
    }
}

// ---------------------------------------------------------------------------------
// Queries

// Upstream may allocate from a pool big enough for the frames we hold (sources with
// fixed pools, like v4l2src, would starve otherwise) and with padded strides.
bool proposeAllocation(GstUavStabilize *self, GstQuery *query)
{
    GstCaps *caps = nullptr;
    gboolean need_pool = FALSE;
    gst_query_parse_allocation(query, &caps, &need_pool);
    GstVideoInfo info;
    if (!caps || !gst_video_info_from_caps(&info, caps))
        return false;
    const guint min_buffers = currentDelay(self) + kExtraInputBuffers;
    const guint size = guint(GST_VIDEO_INFO_SIZE(&info));
    GstBufferPool *pool = nullptr;
    if (need_pool) {
        pool = gst_video_buffer_pool_new();
        GstStructure *config = gst_buffer_pool_get_config(pool);
        gst_buffer_pool_config_set_params(config, caps, size, min_buffers, 0);
        gst_buffer_pool_config_add_option(config, GST_BUFFER_POOL_OPTION_VIDEO_META);
        if (!gst_buffer_pool_set_config(pool, config)) {
            gst_object_unref(pool);
            return false;
        }
    }
    gst_query_add_allocation_pool(query, pool, size, min_buffers, 0);
    if (pool)
        gst_object_unref(pool);
    gst_query_add_allocation_meta(query, GST_VIDEO_META_API_TYPE, nullptr);
    return true;
}

bool acceptCaps(GstUavStabilize *self, GstPad *pad, GstQuery *query)
{
    GstCaps *caps = nullptr;
    gst_query_parse_accept_caps(query, &caps);
    GstCaps *templ = gst_pad_get_pad_template_caps(pad);
    bool accepted = gst_caps_is_subset(caps, templ);
    gst_caps_unref(templ);
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
        return proposeAllocation(self, query);
    case GST_QUERY_DRAIN:
        // Everything held goes out before the answer.
        if (s.stabilizer)
            s.stabilizer->flush();
        if (!waitUntilDrained(s))
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
        GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Handling a query failed"), ("%s", e.what()));
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
    bool delay_changed = false;
    GST_OBJECT_LOCK(self);
    uavstab::StabilizerConfig &c = self->settings->stabilizer;
    switch (Property(id)) {
    case PROP_DELAY: {
        const int delay = int(g_value_get_uint(value));
        delay_changed = delay != c.delay;
        c.delay = delay;
        break;
    }
    case PROP_SMOOTHING_RADIUS:
        c.smoothing_radius = int(g_value_get_uint(value));
        break;
    case PROP_SMOOTHER:
        c.smoother = uavstab::SmootherKind(g_value_get_enum(value));
        break;
    case PROP_MAX_CORNERS:
        c.max_corners = int(g_value_get_uint(value));
        break;
    case PROP_ROI:
        c.roi = g_value_get_double(value);
        break;
    case PROP_REDETECT_INTERVAL:
        c.redetect_interval = int(g_value_get_uint(value));
        break;
    case PROP_FB_THRESHOLD:
        c.fb_threshold = g_value_get_double(value);
        break;
    case PROP_MODEL:
        c.model = uavstab::ModelChoice(g_value_get_enum(value));
        break;
    case PROP_DWELL:
        c.dwell = int(g_value_get_uint(value));
        break;
    case PROP_MIN_POINTS:
        c.min_points = int(g_value_get_uint(value));
        break;
    case PROP_CROP:
        c.crop = g_value_get_double(value);
        break;
    case PROP_LIMIT_TO_CROP:
        c.limit_to_crop = g_value_get_boolean(value);
        break;
    case PROP_BORDER:
        c.border = uavstab::BorderMode(g_value_get_enum(value));
        break;
    case PROP_ANALYSIS_WIDTH:
        c.analysis_width = int(g_value_get_uint(value));
        break;
    case PROP_THREADS:
        c.threads = int(g_value_get_uint(value));
        break;
    case PROP_BYPASS:
        c.bypass = g_value_get_boolean(value);
        break;
    case PROP_POST_MESSAGES:
        self->settings->post_messages = g_value_get_boolean(value);
        break;
    default:
        G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
        break;
    }
    self->settings->dirty = true;
    GST_OBJECT_UNLOCK(self);
    if (delay_changed)
        postLatencyChanged(self);
}

void getProperty(GObject *object, guint id, GValue *value, GParamSpec *pspec)
{
    auto *self = GST_UAV_STABILIZE(object);
    GST_OBJECT_LOCK(self);
    const uavstab::StabilizerConfig &c = self->settings->stabilizer;
    switch (Property(id)) {
    case PROP_DELAY:
        g_value_set_uint(value, guint(c.delay));
        break;
    case PROP_SMOOTHING_RADIUS:
        g_value_set_uint(value, guint(c.smoothing_radius));
        break;
    case PROP_SMOOTHER:
        g_value_set_enum(value, int(c.smoother));
        break;
    case PROP_MAX_CORNERS:
        g_value_set_uint(value, guint(c.max_corners));
        break;
    case PROP_ROI:
        g_value_set_double(value, c.roi);
        break;
    case PROP_REDETECT_INTERVAL:
        g_value_set_uint(value, guint(c.redetect_interval));
        break;
    case PROP_FB_THRESHOLD:
        g_value_set_double(value, c.fb_threshold);
        break;
    case PROP_MODEL:
        g_value_set_enum(value, int(c.model));
        break;
    case PROP_DWELL:
        g_value_set_uint(value, guint(c.dwell));
        break;
    case PROP_MIN_POINTS:
        g_value_set_uint(value, guint(c.min_points));
        break;
    case PROP_CROP:
        g_value_set_double(value, c.crop);
        break;
    case PROP_LIMIT_TO_CROP:
        g_value_set_boolean(value, c.limit_to_crop);
        break;
    case PROP_BORDER:
        g_value_set_enum(value, int(c.border));
        break;
    case PROP_ANALYSIS_WIDTH:
        g_value_set_uint(value, guint(c.analysis_width));
        break;
    case PROP_THREADS:
        g_value_set_uint(value, guint(c.threads));
        break;
    case PROP_BYPASS:
        g_value_set_boolean(value, c.bypass);
        break;
    case PROP_POST_MESSAGES:
        g_value_set_boolean(value, self->settings->post_messages);
        break;
    default:
        G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
        break;
    }
    GST_OBJECT_UNLOCK(self);
}

constexpr GParamFlags kPlaying =
    GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
constexpr GParamFlags kReady = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);

void installProperties(GObjectClass *gobject_class)
{
    const uavstab::StabilizerConfig d;  // the library's defaults are the element's
    auto install = [gobject_class](Property id, GParamSpec *spec) {
        g_object_class_install_property(gobject_class, id, spec);
    };
    install(PROP_DELAY, g_param_spec_uint("delay", "Delay",
                                          "Frames held back so the smoothing window can look ahead (adds delay x "
                                          "frame duration of latency; 0 = causal smoothing)",
                                          0, 1000, guint(d.delay), kPlaying));
    install(PROP_SMOOTHING_RADIUS,
            g_param_spec_uint("smoothing-radius", "Smoothing radius",
                              "Half-width of the camera path smoothing window, in frames", 0, 1000,
                              guint(d.smoothing_radius), kPlaying));
    install(PROP_SMOOTHER, g_param_spec_enum("smoother", "Smoother", "How the camera path is smoothed",
                                             UAVSTABILIZE_TYPE_SMOOTHER, int(d.smoother), kPlaying));
    install(PROP_MAX_CORNERS, g_param_spec_uint("max-corners", "Max corners", "Corners tracked per frame", 4, 200,
                                                guint(d.max_corners), kPlaying));
    install(PROP_ROI, g_param_spec_double("roi", "Region of interest",
                                          "Central share of width and height where corners are detected", 0.1,
                                          1.0, d.roi, kPlaying));
    install(PROP_REDETECT_INTERVAL,
            g_param_spec_uint("redetect-interval", "Redetect interval",
                              "Frames between corner re-detections (sooner when tracks are lost)", 1, 1000,
                              guint(d.redetect_interval), kPlaying));
    install(PROP_FB_THRESHOLD,
            g_param_spec_double("fb-threshold", "Forward-backward threshold",
                                "A track is kept when tracking it back lands within this many analysis pixels",
                                0.01, 100.0, d.fb_threshold, kPlaying));
    install(PROP_MODEL, g_param_spec_enum("model", "Motion model", "Motion model fitted to the tracks",
                                          UAVSTABILIZE_TYPE_MODEL, int(d.model), kPlaying));
    install(PROP_DWELL, g_param_spec_uint("dwell", "Dwell",
                                          "Frames a hybrid model choice is kept before it is re-evaluated", 1,
                                          100000, guint(d.dwell), kPlaying));
    install(PROP_MIN_POINTS,
            g_param_spec_uint("min-points", "Min points",
                              "Fewer surviving tracks than this: the frame gets no correction", 2, 200,
                              guint(d.min_points), kPlaying));
    install(PROP_CROP, g_param_spec_double("crop", "Crop",
                                           "Share of width/height hidden by the zoom (split between opposite "
                                           "edges; zoom = 1 / (1 - crop))",
                                           0.0, 0.5, d.crop, kPlaying));
    install(PROP_LIMIT_TO_CROP,
            g_param_spec_boolean("limit-to-crop", "Limit to crop",
                                 "Shrink corrections that would show more border than the crop hides",
                                 d.limit_to_crop, kPlaying));
    install(PROP_BORDER, g_param_spec_enum("border", "Border", "What uncovered output pixels show",
                                           UAVSTABILIZE_TYPE_BORDER, int(d.border), kPlaying));
    install(PROP_ANALYSIS_WIDTH,
            g_param_spec_uint("analysis-width", "Analysis width",
                              "Motion is estimated on luma downscaled to this width (full size when smaller)", 16,
                              16384, guint(d.analysis_width), kPlaying));
    install(PROP_THREADS, g_param_spec_uint("threads", "Threads", "Warp worker threads (0 = one per core)", 0, 64,
                                            guint(d.threads), kReady));
    install(PROP_BYPASS, g_param_spec_boolean("bypass", "Bypass",
                                              "Pass frames through untouched, with the same delay (toggling "
                                              "never reorders frames)",
                                              d.bypass, kPlaying));
    install(PROP_POST_MESSAGES,
            g_param_spec_boolean("post-messages", "Post messages",
                                 "Post an element message 'uavstabilize' per frame with the motion, path and "
                                 "correction (angles in radians)",
                                 FALSE, kPlaying));
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
    installProperties(gobject_class);

    gst_element_class_add_static_pad_template(element_class, &sink_template);
    gst_element_class_add_static_pad_template(element_class, &src_template);
    gst_element_class_set_static_metadata(element_class, "UAV video stabilizer", "Filter/Effect/Video",
                                          kDescription, "uavstabilize contributors");
    element_class->change_state = changeState;

    gst_type_mark_as_plugin_api(UAVSTABILIZE_TYPE_SMOOTHER, GstPluginAPIFlags(0));
    gst_type_mark_as_plugin_api(UAVSTABILIZE_TYPE_MODEL, GstPluginAPIFlags(0));
    gst_type_mark_as_plugin_api(UAVSTABILIZE_TYPE_BORDER, GstPluginAPIFlags(0));
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
