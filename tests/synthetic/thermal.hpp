// 16-bit thermal test frames (GRAY16_LE / GRAY16_BE): a picture squeezed into a narrow
// band of raw counts, as a thermal camera sees a scene of nearly uniform temperature,
// with sensor noise and hot spots (vehicles, people, engines) far above the band that
// move on their own, appear and vanish. For the 16-bit tests of the library and element.
#pragma once

#include <climits>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "shaky_flight.hpp"
#include "uavstab/frame_buffer.hpp"

namespace uavstab::synthetic {

struct HotSpot {
    Point2 world;        // position at frame `appear`, world px (the flight's world coordinates)
    Point2 velocity;     // world px per frame
    double radius = 6.0; // world px
    int appear = 0;      // visible in frames [appear, vanish)
    int vanish = INT_MAX;
    std::uint16_t value = 60000;
};

struct ThermalOptions {
    PixelFormat format = PixelFormat::Gray16LE;
    double base = 30000.0;  // grey 0 of the picture
    double span = 400.0;    // grey 255: base + span
    double noise = 2.0;     // sensor noise, RMS counts
    std::uint32_t seed = 1;
    std::vector<HotSpot> hot_spots;
};

// A sample of a 16-bit frame, read and written in the frame's byte order.
std::uint16_t sample16(const FrameView &frame, int x, int y);
void setSample16(const FrameView &frame, int x, int y, std::uint16_t value);
void fill16(FrameBuffer &frame, std::uint16_t value);

// Frame `index` of a thermal clip: `grey` (CV_32FC1, 0..255, the frame's size) mapped to
// base + span * grey / 255, hot spots drawn where `world_from_frame` (frame centred px ->
// world) puts them (anti-aliased discs), then noise (seeded by options.seed and index).
FrameBuffer thermalFrame(const cv::Mat &grey, const Similarity &world_from_frame, int index,
                         const ThermalOptions &options);

// The flight's frame i as a thermal camera would see it (the picture's BT.601 luma,
// unrounded, as the grey). The flight itself is untouched.
FrameBuffer renderThermal(const ShakyFlight &flight, int i, const ThermalOptions &options);

// The smallest and largest sample of a 16-bit frame.
std::pair<std::uint16_t, std::uint16_t> sampleRange(const FrameView &frame);

} // namespace uavstab::synthetic
