// Internal: automatic exclusion of screen-fixed overlays (StabilizerConfig::exclude_static).
//
// A burned-in OSD does not move when the camera shakes. Each frame, the tracks that stayed
// put (under kStaticPx analysis pixels) are compared with the motion the *other* tracks
// agree on (a robust fit of the moving ones): where that motion would have moved them
// clearly (over kMovingPx), they are screen-fixed. They are dropped from this frame's fit,
// and their place gains evidence on a coarse grid of the frame; cells with enough
// evidence are handed to the tracker as excluded regions (no corners detected there, tracks
// near them dropped). Evidence decays, so a cell is freed a while after the last sighting
// (and caught again within a frame or two if the overlay is still there).
//
// A scene point near the centre of a rotation or zoom does not move either, but there the
// fitted motion is small too: it is never taken for an overlay. When the camera holds
// still nothing is flagged (nor needs to be: the overlay agrees with the scene then).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "uavstab/config.hpp"
#include "uavstab/feature_tracker.hpp"

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
    void clear();

private:
    std::array<float, kCols * kRows> score_{};
    int width_ = 0, height_ = 0;
};

} // namespace uavstab
