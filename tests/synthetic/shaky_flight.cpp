#include "shaky_flight.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>

#include "format_conversion.hpp"

#ifndef UAVSTAB_DATA_DIR
#error "UAVSTAB_DATA_DIR must point at tests/data"
#endif

namespace uavstab::synthetic {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kBandWaves = 8;
// Propeller vibration: a few sinusoids within +-2 % of the nominal frequency (the motors do
// not turn at exactly the same speed), so that the vibration beats slowly as on a real UAV.
constexpr int kVibrationWaves = 3;
constexpr double kVibrationSpread = 0.02;
// Share of the canvas the camera footprint spans at base altitude.
constexpr double kFootprint = 0.62;

double radians(double deg)
{
    return deg * kPi / 180.0;
}

// Where the manoeuvre flight starts (world px about the canvas centre, for 640x360).
constexpr double kManoeuvreStartX = -105.0, kManoeuvreStartY = 30.0;

// Share of a move done at time t of a segment lasting `length` with ramps of `ramp` at
// both ends: trapezoidal velocity, i.e. constant acceleration, cruise, constant deceleration.
double trapezoid(double t, double length, double ramp)
{
    if (t <= 0)
        return 0.0;
    if (t >= length)
        return 1.0;
    ramp = std::min(ramp, 0.5 * length);
    if (ramp <= 0)
        return t / length;
    const double v = 1.0 / (length - ramp);  // cruise speed, share per second
    if (t < ramp)
        return 0.5 * v / ramp * t * t;
    if (t <= length - ramp)
        return v * (t - 0.5 * ramp);
    const double u = length - t;
    return 1.0 - 0.5 * v / ramp * u * u;
}

} // namespace

const char *toString(FlightProfile p)
{
    switch (p) {
    case FlightProfile::Lissajous:
        return "lissajous";
    case FlightProfile::Manoeuvre:
        return "manoeuvre";
    }
    return "?";
}

const std::vector<ManoeuvreSegment> &manoeuvrePlan()
{
    // 300 frames at 30 fps. Pan 1: 210 px in 2.5 s with 0.5 s ramps = 3.5 px/frame cruise,
    // 0.23 px/frame^2. Yaw: 25 deg in 1.3 s with 0.4 s ramps (peak 0.93 deg/frame). Pan 2: (-125, -50) px in
    // 1.8 s with 0.4 s ramps = 3.2 px/frame. Climb: scale x1.12 in 1.3 s.
    static const std::vector<ManoeuvreSegment> plan{
        {"hover", 0.0, 1.0, 0.0, {}},
        {"pan", 1.0, 3.5, 0.5, {210.0, 0.0, 0.0, 1.0}},
        {"hover", 3.5, 4.2, 0.0, {}},
        {"yaw", 4.2, 5.5, 0.4, {0.0, 0.0, radians(25.0), 1.0}},
        {"hover", 5.5, 5.7, 0.0, {}},
        {"pan", 5.7, 7.5, 0.4, {-125.0, -50.0, 0.0, 1.0}},
        {"hover", 7.5, 8.2, 0.0, {}},
        {"climb", 8.2, 9.5, 0.45, {0.0, 0.0, 0.0, 1.12}},
        {"hover", 9.5, 10.0, 0.0, {}},
    };
    return plan;
}

std::string defaultCanvasPath()
{
    return std::string(UAVSTAB_DATA_DIR) + "/aero1.jpg";
}

namespace {

// Half the frame's diagonal, from the centre to a corner's outer edge.
double halfDiagonal(int width, int height)
{
    return 0.5 * std::hypot(double(width), double(height));
}

void checkFieldOfView(double diagonal_fov_deg)
{
    if (!(diagonal_fov_deg > 0.0 && diagonal_fov_deg < 180.0))
        throw std::invalid_argument("lens: the diagonal field of view must be between 0 and 180 degrees");
}

LensModel centredLens(LensKind kind, int width, int height, double focal, const std::array<double, 5> &coeffs)
{
    LensModel lens;
    lens.kind = kind;
    lens.fx = lens.fy = focal;
    lens.cx = (width - 1) * 0.5;
    lens.cy = (height - 1) * 0.5;
    lens.coeffs = coeffs;
    lens.width = width;
    lens.height = height;
    lens.validate();
    return lens;
}

} // namespace

