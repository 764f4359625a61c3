// Writes a lens as the Gyroflow lens profile a user would hand the stabilizer
// (StabilizerConfig::lens_profile, the element's lens-profile), for tests and the benchmark.
#pragma once

#include <string>

#include "uavstab/lens.hpp"

namespace uavstab::synthetic {

// The profile's current layout: calib_dimension, distortion_model ("opencv_fisheye" or
// "opencv_standard") and fisheye_params' camera_matrix and distortion_coeffs. A readout
// time in ms (0: none) and a global shutter go in when given. Returns `path`; throws
// std::runtime_error when it cannot be written.
std::string writeLensProfile(const LensModel &lens, const std::string &path, double readout_ms = 0.0,
                             bool global_shutter = false);

} // namespace uavstab::synthetic
