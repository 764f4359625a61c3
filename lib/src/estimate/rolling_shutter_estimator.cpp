#include "estimate/rolling_shutter_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Dense>

namespace uavstab {

namespace {

constexpr int kUnknownsPerBand = 3;  // shift x, shift y, turn (px at half the width)
constexpr int kRounds = 3;           // reweighting rounds of the robust fit
constexpr int kMaxTrackBands = 7;    // bands a track's weights are taken over (its nearest +-3)
constexpr double kTukeyScale = 2.0;  // Tukey's weight falls to zero at this many times `robust`
// ...and at twice that after the first round: a large wobble leaves the plain fit far from
// many tracks, which a tight cut would drop before the bands could explain them.
constexpr double kFirstRoundWidening = 2.0;
// Automatic mode: the correction grows from nothing at the threshold to all of it at
// (1 + kRamp) times the threshold (at 1 + 1, a flight with a 0.56 px wobble kept 0.29x of it,
// at 1 + 0.5 0.19x).
constexpr double kRamp = 0.5;
// The bend is held to this many times the level of its frame-to-frame changes (below).
constexpr double kMaxBendPerChange = 8.0;
// The readout estimate: a regression over this many frames at least, held
// for the rest of the stream once its standard error is kReadoutError * (1 - hold) or less.
constexpr int kReadoutMinSamples = 30;
constexpr double kReadoutError = 0.1;
constexpr double kReadoutHoldConfidence = 0.8;
// A held estimate below this share of the frame time: a global shutter.
constexpr double kGlobalShutter = 0.1;

struct Bands {
    int count;
    double first, spacing;  // centred row of band 0's centre, rows between centres
    double centre(int b) const { return first + spacing * b; }
};

Bands bandsFor(int height, int count)
{
    const double spacing = double(height) / count;
    return {count, -0.5 * (height - 1) + 0.5 * spacing, spacing};
}

// Gaussian weights of the bands at row y, summing to one: each point's motion is a smooth
// blend of its neighbouring bands' motions.
void bandWeights(const Bands &bands, double y, std::vector<double> &w)
{
    w.resize(std::size_t(bands.count));
    double sum = 0.0;
    for (int b = 0; b < bands.count; ++b) {
        const double d = (y - bands.centre(b)) / bands.spacing;
        w[std::size_t(b)] = std::exp(-0.5 * d * d);
        sum += w[std::size_t(b)];
    }
    for (double &v : w)
        v /= sum;
}

// Band b's offset (x, y, turn) as the transform mid-exposure -> captured: a turn about the
// band's centre row, then the shift.
Similarity offsetTransform(double x, double y, double turn_px, double half_width, double centre)
{
    const double angle = turn_px / half_width;
    // R(u - c) + c + s with c = (0, centre).
    return {x + std::sin(angle) * centre, y + centre * (1.0 - std::cos(angle)), angle, 1.0};
}

Point2 offsetAt(const std::vector<double> &o, const Bands &bands, double half_width, Point2 p)
{
    // Linear between band centres, as RowMotion::at.
    const double t = std::clamp((p.y - bands.first) / bands.spacing, 0.0, double(bands.count - 1));
    const int b = std::min(int(t), bands.count - 2 < 0 ? 0 : bands.count - 2);
    const double f = bands.count > 1 ? t - b : 0.0;
    double v[kUnknownsPerBand];
    for (int k = 0; k < kUnknownsPerBand; ++k) {
        const double a = o[std::size_t(b * kUnknownsPerBand + k)];
        const double c = bands.count > 1 ? o[std::size_t((b + 1) * kUnknownsPerBand + k)] : a;
        v[k] = a + f * (c - a);
    }
    const double centre = bands.first + bands.spacing * t;
    const double turn = v[2] / half_width;
    return {v[0] - turn * (p.y - centre), v[1] + turn * p.x};
}

// The bands' shifts, RMS over bands (px): how far the rows bend.
double bendRms(const std::vector<double> &o, int band_count)
{
    double sum2 = 0.0;
    for (int b = 0; b < band_count; ++b)
        sum2 += std::pow(o[std::size_t(b * kUnknownsPerBand)], 2) + std::pow(o[std::size_t(b * kUnknownsPerBand + 1)], 2);
    return std::sqrt(sum2 / band_count);
}

} // namespace

Similarity RowMotion::at(double y) const
{
    if (rows.empty())
        return Similarity::identity();
    if (y <= rows.front())
        return offsets.front();
    if (y >= rows.back())
        return offsets.back();
    const std::size_t b = std::size_t(std::upper_bound(rows.begin(), rows.end(), y) - rows.begin()) - 1;
    const double f = (y - rows[b]) / (rows[b + 1] - rows[b]);
    const Similarity &a = offsets[b], &c = offsets[b + 1];
    return {a.dx + f * (c.dx - a.dx), a.dy + f * (c.dy - a.dy), a.angle + f * (c.angle - a.angle),
            a.scale + f * (c.scale - a.scale)};
}

RollingShutterEstimator::RollingShutterEstimator(const Settings &settings) : settings_(settings) {}

void RollingShutterEstimator::setSettings(const Settings &settings)
{
    settings_ = settings;
}

void RollingShutterEstimator::reset()
{
    offsets_.clear();
    mean_velocity_ = Similarity::identity();
    level_ = 0.0;
    frames_ = 0;
    applied_ = false;
    previous_rows_ = {};
    readout_fit_.has_previous = false;
}

void RollingShutterEstimator::restartStream()
{
    reset();
    evidence_ = 0.0;
    evidence_frames_ = 0;
    latched_ = false;
    readout_fit_ = {};
}

RowMotion RollingShutterEstimator::estimate(const std::vector<Point2> &previous, const std::vector<Point2> &current,
                                            const Similarity &motion, int width, int height)
{
    const int band_count = std::clamp(settings_.bands, 1, std::max(1, height / 8));
    const Bands bands = bandsFor(height, band_count);
    const std::size_t unknowns = std::size_t(band_count * kUnknownsPerBand);
    if (width != width_ || height != height_) {
        restartStream();
        width_ = width;
        height_ = height;
    } else if (offsets_.size() != unknowns) {
        reset();
        width_ = width;
        height_ = height;
    }
    if (offsets_.empty())
        offsets_.assign(unknowns, 0.0);
    const double half_width = 0.5 * width;
    const double px640 = double(width) / 640.0;
    const std::size_t n = std::min(previous.size(), current.size());
    const bool automatic = settings_.automatic && settings_.readout <= 0.0;

    // What the similarity leaves: previous - motion(current), per track. A point sits on
    // other rows in the previous frame when the camera moves, where that frame's offsets
    // differ: taking them there leaves this frame's offsets minus the previous frame's at
    // the same rows, the differences the bands fit (a vibration near a multiple of the
    // frame rate bends consecutive frames alike, and these differences are all there is).
    std::vector<Point2> residual(n);
    for (std::size_t i = 0; i < n; ++i) {
        const Point2 m = motion.apply(current[i]);
        const Point2 there = offsetAt(offsets_, bands, half_width, previous[i]);
        const Point2 here = offsetAt(offsets_, bands, half_width, current[i]);
        residual[i] = {previous[i].x - m.x - (there.x - here.x), previous[i].y - m.y - (there.y - here.y)};
    }

    // Tracks the fit may use: not an overlay's (the frame's transform moves them, they stay
    // where they are on the screen; the tracks exclude_static drops never get here). The
    // frame fit's outliers get no weight from the robust rounds below; a hard cut on the
    // frame fit's residual would lose the rows a large wobble moved furthest for good
    // (the 47 Hz flight kept 0.69x of its wobble with one, 0.28x without).
    const double outlier = settings_.robust * px640;
    std::vector<std::uint8_t> eligible(n, 0);
    std::size_t eligible_count = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const Point2 m = motion.apply(current[i]);
        const double expected = std::hypot(m.x - current[i].x, m.y - current[i].y);
        const double moved = std::hypot(previous[i].x - current[i].x, previous[i].y - current[i].y);
        eligible[i] = !(expected > settings_.static_motion * px640 && moved < 0.25 * expected);
        eligible_count += eligible[i];
    }
    // Too few tracks to tell bands apart: the offsets fade out.
    const bool enough = eligible_count >= std::size_t(2 * band_count);

