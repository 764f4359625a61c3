// The element's dataflow contract: every frame comes out once, in order, with its
// metadata; events keep their place; flushes, caps changes, draining, latency, bypass
// and broken input behave.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "test_support.hpp"
#include "uavstab/config.hpp"

using namespace element_test;

namespace {

constexpr int kDelay = 20;  // the element's default

// Flags a source might set; the element must hand them on untouched.
guint inputFlags(int index)
{
    guint flags = 0;
    if (index == 0)
        flags |= GST_BUFFER_FLAG_DISCONT;
    if (index % 3 == 1)
        flags |= GST_BUFFER_FLAG_DELTA_UNIT;
    if (index % 5 == 2)
        flags |= GST_BUFFER_FLAG_MARKER;
    return flags;
}

GstHarness *smallHarness(const std::string &properties, const char *format = "I420", int width = 64,
                         int height = 48)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 " + properties));
    gst_harness_set_src_caps(h, videoCaps(format, width, height));
    gst_harness_set_drop_buffers(h, TRUE);  // the log keeps what the tests look at
    return h;
}

void pushFrames(GstHarness *h, const GstVideoInfo &info, int first, int count)
{
    for (int i = first; i < first + count; ++i) {
        GstBuffer *buffer = makeFrame(info, i);
        GST_BUFFER_FLAGS(buffer) = inputFlags(i);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
}

int indexOfEvent(const std::vector<LoggedItem> &items, GstEventType type, int from = 0)
{
    for (int i = from; i < int(items.size()); ++i)
        if (!items[i].is_buffer && items[i].event_type == type)
            return i;
    return -1;
}

int indexOfBuffer(const std::vector<LoggedItem> &items, guint64 offset)
{
    for (int i = 0; i < int(items.size()); ++i)
        if (items[i].is_buffer && items[i].offset == offset)
            return i;
    return -1;
}

void checkStream(int length)
{
    GstHarness *h = smallHarness("");
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);

    pushFrames(h, info, 0, length);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos(), "no EOS for a stream of %d frames", length);

    const std::vector<LoggedItem> items = log.items();
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), length);
    for (int i = 0; i < length; ++i) {
        const LoggedItem &b = buffers[i];
        const GstClockTime d = frameDuration();
        fail_unless_equals_uint64(b.offset, guint64(i));
        fail_unless_equals_uint64(b.offset_end, guint64(i) + 1);
        fail_unless_equals_uint64(b.pts, i * d);
        fail_unless_equals_uint64(b.dts, i * d);
        fail_unless_equals_uint64(b.duration, d);
        fail_unless_equals_int(b.flags & ~GST_BUFFER_FLAG_TAG_MEMORY, inputFlags(i));
        fail_unless_equals_uint64(b.size, GST_VIDEO_INFO_SIZE(&info));
    }
    fail_unless(!items.back().is_buffer && items.back().event_type == GST_EVENT_EOS, "EOS is not last (length %d)",
                length);
    gst_harness_teardown(h);
}

} // namespace

ELEMENT_TEST(every_frame_comes_out_once_in_order)
{
    for (int length : {0, 1, kDelay - 1, kDelay, kDelay + 1, 500})
        checkStream(length);
}

ELEMENT_TEST(latency_adds_delay_frames)
{
    const GstClockTime upstream = 5 * GST_MSECOND;
    for (int delay : {0, 1, 20}) {
        GstHarness *h = smallHarness("delay=" + std::to_string(delay));
        gst_harness_set_upstream_latency(h, upstream);
        GstQuery *query = gst_query_new_latency();
        fail_unless(gst_pad_peer_query(h->sinkpad, query));
        gboolean live = FALSE;
        GstClockTime min = 0, max = 0;
        gst_query_parse_latency(query, &live, &min, &max);
        fail_unless(live);
        fail_unless_equals_uint64(min, upstream + delay * frameDuration(30, 1));
        fail_unless_equals_uint64(max, GST_CLOCK_TIME_NONE);  // upstream has no maximum
        gst_query_unref(query);
        gst_harness_teardown(h);
    }
}

ELEMENT_TEST(latency_without_framerate_uses_buffer_duration)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=10"));
    gst_harness_set_src_caps(h, videoCaps("GRAY8", 64, 48, 0, 1));
    gst_harness_set_drop_buffers(h, TRUE);
    auto latency = [h] {
        GstQuery *query = gst_query_new_latency();
        fail_unless(gst_pad_peer_query(h->sinkpad, query));
        GstClockTime min = 0;
        gst_query_parse_latency(query, nullptr, &min, nullptr);
        gst_query_unref(query);
        return min;
    };
    // Nothing known yet: 30 fps is assumed.
    fail_unless_equals_uint64(latency(), 10 * (GST_SECOND / 30));
    GstCaps *caps = videoCaps("GRAY8", 64, 48, 0, 1);
    GstBuffer *buffer = makeFrame(videoInfo(caps), 0);
    gst_caps_unref(caps);
    GST_BUFFER_DURATION(buffer) = 40 * GST_MSECOND;
    fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    fail_unless_equals_uint64(latency(), 10 * 40 * GST_MSECOND);
    gst_harness_teardown(h);
}

