#include "chaos_rig.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <set>
#include <sstream>
#include <thread>

namespace chaos {

// ---------------------------------------------------------------------------------
// What the log holds

struct Rig::Item {
    bool is_buffer = false;
    GstEventType type = GST_EVENT_UNKNOWN;
    // Buffers, as pushed.
    GstClockTime pts = GST_CLOCK_TIME_NONE, dts = GST_CLOCK_TIME_NONE, duration = GST_CLOCK_TIME_NONE;
    guint64 offset_end = 0;
    guint flags = 0;
    gsize size = 0;
    Layout layout = Layout::Exact;
    // Filled by the input probe when the item reaches the element.
    bool reached = false;
    bool bad = false;      // cannot be read as a frame of the element's caps then
    bool no_caps = false;  // the element had no caps then
    int caps = -1;         // the element's caps then (interned)
    // The push's result (events: OK or ERROR for TRUE or FALSE).
    bool returned = false;
    GstFlowReturn flow = GST_FLOW_OK;
};

struct Rig::Entry {
    enum Kind {
        In,             // reached the element (input probe)
        Out,            // the element pushed it to our sink pad
        Returned,       // a push of ours returned (flow)
        StateChanging,  // a stop (to READY or NULL) begins
        StateDown,      // ... and is done: everything held was dropped
        DrainAsked,
        DrainAnswered,  // flow OK = TRUE
        NewStream,      // STREAM_START + SEGMENT after EOS were taken: a new stream (no flush)
        Error,          // the element posted an error (text), allowed or not
        Warning,
        Note,           // text from outside (a GLib warning, say), for the report
        StateUp,        // the element is back to PAUSED or PLAYING after a stop
        FlushStarting,  // we are about to push FLUSH_START (its In entry comes later)
    } kind = In;
    std::uint64_t id = 0;  // item id, 0 = not ours
    bool is_buffer = false;
    GstEventType type = GST_EVENT_UNKNOWN;
    guint32 seqnum = 0;
    int caps = -1;       // In buffer: the element's caps; Out buffer: downstream's; CAPS events: theirs
    int prev_caps = -1;  // In CAPS: the element's caps before
    GstFlowReturn flow = GST_FLOW_OK;  // Out buffer: what we returned; Returned: the result
    GstClockTime pts = GST_CLOCK_TIME_NONE, dts = GST_CLOCK_TIME_NONE, duration = GST_CLOCK_TIME_NONE;
    guint64 offset = 0, offset_end = 0;
    guint flags = 0;
    bool allowed = true;  // Error: one of the documented ones
    std::string text;
};

// ---------------------------------------------------------------------------------
// Helpers

GstCaps *capsOf(const Shape &shape)
{
    return gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, shape.format, "width", G_TYPE_INT, shape.width,
                               "height", G_TYPE_INT, shape.height, "framerate", GST_TYPE_FRACTION, shape.fps_n,
                               shape.fps_d, nullptr);
}

std::string describe(const Shape &shape)
{
    return std::string(shape.format) + " " + std::to_string(shape.width) + "x" + std::to_string(shape.height) + " " +
           std::to_string(shape.fps_n) + "/" + std::to_string(shape.fps_d);
}

const char *toString(Layout layout)
{
    switch (layout) {
    case Layout::Exact:
        return "exact";
    case Layout::Larger:
        return "larger";
    case Layout::Short:
        return "short";
    case Layout::Empty:
        return "empty";
    case Layout::MultiMemory:
        return "multi-memory";
    case Layout::PaddedMeta:
        return "padded-meta";
    case Layout::ShortMeta:
        return "short-meta";
    }
    return "?";
}

const char *toString(Downstream mode)
{
    switch (mode) {
    case Downstream::Ok:
        return "ok";
    case Downstream::Error:
        return "error";
    case Downstream::NotLinked:
        return "not-linked";
    case Downstream::Flushing:
        return "flushing";
    case Downstream::Slow:
        return "slow";
    case Downstream::Block:
        return "block";
    }
    return "?";
}

