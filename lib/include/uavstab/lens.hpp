// The camera's lens: OpenCV's fisheye model (k1-k4) or its standard model (k1, k2, p1, p2,
// k3), and the calibration files drone users have (Gyroflow lens profiles, OpenCV
// calibrations): a pixel's undistorted (pinhole) position and back, and the file reader. The
// Stabilizer takes a calibration file (StabilizerConfig::lens_profile) and reads it with
// readLensProfile(); this header is also for code that maps points or pictures through one.
//
// Public API: LensModel's fields and the meaning of distort()/undistort() hold from version
// to version; readLensProfile() keeps reading the formats listed at it.
#pragma once

#include <array>
#include <stdexcept>
#include <string>

#include "uavstab/similarity.hpp"

namespace uavstab {

enum class LensKind {
    None,      // no lens model: the picture is taken as a pinhole view
    Fisheye,   // OpenCV fisheye (equidistant with k1-k4 on the angle)
    Standard,  // OpenCV standard (Brown-Conrady: radial k1, k2, k3, tangential p1, p2)
};

// A calibrated lens at one image size. Pixel coordinates put pixel centres at integers,
// as OpenCV's calibration does. The undistorted view is the pinhole camera with the same
// camera matrix: undistort() maps an image pixel to where a pinhole camera would have
// seen that point, distort() back.
struct LensModel {
    LensKind kind = LensKind::None;
    double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // camera matrix (no skew), pixels
    // Fisheye: k1, k2, k3, k4 (the fifth is 0). Standard: k1, k2, p1, p2, k3 (OpenCV's order).
    std::array<double, 5> coeffs{};
    int width = 0, height = 0;  // the image size the camera matrix is for

    bool active() const { return kind != LensKind::None; }
    // The same lens for another image size of the same aspect ratio (within 1 %): the
    // camera matrix scaled. Throws std::invalid_argument for another aspect ratio.
    LensModel scaledTo(int new_width, int new_height) const;
    // Image pixel -> undistorted (pinhole) pixel, and back. undistort() inverts distort() to
    // well below a millipixel wherever the model is monotonic (validate()).
    Point2 distort(Point2 undistorted) const;
    Point2 undistort(Point2 image) const;
    // Throws std::invalid_argument naming the field out of range: a size not positive, a
    // focal length not positive, a principal point outside the image, a coefficient not
    // finite or beyond +-100, or a model that folds back (is not one to one) inside the
    // image's corners.
    void validate() const;
};

// What a calibration file says: the lens and, when it says so, how the sensor reads out.
struct LensProfile {
    LensModel lens;
    std::string name;           // the profile's "name", else the file's
    double readout_time = 0.0;  // ms, 0 when the file does not say
    bool readout_bottom_up = false;  // the rows are read from the bottom up
    bool global_shutter = false;
};

// A profile or calibration that cannot be used: names the file and the field.
class LensProfileError : public std::runtime_error {
public:
    LensProfileError(const std::string &file, const std::string &field, const std::string &why);
    const std::string &file() const { return file_; }
    const std::string &field() const { return field_; }

private:
    std::string file_, field_;
};

// Reads a lens calibration file:
// - a Gyroflow lens profile (JSON): calib_dimension, fisheye_params.camera_matrix and
//   .distortion_coeffs, distortion_model (null or "opencv_fisheye": fisheye;
//   "opencv_standard": standard), frame_readout_time (ms), global_shutter; or the older
//   layout with use_opencv_fisheye / use_opencv_standard, the standard model's numbers under
//   calib_params;
// - an OpenCV calibration written by cv::FileStorage (YAML, XML or JSON): camera_matrix,
//   distortion_coefficients (4 values: fisheye, 5: standard, or as distortion_model says),
//   image_width, image_height.
// The lens is validated (LensModel::validate). Throws LensProfileError.
LensProfile readLensProfile(const std::string &path);

} // namespace uavstab