ELEMENT_TEST(delay_change_posts_latency_message)
{
    GstHarness *h = smallHarness("delay=5");
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    g_object_set(h->element, "delay", 8u, nullptr);
    GstMessage *message = popMessage(bus, GST_MESSAGE_LATENCY);
    fail_unless(message != nullptr, "no latency message after a delay change");
    gst_message_unref(message);
    // The new delay is what LATENCY reports.
    GstQuery *query = gst_query_new_latency();
    fail_unless(gst_pad_peer_query(h->sinkpad, query));
    GstClockTime min = 0;
    gst_query_parse_latency(query, nullptr, &min, nullptr);
    fail_unless_equals_uint64(min, 8 * frameDuration());
    gst_query_unref(query);
    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
}

ELEMENT_TEST(serialized_events_keep_their_place)
{
    GstHarness *h = smallHarness("delay=5");
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);

    pushFrames(h, info, 0, 4);  // frames 0..3
    fail_unless(gst_harness_push_event(h, gst_event_new_tag(gst_tag_list_new(GST_TAG_TITLE, "after-3", nullptr))));
    pushFrames(h, info, 4, 4);  // frames 4..7
    fail_unless(gst_harness_push_event(
        h, gst_event_new_custom(GST_EVENT_CUSTOM_DOWNSTREAM, gst_structure_new_empty("after-7"))));
    pushFrames(h, info, 8, 2);  // frames 8..9
    fail_unless(gst_harness_push_event(h, gst_event_new_gap(10 * frameDuration(), frameDuration())));
    pushFrames(h, info, 11, 3);  // frames 11..13
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());

    const std::vector<LoggedItem> items = log.items();
    const int tag = indexOfEvent(items, GST_EVENT_TAG);
    const int custom = indexOfEvent(items, GST_EVENT_CUSTOM_DOWNSTREAM);
    const int gap = indexOfEvent(items, GST_EVENT_GAP);
    fail_unless(tag >= 0 && custom >= 0 && gap >= 0);
    fail_unless(indexOfBuffer(items, 3) < tag && tag < indexOfBuffer(items, 4), "TAG is not between frames 3 and 4");
    fail_unless(indexOfBuffer(items, 7) < custom && custom < indexOfBuffer(items, 8),
                "custom event is not between frames 7 and 8");
    fail_unless(indexOfBuffer(items, 9) < gap && gap < indexOfBuffer(items, 11), "GAP is not between frames 9 and 11");
    fail_unless(gst_structure_has_name(gst_event_get_structure(items[custom].event), "after-7"));
    fail_unless_equals_int(int(log.buffers().size()), 13);
    gst_harness_teardown(h);
}

ELEMENT_TEST(flush_drops_held_frames_and_restarts)
{
    GstHarness *h = smallHarness("delay=5");
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);

    pushFrames(h, info, 0, 12);
    // Let the frames that are already final come out, so the flush has both kinds.
    fail_unless(log.waitForBuffers(12 - 5));
    fail_unless(gst_harness_push_event(h, gst_event_new_flush_start()));
    fail_unless(gst_harness_push_event(h, gst_event_new_flush_stop(TRUE)));
    GstSegment segment;
    gst_segment_init(&segment, GST_FORMAT_TIME);
    fail_unless(gst_harness_push_event(h, gst_event_new_segment(&segment)));
    pushFrames(h, info, 100, 10);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());

    const std::vector<LoggedItem> items = log.items();
    const int flush_start = indexOfEvent(items, GST_EVENT_FLUSH_START);
    const int flush_stop = indexOfEvent(items, GST_EVENT_FLUSH_STOP);
    fail_unless(flush_start >= 0 && flush_stop > flush_start);
    guint64 expected = 0;
    for (int i = 0; i < flush_start; ++i)
        if (items[i].is_buffer)
            fail_unless_equals_uint64(items[i].offset, expected++);
    fail_unless(expected >= 7 && expected <= 12);
    for (int i = flush_start; i < flush_stop; ++i)
        fail_unless(!items[i].is_buffer, "a buffer between FLUSH_START and FLUSH_STOP");
    expected = 100;
    for (int i = flush_stop; i < int(items.size()); ++i)
        if (items[i].is_buffer)
            fail_unless_equals_uint64(items[i].offset, expected++);  // no stale frame
    fail_unless_equals_uint64(expected, 110);
    gst_harness_teardown(h);
}

