// Helpers shared by the element tests: building the element and its harness, making
// frames, and a log of everything that leaves the element, in the order it leaves.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

// After the standard headers: libcheck defines macros (fail, ...) that clash with them.
#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include "uavstab/frame_view.hpp"

namespace element_test {

// Runs the suite in this process (no fork), so that a first "warm-up" test, which does
// not check for leaks, makes the singletons and class data that live on (otherwise
// they would count as leaks of whichever test comes first). Returns the failures.
int runSuite(Suite *suite);
// Fails listing the objects created since the test started that are still alive.
void assertNoLeaks();

// A test whose body runs to its end (every local destroyed) before the leak check.
#define ELEMENT_TEST(name)                                                                                  \
    static void name##_body();                                                                              \
    GST_START_TEST(name)                                                                                    \
    {                                                                                                       \
        name##_body();                                                                                      \
        element_test::assertNoLeaks();                                                                      \
    }                                                                                                       \
    GST_END_TEST;                                                                                           \
    static void name##_body()
// A test case with leak tracking started before each test, and a generous timeout.
TCase *makeTestCase(const char *name, int timeout_seconds = 120);

// "uavstabilize" with properties given as "name=value name=value".
GstElement *makeStabilizer(const std::string &properties = "");
void setProperties(GstElement *element, const std::string &properties);
// A harness around `element` (takes the caller's reference).
GstHarness *makeHarness(GstElement *element);

GstCaps *videoCaps(const char *format, int width, int height, int fps_n = 30, int fps_d = 1);
GstVideoInfo videoInfo(GstCaps *caps);
GstClockTime frameDuration(int fps_n = 30, int fps_d = 1);

// A frame of `info` filled with a pattern derived from `index`, stamped like frame
// `index` of a 30 fps stream (PTS, DTS, duration, offset, offset_end).
GstBuffer *makeFrame(const GstVideoInfo &info, int index);
// A frame of `info` with `view`'s pixels (same format and size), default layout.
GstBuffer *makeFrame(const GstVideoInfo &info, const uavstab::FrameView &view);
void stampFrame(GstBuffer *buffer, int index, GstClockTime duration = frameDuration());
// Maps a buffer of `info` for reading as a FrameView; unmaps when destroyed.
class MappedFrame {
public:
    MappedFrame(const GstVideoInfo &info, GstBuffer *buffer);
    ~MappedFrame();
    MappedFrame(const MappedFrame &) = delete;
    MappedFrame &operator=(const MappedFrame &) = delete;
    bool ok() const { return mapped_; }
    const uavstab::FrameView &view() const { return view_; }

private:
    GstVideoFrame frame_{};
    bool mapped_ = false;
    uavstab::FrameView view_;
};

// What came out of the element, buffers and events in one list.
struct LoggedItem {
    bool is_buffer = false;
    // Buffers.
    GstClockTime pts = GST_CLOCK_TIME_NONE, dts = GST_CLOCK_TIME_NONE, duration = GST_CLOCK_TIME_NONE;
    guint64 offset = 0, offset_end = 0;
    guint flags = 0;
    gsize size = 0;
    const void *identity = nullptr;  // the GstBuffer pointer (compare only while alive)
    GstBuffer *buffer = nullptr;     // a reference, when the log keeps buffers
    int caps_index = -1;             // which of StreamLog::caps() was current
    // Events.
    GstEvent *event = nullptr;  // a reference
    GstEventType event_type = GST_EVENT_UNKNOWN;
};

// Logs everything arriving on a pad (the harness sink pad) through a probe.
class StreamLog {
public:
    explicit StreamLog(GstPad *pad, bool keep_buffers = false);
    ~StreamLog();
    StreamLog(const StreamLog &) = delete;
    StreamLog &operator=(const StreamLog &) = delete;

    // Waits until `done(items)` holds; false on timeout.
    bool waitFor(const std::function<bool(const std::vector<LoggedItem> &)> &done,
                 std::chrono::seconds timeout = std::chrono::seconds(60));
    bool waitForEos(std::chrono::seconds timeout = std::chrono::seconds(60));
    bool waitForBuffers(std::size_t count, std::chrono::seconds timeout = std::chrono::seconds(60));
    // A snapshot. Buffer and event pointers stay valid while the log lives.
    std::vector<LoggedItem> items() const;
    std::vector<LoggedItem> buffers() const;
    std::vector<GstCaps *> caps() const;

private:
    static GstPadProbeReturn probe(GstPad *pad, GstPadProbeInfo *info, gpointer user_data);

    GstPad *pad_;
    gulong probe_id_ = 0;
    bool keep_buffers_;
    mutable std::mutex mutex_;
    std::condition_variable changed_;
    std::vector<LoggedItem> items_;
    std::vector<GstCaps *> caps_;
};

// A pipeline from a gst-launch description (fails the test if it cannot be built).
GstElement *launchPipeline(const std::string &description);
// Waits for one of `types` on the pipeline's bus; fails on timeout or an error message.
GstMessage *waitForMessage(GstElement *pipeline, GstMessageType types, GstClockTime timeout = 30 * GST_SECOND);

// Pops messages of `types` from the bus until one matches, or timeout (null).
GstMessage *popMessage(GstBus *bus, GstMessageType types, GstClockTime timeout = 5 * GST_SECOND);

} // namespace element_test
