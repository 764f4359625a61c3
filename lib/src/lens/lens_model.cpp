// OpenCV's fisheye and standard lens models, both ways. distort() is the models' closed
// form (as cv::fisheye::distortPoints and cv::projectPoints); undistort() inverts it by
// Newton's method, which converges to machine precision in a few steps where the model is
// monotonic (validate() checks that it is, out to the image's corners). OpenCV 4.6's
// cv::fisheye::undistortPoints is Newton too (the tests agree with it to 1e-11 px);
// cv::undistortPoints' fixed-point iteration, at its default 5 steps, is pixels off near
// the corners of a wide standard lens (the tests run it to convergence).
#include "uavstab/lens.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace uavstab {

namespace {

constexpr double kHalfPi = 1.57079632679489661923;
// Beyond this angle off the axis (radians) a fisheye point has no pinhole image worth
// the name (tan grows without bound): undistort() holds it there.
constexpr double kMaxFisheyeAngle = kHalfPi - 0.02;
constexpr int kNewtonSteps = 30;

// theta_d(theta) of the fisheye model and its derivative.
double fisheyeThetaD(const std::array<double, 5> &k, double t)
{
    const double t2 = t * t;
    return t * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}

double fisheyeThetaDSlope(const std::array<double, 5> &k, double t)
{
    const double t2 = t * t;
    return 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
}

// The standard model on normalized coordinates, and its Jacobian.
struct Distorted {
    double x, y;
    double j00, j01, j10, j11;
};

Distorted standardDistort(const std::array<double, 5> &c, double x, double y)
{
    const double k1 = c[0], k2 = c[1], p1 = c[2], p2 = c[3], k3 = c[4];
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double slope = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);  // d radial / d r2
    Distorted d;
    d.x = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    d.y = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    d.j00 = radial + 2.0 * x * x * slope + 2.0 * p1 * y + 6.0 * p2 * x;
    d.j01 = 2.0 * x * y * slope + 2.0 * p1 * x + 2.0 * p2 * y;
    d.j10 = 2.0 * x * y * slope + 2.0 * p1 * x + 2.0 * p2 * y;
    d.j11 = radial + 2.0 * y * y * slope + 6.0 * p1 * y + 2.0 * p2 * x;
    return d;
}

// The largest distance of the image's corners from the principal point, in normalized
// coordinates.
double cornerRadius(const LensModel &l)
{
    double r = 0.0;
    for (double px : {-0.5, l.width - 0.5})
        for (double py : {-0.5, l.height - 0.5})
            r = std::max(r, std::hypot((px - l.cx) / l.fx, (py - l.cy) / l.fy));
    return r;
}

[[noreturn]] void outOfRange(const std::string &field, const std::string &why)
{
    throw std::invalid_argument("lens " + field + ": " + why);
}

} // namespace

LensModel LensModel::scaledTo(int new_width, int new_height) const
{
    if (!active() || (new_width == width && new_height == height))
        return *this;
    if (new_width <= 0 || new_height <= 0 || width <= 0 || height <= 0)
        throw std::invalid_argument("lens: image size must be positive");
    const double aspect = double(width) / height, new_aspect = double(new_width) / new_height;
    if (std::abs(new_aspect / aspect - 1.0) > 0.01)
        throw std::invalid_argument("the lens is calibrated for " + std::to_string(width) + "x" +
                                    std::to_string(height) + ", another aspect ratio than the stream's " +
                                    std::to_string(new_width) + "x" + std::to_string(new_height));
    const double sx = double(new_width) / width, sy = double(new_height) / height;
    LensModel l = *this;
    l.fx = fx * sx;
    l.fy = fy * sy;
    // Pixel centres at integers: the image's edge, -0.5, stays the edge.
    l.cx = (cx + 0.5) * sx - 0.5;
    l.cy = (cy + 0.5) * sy - 0.5;
    l.width = new_width;
    l.height = new_height;
    return l;
}

Point2 LensModel::distort(Point2 u) const
{
    const double x = (u.x - cx) / fx, y = (u.y - cy) / fy;
    if (kind == LensKind::Fisheye) {
        // sqrt, not hypot: a warp's mesh distorts some 10 000 points a frame, hypot's guard
        // against overflow costs a third of that, and a pixel's normalized radius cannot overflow.
        const double r = std::sqrt(x * x + y * y);
        if (r < 1e-15)
            return u;
        const double s = fisheyeThetaD(coeffs, std::atan(r)) / r;
        return {fx * s * x + cx, fy * s * y + cy};
    }
    if (kind == LensKind::Standard) {
        const Distorted d = standardDistort(coeffs, x, y);
        return {fx * d.x + cx, fy * d.y + cy};
    }
    return u;
}

