#include "estimate/hybrid_selector.hpp"

#include <cmath>

namespace uavstab {

HybridModelSelector::HybridModelSelector(ModelChoice choice, int dwell)
{
    setChoice(choice, dwell);
}

void HybridModelSelector::setChoice(ModelChoice choice, int dwell)
{
    if (choice != choice_ || dwell != dwell_)
        frames_left_ = 0;
    choice_ = choice;
    dwell_ = dwell < 1 ? 1 : dwell;
}

void HybridModelSelector::reset()
{
    frames_left_ = 0;
    current_ = MotionModel::Rigid;
}

MotionModel HybridModelSelector::select(const std::vector<Point2> &from, const std::vector<Point2> &to,
                                        const std::vector<std::uint8_t> *use)
{
    if (choice_ == ModelChoice::Rigid)
        return MotionModel::Rigid;
    if (choice_ == ModelChoice::Similarity)
        return MotionModel::Similarity;
    if (frames_left_ <= 0) {
        current_ = better(heldOutErrors(from, to, use));
        frames_left_ = dwell_;
    }
    --frames_left_;
    return current_;
}

HeldOutErrors HybridModelSelector::heldOutErrors(const std::vector<Point2> &from, const std::vector<Point2> &to,
                                                 const std::vector<std::uint8_t> *use)
{
    std::vector<std::uint8_t> even(from.size(), 0), odd(from.size(), 0);
    int k = 0;
    for (std::size_t i = 0; i < from.size(); ++i) {
        if (use && !(*use)[i])
            continue;
        (k++ % 2 == 0 ? even : odd)[i] = 1;
    }
    HeldOutErrors e;
    if (k < 6)  // too few points to hold any out: no evidence for the extra parameter
        return e;
    for (MotionModel model : {MotionModel::Rigid, MotionModel::Similarity}) {
        const double a = rmsError(fitLeastSquares(model, from, to, &even), from, to, &odd);
        const double b = rmsError(fitLeastSquares(model, from, to, &odd), from, to, &even);
        const double held_out = std::sqrt(0.5 * (a * a + b * b));
        (model == MotionModel::Rigid ? e.rigid : e.similarity) = held_out;
    }
    return e;
}

MotionModel HybridModelSelector::better(const HeldOutErrors &errors)
{
    return errors.similarity < (1.0 - kSimilarityMargin) * errors.rigid ? MotionModel::Similarity
                                                                         : MotionModel::Rigid;
}

} // namespace uavstab
