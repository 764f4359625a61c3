// A rig around one uavstabilize element for the chaos test and the element fuzzer: our
// own source pad feeds the element's sink pad, our own sink pad sits behind its src pad,
// and everything that crosses either side goes into one log, in the order it happens:
//
//   In    what reached the element (a probe on its sink pad: buffers that got to the chain
//         function, events that got to the event function, with the element's caps then)
//   Out   what the element pushed downstream (our sink pad), and what we returned
//   plus  push results, state changes, drain answers, the element's error messages
//
// Every buffer and every event we push carries an item id from one counter (the buffer
// offset; events by seqnum), so ids grow in push order. check() then walks the log and
// says what, if anything, broke the element's contract (see check() for the rules).
//
// Threads: the upstream calls (push*, startStream, drain, continueAfterEos) belong to one
// "streaming" thread at a time, which holds streamLock() around each; flush(), seek(),
// setState(), setDownstream() and setProperty() may come from any other thread, like an
// application's. Independent of libcheck, so the fuzzer can use it.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <gst/gst.h>
#include <gst/video/video.h>

namespace chaos {

struct Shape {
    const char *format;
    int width, height;
    int fps_n, fps_d;
};
GstCaps *capsOf(const Shape &shape);
std::string describe(const Shape &shape);

// How a buffer's memory relates to its caps.
enum class Layout {
    Exact,        // one frame, default layout
    Larger,       // one frame and `extra` bytes more
    Short,        // `extra` bytes too few (at least one): dropped as bad
    Empty,        // no memory at all: bad
    MultiMemory,  // one frame split over several memory blocks
    PaddedMeta,   // a video meta with padded strides, the buffer big enough
    ShortMeta,    // a video meta with padded strides, the buffer `extra` bytes too short: bad
};
const char *toString(Layout layout);

struct FrameSpec {
    Layout layout = Layout::Exact;
    int extra = 0;      // bytes (Larger, Short, ShortMeta) or blocks (MultiMemory)
    int pad = 0;        // stride padding (metas)
    GstClockTime pts = GST_CLOCK_TIME_NONE, dts = GST_CLOCK_TIME_NONE, duration = GST_CLOCK_TIME_NONE;
    guint flags = 0;    // of kFrameFlags
    int shift_x = 0, shift_y = 0;  // the picture moves by this (so that tracking finds motion)
    std::uint8_t seed = 0;
};
// Buffer flags the driver sets and expects back untouched.
constexpr guint kFrameFlags = GST_BUFFER_FLAG_DISCONT | GST_BUFFER_FLAG_DELTA_UNIT | GST_BUFFER_FLAG_MARKER |
                              GST_BUFFER_FLAG_HEADER | GST_BUFFER_FLAG_DROPPABLE | GST_BUFFER_FLAG_CORRUPTED |
                              GST_BUFFER_FLAG_GAP;

enum class Downstream {
    Ok,
    Error,      // returns GST_FLOW_ERROR
    NotLinked,  // returns GST_FLOW_NOT_LINKED
    Flushing,   // returns GST_FLOW_FLUSHING without a flush
    Slow,       // sleeps `slow_us` per buffer
    Block,      // blocks until the mode changes or a flush (like a paused sink)
};
const char *toString(Downstream mode);

struct RigOptions {
    // Set with gst_util_set_object_arg before the element starts.
    std::vector<std::pair<std::string, std::string>> properties;
    // The ALLOCATION answer of our sink pad: -1 no pool, 0 a pool without a maximum,
    // n > 0 a pool of at most n buffers.
    int pool_max = -1;
    bool video_meta = false;  // our sink pad says it takes video metas
    bool hold_last = false;   // our sink keeps the last buffer it got (like a video sink's last sample)
};

class Rig {
public:
    explicit Rig(const RigOptions &options);
    // Stops everything (the element to NULL) and releases every GStreamer object; the log
    // stays for check(). Idempotent.
    void stop();
    ~Rig();
    Rig(const Rig &) = delete;
    Rig &operator=(const Rig &) = delete;

