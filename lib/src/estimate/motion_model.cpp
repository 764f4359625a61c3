#include "estimate/motion_model.hpp"

#include <Eigen/Core>
#include <cmath>
#include <random>

namespace uavstab {

namespace {

constexpr int kRansacIterations = 64;

Eigen::Vector2d vec(Point2 p)
{
    return {p.x, p.y};
}

bool used(const std::vector<std::uint8_t> *use, std::size_t i)
{
    return use == nullptr || (*use)[i] != 0;
}

double squaredResidual(const Similarity &m, Point2 from, Point2 to)
{
    const Point2 q = m.apply(from);
    return (q.x - to.x) * (q.x - to.x) + (q.y - to.y) * (q.y - to.y);
}

// Exact motion through two correspondences (rigid: best rotation, averaged translation).
Similarity fitTwoPoints(MotionModel model, Point2 fa, Point2 fb, Point2 ta, Point2 tb)
{
    const std::vector<Point2> from{fa, fb}, to{ta, tb};
    return fitLeastSquares(model, from, to);
}

int countInliers(const Similarity &m, const std::vector<Point2> &from, const std::vector<Point2> &to,
                 double threshold2, std::vector<std::uint8_t> *flags, double *sum2)
{
    int count = 0;
    double total = 0.0;
    for (std::size_t i = 0; i < from.size(); ++i) {
        const double r2 = squaredResidual(m, from[i], to[i]);
        const bool in = r2 <= threshold2;
        if (flags)
            (*flags)[i] = in;
        if (in) {
            ++count;
            total += r2;
        }
    }
    if (sum2)
        *sum2 = total;
    return count;
}

} // namespace

const char *toString(MotionModel m)
{
    return m == MotionModel::Rigid ? "rigid" : "similarity";
}

Similarity fitLeastSquares(MotionModel model, const std::vector<Point2> &from,
                           const std::vector<Point2> &to, const std::vector<std::uint8_t> *use)
{
    Eigen::Vector2d mean_from = Eigen::Vector2d::Zero(), mean_to = Eigen::Vector2d::Zero();
    int n = 0;
    for (std::size_t i = 0; i < from.size(); ++i) {
        if (!used(use, i))
            continue;
        mean_from += vec(from[i]);
        mean_to += vec(to[i]);
        ++n;
    }
    if (n == 0)
        return Similarity::identity();
    mean_from /= n;
    mean_to /= n;

    // With centred point sets, s*cos = sum(dot)/sum|f|^2 and s*sin = sum(cross)/sum|f|^2;
    // the rigid fit keeps the angle atan2(sum cross, sum dot) and fixes s = 1.
    double dot = 0.0, cross = 0.0, norm = 0.0;
    for (std::size_t i = 0; i < from.size(); ++i) {
        if (!used(use, i))
            continue;
        const Eigen::Vector2d f = vec(from[i]) - mean_from;
        const Eigen::Vector2d t = vec(to[i]) - mean_to;
        dot += f.dot(t);
        cross += f.x() * t.y() - f.y() * t.x();
        norm += f.squaredNorm();
    }

    Similarity m;
    if (norm > 1e-12 && (dot != 0.0 || cross != 0.0)) {
        m.angle = std::atan2(cross, dot);
        m.scale = model == MotionModel::Similarity ? std::hypot(dot, cross) / norm : 1.0;
        if (!(m.scale > 1e-6))  // degenerate (e.g. all targets coincide)
            m.scale = 1.0;
    }
    const Point2 rotated = Similarity{0.0, 0.0, m.angle, m.scale}.apply({mean_from.x(), mean_from.y()});
    m.dx = mean_to.x() - rotated.x;
    m.dy = mean_to.y() - rotated.y;
    return m;
}

double rmsError(const Similarity &motion, const std::vector<Point2> &from, const std::vector<Point2> &to,
                const std::vector<std::uint8_t> *use)
{
    double sum = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < from.size(); ++i) {
        if (!used(use, i))
            continue;
        sum += squaredResidual(motion, from[i], to[i]);
        ++n;
    }
    return n > 0 ? std::sqrt(sum / n) : 0.0;
}

RobustFit fitRobust(MotionModel model, const std::vector<Point2> &from, const std::vector<Point2> &to,
                    double inlier_threshold, std::uint32_t seed)
{
    RobustFit result;
    const std::size_t n = std::min(from.size(), to.size());
    result.inliers.assign(n, 0);
    if (n == 0)
        return result;
    if (n < 3) {
        result.motion = fitLeastSquares(model, from, to);
        result.inliers.assign(n, 1);
        result.inlier_count = int(n);
        result.rms = rmsError(result.motion, from, to);
        return result;
    }

    const double threshold2 = inlier_threshold * inlier_threshold;
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);

    Similarity best = fitLeastSquares(model, from, to);
    double best_sum2 = 0.0;
    int best_count = countInliers(best, from, to, threshold2, nullptr, &best_sum2);
    for (int it = 0; it < kRansacIterations && best_count < int(n); ++it) {
        const std::size_t a = pick(rng), b = pick(rng);
        const double sep = std::hypot(from[a].x - from[b].x, from[a].y - from[b].y);
        if (a == b || sep < 4.0 * inlier_threshold)
            continue;
        const Similarity h = fitTwoPoints(model, from[a], from[b], to[a], to[b]);
        double sum2 = 0.0;
        const int count = countInliers(h, from, to, threshold2, nullptr, &sum2);
        if (count > best_count || (count == best_count && sum2 < best_sum2)) {
            best = h;
            best_count = count;
            best_sum2 = sum2;
        }
    }

    // Refine on the consensus set; a second round picks up points the sample missed.
    for (int round = 0; round < 2; ++round) {
        countInliers(best, from, to, threshold2, &result.inliers, nullptr);
        best = fitLeastSquares(model, from, to, &result.inliers);
    }
    result.motion = best;
    result.inlier_count = countInliers(best, from, to, threshold2, &result.inliers, nullptr);
    result.rms = rmsError(best, from, to, &result.inliers);
    return result;
}

} // namespace uavstab