    // The bands' motion differences z (this frame's offsets minus the previous frame's,
    // negated), by robust weighted least squares.
    Eigen::VectorXd z = Eigen::VectorXd::Zero(Eigen::Index(unknowns));
    std::vector<double> robust_weight(n, 1.0);
    double difference_rms = 0.0;
    double explained = 0.0;  // the held-out tracks' residual the bands remove (share)
    bool explained_measured = false;
    if (enough) {
        // Each track's band weights (those that matter: a band more than three spacings away
        // gets under 1 %), computed once for all rounds.
        struct TrackBands {
            int lo = 0, hi = -1;
            double w[kMaxTrackBands];
        };
        std::vector<TrackBands> track_bands(n);
        std::vector<double> w;
        for (std::size_t i = 0; i < n; ++i) {
            bandWeights(bands, current[i].y, w);
            TrackBands &t = track_bands[i];
            const int nearest = std::clamp(int(std::lround((current[i].y - bands.first) / bands.spacing)), 0,
                                           band_count - 1);
            t.lo = std::max(0, nearest - kMaxTrackBands / 2);
            t.hi = std::min(band_count - 1, t.lo + kMaxTrackBands - 1);
            for (int b = t.lo; b <= t.hi; ++b)
                t.w[b - t.lo] = w[std::size_t(b)];
        }
        for (std::size_t i = 0; i < n; ++i)
            robust_weight[i] = eligible[i] ? 1.0 : 0.0;
        const Eigen::Index size = Eigen::Index(unknowns);
        // One track's terms of the normal equations. Its motion model: sum over bands of
        // w_b (x_b, y_b) + w_b turn_b (tx_b, ty), tx_b = -(y - centre_b) / half_width,
        // ty = x / half_width; the terms band by band (gx gx^T + gy gy^T, written out).
        auto accumulate = [&](std::size_t i, double rw, Eigen::MatrixXd &a, Eigen::VectorXd &rhs) {
            const Point2 p = current[i];
            const TrackBands &t = track_bands[i];
            const double ty = p.x / half_width;
            for (int b = t.lo; b <= t.hi; ++b) {
                const double wb = rw * t.w[b - t.lo];
                const double txb = -(p.y - bands.centre(b)) / half_width;
                const Eigen::Index kb = b * kUnknownsPerBand;
                rhs[kb] += wb * residual[i].x;
                rhs[kb + 1] += wb * residual[i].y;
                rhs[kb + 2] += wb * (txb * residual[i].x + ty * residual[i].y);
                for (int c = t.lo; c <= t.hi; ++c) {
                    const double wbc = wb * t.w[c - t.lo];
                    const double txc = -(p.y - bands.centre(c)) / half_width;
                    const Eigen::Index kc = c * kUnknownsPerBand;
                    a(kb, kc) += wbc;
                    a(kb, kc + 2) += wbc * txc;
                    a(kb + 1, kc + 1) += wbc;
                    a(kb + 1, kc + 2) += wbc * ty;
                    a(kb + 2, kc) += wbc * txb;
                    a(kb + 2, kc + 1) += wbc * ty;
                    a(kb + 2, kc + 2) += wbc * (txb * txc + ty * ty);
                }
            }
        };
        // The penalties, in proportion to the weight of the tracks fitted.
        auto solve = [&](Eigen::MatrixXd a, const Eigen::VectorXd &rhs, double weight_sum) {
            const double smooth = settings_.band_smoothness * weight_sum, ridge = settings_.band_ridge * weight_sum;
            for (int b = 0; b < band_count; ++b)
                for (int k = 0; k < kUnknownsPerBand; ++k) {
                    const Eigen::Index i = b * kUnknownsPerBand + k;
                    a(i, i) += ridge;
                    if (b + 1 < band_count) {
                        const Eigen::Index j = i + kUnknownsPerBand;
                        a(i, i) += smooth;
                        a(j, j) += smooth;
                        a(i, j) -= smooth;
                        a(j, i) -= smooth;
                    }
                }
            return Eigen::VectorXd(a.ldlt().solve(rhs));
        };
        for (int round = 0; round < kRounds; ++round) {
            Eigen::MatrixXd a = Eigen::MatrixXd::Zero(size, size);
            Eigen::VectorXd rhs = Eigen::VectorXd::Zero(size);
            double weight_sum = 0.0;
            if (round == 0) {
                // Two halves (every other eligible track), each fitted on its own and judged
                // on the other: the evidence that the bands describe the scene (below).
                Eigen::MatrixXd half_a[2] = {a, a};
                Eigen::VectorXd half_rhs[2] = {rhs, rhs};
                double half_sum[2] = {0.0, 0.0};
                std::vector<std::uint8_t> half(n, 0);
                int next = 0;
                for (std::size_t i = 0; i < n; ++i)
                    if (eligible[i]) {
                        half[i] = std::uint8_t(next);
                        accumulate(i, 1.0, half_a[next], half_rhs[next]);
                        half_sum[next] += 1.0;
                        next ^= 1;
                    }
                a = half_a[0] + half_a[1];
                rhs = half_rhs[0] + half_rhs[1];
                weight_sum = half_sum[0] + half_sum[1];
                if (half_sum[1] >= double(band_count)) {
                    const Eigen::VectorXd z_half[2] = {solve(half_a[0], half_rhs[0], half_sum[0]),
                                                       solve(half_a[1], half_rhs[1], half_sum[1])};
                    const std::vector<double> motion_half[2] = {
                        std::vector<double>(z_half[0].data(), z_half[0].data() + z_half[0].size()),
                        std::vector<double>(z_half[1].data(), z_half[1].data() + z_half[1].size())};
                    // Errors capped (at the robust weights' reach): one wild track does not decide.
                    const double cap = std::pow(kTukeyScale * outlier, 2);
                    double before = 0.0, after = 0.0;
                    for (std::size_t i = 0; i < n; ++i) {
                        if (!eligible[i])
                            continue;
                        const Point2 m = offsetAt(motion_half[half[i] ^ 1], bands, half_width, current[i]);
                        before += std::min(cap, residual[i].x * residual[i].x + residual[i].y * residual[i].y);
                        after += std::min(cap, std::pow(residual[i].x - m.x, 2) + std::pow(residual[i].y - m.y, 2));
                    }
                    if (before > 0.0) {
                        explained = 1.0 - after / before;
                        explained_measured = true;
                    }
                }
            } else {
                for (std::size_t i = 0; i < n; ++i)
                    if (robust_weight[i] > 0.0) {
                        accumulate(i, robust_weight[i], a, rhs);
                        weight_sum += robust_weight[i];
                    }
            }
            z = solve(a, rhs, weight_sum);
            // Reweight by each track's distance from the band model: Tukey's biweight, so
            // that tracks the bands cannot explain (an overlay, a moving object) drop out.
            const std::vector<double> band_motion(z.data(), z.data() + z.size());
            double sx = 0.0, sy = 0.0, sxx = 0.0, sum = 0.0;
            for (std::size_t i = 0; i < n; ++i) {
                if (!eligible[i])
                    continue;
                const Point2 model_i = offsetAt(band_motion, bands, half_width, current[i]);
                const double r = std::hypot(residual[i].x - model_i.x, residual[i].y - model_i.y);
                const double u = r / (kTukeyScale * outlier * (round == 0 ? kFirstRoundWidening : 1.0));
                robust_weight[i] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
                sx += model_i.x;
                sy += model_i.y;
                sxx += model_i.x * model_i.x + model_i.y * model_i.y;
                sum += 1.0;
            }
            // The size of the bands' motion, less what they share (a shift the frame fit
            // left over is no wobble).
            difference_rms = std::sqrt(std::max(0.0, sxx / sum - (sx * sx + sy * sy) / (sum * sum)));
            // Footage without wobble (the common case): the plain fit already shows the bands
            // far below the threshold, and robust rounds would not change that.
            const double calm = 0.5 * settings_.threshold;
            if (automatic && !latched_ && level_ < calm && difference_rms / px640 < calm)
                break;
        }
    }

