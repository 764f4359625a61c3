#include "path/path_terms.hpp"

#include <algorithm>
#include <cmath>

namespace uavstab {

namespace {
constexpr double kCoefficients[4][4] = {{1, 0, 0, 0}, {-1, 1, 0, 0}, {1, -2, 1, 0}, {-1, 3, -3, 1}};
}

PoseParams paramsOf(const Similarity &s)
{
    return {s.dx, s.dy, s.angle, std::log(s.scale)};
}

void addDifferences(BandedBoxQp &qp, const std::vector<double> &past, int order, double weight,
                    const std::vector<double> *row_weights)
{
    if (weight <= 0.0)
        return;
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

std::vector<double> differences(const std::vector<double> &past, const std::vector<double> &x, int order)
{
    std::vector<double> z = past;
    z.insert(z.end(), x.begin(), x.end());
    const std::size_t span = std::size_t(order) + 1;
    std::vector<double> d(z.size() >= span ? z.size() - span + 1 : 0, 0.0);
    for (std::size_t r = 0; r < d.size(); ++r)
        for (std::size_t a = 0; a < span; ++a)
            d[r] += kCoefficients[order][a] * z[r + a];
    return d;
}

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

double catchUpShare(const std::vector<double> &camera, const std::vector<double> &path, std::size_t known,
                    const std::vector<double> &past_gaps, std::size_t window, double threshold,
                    const std::vector<double> &series, double min_share)
{
    if (threshold <= 0.0 || window == 0)
        return 1.0;
    double gap = 0.0;
    std::size_t terms = 0;
    for (std::size_t j = std::min(known, window); j-- > 0 && terms < window; ++terms)
        gap += camera[j] - path[j];
    for (auto it = past_gaps.rbegin(); it != past_gaps.rend() && terms < window; ++it, ++terms)
        gap += *it;
    gap = std::abs(gap) / double(terms);
    const double level = threshold * shakeLevel(series, 30);
    if (terms < window || gap <= level)
        return 1.0;
    return std::max(min_share, (level / gap) * (level / gap));
}

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

Point2 uprightTranslationRoom(const CropWindow &window, double relative_angle, double relative_scale,
                              double frame_turn, double camera_scale)
{
    // Rooms are shrunk by this much so that rounding never puts a corner a hair outside.
    constexpr double kRoomEpsilon = 1e-6;
    const Point2 r = window.translationRoom(relative_angle, relative_scale);
    const double bx = std::max(0.0, r.x - kRoomEpsilon), by = std::max(0.0, r.y - kRoomEpsilon);
    const double c = std::abs(std::cos(frame_turn)), s = std::abs(std::sin(frame_turn));
    double shrink = 1.0;
    if (bx > 0.0 && by > 0.0)
        shrink = std::min({1.0, bx / (c * bx + s * by), by / (s * bx + c * by)});
    return {shrink * bx * camera_scale, shrink * by * camera_scale};
}

} // namespace uavstab
