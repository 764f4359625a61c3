#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "estimate/motion_model.hpp"

using namespace uavstab;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

struct Points {
    std::vector<Point2> from, to;
};

// n points spread over a 640x360 frame, moved by `truth`, with Gaussian noise and a
// share of gross outliers (tracks on moving objects).
Points makePoints(const Similarity &truth, int n, double noise, double outlier_share, unsigned seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(-300, 300), uy(-170, 170), bad(-40, 40);
    std::normal_distribution<double> g(0, noise > 0 ? noise : 1e-12);
    Points p;
    for (int i = 0; i < n; ++i) {
        const Point2 a{ux(rng), uy(rng)};
        Point2 b = truth.apply(a);
        b.x += noise > 0 ? g(rng) : 0;
        b.y += noise > 0 ? g(rng) : 0;
        if (i < int(n * outlier_share)) {
            b.x += bad(rng) + 10;
            b.y += bad(rng) - 10;
        }
        p.from.push_back(a);
        p.to.push_back(b);
    }
    return p;
}

} // namespace

TEST(Similarity, ComposeAndInvert)
{
    const Similarity a{3, -2, 5 * kDeg, 1.02}, b{-7, 4, -2 * kDeg, 0.99};
    const Point2 p{10, -20};
    const Point2 ab = (a * b).apply(p), direct = a.apply(b.apply(p));
    EXPECT_NEAR(ab.x, direct.x, 1e-9);
    EXPECT_NEAR(ab.y, direct.y, 1e-9);
    EXPECT_TRUE((a * a.inverse()).isIdentity(1e-12));
    EXPECT_TRUE((a.inverse() * a).isIdentity(1e-12));
}

TEST(Similarity, PixelMatrixRotatesAboutTheCentre)
{
    const Similarity r{0, 0, 90 * kDeg, 1.0};
    const auto m = r.pixelMatrix(101, 51);  // centre (50, 25)
    EXPECT_NEAR(m[0] * 50 + m[1] * 25 + m[2], 50, 1e-9);
    EXPECT_NEAR(m[3] * 50 + m[4] * 25 + m[5], 25, 1e-9);
}

TEST(MotionModel, LeastSquaresRecoversRigidAndSimilarityExactly)
{
    for (const Similarity truth : {Similarity{4.5, -3.25, 1.5 * kDeg, 1.0}, Similarity{-12, 7, -3 * kDeg, 1.04}}) {
        const MotionModel model = truth.scale == 1.0 ? MotionModel::Rigid : MotionModel::Similarity;
        const Points p = makePoints(truth, 50, 0.0, 0.0, 7);
        const Similarity fit = fitLeastSquares(model, p.from, p.to);
        EXPECT_NEAR(fit.dx, truth.dx, 1e-6);
        EXPECT_NEAR(fit.dy, truth.dy, 1e-6);
        EXPECT_NEAR(fit.angle, truth.angle, 1e-9);
        EXPECT_NEAR(fit.scale, truth.scale, 1e-9);
        EXPECT_LT(rmsError(fit, p.from, p.to), 1e-6);
    }
}

TEST(MotionModel, RobustFitIgnoresOutliersOnCleanPoints)
{
    for (const Similarity truth : {Similarity{4.5, -3.25, 1.5 * kDeg, 1.0}, Similarity{-12, 7, -3 * kDeg, 1.04}}) {
        const MotionModel model = truth.scale == 1.0 ? MotionModel::Rigid : MotionModel::Similarity;
        const Points p = makePoints(truth, 60, 0.0, 0.3, 11);
        const RobustFit fit = fitRobust(model, p.from, p.to, 1.0);
        EXPECT_NEAR(fit.motion.dx, truth.dx, 0.05);
        EXPECT_NEAR(fit.motion.dy, truth.dy, 0.05);
        EXPECT_NEAR(fit.motion.angle / kDeg, truth.angle / kDeg, 0.01);
        EXPECT_NEAR(fit.motion.scale, truth.scale, 1e-4);
        EXPECT_EQ(fit.inlier_count, 42);  // exactly the 70 % clean points
    }
}

TEST(MotionModel, RobustFitOnNoisyPointsWithOutliers)
{
    const Similarity truth{6, 2, -1 * kDeg, 1.01};
    const Points p = makePoints(truth, 80, 0.3, 0.25, 3);
    const RobustFit fit = fitRobust(MotionModel::Similarity, p.from, p.to, 1.5);
    EXPECT_NEAR(fit.motion.dx, truth.dx, 0.15);
    EXPECT_NEAR(fit.motion.dy, truth.dy, 0.15);
    EXPECT_NEAR(fit.motion.angle / kDeg, truth.angle / kDeg, 0.05);
    EXPECT_NEAR(fit.motion.scale, truth.scale, 1e-3);
    EXPECT_GE(fit.inlier_count, 55);
    EXPECT_LT(fit.rms, 0.6);
    // The plain least-squares fit is pulled off by the outliers: the robust step matters.
    const Similarity naive = fitLeastSquares(MotionModel::Similarity, p.from, p.to);
    EXPECT_GT(std::hypot(naive.dx - truth.dx, naive.dy - truth.dy), 1.0);
}

TEST(MotionModel, DegenerateInputDoesNotBlowUp)
{
    const std::vector<Point2> none;
    EXPECT_TRUE(fitLeastSquares(MotionModel::Similarity, none, none).isIdentity());
    const std::vector<Point2> same{{1, 1}, {1, 1}, {1, 1}}, moved{{3, 1}, {3, 1}, {3, 1}};
    const Similarity t = fitLeastSquares(MotionModel::Similarity, same, moved);
    EXPECT_NEAR(t.dx, 2, 1e-9);
    EXPECT_NEAR(t.scale, 1, 1e-9);
    const RobustFit r = fitRobust(MotionModel::Rigid, same, moved, 1.0);
    EXPECT_TRUE(std::isfinite(r.motion.dx));
}