namespace {

std::string timeString(GstClockTime t)
{
    if (!GST_CLOCK_TIME_IS_VALID(t))
        return "none";
    char text[64];
    g_snprintf(text, sizeof text, "%" GST_TIME_FORMAT, GST_TIME_ARGS(t));
    return text;
}

// Rows and bytes per row of plane `plane` of `info` (its first component's).
void planeGeometry(const GstVideoInfo &info, guint plane, int &rows, int &row_bytes)
{
    rows = 0;
    row_bytes = 0;
    for (guint c = 0; c < GST_VIDEO_INFO_N_COMPONENTS(&info); ++c) {
        if (GST_VIDEO_INFO_COMP_PLANE(&info, c) != plane)
            continue;
        rows = GST_VIDEO_INFO_COMP_HEIGHT(&info, c);
        // Interleaved planes (NV12's UV, packed RGB) hold every component of a pixel.
        row_bytes = GST_VIDEO_INFO_COMP_WIDTH(&info, c) * GST_VIDEO_INFO_COMP_PSTRIDE(&info, c);
        return;
    }
}

// Whether `buffer` cannot be read as a frame of `info`: the element must drop it. With a
// video meta, every plane the meta describes must lie inside the buffer.
bool unreadable(GstBuffer *buffer, const GstVideoInfo &info)
{
    const gsize size = gst_buffer_get_size(buffer);
    const GstVideoMeta *meta = gst_buffer_get_video_meta(buffer);
    if (!meta)
        return size < GST_VIDEO_INFO_SIZE(&info);
    for (guint p = 0; p < meta->n_planes; ++p) {
        int rows = 0, row_bytes = 0;
        planeGeometry(info, p, rows, row_bytes);
        if (meta->stride[p] < row_bytes)
            return true;
        const gsize end = meta->offset[p] + gsize(meta->stride[p]) * gsize(rows - 1) + gsize(row_bytes);
        if (end > size)
            return true;
    }
    return false;
}

// A picture that moves with (sx, sy): blocks with corners, so tracking finds motion.
inline std::uint8_t texture(int x, int y, std::uint8_t seed)
{
    const int bx = x >> 3, by = y >> 3;
    return std::uint8_t(((bx * 73) ^ (by * 151)) * 29 + ((x + y) & 7) * 3 + seed);
}

void fillPlanes(guint8 *const *data, const gint *stride, const GstVideoInfo &info, const FrameSpec &spec)
{
    for (guint p = 0; p < GST_VIDEO_INFO_N_PLANES(&info); ++p) {
        int rows = 0, row_bytes = 0;
        planeGeometry(info, p, rows, row_bytes);
        const int pixel = std::max(1, GST_VIDEO_INFO_COMP_PSTRIDE(&info, p == 0 ? 0 : 1));
        for (int y = 0; y < rows; ++y) {
            guint8 *row = data[p] + gsize(y) * gsize(stride[p]);
            for (int x = 0; x < row_bytes; ++x)
                row[x] = texture(x / pixel + spec.shift_x, y + spec.shift_y, std::uint8_t(spec.seed + p * 40));
        }
    }
}

GstBuffer *allocate(gsize size)
{
    return size ? gst_buffer_new_allocate(nullptr, size, nullptr) : gst_buffer_new();
}

// A buffer laid out as `spec` says for frames of `info`.
GstBuffer *makeBuffer(const GstVideoInfo &info, const FrameSpec &spec)
{
    const gsize frame_size = GST_VIDEO_INFO_SIZE(&info);
    switch (spec.layout) {
    case Layout::Exact:
    case Layout::Larger:
    case Layout::MultiMemory: {
        const gsize size = frame_size + (spec.layout == Layout::Larger ? gsize(std::max(1, spec.extra)) : 0);
        GstBuffer *buffer = allocate(size);
        GstMapInfo map;
        gst_buffer_map(buffer, &map, GST_MAP_WRITE);
        guint8 *planes[GST_VIDEO_MAX_PLANES];
        for (guint p = 0; p < GST_VIDEO_INFO_N_PLANES(&info); ++p)
            planes[p] = map.data + GST_VIDEO_INFO_PLANE_OFFSET(&info, p);
        fillPlanes(planes, info.stride, info, spec);
        gst_buffer_unmap(buffer, &map);
        if (spec.layout != Layout::MultiMemory)
            return buffer;
        // The same bytes in 2..4 memory blocks (mapping merges them).
        const int blocks = std::clamp(spec.extra, 2, 4);
        GstMemory *whole = gst_buffer_get_all_memory(buffer);
        gst_buffer_unref(buffer);
        GstBuffer *split = gst_buffer_new();
        const gsize step = std::max<gsize>(1, size / gsize(blocks));
        for (gsize offset = 0; offset < size; offset += step)
            gst_buffer_append_memory(split, gst_memory_share(whole, gssize(offset), gssize(std::min(step, size - offset))));
        gst_memory_unref(whole);
        return split;
    }
    case Layout::Short: {
        const gsize cut = std::clamp<gsize>(gsize(std::max(1, spec.extra)), 1, frame_size);
        GstBuffer *buffer = allocate(frame_size - cut);
        if (frame_size - cut > 0) {
            GstMapInfo map;
            gst_buffer_map(buffer, &map, GST_MAP_WRITE);
            for (gsize i = 0; i < map.size; ++i)
                map.data[i] = std::uint8_t(i * 7 + spec.seed);
            gst_buffer_unmap(buffer, &map);
        }
        return buffer;
    }
    case Layout::Empty:
        return gst_buffer_new();
    case Layout::PaddedMeta:
    case Layout::ShortMeta: {
        gsize offsets[GST_VIDEO_MAX_PLANES] = {};
        gint strides[GST_VIDEO_MAX_PLANES] = {};
        gsize total = 0;
        for (guint p = 0; p < GST_VIDEO_INFO_N_PLANES(&info); ++p) {
            int rows = 0, row_bytes = 0;
            planeGeometry(info, p, rows, row_bytes);
            strides[p] = (row_bytes + std::max(0, spec.pad) + 3) & ~3;
            offsets[p] = total;
            total += gsize(strides[p]) * gsize(rows);
        }
        const gsize cut = spec.layout == Layout::ShortMeta ? std::clamp<gsize>(gsize(std::max(1, spec.extra)), 1, total) : 0;
        // Filled in full in a scratch area, then copied as far as the buffer goes.
        std::vector<guint8> scratch(total);
        guint8 *planes[GST_VIDEO_MAX_PLANES];
        for (guint p = 0; p < GST_VIDEO_INFO_N_PLANES(&info); ++p)
            planes[p] = scratch.data() + offsets[p];
        fillPlanes(planes, strides, info, spec);
        GstBuffer *buffer = allocate(total - cut);
        if (total - cut > 0)
            gst_buffer_fill(buffer, 0, scratch.data(), total - cut);
        gst_buffer_add_video_meta_full(buffer, GST_VIDEO_FRAME_FLAG_NONE, GST_VIDEO_INFO_FORMAT(&info),
                                       guint(GST_VIDEO_INFO_WIDTH(&info)), guint(GST_VIDEO_INFO_HEIGHT(&info)),
                                       GST_VIDEO_INFO_N_PLANES(&info), offsets, strides);
        return buffer;
    }
    }
    return gst_buffer_new();
}

const char *flowName(GstFlowReturn flow)
{
    return gst_flow_get_name(flow);
}

} // namespace

// ---------------------------------------------------------------------------------
// Construction

Rig::Rig(const RigOptions &options) : options_(options)
{
    element_ = gst_element_factory_make("uavstabilize", nullptr);
    if (!element_)
        throw std::runtime_error("cannot make uavstabilize (GST_PLUGIN_PATH?)");
    gst_object_ref_sink(element_);
    for (const auto &[name, value] : options.properties) {
        if (name == "max-errors")
            max_errors_ = std::atoi(value.c_str());
        gst_util_set_object_arg(G_OBJECT(element_), name.c_str(), value.c_str());
    }
    bus_ = gst_bus_new();
    gst_bus_set_sync_handler(bus_, onMessage, this, nullptr);
    gst_element_set_bus(element_, bus_);

    src_ = gst_pad_new("chaos-src", GST_PAD_SRC);
    sink_ = gst_pad_new("chaos-sink", GST_PAD_SINK);
    gst_object_ref_sink(src_);
    gst_object_ref_sink(sink_);
    gst_pad_set_element_private(src_, this);
    gst_pad_set_element_private(sink_, this);
    gst_pad_set_event_function(src_, srcEvent);
    gst_pad_set_query_function(src_, srcQuery);
    gst_pad_set_chain_function(sink_, sinkChain);
    gst_pad_set_event_function(sink_, sinkEvent);
    gst_pad_set_query_function(sink_, sinkQuery);

    element_sink_ = gst_element_get_static_pad(element_, "sink");
    GstPad *element_src = gst_element_get_static_pad(element_, "src");
    gst_pad_link(src_, element_sink_);
    gst_pad_link(element_src, sink_);
    gst_object_unref(element_src);
    probe_id_ = gst_pad_add_probe(element_sink_,
                                  GstPadProbeType(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_EVENT_DOWNSTREAM |
                                                  GST_PAD_PROBE_TYPE_EVENT_FLUSH),
                                  inputProbe, this, nullptr);
    gst_pad_set_active(sink_, TRUE);
    gst_pad_set_active(src_, TRUE);
    if (gst_element_set_state(element_, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE)
        problem("the element did not start");
    state_ = GST_STATE_PLAYING;
}

void Rig::stop()
{
    if (!element_)
        return;
    {
        std::lock_guard<std::mutex> lock(down_mutex_);
        down_stopped_ = true;
        down_changed_.notify_all();
    }
    gst_element_set_state(element_, GST_STATE_NULL);
    state_ = GST_STATE_NULL;
    {
        std::lock_guard<std::mutex> lock(down_mutex_);
        gst_buffer_replace(&last_buffer_, nullptr);
    }
    gst_pad_remove_probe(element_sink_, probe_id_);
    gst_pad_set_active(src_, FALSE);
    gst_pad_set_active(sink_, FALSE);
    gst_pad_unlink(src_, element_sink_);
    if (GstPad *peer = gst_pad_get_peer(sink_)) {
        gst_pad_unlink(peer, sink_);
        gst_object_unref(peer);
    }
    gst_object_unref(element_sink_);
    element_sink_ = nullptr;
    gst_element_set_bus(element_, nullptr);
    gst_bus_set_flushing(bus_, TRUE);
    gst_object_unref(bus_);
    bus_ = nullptr;
    gst_object_unref(element_);
    element_ = nullptr;
    gst_object_unref(src_);
    gst_object_unref(sink_);
    src_ = sink_ = nullptr;
    std::lock_guard<std::mutex> lock(mutex_);
    for (GstCaps *caps : caps_)
        gst_caps_unref(caps);
    caps_.clear();
}

Rig::~Rig()
{
    stop();
}

// ---------------------------------------------------------------------------------
// The log

void Rig::append(Entry entry)
{
    std::lock_guard<std::mutex> lock(mutex_);
    log_.push_back(std::move(entry));
    log_changed_.notify_all();
}

int Rig::internCaps(GstCaps *caps)
{
    if (!caps)
        return -1;
    for (std::size_t i = 0; i < caps_.size(); ++i)
        if (caps_[i] == caps || gst_caps_is_equal(caps_[i], caps))
            return int(i);
    caps_.push_back(gst_caps_ref(caps));
    gchar *text = gst_caps_to_string(caps);
    caps_text_.push_back(text);
    g_free(text);
    return int(caps_.size()) - 1;
}

std::uint64_t Rig::newEventId(GstEvent *event)
{
    const std::uint64_t id = next_id_++;
    std::lock_guard<std::mutex> lock(mutex_);
    Item item;
    item.type = GST_EVENT_TYPE(event);
    items_[id] = item;
    event_ids_[gst_event_get_seqnum(event)] = id;
    return id;
}

std::uint64_t Rig::idOfEvent(GstEvent *event) const
{
    const auto it = event_ids_.find(gst_event_get_seqnum(event));
    return it == event_ids_.end() ? 0 : it->second;
}

void Rig::noteResult(std::uint64_t id, GstFlowReturn flow)
{
    std::lock_guard<std::mutex> lock(mutex_);
    Item &item = items_[id];
    item.returned = true;
    item.flow = flow;
    Entry entry;
    entry.kind = Entry::Returned;
    entry.id = id;
    entry.is_buffer = item.is_buffer;
    entry.type = item.type;
    entry.flow = flow;
    log_.push_back(entry);
    log_changed_.notify_all();
}

void Rig::problem(const std::string &what)
{
    std::lock_guard<std::mutex> lock(mutex_);
    if (problems_.size() < 20)
        problems_.push_back(what);
}

std::vector<std::string> Rig::immediateProblems() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return problems_;
}

