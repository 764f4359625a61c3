// The synthetic flight generator: the default (Lissajous) profile is unchanged, and the
// manoeuvre profile hovers where it should, reaches its speeds with piecewise constant
// acceleration, and stays on the canvas with the default jitter. Rolling shutter and
// vibration: off, nothing changes; on, each row has its pose and the frames wobble. A lens: none,
// nothing changes; a fisheye or wide-angle lens, the motion is a similarity in undistorted
// coordinates only and the canvas covers the undistorted view.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shaky_flight.hpp"
#include "truth_csv.hpp"
#include "wobble_metric.hpp"

using namespace uavstab;
using namespace uavstab::synthetic;

namespace {

constexpr double kPi = 3.14159265358979323846;

FlightOptions manoeuvre(int width, int height, std::uint32_t seed = 1)
{
    FlightOptions o;
    o.width = width;
    o.height = height;
    o.seed = seed;
    o.profile = FlightProfile::Manoeuvre;
    return o;
}

// Equal to 1e-12 relative: the values were recorded on x86-64; on aarch64 (the cross build,
// .ci/cross-aarch64.sh) the same code gives them to within ~1e-15 relative but not within
// EXPECT_DOUBLE_EQ's 4 ulps (other libm paths and contractions). Any change to the flight
// itself moves them by far more.
void expectNearlyEqual(double actual, double expected)
{
    EXPECT_NEAR(actual, expected, 1e-12 * std::max(1.0, std::abs(expected)));
}

void expectPose(const Similarity &p, double dx, double dy, double angle, double scale)
{
    expectNearlyEqual(p.dx, dx);
    expectNearlyEqual(p.dy, dy);
    expectNearlyEqual(p.angle, angle);
    expectNearlyEqual(p.scale, scale);
}

} // namespace

// Poses written by uavstab-render-flight (--truth, 17 digits) before the profiles existed.
TEST(ShakyFlight, DefaultProfileIsTheLissajousFlightAsBefore)
{
    FlightOptions o;
    EXPECT_EQ(o.profile, FlightProfile::Lissajous);
    const ShakyFlight a(o);
    expectPose(a.truePose(0), -5.1402691787976682, -73.852991186674672, 0.025853994128454631, 1);
    expectPose(a.intendedPose(0), -3.0525020481253242, -72.169101697710573, 0.025162453429745244, 1);
    expectPose(a.truePose(99), 127.89626981674458, 29.449149524321069, 0.018768412359298527, 1);
    expectPose(a.intendedPose(299), 91.743523514896467, 171.8104424717981, -0.0089610251656359018, 1);

    o.width = 1280;
    o.height = 720;
    o.frames = 60;
    o.seed = 3;
    o.moving_objects = 3;
    o.zoom_amplitude = 0.05;
    const ShakyFlight b(o);
    expectPose(b.truePose(0), 140.82249721990212, -290.70899007072381, 0.020512266682450042, 0.97890699650727009);
    expectPose(b.intendedPose(58), 212.89888027482803, -254.61058920410031, 0.034184004199681373, 0.95262493509857549);
}

TEST(ShakyFlight, ManoeuvreHoversAreStill)
{
    const ShakyFlight f(manoeuvre(640, 360));
    const double fps = f.options().fps;
    int checked = 0;
    for (const ManoeuvreSegment &s : manoeuvrePlan()) {
        if (std::string(s.name) != "hover")
            continue;
        for (int i = int(std::ceil(s.from * fps)); i + 1 <= int(std::floor(s.to * fps)) && i + 1 < f.frameCount(); ++i) {
            const Similarity a = f.intendedPose(i), b = f.intendedPose(i + 1);
            EXPECT_NEAR(b.dx - a.dx, 0.0, 1e-9) << "frame " << i;
            EXPECT_NEAR(b.dy - a.dy, 0.0, 1e-9) << "frame " << i;
            EXPECT_NEAR(b.angle - a.angle, 0.0, 1e-12) << "frame " << i;
            EXPECT_NEAR(b.scale - a.scale, 0.0, 1e-12) << "frame " << i;
            ++checked;
        }
    }
    EXPECT_GT(checked, 60);
    // The hover before the first pan starts at frame 0.
    EXPECT_EQ(manoeuvrePlan().front().from, 0.0);
}

