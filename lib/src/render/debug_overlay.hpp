// The debug overlay (StabilizerConfig::debug_overlay, the element's `debug-overlay`):
// drawn by the stabilizer on each warped output frame, after the warp, like vid.stab's
// `show`. It shows what the estimator used, where it lands in the output:
//   - the tracked points: inliers of the motion fit green, rejected ones red (small squares);
//   - the excluded rectangles (StabilizerConfig::exclude) in yellow: they are fixed to the
//     input frame's screen, so in the output they move with the correction;
//   - the input frame's edges in blue: the crop window's room. With limit_to_crop they stay
//     just outside the output; they show where a correction uses up the crop margin (and
//     where border comes in, limit_to_crop off).
// Colours are drawn as such in RGB formats and YUV (luma and chroma, BT.601 video range);
// GRAY8 and 16-bit gray get white (inliers, rectangles) and black (rejected, edges).
#pragma once

#include <cstdint>
#include <vector>

#include "uavstab/config.hpp"
#include "uavstab/frame_stats.hpp"
#include "uavstab/frame_view.hpp"

namespace uavstab {

struct OverlayColor {
    std::uint8_t r = 0, g = 0, b = 0;
    std::uint8_t gray = 0;  // what gray formats get
};

// Sets one pixel of any supported format (out-of-frame pixels are ignored). For
// subsampled chroma the whole chroma sample of the pixel takes the colour.
void putOverlayPixel(const FrameView &frame, int x, int y, const OverlayColor &color);
// A 1-pixel line between two pixel positions (pixel-centre coordinates), clipped.
void drawOverlayLine(const FrameView &frame, double x0, double y0, double x1, double y1, const OverlayColor &color);

// Draws the overlay of `stats` (its tracks and output_to_input) onto `output`, the warped
// frame, with `exclude` in fractions of the frame.
void drawDebugOverlay(const FrameView &output, const FrameStats &stats, const std::vector<RectF> &exclude);

} // namespace uavstab