std::size_t Rig::logSize() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return log_.size();
}

Rig::Stats Rig::stats() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
}

// ---------------------------------------------------------------------------------
// Input: the probe on the element's sink pad

GstPadProbeReturn Rig::inputProbe(GstPad *pad, GstPadProbeInfo *info, gpointer user_data)
{
    auto *self = static_cast<Rig *>(user_data);
    GstCaps *current = gst_pad_get_current_caps(pad);
    Entry entry;
    entry.kind = Entry::In;
    {
        std::lock_guard<std::mutex> lock(self->mutex_);
        entry.prev_caps = self->internCaps(current);
        if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) {
            GstBuffer *buffer = GST_PAD_PROBE_INFO_BUFFER(info);
            entry.is_buffer = true;
            entry.id = GST_BUFFER_OFFSET(buffer);
            entry.caps = entry.prev_caps;
            auto it = self->items_.find(entry.id);
            if (it == self->items_.end() || !it->second.is_buffer) {
                if (self->problems_.size() < 20)
                    self->problems_.push_back("a buffer that is not ours reached the element");
            } else {
                Item &item = it->second;
                item.reached = true;
                item.caps = entry.caps;
                item.no_caps = current == nullptr;
                GstVideoInfo vinfo;
                item.bad = current && gst_video_info_from_caps(&vinfo, current) && unreadable(buffer, vinfo);
            }
        } else {
            GstEvent *event = GST_PAD_PROBE_INFO_EVENT(info);
            entry.type = GST_EVENT_TYPE(event);
            entry.seqnum = gst_event_get_seqnum(event);
            entry.id = self->idOfEvent(event);
            if (entry.type == GST_EVENT_CAPS) {
                GstCaps *caps = nullptr;
                gst_event_parse_caps(event, &caps);
                entry.caps = self->internCaps(caps);
            }
            auto it = self->items_.find(entry.id);
            if (it != self->items_.end())
                it->second.reached = true;
        }
        self->log_.push_back(entry);
        self->log_changed_.notify_all();
    }
    if (current)
        gst_caps_unref(current);
    return GST_PAD_PROBE_OK;
}

// ---------------------------------------------------------------------------------
// Upstream

bool Rig::pushEventLogged(GstEvent *event)
{
    const std::uint64_t id = newEventId(event);
    {
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.events_pushed;
    }
    const bool ok = gst_pad_push_event(src_, event);
    noteResult(id, ok ? GST_FLOW_OK : GST_FLOW_ERROR);
    return ok;
}

bool Rig::startStream(const Shape *shape, GstClockTime start)
{
    static std::atomic<int> streams{0};
    const std::string name = "chaos-" + std::to_string(++streams);
    bool ok = pushEventLogged(gst_event_new_stream_start(name.c_str()));
    if (shape)
        ok = pushCaps(*shape) && ok;
    ok = pushSegment(start) && ok;
    eos_sent_ = false;
    stream_started_ = true;
    return ok;
}

bool Rig::ensureStreaming()
{
    if (state_.load() < GST_STATE_PAUSED)
        return false;
    if (need_restart_.load()) {
        if (startStream(&shape_))
            need_restart_ = false;
    }
    const gint64 segment = pending_segment_.exchange(-1);
    if (segment >= 0 && !eos_sent_)
        pushSegment(GstClockTime(segment));
    return true;
}

bool Rig::pushCaps(const Shape &shape)
{
    GstCaps *caps = capsOf(shape);
    const bool ok = pushEventLogged(gst_event_new_caps(caps));
    gst_caps_unref(caps);
    // Our pad keeps the caps it was given (unless it was flushing) and sends them again
    // before the next buffer if the element refused them: frames are made for those.
    if (GstCaps *current = gst_pad_get_current_caps(src_)) {
        GstVideoInfo info;
        if (gst_video_info_from_caps(&info, current)) {
            shape_.format = gst_video_format_to_string(GST_VIDEO_INFO_FORMAT(&info));
            shape_.width = GST_VIDEO_INFO_WIDTH(&info);
            shape_.height = GST_VIDEO_INFO_HEIGHT(&info);
            shape_.fps_n = GST_VIDEO_INFO_FPS_N(&info);
            shape_.fps_d = GST_VIDEO_INFO_FPS_D(&info);
        }
        gst_caps_unref(current);
    }
    return ok;
}

bool Rig::pushSegment(GstClockTime start)
{
    GstSegment segment;
    gst_segment_init(&segment, GST_FORMAT_TIME);
    segment.start = start;
    segment.time = start;
    return pushEventLogged(gst_event_new_segment(&segment));
}

bool Rig::pushEvent(GstEvent *event)
{
    return pushEventLogged(event);
}

bool Rig::pushEos()
{
    const bool ok = pushEventLogged(gst_event_new_eos());
    eos_sent_ = eos_sent_ || ok;
    return ok;
}

bool Rig::continueAfterEos()
{
    static std::atomic<int> streams{0};
    const std::string name = "chaos-next-" + std::to_string(++streams);
    const bool started = pushEventLogged(gst_event_new_stream_start(name.c_str()));
    const bool segment = started && pushSegment(0);
    if (started && segment) {
        eos_sent_ = false;
        Entry entry;
        entry.kind = Entry::NewStream;
        entry.id = next_id_++;  // items after this belong to the new stream
        append(entry);
    }
    return started && segment;
}

bool Rig::drain()
{
    const std::uint64_t id = next_id_++;
    Entry asked;
    asked.kind = Entry::DrainAsked;
    asked.id = id;
    append(asked);
    GstQuery *query = gst_query_new_drain();
    const bool ok = gst_pad_peer_query(src_, query);
    gst_query_unref(query);
    Entry answered;
    answered.kind = Entry::DrainAnswered;
    answered.id = id;
    answered.flow = ok ? GST_FLOW_OK : GST_FLOW_ERROR;
    append(answered);
    return ok;
}

