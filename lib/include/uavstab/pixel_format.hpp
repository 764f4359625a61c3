// Pixel formats the library can read and warp, and the plane layout of each.
//
// Public API: the formats and their plane layouts.
#pragma once

#include <optional>
#include <string_view>

namespace uavstab {

enum class PixelFormat {
    Gray8,
    I420,  // Y, U, V planes, chroma 2x2 subsampled
    YV12,  // Y, V, U planes, chroma 2x2 subsampled
    NV12,  // Y plane, interleaved UV plane 2x2 subsampled
    NV21,  // Y plane, interleaved VU plane 2x2 subsampled
    RGB,
    BGR,
    RGBA,
    BGRA,
    RGBx,
    BGRx,
    Gray16LE,  // one plane of 16-bit samples, little-endian (thermal cameras)
    Gray16BE,  // the same, big-endian
};

// How one plane of a format is laid out.
struct PlaneLayout {
    int channels = 1;      // interleaved samples per pixel in this plane
    int subsample_x = 1;   // plane width = ceil(width / subsample_x)
    int subsample_y = 1;
    int bytes_per_sample = 1;  // 2 for the 16-bit formats
};

int planeCount(PixelFormat format);
PlaneLayout planeLayout(PixelFormat format, int plane);
bool isYuv(PixelFormat format);
// One plane of 16-bit samples (Gray16LE, Gray16BE).
bool is16Bit(PixelFormat format);
// 16-bit samples stored most significant byte first.
bool isBigEndian(PixelFormat format);

// Byte offsets of R, G and B inside a pixel of a packed RGB format (-1 for YUV/gray).
struct RgbOrder { int r = -1, g = -1, b = -1; };
RgbOrder rgbOrder(PixelFormat format);

// Names as GStreamer spells them ("I420", "GRAY8", "BGRx", "GRAY16_LE", ...).
std::string_view toString(PixelFormat format);
std::optional<PixelFormat> pixelFormatFromString(std::string_view name);

} // namespace uavstab
