#include <gtest/gtest.h>

#include <random>

#include "estimate/hybrid_selector.hpp"

using namespace uavstab;

namespace {

struct Points {
    std::vector<Point2> from, to;
};

Points moved(const Similarity &m, unsigned seed, double noise = 0.1, int n = 50)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(-280, 280), uy(-150, 150);
    std::normal_distribution<double> g(0, noise);
    Points p;
    for (int i = 0; i < n; ++i) {
        const Point2 a{ux(rng), uy(rng)};
        const Point2 b = m.apply(a);
        p.from.push_back(a);
        p.to.push_back({b.x + g(rng), b.y + g(rng)});
    }
    return p;
}

} // namespace

TEST(HybridSelector, PicksRigidOnPureRigidMotion)
{
    int rigid = 0;
    for (unsigned seed = 1; seed <= 50; ++seed) {
        const Points p = moved({3, -2, 0.01, 1.0}, seed);
        rigid += HybridModelSelector::better(HybridModelSelector::heldOutErrors(p.from, p.to)) == MotionModel::Rigid;
    }
    // The margin makes a spurious similarity choice on pure rigid motion rare.
    EXPECT_GE(rigid, 45);
}

TEST(HybridSelector, PicksSimilarityUnderZoom)
{
    for (unsigned seed = 1; seed <= 20; ++seed) {
        const Points p = moved({3, -2, 0.01, 1.01}, seed);
        const HeldOutErrors e = HybridModelSelector::heldOutErrors(p.from, p.to);
        EXPECT_LT(e.similarity, e.rigid);
        EXPECT_EQ(HybridModelSelector::better(e), MotionModel::Similarity);
    }
}

TEST(HybridSelector, HoldsItsChoiceForTheDwell)
{
    HybridModelSelector selector(ModelChoice::Hybrid, 20);
    const Points rigid = moved({1, 1, 0.0, 1.0}, 3), zoom = moved({1, 1, 0.0, 1.02}, 4);
    EXPECT_EQ(selector.select(rigid.from, rigid.to), MotionModel::Rigid);
    // The motion turns into a zoom, but the choice is kept for the rest of the dwell...
    for (int i = 1; i < 20; ++i)
        EXPECT_EQ(selector.select(zoom.from, zoom.to), MotionModel::Rigid) << "frame " << i;
    // ...and re-made when it runs out.
    EXPECT_EQ(selector.select(zoom.from, zoom.to), MotionModel::Similarity);
    for (int i = 1; i < 20; ++i)
        EXPECT_EQ(selector.select(rigid.from, rigid.to), MotionModel::Similarity);
    EXPECT_EQ(selector.select(rigid.from, rigid.to), MotionModel::Rigid);
}

TEST(HybridSelector, FixedChoicesIgnoreThePoints)
{
    const Points zoom = moved({1, 1, 0.0, 1.02}, 4);
    HybridModelSelector rigid(ModelChoice::Rigid, 20), similarity(ModelChoice::Similarity, 20);
    EXPECT_EQ(rigid.select(zoom.from, zoom.to), MotionModel::Rigid);
    const Points still = moved({0, 0, 0.0, 1.0}, 4);
    EXPECT_EQ(similarity.select(still.from, still.to), MotionModel::Similarity);
}

TEST(HybridSelector, UsesOnlySelectedPoints)
{
    Points p = moved({2, 0, 0.0, 1.02}, 9);
    std::vector<std::uint8_t> use(p.from.size(), 1);
    // Gross outliers outside the selection must not matter.
    for (std::size_t i = 0; i < 10; ++i) {
        p.to[i].x += 50;
        use[i] = 0;
    }
    EXPECT_EQ(HybridModelSelector::better(HybridModelSelector::heldOutErrors(p.from, p.to, &use)),
              MotionModel::Similarity);
}