TEST(ShakyFlight, ManoeuvreReachesItsSpeedsWithConstantAcceleration)
{
    const ShakyFlight f(manoeuvre(640, 360));
    ASSERT_EQ(f.manoeuvreShrink(), 1.0);  // nothing shrunk at 640x360
    const int n = f.frameCount();
    std::vector<double> speed(std::size_t(n), 0.0);
    for (int i = 1; i < n; ++i) {
        const Similarity a = f.intendedPose(i - 1), b = f.intendedPose(i);
        speed[std::size_t(i)] = std::hypot(b.dx - a.dx, b.dy - a.dy);
    }
    auto peak = [&](double from, double to) {
        double m = 0;
        for (int i = int(from * 30) + 1; i <= int(to * 30); ++i)
            m = std::max(m, speed[std::size_t(i)]);
        return m;
    };
    EXPECT_NEAR(peak(1.0, 3.5), 3.5, 1e-9);                                // first pan cruise
    EXPECT_NEAR(peak(5.7, 7.5), std::hypot(125.0, 50.0) / (1.4 * 30), 1e-9);  // second pan, ~3.2
    EXPECT_GT(peak(5.7, 7.5), 3.0);
    // First pan: cruising at 3.5 px/frame for 1.5 s, reached at 0.23 px/frame^2 (constant
    // acceleration: the speed grows by the same step each frame of the ramp).
    for (int i = 46; i <= 90; ++i)
        EXPECT_NEAR(speed[std::size_t(i)], 3.5, 1e-9) << "frame " << i;
    for (int i = 32; i <= 44; ++i)
        EXPECT_NEAR(speed[std::size_t(i + 1)] - speed[std::size_t(i)], 3.5 / 15, 1e-9) << "frame " << i;
    // No jumps anywhere: the speed changes by at most one ramp step per frame (the second
    // pan's ramps are the steepest: 3.2 px/frame in 12 frames).
    for (int i = 2; i < n; ++i)
        EXPECT_LE(std::abs(speed[std::size_t(i)] - speed[std::size_t(i) - 1]), 0.27) << "frame " << i;
    // Turn and climb arrive where planned and stay there.
    const Similarity end = f.intendedPose(n - 1);
    EXPECT_NEAR(end.angle, 25.0 * kPi / 180, 1e-12);
    EXPECT_NEAR(end.scale, 1.12, 1e-12);
    EXPECT_NEAR(end.dx, -105.0 + 210.0 - 125.0, 1e-9);
    EXPECT_NEAR(end.dy, 30.0 - 50.0, 1e-9);
    // The yaw turns smoothly: no more than ~1 degree per frame.
    for (int i = 1; i < n; ++i)
        EXPECT_LE(std::abs(f.intendedPose(i).angle - f.intendedPose(i - 1).angle), 1.0 * kPi / 180);
}

TEST(ShakyFlight, ManoeuvreHasTheSameShakeAsTheDefaultProfile)
{
    FlightOptions o;
    o.seed = 4;
    const ShakyFlight lissajous(o);
    o.profile = FlightProfile::Manoeuvre;
    const ShakyFlight flight(o);
    for (int i : {0, 17, 150, 299}) {
        const Similarity a = lissajous.intendedPose(i).inverse() * lissajous.truePose(i);
        const Similarity b = flight.intendedPose(i).inverse() * flight.truePose(i);
        EXPECT_NEAR(a.dx, b.dx, 1e-9);
        EXPECT_NEAR(a.dy, b.dy, 1e-9);
        EXPECT_NEAR(a.angle, b.angle, 1e-12);
        EXPECT_NEAR(b.scale, 1.0, 1e-12);
    }
}

TEST(ShakyFlight, ManoeuvreStaysOnTheCanvas)
{
    struct Size {
        int w, h;
        bool unshrunk;
    };
    for (const Size s : {Size{640, 360, true}, Size{1280, 720, true}, Size{480, 480, false}}) {
        for (std::uint32_t seed : {1u, 2u, 3u}) {
            const ShakyFlight f(manoeuvre(s.w, s.h, seed));
            if (s.unshrunk) {
                EXPECT_EQ(f.manoeuvreShrink(), 1.0) << s.w << "x" << s.h;
            } else {
                EXPECT_LT(f.manoeuvreShrink(), 1.0) << s.w << "x" << s.h;
            }
            const double cx = (f.canvasSize().width - 1) * 0.5, cy = (f.canvasSize().height - 1) * 0.5;
            const double hx = (s.w - 1) * 0.5, hy = (s.h - 1) * 0.5;
            double closest = 1e9;  // canvas px between a corner and the canvas edge
            for (int i = 0; i < f.frameCount(); ++i)
                for (const Point2 c : {Point2{-hx, -hy}, Point2{hx, -hy}, Point2{-hx, hy}, Point2{hx, hy}}) {
                    const Point2 p = f.worldToCanvas().apply(f.truePose(i).apply(c));
                    closest = std::min({closest, cx - std::abs(p.x), cy - std::abs(p.y)});
                }
            EXPECT_GE(closest, 0.0) << s.w << "x" << s.h << " seed " << seed;
            std::printf("%dx%d seed %u: shrink %.3f, closest corner %.1f canvas px from the edge\n", s.w, s.h, seed,
                        f.manoeuvreShrink(), closest);
        }
    }
}

