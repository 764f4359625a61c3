// OverlayStrokes: a flight OSD's pixels found in the luma while the camera moves, with the
// flight's true motion standing in for the estimator's.
#include <gtest/gtest.h>

#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "estimate/overlay_strokes.hpp"
#include "osd.hpp"
#include "shaky_flight.hpp"

using namespace uavstab;

namespace {

cv::Mat lumaOf(const cv::Mat &bgr)
{
    cv::Mat grey;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    return grey;
}

// The OSD's own pixels at frame i: where it changes a mid-grey frame.
cv::Mat osdPixels(int width, int height, int frame)
{
    cv::Mat grey(height, width, CV_8UC3, cv::Scalar(128, 128, 128)), burnt = grey.clone();
    synthetic::burnOsd(burnt, frame);
    cv::Mat diff, pixels;
    cv::absdiff(burnt, grey, diff);
    cv::cvtColor(diff, pixels, cv::COLOR_BGR2GRAY);
    return pixels > 0;
}

struct Found {
    double osd_found = 0;      // share of the OSD's edge pixels in the mask
    double scene_taken = 0;    // share of the pixels 6 px or more from the OSD in the mask
    double painted_error = 0;  // mean |painted - scene without OSD| on the OSD's edges
    double burnt_error = 0;    // the same for the frame with the OSD
};

Found fly(const synthetic::FlightOptions &options, bool osd)
{
    const synthetic::ShakyFlight flight(options);
    OverlayStrokes strokes;
    cv::Mat painted;
    Found found;
    for (int i = 0; i < flight.frameCount(); ++i) {
        const cv::Mat scene = synthetic::hazy(flight.renderBgr(i));
        cv::Mat bgr = scene.clone();
        if (osd)
            synthetic::burnOsd(bgr, i);
        const cv::Mat luma = lumaOf(bgr);
        const cv::Mat &tracked = strokes.paint(luma, painted);
        if (i > 0)
            strokes.cameraMoved(flight.trueMotion(i), 1.0);
        if (i + 1 < flight.frameCount())
            continue;
        const cv::Mat pixels = osdPixels(options.width, options.height, i);
        // The OSD's edges (its filled boxes' insides are flat: nothing to paint there), and
        // the scene from 6 px off the OSD (its strokes' antialiased rims are taken with them).
        cv::Mat inside, edges, near, far;
        cv::erode(pixels, inside, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
        edges = pixels & ~inside;
        cv::dilate(pixels, near, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(13, 13)));
        cv::bitwise_not(near, far);
        const cv::Mat mask = strokes.mask().empty() ? cv::Mat::zeros(luma.size(), CV_8U) : strokes.mask();
        found.osd_found = double(cv::countNonZero(mask & edges)) / std::max(1, cv::countNonZero(edges));
        found.scene_taken = double(cv::countNonZero(mask & far)) / cv::countNonZero(far);
        cv::Mat clean = lumaOf(scene), e_painted, e_burnt;
        cv::absdiff(tracked, clean, e_painted);
        cv::absdiff(luma, clean, e_burnt);
        found.painted_error = cv::mean(e_painted, edges)[0];
        found.burnt_error = cv::mean(e_burnt, edges)[0];
    }
    return found;
}

} // namespace

TEST(OverlayStrokes, TheOsdIsFoundAndPaintedOverAndTheSceneIsNot)
{
    synthetic::FlightOptions options;  // 640x360, the default shake
    options.frames = 60;
    const Found f = fly(options, true);
    std::printf("OSD pixels found %.3f, scene pixels taken %.4f; |luma - scene| on the OSD %.1f -> %.1f\n",
                f.osd_found, f.scene_taken, f.burnt_error, f.painted_error);
    EXPECT_GT(f.osd_found, 0.9);  // the clock's digits change, and are left
    EXPECT_LT(f.scene_taken, 0.001);
    EXPECT_LT(f.painted_error, 0.2 * f.burnt_error);
}

TEST(OverlayStrokes, NothingIsTakenWithoutAnOverlay)
{
    synthetic::FlightOptions options;
    options.frames = 60;
    const Found f = fly(options, false);
    EXPECT_LT(f.scene_taken, 0.0005);
}

// Along a straight pan the scene's edges parallel to it stay the same too: no mask is made
// until the camera has moved across as well.
TEST(OverlayStrokes, AStraightPanMakesNoMask)
{
    synthetic::FlightOptions options;
    options.frames = 60;
    options.pan_speed = 4.0;
    options.rotation_amplitude_deg = 0.0;
    options.noise_px = options.band_px = 0.0;
    options.rotation_noise_deg = options.rotation_band_deg = 0.0;
    const Found f = fly(options, true);
    EXPECT_EQ(f.osd_found, 0.0);
    EXPECT_EQ(f.scene_taken, 0.0);
}
