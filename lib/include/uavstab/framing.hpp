// From a correction to what the warper draws: the crop zoom that hides borders, and,
// when the correction would still show border, a shrunk correction that does not.
#pragma once

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

} // namespace uavstab
