// A frame that owns its pixels: for tests, samples and the synthetic clip generator.
// Hosts with their own buffers (the GStreamer element) use FrameView directly.
//
// Public API: owning storage with the library's own strides, for hosts without buffers
// of their own.
#pragma once

#include <cstdint>
#include <vector>

#include "uavstab/frame_view.hpp"

namespace uavstab {

class FrameBuffer {
public:
    FrameBuffer() = default;
    // row_padding adds bytes at the end of every row, to exercise stride handling.
    FrameBuffer(PixelFormat format, int width, int height, int row_padding = 0);

    FrameBuffer(const FrameBuffer &other);
    FrameBuffer &operator=(const FrameBuffer &other);
    FrameBuffer(FrameBuffer &&) noexcept = default;
    FrameBuffer &operator=(FrameBuffer &&) noexcept = default;

    const FrameView &view() const { return view_; }
    PixelFormat format() const { return view_.format; }
    int width() const { return view_.width; }
    int height() const { return view_.height; }
    std::uint8_t *row(int plane, int y) { return view_.planes[plane].data + std::size_t(y) * view_.planes[plane].stride; }
    const std::uint8_t *row(int plane, int y) const
    {
        return view_.planes[plane].data + std::size_t(y) * view_.planes[plane].stride;
    }

    void fill(std::uint8_t value);
    // Copies pixels (not padding) from a frame of the same geometry.
    void copyFrom(const FrameView &src);

private:
    void layout(PixelFormat format, int width, int height, int row_padding);

    std::vector<std::uint8_t> storage_;
    FrameView view_;
    int row_padding_ = 0;
};

} // namespace uavstab