LensModel fisheyeLens(int width, int height, double diagonal_fov_deg)
{
    checkFieldOfView(diagonal_fov_deg);
    const std::array<double, 5> k{0.05, 0.01, -0.01, 0.005, 0.0};
    const double theta = radians(0.5 * diagonal_fov_deg), t2 = theta * theta;
    const double theta_d = theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
    return centredLens(LensKind::Fisheye, width, height, halfDiagonal(width, height) / theta_d, k);
}

LensModel wideAngleLens(int width, int height, double diagonal_fov_deg)
{
    checkFieldOfView(diagonal_fov_deg);
    const std::array<double, 5> k{-0.25, 0.07, 0.0, 0.0, 0.0};
    const double r = std::tan(radians(0.5 * diagonal_fov_deg)), r2 = r * r;
    const double r_d = r * (1.0 + r2 * (k[0] + r2 * k[1]));
    return centredLens(LensKind::Standard, width, height, halfDiagonal(width, height) / r_d, k);
}

ShakyFlight::ShakyFlight(const FlightOptions &options)
    : options_(options)
{
    if (options_.width < 2 || options_.height < 2 || options_.frames < 0 || options_.fps <= 0)
        throw std::invalid_argument("ShakyFlight: bad size, frame count or fps");
    const std::string path = options_.canvas.empty() ? defaultCanvasPath() : options_.canvas;
    canvas_ = cv::imread(path, cv::IMREAD_COLOR);
    if (canvas_.empty())
        throw std::runtime_error("ShakyFlight: cannot read canvas " + path);

    // The view's extent in pinhole pixels: with a lens, the bounding box of the undistorted
    // frame (its pixels' outer edges), which for a fisheye is several times the frame.
    footprint_ = cv::Size2d(options_.width, options_.height);
    if (options_.lens.active()) {
        options_.lens = options_.lens.scaledTo(options_.width, options_.height);
        options_.lens.validate();
        const double cx = (options_.width - 1) * 0.5, cy = (options_.height - 1) * 0.5;
        double half_w = 0.0, half_h = 0.0;
        auto extend = [&](double x, double y) {
            const Point2 u = options_.lens.undistort({x, y});
            half_w = std::max(half_w, std::abs(u.x - cx));
            half_h = std::max(half_h, std::abs(u.y - cy));
        };
        const double left = -0.5, right = options_.width - 0.5, top = -0.5, bottom = options_.height - 0.5;
        for (double x = left; x <= right; x += 0.5) {
            extend(x, top);
            extend(x, bottom);
        }
        for (double y = top; y <= bottom; y += 0.5) {
            extend(left, y);
            extend(right, y);
        }
        footprint_ = cv::Size2d(2 * half_w, 2 * half_h);

        undistorted_.create(options_.height, options_.width, CV_64FC2);
        for (int r = 0; r < options_.height; ++r) {
            cv::Vec2d *u = undistorted_.ptr<cv::Vec2d>(r);
            for (int c = 0; c < options_.width; ++c) {
                const Point2 p = options_.lens.undistort({double(c), double(r)});
                u[c] = {p.x, p.y};
            }
        }
    }
    const double view_w = footprint_.width, view_h = footprint_.height;

    base_scale_ = kFootprint * std::min(double(canvas_.cols) / view_w, double(canvas_.rows) / view_h);

    std::mt19937 rng(options_.seed);
    std::uniform_real_distribution<double> phase(0.0, 2 * kPi);
    std::uniform_real_distribution<double> band_frequency(2.0, 8.0);
    std::normal_distribution<double> gauss(0.0, 1.0);

    // Room left for the centre to wander: the canvas minus the (rotated, zoomed, jittered)
    // footprint, in world units.
    const double max_angle = radians(options_.rotation_amplitude_deg + 4 * options_.rotation_band_deg);
    const double zoom = 1.0 + options_.zoom_amplitude;
    const double half_w = 0.5 * zoom * (view_w * std::cos(max_angle) + view_h * std::sin(max_angle));
    const double half_h = 0.5 * zoom * (view_h * std::cos(max_angle) + view_w * std::sin(max_angle));
    const double shake = 4 * (options_.band_px + options_.noise_px);
    path_amplitude_.x = std::max(0.0, 0.5 * canvas_.cols / base_scale_ - half_w - shake);
    path_amplitude_.y = std::max(0.0, 0.5 * canvas_.rows / base_scale_ - half_h - shake);
    path_phase_x_ = phase(rng);
    path_phase_y_ = phase(rng);
    rotation_phase_ = phase(rng);
    zoom_phase_ = phase(rng);

    if (options_.profile == FlightProfile::Manoeuvre) {
        // The same check for the manoeuvre, pose by pose: the rotated, zoomed footprint plus
        // the shake must stay on the canvas; translations shrink (about the canvas centre)
        // until every pose fits.
        const double half_cw = 0.5 * canvas_.cols / base_scale_, half_ch = 0.5 * canvas_.rows / base_scale_;
        const double angle_margin = radians(4 * (options_.rotation_band_deg + options_.rotation_noise_deg));
        const double end = manoeuvrePlan().back().to;
        for (int k = 0; k <= int(std::ceil(end * options_.fps)); ++k) {
            const Similarity p = manoeuvrePose(std::min(k / options_.fps, end), 1.0);
            const double a = std::min(std::abs(p.angle) + angle_margin, 0.5 * kPi);
            const double hw = 0.5 * p.scale * (view_w * std::cos(a) + view_h * std::sin(a));
            const double hh = 0.5 * p.scale * (view_h * std::cos(a) + view_w * std::sin(a));
            const double room_x = std::max(0.0, half_cw - hw - shake * p.scale);
            const double room_y = std::max(0.0, half_ch - hh - shake * p.scale);
            if (std::abs(p.dx) > room_x)
                manoeuvre_shrink_ = std::min(manoeuvre_shrink_, room_x / std::abs(p.dx));
            if (std::abs(p.dy) > room_y)
                manoeuvre_shrink_ = std::min(manoeuvre_shrink_, room_y / std::abs(p.dy));
        }
    }

    auto make_band = [&](double rms) {
        std::vector<Wave> band;
        // Equal amplitudes a give RMS a * sqrt(n / 2).
        const double a = rms / std::sqrt(kBandWaves / 2.0);
        for (int k = 0; k < kBandWaves; ++k)
            band.push_back({a, band_frequency(rng), phase(rng)});
        return band;
    };
    band_x_ = make_band(options_.band_px);
    band_y_ = make_band(options_.band_px);
    band_angle_ = make_band(radians(options_.rotation_band_deg));
    auto make_noise = [&](double rms) {
        std::vector<double> noise(std::size_t(std::max(options_.frames, 1)));
        for (auto &n : noise)
            n = rms * gauss(rng);
        return noise;
    };
    noise_x_ = make_noise(options_.noise_px);
    noise_y_ = make_noise(options_.noise_px);
    noise_angle_ = make_noise(radians(options_.rotation_noise_deg));

    if (options_.vibration_hz > 0) {
        // A generator of its own: the draws above and below (and so every flight without
        // vibration) stay as they were.
        std::seed_seq vibration_seed{options_.seed, 0x76696272u};
        std::mt19937 vibration_rng(vibration_seed);
        std::uniform_real_distribution<double> spread(1.0 - kVibrationSpread, 1.0 + kVibrationSpread);
        auto make_vibration = [&](double rms) {
            std::vector<Wave> waves;
            if (rms <= 0)
                return waves;
            const double a = rms / std::sqrt(kVibrationWaves / 2.0);
            for (int k = 0; k < kVibrationWaves; ++k) {
                const double f = options_.vibration_hz * spread(vibration_rng);
                waves.push_back({a, f, phase(vibration_rng)});
            }
            return waves;
        };
        vibration_x_ = make_vibration(options_.vibration_px);
        vibration_y_ = make_vibration(options_.vibration_px);
        vibration_angle_ = make_vibration(radians(options_.vibration_deg));
    }

    if (options_.moving_objects > 0) {
        cv::Mat texture = cv::imread(std::string(UAVSTAB_DATA_DIR) + "/aero3.jpg", cv::IMREAD_COLOR);
        if (texture.empty())
            texture = canvas_;
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        for (int k = 0; k < options_.moving_objects; ++k) {
            MovingObject o;
            const int pw = std::max(4, int(0.12 * options_.width * base_scale_));
            const int ph = std::max(4, int(0.08 * options_.width * base_scale_));
            const int px = int(unit(rng) * (texture.cols - pw)), py = int(unit(rng) * (texture.rows - ph));
            o.patch = texture(cv::Rect(px, py, std::min(pw, texture.cols), std::min(ph, texture.rows))).clone();
            o.start = {(unit(rng) - 0.5) * options_.width, (unit(rng) - 0.5) * options_.height};
            const double speed = 2.0 + 3.0 * unit(rng), heading = phase(rng);
            o.velocity = {speed * std::cos(heading), speed * std::sin(heading)};
            objects_.push_back(std::move(o));
        }
    }
}

