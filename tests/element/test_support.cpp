// Standard headers first: libcheck defines macros (fail, ...) that clash with them.
#include <cstdio>
#include <cstring>
#include <sstream>

#include <unistd.h>

#include "test_support.hpp"

#include "leak_check.hpp"

namespace element_test {

namespace {

void leakSetup()
{
    startLeakTracking();
}

} // namespace

int runSuite(Suite *suite)
{
    if (!leakTracerActive())
        g_print("note: the leaks tracer is not active (GST_TRACERS=leaks): leak checks are skipped\n");
    SRunner *runner = srunner_create(suite);
    srunner_set_fork_status(runner, CK_NOFORK);
    srunner_run_all(runner, CK_ENV);
    const int failed = srunner_ntests_failed(runner);
    srunner_free(runner);
    if (failed > 0) {
        // A failed test may have left a pipeline running (no fork: nothing was torn
        // down), and gst_deinit at exit would wait for its threads forever.
        std::fflush(stdout);
        std::fflush(stderr);
        _exit(1);
    }
    return failed;
}

void assertNoLeaks()
{
    const std::string leaks = stopLeakTracking();
    fail_unless(leaks.empty(), "objects leaked by the test: %s", leaks.c_str());
}

TCase *makeTestCase(const char *name, int timeout_seconds)
{
    TCase *tc = tcase_create(name);
    tcase_set_timeout(tc, timeout_seconds);
    tcase_add_checked_fixture(tc, leakSetup, nullptr);
    return tc;
}

void setProperties(GstElement *element, const std::string &properties)
{
    std::istringstream words(properties);
    std::string word;
    while (words >> word) {
        const auto eq = word.find('=');
        fail_unless(eq != std::string::npos, "bad property '%s'", word.c_str());
        gst_util_set_object_arg(G_OBJECT(element), word.substr(0, eq).c_str(), word.substr(eq + 1).c_str());
    }
}

GstElement *makeStabilizer(const std::string &properties)
{
    GstElement *element = gst_element_factory_make("uavstabilize", nullptr);
    fail_unless(element != nullptr, "cannot make uavstabilize (GST_PLUGIN_PATH?)");
    gst_object_ref_sink(element);
    setProperties(element, properties);
    return element;
}

GstHarness *makeHarness(GstElement *element)
{
    GstHarness *h = gst_harness_new_with_element(element, "sink", "src");
    gst_object_unref(element);
    return h;
}

GstCaps *videoCaps(const char *format, int width, int height, int fps_n, int fps_d)
{
    return gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, format, "width", G_TYPE_INT, width, "height",
                               G_TYPE_INT, height, "framerate", GST_TYPE_FRACTION, fps_n, fps_d, nullptr);
}

GstVideoInfo videoInfo(GstCaps *caps)
{
    GstVideoInfo info;
    fail_unless(gst_video_info_from_caps(&info, caps));
    return info;
}

GstClockTime frameDuration(int fps_n, int fps_d)
{
    return gst_util_uint64_scale_int(GST_SECOND, fps_d, fps_n);
}

void stampFrame(GstBuffer *buffer, int index, GstClockTime duration)
{
    GST_BUFFER_PTS(buffer) = index * duration;
    GST_BUFFER_DTS(buffer) = index * duration;
    GST_BUFFER_DURATION(buffer) = duration;
    GST_BUFFER_OFFSET(buffer) = guint64(index);
    GST_BUFFER_OFFSET_END(buffer) = guint64(index) + 1;
}

GstBuffer *makeFrame(const GstVideoInfo &info, int index)
{
    GstBuffer *buffer = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&info), nullptr);
    GstMapInfo map;
    fail_unless(gst_buffer_map(buffer, &map, GST_MAP_WRITE));
    for (gsize i = 0; i < map.size; ++i)
        map.data[i] = guint8((i * 7 + gsize(index) * 13) & 0xff);
    gst_buffer_unmap(buffer, &map);
    stampFrame(buffer, index);
    return buffer;
}

GstBuffer *makeFrame(const GstVideoInfo &info, const uavstab::FrameView &view)
{
    GstBuffer *buffer = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&info), nullptr);
    GstVideoInfo copy = info;
    GstVideoFrame frame;
    fail_unless(gst_video_frame_map(&frame, &copy, buffer, GST_MAP_WRITE));
    for (int p = 0; p < view.planeCount(); ++p) {
        auto *dst = static_cast<guint8 *>(GST_VIDEO_FRAME_PLANE_DATA(&frame, p));
        const int stride = GST_VIDEO_FRAME_PLANE_STRIDE(&frame, p);
        for (int y = 0; y < view.planeHeight(p); ++y)
            std::memcpy(dst + std::size_t(y) * stride, view.planes[p].data + std::size_t(y) * view.planes[p].stride,
                        std::size_t(view.planeRowBytes(p)));
    }
    gst_video_frame_unmap(&frame);
    return buffer;
}

