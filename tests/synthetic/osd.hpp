// A drone's on-screen display burned into synthetic frames, and the haze that makes the
// scene behind it faint: the case where screen-fixed strokes outshine the scene and pull
// any estimate that tracks them towards "no motion" (tests, benchmark).
#pragma once

#include <opencv2/core.hpp>

namespace uavstab::synthetic {

// The picture through haze: blurred by `blur` px (sigma), contrast scaled by `contrast`
// about mid-grey.
cv::Mat hazy(const cv::Mat &bgr, double contrast = 0.5, double blur = 2.0);

struct OsdStyle {
    // The flight OSD of the exclude tests: a timestamp and telemetry along the top, a
    // status bar along the bottom, speed and altitude boxes with tape ticks at the sides,
    // a crosshair and a pitch ladder in the centre.
    // With `full`: also a heading tape under the top text and a thin frame border, as
    // many flight controllers draw (strokes over the whole width, near the top and bottom
    // rows, where a rolling shutter bends the frame most).
    bool full = false;
};

// Burns frame `frame`'s OSD (its clock ticks) into a frame laid out for 640x360; other
// sizes get the same layout scaled.
void burnOsd(cv::Mat &bgr, int frame, const OsdStyle &style = {});

} // namespace uavstab::synthetic