    GstElement *element() const { return element_; }

    // --- Upstream, one streaming thread at a time, holding streamLock().
    std::mutex &streamLock() { return stream_mutex_; }
    // STREAM_START, CAPS (if `shape`), SEGMENT starting at `start`. True if all were taken.
    bool startStream(const Shape *shape, GstClockTime start = 0);
    // Before a data operation: restarts the stream if a state change asked for it
    // (a real source starts afresh after READY). False while the element is down.
    bool ensureStreaming();
    GstFlowReturn pushFrame(const FrameSpec &spec);
    bool pushCaps(const Shape &shape);
    bool pushSegment(GstClockTime start);
    bool pushEvent(GstEvent *event);  // any serialized event; takes it
    bool pushEos();
    // After EOS: STREAM_START and SEGMENT, a new stream (no flush).
    bool continueAfterEos();
    bool drain();  // DRAIN query
    const Shape &shape() const { return shape_; }
    bool eosSent() const { return eos_sent_; }

    // --- Any thread.
    // FLUSH_START now, then (under the stream lock) FLUSH_STOP and a new SEGMENT.
    void flush(GstClockTime segment_start = 0);
    // The two halves of flush(): FLUSH_START (no lock), FLUSH_STOP and SEGMENT (the caller
    // holds the stream lock).
    bool flushStart();
    bool flushStop(GstClockTime segment_start = 0, bool segment = true);
    // The next FLUSH_START to reach our sink pad waits there until releaseFlushStart().
    void holdNextFlushStart();
    bool waitForHeldFlushStart(int timeout_ms);
    void releaseFlushStart();
    // A SEEK sent upstream through the element from our sink pad; our source answers it
    // like a base source (flushing: flush() above; otherwise a new SEGMENT).
    bool seek(bool flushing, GstClockTime start);
    // Changes the element's state; a state below PAUSED makes our sink act like a stopped
    // sink first (returns FLUSHING, unblocks), as a pipeline stops its sink first.
    GstStateChangeReturn setState(GstState state);
    GstState state() const { return state_.load(); }
    void setDownstream(Downstream mode, bool once = false, int slow_us = 0);
    void setProperty(const std::string &name, const std::string &value);
    // LATENCY and CAPS queries through the element, from downstream.
    void queryFromDownstream();

    // --- Waiting and checking.
    // EOS events that reached our sink pad so far (any thread; for tests that race it).
    int eosSeen() const { return eos_seen_.load(); }
    // Buffers whose push into our sink pad has returned (any thread).
    int buffersReturned() const { return buffers_returned_.load(); }
    // Waits until an EOS arrives downstream after log position `from`; false on timeout.
    bool waitForEosAfter(std::size_t from, int timeout_ms);
    // The same for any event type.
    bool waitForEventAfter(GstEventType type, std::size_t from, int timeout_ms);
    std::size_t logSize() const;
    // Item ids of the frames that came out since log position `from`.
    std::vector<std::uint64_t> framesOutSince(std::size_t from) const;
    // Walks the log: an empty string when the element kept its contract, else what broke.
    std::string check() const;
    // Problems found as they happened (bad-buffer accounting), as check() reports them.
    std::vector<std::string> immediateProblems() const;
    // The last `count` log entries, one a line, for a failure report.
    std::string describeLog(std::size_t count) const;
    // Entries [first, last) (clamped), one a line.
    std::string describeLogRange(std::size_t first, std::size_t last) const;
    // Counters for the report.
    struct Stats {
        int frames_pushed = 0, frames_out = 0, bad_pushed = 0, events_pushed = 0, flushes = 0, state_downs = 0,
            downstream_errors = 0, eos_out = 0, errors_posted = 0, warnings_posted = 0;
    };
    Stats stats() const;

