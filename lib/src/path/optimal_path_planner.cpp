#include "path/optimal_path_planner.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "path/box_qp.hpp"
#include "path/path_terms.hpp"
#include "path/framing.hpp"

namespace uavstab {

namespace {

// Rooms are shrunk by this much so that rounding never puts a corner a hair outside.
constexpr double kRoomEpsilon = 1e-6;

using Params = PoseParams;

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
            std::vector<double> gaps;
            for (const Params &g : past_gap_)
                gaps.push_back(g[a]);
            const double share = catchUpShare(camera[a], reference[a], known, gaps,
                                              std::size_t(std::max(1, settings_.manoeuvre_window)),
                                              settings_.manoeuvre_threshold, series, settings_.min_smoothness_share);
            if (share < 1.0)
                reference[a] = smoothAxis(camera[a], history[a], settings_.smoothness * share, threshold,
                                          settings_.reweighting_rounds);
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
        room[j] = uprightTranslationRoom(windowOf(j), output_turn - turn, relative_scale[j], turn,
                                         std::exp(origin[kLogScale] + camera[kLogScale][j]));
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
