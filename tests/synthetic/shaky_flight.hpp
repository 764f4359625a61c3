// A synthetic shaky UAV clip with known true motion: a virtual camera flies over a real
// aerial photograph along a smooth path (slow pan, slow rotation, optional slow zoom),
// with UAV-like jitter on top (white noise plus a 2-8 Hz band), optionally with
// independently moving foreground objects. Tests, the demo and the benchmark use it to
// compare what the stabilizer did against the truth.
//
// Optionally a rolling shutter and propeller vibration (FlightOptions::readout, vibration_*):
// the camera pose is then a continuous function of time and each image row is rendered with
// the pose at the moment it was read, which bends the frame when the camera shakes fast
// (jello). truePose(i) stays the pose of the middle row.
//
// Optionally a lens (FlightOptions::lens): the motion is still a similarity, but in the
// lens's undistorted (pinhole) coordinates; the picture is the pinhole picture pushed through
// the lens, so a fisheye flight's frame-to-frame motion is not a similarity in image pixels.
// fisheyeLens() and wideAngleLens() are ready-made lenses.
//
// Two intended paths (FlightOptions::profile):
//   Lissajous  (default) a slow Lissajous pan, a slow yaw, an optional slow zoom.
//   Manoeuvre  what a pilot flies: hover, a pan that accelerates at constant acceleration to
//              3.5 px/frame, cruises and decelerates to a stop, hover, a 25 degree yaw turn,
//              a pan in another direction, a stop, a climb (scale +12 %), hover to the end;
//              every segment is piecewise constant acceleration (manoeuvrePlan()). Meant to
//              tell deliberate motion from shake: a stabilizer that lags or bends it pays.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "uavstab/frame_buffer.hpp"
#include "uavstab/lens.hpp"
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

    // Rolling shutter: share of the frame time over which the rows are read, top to bottom
    // (0 = global shutter; small-drone CMOS cameras: 0.5-0.9). Row r of frame i is read at
    // frame time i + readout * (r / (height-1) - 0.5), so the middle row is read at frame i.
    double readout = 0.0;
    // Propeller vibration: sinusoids near vibration_hz (a slight spread, independent random
    // phases for x, y and roll), RMS per axis in output px (x, y) and degrees (roll). Drawn
    // from a generator of its own, so the other random draws do not depend on it. The room
    // the intended path leaves for shake does not count it: the intended path is the same
    // with and without vibration.
    double vibration_hz = 0.0;
    double vibration_px = 0.0;
    double vibration_deg = 0.0;

    // The camera's lens; one calibrated for another size of the same aspect ratio is scaled to
    // the frame (LensModel::scaledTo; options().lens is the scaled one). None: a pinhole view.
    // Otherwise output pixel q of frame i shows what the pinhole camera of the same pose sees
    // at pinhole pixel lens.undistort(q); with a rolling shutter, with the pose of q's own
    // (sensor) row. The canvas scale leaves room for the whole undistorted view, which spreads
    // the photograph thinner: at 640x360 the fisheye below gets 0.24 canvas px per pinhole px
    // (no lens: 0.62), i.e. the frame centre is a 4x bicubic upsample of the default canvas.
    LensModel lens;
};

std::string defaultCanvasPath();

// A small-drone / action-camera fisheye (OpenCV fisheye model, k1..k4 of the order of a
// GoPro or DJI wide mode: 0.05, 0.01, -0.01, 0.005), principal point at the frame centre,
// square pixels; the focal length puts the corners diagonal_fov_deg apart (default 150 deg
// diagonal; at 16:9 about 134 deg horizontal, 79 deg vertical; fx about 0.4 * width).
LensModel fisheyeLens(int width, int height, double diagonal_fov_deg = 150.0);
// A wide-angle lens with barrel distortion (OpenCV standard model, k1 = -0.25, k2 = 0.07, no
// tangential terms), principal point at the frame centre; default 110 deg diagonal (at 16:9
// about 102 deg horizontal, 61 deg vertical; fx about 0.51 * width).
LensModel wideAngleLens(int width, int height, double diagonal_fov_deg = 110.0);