double ShakyFlight::waves(const std::vector<Wave> &band, double t)
{
    double v = 0.0;
    for (const Wave &w : band)
        v += w.amplitude * std::sin(2 * kPi * w.frequency * t + w.phase);
    return v;
}

double ShakyFlight::jitter(const std::vector<Wave> &band, const std::vector<double> &noise, double frame_time) const
{
    const double t = frame_time / options_.fps;
    double v = 0.0;
    if (!noise.empty()) {
        // Linear between frames; at a whole frame time exactly that frame's draw (w = 0).
        const double last = double(noise.size() - 1);
        const double clamped = std::clamp(frame_time, 0.0, last);
        const double before = std::floor(clamped);
        const double w = clamped - before;
        const std::size_t k = std::size_t(before);
        const double a = noise[k], b = noise[std::min(k + 1, noise.size() - 1)];
        v = a + w * (b - a);
    }
    for (const Wave &w : band)
        v += w.amplitude * std::sin(2 * kPi * w.frequency * t + w.phase);
    return v;
}

Similarity ShakyFlight::manoeuvrePose(double t, double shrink) const
{
    Similarity pose{kManoeuvreStartX, kManoeuvreStartY, 0.0, 1.0};
    for (const ManoeuvreSegment &s : manoeuvrePlan()) {
        if (t <= s.from)
            break;
        const double f = trapezoid(t - s.from, s.to - s.from, s.ramp);
        pose.dx += f * s.move.dx;
        pose.dy += f * s.move.dy;
        pose.angle += f * s.move.angle;
        pose.scale *= 1.0 + f * (s.move.scale - 1.0);
    }
    pose.dx *= shrink;
    pose.dy *= shrink;
    return pose;
}