ELEMENT_TEST(caps_changes_keep_each_frame_with_its_caps)
{
    struct Group {
        const char *format;
        int width, height;
    };
    const Group groups[] = {{"I420", 640, 360}, {"I420", 1280, 720}, {"I420", 320, 240}, {"BGRx", 320, 240}};
    constexpr int kFramesPerGroup = 6;
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=3 analysis-width=160"));
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad);
    int index = 0;
    for (const Group &g : groups) {
        GstCaps *caps = videoCaps(g.format, g.width, g.height);
        const GstVideoInfo info = videoInfo(caps);
        gst_harness_set_src_caps(h, caps);
        for (int i = 0; i < kFramesPerGroup; ++i, ++index)
            fail_unless_equals_int(gst_harness_push(h, makeFrame(info, index)), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());

    const std::vector<GstCaps *> caps = log.caps();
    fail_unless_equals_int(int(caps.size()), 4);
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 4 * kFramesPerGroup);
    for (int i = 0; i < int(buffers.size()); ++i) {
        const LoggedItem &b = buffers[i];
        fail_unless_equals_uint64(b.offset, guint64(i));
        fail_unless_equals_int(b.caps_index, i / kFramesPerGroup);  // went out after its own caps
        const GstVideoInfo info = videoInfo(caps[b.caps_index]);
        fail_unless_equals_uint64(b.size, GST_VIDEO_INFO_SIZE(&info));
        fail_unless_equals_string(GST_VIDEO_INFO_NAME(&info), groups[i / kFramesPerGroup].format);
        fail_unless_equals_int(GST_VIDEO_INFO_WIDTH(&info), groups[i / kFramesPerGroup].width);
    }
    gst_harness_teardown(h);
}

ELEMENT_TEST(same_caps_again_is_just_forwarded)
{
    GstHarness *h = smallHarness("delay=4");
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    pushFrames(h, info, 0, 6);
    // Equal caps do not flush the held frames: they queue like any serialized event.
    fail_unless(gst_pad_push_event(h->srcpad, gst_event_new_caps(caps)));
    gst_caps_unref(caps);
    pushFrames(h, info, 6, 6);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    fail_unless_equals_int(int(log.buffers().size()), 12);
    gst_harness_teardown(h);
}

ELEMENT_TEST(drain_query_pushes_every_held_frame)
{
    GstHarness *h = smallHarness("delay=8");
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    pushFrames(h, info, 0, 5);  // all held: fewer than the delay
    GstQuery *drain = gst_query_new_drain();
    fail_unless(gst_pad_peer_query(h->srcpad, drain));
    gst_query_unref(drain);
    fail_unless_equals_int(int(log.buffers().size()), 5);  // out before the answer
    pushFrames(h, info, 5, 3);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    fail_unless_equals_int(int(log.buffers().size()), 8);
    gst_harness_teardown(h);
}