class ShakyFlight {
public:
    explicit ShakyFlight(const FlightOptions &options);

    const FlightOptions &options() const { return options_; }
    int frameCount() const { return options_.frames; }

    // Camera pose of frame i: maps the frame's centred pixel coordinates to world
    // coordinates (world units are output pixels at the flight's base altitude). With a
    // rolling shutter: the pose of the middle row (truePoseAtRow(i, (height-1)/2)).
    // With a lens, this and every pose and motion below are in undistorted (pinhole)
    // coordinates (world units: pinhole pixels), centred: for image pixel q,
    // lens.undistort(q) - ((width-1)/2, (height-1)/2).
    Similarity truePose(int i) const;
    // The camera pose at any time, in frames (frame_time = i is frame i's middle row): the
    // intended path, the jitter's waves and the vibration evaluated at that time, the
    // per-frame white noise linearly interpolated between frames (held before the first and
    // after the last). truePoseAt(i) == truePose(i).
    Similarity truePoseAt(double frame_time) const;
    // The pose that row `row` (0 = top, height-1 = bottom) of frame i was read with (with a
    // lens: a row of the sensor, i.e. of the distorted image).
    Similarity truePoseAtRow(int i, double row) const;
    // When row `row` of frame i was read, in frames.
    double rowTime(int i, double row) const;
    // The same without jitter: the path a perfect stabilizer would follow.
    Similarity intendedPose(int i) const;
    Similarity intendedPoseAt(double frame_time) const;
    // True motion in the stabilizer's convention: frame i -> frame i-1 coordinates.
    Similarity trueMotion(int i) const;

    // Canvas pixels of a world point: canvas = worldToCanvas().apply(world) + canvas centre
    // ((cols-1)/2, (rows-1)/2), i.e. worldToCanvas() is a pure scale (canvas px per world px).
    Similarity worldToCanvas() const { return {0.0, 0.0, 0.0, base_scale_}; }
    cv::Size canvasSize() const { return canvas_.size(); }
    // Width and height of the view in undistorted (pinhole) pixels: the frame's size without
    // a lens, the bounding box of the undistorted frame with one.
    cv::Size2d undistortedFootprint() const { return footprint_; }
    // Where on the canvas (canvas pixels) output pixel `pixel` of frame i is sampled.
    Point2 canvasPosition(int i, Point2 pixel) const;
    // Shrink applied to the manoeuvre's translations so that it fits the canvas (1 = none).
    double manoeuvreShrink() const { return manoeuvre_shrink_; }

    // Frame i: with readout = 0 and no lens one warp with truePose(i); with a rolling shutter
    // each row is sampled with its own pose (moving objects stay where they are at frame i);
    // with a lens every pixel at its undistorted position (the same bicubic sampling).
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
    double jitter(const std::vector<Wave> &band, const std::vector<double> &noise, double frame_time) const;
    static double waves(const std::vector<Wave> &band, double t);
    Similarity manoeuvrePose(double t, double shrink) const;
    // Canvas from output pixel (not centred) for a pose: a 2x3 affine matrix.
    std::array<double, 6> canvasFromOutput(const Similarity &pose) const;

    FlightOptions options_;
    cv::Mat canvas_;
    double base_scale_ = 1.0;  // canvas px per world px (output px without a lens)
    cv::Size2d footprint_;     // undistortedFootprint()
    cv::Mat undistorted_;      // CV_64FC2: lens.undistort() of every output pixel (lens only)
    cv::Point2d path_amplitude_;
    double path_phase_x_ = 0, path_phase_y_ = 0, rotation_phase_ = 0, zoom_phase_ = 0;
    std::vector<Wave> band_x_, band_y_, band_angle_;
    std::vector<double> noise_x_, noise_y_, noise_angle_;
    std::vector<Wave> vibration_x_, vibration_y_, vibration_angle_;
    std::vector<MovingObject> objects_;
    double manoeuvre_shrink_ = 1.0;
};

} // namespace uavstab::synthetic
