// From a correction to what the warper draws: the crop zoom that hides borders, and,
// when the correction would still show border, a shrunk correction that does not.
#pragma once

#include <functional>

#include "uavstab/similarity.hpp"

namespace uavstab {

struct Framing {
    // Maps an output pixel (centred coordinates) to where it is read in the input frame.
    Similarity output_to_input;
    // Correction actually applied (input -> stabilized), after limiting.
    Similarity applied;
    double zoom = 1.0;
    // Share of the requested correction applied: 1 unless limited to the crop.
    double fraction = 1.0;
};

double zoomForCrop(double crop);

// Same correction scaled by t in parameter space: identity at t = 0, `c` at t = 1.
Similarity scaleCorrection(const Similarity &c, double t);

// True when every output corner reads from inside the input frame.
bool coversFrame(const Similarity &output_to_input, int width, int height);

Framing frameOutput(const Similarity &correction, int width, int height, double crop, bool limit_to_crop);

// The largest share t of `correction` (scaleCorrection) whose output_to_input,
// scaleCorrection(correction, t)^-1 * zoom^-1, `covers` accepts, found by bisection to
// 1/16384 (0 when none); frameOutput with coversFrame, the lens's framing with its own test.
double largestCoveredShare(const Similarity &correction, double zoom,
                           const std::function<bool(const Similarity &output_to_input)> &covers);

// How far the crop window may move inside the frame. The window is the output frame's
// footprint in the input frame: half size (hx, hy) / zoom about the centre, where
// hx = (width - 1) / 2. Placed by a displacement D (output pose relative to the camera's:
// scale s, angle a, translation t in the input frame's axes), it stays inside the frame
// when |t.x| <= room.x and |t.y| <= room.y.
struct CropWindow {
    double hx = 0, hy = 0;  // the frame's half size
    double wx = 0, wy = 0;  // the window's half size
    CropWindow(int width, int height, double zoom);
    // Translation room left once the window is rotated by `angle` and scaled by `scale`
    // (negative when even a centred window does not fit).
    Point2 translationRoom(double angle, double scale) const;
    // Largest |angle| that leaves at least `reserve` (a share of the unrotated window's
    // translation room, per axis) for translation at this scale; 0 when none.
    double angleRoom(double scale, double reserve) const;
};

} // namespace uavstab