Similarity ShakyFlight::intendedPose(int i) const
{
    return intendedPoseAt(double(i));
}

Similarity ShakyFlight::intendedPoseAt(double frame_time) const
{
    const double t = frame_time / options_.fps;
    if (options_.profile == FlightProfile::Manoeuvre)
        return manoeuvrePose(t, manoeuvre_shrink_);
    // A Lissajous pan whose speed peaks near pan_speed, a slow yaw, an optional slow zoom.
    const double wx = path_amplitude_.x > 0 ? options_.pan_speed * options_.fps / path_amplitude_.x : 0.0;
    const double wy = path_amplitude_.y > 0 ? 0.7 * options_.pan_speed * options_.fps / path_amplitude_.y : 0.0;
    Similarity pose;
    pose.dx = path_amplitude_.x * std::sin(wx * t + path_phase_x_);
    pose.dy = path_amplitude_.y * std::sin(wy * t + path_phase_y_);
    pose.angle = radians(options_.rotation_amplitude_deg) * std::sin(2 * kPi * t / 12.0 + rotation_phase_);
    pose.scale = 1.0 + options_.zoom_amplitude * std::sin(2 * kPi * t / 15.0 + zoom_phase_);
    return pose;
}

Similarity ShakyFlight::truePose(int i) const
{
    return truePoseAt(double(i));
}

Similarity ShakyFlight::truePoseAt(double frame_time) const
{
    Similarity pose = intendedPoseAt(frame_time);
    // Jitter is camera shake in the camera's own frame: offset in output pixels.
    Similarity shake{jitter(band_x_, noise_x_, frame_time), jitter(band_y_, noise_y_, frame_time),
                     jitter(band_angle_, noise_angle_, frame_time), 1.0};
    // Vibration likewise; only added when there is some, so that the poses without it are
    // bit for bit what they were.
    const double t = frame_time / options_.fps;
    if (!vibration_x_.empty())
        shake.dx += waves(vibration_x_, t);
    if (!vibration_y_.empty())
        shake.dy += waves(vibration_y_, t);
    if (!vibration_angle_.empty())
        shake.angle += waves(vibration_angle_, t);
    return pose * shake;
}

double ShakyFlight::rowTime(int i, double row) const
{
    if (options_.readout == 0)
        return double(i);
    return i + options_.readout * (row / (options_.height - 1) - 0.5);
}

Similarity ShakyFlight::truePoseAtRow(int i, double row) const
{
    return truePoseAt(rowTime(i, row));
}

Similarity ShakyFlight::trueMotion(int i) const
{
    return truePose(i - 1).inverse() * truePose(i);
}