namespace {

FlightOptions vibrating(double readout)
{
    FlightOptions o;
    o.readout = readout;
    o.vibration_hz = 47.0;
    o.vibration_px = 2.0;
    o.vibration_deg = 0.1;
    return o;
}

cv::Mat luma(const cv::Mat &bgr)
{
    cv::Mat grey;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    return grey;
}

double meanWobbleOfFlight(const ShakyFlight &f, int frames)
{
    WobbleMeter meter;
    for (int i = 0; i < frames; ++i)
        meter.add(f.renderBgr(i));
    EXPECT_EQ(meter.pairs(), frames - 1);
    return meter.mean();
}

} // namespace

// Without a rolling shutter or vibration the frames are the single warp they always were:
// the canvas warped once with truePose(i), as renderBgr did before rows had poses.
TEST(ShakyFlight, GlobalShutterRendersAsBefore)
{
    FlightOptions o;
    o.frames = 30;
    o.vibration_hz = 47.0;  // no amplitude: no vibration, nothing drawn
    const ShakyFlight f(o);
    const cv::Mat canvas = cv::imread(defaultCanvasPath(), cv::IMREAD_COLOR);
    ASSERT_FALSE(canvas.empty());
    const double ccx = (canvas.cols - 1) * 0.5, ccy = (canvas.rows - 1) * 0.5;
    const double cx = (o.width - 1) * 0.5, cy = (o.height - 1) * 0.5;
    for (int i : {0, 13, 29}) {
        const Similarity world_to_canvas{ccx, ccy, 0.0, f.worldToCanvas().scale};
        const auto m = (world_to_canvas * f.truePose(i)).pixelMatrix(o.width, o.height);
        double matrix[6] = {m[0], m[1], m[2] - cx, m[3], m[4], m[5] - cy};
        cv::Mat expected;
        cv::warpAffine(canvas, expected, cv::Mat(2, 3, CV_64F, matrix), cv::Size(o.width, o.height),
                       cv::INTER_CUBIC | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT_101);
        const cv::Mat rendered = f.renderBgr(i);
        ASSERT_EQ(rendered.size(), expected.size());
        EXPECT_EQ(cv::norm(rendered, expected, cv::NORM_INF), 0.0) << "frame " << i;
    }
    // The poses are those of a flight that never heard of vibration.
    FlightOptions without;
    without.frames = o.frames;
    const ShakyFlight plain(without);
    for (int i : {0, 13, 29}) {
        const Similarity a = f.truePose(i), b = plain.truePose(i);
        EXPECT_EQ(a.dx, b.dx);
        EXPECT_EQ(a.dy, b.dy);
        EXPECT_EQ(a.angle, b.angle);
        EXPECT_EQ(a.scale, b.scale);
    }
}

TEST(ShakyFlight, VibrationLeavesTheOtherDrawsAlone)
{
    const ShakyFlight plain{FlightOptions{}};
    const ShakyFlight shaken(vibrating(0.0));
    double largest = 0.0;
    for (int i = 0; i < plain.frameCount(); ++i) {
        const Similarity a = plain.intendedPose(i), b = shaken.intendedPose(i);
        EXPECT_EQ(a.dx, b.dx);
        EXPECT_EQ(a.dy, b.dy);
        EXPECT_EQ(a.angle, b.angle);
        // The shake differs by the vibration only: a few px, never more.
        const Similarity d = plain.truePose(i).inverse() * shaken.truePose(i);
        largest = std::max(largest, std::hypot(d.dx, d.dy));
    }
    EXPECT_GT(largest, 2.0);
    EXPECT_LT(largest, 12.0);
}