    // This frame's offsets: the previous frame's, faded, less the differences.
    std::vector<double> offsets(unknowns);
    for (std::size_t k = 0; k < unknowns; ++k)
        offsets[k] = settings_.leak * offsets_[k] - (enough ? z[Eigen::Index(k)] : 0.0);
    // The middle row is the frame's mid-exposure: it stays where it is.
    const Point2 mid_shift = offsetAt(offsets, bands, half_width, {0.0, 0.0});
    {
        const double t = std::clamp((0.0 - bands.first) / bands.spacing, 0.0, double(band_count - 1));
        const int b = std::min(int(t), std::max(0, band_count - 2));
        const double f = band_count > 1 ? t - b : 0.0;
        const double turn0 = offsets[std::size_t(b * 3 + 2)];
        const double turn1 = band_count > 1 ? offsets[std::size_t((b + 1) * 3 + 2)] : turn0;
        const double mid_turn = turn0 + f * (turn1 - turn0);
        for (int c = 0; c < band_count; ++c) {
            // Removing a turn about the frame's centre shifts each band's centre row.
            offsets[std::size_t(c * 3 + 0)] -= mid_shift.x - mid_turn / half_width * bands.centre(c);
            offsets[std::size_t(c * 3 + 1)] -= mid_shift.y;
            offsets[std::size_t(c * 3 + 2)] -= mid_turn;
        }
    }

