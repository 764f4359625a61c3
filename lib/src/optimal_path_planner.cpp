#include "uavstab/optimal_path_planner.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "box_qp.hpp"
#include "uavstab/framing.hpp"

namespace uavstab {

namespace {

// Rooms are shrunk by this much so that rounding never puts a corner a hair outside.
constexpr double kRoomEpsilon = 1e-6;

// A pose as the four parameters planned: x, y, angle, log scale.
enum { kX, kY, kAngle, kLogScale };
using Params = std::array<double, 4>;

Params paramsOf(const Similarity &s)
{
    return {s.dx, s.dy, s.angle, std::log(s.scale)};
}

// Adds weight * sum of squared `order`-th differences of z = past ++ x to the problem in x.
void addDifferences(BandedBoxQp &qp, const std::vector<double> &past, int order, double weight,
                    const std::vector<double> *row_weights = nullptr)
{
    if (weight <= 0.0)
        return;
    static constexpr double kCoefficients[4][4] = {{1, 0, 0, 0}, {-1, 1, 0, 0}, {1, -2, 1, 0}, {-1, 3, -3, 1}};
    const double *c = kCoefficients[order];
    const std::size_t p = past.size(), n = qp.size(), span = std::size_t(order) + 1;
    for (std::size_t r = 0; r + span <= p + n; ++r) {
        if (r + span <= p)
            continue;  // all in the past: a constant
        double constant = 0.0;
        for (std::size_t a = 0; a < span; ++a)
            if (r + a < p)
                constant += c[a] * past[r + a];
        const double w = row_weights ? weight * (*row_weights)[r] : weight;
        for (std::size_t a = 0; a < span; ++a) {
            if (r + a < p)
                continue;
            // One band entry stands for both Q(i, j) and Q(j, i).
            for (std::size_t b = a; b < span; ++b)
                qp.addQ(r + a - p, r + b - p, w * c[a] * c[b]);
            qp.addG(r + a - p, w * c[a] * constant);
        }
    }
}

// Stage 1: the fixed-lag smoother. Minimises sum_j (r_j - c_j)^2 + smoothness *
// sum Huber(D3 r), the differences running on from the past references; the Huber
// penalty by reweighted least squares (each round weights a jerk above the threshold by
// threshold / |jerk|, the weight that makes its square cost what its absolute value would).
std::vector<double> smoothAxis(const std::vector<double> &camera, const std::vector<double> &past, double smoothness,
                               double jerk_threshold, int rounds)
{
    const std::size_t n = camera.size();
    std::vector<double> x, weights, z;
    for (int round = 0;; ++round) {
        BandedBoxQp qp(n);
        for (std::size_t j = 0; j < n; ++j) {
            qp.addQ(j, j, 1.0);
            qp.addG(j, -camera[j]);
        }
        addDifferences(qp, past, 3, smoothness, round > 0 ? &weights : nullptr);
        x = qp.solve().x;
        if (round == rounds)
            return x;
        z = past;
        z.insert(z.end(), x.begin(), x.end());
        weights.assign(z.size() > 3 ? z.size() - 3 : 0, 1.0);
        for (std::size_t r = 0; r < weights.size(); ++r) {
            const double jerk = std::abs(-z[r] + 3 * z[r + 1] - 3 * z[r + 2] + z[r + 3]);
            if (jerk > jerk_threshold)
                weights[r] = jerk_threshold / jerk;
        }
    }
}

// Stage 2: the smallest, smoothest change delta to the reference that keeps every frame's
// crop window inside it: minimises sum delta_j^2 + stiffness * sum (delta_j - delta_j-1)^2
// subject to lower_j <= reference_j + delta_j <= upper_j. Zero where nothing binds.
std::vector<double> fitAxis(const std::vector<double> &reference, const std::vector<double> &lower,
                            const std::vector<double> &upper, double past_change, double stiffness, bool constrained)
{
    const std::size_t n = lower.size();
    if (!constrained)
        return std::vector<double>(n, 0.0);
    BandedBoxQp qp(n);
    for (std::size_t j = 0; j < n; ++j) {
        qp.addQ(j, j, 1.0);
        qp.setBounds(j, lower[j] - reference[j], upper[j] - reference[j]);
    }
    addDifferences(qp, {past_change}, 1, stiffness);
    return qp.solve().x;
}

// Line through the newest `count` values of `values` (oldest first), extrapolated
// `ahead` steps past the newest. While fewer than `count` values are known (a young
// segment) the slope is pulled towards zero, by a prior worth `prior` squared frames that
// fades as values arrive: a slope fitted to a few shaken frames is mostly shake, and a
// smooth path that set off along it would take a second to come back.
double extrapolate(const std::vector<double> &values, std::size_t count, int ahead, double prior)
{
    const std::size_t n = values.size();
    const double young = count > 0 ? std::max(0.0, 1.0 - double(n) / double(count)) : 0.0;
    count = std::min(count, n);
    if (count < 2)
        return values.back();
    double s0 = 0, s1 = 0, s2 = 0, v0 = 0, v1 = 0;
    for (std::size_t k = 0; k < count; ++k) {
        const double t = -double(k);  // 0 = newest
        const double v = values[n - 1 - k];
        s0 += 1;
        s1 += t;
        s2 += t * t;
        v0 += v;
        v1 += t * v;
    }
    const double det = s0 * (s2 + prior * young) - s1 * s1;
    const double slope = (s0 * v1 - s1 * v0) / det;
    const double intercept = (v0 - slope * s1) / s0;
    return intercept + slope * ahead;
}

// The shake's level in a camera path (oldest first): the RMS of its second differences
// over the newest `count` values. A manoeuvre's second differences (accelerations) are a
// small fraction of a pixel per frame squared; shake's are of the order of its amplitude.
double shakeLevel(const std::vector<double> &values, std::size_t count)
{
    const std::size_t n = values.size();
    double sum = 0.0;
    std::size_t terms = 0;
    for (std::size_t k = 0; k < count && k + 2 < n; ++k) {
        const std::size_t i = n - 1 - k;
        const double d2 = values[i] - 2 * values[i - 1] + values[i - 2];
        sum += d2 * d2;
        ++terms;
    }
    return terms ? std::sqrt(sum / double(terms)) : 0.0;
}

} // namespace

OptimalPathPlanner::OptimalPathPlanner(const Settings &settings) : settings_(settings) {}

double OptimalPathPlanner::planZoom(const PlanRequest &request, const std::array<std::vector<double>, 4> &camera,
                                    const std::array<std::vector<double>, 4> &reference, const Params &origin)
{
    const double base = zoomForCrop(settings_.crop);
    if (!settings_.adaptive_zoom)
        return base;
    const double max_zoom = std::max(base, settings_.max_zoom);
    const double hx = (request.width - 1) * 0.5, hy = (request.height - 1) * 0.5;
    // The zoom each known frame needs to show stage 1's pose with no border, less what the
    // zoom can gain before that frame: the largest is what this frame needs.
    double needed = base;
    for (std::size_t j = 0; j < request.lookahead.size(); ++j) {
        const double scale = std::exp(reference[kLogScale][j] - camera[kLogScale][j]);
        const double angle = reference[kAngle][j] - camera[kAngle][j];
        const double turn = origin[kAngle] + camera[kAngle][j];
        const double dx = reference[kX][j] - camera[kX][j], dy = reference[kY][j] - camera[kY][j];
        const double camera_scale = std::exp(origin[kLogScale] + camera[kLogScale][j]);
        // Translation in frame j's own axes.
        const double tx = std::abs(std::cos(turn) * dx + std::sin(turn) * dy) / camera_scale;
        const double ty = std::abs(-std::sin(turn) * dx + std::cos(turn) * dy) / camera_scale;
        const double c = std::abs(std::cos(angle)), s = std::abs(std::sin(angle));
        const double need_x = tx < hx ? scale * (hx * c + hy * s) / (hx - tx) : max_zoom;
        const double need_y = ty < hy ? scale * (hx * s + hy * c) / (hy - ty) : max_zoom;
        needed = std::max(needed, std::max(need_x, need_y) - double(j) * settings_.zoom_speed);
    }
    double zoom = std::min(needed, max_zoom);
    if (past_zoom_ > 0.0)  // in at zoom_speed, out at a quarter of it: never pumping
        zoom = std::clamp(zoom, past_zoom_ - 0.25 * settings_.zoom_speed, past_zoom_ + settings_.zoom_speed);
    return std::clamp(zoom, base, max_zoom);
}

PlannedFrame OptimalPathPlanner::plan(const PlanRequest &request)
{
    if (request.segment_start) {
        past_reference_.clear();
        past_camera_.clear();
        past_gap_.clear();
        past_change_ = {0.0, 0.0, 0.0, 0.0};
        past_zoom_ = 0.0;
    }

    // The camera path over the horizon: what is known, then the extrapolation. Values are
    // relative to the first frame's camera, for conditioning.
    const std::size_t known = request.lookahead.size();
    const std::size_t horizon = known + std::size_t(settings_.extension);
    const Params origin = paramsOf(request.lookahead.front());
    std::array<std::vector<double>, 4> camera, history, reference;
    for (int a = 0; a < 4; ++a) {
        std::vector<double> series;
        for (const Params &p : past_camera_)
            series.push_back(p[a] - origin[a]);
        for (const Similarity &s : request.lookahead)
            series.push_back(paramsOf(s)[a] - origin[a]);
        camera[a].assign(series.end() - long(known), series.end());
        for (int k = 1; k <= settings_.extension; ++k)
            camera[a].push_back(
                extrapolate(series, std::size_t(settings_.prediction_frames), k, settings_.young_slope_prior));
        for (const Params &p : past_reference_)
            history[a].push_back(p[a] - origin[a]);
        // Stage 1: where the camera means to go.
        // The jerk threshold is a share of the frame's diagonal in px or, for angle and log
        // scale, what moves a corner by that much.
        const double diagonal = std::hypot(double(request.width), double(request.height));
        const double threshold = settings_.jerk_threshold * (a == kX || a == kY ? diagonal : 2.0);
        reference[a] =
            smoothAxis(camera[a], history[a], settings_.smoothness, threshold, settings_.reweighting_rounds);
        if (settings_.manoeuvre_threshold > 0.0 && int(known) <= settings_.manoeuvre_max_lookahead) {
            // The mean gap between camera and path over the last frames: the known
            // look-ahead's, then the committed ones before it.
            const std::size_t window = std::size_t(std::max(1, settings_.manoeuvre_window));
            double gap = 0.0;
            std::size_t terms = 0;
            for (std::size_t j = std::min(known, window); j-- > 0 && terms < window; ++terms)
                gap += camera[a][j] - reference[a][j];
            for (auto it = past_gap_.rbegin(); it != past_gap_.rend() && terms < window; ++it, ++terms)
                gap += (*it)[a];
            gap = std::abs(gap) / double(terms);
            const double level = settings_.manoeuvre_threshold * shakeLevel(series, 30);
            if (terms == window && gap > level) {
                const double share = std::max(settings_.min_smoothness_share, (level / gap) * (level / gap));
                reference[a] = smoothAxis(camera[a], history[a], settings_.smoothness * share, threshold,
                                          settings_.reweighting_rounds);
            }
        }
    }

    const double zoom = planZoom(request, camera, reference, origin);
    // Frame j's zoom is at least this (zooming out is rate-limited).
    const double zoom_out_speed = settings_.adaptive_zoom ? 0.25 * settings_.zoom_speed : 0.0;
    const double base_zoom = zoomForCrop(settings_.crop);
    auto windowOf = [&](std::size_t j) {
        return CropWindow(request.width, request.height, std::max(base_zoom, zoom - double(j) * zoom_out_speed));
    };

    // Stage 2: keep every known frame's crop window inside its frame, per parameter in
    // the order scale, angle, translation, each leaving the next what it does not use.
    // Only known frames are constrained: the extrapolated ones are a guess.
    const std::size_t fitted = known;
    std::vector<double> lower(fitted), upper(fitted);
    auto fit = [&](int a, const std::vector<double> &target) {
        std::vector<double> ref(target.begin(), target.begin() + long(fitted));
        return fitAxis(ref, lower, upper, past_change_[a], settings_.stiffness, settings_.keep_inside);
    };

    for (std::size_t j = 0; j < fitted; ++j) {
        const CropWindow w = windowOf(j);
        const double scale_room = std::max(0.0, settings_.scale_share * std::log(w.hx / w.wx) - kRoomEpsilon);
        lower[j] = camera[kLogScale][j] - scale_room;
        upper[j] = camera[kLogScale][j] + scale_room;
    }
    const std::vector<double> delta_scale = fit(kLogScale, reference[kLogScale]);
    std::vector<double> relative_scale(fitted);  // output scale / camera scale
    for (std::size_t j = 0; j < fitted; ++j)
        relative_scale[j] = std::exp(reference[kLogScale][j] + delta_scale[j] - camera[kLogScale][j]);

    for (std::size_t j = 0; j < fitted; ++j) {
        const double room =
            std::max(0.0, windowOf(j).angleRoom(relative_scale[j], settings_.translation_reserve) - kRoomEpsilon);
        lower[j] = camera[kAngle][j] - room;
        upper[j] = camera[kAngle][j] + room;
    }
    const std::vector<double> delta_angle = fit(kAngle, reference[kAngle]);

    // Translation, in axes turned by the first frame's camera angle. Frame j's room is a
    // box in its own camera's axes, turned by its angle relative to the first frame's: the
    // largest upright box of the same proportions inside it stands in for it.
    const double ca = std::cos(origin[kAngle]), sa = std::sin(origin[kAngle]);
    auto toPlanning = [&](double x, double y) { return Point2{ca * x + sa * y, -sa * x + ca * y}; };
    std::vector<Point2> room(fitted), centre(fitted), target(horizon);
    for (std::size_t j = 0; j < horizon; ++j)
        target[j] = toPlanning(reference[kX][j], reference[kY][j]);
    for (std::size_t j = 0; j < fitted; ++j) {
        const double turn = camera[kAngle][j];
        const double output_turn = reference[kAngle][j] + delta_angle[j];
        const Point2 r = windowOf(j).translationRoom(output_turn - turn, relative_scale[j]);
        const double bx = std::max(0.0, r.x - kRoomEpsilon), by = std::max(0.0, r.y - kRoomEpsilon);
        const double c = std::abs(std::cos(turn)), s = std::abs(std::sin(turn));
        double shrink = 1.0;
        if (bx > 0.0 && by > 0.0)
            shrink = std::min({1.0, bx / (c * bx + s * by), by / (s * bx + c * by)});
        const double camera_scale = std::exp(origin[kLogScale] + camera[kLogScale][j]);
        room[j] = {shrink * bx * camera_scale, shrink * by * camera_scale};
        centre[j] = toPlanning(camera[kX][j], camera[kY][j]);
    }
    // The previous frame's change, in today's planning axes.
    const Point2 past_change = toPlanning(past_change_[kX], past_change_[kY]);
    std::array<std::vector<double>, 2> delta_position;
    for (int axis = 0; axis < 2; ++axis) {
        std::vector<double> ref(fitted);
        for (std::size_t j = 0; j < fitted; ++j) {
            const double c = axis == 0 ? centre[j].x : centre[j].y, r = axis == 0 ? room[j].x : room[j].y;
            ref[j] = axis == 0 ? target[j].x : target[j].y;
            lower[j] = c - r;
            upper[j] = c + r;
        }
        delta_position[axis] = fitAxis(ref, lower, upper, axis == 0 ? past_change.x : past_change.y,
                                     settings_.stiffness, settings_.keep_inside);
    }

    // Commit the first frame.
    const Point2 planned_xy{target[0].x + delta_position[0][0], target[0].y + delta_position[1][0]};
    const double px = ca * planned_xy.x - sa * planned_xy.y, py = sa * planned_xy.x + ca * planned_xy.y;
    PlannedFrame planned;
    planned.smoothed = {origin[kX] + px, origin[kY] + py, origin[kAngle] + reference[kAngle][0] + delta_angle[0],
                        std::exp(origin[kLogScale] + reference[kLogScale][0] + delta_scale[0])};
    const Similarity &camera_pose = request.lookahead.front();
    // frameOutput checks the corners and would shrink the correction should rounding ever
    // put one outside: the output is covered whatever happened above.
    const Framing framing = frameOutput(planned.smoothed.inverse() * camera_pose, request.width, request.height,
                                        1.0 - 1.0 / zoom, settings_.keep_inside);
    planned.correction = framing.applied;
    planned.output_to_input = framing.output_to_input;
    planned.zoom = framing.zoom;
    planned.correction_fraction = framing.fraction;

    // Remember the reference (stage 1 runs on from it) and the change (stage 2 does), in
    // segment coordinates.
    Params committed_reference;
    for (int a = 0; a < 4; ++a)
        committed_reference[a] = origin[a] + reference[a][0];
    past_reference_.push_back(committed_reference);
    while (past_reference_.size() > std::size_t(kHistory))
        past_reference_.pop_front();
    const double dx = delta_position[0][0], dy = delta_position[1][0];
    past_change_ = {ca * dx - sa * dy, sa * dx + ca * dy, delta_angle[0], delta_scale[0]};
    past_zoom_ = zoom;
    Params gap;
    for (int a = 0; a < 4; ++a)
        gap[a] = -reference[a][0];  // camera[a][0] is 0: values are relative to it
    past_gap_.push_back(gap);
    while (past_gap_.size() > std::size_t(std::max(1, settings_.manoeuvre_window)))
        past_gap_.pop_front();
    past_camera_.push_back(origin);
    while (past_camera_.size() > std::size_t(settings_.prediction_frames))
        past_camera_.pop_front();
    return planned;
}

} // namespace uavstab
