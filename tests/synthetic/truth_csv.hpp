// The true camera path of a rendered flight, as CSV beside the clip: written by
// uavstab-render-flight, read by the samples and the benchmark.
#pragma once

#include <string>
#include <vector>

#include "uavstab/similarity.hpp"

namespace uavstab::synthetic {

class ShakyFlight;

// Columns: frame, dx, dy, angle, scale (true pose), then the intended pose likewise.
void writeTruthCsv(const std::string &path, const ShakyFlight &flight);
// The true poses, one per frame; empty if the file cannot be read.
std::vector<Similarity> readTruthCsv(const std::string &path);

} // namespace uavstab::synthetic
