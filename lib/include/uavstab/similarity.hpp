// A 2-D similarity transform about the frame centre: the one motion type of the library.
//
// Points are in "centred" coordinates: pixel (x, y) of a W x H frame is
// (x - (W-1)/2, y - (H-1)/2). Expressing motion about the centre keeps rotation from
// leaking into translation when transforms are accumulated and smoothed as parameters.
//
// Public API: the transform and the centred coordinates that every result is given in.
#pragma once

#include <array>

namespace uavstab {

struct Point2 {
    double x = 0.0;
    double y = 0.0;
};

struct Similarity {
    double dx = 0.0;     // translation, pixels
    double dy = 0.0;
    double angle = 0.0;  // rotation, radians, counter-clockwise in image axes (y down)
    double scale = 1.0;

    static Similarity identity() { return {}; }

    Point2 apply(Point2 p) const;
    Similarity inverse() const;
    bool isIdentity(double eps = 1e-9) const;

    // Row-major 2x3 matrix acting on pixel coordinates of a width x height frame.
    std::array<double, 6> pixelMatrix(int width, int height) const;
};

// (a * b)(p) = a(b(p)): b is applied first. Angles add without wrapping, so a trajectory
// composed from many steps keeps a continuous angle that can be smoothed directly.
Similarity operator*(const Similarity &a, const Similarity &b);

// The kind of motion fitted to a frame: rigid (shift and turn, 3 DOF) or similarity
// (shift, turn and scale, 4 DOF).
enum class MotionModel { Rigid, Similarity };

const char *toString(MotionModel m);  // "rigid" or "similarity"

} // namespace uavstab
