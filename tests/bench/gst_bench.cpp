#include "gst_bench.hpp"

#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace bench {

using namespace uavstab;

bool initElement(int *argc, char ***argv, std::string *why)
{
#ifdef UAVSTAB_GST_PLUGIN_DIR
    const char *old = std::getenv("GST_PLUGIN_PATH");
    std::string path = UAVSTAB_GST_PLUGIN_DIR;
    if (old && *old)
        path += std::string(":") + old;
    setenv("GST_PLUGIN_PATH", path.c_str(), 1);
#endif
    gst_init(argc, argv);
    GstElementFactory *f = gst_element_factory_find("uavstabilize");
    if (!f) {
        *why = "the uavstabilize element was not found (plugin not built?)";
        return false;
    }
    gst_object_unref(f);
    for (const char *name : {"appsrc", "fakesink"}) {
        GstElementFactory *g = gst_element_factory_find(name);
        if (!g) {
            *why = std::string("GStreamer element ") + name + " is missing";
            return false;
        }
        gst_object_unref(g);
    }
    return true;
}

GstFrames::GstFrames(const std::vector<FrameBuffer> &frames, int fps)
{
    if (frames.empty())
        throw std::invalid_argument("GstFrames: no frames");
    const FrameBuffer &f0 = frames.front();
    const GstVideoFormat fmt = f0.format() == PixelFormat::I420   ? GST_VIDEO_FORMAT_I420
                               : f0.format() == PixelFormat::BGRx ? GST_VIDEO_FORMAT_BGRx
                                                                  : GST_VIDEO_FORMAT_UNKNOWN;
    if (fmt == GST_VIDEO_FORMAT_UNKNOWN)
        throw std::invalid_argument("GstFrames: only I420 and BGRx");
    gst_video_info_set_format(&info_, fmt, guint(f0.width()), guint(f0.height()));
    info_.fps_n = fps;
    info_.fps_d = 1;
    caps_ = gst_video_info_to_caps(&info_);
    duration_ = gst_util_uint64_scale_int(GST_SECOND, 1, fps);
    for (const FrameBuffer &f : frames) {
        GstBuffer *b = gst_buffer_new_allocate(nullptr, info_.size, nullptr);
        GstVideoFrame vf;
        if (!gst_video_frame_map(&vf, &info_, b, GST_MAP_WRITE))
            throw std::runtime_error("GstFrames: cannot map");
        for (int p = 0; p < f.view().planeCount(); ++p) {
            const int bytes = f.view().planeRowBytes(p);
            for (int y = 0; y < f.view().planeHeight(p); ++y)
                std::memcpy(static_cast<std::uint8_t *>(GST_VIDEO_FRAME_PLANE_DATA(&vf, p)) +
                                std::size_t(y) * GST_VIDEO_FRAME_PLANE_STRIDE(&vf, p),
                            f.row(p, y), std::size_t(bytes));
        }
        gst_video_frame_unmap(&vf);
        buffers_.push_back(b);
    }
}

bool GstFrames::isInput(GstBuffer *b) const
{
    if (gst_buffer_n_memory(b) == 0)
        return false;
    GstMemory *m = gst_buffer_peek_memory(b, 0);
    for (GstBuffer *in : buffers_)
        if (gst_buffer_peek_memory(in, 0) == m)
            return true;
    return false;
}

GstFrames::~GstFrames()
{
    for (GstBuffer *b : buffers_)
        gst_buffer_unref(b);
    if (caps_)
        gst_caps_unref(caps_);
}

GstBuffer *GstFrames::make(std::size_t i, long k, bool deep) const
{
    GstBuffer *b = deep ? gst_buffer_copy_deep(buffers_[i]) : gst_buffer_copy(buffers_[i]);
    GST_BUFFER_PTS(b) = GstClockTime(k) * duration_;
    GST_BUFFER_DTS(b) = GST_CLOCK_TIME_NONE;
    GST_BUFFER_DURATION(b) = duration_;
    GST_BUFFER_OFFSET(b) = guint64(k);
    return b;
}