    // How much to apply: all of it when the readout is known or the mode is forced, else
    // in proportion to how far the bands' residual motion stands above the threshold.
    ++frames_;
    const double alpha = 1.0 / double(std::min(frames_, std::max(1, settings_.settle)));
    level_ += alpha * (difference_rms / px640 - level_);
    // The stream's decision: the evidence (a frame without enough tracks counts as none)
    // averaged over twice the settling time, switched with a margin.
    ++evidence_frames_;
    const double evidence_alpha = 1.0 / double(std::min(evidence_frames_, std::max(1, 2 * settings_.settle)));
    evidence_ += evidence_alpha * ((explained_measured ? explained : 0.0) - evidence_);
    if (automatic) {
        // A stream whose readout is known to be (near) zero has no rolling shutter to correct.
        const bool global_shutter = readoutConfidence() >= kReadoutHoldConfidence && readout() < kGlobalShutter;
        if (!latched_)
            latched_ = evidence_frames_ >= settings_.decide_frames && evidence_ >= settings_.evidence_on &&
                       level_ >= settings_.threshold && !global_shutter;
        else
            latched_ = evidence_ >= settings_.evidence_off && level_ >= 0.5 * settings_.threshold;
    }
    if (enough && settings_.readout <= 0.0)
        updateReadout(std::vector<double>(z.data(), z.data() + z.size()), motion, band_count, height);
    // A bend far larger than the changes it was summed from is not a vibration's: a bias
    // that repeats from frame to frame (parallax, a moving object the robust weights kept)
    // adds up in the leaky sum. It is held to kMaxBendPerChange times the changes' level
    // (the AR.Drone clip: 11 px of bend reported without it, ITF 0.29 dB below off; a
    // vibration beating at 0.8 Hz with 30 fps frames reaches 6 times).
    {
        const double bend = bendRms(offsets, band_count), limit = kMaxBendPerChange * level_ * px640;
        if (bend > limit && bend > 0.0) {
            for (double &v : offsets)
                v *= limit / bend;
        }
    }
    const std::vector<double> previous_offsets = std::move(offsets_);
    offsets_ = offsets;
    double gain = 1.0;
    if (automatic)
        gain = latched_ ? std::clamp((level_ - settings_.threshold) / std::max(1e-9, kRamp * settings_.threshold), 0.0,
                                     1.0)
                        : 0.0;
    std::vector<double> applied(unknowns);
    for (std::size_t k = 0; k < unknowns; ++k)
        applied[k] = gain * offsets[k];
    // A known readout: the skew of a camera moving at its mean speed. `motion` takes this
    // frame's points to the previous frame's, so its shift is the camera's velocity; a row
    // read later sees the camera further on, the picture further back. The leaky sum above
    // follows the skew's changes and forgets its mean at the rate it leaks: what it forgets
    // is the mean velocity's skew, an average that leaks in at the same rate.
    if (settings_.readout > 0.0 && height > 1) {
        const double keep = settings_.leak;
        mean_velocity_ = {keep * mean_velocity_.dx + (1.0 - keep) * motion.dx,
                          keep * mean_velocity_.dy + (1.0 - keep) * motion.dy,
                          keep * mean_velocity_.angle + (1.0 - keep) * motion.angle, 1.0};
        const double rho = settings_.readout / double(height);
        for (int b = 0; b < band_count; ++b) {
            const double tau = rho * bands.centre(b);         // frames after mid-exposure
            const double turn = -mean_velocity_.angle * tau;  // radians
            applied[std::size_t(b * 3 + 0)] += -mean_velocity_.dx * tau - turn * bands.centre(b);
            applied[std::size_t(b * 3 + 1)] += -mean_velocity_.dy * tau;
            applied[std::size_t(b * 3 + 2)] += turn * half_width;
        }
    }

