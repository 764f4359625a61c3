// The paper's hybrid mechanism: every `dwell` frames fit both the rigid and the
// similarity model, keep the one with the lower RMS error for the next `dwell` frames.
//
// Comparing the two fits' in-sample RMS would be meaningless: the similarity model has
// one more parameter, so on the same points its least-squares error is never higher and
// it would always win. We compare *held-out* error instead (2-fold cross-validation):
// each model is fitted on the even-numbered points and scored on the odd ones, and vice
// versa. Extra freedom that only fits noise then shows up as a higher held-out error.
// Similarity must also beat rigid by a margin (kSimilarityMargin): near a tie the
// cheaper, better-constrained rigid model is kept, as the paper prefers.
#pragma once

#include <cstdint>
#include <vector>

#include "uavstab/config.hpp"
#include "estimate/motion_model.hpp"

namespace uavstab {

struct HeldOutErrors {
    double rigid = 0.0;
    double similarity = 0.0;
};

class HybridModelSelector {
public:
    static constexpr double kSimilarityMargin = 0.05;

    HybridModelSelector(ModelChoice choice, int dwell);

    // The model to use for this frame. In hybrid mode the choice is re-made when the
    // dwell has run out, from the given matches (restricted to `use` when given).
    MotionModel select(const std::vector<Point2> &from, const std::vector<Point2> &to,
                       const std::vector<std::uint8_t> *use = nullptr);
    void reset();
    void setChoice(ModelChoice choice, int dwell);

    // Exposed for tests and statistics.
    static HeldOutErrors heldOutErrors(const std::vector<Point2> &from, const std::vector<Point2> &to,
                                       const std::vector<std::uint8_t> *use = nullptr);
    static MotionModel better(const HeldOutErrors &errors);

private:
    ModelChoice choice_ = ModelChoice::Hybrid;
    int dwell_ = 20;
    int frames_left_ = 0;  // frames the current hybrid choice is still held
    MotionModel current_ = MotionModel::Rigid;
};

} // namespace uavstab