ElementRun::ElementRun(const GstFrames &frames, const std::string &element_props, int max_queued_buffers)
    : frames_(frames)
{
    const std::string desc = "appsrc name=src ! uavstabilize name=stab " + element_props +
                             " ! fakesink name=sink sync=false async=false signal-handoffs=true enable-last-sample=false";
    GError *err = nullptr;
    pipeline_ = gst_parse_launch(desc.c_str(), &err);
    if (!pipeline_ || err) {
        const std::string msg = err ? err->message : "unknown";
        if (err)
            g_error_free(err);
        throw std::runtime_error("cannot build pipeline: " + msg);
    }
    src_ = gst_bin_get_by_name(GST_BIN(pipeline_), "src");
    g_object_set(src_, "caps", frames.caps(), "format", GST_FORMAT_TIME, "is-live", FALSE, "block", TRUE, "max-bytes",
                 guint64(max_queued_buffers) * frames.frameBytes(), "emit-signals", FALSE, nullptr);
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline_), "sink");
    g_signal_connect(sink, "handoff", G_CALLBACK(onHandoff), this);
    gst_object_unref(sink);
    arrivals_.reserve(4096);
    push_times_.reserve(4096);
}

ElementRun::~ElementRun()
{
    if (pipeline_) {
        gst_element_set_state(pipeline_, GST_STATE_NULL);
        gst_object_unref(src_);
        gst_object_unref(pipeline_);
    }
}

void ElementRun::onHandoff(GstElement *, GstBuffer *buffer, GstPad *, gpointer data)
{
    auto *self = static_cast<ElementRun *>(data);
    const auto now = Clock::now();
    const GstClockTime pts = GST_BUFFER_PTS(buffer);
    const long index = GST_CLOCK_TIME_IS_VALID(pts)
                           ? long((pts + self->frames_.frameDuration() / 2) / self->frames_.frameDuration())
                           : -1;
    if (self->recording_) {
        std::lock_guard<std::mutex> lock(self->mutex_);
        self->arrivals_.push_back({index, now, self->pushed_.load()});
    }
    if (self->frames_.isInput(buffer))
        self->passed_through_.fetch_add(1);
    self->received_.fetch_add(1);
}

void ElementRun::start()
{
    if (gst_element_set_state(pipeline_, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE)
        throw std::runtime_error("pipeline refused to play");
}

void ElementRun::push(long k, bool deep)
{
    GstBuffer *b = frames_.make(std::size_t(pingPong(k, int(frames_.size()))), k, deep);
    if (recording_)
        push_times_.push_back(Clock::now());
    pushed_.store(k + 1);
    gst_app_src_push_buffer(GST_APP_SRC(src_), b);
}

bool ElementRun::finish(double timeout_s)
{
    gst_app_src_end_of_stream(GST_APP_SRC(src_));
    GstBus *bus = gst_element_get_bus(pipeline_);
    GstMessage *msg = gst_bus_timed_pop_filtered(bus, GstClockTime(timeout_s * GST_SECOND),
                                                 GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    bool ok = false;
    if (!msg) {
        error_ = "timeout";
    } else if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
        GError *err = nullptr;
        gst_message_parse_error(msg, &err, nullptr);
        error_ = err ? err->message : "error";
        if (err)
            g_error_free(err);
    } else {
        ok = true;
    }
    if (msg)
        gst_message_unref(msg);
    gst_object_unref(bus);
    return ok;
}

std::vector<ElementRun::Arrival> ElementRun::arrivals() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return arrivals_;
}

gint64 ElementRun::queryLatency() const
{
    // Asked of the element's src pad: the element adds its delay to upstream's answer.
    GstElement *stab = gst_bin_get_by_name(GST_BIN(pipeline_), "stab");
    GstPad *pad = gst_element_get_static_pad(stab, "src");
    GstQuery *q = gst_query_new_latency();
    gint64 result = -1;
    if (gst_pad_query(pad, q)) {
        gboolean live = FALSE;
        GstClockTime min = 0, max = 0;
        gst_query_parse_latency(q, &live, &min, &max);
        result = gint64(min);
    }
    gst_query_unref(q);
    gst_object_unref(pad);
    gst_object_unref(stab);
    return result;
}

} // namespace bench
