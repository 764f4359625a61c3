// A non-owning description of one video frame: format, size, and for each plane a
// pointer and a stride, so that host buffers (GStreamer, V4L2, OpenCV) wrap without copies.
//
// Public API: how a host hands its frames to the library. The library reads and writes a
// frame only through these pointers and strides, within its width and height.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "uavstab/pixel_format.hpp"

namespace uavstab {

struct Plane {
    std::uint8_t *data = nullptr;
    int stride = 0;  // bytes from one row to the next; may exceed the row's width
};

struct FrameView {
    PixelFormat format = PixelFormat::Gray8;
    int width = 0;
    int height = 0;
    std::array<Plane, 3> planes{};

    int planeCount() const { return uavstab::planeCount(format); }
    int planeWidth(int plane) const;
    int planeHeight(int plane) const;
    // Bytes of a plane's row that hold pixels (width x channels x bytes per sample).
    int planeRowBytes(int plane) const;

    // True when every plane has data and a stride wide enough for its rows.
    bool valid() const;
    bool sameGeometry(const FrameView &other) const
    {
        return format == other.format && width == other.width && height == other.height;
    }
};

} // namespace uavstab