MappedFrame::MappedFrame(const GstVideoInfo &info, GstBuffer *buffer)
{
    GstVideoInfo copy = info;
    mapped_ = gst_video_frame_map(&frame_, &copy, buffer, GST_MAP_READ);
    if (!mapped_)
        return;
    const auto format = uavstab::pixelFormatFromString(gst_video_format_to_string(GST_VIDEO_FRAME_FORMAT(&frame_)));
    fail_unless(format.has_value());
    view_.format = *format;
    view_.width = GST_VIDEO_FRAME_WIDTH(&frame_);
    view_.height = GST_VIDEO_FRAME_HEIGHT(&frame_);
    for (int p = 0; p < view_.planeCount(); ++p) {
        view_.planes[p].data = static_cast<std::uint8_t *>(GST_VIDEO_FRAME_PLANE_DATA(&frame_, p));
        view_.planes[p].stride = GST_VIDEO_FRAME_PLANE_STRIDE(&frame_, p);
    }
}

MappedFrame::~MappedFrame()
{
    if (mapped_)
        gst_video_frame_unmap(&frame_);
}

StreamLog::StreamLog(GstPad *pad, bool keep_buffers)
    : pad_(GST_PAD(gst_object_ref(pad))), keep_buffers_(keep_buffers)
{
    probe_id_ = gst_pad_add_probe(pad_,
                                  GstPadProbeType(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_EVENT_DOWNSTREAM |
                                                  GST_PAD_PROBE_TYPE_EVENT_FLUSH),
                                  probe, this, nullptr);
}

StreamLog::~StreamLog()
{
    gst_pad_remove_probe(pad_, probe_id_);
    gst_object_unref(pad_);
    for (LoggedItem &item : items_) {
        if (item.buffer)
            gst_buffer_unref(item.buffer);
        if (item.event)
            gst_event_unref(item.event);
    }
    for (GstCaps *caps : caps_)
        gst_caps_unref(caps);
}

GstPadProbeReturn StreamLog::probe(GstPad *, GstPadProbeInfo *info, gpointer user_data)
{
    auto *self = static_cast<StreamLog *>(user_data);
    LoggedItem item;
    std::lock_guard<std::mutex> lock(self->mutex_);
    if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) {
        GstBuffer *buffer = GST_PAD_PROBE_INFO_BUFFER(info);
        item.is_buffer = true;
        item.pts = GST_BUFFER_PTS(buffer);
        item.dts = GST_BUFFER_DTS(buffer);
        item.duration = GST_BUFFER_DURATION(buffer);
        item.offset = GST_BUFFER_OFFSET(buffer);
        item.offset_end = GST_BUFFER_OFFSET_END(buffer);
        item.flags = GST_BUFFER_FLAGS(buffer);
        item.size = gst_buffer_get_size(buffer);
        item.identity = buffer;
        item.caps_index = int(self->caps_.size()) - 1;
        if (self->keep_buffers_)
            item.buffer = gst_buffer_ref(buffer);
    } else {
        GstEvent *event = GST_PAD_PROBE_INFO_EVENT(info);
        item.event = gst_event_ref(event);
        item.event_type = GST_EVENT_TYPE(event);
        if (item.event_type == GST_EVENT_CAPS) {
            GstCaps *caps = nullptr;
            gst_event_parse_caps(event, &caps);
            self->caps_.push_back(gst_caps_ref(caps));
        }
    }
    self->items_.push_back(item);
    self->changed_.notify_all();
    return GST_PAD_PROBE_OK;
}

bool StreamLog::waitFor(const std::function<bool(const std::vector<LoggedItem> &)> &done, std::chrono::seconds timeout)
{
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return done(items_); });
}

bool StreamLog::waitForEos(std::chrono::seconds timeout)
{
    return waitFor(
        [](const std::vector<LoggedItem> &items) {
            for (const LoggedItem &item : items)
                if (item.event_type == GST_EVENT_EOS)
                    return true;
            return false;
        },
        timeout);
}

bool StreamLog::waitForBuffers(std::size_t count, std::chrono::seconds timeout)
{
    return waitFor(
        [count](const std::vector<LoggedItem> &items) {
            std::size_t n = 0;
            for (const LoggedItem &item : items)
                n += item.is_buffer;
            return n >= count;
        },
        timeout);
}

std::vector<LoggedItem> StreamLog::items() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return items_;
}

std::vector<LoggedItem> StreamLog::buffers() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<LoggedItem> result;
    for (const LoggedItem &item : items_)
        if (item.is_buffer)
            result.push_back(item);
    return result;
}

std::vector<GstCaps *> StreamLog::caps() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return caps_;
}

GstMessage *popMessage(GstBus *bus, GstMessageType types, GstClockTime timeout)
{
    return gst_bus_timed_pop_filtered(bus, timeout, types);
}

GstElement *launchPipeline(const std::string &description)
{
    GError *error = nullptr;
    GstElement *pipeline = gst_parse_launch(description.c_str(), &error);
    fail_unless(pipeline != nullptr && error == nullptr, "cannot launch '%s': %s", description.c_str(),
                error ? error->message : "?");
    return GST_ELEMENT(gst_object_ref_sink(pipeline));
}

GstMessage *waitForMessage(GstElement *pipeline, GstMessageType types, GstClockTime timeout)
{
    GstBus *bus = gst_element_get_bus(pipeline);
    GstMessage *message =
        gst_bus_timed_pop_filtered(bus, timeout, GstMessageType(types | GST_MESSAGE_ERROR));
    gst_object_unref(bus);
    fail_unless(message != nullptr, "timed out waiting for a message");
    if (GST_MESSAGE_TYPE(message) == GST_MESSAGE_ERROR) {
        GError *error = nullptr;
        gst_message_parse_error(message, &error, nullptr);
        fail("error from the pipeline: %s", error->message);
    }
    return message;
}

} // namespace element_test
