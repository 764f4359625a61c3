// Automatic exclusion of screen-fixed overlays (StabilizerConfig::exclude_static).
//
// A burned-in OSD does not move when the camera shakes. Each frame, a robust fit of the
// tracks that clearly moved (over 1.5 analysis px) gives the camera's motion, if it looks
// like one: most of them agree, they are spread over at least a quarter of the width and
// height, with little rotation or scale. Tracks that this motion would have moved clearly
// but that moved less than a fifth of that are screen-fixed: they are dropped from this
// frame's fit and from the tracker, and their place gains evidence on a 32x18 grid; a cell
// seen twice is handed to the tracker as an excluded region (no corners detected there,
// tracks near it dropped) until ~400 frames after its last sighting. When so many tracks
// were dropped that too few are left for the frame, the estimator has the tracker detect
// afresh around the cells seen in this frame (and those excluded), match the frame again
// (FeatureTracker::retrack), so that learning costs no skipped frame.
//
// A scene point near the centre of a rotation or zoom does not move either, but there the
// fitted motion is small too: it is never taken for an overlay. When the camera holds
// still nothing is flagged (nor needs to be: the overlay agrees with the scene then), and
// objects moving before a still camera do not pass for a camera motion (they are compact,
// or do not agree, or look like a zoom or a turn): tests/unit/exclude_test.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "uavstab/config.hpp"
#include "estimate/feature_tracker.hpp"

namespace uavstab {

class ScreenFixedMap {
public:
    static constexpr int kCols = 32, kRows = 18;

    // Drops the screen-fixed tracks from `matches` (frame of width x height; `scale` =
    // full-resolution pixels per analysis pixel), gathers their evidence and ages the map.
    // Returns how many tracks were dropped.
    // `dropped` gets one flag per track of `matches` as given.
    int filter(PointMatches &matches, int width, int height, double scale, std::uint32_t seed,
               std::vector<std::uint8_t> &dropped);
    // The cells taken for overlays, merged into rectangles along rows (fractions of the frame).
    std::vector<RectF> regions() const;
    // ... and also the cells seen in the latest filter() call (not excluded yet).
    std::vector<RectF> suspectRegions() const;
    void clear();

private:
    std::vector<RectF> regionsFrom(float score) const;

    std::array<float, kCols * kRows> score_{};
    int width_ = 0, height_ = 0;
};

} // namespace uavstab
