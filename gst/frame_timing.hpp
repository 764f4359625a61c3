// How long a frame lasts, for the LATENCY answer (delay x frame duration): the caps'
// framerate, else the last buffer duration seen. Written by the streaming thread, read
// by whoever asks for the latency.
#pragma once

#include <mutex>

#include <gst/gst.h>

class FrameTiming {
public:
    // New caps' framerate; true when it differs from the previous one.
    bool setFramerate(gint fps_n, gint fps_d)
    {
        std::lock_guard<std::mutex> lock(mutex_);
        const bool changed = fps_n_ != fps_n || fps_d_ != fps_d;
        fps_n_ = fps_n;
        fps_d_ = fps_d;
        return changed;
    }

    void noteBuffer(GstBuffer *buffer)
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (GST_BUFFER_DURATION_IS_VALID(buffer))
            last_duration_ = GST_BUFFER_DURATION(buffer);
    }

    // The frame duration, or GST_CLOCK_TIME_NONE when neither caps nor buffers tell.
    GstClockTime frameDuration() const
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (fps_n_ > 0 && fps_d_ > 0)
            return gst_util_uint64_scale_int(GST_SECOND, fps_d_, fps_n_);
        if (GST_CLOCK_TIME_IS_VALID(last_duration_) && last_duration_ > 0)
            return last_duration_;
        return GST_CLOCK_TIME_NONE;
    }

    void reset()
    {
        std::lock_guard<std::mutex> lock(mutex_);
        fps_n_ = 0;
        fps_d_ = 1;
        last_duration_ = GST_CLOCK_TIME_NONE;
    }

private:
    mutable std::mutex mutex_;
    gint fps_n_ = 0;
    gint fps_d_ = 1;
    GstClockTime last_duration_ = GST_CLOCK_TIME_NONE;
};