GstFlowReturn Rig::pushFrame(const FrameSpec &spec)
{
    // A source never sends data without a segment (a flush took it off our pad while the
    // element was down, say).
    if (GstEvent *segment = gst_pad_get_sticky_event(src_, GST_EVENT_SEGMENT, 0))
        gst_event_unref(segment);
    else
        pushSegment(0);
    GstCaps *caps = capsOf(shape_);
    GstVideoInfo info;
    gst_video_info_from_caps(&info, caps);
    gst_caps_unref(caps);
    GstBuffer *buffer = makeBuffer(info, spec);
    const std::uint64_t id = next_id_++;
    GST_BUFFER_PTS(buffer) = spec.pts;
    GST_BUFFER_DTS(buffer) = spec.dts;
    GST_BUFFER_DURATION(buffer) = spec.duration;
    GST_BUFFER_OFFSET(buffer) = id;
    GST_BUFFER_OFFSET_END(buffer) = id * 3 + 1;
    GST_BUFFER_FLAGS(buffer) = spec.flags & kFrameFlags;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        Item item;
        item.is_buffer = true;
        item.pts = spec.pts;
        item.dts = spec.dts;
        item.duration = spec.duration;
        item.offset_end = id * 3 + 1;
        item.flags = spec.flags & kFrameFlags;
        item.size = gst_buffer_get_size(buffer);
        item.layout = spec.layout;
        items_[id] = item;
        ++stats_.frames_pushed;
    }

    // Whatever stopped the element since the last push reset its count of bad buffers.
    const unsigned epoch = state_epoch_.load();
    if (epoch != seen_state_epoch_) {
        seen_state_epoch_ = epoch;
        bad_run_ = 0;
        bad_run_known_ = true;
    }
    const unsigned version = max_errors_version_.load();
    const int max_errors = max_errors_.load();
    const int warnings = bad_warnings_.load(), errors = bad_errors_.load(), negotiation = negotiation_errors_.load();

    const GstFlowReturn ret = gst_pad_push(src_, buffer);

    noteResult(id, ret);
    const bool state_stable = state_epoch_.load() == epoch;
    const bool max_stable = max_errors_version_.load() == version && !(version & 1);
    checkBadBufferAccounting(id, ret, bad_warnings_.load() - warnings, bad_errors_.load() - errors,
                             negotiation_errors_.load() - negotiation, state_stable && max_stable, max_errors);
    if (!state_stable) {
        seen_state_epoch_ = state_epoch_.load();
        bad_run_known_ = false;
    }
    return ret;
}

// The element drops a bad buffer with one warning and returns OK, until more than
// max-errors in a row: then one error and GST_FLOW_ERROR. A good buffer taken resets the
// count, as do FLUSH_STOP and a stop. Checked here, as each push returns.
void Rig::checkBadBufferAccounting(std::uint64_t id, GstFlowReturn ret, int warnings, int errors, int negotiation,
                                   bool stable, int max_errors)
{
    Item item;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        item = items_[id];
        if (item.bad && item.reached && !item.no_caps)
            ++stats_.bad_pushed;
    }
    const std::string what = "frame " + std::to_string(id) + " (" + toString(item.layout) + ", " +
                             std::to_string(item.size) + " bytes, returned " + flowName(ret) + ")";
    if (!item.reached) {
        if (warnings || errors || negotiation)
            problem(what + ": a bad-buffer message without a chain call");
        return;
    }
    if (item.no_caps) {
        if (ret == GST_FLOW_OK)
            problem(what + ": taken although the element had no caps");
        else if (ret == GST_FLOW_NOT_NEGOTIATED && negotiation != 1)
            problem(what + ": NOT_NEGOTIATED without its error message");
        return;
    }
    if (!item.bad) {
        if (warnings || errors)
            problem(what + ": a readable frame was dropped as bad");
        if (ret == GST_FLOW_OK) {
            bad_run_ = 0;
            bad_run_known_ = true;
        } else {
            bad_run_known_ = false;  // refused before or after the check: the count may or may not be reset
        }
        return;
    }
    bool fatal;
    if (ret == GST_FLOW_OK && warnings == 1 && errors == 0) {
        fatal = false;
    } else if (ret == GST_FLOW_ERROR && errors == 1 && warnings == 0) {
        fatal = true;
    } else if (ret != GST_FLOW_OK && warnings == 0 && errors == 0) {
        return;  // refused before it was looked at (flushing, downstream stopped): not counted
    } else {
        problem(what + ": a bad buffer gave " + std::to_string(warnings) + " warnings and " + std::to_string(errors) +
                " errors");
        bad_run_known_ = false;
        return;
    }
    if (bad_run_known_ && stable) {
        const bool expected = max_errors >= 0 && bad_run_ + 1 > max_errors;
        if (fatal != expected)
            problem(what + ": with max-errors=" + std::to_string(max_errors) + " and " + std::to_string(bad_run_) +
                    " bad buffers in a row before it, expected " + (expected ? "an error" : "a warning"));
    }
    ++bad_run_;
}

void Rig::note(const std::string &text)
{
    Entry entry;
    entry.kind = Entry::Note;
    entry.text = text;
    append(entry);
}

void Rig::setMaxErrors(int value)
{
    ++max_errors_version_;  // odd while changing
    max_errors_ = value;
    g_object_set(element_, "max-errors", value, nullptr);
    ++max_errors_version_;
}

// ---------------------------------------------------------------------------------
// Any thread

void Rig::flush(GstClockTime segment_start)
{
    // One flush at a time: two overlapping ones (as from two threads seeking at once)
    // turn the second FLUSH_STOP into one without a FLUSH_START (the pad was already
    // flushing and refused the second FLUSH_START); with a downstream that blocks until
    // the seeking thread itself unblocks it, that deadlocks by construction. Overlapping
    // flushes have their own test (overlapping_flushes_neither_hang_nor_stall).
    std::lock_guard<std::mutex> one_flush(flush_mutex_);
    flushStart();
    // Like a base source: the streaming thread has stopped (it holds the stream lock
    // while it pushes) before FLUSH_STOP and the new segment go out.
    std::lock_guard<std::mutex> stream(stream_mutex_);
    flushStop(segment_start);
}

bool Rig::flushStart()
{
    GstEvent *start = gst_event_new_flush_start();
    const std::uint64_t start_id = newEventId(start);
    // FLUSH_START sets our pad and the element's sink pad flushing before the probe logs
    // it: a push of the streaming thread refused in between (an EOS accepted by the
    // element but then not stored on its flushing pad) must find its reason in the log.
    Entry starting;
    starting.kind = Entry::FlushStarting;
    starting.id = start_id;
    append(starting);
    const bool started = gst_pad_push_event(src_, start);
    noteResult(start_id, started ? GST_FLOW_OK : GST_FLOW_ERROR);
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.flushes;
    return started;
}

bool Rig::flushStop(GstClockTime segment_start, bool segment)
{
    GstEvent *stop_event = gst_event_new_flush_stop(TRUE);
    const std::uint64_t stop_id = newEventId(stop_event);
    const bool stopped = gst_pad_push_event(src_, stop_event);
    noteResult(stop_id, stopped ? GST_FLOW_OK : GST_FLOW_ERROR);
    eos_sent_ = false;
    if (stopped) {
        bad_run_ = 0;
        bad_run_known_ = true;
    } else {
        bad_run_known_ = false;
    }
    // FLUSH_STOP took the segment off our pad: a new one, even if the element is down
    // (our pad keeps it and sends it on later). Without one, pushFrame() sends one.
    if (segment)
        pushSegment(segment_start);
    return stopped;
}