TEST(ShakyFlight, RollingShutterGivesEachRowItsPose)
{
    const ShakyFlight f(vibrating(0.8));
    const ShakyFlight global(vibrating(0.0));
    const double middle = (f.options().height - 1) * 0.5, bottom = f.options().height - 1;
    double top_offset = 0.0, bottom_offset = 0.0;
    for (int i : {0, 1, 57, 150, 299}) {
        const Similarity mid = f.truePoseAtRow(i, middle), pose = f.truePose(i);
        EXPECT_EQ(mid.dx, pose.dx) << "frame " << i;
        EXPECT_EQ(mid.dy, pose.dy) << "frame " << i;
        EXPECT_EQ(mid.angle, pose.angle) << "frame " << i;
        EXPECT_EQ(mid.scale, pose.scale) << "frame " << i;
        // The readout moves the rows in time, not the camera's path.
        const Similarity g = global.truePose(i);
        EXPECT_EQ(pose.dx, g.dx);
        EXPECT_EQ(pose.angle, g.angle);
        EXPECT_DOUBLE_EQ(f.rowTime(i, 0), i - 0.4);
        EXPECT_DOUBLE_EQ(f.rowTime(i, bottom), i + 0.4);
        const Similarity top_pose = f.truePoseAtRow(i, 0), bottom_pose = f.truePoseAtRow(i, bottom);
        top_offset = std::max(top_offset, std::hypot(top_pose.dx - pose.dx, top_pose.dy - pose.dy));
        bottom_offset = std::max(bottom_offset, std::hypot(bottom_pose.dx - pose.dx, bottom_pose.dy - pose.dy));
        // The pose is continuous in time, across frame boundaries too (the white noise is
        // interpolated, not held).
        for (double t : {i + 1e-7, i + 0.5, i + 1.0 - 1e-7}) {
            const Similarity p = f.truePoseAt(t), q = f.truePoseAt(t + 1e-7);
            EXPECT_LT(std::hypot(p.dx - q.dx, p.dy - q.dy), 1e-4) << "time " << t;
        }
    }
    EXPECT_GT(top_offset, 1.0);
    EXPECT_GT(bottom_offset, 1.0);
    // Between frames the white noise is interpolated: halfway, half of each frame's draw.
    FlightOptions quiet;
    quiet.band_px = 0.0;
    quiet.rotation_band_deg = 0.0;
    const ShakyFlight noise_only(quiet);
    const Similarity a = noise_only.intendedPoseAt(10.5).inverse() * noise_only.truePoseAt(10.5);
    const Similarity b = noise_only.intendedPose(10).inverse() * noise_only.truePose(10);
    const Similarity c = noise_only.intendedPose(11).inverse() * noise_only.truePose(11);
    EXPECT_NEAR(a.angle, 0.5 * (b.angle + c.angle), 1e-12);
}

TEST(ShakyFlight, RollingShutterStaysOnTheCanvas)
{
    for (std::uint32_t seed : {1u, 2u, 3u}) {
        FlightOptions o = vibrating(0.8);
        o.seed = seed;
        const ShakyFlight f(o);
        const double cx = (f.canvasSize().width - 1) * 0.5, cy = (f.canvasSize().height - 1) * 0.5;
        const double hx = (o.width - 1) * 0.5, hy = (o.height - 1) * 0.5;
        double closest = 1e9;
        for (int i = 0; i < f.frameCount(); ++i)
            for (const Point2 c : {Point2{-hx, -hy}, Point2{hx, -hy}, Point2{-hx, hy}, Point2{hx, hy}}) {
                const Point2 p = f.worldToCanvas().apply(f.truePoseAtRow(i, c.y + hy).apply(c));
                closest = std::min({closest, cx - std::abs(p.x), cy - std::abs(p.y)});
            }
        EXPECT_GE(closest, 0.0) << "seed " << seed;
    }
}

// The jello the rolling shutter makes of the vibration is what the wobble metric measures;
// with a global shutter the same vibration only moves whole frames.
TEST(ShakyFlight, RollingShutterWobbles)
{
    FlightOptions o = vibrating(0.8);
    o.frames = 12;
    const double rolling = meanWobbleOfFlight(ShakyFlight(o), o.frames);
    o.readout = 0.0;
    const double global = meanWobbleOfFlight(ShakyFlight(o), o.frames);
    std::printf("wobble at 640x360, 47 Hz 2 px 0.1 deg: readout 0.8 %.3f px, global shutter %.3f px\n", rolling,
                global);
    EXPECT_GT(rolling, 0.5);
    EXPECT_LT(global, 0.1);
    // One frame pair, measured directly, agrees.
    const ShakyFlight f(vibrating(0.8));
    EXPECT_GT(wobble(luma(f.renderBgr(3)), luma(f.renderBgr(4))), 0.5);
}

