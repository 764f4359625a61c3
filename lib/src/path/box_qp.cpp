#include "path/box_qp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace uavstab {

namespace {
constexpr int K = BandedBoxQp::kBandwidth;
constexpr std::size_t kStride = K + 1;
constexpr signed char kFree = 0, kAtLower = -1, kAtUpper = 1;
} // namespace

void BandedBoxQp::resize(std::size_t n)
{
    n_ = n;
    band_.assign(n * kStride, 0.0);
    g_.assign(n, 0.0);
    lower_.assign(n, -std::numeric_limits<double>::infinity());
    upper_.assign(n, std::numeric_limits<double>::infinity());
}

void BandedBoxQp::addQ(std::size_t i, std::size_t j, double value)
{
    if (i < j)
        std::swap(i, j);
    band_[i * kStride + (i - j)] += value;
}

void BandedBoxQp::setBounds(std::size_t i, double lower, double upper)
{
    lower_[i] = lower;
    upper_[i] = std::max(lower, upper);
}

double BandedBoxQp::q(std::size_t i, std::size_t j) const
{
    if (i < j)
        std::swap(i, j);
    return i - j <= std::size_t(K) ? band_[i * kStride + (i - j)] : 0.0;
}

bool BandedBoxQp::solveFree(const std::vector<signed char> &state, std::vector<double> &x) const
{
    // Removing rows and columns of a banded matrix leaves it banded with the same width
    // (free indices within K of each other in the reduced order were within K before).
    std::vector<std::size_t> free;
    free.reserve(n_);
    for (std::size_t i = 0; i < n_; ++i)
        if (state[i] == kFree)
            free.push_back(i);
    const std::size_t m = free.size();
    if (m == 0)
        return true;

    std::vector<double> rhs(m), chol(m * kStride, 0.0);
    for (std::size_t a = 0; a < m; ++a) {
        const std::size_t i = free[a];
        double r = -g_[i];
        const std::size_t lo = i >= std::size_t(K) ? i - K : 0, hi = std::min(n_ - 1, i + K);
        for (std::size_t j = lo; j <= hi; ++j)
            if (state[j] != kFree)
                r -= q(i, j) * x[j];
        rhs[a] = r;
    }
    // Banded Cholesky, L stored like the band: chol[a * kStride + k] = L(a, a - k).
    for (std::size_t a = 0; a < m; ++a) {
        const std::size_t first = a >= std::size_t(K) ? a - K : 0;
        for (std::size_t b = first; b <= a; ++b) {
            double s = free[a] - free[b] <= std::size_t(K) ? q(free[a], free[b]) : 0.0;
            for (std::size_t c = first; c < b; ++c)
                if (b - c <= std::size_t(K))
                    s -= chol[a * kStride + (a - c)] * chol[b * kStride + (b - c)];
            if (a == b) {
                if (!(s > 0.0))
                    return false;
                chol[a * kStride] = std::sqrt(s);
            } else {
                chol[a * kStride + (a - b)] = s / chol[b * kStride];
            }
        }
    }
    // L y = rhs, then L' x = y.
    for (std::size_t a = 0; a < m; ++a) {
        double s = rhs[a];
        const std::size_t first = a >= std::size_t(K) ? a - K : 0;
        for (std::size_t c = first; c < a; ++c)
            s -= chol[a * kStride + (a - c)] * rhs[c];
        rhs[a] = s / chol[a * kStride];
    }
    for (std::size_t a = m; a-- > 0;) {
        double s = rhs[a];
        for (std::size_t c = a + 1; c < std::min(m, a + K + 1); ++c)
            s -= chol[c * kStride + (c - a)] * rhs[c];
        rhs[a] = s / chol[a * kStride];
    }
    for (std::size_t a = 0; a < m; ++a)
        x[free[a]] = rhs[a];
    return true;
}

BandedBoxQp::Result BandedBoxQp::solve() const
{
    Result result;
    result.x.assign(n_, 0.0);
    if (n_ == 0) {
        result.optimal = true;
        return result;
    }
    double scale = 1.0;
    for (std::size_t i = 0; i < n_; ++i)
        scale = std::max({scale, std::abs(g_[i]), std::abs(q(i, i))});
    const double dual_tolerance = 1e-12 * scale;
    auto primal_tolerance = [](double bound) { return 1e-9 * (1.0 + std::abs(bound)); };

    // Primal-dual active set: fix every violated bound and free every bound whose
    // multiplier has the wrong sign, re-solve, repeat. It usually ends in two or three
    // rounds; should it cycle, it goes on changing one variable at a time (the worst),
    // and after the limit it returns the last iterate clipped: feasible, nearly optimal.
    std::vector<signed char> state(n_, kFree);
    std::vector<double> &x = result.x;
    const int block_rounds = int(n_) + 5, limit = 4 * int(n_) + 20;
    for (int round = 0; round < limit; ++round) {
        for (std::size_t i = 0; i < n_; ++i)
            if (state[i] != kFree)
                x[i] = state[i] == kAtLower ? lower_[i] : upper_[i];
        if (!solveFree(state, x))
            break;  // not positive definite: fall through to the clip
        std::size_t worst = n_;
        double worst_amount = 0.0;
        std::vector<signed char> next = state;
        for (std::size_t i = 0; i < n_; ++i) {
            double amount = 0.0;
            signed char to = state[i];
            if (state[i] == kFree) {
                if (x[i] < lower_[i] - primal_tolerance(lower_[i])) {
                    amount = lower_[i] - x[i];
                    to = kAtLower;
                } else if (x[i] > upper_[i] + primal_tolerance(upper_[i])) {
                    amount = x[i] - upper_[i];
                    to = kAtUpper;
                }
            } else {
                double gradient = g_[i];
                const std::size_t lo = i >= std::size_t(K) ? i - K : 0, hi = std::min(n_ - 1, i + K);
                for (std::size_t j = lo; j <= hi; ++j)
                    gradient += q(i, j) * x[j];
                // At the lower bound the objective must not fall as x rises (gradient >= 0);
                // at the upper bound, not as it falls.
                if (state[i] == kAtLower && gradient < -dual_tolerance) {
                    amount = -gradient / std::max(q(i, i), 1e-300);
                    to = kFree;
                } else if (state[i] == kAtUpper && gradient > dual_tolerance) {
                    amount = gradient / std::max(q(i, i), 1e-300);
                    to = kFree;
                }
            }
            if (to != state[i]) {
                next[i] = to;
                if (amount > worst_amount) {
                    worst_amount = amount;
                    worst = i;
                }
            }
        }
        if (worst == n_) {
            result.optimal = true;
            break;
        }
        ++result.iterations;
        if (round < block_rounds) {
            state.swap(next);
        } else {
            state[worst] = next[worst];
        }
    }
    for (std::size_t i = 0; i < n_; ++i)
        x[i] = std::clamp(x[i], lower_[i], upper_[i]);
    return result;
}

} // namespace uavstab