void Rig::holdNextFlushStart()
{
    std::lock_guard<std::mutex> lock(down_mutex_);
    hold_flush_start_ = true;
    flush_start_held_ = false;
}

bool Rig::waitForHeldFlushStart(int timeout_ms)
{
    std::unique_lock<std::mutex> lock(down_mutex_);
    return down_changed_.wait_for(lock, std::chrono::milliseconds(timeout_ms), [this] { return flush_start_held_; });
}

void Rig::releaseFlushStart()
{
    std::lock_guard<std::mutex> lock(down_mutex_);
    hold_flush_start_ = false;
    down_changed_.notify_all();
}

bool Rig::seek(bool flushing, GstClockTime start)
{
    GstEvent *seek = gst_event_new_seek(1.0, GST_FORMAT_TIME,
                                        GstSeekFlags(flushing ? GST_SEEK_FLAG_FLUSH : GST_SEEK_FLAG_NONE),
                                        GST_SEEK_TYPE_SET, gint64(start), GST_SEEK_TYPE_NONE, -1);
    return gst_pad_push_event(sink_, seek);
}

gboolean Rig::srcEvent(GstPad *pad, GstObject *, GstEvent *event)
{
    auto *self = static_cast<Rig *>(gst_pad_get_element_private(pad));
    if (GST_EVENT_TYPE(event) != GST_EVENT_SEEK) {
        gst_event_unref(event);
        return TRUE;
    }
    GstSeekFlags flags;
    GstSeekType start_type, stop_type;
    gint64 start = 0, stop = 0;
    gst_event_parse_seek(event, nullptr, nullptr, &flags, &start_type, &start, &stop_type, &stop);
    gst_event_unref(event);
    const GstClockTime position = start >= 0 ? GstClockTime(start) : 0;
    if (flags & GST_SEEK_FLAG_FLUSH) {
        self->flush(position);
    } else {
        // The streaming thread sends the new segment before its next data (waiting for it
        // here could wait for a downstream that only this thread would unblock).
        self->pending_segment_ = gint64(position);
    }
    return TRUE;
}

gboolean Rig::srcQuery(GstPad *, GstObject *, GstQuery *query)
{
    if (GST_QUERY_TYPE(query) == GST_QUERY_LATENCY) {
        gst_query_set_latency(query, FALSE, 0, GST_CLOCK_TIME_NONE);
        return TRUE;
    }
    return FALSE;
}

GstStateChangeReturn Rig::setState(GstState state)
{
    const GstState current = state_.load();
    GstStateChangeReturn ret;
    if (state < GST_STATE_PAUSED && current >= GST_STATE_PAUSED) {
        Entry changing;
        changing.kind = Entry::StateChanging;
        append(changing);
        // A pipeline stops its sink first: our sink pad goes inactive (it unblocks and
        // refuses data; and a FLUSH_START that reached it without its FLUSH_STOP, because
        // the element went down in between, is forgotten when it comes back).
        {
            std::lock_guard<std::mutex> lock(down_mutex_);
            down_stopped_ = true;
            down_changed_.notify_all();
        }
        gst_pad_set_active(sink_, FALSE);
        ret = gst_element_set_state(element_, state);
        ++state_epoch_;
        need_restart_ = true;
        Entry down;
        down.kind = Entry::StateDown;
        append(down);
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.state_downs;
    } else if (state >= GST_STATE_PAUSED && current < GST_STATE_PAUSED) {
        // ... and starts it first.
        gst_pad_set_active(sink_, TRUE);
        {
            std::lock_guard<std::mutex> lock(down_mutex_);
            down_stopped_ = false;
            down_flushing_ = false;
        }
        // Under the stream lock, so that the streaming thread's next operation sees the
        // element up and starts the stream afresh (STREAM_START, CAPS, SEGMENT) before
        // anything else.
        std::lock_guard<std::mutex> stream(stream_mutex_);
        ret = gst_element_set_state(element_, state);
        state_ = state;
        Entry up;
        up.kind = Entry::StateUp;
        append(up);
        return ret;
    } else {
        ret = gst_element_set_state(element_, state);
    }
    state_ = state;
    return ret;
}

void Rig::setDownstream(Downstream mode, bool once, int slow_us)
{
    std::lock_guard<std::mutex> lock(down_mutex_);
    mode_ = mode;
    mode_once_ = once;
    slow_us_ = slow_us;
    down_changed_.notify_all();
}

void Rig::setProperty(const std::string &name, const std::string &value)
{
    if (name == "max-errors") {
        setMaxErrors(std::atoi(value.c_str()));
        return;
    }
    gst_util_set_object_arg(G_OBJECT(element_), name.c_str(), value.c_str());
}

void Rig::queryFromDownstream()
{
    GstQuery *latency = gst_query_new_latency();
    gst_pad_peer_query(sink_, latency);
    gst_query_unref(latency);
    GstCaps *caps = gst_pad_peer_query_caps(sink_, nullptr);
    if (caps)
        gst_caps_unref(caps);
}

// ---------------------------------------------------------------------------------
// Downstream: our sink pad

GstFlowReturn Rig::sinkChain(GstPad *pad, GstObject *, GstBuffer *buffer)
{
    auto *self = static_cast<Rig *>(gst_pad_get_element_private(pad));
    GstCaps *current = gst_pad_get_current_caps(pad);
    std::size_t index;
    {
        Entry entry;
        entry.kind = Entry::Out;
        entry.is_buffer = true;
        entry.id = GST_BUFFER_OFFSET(buffer);
        entry.pts = GST_BUFFER_PTS(buffer);
        entry.dts = GST_BUFFER_DTS(buffer);
        entry.duration = GST_BUFFER_DURATION(buffer);
        entry.offset = GST_BUFFER_OFFSET(buffer);
        entry.offset_end = GST_BUFFER_OFFSET_END(buffer);
        entry.flags = GST_BUFFER_FLAGS(buffer);
        std::lock_guard<std::mutex> lock(self->mutex_);
        entry.caps = self->internCaps(current);
        index = self->log_.size();
        self->log_.push_back(entry);
        ++self->stats_.frames_out;
        self->log_changed_.notify_all();
    }
    if (current)
        gst_caps_unref(current);

    GstFlowReturn ret = GST_FLOW_OK;
    int sleep_us = 0;
    {
        std::unique_lock<std::mutex> lock(self->down_mutex_);
        // A sink holds the buffer while it blocks (and, keeping the last sample, after).
        if (self->options_.hold_last)
            gst_buffer_replace(&self->last_buffer_, buffer);
        for (;;) {
            if (self->down_stopped_ || self->down_flushing_) {
                ret = GST_FLOW_FLUSHING;
                break;
            }
            if (self->mode_ == Downstream::Block) {
                self->down_changed_.wait(lock);
                continue;
            }
            switch (self->mode_) {
            case Downstream::Error:
                ret = GST_FLOW_ERROR;
                break;
            case Downstream::NotLinked:
                ret = GST_FLOW_NOT_LINKED;
                break;
            case Downstream::Flushing:
                ret = GST_FLOW_FLUSHING;
                break;
            case Downstream::Slow:
                sleep_us = self->slow_us_;
                break;
            default:
                break;
            }
            if (self->mode_once_)
                self->mode_ = Downstream::Ok;
            break;
        }
    }
    if (sleep_us > 0)
        std::this_thread::sleep_for(std::chrono::microseconds(sleep_us));
    gst_buffer_unref(buffer);
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->log_[index].flow = ret;
    if (ret != GST_FLOW_OK)
        ++self->stats_.downstream_errors;
    ++self->buffers_returned_;
    return ret;
}