    RowMotion result;
    bool any = false;
    for (double v : applied)
        any = any || std::abs(v) > 1e-6;
    if (any) {
        for (int b = 0; b < band_count; ++b) {
            result.rows.push_back(bands.centre(b));
            result.offsets.push_back(offsetTransform(applied[std::size_t(b * 3)], applied[std::size_t(b * 3 + 1)],
                                                     applied[std::size_t(b * 3 + 2)], half_width, bands.centre(b)));
        }
        result.wobble = bendRms(applied, band_count);
    }
    // Switched on at this frame: the previous frame's rows, as they would have been
    // corrected, so that the motion between the two mid-exposures is not a jump.
    previous_rows_ = {};
    if (any && !applied_ && previous_offsets.size() == unknowns) {
        std::vector<double> before(unknowns);
        for (std::size_t k = 0; k < unknowns; ++k)
            before[k] = gain * previous_offsets[k];
        for (int b = 0; b < band_count; ++b) {
            previous_rows_.rows.push_back(bands.centre(b));
            previous_rows_.offsets.push_back(offsetTransform(before[std::size_t(b * 3)], before[std::size_t(b * 3 + 1)],
                                                             before[std::size_t(b * 3 + 2)], half_width,
                                                             bands.centre(b)));
        }
        previous_rows_.wobble = bendRms(before, band_count);
    }
    applied_ = any;
    return result;
}