namespace {

FlightOptions throughLens(const LensModel &lens, std::uint32_t seed = 1)
{
    FlightOptions o;
    o.seed = seed;
    o.lens = lens;
    return o;
}

Point2 centredOf(const ShakyFlight &f, Point2 pinhole)
{
    return {pinhole.x - (f.options().width - 1) * 0.5, pinhole.y - (f.options().height - 1) * 0.5};
}

Point2 pinholeOf(const ShakyFlight &f, Point2 centred)
{
    return {centred.x + (f.options().width - 1) * 0.5, centred.y + (f.options().height - 1) * 0.5};
}

// Where world point `world` appears in frame i (global shutter): through the pose, then the lens.
Point2 imageOf(const ShakyFlight &f, int i, Point2 world)
{
    return f.options().lens.distort(pinholeOf(f, f.truePose(i).inverse().apply(world)));
}

Point2 worldOf(const ShakyFlight &f, int i, Point2 image)
{
    return f.truePose(i).apply(centredOf(f, f.options().lens.undistort(image)));
}

// The least-squares similarity a -> b (x' = s x - t y + tx, y' = t x + s y + ty) applied to a.
std::vector<Point2> fitSimilarity(const std::vector<Point2> &a, const std::vector<Point2> &b)
{
    const double n = double(a.size());
    Point2 ma{0, 0}, mb{0, 0};
    for (std::size_t k = 0; k < a.size(); ++k) {
        ma = {ma.x + a[k].x / n, ma.y + a[k].y / n};
        mb = {mb.x + b[k].x / n, mb.y + b[k].y / n};
    }
    double sxx = 0, sc = 0, ss = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
        const double ax = a[k].x - ma.x, ay = a[k].y - ma.y, bx = b[k].x - mb.x, by = b[k].y - mb.y;
        sxx += ax * ax + ay * ay;
        sc += ax * bx + ay * by;
        ss += ax * by - ay * bx;
    }
    const double s = sc / sxx, t = ss / sxx;
    std::vector<Point2> fitted;
    for (const Point2 p : a) {
        const double ax = p.x - ma.x, ay = p.y - ma.y;
        fitted.push_back({s * ax - t * ay + mb.x, t * ax + s * ay + mb.y});
    }
    return fitted;
}

// The largest residual of that fit, px.
double similarityFitResidual(const std::vector<Point2> &a, const std::vector<Point2> &b)
{
    const std::vector<Point2> fitted = fitSimilarity(a, b);
    double worst = 0;
    for (std::size_t k = 0; k < a.size(); ++k)
        worst = std::max(worst, std::hypot(fitted[k].x - b[k].x, fitted[k].y - b[k].y));
    return worst;
}

std::vector<Point2> pixelGrid(int width, int height, int steps)
{
    std::vector<Point2> grid;
    for (int gy = 0; gy <= steps; ++gy)
        for (int gx = 0; gx <= steps; ++gx)
            grid.push_back({double(gx * (width - 1) / steps), double(gy * (height - 1) / steps)});
    return grid;
}

// The canvas sampled at one position as the renderer samples it (bicubic, float map).
cv::Vec3b sampleCanvas(const cv::Mat &canvas, Point2 p)
{
    cv::Mat mx(1, 1, CV_32F, cv::Scalar(float(p.x))), my(1, 1, CV_32F, cv::Scalar(float(p.y))), out;
    cv::remap(canvas, out, mx, my, cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
    return out.at<cv::Vec3b>(0, 0);
}

// Bilinear luma at a sub-pixel position.
double lumaAt(const cv::Mat &grey, Point2 p)
{
    cv::Mat patch;
    cv::getRectSubPix(grey, cv::Size(1, 1), cv::Point2f(float(p.x), float(p.y)), patch, CV_32F);
    return patch.at<float>(0, 0);
}

} // namespace