gboolean Rig::sinkEvent(GstPad *pad, GstObject *, GstEvent *event)
{
    auto *self = static_cast<Rig *>(gst_pad_get_element_private(pad));
    const GstEventType type = GST_EVENT_TYPE(event);
    if (type == GST_EVENT_FLUSH_START || type == GST_EVENT_FLUSH_STOP) {
        std::unique_lock<std::mutex> lock(self->down_mutex_);
        self->down_flushing_ = type == GST_EVENT_FLUSH_START;
        self->down_changed_.notify_all();
        if (type == GST_EVENT_FLUSH_START && self->hold_flush_start_ && !self->flush_start_held_) {
            // A downstream slow to take FLUSH_START (holdNextFlushStart()).
            self->flush_start_held_ = true;
            self->down_changed_.notify_all();
            self->down_changed_.wait(lock, [self] { return !self->hold_flush_start_ || self->down_stopped_; });
        }
    }
    Entry entry;
    entry.kind = Entry::Out;
    entry.type = type;
    entry.seqnum = gst_event_get_seqnum(event);
    {
        std::lock_guard<std::mutex> lock(self->mutex_);
        entry.id = self->idOfEvent(event);
        if (type == GST_EVENT_CAPS) {
            GstCaps *caps = nullptr;
            gst_event_parse_caps(event, &caps);
            entry.caps = self->internCaps(caps);
        }
        if (type == GST_EVENT_EOS)
            ++self->stats_.eos_out;
        self->log_.push_back(entry);
        self->log_changed_.notify_all();
    }
    gst_event_unref(event);
    if (type == GST_EVENT_EOS)
        ++self->eos_seen_;
    return TRUE;
}

gboolean Rig::sinkQuery(GstPad *pad, GstObject *, GstQuery *query)
{
    auto *self = static_cast<Rig *>(gst_pad_get_element_private(pad));
    switch (GST_QUERY_TYPE(query)) {
    case GST_QUERY_CAPS: {
        GstCaps *filter = nullptr;
        gst_query_parse_caps(query, &filter);
        GstCaps *result = filter ? gst_caps_ref(filter) : gst_caps_new_empty_simple("video/x-raw");
        gst_query_set_caps_result(query, result);
        gst_caps_unref(result);
        return TRUE;
    }
    case GST_QUERY_ACCEPT_CAPS:
        gst_query_set_accept_caps_result(query, TRUE);
        return TRUE;
    case GST_QUERY_ALLOCATION: {
        if (self->options_.pool_max < 0)
            return FALSE;
        GstCaps *caps = nullptr;
        gst_query_parse_allocation(query, &caps, nullptr);
        GstVideoInfo info;
        if (!caps || !gst_video_info_from_caps(&info, caps))
            return FALSE;
        GstBufferPool *pool = gst_video_buffer_pool_new();
        gst_query_add_allocation_pool(query, pool, guint(GST_VIDEO_INFO_SIZE(&info)), 0, guint(self->options_.pool_max));
        gst_object_unref(pool);
        if (self->options_.video_meta)
            gst_query_add_allocation_meta(query, GST_VIDEO_META_API_TYPE, nullptr);
        return TRUE;
    }
    default:
        return FALSE;
    }
}

// ---------------------------------------------------------------------------------
// Messages

GstBusSyncReply Rig::onMessage(GstBus *, GstMessage *message, gpointer user_data)
{
    auto *self = static_cast<Rig *>(user_data);
    const GstMessageType type = GST_MESSAGE_TYPE(message);
    // A sync handler that drops a message owns it.
    if (type != GST_MESSAGE_ERROR && type != GST_MESSAGE_WARNING) {
        gst_message_unref(message);
        return GST_BUS_DROP;
    }
    GError *error = nullptr;
    gchar *debug = nullptr;
    if (type == GST_MESSAGE_ERROR)
        gst_message_parse_error(message, &error, &debug);
    else
        gst_message_parse_warning(message, &error, &debug);
    const bool stream = error->domain == GST_STREAM_ERROR;
    const bool format = stream && error->code == GST_STREAM_ERROR_FORMAT;
    const bool negotiation = error->domain == GST_CORE_ERROR && error->code == GST_CORE_ERROR_NEGOTIATION;
    // What the element may post: bad buffers (STREAM FORMAT), a buffer before caps, and
    // a flow error it reports itself once upstream has sent EOS.
    const bool flow_error = stream && error->code == GST_STREAM_ERROR_FAILED && debug &&
                            std::strstr(debug, "streaming stopped, reason");
    Entry entry;
    entry.kind = type == GST_MESSAGE_ERROR ? Entry::Error : Entry::Warning;
    entry.text = std::string(g_quark_to_string(error->domain)) + " " + std::to_string(error->code) + ": " +
                 error->message + " | " + (debug ? debug : "");
    if (type == GST_MESSAGE_ERROR) {
        entry.allowed = format || negotiation || flow_error;
        if (format)
            ++self->bad_errors_;
        if (negotiation)
            ++self->negotiation_errors_;
    } else {
        // Warnings: bad buffers dropped; anything else (a frame passed through
        // uncorrected, settings refused) is reported by check().
        entry.allowed = format;
        if (format)
            ++self->bad_warnings_;
    }
    {
        std::lock_guard<std::mutex> lock(self->mutex_);
        if (type == GST_MESSAGE_ERROR)
            ++self->stats_.errors_posted;
        else
            ++self->stats_.warnings_posted;
        self->log_.push_back(entry);
        self->log_changed_.notify_all();
    }
    g_error_free(error);
    g_free(debug);
    gst_message_unref(message);
    return GST_BUS_DROP;
}

// ---------------------------------------------------------------------------------
// Waiting

bool Rig::waitForEosAfter(std::size_t from, int timeout_ms)
{
    return waitForEventAfter(GST_EVENT_EOS, from, timeout_ms);
}

bool Rig::waitForEventAfter(GstEventType type, std::size_t from, int timeout_ms)
{
    std::unique_lock<std::mutex> lock(mutex_);
    return log_changed_.wait_for(lock, std::chrono::milliseconds(timeout_ms), [&] {
        for (std::size_t i = from; i < log_.size(); ++i)
            if (log_[i].kind == Entry::Out && !log_[i].is_buffer && log_[i].type == type)
                return true;
        return false;
    });
}

std::vector<std::uint64_t> Rig::framesOutSince(std::size_t from) const
{
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::uint64_t> ids;
    for (std::size_t i = from; i < log_.size(); ++i)
        if (log_[i].kind == Entry::Out && log_[i].is_buffer)
            ids.push_back(log_[i].id);
    return ids;
}

// ---------------------------------------------------------------------------------
// The contract, checked over the whole log