    // Adds a line of text to the log (any thread).
    void note(const std::string &text);
    // The bad-buffer accounting must know when max-errors changes (any thread).
    void setMaxErrors(int value);

private:
    struct Item;
    struct Entry;

    static GstPadProbeReturn inputProbe(GstPad *pad, GstPadProbeInfo *info, gpointer user_data);
    static GstFlowReturn sinkChain(GstPad *pad, GstObject *parent, GstBuffer *buffer);
    static gboolean sinkEvent(GstPad *pad, GstObject *parent, GstEvent *event);
    static gboolean sinkQuery(GstPad *pad, GstObject *parent, GstQuery *query);
    static gboolean srcEvent(GstPad *pad, GstObject *parent, GstEvent *event);
    static gboolean srcQuery(GstPad *pad, GstObject *parent, GstQuery *query);
    static GstBusSyncReply onMessage(GstBus *bus, GstMessage *message, gpointer user_data);

    std::uint64_t newEventId(GstEvent *event);
    std::uint64_t idOfEvent(GstEvent *event) const;  // 0 when not ours
    int internCaps(GstCaps *caps);                    // under mutex_
    void append(Entry entry);
    bool pushEventLogged(GstEvent *event);
    void noteResult(std::uint64_t id, GstFlowReturn flow);
    void checkBadBufferAccounting(std::uint64_t id, GstFlowReturn ret, int warnings, int errors,
                                  int negotiation_errors, bool stable, int max_errors);
    void problem(const std::string &what);
    std::string describe(const Entry &entry) const;

    RigOptions options_;
    GstElement *element_ = nullptr;
    GstPad *src_ = nullptr, *sink_ = nullptr;  // ours
    GstPad *element_sink_ = nullptr;
    GstBus *bus_ = nullptr;
    gulong probe_id_ = 0;
    std::atomic<GstState> state_{GST_STATE_NULL};

    // Upstream state (stream lock).
    std::mutex stream_mutex_;
    std::mutex flush_mutex_;
    Shape shape_{"I420", 64, 48, 30, 1};
    bool eos_sent_ = false;
    bool stream_started_ = false;
    std::atomic<bool> need_restart_{false};
    std::atomic<gint64> pending_segment_{-1};  // a non-flushing seek's new segment start
    int bad_run_ = 0;           // our mirror of the element's consecutive bad buffers
    bool bad_run_known_ = true;
    unsigned seen_state_epoch_ = 0;
    std::atomic<unsigned> state_epoch_{0};      // +1 after each stop (READY or NULL)
    std::atomic<unsigned> max_errors_version_{0};
    std::atomic<int> max_errors_{10};

    // Downstream behaviour.
    std::mutex down_mutex_;
    std::condition_variable down_changed_;
    Downstream mode_ = Downstream::Ok;
    bool mode_once_ = false;
    int slow_us_ = 0;
    bool down_flushing_ = false;  // a FLUSH_START reached our sink pad
    bool down_stopped_ = false;   // emulates the sink being stopped (state change, teardown)
    bool hold_flush_start_ = false, flush_start_held_ = false;
    GstBuffer *last_buffer_ = nullptr;  // hold_last (down_mutex_)

    // The log (mutex_).
    mutable std::mutex mutex_;
    std::condition_variable log_changed_;
    std::vector<Entry> log_;
    std::map<std::uint64_t, Item> items_;
    std::map<guint32, std::uint64_t> event_ids_;  // seqnum -> item id
    std::vector<GstCaps *> caps_;                  // interned (references, until stop())
    std::vector<std::string> caps_text_;
    std::atomic<std::uint64_t> next_id_{1};
    std::vector<std::string> problems_;
    Stats stats_;
    // Message counters (bus sync handler; read by the streaming thread around a push).
    std::atomic<int> bad_warnings_{0}, bad_errors_{0}, negotiation_errors_{0};
    std::atomic<int> eos_seen_{0};
    std::atomic<int> buffers_returned_{0};
};

} // namespace chaos
