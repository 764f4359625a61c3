#include "uavstab/pixel_format.hpp"

#include <array>
#include <utility>

namespace uavstab {

namespace {
constexpr std::array<std::pair<PixelFormat, std::string_view>, 13> kNames{{
    {PixelFormat::Gray8, "GRAY8"}, {PixelFormat::I420, "I420"}, {PixelFormat::YV12, "YV12"},
    {PixelFormat::NV12, "NV12"},   {PixelFormat::NV21, "NV21"}, {PixelFormat::RGB, "RGB"},
    {PixelFormat::BGR, "BGR"},     {PixelFormat::RGBA, "RGBA"}, {PixelFormat::BGRA, "BGRA"},
    {PixelFormat::RGBx, "RGBx"},   {PixelFormat::BGRx, "BGRx"}, {PixelFormat::Gray16LE, "GRAY16_LE"},
    {PixelFormat::Gray16BE, "GRAY16_BE"},
}};
} // namespace

int planeCount(PixelFormat format)
{
    switch (format) {
    case PixelFormat::I420:
    case PixelFormat::YV12:
        return 3;
    case PixelFormat::NV12:
    case PixelFormat::NV21:
        return 2;
    default:
        return 1;
    }
}

PlaneLayout planeLayout(PixelFormat format, int plane)
{
    switch (format) {
    case PixelFormat::Gray8:
        return {1, 1, 1};
    case PixelFormat::Gray16LE:
    case PixelFormat::Gray16BE:
        return {1, 1, 1, 2};
    case PixelFormat::I420:
    case PixelFormat::YV12:
        return plane == 0 ? PlaneLayout{1, 1, 1} : PlaneLayout{1, 2, 2};
    case PixelFormat::NV12:
    case PixelFormat::NV21:
        return plane == 0 ? PlaneLayout{1, 1, 1} : PlaneLayout{2, 2, 2};
    case PixelFormat::RGB:
    case PixelFormat::BGR:
        return {3, 1, 1};
    default:
        return {4, 1, 1};
    }
}

bool isYuv(PixelFormat format)
{
    switch (format) {
    case PixelFormat::I420:
    case PixelFormat::YV12:
    case PixelFormat::NV12:
    case PixelFormat::NV21:
        return true;
    default:
        return false;
    }
}

bool is16Bit(PixelFormat format)
{
    return format == PixelFormat::Gray16LE || format == PixelFormat::Gray16BE;
}

bool isBigEndian(PixelFormat format)
{
    return format == PixelFormat::Gray16BE;
}

RgbOrder rgbOrder(PixelFormat format)
{
    switch (format) {
    case PixelFormat::RGB:
    case PixelFormat::RGBA:
    case PixelFormat::RGBx:
        return {0, 1, 2};
    case PixelFormat::BGR:
    case PixelFormat::BGRA:
    case PixelFormat::BGRx:
        return {2, 1, 0};
    default:
        return {};
    }
}

std::string_view toString(PixelFormat format)
{
    for (const auto &[f, name] : kNames)
        if (f == format)
            return name;
    return "unknown";
}

std::optional<PixelFormat> pixelFormatFromString(std::string_view name)
{
    for (const auto &[f, n] : kNames)
        if (n == name)
            return f;
    return std::nullopt;
}

} // namespace uavstab