cv::Mat ShakyFlight::renderBgr(int i) const
{
    cv::Mat scene = canvas_;
    const cv::Point2d canvas_centre((canvas_.cols - 1) * 0.5, (canvas_.rows - 1) * 0.5);
    if (!objects_.empty()) {
        scene = canvas_.clone();
        for (const MovingObject &o : objects_) {
            // Objects bounce around the middle of the scene, independently of the camera.
            const cv::Point2d range(0.6 * options_.width, 0.6 * options_.height);
            cv::Point2d p = o.start + o.velocity * double(i);
            auto fold = [](double v, double r) {
                const double period = 4 * r;
                double m = std::fmod(v + r, period);
                if (m < 0)
                    m += period;
                return m < 2 * r ? m - r : 3 * r - m;
            };
            p = {fold(p.x, range.x), fold(p.y, range.y)};
            const int x = int(std::lround(canvas_centre.x + base_scale_ * p.x - o.patch.cols / 2.0));
            const int y = int(std::lround(canvas_centre.y + base_scale_ * p.y - o.patch.rows / 2.0));
            const cv::Rect target = cv::Rect(x, y, o.patch.cols, o.patch.rows) & cv::Rect(0, 0, scene.cols, scene.rows);
            if (target.area() > 0)
                o.patch(cv::Rect(target.x - x, target.y - y, target.width, target.height)).copyTo(scene(target));
        }
    }
    cv::Mat out;
    const cv::Size size(options_.width, options_.height);
    if (options_.readout == 0 && !options_.lens.active()) {
        auto matrix = canvasFromOutput(truePose(i));
        cv::warpAffine(scene, out, cv::Mat(2, 3, CV_64F, matrix.data()), size, cv::INTER_CUBIC | cv::WARP_INVERSE_MAP,
                       cv::BORDER_REFLECT_101);
        return out;
    }
    // Rolling shutter or lens: one remap, the map made row by row (every row has its pose;
    // with a lens every pixel is sampled at its undistorted position).
    cv::Mat map_x(size, CV_32F), map_y(size, CV_32F);
    const Similarity frame_pose = truePose(i);
    for (int r = 0; r < options_.height; ++r) {
        const auto m = canvasFromOutput(options_.readout == 0 ? frame_pose : truePoseAtRow(i, r));
        float *mx = map_x.ptr<float>(r), *my = map_y.ptr<float>(r);
        if (options_.lens.active()) {
            const cv::Vec2d *u = undistorted_.ptr<cv::Vec2d>(r);
            for (int c = 0; c < options_.width; ++c) {
                mx[c] = float(m[0] * u[c][0] + m[1] * u[c][1] + m[2]);
                my[c] = float(m[3] * u[c][0] + m[4] * u[c][1] + m[5]);
            }
        } else {
            for (int c = 0; c < options_.width; ++c) {
                mx[c] = float(m[0] * c + m[1] * r + m[2]);
                my[c] = float(m[3] * c + m[4] * r + m[5]);
            }
        }
    }
    cv::remap(scene, out, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
    return out;
}

std::array<double, 6> ShakyFlight::canvasFromOutput(const Similarity &pose) const
{
    // canvas = canvas centre + base_scale * pose(p), p = output pixel - output centre.
    const Similarity world_to_canvas{(canvas_.cols - 1) * 0.5, (canvas_.rows - 1) * 0.5, 0.0, base_scale_};
    const double cx = (options_.width - 1) * 0.5, cy = (options_.height - 1) * 0.5;
    const auto m = (world_to_canvas * pose).pixelMatrix(options_.width, options_.height);
    // pixelMatrix adds the output centre back on both sides; undo it on the canvas side.
    return {m[0], m[1], m[2] - cx, m[3], m[4], m[5] - cy};
}

Point2 ShakyFlight::canvasPosition(int i, Point2 pixel) const
{
    const Point2 u = options_.lens.active() ? options_.lens.undistort(pixel) : pixel;
    const auto m = canvasFromOutput(options_.readout == 0 ? truePose(i) : truePoseAtRow(i, pixel.y));
    return {m[0] * u.x + m[1] * u.y + m[2], m[3] * u.x + m[4] * u.y + m[5]};
}

FrameBuffer ShakyFlight::render(int i, int row_padding) const
{
    FrameBuffer frame(options_.format, options_.width, options_.height, row_padding);
    bgrToFrame(renderBgr(i), frame);
    return frame;
}

} // namespace uavstab::synthetic