TEST(ShakyFlightLens, ReadyMadeLensesHaveTheirFieldOfView)
{
    for (const cv::Size s : {cv::Size(640, 360), cv::Size(1280, 720), cv::Size(640, 480)}) {
        const LensModel fisheye = fisheyeLens(s.width, s.height), wide = wideAngleLens(s.width, s.height);
        EXPECT_NO_THROW(fisheye.validate());
        EXPECT_NO_THROW(wide.validate());
        EXPECT_EQ(fisheye.kind, LensKind::Fisheye);
        EXPECT_EQ(wide.kind, LensKind::Standard);
        // The angle off the axis of a corner's outer edge: half the diagonal field of view.
        for (const auto &[lens, half_fov] : {std::pair{fisheye, 75.0}, std::pair{wide, 55.0}}) {
            const Point2 corner = lens.undistort({-0.5, -0.5});
            const double r = std::hypot(corner.x - lens.cx, corner.y - lens.cy) / lens.fx;
            EXPECT_NEAR(std::atan(r) * 180 / kPi, half_fov, 1e-6) << s.width << "x" << s.height;
        }
    }
    // Another size of the same aspect ratio is the same lens scaled.
    const LensModel a = fisheyeLens(1280, 720), b = fisheyeLens(640, 360).scaledTo(1280, 720);
    EXPECT_NEAR(a.fx, b.fx, 1e-9);
    EXPECT_NEAR(a.cx, b.cx, 1e-9);
}

// No lens (the default): the frames are byte for byte the pinhole renders, whatever the
// unused lens fields hold, with and without a rolling shutter.
TEST(ShakyFlightLens, NoLensRendersThePinholeView)
{
    EXPECT_EQ(FlightOptions{}.lens.kind, LensKind::None);
    for (double readout : {0.0, 0.8}) {
        FlightOptions plain = vibrating(readout);
        plain.frames = 20;
        plain.moving_objects = 1;
        FlightOptions unused = plain;
        unused.lens = fisheyeLens(320, 240);
        unused.lens.kind = LensKind::None;
        const ShakyFlight a(plain), b(unused);
        EXPECT_EQ(a.worldToCanvas().scale, b.worldToCanvas().scale);
        EXPECT_EQ(b.undistortedFootprint().width, plain.width);
        EXPECT_EQ(b.undistortedFootprint().height, plain.height);
        for (int i : {0, 7, 19}) {
            const cv::Mat x = a.renderBgr(i), y = b.renderBgr(i);
            ASSERT_EQ(x.size(), y.size());
            EXPECT_EQ(cv::norm(x, y, cv::NORM_INF), 0.0) << "readout " << readout << " frame " << i;
        }
    }
}

// Every rendered pixel is the canvas where the pose puts its undistorted position; with a
// rolling shutter the pose of its own (distorted, sensor) row.
TEST(ShakyFlightLens, PixelsShowTheWorldAtTheirUndistortedPosition)
{
    const cv::Mat canvas = cv::imread(defaultCanvasPath(), cv::IMREAD_COLOR);
    ASSERT_FALSE(canvas.empty());
    for (double readout : {0.0, 0.8}) {
        FlightOptions o = vibrating(readout);
        o.frames = 40;
        o.lens = fisheyeLens(o.width, o.height);
        const ShakyFlight f(o);
        const Point2 centre{(canvas.cols - 1) * 0.5, (canvas.rows - 1) * 0.5};
        int differing = 0, checked = 0;
        for (int i : {3, 31}) {
            const cv::Mat frame = f.renderBgr(i);
            for (const Point2 q : pixelGrid(o.width, o.height, 24)) {
                const Point2 world = f.truePoseAtRow(i, q.y).apply(centredOf(f, f.options().lens.undistort(q)));
                const Point2 expected = f.worldToCanvas().apply(world);
                const Point2 at = f.canvasPosition(i, q);
                ASSERT_NEAR(at.x, expected.x + centre.x, 1e-6);
                ASSERT_NEAR(at.y, expected.y + centre.y, 1e-6);
                const cv::Vec3b want = sampleCanvas(canvas, at);
                const cv::Vec3b got = frame.at<cv::Vec3b>(int(q.y), int(q.x));
                // The renderer's float map may round a coordinate the other way: 1 level.
                for (int ch = 0; ch < 3; ++ch)
                    differing += std::abs(int(want[ch]) - int(got[ch])) > 1;
                ++checked;
            }
        }
        EXPECT_EQ(differing, 0) << "readout " << readout << ", of " << checked << " pixels";
    }
}