std::string Rig::describe(const Entry &e) const
{
    std::ostringstream out;
    static const char *kinds[] = {"in",     "out",        "returned", "stopping", "stopped", "drain?",
                                  "drain!", "new-stream", "ERROR",    "warning",  "note",    "started",
                                  "flush-starting"};
    out << kinds[e.kind] << " ";
    if (e.kind == Entry::In || e.kind == Entry::Out || e.kind == Entry::Returned) {
        if (e.is_buffer)
            out << "frame " << e.id;
        else
            out << gst_event_type_get_name(e.type) << " " << e.id << " (seqnum " << e.seqnum << ")";
    } else {
        out << e.id;
    }
    if (e.kind == Entry::Out && e.is_buffer)
        out << " pts " << timeString(e.pts) << " returned " << flowName(e.flow);
    if (e.kind == Entry::Returned || e.kind == Entry::DrainAnswered)
        out << " -> " << flowName(e.flow);
    if (e.caps >= 0 && std::size_t(e.caps) < caps_text_.size())
        out << " [" << caps_text_[std::size_t(e.caps)] << "]";
    if (!e.text.empty())
        out << " " << e.text;
    return out.str();
}

std::string Rig::describeLog(std::size_t count) const
{
    const std::size_t size = logSize();
    return describeLogRange(size > count ? size - count : 0, size);
}

std::string Rig::describeLogRange(std::size_t first, std::size_t last) const
{
    std::lock_guard<std::mutex> lock(mutex_);
    std::ostringstream out;
    for (std::size_t i = first; i < std::min(last, log_.size()); ++i)
        out << "  #" << i << " " << describe(log_[i]) << "\n";
    return out.str();
}

