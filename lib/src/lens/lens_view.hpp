// A stream seen through a calibrated lens: where the stabilizer's similarity motion holds
// and how an output pixel finds its source.
//
// On a wide-angle or fisheye picture a turn or shift of the camera moves the centre and the
// edges by different amounts, so no 2-D transform of the image describes it; in the lens's
// undistorted (pinhole) view it is a similarity again. So tracked points are undistorted
// before the motion fit, the path is planned on the undistorted view, and each output pixel
// is mapped, in one chain:
//   original:  output --crop zoom (in the picture as the lens draws it)--> undistort
//              --correction (output_to_input without its zoom)--> distort --> input
//   rectified: output (pinhole) --output_to_input--> distort --> input
// The crop zoom of `original` is applied to the lens's picture, not the pinhole view: a
// fisheye's undistorted corners lie several times further out than its edges' middles,
// and zooming there would hide almost nothing at the corners.
#pragma once

#include <array>
#include <vector>

#include "uavstab/config.hpp"
#include "uavstab/lens.hpp"
#include "uavstab/similarity.hpp"

namespace uavstab {

class LensView {
public:
    // `lens` at the frame's size (LensModel::scaledTo).
    LensView(const LensModel &lens, LensOutput output, int width, int height);

    const LensModel &lens() const { return lens_; }
    LensOutput output() const { return output_; }
    int width() const { return width_; }
    int height() const { return height_; }

    // Centred frame coordinates (similarity.hpp) to the undistorted view's, centred on the
    // same pixel ((W-1)/2, (H-1)/2).
    Point2 undistortCentred(Point2 p) const;

    // Output pixel -> where it is undistorted before the correction (pinhole pixels, not
    // centred): depends on the crop zoom only, so a warp computes it once per stream.
    Point2 outputToView(Point2 output_px, double zoom) const;
    // ...then from there to the input picture, given the output_to_input pixel matrix of the
    // frame at that row (Similarity::pixelMatrix, RowMatrices::at): input pixel.
    Point2 viewToInput(Point2 view_px, const std::array<double, 6> &output_to_input) const;

    // The output frame's edges, sampled, where they are undistorted (outputToView): for
    // coversFrame, computed once for a frame's tests (each sample is a Newton solve).
    std::vector<Point2> edgeInView(double zoom) const;
    // Whether every output pixel reads from inside the input picture (the edges of
    // edgeInView checked, output_to_input as one transform: the rolling-shutter rows aside,
    // as path/framing.hpp's coversFrame).
    bool coversFrame(const Similarity &output_to_input, const std::vector<Point2> &edge_in_view) const;

private:
    LensModel lens_;
    LensOutput output_;
    int width_, height_;
    double cx_, cy_;  // the frame's centre pixel
};

} // namespace uavstab