// Through the fisheye (and the wide-angle lens): a world point seen at pixel q of frame j is
// where pose and lens put it in frame i, and the motion between frames is a similarity in
// undistorted coordinates but not in image pixels.
TEST(ShakyFlightLens, FisheyeMotionIsASimilarityOnlyWhenUndistorted)
{
    for (const bool fisheye : {true, false}) {
        const ShakyFlight f(throughLens(fisheye ? fisheyeLens(640, 360) : wideAngleLens(640, 360)));
        const LensModel &lens = f.options().lens;
        const std::vector<Point2> grid = pixelGrid(640, 360, 16);
        double worst_undistorted = 0, worst_distorted_1 = 0, worst_distorted_10 = 0;
        for (int i : {20, 100, 200}) {
            for (int gap : {1, 10}) {
                const int j = i + gap;
                // Frame j -> frame i: trueMotion's convention, composed over the gap.
                const Similarity motion = f.truePose(i).inverse() * f.truePose(j);
                std::vector<Point2> from, to, from_u, to_u;
                for (const Point2 q : grid) {
                    const Point2 u = centredOf(f, lens.undistort(q));
                    const Point2 v = motion.apply(u);
                    from.push_back(q);
                    to.push_back(lens.distort(pinholeOf(f, v)));
                    from_u.push_back(u);
                    to_u.push_back(v);
                    // The same point reached through the world.
                    const Point2 through_world = imageOf(f, i, worldOf(f, j, q));
                    EXPECT_NEAR(through_world.x, to.back().x, 1e-6);
                    EXPECT_NEAR(through_world.y, to.back().y, 1e-6);
                }
                if (gap == 1) {
                    const Similarity m = f.trueMotion(j);
                    EXPECT_NEAR(m.dx, motion.dx, 1e-9);
                    EXPECT_NEAR(m.dy, motion.dy, 1e-9);
                    EXPECT_NEAR(m.angle, motion.angle, 1e-12);
                }
                worst_undistorted = std::max(worst_undistorted, similarityFitResidual(from_u, to_u));
                double &worst_distorted = gap == 1 ? worst_distorted_1 : worst_distorted_10;
                worst_distorted = std::max(worst_distorted, similarityFitResidual(from, to));
            }
        }
        std::printf("%s 640x360: similarity fit residual, largest over a 17x17 grid: undistorted %.2g px; "
                    "image pixels %.2f px (consecutive frames), %.2f px (10 frames apart)\n",
                    fisheye ? "fisheye" : "wide-angle", worst_undistorted, worst_distorted_1, worst_distorted_10);
        EXPECT_LT(worst_undistorted, 1e-9);
        if (fisheye) {
            EXPECT_GT(worst_distorted_1, 1.5);
            EXPECT_GT(worst_distorted_10, 6.0);
        }
    }
}

// The picture agrees: a textured pixel of frame i reappears where pose and lens predict it ten
// frames later, and not where a similarity fitted in image pixels would put it.
TEST(ShakyFlightLens, FisheyePictureMovesAsPredicted)
{
    const ShakyFlight f(throughLens(fisheyeLens(640, 360)));
    const std::vector<Point2> grid = pixelGrid(640, 360, 40);
    double lens_error = 0, similarity_error = 0;
    int points = 0;
    for (int i : {30, 150}) {
        const int gap = 10, j = i + gap;
        const cv::Mat a = luma(f.renderBgr(i)), b = luma(f.renderBgr(j));
        // Points of frame i, predicted in frame j through the world, and the similarity that
        // best maps the one onto the other in image pixels.
        std::vector<Point2> from, to;
        for (const Point2 q : grid) {
            from.push_back(q);
            to.push_back(imageOf(f, j, worldOf(f, i, q)));
        }
        const std::vector<Point2> fitted = fitSimilarity(from, to);
        for (std::size_t k = 0; k < from.size(); ++k) {
            const Point2 fit = fitted[k];
            // Only points that stay inside frame j, away from the edge.
            auto inside = [](Point2 p) { return p.x >= 2 && p.y >= 2 && p.x <= 637 && p.y <= 357; };
            if (!inside(to[k]) || !inside(fit))
                continue;
            const double seen = a.at<std::uint8_t>(int(from[k].y), int(from[k].x));
            lens_error += std::abs(lumaAt(b, to[k]) - seen);
            similarity_error += std::abs(lumaAt(b, fit) - seen);
            ++points;
        }
    }
    lens_error /= points;
    similarity_error /= points;
    std::printf("fisheye picture, frames 10 apart, %d points: mean |luma difference| at the predicted position %.2f, "
                "at the similarity fit's %.2f\n",
                points, lens_error, similarity_error);
    EXPECT_GT(points, 1000);
    EXPECT_LT(lens_error, 3.0);
    EXPECT_GT(similarity_error, 2 * lens_error);
}