// The rules, per "epoch" (the input between two resets: FLUSH_STOP reaching the element,
// or a stop to READY/NULL). An item's place is where it reached the element (its In entry;
// frames reach it in push order).
//  1. What comes out was taken in: frames whose push returned OK and that were readable
//     under the element's caps then (bad ones are dropped), events the element saw.
//  2. Frames and non-sticky events (GAP, custom) come out in the order they came in, each
//     at most once. Sticky events (STREAM_START, CAPS, SEGMENT, TAG, EOS) may be sent
//     again by the pads after a failed push; each comes out neither before a frame that
//     came in before it (of a live epoch) nor after one that came in after it.
//  3. Per epoch, the frames that come out are a prefix of the frames taken: a flush, a
//     stop or downstream refusing data may cut the tail, nothing is lost in between.
//  4. After FLUSH_STOP has gone downstream, or a stop, nothing of an older epoch comes
//     out (frames, non-sticky events).
//  5. A frame comes out with its PTS, DTS, duration, offsets and flags, and under the caps
//     it came in with. After downstream refused a frame, no frame of that epoch follows.
//  6. Drain points: when EOS or new caps come out, or a DRAIN query is answered TRUE,
//     every frame taken before them in their epoch is already out.
//  7. A push that returned an error has a reason: FLUSHING during a flush or a stop or
//     after downstream said so, NOT_LINKED / ERROR after downstream said so (ERROR also
//     after an error message), EOS after our EOS went out and before a new stream,
//     NOT_NEGOTIATED without caps. A frame of a new stream started after EOS (STREAM_START
//     and SEGMENT taken) is never refused with EOS.
//  8. The element posts no error or warning other than the documented ones.
std::string Rig::check() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::string> found = problems_;
    auto fail = [&](const std::string &what, std::size_t at) {
        if (found.size() < 12)
            found.push_back(what + " (log #" + std::to_string(at) + ")");
    };

    struct Taken {
        std::size_t key;  // where it came in
        std::uint64_t id;
    };
    struct Epoch {
        std::vector<Taken> taken;  // frames, in order
        std::size_t next = 0;      // taken[0..next) came out
        bool flushing = false, stopping = false, element_error = false, eos_out = false;
        std::set<GstFlowReturn> refused;    // what downstream returned
        std::uint64_t new_stream_from = 0;  // items from this id on belong to a stream started after EOS
    };
    std::vector<Epoch> epochs(1);
    std::map<std::uint64_t, int> frame_epoch;
    std::map<std::uint64_t, std::size_t> frame_key;
    std::map<std::uint64_t, std::size_t> event_last_in;  // event id -> its latest In entry
    std::map<std::size_t, int> in_epoch;                  // In entry -> epoch
    std::map<std::size_t, bool> in_new_caps;              // In entry of CAPS -> differs from the caps before
    std::map<guint32, int> flush_stop_epoch;
    std::map<std::uint64_t, std::size_t> drain_key;
    std::map<std::uint64_t, int> drain_epoch;
    std::set<std::uint64_t> frames_out;
    std::set<std::size_t> events_out;  // In entries already matched by an Out
    std::size_t last_key = 0;          // place of the last frame or event out (0: none)
    std::size_t last_frame_key = 0;
    int floor = 0;
    std::set<std::uint64_t> arrived;  // items the element has seen so far
    bool down = false;  // between a stop's start and the element being up again (epochs may pass)

    // Frames of epoch e taken before place `key` that have not come out.
    auto missingBefore = [&](int e, std::size_t key) {
        const Epoch &ep = epochs[std::size_t(e)];
        std::string missing;
        for (std::size_t i = ep.next; i < ep.taken.size() && ep.taken[i].key < key && missing.size() < 80; ++i)
            missing += (missing.empty() ? "" : " ") + std::to_string(ep.taken[i].id);
        return missing;
    };
    auto anyDownstreamFailure = [&] {
        for (const Epoch &ep : epochs)
            if (!ep.refused.empty() || ep.element_error)
                return true;
        return false;
    };

    for (std::size_t at = 0; at < log_.size(); ++at) {
        const Entry &e = log_[at];
        const int current = int(epochs.size()) - 1;
        switch (e.kind) {
        case Entry::In: {
            in_epoch[at] = current;
            arrived.insert(e.id);
            if (e.is_buffer) {
                const auto it = items_.find(e.id);
                if (it == items_.end())
                    break;
                const Item &item = it->second;
                if (item.returned && item.flow == GST_FLOW_OK && !item.bad && !item.no_caps) {
                    epochs.back().taken.push_back({at, e.id});
                    frame_epoch[e.id] = current;
                    frame_key[e.id] = at;
                }
            } else if (e.type == GST_EVENT_FLUSH_START) {
                epochs.back().flushing = true;
            } else if (e.type == GST_EVENT_FLUSH_STOP) {
                epochs.emplace_back();
                flush_stop_epoch[e.seqnum] = int(epochs.size()) - 1;
            } else if (e.id) {
                event_last_in[e.id] = at;
                if (e.type == GST_EVENT_CAPS)
                    in_new_caps[at] = e.caps != e.prev_caps;
            }
            break;
        }
        case Entry::FlushStarting:
            epochs.back().flushing = true;
            break;
        case Entry::StateChanging:
            epochs.back().stopping = true;
            down = true;
            break;
        case Entry::StateUp:
            down = false;
            break;
        case Entry::StateDown:
            epochs.emplace_back();
            floor = int(epochs.size()) - 1;
            break;
        case Entry::NewStream:
            epochs.back().new_stream_from = e.id;
            break;
        case Entry::Error:
        case Entry::Warning:
            if (e.kind == Entry::Error)
                epochs.back().element_error = true;
            if (!e.allowed)
                fail(std::string("the element posted an unexpected ") + (e.kind == Entry::Error ? "error" : "warning") +
                         ": " + e.text,
                     at);
            else if (e.kind == Entry::Error && e.text.find("streaming stopped") != std::string::npos &&
                     !anyDownstreamFailure())
                fail("a flow error was posted although downstream never refused data: " + e.text, at);
            break;
        case Entry::Note:
            break;
        case Entry::DrainAsked:
            drain_key[e.id] = at;
            drain_epoch[e.id] = current;
            break;
        case Entry::DrainAnswered:
            if (e.flow == GST_FLOW_OK) {
                const std::string missing = missingBefore(drain_epoch[e.id], drain_key[e.id]);
                if (!missing.empty())
                    fail("DRAIN answered TRUE with frames still held: " + missing, at);
            }
            break;
        case Entry::Returned: {
            if (e.flow == GST_FLOW_OK || e.type == GST_EVENT_FLUSH_START || e.type == GST_EVENT_FLUSH_STOP)
                break;
            const auto it = items_.find(e.id);
            // Not seen by the element before the push returned: refused by the pads
            // themselves (flushing, EOS), not the element's doing. (A FLUSH_START sets the
            // pad flushing a moment before the probe logs it; our pad may send a refused
            // sticky event again later, which then arrives after this entry.)
            if (it == items_.end() || !arrived.count(e.id))
                break;
            const Item &item = it->second;
            // The reason may have come in any epoch since the item was pushed.
            bool flushing = false, stopping = down, element_error = false, eos_out = false;
            std::set<GstFlowReturn> refused;
            std::uint64_t new_stream_from = 0;
            for (int i = std::max(0, current - 2); i <= current; ++i) {
                const Epoch &ep = epochs[std::size_t(i)];
                flushing |= ep.flushing;
                stopping |= ep.stopping;
                element_error |= ep.element_error;
                eos_out |= ep.eos_out;
                refused.insert(ep.refused.begin(), ep.refused.end());
                new_stream_from = std::max(new_stream_from, ep.new_stream_from);
            }
            bool explained = false;
            switch (e.flow) {
            case GST_FLOW_FLUSHING:
                explained = flushing || stopping || refused.count(GST_FLOW_FLUSHING);
                break;
            case GST_FLOW_NOT_LINKED:
                explained = refused.count(GST_FLOW_NOT_LINKED) > 0;
                break;
            case GST_FLOW_ERROR:
                explained = refused.count(GST_FLOW_ERROR) > 0 || element_error || (item.is_buffer && item.bad) ||
                            (!item.is_buffer && (flushing || stopping || !refused.empty() || eos_out));
                break;
            case GST_FLOW_EOS:
                explained = true;
                if (new_stream_from && e.id > new_stream_from)
                    fail("frame " + std::to_string(e.id) +
                             " of a new stream (STREAM_START and SEGMENT taken after EOS) was refused with EOS",
                         at);
                break;
            case GST_FLOW_NOT_NEGOTIATED:
                explained = item.no_caps || (!item.is_buffer && (flushing || stopping || !refused.empty()));
                break;
            default:
                break;
            }
            if (!explained)
                fail(std::string(item.is_buffer ? "frame" : gst_event_type_get_name(item.type)) + " " +
                         std::to_string(e.id) + " refused with " + flowName(e.flow) + " for no reason",
                     at);
            break;
        }
        case Entry::Out: {
            if (e.is_buffer) {
                const std::string frame = "frame " + std::to_string(e.id);
                const auto it = items_.find(e.id);
                if (it == items_.end() || !it->second.is_buffer) {
                    fail("a buffer that was never pushed came out (offset " + std::to_string(e.offset) + ")", at);
                    break;
                }
                const Item &item = it->second;
                if (!frames_out.insert(e.id).second) {
                    fail(frame + " came out twice", at);
                    break;
                }
                if (!frame_epoch.count(e.id)) {
                    if (item.bad)
                        fail(frame + " (" + toString(item.layout) + ", unreadable) came out: it should be dropped", at);
                    else
                        fail(frame + " came out although its push returned " + flowName(item.flow), at);
                    break;
                }
                const int fe = frame_epoch[e.id];
                const std::size_t key = frame_key[e.id];
                Epoch &ep = epochs[std::size_t(fe)];
                if (fe < floor)
                    fail(frame + " came out after a flush or stop that dropped it (stale)", at);
                if (key <= last_key)
                    fail(frame + " came out of order (after an item that came in after it)", at);
                last_key = std::max(last_key, key);
                last_frame_key = std::max(last_frame_key, key);
                if (!ep.refused.empty())
                    fail(frame + " came out after downstream refused a frame of its epoch", at);
                // Rule 3: a prefix of what was taken.
                std::size_t k = ep.next;
                while (k < ep.taken.size() && ep.taken[k].id != e.id)
                    ++k;
                if (k == ep.taken.size()) {
                    fail(frame + " is not among the frames taken in its epoch", at);
                } else {
                    if (k != ep.next) {
                        std::string lost;
                        for (std::size_t i = ep.next; i < k && lost.size() < 80; ++i)
                            lost += (lost.empty() ? "" : " ") + std::to_string(ep.taken[i].id);
                        fail("frames lost before " + frame + ": " + lost, at);
                    }
                    ep.next = k + 1;
                }
                if (e.pts != item.pts || e.dts != item.dts || e.duration != item.duration ||
                    e.offset_end != item.offset_end || (e.flags & kFrameFlags) != item.flags)
                    fail(frame + " came out with other metadata: pts " + timeString(e.pts) + " (in " +
                             timeString(item.pts) + "), dts " + timeString(e.dts) + " (in " + timeString(item.dts) +
                             "), duration " + timeString(e.duration) + ", flags " +
                             std::to_string(e.flags & kFrameFlags) + " (in " + std::to_string(item.flags) + ")",
                         at);
                if (e.caps != item.caps)
                    fail(frame + " came out under other caps than it came in with", at);
                if (e.flow != GST_FLOW_OK)
                    ep.refused.insert(e.flow);
                break;
            }
            // Events.
            if (e.type == GST_EVENT_FLUSH_START)
                break;
            if (e.type == GST_EVENT_FLUSH_STOP) {
                const auto it = flush_stop_epoch.find(e.seqnum);
                if (it != flush_stop_epoch.end())
                    floor = std::max(floor, it->second);
                break;
            }
            const bool sticky = (e.type & GST_EVENT_TYPE_STICKY) != 0;
            const std::string name = std::string(gst_event_type_get_name(e.type)) + " " + std::to_string(e.id);
            if (!e.id) {
                if (!(e.type == GST_EVENT_EOS && anyDownstreamFailure()))
                    fail(std::string("an event we never pushed came out: ") + gst_event_type_get_name(e.type), at);
                break;
            }
            const auto last_in = event_last_in.find(e.id);
            if (last_in == event_last_in.end()) {
                fail(name + " came out but never reached the element", at);
                break;
            }
            const std::size_t key = last_in->second;
            if (!events_out.insert(key).second) {
                if (!sticky)
                    fail(name + " came out twice", at);
                break;  // a sticky event sent again by the element's pad
            }
            const int ee = in_epoch[key];
            if (ee < floor && !sticky)
                fail(name + " came out after a flush or stop that dropped it (stale)", at);
            if (sticky ? key < last_frame_key : key <= last_key)
                fail(name + " came out of order (after an item that came in after it)", at);
            if (!sticky)
                last_key = std::max(last_key, key);
            const bool drain_point =
                e.type == GST_EVENT_EOS || (e.type == GST_EVENT_CAPS && in_new_caps.count(key) && in_new_caps[key]);
            if ((drain_point || sticky) && ee >= floor) {
                const std::string missing = missingBefore(ee, key);
                if (!missing.empty())
                    fail(name + " came out before frames that came in before it: " + missing, at);
            }
            if (e.type == GST_EVENT_EOS)
                epochs[std::size_t(ee)].eos_out = true;
            break;
        }
        }
    }
    std::string result;
    for (const std::string &f : found)
        result += "  - " + f + "\n";
    return result;
}

} // namespace chaos