namespace {

// Pushes `delay` frames (none may come out), then one more (exactly the first comes out).
void checkDelay(GstHarness *h, StreamLog &log, const GstVideoInfo &info, int delay, std::vector<GstBuffer *> &inputs)
{
    for (int i = 0; i < delay; ++i) {
        inputs.push_back(makeFrame(info, i));
        fail_unless_equals_int(gst_harness_push(h, gst_buffer_ref(inputs.back())), GST_FLOW_OK);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    fail_unless_equals_int(int(log.buffers().size()), 0);
    inputs.push_back(makeFrame(info, delay));
    fail_unless_equals_int(gst_harness_push(h, gst_buffer_ref(inputs.back())), GST_FLOW_OK);
    fail_unless(log.waitForBuffers(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    fail_unless_equals_int(int(log.buffers().size()), 1);
    fail_unless_equals_uint64(log.buffers()[0].offset, 0);
}

} // namespace

ELEMENT_TEST(bypass_outputs_the_input_buffers_with_the_same_delay)
{
    constexpr int kBypassDelay = 4;
    GstCaps *caps = videoCaps("NV12", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    for (bool bypass : {true, false}) {
        GstHarness *h = smallHarness(std::string("delay=4 bypass=") + (bypass ? "true" : "false"), "NV12");
        StreamLog log(h->sinkpad, true);
        std::vector<GstBuffer *> inputs;
        checkDelay(h, log, info, kBypassDelay, inputs);
        for (int i = kBypassDelay + 1; i < 12; ++i) {
            inputs.push_back(makeFrame(info, i));
            fail_unless_equals_int(gst_harness_push(h, gst_buffer_ref(inputs.back())), GST_FLOW_OK);
        }
        fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
        fail_unless(log.waitForEos());
        const std::vector<LoggedItem> buffers = log.buffers();
        fail_unless_equals_int(int(buffers.size()), int(inputs.size()));
        for (std::size_t i = 0; i < inputs.size(); ++i) {
            // Inputs are still alive (we hold them), so pointers are unique. We hold them,
            // so the element cannot attach its meta to them: a bypassed frame goes out as
            // a new GstBuffer over the input's memory, never a copy of the pixels.
            const bool same_memory = gst_buffer_peek_memory(buffers[i].buffer, 0) == gst_buffer_peek_memory(inputs[i], 0);
            if (bypass)
                fail_unless(same_memory, "frame %zu is not the input buffer's memory", i);
            else
                fail_unless(buffers[i].identity != inputs[i] && !same_memory, "frame %zu was not warped", i);
        }
        for (GstBuffer *buffer : inputs)
            gst_buffer_unref(buffer);
        gst_harness_teardown(h);
    }
}

ELEMENT_TEST(toggling_bypass_never_reorders)
{
    GstHarness *h = smallHarness("delay=6");
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    for (int i = 0; i < 40; ++i) {
        if (i % 7 == 3)
            g_object_set(h->element, "bypass", gboolean((i / 7) % 2 == 0), nullptr);
        fail_unless_equals_int(gst_harness_push(h, makeFrame(info, i)), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 40);
    for (int i = 0; i < 40; ++i)
        fail_unless_equals_uint64(buffers[i].offset, guint64(i));
    gst_harness_teardown(h);
}

namespace {

// A buffer of 100 bytes stamped as frame `index`: 64x48 I420 needs 4608.
GstBuffer *shortBuffer(int index)
{
    GstBuffer *buffer = gst_buffer_new_allocate(nullptr, 100, nullptr);
    stampFrame(buffer, index);
    return buffer;
}

struct MessageCount {
    int warnings = 0;
    int errors = 0;
};

// Pops every message on the bus; each warning and error must mention `text`.
MessageCount countMessages(GstBus *bus, const char *text = "buffer too small for caps")
{
    MessageCount count;
    while (GstMessage *message = gst_bus_pop(bus)) {
        GError *error = nullptr;
        gchar *debug = nullptr;
        if (GST_MESSAGE_TYPE(message) == GST_MESSAGE_WARNING) {
            gst_message_parse_warning(message, &error, &debug);
            ++count.warnings;
        } else if (GST_MESSAGE_TYPE(message) == GST_MESSAGE_ERROR) {
            gst_message_parse_error(message, &error, &debug);
            ++count.errors;
        }
        if (error) {
            fail_unless(g_strrstr(error->message, text) != nullptr, "message: %s", error->message);
            g_error_free(error);
            g_free(debug);
        }
        gst_message_unref(message);
    }
    return count;
}

} // namespace

// Like a video decoder's corrupt frame: a buffer smaller than its caps is dropped with a
// warning, and the frames held before it (delay 20: all twelve) and after it go on.
ELEMENT_TEST(a_short_buffer_is_dropped_with_a_warning)
{
    GstHarness *h = smallHarness("");
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    constexpr int kBad = 12;
    for (int i = 0; i < 25; ++i) {
        GstBuffer *buffer = i == kBad ? shortBuffer(i) : makeFrame(info, i);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 24);
    for (int out = 0; out < 24; ++out) {
        const int in = out < kBad ? out : out + 1;
        fail_unless_equals_uint64(buffers[out].offset, guint64(in));
        fail_unless_equals_uint64(buffers[out].pts, in * frameDuration());
        fail_unless_equals_uint64(buffers[out].duration, frameDuration());
    }
    const MessageCount count = countMessages(bus);
    fail_unless_equals_int(count.warnings, 1);
    fail_unless_equals_int(count.errors, 0);
    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
}

// max-errors consecutive short buffers are dropped with a warning each; one more is an
// error (GstVideoDecoder's rule). A good buffer starts the count afresh. Never a crash.
ELEMENT_TEST(short_buffer_is_an_error_not_a_crash)
{
    GstHarness *h = smallHarness("delay=2 max-errors=3");
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    int index = 0;
    fail_unless_equals_int(gst_harness_push(h, makeFrame(info, index++)), GST_FLOW_OK);
    for (int round = 0; round < 2; ++round) {
        for (int i = 0; i < 3; ++i)
            fail_unless_equals_int(gst_harness_push(h, shortBuffer(index++)), GST_FLOW_OK);
        fail_unless_equals_int(gst_harness_push(h, makeFrame(info, index++)), GST_FLOW_OK);  // resets the count
    }
    fail_unless_equals_int(countMessages(bus).warnings, 6);
    for (int i = 0; i < 3; ++i)
        fail_unless_equals_int(gst_harness_push(h, shortBuffer(index++)), GST_FLOW_OK);
    fail_unless_equals_int(gst_harness_push(h, shortBuffer(index++)), GST_FLOW_ERROR);
    MessageCount count = countMessages(bus);
    fail_unless_equals_int(count.warnings, 3);
    fail_unless_equals_int(count.errors, 1);
    // The three good frames before the error were held (delay 2) and still come out.
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 3);
    fail_unless_equals_uint64(buffers[0].offset, 0);
    fail_unless_equals_uint64(buffers[1].offset, 4);
    fail_unless_equals_uint64(buffers[2].offset, 8);

    // max-errors=0: the first short buffer is an error.
    GstHarness *strict = smallHarness("delay=2 max-errors=0");
    gst_element_set_bus(strict->element, bus);
    fail_unless_equals_int(gst_harness_push(strict, shortBuffer(0)), GST_FLOW_ERROR);
    count = countMessages(bus);
    fail_unless_equals_int(count.warnings, 0);
    fail_unless_equals_int(count.errors, 1);
    gst_element_set_bus(strict->element, nullptr);
    gst_harness_teardown(strict);

    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
}

ELEMENT_TEST(max_errors_minus_one_never_errors)
{
    GstHarness *h = smallHarness("delay=5 max-errors=-1");
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    pushFrames(h, info, 0, 3);
    for (int i = 3; i < 103; ++i)
        fail_unless_equals_int(gst_harness_push(h, shortBuffer(i)), GST_FLOW_OK);
    pushFrames(h, info, 103, 3);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 6);
    for (int i = 0; i < 6; ++i)
        fail_unless_equals_uint64(buffers[i].offset, guint64(i < 3 ? i : 100 + i));
    const MessageCount count = countMessages(bus);
    fail_unless_equals_int(count.warnings, 100);
    fail_unless_equals_int(count.errors, 0);
    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
}

ELEMENT_TEST(properties_have_the_documented_defaults)
{
    GstElement *element = makeStabilizer();
    guint delay = 0, radius = 0, corners = 0, redetect = 0, dwell = 0, min_points = 0, width = 0, threads = 99,
          window = 0;
    gdouble roi = 0, crop = 0;
    gint planner = -1, model = -1, border = -1;
    gboolean bypass = TRUE, post = TRUE;
    g_object_get(element, "delay", &delay, "smoothing-radius", &radius, "max-corners", &corners, "redetect-interval",
                 &redetect, "dwell", &dwell, "min-points", &min_points, "analysis-width", &width, "threads", &threads,
                 "roi", &roi, "crop", &crop, "planner", &planner, "model", &model, "border", &border, "bypass",
                 &bypass, "post-messages", &post, "tracking-window", &window, nullptr);
    fail_unless_equals_int(delay, 20);
    fail_unless_equals_int(window, 21);
    setProperties(element, "tracking-window=18");  // rounded up to odd: the window has a centre
    g_object_get(element, "tracking-window", &window, nullptr);
    fail_unless_equals_int(window, 19);
    fail_unless_equals_int(radius, 20);
    fail_unless_equals_int(corners, 50);
    fail_unless_equals_int(redetect, 5);
    fail_unless_equals_int(dwell, 20);
    fail_unless_equals_int(min_points, 10);
    fail_unless_equals_int(width, 640);
    fail_unless_equals_int(threads, 0);
    fail_unless_equals_float(roi, 0.8);
    fail_unless_equals_float(crop, 0.08);
    fail_unless(!bypass && !post);
    gint max_errors = 0;
    g_object_get(element, "max-errors", &max_errors, nullptr);
    fail_unless_equals_int(max_errors, 10);  // GstVideoDecoder's default
    fail_unless_equals_int(planner, int(uavstab::PlannerKind::L1));
    // Enums are known by their nicks, as gst-launch spells them.
    setProperties(element, "planner=box model=similarity border=replicate");
    g_object_get(element, "planner", &planner, "model", &model, "border", &border, nullptr);
    GEnumClass *klass = G_ENUM_CLASS(g_type_class_ref(G_PARAM_SPEC_VALUE_TYPE(
        g_object_class_find_property(G_OBJECT_GET_CLASS(element), "planner"))));
    fail_unless_equals_string(g_enum_get_value(klass, planner)->value_nick, "box");
    g_type_class_unref(klass);
    fail_unless_equals_int(model, 2);
    fail_unless_equals_int(border, 1);
    GstElementFactory *factory = gst_element_get_factory(element);
    fail_unless_equals_string(gst_element_factory_get_metadata(factory, GST_ELEMENT_METADATA_KLASS),
                              "Filter/Effect/Video");
    fail_unless(g_strrstr(gst_element_factory_get_metadata(factory, GST_ELEMENT_METADATA_DESCRIPTION),
                          "gst-launch-1.0") != nullptr);
    gst_object_unref(element);
}

ELEMENT_TEST(allocation_proposal_covers_the_held_frames)
{
    GstHarness *h = smallHarness("delay=7");
    GstCaps *caps = videoCaps("I420", 64, 48);
    GstQuery *query = gst_query_new_allocation(caps, TRUE);
    fail_unless(gst_pad_peer_query(h->srcpad, query));
    fail_unless(gst_query_get_n_allocation_pools(query) > 0);
    GstBufferPool *pool = nullptr;
    guint size = 0, min = 0, max = 0;
    gst_query_parse_nth_allocation_pool(query, 0, &pool, &size, &min, &max);
    fail_unless(pool != nullptr);
    fail_unless_equals_int(min, 7 + 4);  // delay + frames in estimation, warp and push
    fail_unless_equals_int(max, 0);
    const GstVideoInfo info = videoInfo(caps);
    fail_unless_equals_uint64(size, GST_VIDEO_INFO_SIZE(&info));
    fail_unless(gst_query_find_allocation_meta(query, GST_VIDEO_META_API_TYPE, nullptr));
    gst_object_unref(pool);
    gst_query_unref(query);
    gst_caps_unref(caps);
    gst_harness_teardown(h);
}

ELEMENT_TEST(safe_metas_are_copied_to_warped_frames)
{
    GstHarness *h = smallHarness("delay=1");
    StreamLog log(h->sinkpad, true);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    GstCaps *reference = gst_caps_new_empty_simple("timestamp/x-test");
    for (int i = 0; i < 3; ++i) {
        GstBuffer *buffer = makeFrame(info, i);
        // No tags: describes the content, survives a warp.
        gst_buffer_add_reference_timestamp_meta(buffer, reference, guint64(1000 + i), GST_CLOCK_TIME_NONE);
        // Geometry: a region in input pixels would be wrong after the warp, so it comes
        // out mapped into the output (meta_test checks where).
        gst_buffer_add_video_region_of_interest_meta(buffer, "thing", 27, 19, 10, 10);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    gst_caps_unref(reference);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 3);
    for (int i = 0; i < 3; ++i) {
        GstReferenceTimestampMeta *meta = gst_buffer_get_reference_timestamp_meta(buffers[i].buffer, nullptr);
        fail_unless(meta != nullptr, "frame %d lost its reference timestamp", i);
        fail_unless_equals_uint64(meta->timestamp, guint64(1000 + i));
        fail_unless(gst_buffer_get_video_region_of_interest_meta(buffers[i].buffer) != nullptr,
                    "frame %d lost its region of interest", i);
    }
    gst_harness_teardown(h);
}

namespace {

std::atomic<int> live_inputs{0};

void inputFreed(gpointer, GstMiniObject *)
{
    --live_inputs;
}

GstPadProbeReturn slowSink(GstPad *, GstPadProbeInfo *, gpointer)
{
    g_usleep(4000);
    return GST_PAD_PROBE_OK;
}

} // namespace

ELEMENT_TEST(slow_downstream_bounds_what_is_held)
{
    constexpr int kHoldDelay = 5, kThreads = 2, kFrames = 80;
    GstHarness *h = smallHarness("delay=5");
    StreamLog log(h->sinkpad);
    gst_pad_add_probe(h->sinkpad, GST_PAD_PROBE_TYPE_BUFFER, slowSink, nullptr, nullptr);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    int most_alive = 0;
    for (int i = 0; i < kFrames; ++i) {
        GstBuffer *buffer = makeFrame(info, i);
        ++live_inputs;
        gst_mini_object_weak_ref(GST_MINI_OBJECT(buffer), inputFreed, nullptr);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
        most_alive = std::max(most_alive, live_inputs.load());
    }
    // Held: the delay, the finalized frames the chain lets pile up, the one being pushed.
    fail_unless(most_alive <= kHoldDelay + kThreads + 4, "%d input frames alive at once", most_alive);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    fail_unless_equals_int(int(log.buffers().size()), kFrames);
    gst_harness_teardown(h);
    fail_unless_equals_int(live_inputs.load(), 0);
}

namespace {

GstFlowReturn failingChain(GstPad *, GstObject *, GstBuffer *buffer)
{
    gst_buffer_unref(buffer);
    return GST_FLOW_ERROR;
}

} // namespace

ELEMENT_TEST(downstream_errors_reach_upstream)
{
    GstHarness *h = smallHarness("delay=1");
    gst_pad_set_chain_function(h->sinkpad, failingChain);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    GstFlowReturn ret = GST_FLOW_OK;
    for (int i = 0; i < 200 && ret == GST_FLOW_OK; ++i) {
        ret = gst_harness_push(h, makeFrame(info, i));
        g_usleep(1000);
    }
    fail_unless_equals_int(ret, GST_FLOW_ERROR);
    // Remembered until a flush.
    fail_unless_equals_int(gst_harness_push(h, makeFrame(info, 1000)), GST_FLOW_ERROR);
    fail_unless(gst_harness_push_event(h, gst_event_new_flush_start()));
    fail_unless(gst_harness_push_event(h, gst_event_new_flush_stop(TRUE)));
    GstSegment segment;
    gst_segment_init(&segment, GST_FORMAT_TIME);
    fail_unless(gst_harness_push_event(h, gst_event_new_segment(&segment)));
    fail_unless_equals_int(gst_harness_push(h, makeFrame(info, 1001)), GST_FLOW_OK);
    gst_harness_teardown(h);
}

namespace {

// A pool handing out buffers too small for any frame: the output cannot be mapped.
GstFlowReturn allocTinyBuffer(GstBufferPool *, GstBuffer **buffer, GstBufferPoolAcquireParams *)
{
    *buffer = gst_buffer_new_allocate(nullptr, 16, nullptr);
    return GST_FLOW_OK;
}

GType tinyPoolType()
{
    static const GType type = g_type_register_static_simple(
        GST_TYPE_BUFFER_POOL, "UavStabilizeTestTinyPool", sizeof(GstBufferPoolClass),
        [](gpointer klass, gpointer) { GST_BUFFER_POOL_CLASS(klass)->alloc_buffer = allocTinyBuffer; },
        sizeof(GstBufferPool), nullptr, GTypeFlags(0));
    return type;
}

gboolean proposeTinyPool(GstPad *pad, GstObject *parent, GstQuery *query)
{
    if (GST_QUERY_TYPE(query) != GST_QUERY_ALLOCATION)
        return gst_pad_query_default(pad, parent, query);
    auto *pool = GST_BUFFER_POOL(gst_object_ref_sink(g_object_new(tinyPoolType(), nullptr)));
    gst_query_add_allocation_pool(query, pool, 16, 0, 0);
    gst_object_unref(pool);
    return TRUE;
}

} // namespace

ELEMENT_TEST(failed_frames_pass_through_with_one_warning)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=2"));
    gst_pad_set_query_function(h->sinkpad, proposeTinyPool);
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad, true);
    std::vector<GstBuffer *> inputs;
    for (int i = 0; i < 8; ++i) {
        inputs.push_back(makeFrame(info, i));
        fail_unless_equals_int(gst_harness_push(h, gst_buffer_ref(inputs.back())), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    // Never lose a frame: each goes out uncorrected, as it came.
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 8);
    for (int i = 0; i < 8; ++i)
        // (Over the input's memory: a new GstBuffer, as we hold the input, for the meta.)
        fail_unless(gst_buffer_peek_memory(buffers[i].buffer, 0) == gst_buffer_peek_memory(inputs[i], 0),
                    "frame %d is not its input", i);
    // One warning for the one distinct error.
    int warnings = 0;
    while (GstMessage *message = gst_bus_pop_filtered(bus, GST_MESSAGE_WARNING)) {
        ++warnings;
        gst_message_unref(message);
    }
    fail_unless_equals_int(warnings, 1);
    fail_unless(gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR) == nullptr);
    for (GstBuffer *buffer : inputs)
        gst_buffer_unref(buffer);
    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
}

namespace {

// Downstream offers a pool of at most three buffers.
gboolean proposeSmallPool(GstPad *pad, GstObject *parent, GstQuery *query)
{
    if (GST_QUERY_TYPE(query) != GST_QUERY_ALLOCATION)
        return gst_pad_query_default(pad, parent, query);
    GstCaps *caps = nullptr;
    gst_query_parse_allocation(query, &caps, nullptr);
    GstVideoInfo info;
    fail_unless(gst_video_info_from_caps(&info, caps));
    GstBufferPool *pool = gst_video_buffer_pool_new();
    gst_query_add_allocation_pool(query, pool, guint(GST_VIDEO_INFO_SIZE(&info)), 2, 3);
    gst_object_unref(pool);
    return TRUE;
}

} // namespace

ELEMENT_TEST(small_downstream_pool_neither_starves_nor_deadlocks)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=10"));
    gst_pad_set_query_function(h->sinkpad, proposeSmallPool);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);  // buffers go back to the pool at once
    StreamLog log(h->sinkpad);
    for (int i = 0; i < 40; ++i)
        fail_unless_equals_int(gst_harness_push(h, makeFrame(info, i)), GST_FLOW_OK);
    // EOS finalizes ten frames at once: more than the pool holds.
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), 40);
    for (int i = 0; i < 40; ++i)
        fail_unless_equals_uint64(buffers[i].offset, guint64(i));
    gst_harness_teardown(h);
}

