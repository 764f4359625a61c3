// A small dedicated solver for the path planner's quadratic programs.
//
//   minimise 1/2 x'Qx + g'x   subject to   lower <= x <= upper
//
// with Q symmetric positive definite and banded (every planner problem is: a quadratic
// data term plus squared first/second/third differences of the path, so Q couples a frame
// only with its three neighbours on each side). Why not a general solver (CLP, GLPK,
// OSQP): these problems have 1 to ~60 variables and only bounds, and one is solved per
// frame and per axis; an active-set method on a banded Cholesky factorisation solves them
// exactly in a few microseconds, deterministically, with no dependency and no tolerance
// that could show up as jitter between consecutive frames.
#pragma once

#include <cstddef>
#include <vector>

namespace uavstab {

class BandedBoxQp {
public:
    static constexpr int kBandwidth = 3;  // Q(i, j) = 0 for |i - j| > kBandwidth

    explicit BandedBoxQp(std::size_t n = 0) { resize(n); }
    // Sets the problem size and clears Q, g and the bounds (to +-infinity).
    void resize(std::size_t n);
    std::size_t size() const { return n_; }

    // Adds to Q(i, j) (and Q(j, i)); |i - j| <= kBandwidth.
    void addQ(std::size_t i, std::size_t j, double value);
    void addG(std::size_t i, double value) { g_[i] += value; }
    void setBounds(std::size_t i, double lower, double upper);

    struct Result {
        std::vector<double> x;  // always within the bounds
        int iterations = 0;     // active-set changes
        bool optimal = false;   // false: iteration limit; x is then the last iterate clipped
    };
    Result solve() const;

private:
    double q(std::size_t i, std::size_t j) const;  // Q(i, j), zero outside the band
    // Solves Q_FF x_F = -(g_F + Q_FA x_A) for the free variables, in place in x.
    bool solveFree(const std::vector<signed char> &state, std::vector<double> &x) const;

    std::size_t n_ = 0;
    std::vector<double> band_;  // band_[i * (kBandwidth + 1) + k] = Q(i, i - k)
    std::vector<double> g_, lower_, upper_;
};

} // namespace uavstab
