// A synthetic shaky UAV clip with known true motion: a virtual camera flies over a real
// aerial photograph along a smooth path (slow pan, slow rotation, optional slow zoom),
// with UAV-like jitter on top (white noise plus a 2-8 Hz band), optionally with
// independently moving foreground objects. Tests, the demo and the benchmark use it to
// compare what the stabilizer did against the truth.
//
// Two intended paths (FlightOptions::profile):
//   Lissajous  (default) a slow Lissajous pan, a slow yaw, an optional slow zoom.
//   Manoeuvre  what a pilot flies: hover, a pan that accelerates at constant acceleration to
//              3.5 px/frame, cruises and decelerates to a stop, hover, a 25 degree yaw turn,
//              a pan in another direction, a stop, a climb (scale +12 %), hover to the end;
//              every segment is piecewise constant acceleration (manoeuvrePlan()). Meant to
//              tell deliberate motion from shake: a stabilizer that lags or bends it pays.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "uavstab/frame_buffer.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab::synthetic {

enum class FlightProfile {
    Lissajous,  // slow Lissajous pan + slow yaw (+ optional zoom): the historical default
    Manoeuvre,  // hover, accelerating pans, a yaw turn, stops, a climb (see manoeuvrePlan())
};

const char *toString(FlightProfile p);

// One segment of the manoeuvre flight, in seconds from the start of the clip. From `from`
// to `to` the intended pose moves from the segment's start pose by `move` (dx, dy in world
// px, angle in radians, scale as a factor), along a trapezoidal velocity profile: constant
// acceleration for `ramp` seconds, cruise, constant deceleration for `ramp` seconds
// (ramp = 0: a hover, `move` is the identity).
struct ManoeuvreSegment {
    const char *name;  // "hover", "pan", "yaw", "climb"
    double from, to, ramp;
    Similarity move;   // dx, dy: displacement; angle: added; scale: multiplied
};

// The manoeuvre flight's segments (10 s; after the last one the camera hovers). Translations
// are for a 640x360 frame and are shrunk (never grown) when the canvas leaves less room;
// at 640x360 and 1280x720 they are used as they are.
const std::vector<ManoeuvreSegment> &manoeuvrePlan();

struct FlightOptions {
    int width = 640;
    int height = 360;
    int frames = 300;
    double fps = 30.0;
    std::uint32_t seed = 1;
    PixelFormat format = PixelFormat::I420;
    // Canvas photograph; empty = the project's tests/data/aero1.jpg.
    std::string canvas;

    // Intended (smooth) motion. The three numbers below shape the Lissajous profile only;
    // the manoeuvre's are fixed (manoeuvrePlan()). The jitter is the same for both.
    FlightProfile profile = FlightProfile::Lissajous;
    double pan_speed = 1.5;          // world px per frame, roughly
    double rotation_amplitude_deg = 2.0;
    double zoom_amplitude = 0.0;     // e.g. 0.05: scale drifts within +-5 %

    // Jitter, in output pixels and degrees (RMS of each component, per axis).
    double noise_px = 0.5;           // white
    double band_px = 3.0;            // 2-8 Hz band
    double rotation_noise_deg = 0.05;
    double rotation_band_deg = 0.3;

    int moving_objects = 0;          // textured patches moving across the scene
};

std::string defaultCanvasPath();

class ShakyFlight {
public:
    explicit ShakyFlight(const FlightOptions &options);

    const FlightOptions &options() const { return options_; }
    int frameCount() const { return options_.frames; }

    // Camera pose of frame i: maps the frame's centred pixel coordinates to world
    // coordinates (world units are output pixels at the flight's base altitude).
    Similarity truePose(int i) const;
    // The same without jitter: the path a perfect stabilizer would follow.
    Similarity intendedPose(int i) const;
    // True motion in the stabilizer's convention: frame i -> frame i-1 coordinates.
    Similarity trueMotion(int i) const;

    // Canvas pixels of a world point: canvas = worldToCanvas().apply(world) + canvas centre
    // ((cols-1)/2, (rows-1)/2), i.e. worldToCanvas() is a pure scale (canvas px per world px).
    Similarity worldToCanvas() const { return {0.0, 0.0, 0.0, base_scale_}; }
    cv::Size canvasSize() const { return canvas_.size(); }
    // Shrink applied to the manoeuvre's translations so that it fits the canvas (1 = none).
    double manoeuvreShrink() const { return manoeuvre_shrink_; }

    cv::Mat renderBgr(int i) const;
    FrameBuffer render(int i, int row_padding = 0) const;

private:
    struct Wave {
        double amplitude, frequency, phase;  // Hz, radians
    };
    struct MovingObject {
        cv::Mat patch;         // BGR, canvas pixels
        cv::Point2d start;     // world
        cv::Point2d velocity;  // world px per frame
    };
    double jitter(const std::vector<Wave> &band, const std::vector<double> &noise, int i) const;
    Similarity manoeuvrePose(double t, double shrink) const;

    FlightOptions options_;
    cv::Mat canvas_;
    double base_scale_ = 1.0;  // canvas px per output px
    cv::Point2d path_amplitude_;
    double path_phase_x_ = 0, path_phase_y_ = 0, rotation_phase_ = 0, zoom_phase_ = 0;
    std::vector<Wave> band_x_, band_y_, band_angle_;
    std::vector<double> noise_x_, noise_y_, noise_angle_;
    std::vector<MovingObject> objects_;
    double manoeuvre_shrink_ = 1.0;
};

} // namespace uavstab::synthetic