ELEMENT_TEST(flush_unblocks_a_chain_waiting_for_output_buffers)
{
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=2"));
    gst_pad_set_query_function(h->sinkpad, proposeSmallPool);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    // The harness keeps what it receives: after three frames the pool is empty and the
    // chain waits in the pool for a buffer that never comes back.
    std::atomic<GstFlowReturn> last{GST_FLOW_OK};
    std::atomic<int> pushed{0};
    std::vector<GstBuffer *> frames;
    for (int i = 0; i < 20; ++i)
        frames.push_back(makeFrame(info, i));
    std::thread streaming([&] {
        for (GstBuffer *frame : frames) {
            last = gst_harness_push(h, frame);
            if (last != GST_FLOW_OK)
                break;
            ++pushed;
        }
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    fail_unless(pushed < 20, "the chain never blocked (%d frames pushed)", pushed.load());
    fail_unless(gst_harness_push_event(h, gst_event_new_flush_start()));
    streaming.join();
    fail_unless_equals_int(last.load(), GST_FLOW_FLUSHING);
    for (std::size_t i = std::size_t(pushed) + 1; i < frames.size(); ++i)
        gst_buffer_unref(frames[i]);  // never pushed
    fail_unless(gst_harness_push_event(h, gst_event_new_flush_stop(TRUE)));
    gst_harness_teardown(h);
}

ELEMENT_TEST(shutdown_unblocks_a_chain_waiting_for_room)
{
    // Downstream blocks the src task's first push: finalized frames pile up and the chain
    // waits for room (after estimating its frame). Going to NULL must wake it with FLUSHING,
    // not hang, and free every frame it held.
    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=2"));
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    GstPad *src = gst_element_get_static_pad(h->element, "src");
    gst_pad_add_probe(src, GST_PAD_PROBE_TYPE_BLOCK_DOWNSTREAM, [](GstPad *, GstPadProbeInfo *, gpointer) {
        return GST_PAD_PROBE_OK;
    }, nullptr, nullptr);
    gst_object_unref(src);
    std::atomic<GstFlowReturn> last{GST_FLOW_OK};
    std::atomic<int> pushed{0};
    std::atomic<bool> done{false};
    std::vector<GstBuffer *> frames;
    for (int i = 0; i < 20; ++i) {
        frames.push_back(makeFrame(info, i));
        ++live_inputs;
        gst_mini_object_weak_ref(GST_MINI_OBJECT(frames.back()), inputFreed, nullptr);
    }
    std::thread streaming([&] {
        for (GstBuffer *frame : frames) {
            last = gst_harness_push(h, frame);
            if (last != GST_FLOW_OK)
                break;
            ++pushed;
        }
        done = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    fail_unless(pushed < 20, "the chain never blocked (%d frames pushed)", pushed.load());
    fail_if(done.load());
    gst_element_set_state(h->element, GST_STATE_NULL);
    for (int i = 0; i < 200 && !done; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    fail_unless(done.load(), "the chain still waits 10 s after the element went to NULL");
    streaming.join();
    fail_unless_equals_int(last.load(), GST_FLOW_FLUSHING);
    for (std::size_t i = std::size_t(pushed) + 1; i < frames.size(); ++i)
        gst_buffer_unref(frames[i]);  // never pushed
    gst_harness_teardown(h);
    fail_unless_equals_int(live_inputs.load(), 0);
}

GST_START_TEST(warm_up)
{
    GstHarness *h = smallHarness("delay=1");
    StreamLog log(h->sinkpad);
    GstCaps *caps = videoCaps("I420", 64, 48);
    pushFrames(h, videoInfo(caps), 0, 3);
    gst_caps_unref(caps);
    gst_harness_push_event(h, gst_event_new_eos());
    fail_unless(log.waitForEos());
    gst_harness_teardown(h);
}
GST_END_TEST;

namespace {

Suite *flowSuite()
{
    Suite *s = suite_create("uavstabilize-flow");
    TCase *tc = makeTestCase("flow");
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, every_frame_comes_out_once_in_order);
    tcase_add_test(tc, latency_adds_delay_frames);
    tcase_add_test(tc, latency_without_framerate_uses_buffer_duration);
    tcase_add_test(tc, delay_change_posts_latency_message);
    tcase_add_test(tc, serialized_events_keep_their_place);
    tcase_add_test(tc, flush_drops_held_frames_and_restarts);
    tcase_add_test(tc, caps_changes_keep_each_frame_with_its_caps);
    tcase_add_test(tc, same_caps_again_is_just_forwarded);
    tcase_add_test(tc, drain_query_pushes_every_held_frame);
    tcase_add_test(tc, bypass_outputs_the_input_buffers_with_the_same_delay);
    tcase_add_test(tc, toggling_bypass_never_reorders);
    tcase_add_test(tc, a_short_buffer_is_dropped_with_a_warning);
    tcase_add_test(tc, short_buffer_is_an_error_not_a_crash);
    tcase_add_test(tc, max_errors_minus_one_never_errors);
    tcase_add_test(tc, properties_have_the_documented_defaults);
    tcase_add_test(tc, allocation_proposal_covers_the_held_frames);
    tcase_add_test(tc, safe_metas_are_copied_to_warped_frames);
    tcase_add_test(tc, slow_downstream_bounds_what_is_held);
    tcase_add_test(tc, downstream_errors_reach_upstream);
    tcase_add_test(tc, failed_frames_pass_through_with_one_warning);
    tcase_add_test(tc, small_downstream_pool_neither_starves_nor_deadlocks);
    tcase_add_test(tc, flush_unblocks_a_chain_waiting_for_output_buffers);
    tcase_add_test(tc, shutdown_unblocks_a_chain_waiting_for_room);
    return s;
}

} // namespace

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    return runSuite(flowSuite()) == 0 ? 0 : 1;
}
