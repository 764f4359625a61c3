#include "path/l1_path_planner.hpp"

#include <algorithm>
#include <cmath>

#include "path/box_qp.hpp"
#include "path/path_terms.hpp"
#include "path/framing.hpp"

namespace uavstab {

namespace {

// Rooms are shrunk by this much so that rounding never puts a corner a hair outside.
constexpr double kRoomEpsilon = 1e-6;
// A whisper of pull towards the camera path (per px^2): the L1 terms leave a still path's
// place in the tube free, and this picks the most central one (and keeps every round's
// problem strictly convex).
constexpr double kRidge = 1e-4;
// Velocities for the steadiness are taken over this many frames: the committed values of
// the followed path come from one solve each, and frame-to-frame differences are noisy.
constexpr std::size_t kSteadyLag = 10;

// One parameter's stage 1 over the horizon, in px.
struct AxisProblem {
    std::vector<double> past;    // committed stage 1 values, oldest first
    std::vector<double> camera;  // one per horizon frame
    std::vector<double> room;    // |p_j - camera_j| <= room_j keeps frame j covered
    std::vector<double> follow;  // where the camera means to go
    std::vector<double> tube;    // |p_j - follow_j| <= tube_j
    double pull = 0.0;           // L1 weight of the pull towards `follow`
};

// Stage 1 by iteratively reweighted least squares, from `x`.
std::vector<double> solveAxis(const AxisProblem &p, const L1PathPlanner::Settings &s, std::vector<double> x,
                              int rounds)
{
    const std::size_t n = p.camera.size();
    for (std::size_t j = 0; j < n; ++j)
        x[j] = std::clamp(x[j], p.follow[j] - p.tube[j], p.follow[j] + p.tube[j]);
    const double weights[3] = {s.velocity_weight, s.acceleration_weight, s.jerk_weight};
    const double eps = s.epsilon, ew = s.edge_weight;
    std::vector<double> row_weights;
    for (int round = 0; round < rounds; ++round) {
        BandedBoxQp qp(n);
        for (int order = 1; order <= 3; ++order) {
            const std::vector<double> d = differences(p.past, x, order);
            row_weights.resize(d.size());
            for (std::size_t r = 0; r < d.size(); ++r)
                row_weights[r] = 1.0 / std::max(std::abs(d[r]), eps);
            addDifferences(qp, p.past, order, weights[order - 1], &row_weights);
        }
        // The speed's square: L1 norms charge a move by its length alone, so standing still
        // and then rushing after the camera costs them what moving with it does.
        addDifferences(qp, p.past, 1, s.speed_weight, nullptr);
        for (std::size_t j = 0; j < n; ++j) {
            qp.addQ(j, j, kRidge);
            qp.addG(j, -kRidge * p.camera[j]);
            // Leaving the room: ew * max(0, e) for e = p - upper and e = lower - p, each
            // majorised as ew/2 (e^2 / |e0| + e) (+ a constant).
            const double upper = p.camera[j] + p.room[j], lower = p.camera[j] - p.room[j];
            const double au = ew / (2.0 * std::max(std::abs(x[j] - upper), eps));
            const double al = ew / (2.0 * std::max(std::abs(lower - x[j]), eps));
            qp.addQ(j, j, au + al);
            qp.addG(j, -au * upper - al * lower);
            if (p.pull > 0.0) {  // pull * |p - follow|, majorised likewise
                const double af = p.pull / std::max(std::abs(x[j] - p.follow[j]), eps);
                qp.addQ(j, j, af);
                qp.addG(j, -af * p.follow[j]);
            }
            qp.setBounds(j, p.follow[j] - p.tube[j], p.follow[j] + p.tube[j]);
        }
        x = qp.solve().x;
    }
    return x;
}

} // namespace

L1PathPlanner::L1PathPlanner(const Settings &settings) : settings_(settings) {}

void L1PathPlanner::restart()
{
    past_camera_.clear();
    past_reference_.clear();
    past_follow_.clear();
    past_follow_gap_.clear();
    past_change_ = {0.0, 0.0, 0.0, 0.0};
    shake_variance_ = {0.0, 0.0, 0.0, 0.0};
    shake_frames_ = 0;
    // A new scene's shake is judged afresh; a cut hides the change of zoom.
    shake_crop_ = 0.0;
    longest_lookahead_ = 0;
    for (auto &v : last_plan_)
        v.clear();
}

PlannedFrame L1PathPlanner::plan(const PlanRequest &request)
{
    if (request.segment_start)
        restart();
    const std::size_t known = request.lookahead.size();
    const std::size_t horizon = known + std::size_t(std::max(0, settings_.extension));
    // The look-ahead shrinks at the end of a stream: the tube keeps the width it had.
    longest_lookahead_ = std::max(longest_lookahead_, known);
    const Params origin = paramsOf(request.lookahead.front());
    const double half_diagonal = 0.5 * std::hypot(double(request.width), double(request.height));
    const double unit[4] = {1.0, 1.0, half_diagonal, half_diagonal};  // px per unit of each parameter
    // Everything is planned relative to the first frame's camera pose, in px, with x and y
    // in axes turned by its angle (where its crop room is an upright box).
    const double ca = std::cos(origin[kAngle]), sa = std::sin(origin[kAngle]);
    auto relative = [&](const Params &p, bool position) {
        Params d;
        for (int a = 0; a < 4; ++a)
            d[a] = p[a] - (position ? origin[a] : 0.0);
        const double x = ca * d[kX] + sa * d[kY], y = -sa * d[kX] + ca * d[kY];
        d[kX] = x;
        d[kY] = y;
        for (int a = 0; a < 4; ++a)
            d[a] *= unit[a];
        return d;
    };
    auto absolute = [&](const std::array<std::vector<double>, 4> &path, std::size_t j, bool position) {
        Params q;
        for (int a = 0; a < 4; ++a)
            q[a] = path[a][j] / unit[a];
        const double x = ca * q[kX] - sa * q[kY], y = sa * q[kX] + ca * q[kY];
        q[kX] = x;
        q[kY] = y;
        if (position)
            for (int a = 0; a < 4; ++a)
                q[a] += origin[a];
        return q;
    };
    auto series = [&](const std::deque<Params> &values) {
        std::array<std::vector<double>, 4> s;
        for (const Params &p : values) {
            const Params r = relative(p, true);
            for (int a = 0; a < 4; ++a)
                s[a].push_back(r[a]);
        }
        return s;
    };

    // The camera path: the past, the known look-ahead, then the extrapolation.
    std::array<std::vector<double>, 4> camera_series = series(past_camera_), camera;
    for (const Similarity &s : request.lookahead) {
        const Params r = relative(paramsOf(s), true);
        for (int a = 0; a < 4; ++a)
            camera_series[a].push_back(r[a]);
    }
    for (int a = 0; a < 4; ++a) {
        camera[a].assign(camera_series[a].end() - long(known), camera_series[a].end());
        for (int k = 1; k <= settings_.extension; ++k)
            camera[a].push_back(extrapolate(camera_series[a], std::size_t(settings_.prediction_frames), k,
                                            settings_.young_slope_prior));
    }
    const std::array<std::vector<double>, 4> past_reference = series(past_reference_);
    const std::array<std::vector<double>, 4> follow_history = series(past_follow_);

    // Where the camera means to go, per parameter.
    std::array<AxisProblem, 4> problems;
    const double jerk_threshold = 2e-6 * half_diagonal;
    for (int a = 0; a < 4; ++a) {
        AxisProblem &p = problems[a];
        p.past = past_reference[a];
        p.camera = camera[a];
        const std::vector<double> &history = follow_history[a];
        const std::vector<double> recent(history.end() - long(std::min<std::size_t>(kHistory, history.size())),
                                         history.end());
        p.follow = smoothAxis(camera[a], recent, settings_.follow_smoothness, jerk_threshold, 5);
        if (int(known) <= settings_.catch_up_max_lookahead) {
            std::vector<double> gaps;
            for (const Params &g : past_follow_gap_)
                gaps.push_back(g[a] * unit[a]);
            const double share = catchUpShare(camera[a], p.follow, known, gaps,
                                              std::size_t(std::max(1, settings_.catch_up_window)),
                                              settings_.catch_up_threshold, camera_series[a], 0.01);
            if (share < 1.0)
                p.follow = smoothAxis(camera[a], recent, settings_.follow_smoothness * share, jerk_threshold, 5);
        }
    }

    // The shake's level: the mean square of camera minus followed path; at a segment's first
    // frame over the known look-ahead (so that the tube does not narrow, and push the path,
    // while it is learnt), then over about a second.
    if (shake_frames_ == 0) {
        for (int a = 0; a < 4; ++a) {
            double sum = 0.0;
            for (std::size_t j = 0; j < known; ++j)
                sum += std::pow(camera[a][j] - problems[a].follow[j], 2);
            shake_variance_[a] = sum / double(known);
        }
        shake_frames_ = int(known) - 1;
    }

    // Steady moves: the followed path's mean velocity against its spread, over the newest
    // steady_window frames of its committed past and its known look-ahead. The look-ahead
    // counts so that a drift the delay already shows is followed from where it shows, not
    // ridden at the tube's edge until the past proves it steady. x and y count together (a
    // drift along a curve is steady as a whole); a steady flight also has its turns and
    // climbs followed.
    auto steadiness = [&](int a) {
        std::vector<double> f = follow_history[a];
        f.insert(f.end(), problems[a].follow.begin(), problems[a].follow.begin() + long(known));
        const std::size_t w =
            std::min(f.size() > kSteadyLag ? f.size() - kSteadyLag : 0, std::size_t(std::max(2, settings_.steady_window)));
        if (w < 10)
            return 0.0;
        double sum = 0.0, sum2 = 0.0;
        for (std::size_t k = f.size() - w; k < f.size(); ++k) {
            const double v = (f[k] - f[k - kSteadyLag]) / double(kSteadyLag);
            sum += v;
            sum2 += v * v;
        }
        const double mean = sum / double(w);
        const double spread = std::sqrt(std::max(0.0, sum2 / double(w) - mean * mean));
        const double floor = settings_.steady_floor * double(request.width) / 640.0;
        const double steadiness = std::abs(mean) / (spread + floor);
        return std::clamp((steadiness - settings_.steady_from) / (settings_.steady_full - settings_.steady_from), 0.0,
                          1.0);
    };
    if (settings_.steady_pull > 0.0) {
        const double moving = std::max(steadiness(kX), steadiness(kY));
        const double turning = std::max({moving, steadiness(kAngle), steadiness(kLogScale)});
        problems[kX].pull = problems[kY].pull = settings_.steady_pull * moving;
        problems[kAngle].pull = problems[kLogScale].pull = settings_.steady_pull * turning;
    }

    // Warm start: the previous frame's plan, one frame on; where it ends, its last value.
    std::array<std::vector<double>, 4> start;
    const bool warm = last_plan_[0].size() >= 2;
    for (std::size_t j = 0; j < horizon; ++j) {
        Params p = camera[0].empty() ? Params{} : Params{camera[0][j], camera[1][j], camera[2][j], camera[3][j]};
        if (warm) {
            const std::size_t k = std::min(j + 1, last_plan_[0].size() - 1);
            p = relative({last_plan_[0][k], last_plan_[1][k], last_plan_[2][k], last_plan_[3][k]}, true);
        }
        for (int a = 0; a < 4; ++a)
            start[a].push_back(p[a]);
    }
    const int rounds = warm ? settings_.rounds : settings_.start_rounds;

    // Strong shake: the crop the shake's level needs, per axis (a turn moves the corners
    // by angle times the other half size), grown into slowly so that the zoom does not pump.
    const double base_log_zoom = std::log(zoomForCrop(settings_.crop));
    if (settings_.shake_crop) {
        const double hx = 0.5 * double(request.width), hy = 0.5 * double(request.height);
        const double turn = shake_variance_[kAngle] / (half_diagonal * half_diagonal);
        const double sx = std::sqrt(shake_variance_[kX] + turn * hy * hy);
        const double sy = std::sqrt(shake_variance_[kY] + turn * hx * hx);
        const double need = settings_.room_per_shake * std::max(sx / hx, sy / hy);
        const double widest = 1.0 - std::exp(-(1.0 + settings_.scale_share) * base_log_zoom);
        const double target =
            widest > settings_.crop ? std::clamp((need - settings_.crop) / (widest - settings_.crop), 0.0, 1.0) : 0.0;
        const double step = 1.0 / double(std::max(1, settings_.shake_crop_frames));
        shake_crop_ += std::clamp(target - shake_crop_, -0.25 * step, step);
    }
    const double zoom = std::exp(base_log_zoom * (1.0 + settings_.scale_share * shake_crop_));
    const CropWindow window(request.width, request.height, zoom);
    const Params past_change = relative(past_change_, false);
    const double reach =
        std::min(1.0, double(longest_lookahead_ - 1) / double(std::max(1, settings_.full_tube_lookahead)));
    const double tube_cap = settings_.short_tube + (1.0 - settings_.short_tube) * reach;
    std::array<std::vector<double>, 4> reference, planned;
    auto planAxis = [&](int a) {
        AxisProblem &problem = problems[a];
        const double shake = settings_.shake_margin * std::sqrt(shake_variance_[a]);
        problem.tube.resize(horizon);
        for (std::size_t j = 0; j < horizon; ++j)
            problem.tube[j] = std::min(tube_cap * problem.room[j], std::max(0.0, problem.room[j] - shake));
        reference[a] = solveAxis(problem, settings_, start[a], rounds);
        std::vector<double> lower(known), upper(known);
        for (std::size_t j = 0; j < known; ++j) {
            lower[j] = problem.camera[j] - problem.room[j];
            upper[j] = problem.camera[j] + problem.room[j];
        }
        const std::vector<double> delta =
            fitAxis(std::vector<double>(reference[a].begin(), reference[a].begin() + long(known)), lower, upper,
                    past_change[a], settings_.stiffness, settings_.keep_inside);
        planned[a] = reference[a];
        for (std::size_t j = 0; j < known; ++j)
            planned[a][j] += delta[j];
    };

    // Log scale, then angle, then translation, each in the room the previous one left.
    const double scale_room =
        std::max(0.0, settings_.scale_share * (1.0 - shake_crop_) * base_log_zoom - kRoomEpsilon) * unit[kLogScale];
    problems[kLogScale].room.assign(horizon, scale_room);
    planAxis(kLogScale);
    std::vector<double> relative_scale(horizon);
    for (std::size_t j = 0; j < horizon; ++j)
        relative_scale[j] = std::exp((planned[kLogScale][j] - camera[kLogScale][j]) / unit[kLogScale]);

    problems[kAngle].room.resize(horizon);
    for (std::size_t j = 0; j < horizon; ++j)
        problems[kAngle].room[j] =
            std::max(0.0, window.angleRoom(relative_scale[j], settings_.translation_reserve) - kRoomEpsilon) *
            unit[kAngle];
    planAxis(kAngle);

    problems[kX].room.resize(horizon);
    problems[kY].room.resize(horizon);
    for (std::size_t j = 0; j < horizon; ++j) {
        const double turn = camera[kAngle][j] / unit[kAngle];
        const double output_turn = planned[kAngle][j] / unit[kAngle];
        const double camera_scale = std::exp(origin[kLogScale] + camera[kLogScale][j] / unit[kLogScale]);
        const Point2 room = uprightTranslationRoom(window, output_turn - turn, relative_scale[j], turn, camera_scale);
        problems[kX].room[j] = room.x;
        problems[kY].room[j] = room.y;
    }
    planAxis(kX);
    planAxis(kY);

    // Commit the first frame.
    const Params output = absolute(planned, 0, true);
    PlannedFrame result;
    result.smoothed = {output[kX], output[kY], output[kAngle], std::exp(output[kLogScale])};
    // frameOutput checks the corners and would shrink the correction should rounding ever
    // put one outside: the output is covered whatever happened above.
    const Framing framing = frameOutput(result.smoothed.inverse() * request.lookahead.front(), request.width,
                                        request.height, 1.0 - 1.0 / zoom, settings_.keep_inside);
    result.correction = framing.applied;
    result.output_to_input = framing.output_to_input;
    result.zoom = framing.zoom;
    result.correction_fraction = framing.fraction;

    // Remember what the next frame runs on from, in segment coordinates.
    for (auto &v : last_plan_)
        v.clear();
    for (std::size_t j = 0; j < horizon; ++j) {
        const Params q = absolute(reference, j, true);
        for (int a = 0; a < 4; ++a)
            last_plan_[a].push_back(q[a]);
    }
    std::array<std::vector<double>, 4> first_change, first_follow;
    for (int a = 0; a < 4; ++a) {
        first_change[a] = {planned[a][0] - reference[a][0]};
        first_follow[a] = {problems[a].follow[0]};
    }
    past_change_ = absolute(first_change, 0, false);
    past_reference_.push_back(absolute(reference, 0, true));
    past_follow_.push_back(absolute(first_follow, 0, true));
    past_camera_.push_back(origin);
    Params gap;
    ++shake_frames_;
    const double alpha = 1.0 / double(std::min(shake_frames_, 30));
    for (int a = 0; a < 4; ++a) {
        const double d = camera[a][0] - problems[a].follow[0];
        gap[a] = d / unit[a];
        shake_variance_[a] += alpha * (d * d - shake_variance_[a]);
    }
    past_follow_gap_.push_back(gap);
    auto keep = [](auto &deque, int count) {
        while (deque.size() > std::size_t(std::max(1, count)))
            deque.pop_front();
    };
    keep(past_reference_, kHistory);
    keep(past_follow_, std::max(kHistory, settings_.steady_window + int(kSteadyLag)));
    keep(past_camera_, std::max(30, settings_.prediction_frames));
    keep(past_follow_gap_, settings_.catch_up_window);
    return result;
}

} // namespace uavstab
