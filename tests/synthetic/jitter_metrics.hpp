// Quality measures on clips whose true camera path is known.
#pragma once

#include <array>
#include <vector>

#include "uavstab/frame_stats.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab::synthetic {

// Output pixel (centred) -> input pixel (centred) for a frame the stabilizer produced.
Similarity outputToInput(const FrameStats &stats);

// Residual jitter, in world pixels: the four frame corners are followed through the
// world along the given camera path (frame centred coords -> world); the result is the
// RMS, over corners and frames, of each corner's path minus its Gaussian low-pass
// (sigma in frames; near the clip's ends, where the window is cut short, a
// Gaussian-weighted local line, so that a pan is not mistaken for shake).
// For the input: the true poses; for the output: true pose * output_to_input.
// Frames before `first` are left out of the RMS (the low-pass still sees them): with
// first = 30 it measures the steady state, without the first second's start-up.
double residualJitter(const std::vector<Similarity> &world_from_frame, int width, int height, double sigma = 8.0,
                      std::size_t first = 0);
// The same from the four output corners' world positions per frame (top-left, top-right,
// bottom-left, bottom-right), for frames that have no single pose: a rolling shutter's,
// whose output rows each show the world as their input row's own pose saw it.
double cornerJitter(const std::vector<std::array<Point2, 4>> &corners, double sigma = 8.0, std::size_t first = 0);

// Error against the intended (shake-free) path, in px: how far the output strays from the
// path the pilot meant to fly, up to a constant. output_path[i] maps output-frame centred
// coordinates to world (true pose * output_to_input, as for residualJitter); for each frame
// E_i = intended_i^-1 * output_i is where the output frame sits in the intended frame's
// coordinates, ideally the same for every frame (the crop zoom, maybe an offset). The result
// is the RMS over the four output-frame corners and all frames of E_i(corner) minus the
// mean over frames of E_j(corner). A constant offset or zoom costs nothing; lagging behind
// a pan that starts or stops, bending a manoeuvre and leftover shake all cost.
double intendedPathError(const std::vector<Similarity> &output_path, const std::vector<Similarity> &intended_path,
                         int width, int height);

// Jitter against the intended path: residualJitter of E_i = intended_i^-1 * output_i (the
// high-pass of output minus intended, so a smooth lag or a constant offset costs nothing,
// leftover shake and kinks where the output starts or stops late do), over the frames from
// `first` on.
double intendedPathJitter(const std::vector<Similarity> &output_path, const std::vector<Similarity> &intended_path,
                          int width, int height, std::size_t first = 0);

// The largest distance (px) of an output corner from its mean place relative to the intended
// path (of E_i(corner) from the mean over frames of E_j(corner)): how far the output strays.
double intendedPathMaxDeviation(const std::vector<Similarity> &output_path,
                                const std::vector<Similarity> &intended_path, int width, int height);

// The whip: the output view's fastest move over the world against the intended view's
// fastest. Each frame corner's world position (output_path[i] and intended_path[i] applied
// to it) is smoothed lightly (Gaussian, sigma frames, so that leftover shake does not count
// as speed); the speed of a frame is its fastest corner's step. Frames from `first` on.
// Above 1 the output rushes past the pilot's own speed to catch up; 0 where the intended
// view never moves faster than `still` px per frame (a hover has no speed to compare).
double pathWhip(const std::vector<Similarity> &output_path, const std::vector<Similarity> &intended_path, int width,
                int height, std::size_t first = 0, double sigma = 2.0, double still = 0.5);

// Share of the output frame that shows picture: output pixels whose source lies inside
// the input frame (sampled on a grid).
double coverage(const Similarity &output_to_input, int width, int height);

} // namespace uavstab::synthetic
