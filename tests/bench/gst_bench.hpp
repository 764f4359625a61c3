// Driving the uavstabilize element from the benchmark: appsrc (frames made in memory
// beforehand) ! uavstabilize ! fakesink sync=false, with per-frame push and arrival times.
#pragma once

#include <atomic>
#include <mutex>
#include <string>
#include <vector>

#include <gst/app/gstappsrc.h>
#include <gst/gst.h>
#include <gst/video/video.h>

#include "common.hpp"

namespace bench {

// Makes GST_PLUGIN_PATH point at the uninstalled plugin (UAVSTAB_GST_PLUGIN_DIR) and
// initializes GStreamer. False (with a reason) when the element cannot be found.
bool initElement(int *argc, char ***argv, std::string *why);

// Frames wrapped as GstBuffers (copied once, here), in the caps' layout.
class GstFrames {
public:
    GstFrames(const std::vector<uavstab::FrameBuffer> &frames, int fps);
    ~GstFrames();
    GstFrames(const GstFrames &) = delete;
    GstFrames &operator=(const GstFrames &) = delete;
    GstCaps *caps() const { return caps_; }
    std::size_t size() const { return buffers_.size(); }
    // A buffer to push: shares frame i's memory (deep = a private copy), stamped as frame k.
    GstBuffer *make(std::size_t i, long k, bool deep = false) const;
    GstClockTime frameDuration() const { return duration_; }
    std::size_t frameBytes() const { return info_.size; }
    // True when `b` shares memory with one of the input frames (passed through, not warped).
    bool isInput(GstBuffer *b) const;

private:
    GstVideoInfo info_;
    GstCaps *caps_ = nullptr;
    std::vector<GstBuffer *> buffers_;
    GstClockTime duration_;
};

// One pipeline run. Arrival times are taken in fakesink's handoff (streaming thread).
class ElementRun {
public:
    // Extra element properties as "name=value ..." (gst-launch syntax).
    ElementRun(const GstFrames &frames, const std::string &element_props, int max_queued_buffers = 3);
    ~ElementRun();
    ElementRun(const ElementRun &) = delete;
    ElementRun &operator=(const ElementRun &) = delete;

    // Per-frame push/arrival records (on by default); off for very long runs.
    void setRecording(bool on) { recording_ = on; }
    void start();  // to PLAYING
    // Pushes frame k (= buffer pingPong(k)); records its push time.
    void push(long k, bool deep = false);
    // EOS, then waits for it at the sink (or an error). False on error/timeout.
    bool finish(double timeout_s = 600.0);

    long received() const { return received_.load(); }
    long passedThrough() const { return passed_through_.load(); }
    const std::vector<Clock::time_point> &pushTimes() const { return push_times_; }
    // Per output frame (in arrival order): its input index (from its PTS), arrival time,
    // and frames pushed when it arrived.
    struct Arrival {
        long index;
        Clock::time_point time;
        long pushed;
    };
    std::vector<Arrival> arrivals() const;
    // Min latency reported by the LATENCY query (ns), or -1.
    gint64 queryLatency() const;
    std::string error() const { return error_; }
    GstElement *pipeline() const { return pipeline_; }

private:
    static void onHandoff(GstElement *, GstBuffer *buffer, GstPad *, gpointer self);

    const GstFrames &frames_;
    GstElement *pipeline_ = nullptr;
    GstElement *src_ = nullptr;
    std::atomic<long> received_{0};
    std::atomic<long> pushed_{0};
    std::atomic<long> passed_through_{0};
    bool recording_ = true;
    std::vector<Clock::time_point> push_times_;
    mutable std::mutex mutex_;
    std::vector<Arrival> arrivals_;
    std::string error_;
};

} // namespace bench