Point2 LensModel::undistort(Point2 p) const
{
    const double xd = (p.x - cx) / fx, yd = (p.y - cy) / fy;
    if (kind == LensKind::Fisheye) {
        const double td = std::hypot(xd, yd);
        if (td < 1e-15)
            return p;
        double t = std::min(td, kMaxFisheyeAngle);
        for (int i = 0; i < kNewtonSteps; ++i) {
            const double step = (fisheyeThetaD(coeffs, t) - td) / fisheyeThetaDSlope(coeffs, t);
            t = std::clamp(t - step, 0.0, kMaxFisheyeAngle);
            if (std::abs(step) < 1e-15)
                break;
        }
        const double s = std::tan(t) / td;
        return {fx * s * xd + cx, fy * s * yd + cy};
    }
    if (kind == LensKind::Standard) {
        double x = xd, y = yd;
        for (int i = 0; i < kNewtonSteps; ++i) {
            const Distorted d = standardDistort(coeffs, x, y);
            const double ex = d.x - xd, ey = d.y - yd;
            const double det = d.j00 * d.j11 - d.j01 * d.j10;
            if (!(std::abs(det) > 1e-300))
                break;
            const double sx = (d.j11 * ex - d.j01 * ey) / det, sy = (d.j00 * ey - d.j10 * ex) / det;
            x -= sx;
            y -= sy;
            if (std::abs(sx) + std::abs(sy) < 1e-15)
                break;
        }
        return {fx * x + cx, fy * y + cy};
    }
    return p;
}

void LensModel::validate() const
{
    if (!active())
        return;
    if (width <= 0 || height <= 0)
        outOfRange("calibration size", std::to_string(width) + "x" + std::to_string(height) + " is not positive");
    const char *names[2][5] = {{"k1", "k2", "k3", "k4", "(fifth coefficient)"}, {"k1", "k2", "p1", "p2", "k3"}};
    const auto &name = names[kind == LensKind::Standard ? 1 : 0];
    if (!(std::isfinite(fx) && fx > 0.0))
        outOfRange("camera matrix fx", std::to_string(fx) + " is not a positive focal length");
    if (!(std::isfinite(fy) && fy > 0.0))
        outOfRange("camera matrix fy", std::to_string(fy) + " is not a positive focal length");
    if (!(std::isfinite(cx) && cx >= -0.5 && cx <= width - 0.5))
        outOfRange("camera matrix cx", std::to_string(cx) + " is outside the image (0-" + std::to_string(width) + ")");
    if (!(std::isfinite(cy) && cy >= -0.5 && cy <= height - 0.5))
        outOfRange("camera matrix cy", std::to_string(cy) + " is outside the image (0-" + std::to_string(height) + ")");
    for (int i = 0; i < 5; ++i)
        if (!(std::isfinite(coeffs[i]) && std::abs(coeffs[i]) <= 100.0))
            outOfRange(std::string("distortion coefficient ") + name[i], std::to_string(coeffs[i]) + " is beyond +-100");
    if (kind == LensKind::Fisheye && coeffs[4] != 0.0)
        outOfRange("distortion coefficients", "the fisheye model has four");
    // One to one out to the corners: the distorted radius must grow with the undistorted one
    // until it reaches the corners'.
    const double corner = cornerRadius(*this);
    constexpr int kSteps = 4000;
    if (kind == LensKind::Fisheye) {
        for (int i = 0; i <= kSteps; ++i) {
            const double t = kMaxFisheyeAngle * i / kSteps;
            if (!(fisheyeThetaDSlope(coeffs, t) > 0.0))
                outOfRange("distortion coefficients", "the fisheye model folds back at " +
                                                          std::to_string(t * 180.0 / 3.14159265358979) +
                                                          " deg, inside the image");
            if (fisheyeThetaD(coeffs, t) >= corner)
                return;
        }
        outOfRange("distortion coefficients", "the image's corners lie beyond 90 deg off the axis");
    }
    // Standard: along the diagonal directions, which bound the corners.
    constexpr double kMaxRadius = 20.0;  // undistorted, normalized: 87 deg off the axis
    for (double dir : {0.0, 0.7853981633974483, 1.5707963267948966, 2.356194490192345, 3.141592653589793,
                       3.9269908169872414, 4.71238898038469, 5.497787143782138}) {
        double last = -1.0;
        bool reached = false;
        for (int i = 0; i <= kSteps && !reached; ++i) {
            const double r = kMaxRadius * i / kSteps;
            const Distorted d = standardDistort(coeffs, r * std::cos(dir), r * std::sin(dir));
            const double rd = std::hypot(d.x, d.y);
            if (!(rd > last))
                outOfRange("distortion coefficients", "the standard model folds back inside the image (at " +
                                                          std::to_string(r) + " focal lengths off the axis)");
            last = rd;
            reached = rd >= corner;
        }
        if (!reached)
            outOfRange("distortion coefficients", "the standard model does not reach the image's corners");
    }
}

} // namespace uavstab
