// The true camera path of a rendered flight, as CSV beside the clip: written by
// uavstab-render-flight, read by the samples and the benchmark; and the lens it was seen
// through, as an OpenCV calibration.
#pragma once

#include <string>
#include <vector>

#include "uavstab/lens.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab::synthetic {

class ShakyFlight;

// Columns: frame, dx, dy, angle, scale (true pose), then the intended pose likewise.
void writeTruthCsv(const std::string &path, const ShakyFlight &flight);
// The true poses, one per frame; empty if the file cannot be read.
std::vector<Similarity> readTruthCsv(const std::string &path);

// The lens as an OpenCV calibration written by cv::FileStorage (YAML, XML or JSON by the
// file's extension): camera_matrix, distortion_coefficients, image_width, image_height and
// distortion_model ("fisheye" or "plumb_bob"), which uavstab::readLensProfile reads back.
// Throws std::invalid_argument for no lens, std::runtime_error if the file cannot be written.
void writeLensCalibration(const std::string &path, const LensModel &lens);

} // namespace uavstab::synthetic