void RollingShutterEstimator::updateReadout(const std::vector<double> &z, const Similarity &motion, int band_count,
                                            int height)
{
    // A camera whose horizontal speed changes by dv between frames changes the skew of its
    // rows: the row read at time tau after the mid-exposure moves by -dv * tau, tau = readout
    // * row / height. The bands' differences z (this frame's offsets minus the previous
    // frame's, negated) then hold dv * readout / height per row; that skew, regressed on dv
    // over the stream, gives the readout. The frame's similarity took up the turn half of
    // it, and the bands hold the rest (x growing with the row, and y with the column in
    // their turns). A vertical skew stretches the rows, which the similarity's scale and
    // the bands share in proportions that depend on the scene: it is not used. A
    // vibration's bend between frames does not follow dv, and stays as noise (it keeps
    // the estimate from being sure on vibrating flights: bench_rolling_shutter.cpp).
    ReadoutFit &f = readout_fit_;
    if (f.has_previous && band_count > 2) {
        const Bands bands = bandsFor(height, band_count);
        double cc = 0.0, cx = 0.0, turn = 0.0;
        for (int b = 0; b < band_count; ++b) {
            const double c = bands.centre(b);
            cc += c * c;
            cx += c * z[std::size_t(b * kUnknownsPerBand)];
            turn += z[std::size_t(b * kUnknownsPerBand + 2)] / (0.5 * width_);
        }
        turn /= band_count;
        const double dvx = motion.dx - f.previous_motion.dx;
        const double sx = (cx / cc + turn) * height;
        if (std::isfinite(sx) && std::abs(dvx) < 0.25 * height) {
            f.sxy += sx * dvx;
            f.sxx += dvx * dvx;
            f.syy += sx * sx;
            ++f.samples;
        }
        if (f.samples >= kReadoutMinSamples && f.sxx > 0.0 && f.confidence < kReadoutHoldConfidence) {
            const double estimate = f.sxy / f.sxx;
            const double variance = std::max(0.0, f.syy - estimate * f.sxy) / double(f.samples - 1);
            const double error = std::sqrt(variance / f.sxx);
            f.confidence = std::clamp(1.0 - error / kReadoutError, 0.0, 1.0);
            f.held = std::clamp(estimate, 0.0, 1.0);
        }
    }
    f.previous_motion = motion;
    f.has_previous = true;
}

double RollingShutterEstimator::readout() const
{
    if (settings_.readout > 0.0)
        return settings_.readout;
    return readout_fit_.confidence >= kReadoutHoldConfidence ? readout_fit_.held : 0.0;
}

double RollingShutterEstimator::readoutConfidence() const
{
    return settings_.readout > 0.0 ? 1.0 : readout_fit_.confidence;
}

} // namespace uavstab
