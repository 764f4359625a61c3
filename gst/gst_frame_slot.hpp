// A uavstab::FrameSlot over GStreamer buffers: the input buffer is held by reference and
// stays mapped (read) while the stabilizer holds the frame; the output buffer comes from
// the negotiated pool only when the frame's correction is final. Nothing is copied.
#pragma once

#include <memory>
#include <optional>

#include <gst/gst.h>
#include <gst/video/video.h>

#include "uavstab/stabilizer.hpp"

// The library's pixel format for a GStreamer video format, if it has one.
std::optional<uavstab::PixelFormat> pixelFormatFor(GstVideoFormat format);

// Wraps a mapped frame, plane by plane, with the strides GStreamer reports.
std::optional<uavstab::FrameView> frameViewOf(const GstVideoFrame &frame);

// Where output buffers come from. Called on the streaming thread.
class OutputBufferSource {
public:
    virtual ~OutputBufferSource() = default;
    // A writable buffer for one frame of the current caps, or null when flushing.
    virtual GstBuffer *acquireOutputBuffer() = 0;
    // Frames go downstream unwarped, with an affine meta (render=affine-meta): the
    // stabilizer gets no output to warp into.
    virtual bool leavesFramesUnwarped() = 0;
};

class GstFrameSlot final : public uavstab::FrameSlot {
public:
    // Takes over the caller's reference to `buffer` and maps it for reading; null (and
    // the reference released) when the buffer does not hold a frame of `info`, e.g. when
    // it is smaller than the caps require. `outputs` must outlive the slot.
    static std::unique_ptr<GstFrameSlot> map(GstBuffer *buffer, const GstVideoInfo &info,
                                             OutputBufferSource &outputs);
    ~GstFrameSlot() override;
    GstFrameSlot(const GstFrameSlot &) = delete;
    GstFrameSlot &operator=(const GstFrameSlot &) = delete;

    uavstab::FrameView input() override { return input_view_; }
    std::optional<uavstab::FrameView> acquireOutput() override;
    // Gives the slot `buffer` (the caller's reference) as its output, mapped for writing:
    // for a frame left unwarped that is warped after all, outside the stabilizer.
    uavstab::FrameView adoptOutput(GstBuffer *buffer);
    // acquireOutput() gave no output because frames go downstream with an affine meta.
    bool leftUnwarped() const { return left_unwarped_; }

    GstBuffer *inputBuffer() const { return input_; }
    // Unmaps and hands over the input buffer, untouched.
    GstBuffer *releaseInput();
    // Unmaps and hands over the output buffer, stamped with the input's timestamps,
    // offsets, flags and the metas that survive a geometric transform. Null if the
    // slot has no output.
    GstBuffer *releaseOutput();

private:
    GstFrameSlot(GstBuffer *input, const GstVideoInfo &info, OutputBufferSource &outputs)
        : input_(input), outputs_(outputs), caps_info_(info)
    {
    }

    GstBuffer *input_;  // owned reference
    OutputBufferSource &outputs_;
    // The layout the caps describe. The input's mapping may differ (a video meta with
    // padded strides); the output is mapped with this or its own meta, never the input's.
    GstVideoInfo caps_info_;
    GstVideoFrame input_frame_{};
    bool input_mapped_ = false;
    uavstab::FrameView input_view_;
    GstBuffer *output_ = nullptr;  // owned reference
    GstVideoFrame output_frame_{};
    bool output_mapped_ = false;
    bool left_unwarped_ = false;
};