// The canvas covers the whole undistorted view: no pixel of any frame is sampled outside the
// photograph (bicubic: one pixel in from the edge on either side), for the fisheye and the
// wide-angle lens, both profiles, with a rolling shutter too. With one pose per frame the
// frame's outline bounds what it samples (pose and lens map the frame one to one).
TEST(ShakyFlightLens, LensFlightsStayOnTheCanvas)
{
    struct Case {
        const char *name;
        FlightOptions options;
    };
    std::vector<Case> cases;
    for (std::uint32_t seed : {1u, 2u, 3u}) {
        cases.push_back({"fisheye", throughLens(fisheyeLens(640, 360), seed)});
        cases.push_back({"wide", throughLens(wideAngleLens(640, 360), seed)});
    }
    FlightOptions m = throughLens(fisheyeLens(640, 360));
    m.profile = FlightProfile::Manoeuvre;
    cases.push_back({"fisheye manoeuvre", m});
    FlightOptions rs = vibrating(0.8);
    rs.lens = fisheyeLens(640, 360);
    cases.push_back({"fisheye rolling shutter", rs});
    FlightOptions hd = throughLens(fisheyeLens(640, 360));  // scaled to the frame
    hd.width = 1280;
    hd.height = 720;
    cases.push_back({"fisheye 1280x720", hd});

    for (const Case &c : cases) {
        const ShakyFlight f(c.options);
        const int w = c.options.width, h = c.options.height;
        std::vector<Point2> outline;
        for (int x = 0; x < w; ++x) {
            outline.push_back({double(x), 0.0});
            outline.push_back({double(x), double(h - 1)});
        }
        for (int y = 0; y < h; ++y) {
            outline.push_back({0.0, double(y)});
            outline.push_back({double(w - 1), double(y)});
        }
        const double cols = f.canvasSize().width, rows = f.canvasSize().height;
        auto inside = [&](Point2 p) { return std::min({p.x - 1, p.y - 1, cols - 3 - p.x, rows - 3 - p.y}); };
        double closest = 1e9;  // canvas px between a sampled position and the canvas edge
        int closest_frame = 0;
        for (int i = 0; i < f.frameCount(); ++i)
            for (const Point2 q : outline)
                if (const double d = inside(f.canvasPosition(i, q)); d < closest) {
                    closest = d;
                    closest_frame = i;
                }
        EXPECT_GE(closest, 0.0) << c.name << " seed " << c.options.seed;
        // In the frame that comes closest, every pixel (with a rolling shutter the rows' poses
        // differ, so the outline alone is not a proof).
        double closest_pixel = 1e9;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                closest_pixel =
                    std::min(closest_pixel, inside(f.canvasPosition(closest_frame, {double(x), double(y)})));
        EXPECT_GE(closest_pixel, closest - 1e-9) << c.name << " frame " << closest_frame;
        std::printf("%s %dx%d seed %u: view %.0fx%.0f pinhole px, %.3f canvas px per pinhole px, closest sample "
                    "%.1f canvas px inside\n",
                    c.name, w, h, c.options.seed, f.undistortedFootprint().width, f.undistortedFootprint().height,
                    f.worldToCanvas().scale, closest);
    }
}

// uavstab-render-flight --lens-out: the calibration beside the clip reads back as the lens.
TEST(ShakyFlightLens, CalibrationFileReadsBack)
{
    for (const LensModel &lens : {fisheyeLens(640, 360), wideAngleLens(1280, 720)}) {
        for (const char *extension : {".yml", ".json"}) {
            const std::string path = ::testing::TempDir() + "shaky_flight_lens" + extension;
            writeLensCalibration(path, lens);
            const LensProfile read = readLensProfile(path);
            std::remove(path.c_str());
            EXPECT_EQ(read.lens.kind, lens.kind) << extension;
            EXPECT_EQ(read.lens.width, lens.width);
            EXPECT_EQ(read.lens.height, lens.height);
            EXPECT_DOUBLE_EQ(read.lens.fx, lens.fx);
            EXPECT_DOUBLE_EQ(read.lens.fy, lens.fy);
            EXPECT_DOUBLE_EQ(read.lens.cx, lens.cx);
            EXPECT_DOUBLE_EQ(read.lens.cy, lens.cy);
            for (std::size_t k = 0; k < 5; ++k)
                EXPECT_DOUBLE_EQ(read.lens.coeffs[k], lens.coeffs[k]) << "coefficient " << k;
        }
    }
    EXPECT_THROW(writeLensCalibration(::testing::TempDir() + "none.yml", LensModel{}), std::invalid_argument);
    EXPECT_THROW(fisheyeLens(640, 360, 180.0), std::invalid_argument);
}
