// Quality of ours and of the peers on the same input:
//   synthetic  ShakyFlight "hover" clips (the default, slowly drifting Lissajous flight) with
//              known true motion (seeds x moving objects x 360p/720p): residual jitter (px),
//              coverage, zoom, distortion
//   manoeuvre  ShakyFlight manoeuvre flights (hover, accelerating pans, a yaw turn, stops, a
//              climb): error against the intended shake-free path (px), residual jitter beside
//   drone      the real drone clip (../shared/data/aerial_drone_nadir_steady_1920x1080.mp4) with
//              known synthetic shake added: the same, plus stability score and ITF
//   strong     hover flights at 720p under strong shake (x0.5, x1, x2 of bench_path.cpp's
//              "strong720") and with 47 Hz propeller vibration: residual jitter against
//              vid.stab's, coverage, zoom
//   real       the real clips in ../shared/data: stability score (Liu et al. 2013), ITF,
//              coverage and zoom
// Every one of our configurations (oursTable()) runs at every delay of kDelays; the peers are
// offline (no delay) and appear once beside them. Output motion is measured with ORB + RANSAC
// (registration.hpp), independently of the stabilizer's tracker; ours is also cross-checked
// against its own FrameStats.
//
//   uavstab-bench-quality --out DIR [--quick] [--data DIR] [--only synthetic|manoeuvre|drone|strong|real]...
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <dirent.h>
#include <functional>
#include <future>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "common.hpp"
#include "jitter_metrics.hpp"
#include "plot.hpp"
#include "registration.hpp"
#include "shaky_flight.hpp"
#include "render/frame_warper.hpp"
#include "uavstab/stabilizer.hpp"

using namespace uavstab;
using namespace bench;

namespace {

constexpr double kPi = 3.14159265358979323846;
const double kNaN = std::nan("");

// ---- clips -----------------------------------------------------------------------------

struct Clip {
    std::string name;   // short id (file names, keys)
    std::string label;  // for tables
    std::string group;  // synthetic clips are averaged per group
    int width = 0, height = 0;
    int fps_num = 30, fps_den = 1;
    std::vector<FrameBuffer> frames;   // I420
    std::vector<Similarity> truth;     // frame (centred) -> world; empty when unknown
    std::vector<Similarity> intended;  // the smooth part of the truth (synthetic only)
    double fps() const { return double(fps_num) / fps_den; }
};

cv::Mat lumaOf(const FrameBuffer &f)
{
    return cv::Mat(f.height(), f.width(), CV_8UC1, const_cast<std::uint8_t *>(f.row(0, 0)),
                   std::size_t(f.view().planes[0].stride));
}

// A ShakyFlight's frames (I420) with its true and intended poses.
void renderInto(const synthetic::ShakyFlight &flight, Clip *c)
{
    c->width = flight.options().width;
    c->height = flight.options().height;
    for (int i = 0; i < flight.frameCount(); ++i) {
        c->frames.push_back(frameFromBgr(flight.renderBgr(i), PixelFormat::I420));
        c->truth.push_back(flight.truePose(i));
        c->intended.push_back(flight.intendedPose(i));
    }
}

Clip syntheticClip(int width, int height, std::uint32_t seed, int objects, int frames,
                   synthetic::FlightProfile profile = synthetic::FlightProfile::Lissajous)
{
    synthetic::FlightOptions o;
    o.width = width;
    o.height = height;
    o.frames = frames;
    o.seed = seed;
    o.moving_objects = objects;
    o.profile = profile;
    const synthetic::ShakyFlight flight(o);
    Clip c;
    if (profile == synthetic::FlightProfile::Manoeuvre) {
        c.name = format("man_%dx%d_s%u%s", width, height, seed, objects ? "_obj" : "");
        c.label = format("manoeuvre %dx%d seed %u%s", width, height, seed, objects ? ", 3 moving objects" : "");
        c.group = format("manoeuvre %dx%d%s", width, height, objects ? " / moving objects" : "");
    } else {
        c.name = format("syn_%dx%d_s%u%s", width, height, seed, objects ? "_obj" : "");
        c.label = format("synthetic %dx%d seed %u%s", width, height, seed, objects ? ", 3 moving objects" : "");
        c.group = format("%dx%d%s", width, height, objects ? " / moving objects" : "");
    }
    renderInto(flight, &c);
    return c;
}

// Under strong shake: the default hover flight at 1280x720 with bench_path.cpp's "strong720"
// shake times `strength`; or (vibration) with the default jitter and propeller vibration
// on top (global shutter).
struct StrongShake {
    double strength;
    bool vibration;
    std::string key() const { return vibration ? format("%g_vib47", strength) : format("%g", strength); }
    std::string label() const { return vibration ? "default jitter + 47 Hz vibration" : format("x%g", strength); }
};

Clip strongClip(const StrongShake &shake, std::uint32_t seed, int frames)
{
    synthetic::FlightOptions o;
    o.width = 1280;
    o.height = 720;
    o.frames = frames;
    o.seed = seed;
    if (shake.vibration) {  // the default jitter with bench_rolling_shutter.cpp's reference vibration
        o.vibration_hz = 47;
        o.vibration_px = 2;
        o.vibration_deg = 0.1;
    } else {
        o.noise_px = 3.0 * shake.strength;
        o.band_px = 11.0 * shake.strength;
        o.rotation_noise_deg = 0.1 * shake.strength;
        o.rotation_band_deg = 0.5 * shake.strength;
    }
    const synthetic::ShakyFlight flight(o);
    Clip c;
    c.name = format("strong_%s_s%u", shake.key().c_str(), seed);
    c.label = format("strong %s seed %u", shake.label().c_str(), seed);
    c.group = shake.label();
    renderInto(flight, &c);
    return c;
}

// Decodes up to max_frames frames of a real clip to I420 in memory.
bool decodeClip(const std::string &path, int max_frames, Clip *c)
{
    DecodedClip d;
    if (!decodeI420(path, max_frames, &d))
        return false;
    c->width = d.width;
    c->height = d.height;
    c->fps_num = d.fps_num;
    c->fps_den = d.fps_den;
    c->frames = std::move(d.frames);
    return true;
}

// The steady drone clip with a known shake: shaky(q) = steady(J_i(q)), J_i = zoom * shake_i
// (zoom 0.94 reads the central 94 %, so the shake rarely reaches past the edge; where it
// does, the picture is mirrored). The shake is ShakyFlight's jitter model, scaled to 1080p.
Clip shakenDrone(const Clip &steady, std::uint32_t seed)
{
    synthetic::FlightOptions o;
    o.width = steady.width;
    o.height = steady.height;
    o.frames = int(steady.frames.size());
    o.fps = steady.fps();
    o.seed = seed;
    o.pan_speed = 0;
    o.rotation_amplitude_deg = 0;
    const double s = steady.width / 640.0;  // the model's pixels are 640-wide frames'
    o.noise_px *= s;
    o.band_px *= s;
    const synthetic::ShakyFlight flight(o);
    Clip c;
    c.name = "drone_shaken";
    c.label = format("real drone %dx%d + known shake", steady.width, steady.height);
    c.group = "drone 1080p / known shake";
    c.width = steady.width;
    c.height = steady.height;
    c.fps_num = steady.fps_num;
    c.fps_den = steady.fps_den;
    for (std::size_t i = 0; i < steady.frames.size(); ++i) {
        const Similarity shake = flight.intendedPose(int(i)).inverse() * flight.truePose(int(i));
        const Similarity j = Similarity{0, 0, 0, 0.94} * shake;
        const FrameBuffer &in = steady.frames[i];
        FrameBuffer out(PixelFormat::I420, in.width(), in.height());
        for (int p = 0; p < 3; ++p) {
            double m[6];
            FrameWarper::planeMatrix(in.view(), p, j, m);
            const cv::Mat src(in.view().planeHeight(p), in.view().planeWidth(p), CV_8UC1,
                              const_cast<std::uint8_t *>(in.row(p, 0)), std::size_t(in.view().planes[p].stride));
            cv::Mat dst(out.view().planeHeight(p), out.view().planeWidth(p), CV_8UC1, out.row(p, 0),
                        std::size_t(out.view().planes[p].stride));
            cv::warpAffine(src, dst, cv::Mat(2, 3, CV_64F, m), dst.size(), cv::INTER_CUBIC | cv::WARP_INVERSE_MAP,
                           cv::BORDER_REFLECT_101);
        }
        c.frames.push_back(std::move(out));
        c.truth.push_back(j);
        c.intended.push_back(Similarity{0, 0, 0, 0.94});
    }
    return c;
}

// ---- methods ---------------------------------------------------------------------------

// Our configurations, one line each. Every entry runs at every delay of kDelays, with
// config.delay set to that delay and everything else as given here; the first entry is the
// library's default. Adding a planner is one line, e.g.
//   {"optimal_r5", "optimal, smoothness 1e4", [] { StabilizerConfig c; c.planner_smoothness = 1e4; return c; }()},
struct OursEntry {
    std::string name;   // keys: ours_<name> at delay 20 (as in earlier reports), ours_<name>_d<delay> otherwise
    std::string label;  // for tables
    StabilizerConfig config;
};

StabilizerConfig plannerConfig(PlannerKind kind, int radius)
{
    // Spelled out, so the rows keep their meaning when the library's defaults move.
    StabilizerConfig c;
    c.planner = kind;
    c.smoothing_radius = radius;
    return c;
}

const std::vector<OursEntry> &oursTable()
{
    static const std::vector<OursEntry> table{
        {"l1", "l1 planner (default)", plannerConfig(PlannerKind::L1, 20)},
        {"optimal", "optimal planner", plannerConfig(PlannerKind::Optimal, 20)},
        {"gauss20", "gaussian r20", plannerConfig(PlannerKind::Gaussian, 20)},
        {"box10", "box r10 (the paper's)", plannerConfig(PlannerKind::Box, 10)},
    };
    // UAVSTAB_BENCH_OURS=l1,gauss20 runs only those (for quick comparisons while tuning).
    static const std::vector<OursEntry> chosen = [] {
        const char *only = std::getenv("UAVSTAB_BENCH_OURS");
        if (!only)
            return table;
        std::vector<OursEntry> t;
        for (const OursEntry &e : table)
            if (("," + std::string(only) + ",").find("," + e.name + ",") != std::string::npos)
                t.push_back(e);
        return t;
    }();
    return chosen;
}

// Look-ahead frames every entry of oursTable() runs at (0 = causal); 20 is the library's default.
// UAVSTAB_BENCH_DELAYS=5,20 runs only those (for quick comparisons while tuning).
const std::vector<int> kDelays = [] {
    std::vector<int> d{0, 5, 10, 20};
    if (const char *only = std::getenv("UAVSTAB_BENCH_DELAYS")) {
        d.clear();
        std::stringstream ss(only);
        std::string item;
        while (std::getline(ss, item, ','))
            d.push_back(std::stoi(item));
    }
    return d;
}();
constexpr int kReferenceDelay = 20;

std::string oursKey(const std::string &name, int delay)
{
    return "ours_" + name + (delay == kReferenceDelay ? "" : format("_d%d", delay));
}

enum class Kind { Input, Ours, Deshake, VidstabDefault, VidstabZoom };

struct Method {
    std::string key, label;
    std::string short_label;  // column headers of per-clip tables
    Kind kind;
    StabilizerConfig config;
    std::string family;  // ours: OursEntry::name; the others: their key
    int delay = -1;      // ours: config.delay; -1: the input and the peers (offline, no delay)
};

std::vector<Method> methods(bool deshake, bool vidstab)
{
    // Named, not `{}` in each initializer: g++ 12 warns (falsely) that the config's
    // vector member may be used uninitialized when it is brace-initialized in place.
    const StabilizerConfig unused;
    std::vector<Method> m;
    m.push_back({"input", "input (no stabilization)", "input", Kind::Input, unused, "input", -1});
    for (int delay : kDelays)
        for (const OursEntry &e : oursTable()) {
            StabilizerConfig c = e.config;
            c.delay = delay;
            m.push_back({oursKey(e.name, delay), "ours " + e.label, format("%s d%d", e.name.c_str(), delay), Kind::Ours,
                         c, e.name, delay});
        }
    // UAVSTAB_BENCH_PEERS=0 leaves the peers out (for quick comparisons while tuning).
    const char *peers = std::getenv("UAVSTAB_BENCH_PEERS");
    if (peers && std::string(peers) == "0")
        deshake = vidstab = false;
    if (vidstab) {
        m.push_back({"vidstab", "vid.stab default (optzoom=1)", "vid.stab", Kind::VidstabDefault, unused, "vidstab", -1});
        m.push_back({"vidstab_zoom", "vid.stab zoom 8.7 % (= ours)", "vid.stab z8.7", Kind::VidstabZoom, unused,
                     "vidstab_zoom", -1});
    }
    if (deshake)
        m.push_back({"deshake", "ffmpeg deshake", "deshake", Kind::Deshake, unused, "deshake", -1});
    return m;
}

// The methods to run on a clip: the input, the peers, and ours at the given delays only.
std::vector<Method> atDelays(const std::vector<Method> &all, const std::vector<int> &delays)
{
    std::vector<Method> m;
    for (const Method &x : all)
        if (x.kind != Kind::Ours || std::find(delays.begin(), delays.end(), x.delay) != delays.end())
            m.push_back(x);
    return m;
}

std::string delayCell(const Method &m)
{
    return m.kind == Kind::Ours ? std::to_string(m.delay) : m.kind == Kind::Input ? "-" : "offline";
}

std::string longLabel(const Method &m)
{
    return m.kind == Kind::Ours ? format("%s, delay %d", m.label.c_str(), m.delay) : m.label;
}

struct Output {
    std::vector<cv::Mat> luma;
    std::vector<FrameStats> stats;  // ours only
    double seconds = 0;
    std::string error;
};

Output runOurs(const Clip &clip, const StabilizerConfig &config)
{
    Output out;
    Stabilizer stabilizer(config);
    OutputPool pool(PixelFormat::I420, clip.width, clip.height);
    auto take = [&](StabilizedFrame f) {
        const auto &slot = static_cast<const PoolSlot &>(*f.slot);
        const FrameBuffer &shown =
            f.outcome == Outcome::Warped ? *slot.output() : clip.frames[std::size_t(slot.index())];
        out.luma.push_back(lumaOf(shown).clone());
        out.stats.push_back(f.stats);
        if (f.outcome != Outcome::Warped && out.error.empty())
            out.error = "frame " + std::to_string(slot.index()) + " not warped: " + f.error;
    };
    const auto t0 = Clock::now();
    for (std::size_t i = 0; i < clip.frames.size(); ++i) {
        stabilizer.push(std::make_unique<PoolSlot>(clip.frames[i].view(), pool, long(i)));
        while (auto f = stabilizer.tryPop())
            take(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        take(std::move(*f));
    out.seconds = secondsBetween(t0, Clock::now());
    return out;
}

Output runFfmpeg(const Clip &clip, const std::string &raw, const std::string &filter, const std::string &pre_filter)
{
    Output out;
    const std::string in = format("ffmpeg -hide_banner -loglevel error -nostdin -f rawvideo -pix_fmt yuv420p -s %dx%d "
                                  "-framerate %d/%d -i %s ",
                                  clip.width, clip.height, clip.fps_num, clip.fps_den, raw.c_str());
    const auto t0 = Clock::now();
    if (!pre_filter.empty() && runCommand(in + "-vf " + pre_filter + " -f null -") != 0) {
        out.error = "ffmpeg failed: " + pre_filter;
        return out;
    }
    RawPipeReader reader(in + "-vf " + filter + " -fps_mode passthrough -f rawvideo -pix_fmt yuv420p -", clip.width,
                         clip.height);
    FrameBuffer f;
    while (reader.read(f))
        out.luma.push_back(lumaOf(f).clone());
    const int status = reader.close();
    out.seconds = secondsBetween(t0, Clock::now());
    if (status != 0)
        out.error = "ffmpeg exited with " + std::to_string(status) + " (" + filter + ")";
    else if (out.luma.size() != clip.frames.size())
        out.error = format("ffmpeg gave %zu frames for %zu", out.luma.size(), clip.frames.size());
    return out;
}

// ---- analysis ----------------------------------------------------------------------------

std::vector<Features> featuresOf(const std::vector<cv::Mat> &luma)
{
    std::vector<Features> f(luma.size());
    cv::parallel_for_(cv::Range(0, int(luma.size())), [&](const cv::Range &r) {
        const FeatureExtractor extractor;
        for (int i = r.start; i < r.end; ++i)
            f[std::size_t(i)] = extractor.extract(luma[std::size_t(i)]);
    });
    return f;
}

// Share of spectral energy in bins 1..5 among bins 1..n/2 (one-sided, DC excluded).
double lowFrequencyShare(const std::vector<double> &signal)
{
    const int n = int(signal.size());
    if (n < 12)
        return kNaN;
    cv::Mat in(1, n, CV_64F, const_cast<double *>(signal.data())), spectrum;
    cv::dft(in, spectrum, cv::DFT_COMPLEX_OUTPUT);
    double low = 0, total = 0;
    for (int k = 1; k <= n / 2; ++k) {
        const cv::Vec2d c = spectrum.at<cv::Vec2d>(0, k);
        const double e = c[0] * c[0] + c[1] * c[1];
        total += e;
        if (k <= 5)
            low += e;
    }
    return total > 0 ? low / total : kNaN;
}

double cornerRms(const Similarity &a, const Similarity &b, int w, int h)
{
    const double hx = (w - 1) * 0.5, hy = (h - 1) * 0.5;
    double s = 0;
    for (const Point2 c : {Point2{-hx, -hy}, Point2{hx, -hy}, Point2{-hx, hy}, Point2{hx, hy}}) {
        const Point2 p = a.apply(c), q = b.apply(c);
        s += (p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y);
    }
    return std::sqrt(s / 4);
}

struct Metrics {
    std::string error;
    int frames = 0;
    double seconds = 0;
    int failed_out2in = 0, failed_inter = 0;
    double failed_registrations = 0;  // the two above, for per-clip tables
    // truth-based (synthetic, drone)
    double jitter = kNaN, jitter_stats = kNaN, crosscheck_px = kNaN;
    double jitter_steady = kNaN;  // the same after the first second: without the start-up
    double path_error = kNaN, path_error_stats = kNaN;  // against the intended path (synthetic::intendedPathError)
    double path_jitter = kNaN;   // synthetic::intendedPathJitter after the first second
    double path_max_dev = kNaN;  // synthetic::intendedPathMaxDeviation
    double path_jitter_first = kNaN;  // synthetic::intendedPathJitter over the first second alone
    std::vector<Similarity> path;  // true world pose of the output frames (for plots)
    std::vector<double> zoom_series;  // registered input -> output zoom per frame (NaN: registration failed)
    // geometry from the registered output -> input
    double coverage_mean = kNaN, coverage_min = kNaN, zoom_mean = kNaN, zoom_max = kNaN, distortion_max = kNaN;
    double coverage_stats_mean = kNaN, coverage_stats_min = kNaN, zoom_stats = kNaN;
    double zoom_stats_max = kNaN;  // crop zoom times the correction's scale, max over frames (FrameStats)
    // real-clip measures
    double stability_t = kNaN, stability_r = kNaN, itf = kNaN;
    std::vector<FrameStats> stats;
};

// Replaces failed registrations by the nearest earlier good one (or identity).
std::vector<Similarity> filled(const std::vector<Registration> &r, const Similarity &fallback, int *failed)
{
    std::vector<Similarity> s(r.size(), fallback);
    Similarity last = fallback;
    for (std::size_t i = 0; i < r.size(); ++i) {
        if (r[i].ok)
            last = r[i].similarity;
        else
            ++*failed;
        s[i] = last;
    }
    return s;
}

Metrics analyze(const Clip &clip, const std::vector<Features> &input_features, const Method &method, Output out,
                bool real_measures, bool stability)
{
    Metrics m;
    m.error = out.error;
    m.seconds = out.seconds;
    const std::size_t n = std::min(out.luma.size(), clip.frames.size());
    m.frames = int(n);
    if (n < 10) {
        if (m.error.empty())
            m.error = "too few frames";
        return m;
    }
    out.luma.resize(n);
    const bool is_input = method.kind == Kind::Input;
    const std::vector<Features> own = is_input ? std::vector<Features>{} : featuresOf(out.luma);
    const std::vector<Features> &feat = is_input ? input_features : own;

    // Output -> input registration (identity for the input itself).
    std::vector<Registration> out2in(n);
    if (!is_input)
        cv::parallel_for_(cv::Range(0, int(n)), [&](const cv::Range &r) {
            for (int i = r.start; i < r.end; ++i)
                out2in[std::size_t(i)] = registerFeatures(feat[std::size_t(i)], input_features[std::size_t(i)]);
        });
    std::vector<Similarity> o2i =
        is_input ? std::vector<Similarity>(n) : filled(out2in, Similarity{}, &m.failed_out2in);

    if (!clip.truth.empty()) {
        std::vector<Similarity> path(n);
        for (std::size_t i = 0; i < n; ++i)
            path[i] = clip.truth[i] * o2i[i];
        m.jitter = synthetic::residualJitter(path, clip.width, clip.height);
        m.jitter_steady =
            synthetic::residualJitter(path, clip.width, clip.height, 8.0, std::size_t(std::lround(clip.fps())));
        if (!clip.intended.empty()) {
            m.path_error = synthetic::intendedPathError(path, clip.intended, clip.width, clip.height);
            m.path_jitter = synthetic::intendedPathJitter(path, clip.intended, clip.width, clip.height,
                                                          std::size_t(std::lround(clip.fps())));
            m.path_max_dev = synthetic::intendedPathMaxDeviation(path, clip.intended, clip.width, clip.height);
            const std::size_t second = std::min(n, std::size_t(std::lround(clip.fps())));
            m.path_jitter_first = synthetic::intendedPathJitter(
                std::vector<Similarity>(path.begin(), path.begin() + long(second)),
                std::vector<Similarity>(clip.intended.begin(), clip.intended.begin() + long(second)), clip.width,
                clip.height);
        }
        m.path = path;
    }
    if (!is_input) {
        std::vector<double> cov, zoom;
        double dist = 1.0;
        m.zoom_series.assign(n, kNaN);
        for (std::size_t i = 0; i < n; ++i) {
            cov.push_back(synthetic::coverage(o2i[i], clip.width, clip.height));
            if (!out2in[i].ok)
                continue;
            double s1, s2;
            singularValues(out2in[i].affine, &s1, &s2);  // output -> input
            zoom.push_back(1.0 / std::sqrt(s1 * s2));    // input -> output
            m.zoom_series[i] = zoom.back();
            dist = std::max(dist, s1 / s2);
        }
        m.coverage_mean = mean(cov);
        m.coverage_min = minOf(cov);
        m.zoom_mean = mean(zoom);
        m.zoom_max = maxOf(zoom);
        m.distortion_max = dist;
    } else {
        m.coverage_mean = m.coverage_min = m.zoom_mean = m.zoom_max = m.distortion_max = 1.0;
        m.zoom_series.assign(n, 1.0);
    }
    if (!out.stats.empty()) {
        std::vector<Similarity> own_path;
        std::vector<double> diff, cov;
        for (std::size_t i = 0; i < n; ++i) {
            const Similarity s = synthetic::outputToInput(out.stats[i]);
            if (!clip.truth.empty())
                own_path.push_back(clip.truth[i] * s);
            cov.push_back(synthetic::coverage(s, clip.width, clip.height));
            if (out2in[i].ok) {
                const double d = cornerRms(s, out2in[i].similarity, clip.width, clip.height);
                diff.push_back(d * d);
            }
        }
        if (!own_path.empty())
            m.jitter_stats = synthetic::residualJitter(own_path, clip.width, clip.height);
        if (!own_path.empty() && !clip.intended.empty())
            m.path_error_stats = synthetic::intendedPathError(own_path, clip.intended, clip.width, clip.height);
        m.crosscheck_px = std::sqrt(mean(diff));
        m.coverage_stats_mean = mean(cov);
        m.coverage_stats_min = minOf(cov);
        m.zoom_stats = out.stats.front().zoom;
        m.zoom_stats_max = 0;
        for (std::size_t i = 0; i < n; ++i)
            m.zoom_stats_max = std::max(m.zoom_stats_max, 1.0 / out.stats[i].output_to_input.scale);
        m.stats = out.stats;
    }

    if (real_measures && stability) {
        // Inter-frame motion of the output (frame i -> frame i-1), accumulated.
        std::vector<Registration> inter(n);
        cv::parallel_for_(cv::Range(1, int(n)), [&](const cv::Range &r) {
            for (int i = r.start; i < r.end; ++i)
                inter[std::size_t(i)] = registerFeatures(feat[std::size_t(i)], feat[std::size_t(i) - 1]);
        });
        inter[0].ok = true;  // frame 0: identity
        int failed = 0;
        const std::vector<Similarity> motion = filled(inter, Similarity{}, &failed);
        m.failed_inter = failed;
        Similarity pose;
        std::vector<double> t, r;
        for (std::size_t i = 0; i < n; ++i) {
            if (i > 0)
                pose = pose * motion[i];
            t.push_back(std::hypot(pose.dx, pose.dy));
            r.push_back(pose.angle);
        }
        m.stability_t = lowFrequencyShare(t);
        m.stability_r = lowFrequencyShare(r);
    }
    if (real_measures) {
        std::vector<double> psnr(n - 1);
        cv::parallel_for_(cv::Range(1, int(n)), [&](const cv::Range &rr) {
            for (int i = rr.start; i < rr.end; ++i)
                psnr[std::size_t(i) - 1] = psnrCentral(out.luma[std::size_t(i)], out.luma[std::size_t(i) - 1]);
        });
        m.itf = mean(psnr);
    }
    m.failed_registrations = m.failed_out2in + m.failed_inter;
    return m;
}

struct ClipResult {
    Clip clip;  // frames released after the run
    std::vector<Method> methods;
    std::vector<Metrics> metrics;
};

// Two runs of ours that drew every frame the same way (e.g. box r10 at delays 10 and 20: its
// window is whole at both) have the same output: the second is not measured again.
bool sameWarps(const std::vector<FrameStats> &a, const std::vector<FrameStats> &b)
{
    if (a.empty() || a.size() != b.size())
        return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const Similarity &p = a[i].output_to_input, &q = b[i].output_to_input;
        if (p.dx != q.dx || p.dy != q.dy || p.angle != q.angle || p.scale != q.scale)
            return false;
    }
    return true;
}

// real_measures: ITF and (for the input, the peers and ours at delay 20, and for ours at the
// other delays too when stability_every_delay) the stability score, which costs one more
// registration per frame.
ClipResult evaluate(Clip clip, const std::vector<Method> &ms, bool real_measures, bool stability_every_delay = true)
{
    ClipResult result;
    const auto t0 = Clock::now();
    std::printf("  %s (%zu frames)...", clip.label.c_str(), clip.frames.size());
    std::fflush(stdout);
    std::vector<cv::Mat> in_luma;
    for (const FrameBuffer &f : clip.frames)
        in_luma.push_back(lumaOf(f));
    const std::vector<Features> input_features = featuresOf(in_luma);
    ScratchDir scratch("quality");
    const std::string raw = scratch.file("in.yuv"), trf = scratch.file("t.trf");
    double ours_s = 0, peers_s = 0, measure_s = 0;
    int reused = 0;
    // The peers (ffmpeg, largely single-threaded) run in the background while ours run and
    // are measured, so that both cores stay busy; they are measured last. Their outputs do
    // not depend on it.
    std::map<Kind, Output> peer_out;
    std::future<void> peers_done;
    if (std::any_of(ms.begin(), ms.end(), [](const Method &m) { return m.kind != Kind::Input && m.kind != Kind::Ours; })) {
        std::FILE *f = std::fopen(raw.c_str(), "wb");
        for (const FrameBuffer &fb : clip.frames)
            writeRawI420(f, fb.view());
        std::fclose(f);
        peers_done = std::async(std::launch::async, [&] {
            for (const Method &m : ms) {
                if (m.kind == Kind::Deshake)
                    peer_out[m.kind] = runFfmpeg(clip, raw, "deshake=edge=blank", "");
                else if (m.kind == Kind::VidstabDefault)
                    peer_out[m.kind] = runFfmpeg(clip, raw, "vidstabtransform=input=" + trf + ":crop=black",
                                                 "vidstabdetect=result=" + trf);
                else if (m.kind == Kind::VidstabZoom)  // after VidstabDefault: same transforms file
                    peer_out[m.kind] =
                        runFfmpeg(clip, raw, "vidstabtransform=input=" + trf + ":crop=black:optzoom=0:zoom=8.7", "");
            }
        });
    }
    // Ours at the reference delay first: its measurement is the most complete (stability),
    // so a run at another delay with the same output can take it over whole. The peers last.
    std::vector<const Method *> order;
    for (const Method &m : ms)
        if (m.kind == Kind::Input || (m.kind == Kind::Ours && m.delay == kReferenceDelay))
            order.push_back(&m);
    for (const Method &m : ms)
        if (m.kind == Kind::Ours && m.delay != kReferenceDelay)
            order.push_back(&m);
    for (const Method &m : ms)
        if (std::find(order.begin(), order.end(), &m) == order.end())
            order.push_back(&m);
    for (const Method *mp : order) {
        const Method &m = *mp;
        Output out;
        switch (m.kind) {
        case Kind::Input:
            for (const cv::Mat &l : in_luma)
                out.luma.push_back(l);
            break;
        case Kind::Ours:
            out = runOurs(clip, m.config);
            break;
        case Kind::Deshake:
        case Kind::VidstabDefault:
        case Kind::VidstabZoom:
            if (peers_done.valid())
                peers_done.get();
            out = std::move(peer_out[m.kind]);
            break;
        }
        const Metrics *twin = nullptr;
        if (m.kind == Kind::Ours && out.error.empty())
            for (std::size_t k = 0; k < result.methods.size() && !twin; ++k)
                if (result.methods[k].kind == Kind::Ours && result.metrics[k].error.empty() &&
                    sameWarps(out.stats, result.metrics[k].stats))
                    twin = &result.metrics[k];
        (m.kind == Kind::Ours ? ours_s : peers_s) += out.seconds;
        if (twin) {
            Metrics copy = *twin;
            copy.seconds = out.seconds;
            result.metrics.push_back(std::move(copy));
            ++reused;
        } else {
            const auto a0 = Clock::now();
            const bool stability =
                stability_every_delay || m.kind != Kind::Ours || m.delay == kReferenceDelay;
            result.metrics.push_back(analyze(clip, input_features, m, std::move(out), real_measures, stability));
            measure_s += secondsBetween(a0, Clock::now());
        }
        result.methods.push_back(m);
    }
    std::printf(" %.1f s (ours %.1f s, peers %.1f s, measuring %.1f s%s)\n", secondsBetween(t0, Clock::now()), ours_s,
                peers_s, measure_s, reused ? format("; %d identical output%s measured once", reused, reused > 1 ? "s" : "").c_str() : "");
    std::fflush(stdout);
    clip.frames.clear();
    clip.frames.shrink_to_fit();
    result.clip = std::move(clip);
    return result;
}

// ---- reporting ---------------------------------------------------------------------------

std::string num(double v, const char *f = "%.2f")
{
    return std::isfinite(v) ? format(f, v) : "n/a";
}

const Metrics *find(const ClipResult &r, const std::string &key)
{
    for (std::size_t i = 0; i < r.methods.size(); ++i)
        if (r.methods[i].key == key)
            return &r.metrics[i];
    return nullptr;
}

std::string errorsOf(const std::vector<ClipResult> &results)
{
    std::string s;
    for (const ClipResult &r : results)
        for (std::size_t i = 0; i < r.methods.size(); ++i)
            if (!r.metrics[i].error.empty())
                s += "- " + r.clip.label + ", " + r.methods[i].label + ": " + r.metrics[i].error + "\n";
    return s;
}

// One frame's trajectory figure: dx, dy, angle of the raw path and of the smoothed paths.
void trajectoryPlot(const Options &o, const ClipResult &r, const std::string &file, const std::string &truth_label)
{
    const Metrics *box = find(r, "ours_box10"), *gauss = find(r, "ours_gauss20"), *optimal = find(r, "ours_optimal"),
                  *l1 = find(r, "ours_l1");
    if (!box || box->stats.empty())
        return;
    const std::size_t n = box->stats.size();
    std::vector<double> x(n);
    for (std::size_t i = 0; i < n; ++i)
        x[i] = double(i);
    auto component = [&](const std::vector<FrameStats> &stats, bool smoothed, int k) {
        std::vector<double> v;
        for (const FrameStats &s : stats) {
            const Similarity &p = smoothed ? s.smoothed : s.trajectory;
            v.push_back(k == 0 ? p.dx : k == 1 ? p.dy : p.angle * 180.0 / kPi);
        }
        return v;
    };
    // The true intended (shake-free) path in the stabilizer's frame-0 coordinates.
    std::vector<Similarity> intended;
    if (!r.clip.truth.empty() && !r.clip.intended.empty())
        for (std::size_t i = 0; i < n && i < r.clip.intended.size(); ++i)
            intended.push_back(r.clip.truth[0].inverse() * r.clip.intended[i]);
    const char *names[3] = {"dx (px)", "dy (px)", "angle (deg)"};
    std::vector<cv::Mat> panels;
    for (int k = 0; k < 3; ++k) {
        std::vector<Series> s;
        s.push_back(
            {"raw camera path (FrameStats.trajectory)", x, component(box->stats, false, k), paletteColor(0), 1});
        if (!intended.empty()) {
            std::vector<double> v;
            for (const Similarity &p : intended)
                v.push_back(k == 0 ? p.dx : k == 1 ? p.dy : p.angle * 180.0 / kPi);
            s.push_back({truth_label, x, v, paletteColor(3), 1});
        }
        s.push_back({"smoothed, box r10 (the paper's)", x, component(box->stats, true, k), paletteColor(1), 2});
        if (gauss && gauss->stats.size() == n)
            s.push_back({"smoothed, gaussian r20", x, component(gauss->stats, true, k), paletteColor(4), 2});
        if (optimal && optimal->stats.size() == n)
            s.push_back({"planned, optimal", x, component(optimal->stats, true, k), paletteColor(2), 2});
        if (l1 && l1->stats.size() == n)
            s.push_back({"planned, l1 (default)", x, component(l1->stats, true, k), paletteColor(4), 2});
        panels.push_back(linePlot(format("%s: %s", r.clip.label.c_str(), names[k]), "frame", names[k], s));
    }
    writePng(o.out_dir + "/" + file, stackVertically(panels));
}

// Residual jitter per method, one group of bars per clip group.
void jitterPlot(const Options &o, const std::vector<ClipResult> &results, const std::vector<Method> &ms)
{
    std::vector<std::string> groups;
    for (const ClipResult &r : results)
        if (!r.clip.truth.empty() && std::find(groups.begin(), groups.end(), r.clip.group) == groups.end())
            groups.push_back(r.clip.group);
    if (groups.empty())
        return;
    std::vector<std::string> labels, categories;
    std::vector<std::vector<double>> values;
    std::vector<cv::Scalar> colors;
    for (const std::string &g : groups) {
        std::vector<double> j;
        for (const ClipResult &r : results)
            if (const Metrics *m = find(r, "input"); m && r.clip.group == g)
                j.push_back(m->jitter);
        std::string label = g;
        for (std::size_t at; (at = label.find(" / ")) != std::string::npos;)
            label.replace(at, 3, ", ");
        categories.push_back(label + format(" / (input: %.2f px)", mean(j)));
    }
    for (std::size_t k = 0; k < ms.size(); ++k) {
        if (ms[k].kind == Kind::Input)
            continue;  // its bar would dwarf the others: its value is in the category label
        std::vector<double> v;
        bool any = false;
        for (const std::string &g : groups) {
            std::vector<double> j;
            for (const ClipResult &r : results)
                if (r.clip.group == g)
                    if (const Metrics *m = find(r, ms[k].key); m && std::isfinite(m->jitter))
                        j.push_back(m->jitter);
            v.push_back(j.empty() ? kNaN : mean(j));
            any = any || !j.empty();
        }
        if (!any)
            continue;
        labels.push_back(longLabel(ms[k]));
        colors.push_back(paletteColor(int(k)));
        values.push_back(v);
    }
    writePng(o.out_dir + "/residual_jitter.png",
             barChart("Residual jitter (px, RMS of the 4 corners' path minus its Gaussian low-pass, sigma 8 frames; "
                      "mean over seeds) - lower is better",
                      "residual jitter (px)", categories, labels, values, colors, {1800, 600}));
}

std::vector<double> collect(const std::vector<ClipResult> &results, const std::string &key, double Metrics::*field)
{
    std::vector<double> v;
    for (const ClipResult &r : results)
        if (const Metrics *m = find(r, key); m && std::isfinite(m->*field))
            v.push_back(m->*field);
    return v;
}

bool ranOnAny(const std::vector<ClipResult> &results, const std::string &key)
{
    for (const ClipResult &r : results)
        if (find(r, key))
            return true;
    return false;
}

// A method's mean of `field` over the clips it ran on, and vid.stab default's mean over the
// same clips (delays other than 20 may run on fewer clips).
struct VsVidstab {
    double value = kNaN, vidstab = kNaN;
    int clips = 0;
};

VsVidstab vsVidstab(const std::vector<ClipResult> &results, const std::string &key, double Metrics::*field)
{
    std::vector<double> v, ref;
    for (const ClipResult &r : results) {
        const Metrics *m = find(r, key);
        if (!m || !std::isfinite(m->*field))
            continue;
        v.push_back(m->*field);
        if (const Metrics *x = find(r, "vidstab"); x && std::isfinite(x->*field))
            ref.push_back(x->*field);
    }
    return {mean(v), mean(ref), int(v.size())};
}

// Per-method table over a group of clips with known truth: rows = method x delay.
// path_first: the error against the intended path is the headline (manoeuvre flights).
Table truthTable(const Options &o, const std::string &prefix, const std::vector<ClipResult> &results,
                 const std::vector<Method> &ms, bool path_first, bool real_measures)
{
    bool with_path = false;
    for (const ClipResult &r : results)
        with_path = with_path || !r.clip.intended.empty();
    const std::vector<std::string> path_cols{"jitter vs intended after 1 s px", "vs vid.stab",
                                             "error vs intended path px", "vs vid.stab", "max deviation px"};
    const std::vector<std::string> jitter_cols{"residual jitter px", "vs vid.stab", "after 1 s px", "vs vid.stab"};
    std::vector<std::string> header{"method", "delay"};
    auto append = [&](const std::vector<std::string> &cols) { header.insert(header.end(), cols.begin(), cols.end()); };
    if (with_path && path_first)
        append(path_cols);
    append(jitter_cols);
    if (with_path && !path_first)
        append(path_cols);
    append({"coverage mean", "coverage min", "zoom mean", "zoom max", "distortion max"});
    if (real_measures)
        append({"stability t / r", "ITF dB", "ITF - vid.stab dB"});
    append({"clips", "failed registrations"});
    Table t(header);
    for (const Method &m : ms) {
        if (!ranOnAny(results, m.key))
            continue;
        const VsVidstab j = vsVidstab(results, m.key, &Metrics::jitter);
        const VsVidstab js = vsVidstab(results, m.key, &Metrics::jitter_steady);
        const VsVidstab e = vsVidstab(results, m.key, &Metrics::path_error);
        const VsVidstab pj = vsVidstab(results, m.key, &Metrics::path_jitter);
        const double max_dev = maxOf(collect(results, m.key, &Metrics::path_max_dev));
        const VsVidstab itf = vsVidstab(results, m.key, &Metrics::itf);
        int failed = 0, clips = 0;
        for (const ClipResult &r : results)
            if (const Metrics *x = find(r, m.key)) {
                failed += x->failed_out2in + x->failed_inter;
                ++clips;
            }
        const double cov_mean = mean(collect(results, m.key, &Metrics::coverage_mean));
        const double cov_min = minOf(collect(results, m.key, &Metrics::coverage_min));
        const double zoom = mean(collect(results, m.key, &Metrics::zoom_mean));
        const double zoom_max = maxOf(collect(results, m.key, &Metrics::zoom_max));
        const double dist = maxOf(collect(results, m.key, &Metrics::distortion_max));
        const std::vector<std::string> path_cells{num(pj.value), num(pj.value / pj.vidstab, "%.2fx"), num(e.value),
                                                  num(e.value / e.vidstab, "%.2fx"), num(max_dev, "%.1f")};
        const std::vector<std::string> jitter_cells{num(j.value), num(j.value / j.vidstab, "%.2fx"), num(js.value),
                                                    num(js.value / js.vidstab, "%.2fx")};
        std::vector<std::string> row{m.label, delayCell(m)};
        auto add = [&](const std::vector<std::string> &cells) { row.insert(row.end(), cells.begin(), cells.end()); };
        if (with_path && path_first)
            add(path_cells);
        add(jitter_cells);
        if (with_path && !path_first)
            add(path_cells);
        add({num(cov_mean, "%.4f"), num(cov_min, "%.4f"), num(zoom, "%.3f"), num(zoom_max, "%.3f"),
             num(dist, "%.4f")});
        if (real_measures)
            add({num(mean(collect(results, m.key, &Metrics::stability_t)), "%.3f") + " / " +
                     num(mean(collect(results, m.key, &Metrics::stability_r)), "%.3f"),
                 num(itf.value, "%.2f"), num(itf.value - itf.vidstab, "%+.2f")});
        add({std::to_string(clips), std::to_string(failed)});
        t.row(row);
        const std::string key = "quality." + prefix + "." + m.key;
        putResult(o, key + ".jitter", j.value);
        putResult(o, key + ".jitter_vs_vidstab", j.value / j.vidstab);
        putResult(o, key + ".jitter_after_1s", js.value);
        putResult(o, key + ".jitter_after_1s_vs_vidstab", js.value / js.vidstab);
        if (with_path) {
            putResult(o, key + ".path_error", e.value);
            putResult(o, key + ".path_error_vs_vidstab", e.value / e.vidstab);
            putResult(o, key + ".path_jitter", pj.value);
            putResult(o, key + ".path_jitter_vs_vidstab", pj.value / pj.vidstab);
            putResult(o, key + ".path_max_dev", max_dev);
            putResult(o, key + ".path_jitter_first", mean(collect(results, m.key, &Metrics::path_jitter_first)));
        }
        putResult(o, key + ".coverage_mean", cov_mean);
        putResult(o, key + ".coverage_min", cov_min);
        putResult(o, key + ".zoom_mean", zoom);
        putResult(o, key + ".zoom_max", zoom_max);
        putResult(o, key + ".distortion_max", dist);
        putResult(o, key + ".clips", clips);
        if (real_measures) {
            putResult(o, key + ".itf", itf.value);
            putResult(o, key + ".itf_minus_vidstab", itf.value - itf.vidstab);
        }
    }
    return t;
}

// Rows = clips, columns = methods (short labels): one measure per cell ("-": not run on it).
Table matrixTable(const std::vector<ClipResult> &results, const std::vector<Method> &ms, double Metrics::*field,
                  const char *number_format = "%.2f", bool minus_vidstab = false,
                  double Metrics::*in_brackets = nullptr)
{
    std::vector<std::string> header{"clip"};
    std::vector<const Method *> cols;
    for (const Method &m : ms)
        if (ranOnAny(results, m.key) && !(minus_vidstab && (m.kind == Kind::Input || m.key == "vidstab"))) {
            header.push_back(m.short_label);
            cols.push_back(&m);
        }
    Table t(header);
    for (const ClipResult &r : results) {
        std::vector<std::string> row{r.clip.label};
        const Metrics *ref = find(r, "vidstab");
        for (const Method *m : cols) {
            const Metrics *x = find(r, m->key);
            if (!x)
                row.push_back("-");
            else if (minus_vidstab)
                row.push_back(ref ? num(x->*field - ref->*field, number_format) : "n/a");
            else if (in_brackets)
                row.push_back(num(x->*field, number_format) + " (" + num(x->*in_brackets, number_format) + ")");
            else
                row.push_back(num(x->*field, number_format));
        }
        t.row(row);
    }
    return t;
}

// Ours: the registered measurement against the stabilizer's own account (FrameStats), as
// means over the clips.
Table crossCheckTable(const std::vector<ClipResult> &results, const std::vector<Method> &ms)
{
    bool with_path = false;
    for (const ClipResult &r : results)
        with_path = with_path || !r.clip.intended.empty();
    std::vector<std::string> header{"ours", "delay", "jitter registered / own FrameStats px"};
    if (with_path)
        header.push_back("error vs intended registered / own px");
    for (const char *h : {"RMS corner gap registered vs FrameStats px (mean, max over clips)",
                          "coverage from FrameStats mean / min", "crop zoom (max with scale correction)"})
        header.push_back(h);
    Table t(header);
    for (const Method &m : ms) {
        if (m.kind != Kind::Ours || !ranOnAny(results, m.key))
            continue;
        std::vector<double> zoom;
        for (const ClipResult &r : results)
            if (const Metrics *x = find(r, m.key); x && std::isfinite(x->zoom_stats))
                zoom.push_back(x->zoom_stats);
        std::vector<std::string> row{m.label, delayCell(m),
                                     num(mean(collect(results, m.key, &Metrics::jitter)), "%.3f") + " / " +
                                         num(mean(collect(results, m.key, &Metrics::jitter_stats)), "%.3f")};
        if (with_path)
            row.push_back(num(mean(collect(results, m.key, &Metrics::path_error)), "%.3f") + " / " +
                          num(mean(collect(results, m.key, &Metrics::path_error_stats)), "%.3f"));
        row.push_back(num(mean(collect(results, m.key, &Metrics::crosscheck_px)), "%.3f") + " (" +
                      num(maxOf(collect(results, m.key, &Metrics::crosscheck_px)), "%.3f") + ")");
        row.push_back(num(mean(collect(results, m.key, &Metrics::coverage_stats_mean)), "%.4f") + " / " +
                      num(minOf(collect(results, m.key, &Metrics::coverage_stats_min)), "%.4f"));
        row.push_back(num(minOf(zoom), "%.3f") + (maxOf(zoom) > minOf(zoom) + 5e-4 ? num(maxOf(zoom), "-%.3f") : "") +
                      " (" + num(maxOf(collect(results, m.key, &Metrics::zoom_stats_max)), "%.3f") + ")");
        t.row(row);
    }
    return t;
}

// "gaussian r20 vs box r10" in one sentence (both at delay 20).
std::string boxVsGauss(const std::vector<ClipResult> &results)
{
    int better = 0, total = 0;
    std::vector<double> ratio;
    for (const ClipResult &r : results) {
        const Metrics *b = find(r, "ours_box10"), *g = find(r, "ours_gauss20");
        if (!b || !g || !std::isfinite(b->jitter) || !std::isfinite(g->jitter))
            continue;
        ++total;
        better += g->jitter < b->jitter;
        ratio.push_back(g->jitter / b->jitter);
    }
    if (!total)
        return "";
    return format("Gaussian r20 vs box r10 (both delay 20): gaussian leaves %.0f %% of box's residual jitter on "
                  "average (per-clip ratio %.2f-%.2f), lower on %d of %d clips: %s is better here.",
                  100 * mean(ratio), minOf(ratio), maxOf(ratio), better, total,
                  better * 2 > total ? "**gaussian r20**" : "**box r10**");
}

// Per frame: RMS over the output frame's corners of E_i(corner) - mean_j E_j(corner),
// E_i = intended_i^-1 * output_i (the per-frame terms of synthetic::intendedPathError).
std::vector<double> pathErrorSeries(const std::vector<Similarity> &path, const std::vector<Similarity> &intended,
                                    int width, int height)
{
    const std::size_t n = std::min(path.size(), intended.size());
    const double hx = (width - 1) * 0.5, hy = (height - 1) * 0.5;
    const Point2 corners[4] = {{-hx, -hy}, {hx, -hy}, {-hx, hy}, {hx, hy}};
    std::vector<double> e2(n, 0.0);
    for (const Point2 &c : corners) {
        std::vector<Point2> p(n);
        double mx = 0, my = 0;
        for (std::size_t i = 0; i < n; ++i) {
            p[i] = (intended[i].inverse() * path[i]).apply(c);
            mx += p[i].x / double(n);
            my += p[i].y / double(n);
        }
        for (std::size_t i = 0; i < n; ++i)
            e2[i] += 0.25 * ((p[i].x - mx) * (p[i].x - mx) + (p[i].y - my) * (p[i].y - my));
    }
    for (double &v : e2)
        v = std::sqrt(v);
    return e2;
}

// The manoeuvre flight's path: centre x, y and angle of the intended, the raw (true) and
// the output paths, and the per-frame error against the intended path.
void manoeuvrePlot(const Options &o, const ClipResult &r, const std::string &file)
{
    const std::string def = oursTable().front().name;
    struct Line {
        std::string key, label;
        int color, thickness;
    };
    const std::vector<Line> lines{
        {oursKey(def, 0), "ours " + oursTable().front().label + ", delay 0", 2, 2},
        {oursKey(def, kReferenceDelay), format("ours %s, delay %d", oursTable().front().label.c_str(), kReferenceDelay),
         4, 2},
        {"vidstab", "vid.stab default (two-pass)", 1, 2},
    };
    const std::size_t n = r.clip.intended.size();
    std::vector<double> x(n);
    for (std::size_t i = 0; i < n; ++i)
        x[i] = double(i);
    auto component = [](const std::vector<Similarity> &p, int k) {
        std::vector<double> v;
        for (const Similarity &s : p)
            v.push_back(k == 0 ? s.dx : k == 1 ? s.dy : s.angle * 180.0 / kPi);
        return v;
    };
    const char *names[3] = {"x of the frame centre (world px)", "y of the frame centre (world px)", "angle (deg)"};
    std::vector<cv::Mat> panels;
    for (int k = 0; k < 3; ++k) {
        std::vector<Series> s;
        s.push_back({"raw (true camera path, with shake)", x, component(r.clip.truth, k), paletteColor(10), 1});
        for (const Line &l : lines)
            if (const Metrics *m = find(r, l.key); m && m->path.size() == n)
                s.push_back({l.label, x, component(m->path, k), paletteColor(l.color), l.thickness});
        s.push_back({"intended (shake-free)", x, component(r.clip.intended, k), paletteColor(0), 1});
        panels.push_back(linePlot(format("%s: %s", r.clip.label.c_str(), names[k]), "frame", names[k], s));
    }
    std::vector<Series> s;
    for (const Line &l : lines)
        if (const Metrics *m = find(r, l.key); m && m->path.size() == n)
            s.push_back({format("%s (RMS %.2f px)", l.label.c_str(), m->path_error), x,
                         pathErrorSeries(m->path, r.clip.intended, r.clip.width, r.clip.height), paletteColor(l.color),
                         l.thickness});
    panels.push_back(linePlot("Error against the intended path per frame: RMS over the corners of E_i - mean E, "
                              "E_i = intended_i^-1 * output_i (px)",
                              "frame", "px", s));
    writePng(o.out_dir + "/" + file, stackVertically(panels));
}

// Registered zoom per frame of ours (the default entry at every delay, the others at 20) and
// vid.stab on one real clip.
void zoomPlot(const Options &o, const ClipResult &r, const std::vector<Method> &ms, const std::string &file)
{
    std::vector<Series> s;
    int k = 0;
    for (const Method &m : ms) {
        ++k;
        const bool wanted = m.kind == Kind::VidstabDefault || m.kind == Kind::VidstabZoom ||
                            (m.kind == Kind::Ours && (m.family == oursTable().front().name || m.delay == kReferenceDelay));
        const Metrics *x = find(r, m.key);
        if (!wanted || !x || x->zoom_series.empty())
            continue;
        std::vector<double> f(x->zoom_series.size());
        for (std::size_t i = 0; i < f.size(); ++i)
            f[i] = double(i);
        s.push_back({longLabel(m), f, x->zoom_series, paletteColor(k - 1), m.kind == Kind::Ours ? 2 : 1});
    }
    writePng(o.out_dir + "/" + file,
             linePlot(format("Zoom over time (input -> output scale, registered): %s", r.clip.name.c_str()),
                      "frame", "zoom", s, {1400, 460}));
}

// Which of our delays run on which synthetic clips: all delays on the first `all_delay_seeds`
// seeds, delay 20 alone on the others.
std::vector<Method> forSeed(const std::vector<Method> &ms, std::uint32_t seed, std::uint32_t all_delay_seeds)
{
    return seed <= all_delay_seeds ? ms : atDelays(ms, {kReferenceDelay});
}

std::string delaysText()
{
    std::string d;
    for (int x : kDelays)
        d += (d.empty() ? "" : ", ") + std::to_string(x);
    std::string names;
    for (const OursEntry &e : oursTable())
        names += (names.empty() ? "" : "; ") + e.label;
    return format("Ours (%s) at delays %s (config.delay, everything else default; delay 0 is causal); the peers are "
                  "offline two-pass or whole-clip filters with no delay and appear once. \"vs vid.stab\" = ours / "
                  "vid.stab default (two-pass, optzoom=1) over the same clips; for ITF the difference in dB.",
                  names.c_str(), d.c_str());
}

void sectionSynthetic(const Options &o, const std::vector<Method> &ms, std::vector<ClipResult> *truth_results)
{
    Fragment frag(o, "quality_synthetic");
    std::vector<Resolution> sizes{{640, 360}, {1280, 720}};
    std::vector<std::uint32_t> seeds{1, 2, 3};
    std::vector<int> objects_set{0, 3};
    std::uint32_t all_delay_seeds = 1;  // delays other than 20: seed 1 only (run time)
    int frames = 160;
    if (o.quick) {
        sizes = {{640, 360}};
        seeds = {1};
        objects_set = {3};
        frames = 150;
    }
    frag.text(format(
        "Synthetic \"hover\" clips (ShakyFlight's default flight over tests/data/aero1.jpg: a drone holding "
        "station that drifts slowly, known true camera poses): %zu seed%s x {%s} x {%s}, %d frames at 30 fps each. Default jitter model (0.5 px white + 3 px RMS 2-8 Hz band, 0.05 + 0.3 deg "
        "rotation), drift ~1.5 px/frame on a Lissajous path, slow yaw. %s%s "
        "**Residual jitter** = RMS over the four frame corners of (output camera path - its Gaussian low-pass, "
        "sigma 8 frames) with `synthetic::residualJitter`; the output path is truePose_i * output_to_input_i, "
        "output_to_input_i measured by registering each output frame to its input frame (ORB + RANSAC similarity, "
        "features only in the central 88 %%), the same way for ours and the peers. **After 1 s**: the same RMS "
        "over the frames after the first second only, for every method alike: a causal planner (short delay) "
        "cannot know a pan's speed at a clip's first frame and starts from rest, so its start-up is counted "
        "apart from its steady state. **Error vs intended path** = "
        "`synthetic::intendedPathError` of the same output path against the shake-free path (see the manoeuvre "
        "section). **Coverage** = share of the output frame showing picture (`synthetic::coverage` of the "
        "registered transform). Peers: vid.stab with crop=black (default optzoom=1 = optimal static zoom; and "
        "optzoom=0 zoom=8.7 = ours' zoom 1.087), deshake with edge=blank; all other settings default.",
        seeds.size(), seeds.size() > 1 ? "s" : "",
        objects_set.size() == 2 ? "no moving objects, 3 moving objects" : "3 moving objects",
        sizes.size() == 2 ? "640x360, 1280x720" : "640x360", frames, delaysText().c_str(),
        all_delay_seeds < seeds.size()
            ? format(" To keep the run short, ours at delays other than 20 run on seed%s %s only (%u of %zu seeds: "
                     "%zu of %zu clips); their \"vs vid.stab\" ratios are over those clips.",
                     all_delay_seeds > 1 ? "s" : "", all_delay_seeds > 1 ? format("1-%u", all_delay_seeds).c_str() : "1",
                     all_delay_seeds, seeds.size(), sizes.size() * objects_set.size() * all_delay_seeds,
                     sizes.size() * objects_set.size() * seeds.size())
                  .c_str()
            : ""));
    std::vector<ClipResult> results;
    for (const Resolution &res : sizes)
        for (int objects : objects_set)
            for (std::uint32_t seed : seeds)
                results.push_back(evaluate(syntheticClip(res.width, res.height, seed, objects, frames),
                                           forSeed(ms, seed, all_delay_seeds), false));

    frag.text("Over all hover clips (jitter and error: mean of the per-clip values; coverage min, zoom max and "
              "distortion max: over all frames; zoom = input -> output scale; distortion = ratio of the singular "
              "values of the linear part of input -> output, from a full affine fitted to the registration's "
              "inliers):");
    frag.table(truthTable(o, "syn", results, ms, false, false));
    {
        // Delay 20 on just the clips that ran every delay, for a like-for-like column.
        std::vector<ClipResult> every;
        for (const ClipResult &r : results)
            if (r.metrics.size() == ms.size())
                every.push_back(ClipResult{r.clip, r.methods, r.metrics});
        if (!every.empty() && every.size() < results.size()) {
            std::string line;
            for (const OursEntry &e : oursTable()) {
                const VsVidstab j = vsVidstab(every, oursKey(e.name, kReferenceDelay), &Metrics::jitter);
                line += format("%s%s %.2f px (%.2fx vid.stab)", line.empty() ? "" : ", ", e.label.c_str(), j.value,
                               j.value / j.vidstab);
            }
            frag.text(format("On the %zu clips that ran every delay, delay %d gives: %s.", every.size(),
                             kReferenceDelay, line.c_str()));
        }
    }
    frag.text(boxVsGauss(results));
    frag.text("Residual jitter (px) per clip:");
    frag.table(matrixTable(results, ms, &Metrics::jitter));
    frag.text("Cross-check of ours: the registered measurement against the stabilizer's own account "
              "(`synthetic::outputToInput(FrameStats)`), means over the clips; the corner gap is the measuring "
              "stick's error.");
    frag.table(crossCheckTable(results, ms));
    const std::string errors = errorsOf(results);
    if (!errors.empty())
        frag.text("Problems:\n\n" + errors);
    for (const ClipResult &r : results)
        if (r.clip.name == "syn_1280x720_s1_obj" || (o.quick && r.clip.name == "syn_640x360_s1_obj")) {
            trajectoryPlot(o, r, "trajectory_synthetic.png", "true intended path (no shake)");
            frag.text(format("![trajectory](trajectory_synthetic.png)\n\nCamera path of %s: raw (estimated) and "
                             "smoothed (delay 20), as in the paper's \"Compensation Results\" figure.",
                             r.clip.label.c_str()));
        }
    for (ClipResult &r : results)
        truth_results->push_back(std::move(r));
}

void sectionManoeuvre(const Options &o, const std::vector<Method> &ms, std::vector<ClipResult> *truth_results)
{
    Fragment frag(o, "quality_manoeuvre");
    // 640x360 seeds 1 and 2, 1280x720 seed 1 (run time; quick: 640x360 seed 1).
    struct ClipSpec {
        Resolution res;
        std::uint32_t seed;
    };
    std::vector<ClipSpec> specs{{{640, 360}, 1}, {{640, 360}, 2}, {{1280, 720}, 1}};
    const int frames = 300;
    if (o.quick)
        specs.resize(1);
    std::string clips_text;
    for (const ClipSpec &c : specs)
        clips_text += format("%s%dx%d seed %u", clips_text.empty() ? "" : ", ", c.res.width, c.res.height, c.seed);
    frag.text(format(
        "Manoeuvre flights (ShakyFlight profile `Manoeuvre`, tests/synthetic/shaky_flight.cpp: `manoeuvrePlan()`): "
        "%s; %d frames at 30 fps each. The intended path is what a pilot flies, piecewise constant "
        "acceleration: hover 1 s; a pan accelerating for 0.5 s to 3.5 px/frame, cruising, decelerating to a stop "
        "(210 px); hover 0.7 s; a 25 deg yaw turn in 1.3 s; a second pan in another direction (-125, -50 px, "
        "3.2 px/frame); hover 0.7 s; a climb (scale x1.12 in 1.3 s); hover to the end. Same jitter model as the hover "
        "clips. **Error vs intended path** (`synthetic::intendedPathError`): for each frame E_i = intended_i^-1 * "
        "output_i (output_i = truePose_i * output_to_input_i, registered as everywhere else), and the RMS over the "
        "four output corners and all frames of E_i(corner) - mean_j E_j(corner), in px: a constant offset or zoom "
        "costs nothing; lagging behind a start or a stop, bending the manoeuvre and leftover shake cost. Residual "
        "jitter beside it (it forgives a smoother that bends the path slowly). %s",
        clips_text.c_str(), frames, delaysText().c_str()));
    std::vector<ClipResult> results;
    for (const ClipSpec &c : specs)
        results.push_back(evaluate(
            syntheticClip(c.res.width, c.res.height, c.seed, 0, frames, synthetic::FlightProfile::Manoeuvre), ms, false));
    std::vector<double> own_jitter;
    for (const ClipResult &r : results)
        own_jitter.push_back(synthetic::residualJitter(r.clip.intended, r.clip.width, r.clip.height));
    frag.text(format("Over all manoeuvre clips (means of the per-clip values; coverage min and zoom max over all "
                     "frames). Note: the intended (shake-free) path alone scores %.2f px of residual jitter on these "
                     "clips (%.2f-%.2f): its Gaussian low-pass (sigma 8 frames) does not follow the starts, stops and "
                     "the turn, so on a manoeuvre residual jitter counts deliberate motion, and following the pilot "
                     "exactly is not its minimum; the error against the intended path is the measure here.",
                     mean(own_jitter), minOf(own_jitter), maxOf(own_jitter)));
    frag.table(truthTable(o, "man", results, ms, true, false));
    frag.text("Error against the intended path (px) per clip:");
    frag.table(matrixTable(results, ms, &Metrics::path_error));
    frag.text("Residual jitter (px) per clip:");
    frag.table(matrixTable(results, ms, &Metrics::jitter));
    frag.text("Cross-check of ours against its own FrameStats (means over the clips):");
    frag.table(crossCheckTable(results, ms));
    const std::string errors = errorsOf(results);
    if (!errors.empty())
        frag.text("Problems:\n\n" + errors);
    const std::string plotted = o.quick ? "man_640x360_s1" : "man_1280x720_s1";
    for (const ClipResult &r : results)
        if (r.clip.name == plotted) {
            manoeuvrePlot(o, r, "manoeuvre_path.png");
            frag.text(format("![manoeuvre path](manoeuvre_path.png)\n\nPath of %s: x and y of the output frame's "
                             "centre and its angle in the world (the output path above), intended, raw (true, with "
                             "shake), ours (%s) at delays 0 and %d and vid.stab; the last panel is the per-frame "
                             "error against the intended path.",
                             r.clip.label.c_str(), oursTable().front().label.c_str(), kReferenceDelay));
        }
    for (ClipResult &r : results)
        truth_results->push_back(std::move(r));
}

void sectionDrone(const Options &o, const std::vector<Method> &ms, std::vector<ClipResult> *truth_results)
{
    Fragment frag(o, "quality_drone");
    const std::string path = o.data_dir + "/aerial_drone_nadir_steady_1920x1080.mp4";
    Clip steady;
    if (o.data_dir.empty() || !haveCommand("ffmpeg") || !decodeClip(path, o.quick ? 60 : 1000, &steady)) {
        frag.text("Real drone clip with known shake: skipped: " + path +
                  (haveCommand("ffmpeg") ? " is not present." : " needs ffmpeg to decode."));
        return;
    }
    const Clip clip = shakenDrone(steady, 11);
    steady.frames.clear();
    frag.text(format("Real drone clip with known shake: `aerial_drone_nadir_steady_1920x1080.mp4` (%zu frames, "
                     "%.0f fps), each frame warped by a known similarity J_i = zoom 0.94 * shake_i (bicubic; the "
                     "shake is ShakyFlight's jitter model at 3x its pixel amplitudes: 1.5 px white + 9 px RMS 2-8 Hz "
                     "band, 0.05 + 0.3 deg rotation). Truth = J_i (shaky frame -> steady frame), so the residual "
                     "jitter is measured against the original steady footage; the error vs intended path takes the "
                     "steady footage as the intended path (the drone's own slow motion is in both). Also the "
                     "stability score and ITF (see the real-clip section). %s",
                     clip.frames.size(), clip.fps(), delaysText().c_str()));
    ClipResult r = evaluate(clip, ms, true);
    std::vector<ClipResult> one;
    one.push_back(std::move(r));
    frag.table(truthTable(o, "drone", one, ms, false, true));
    frag.text(boxVsGauss(one));
    frag.text("Cross-check of ours against its own FrameStats:");
    frag.table(crossCheckTable(one, ms));
    const std::string errors = errorsOf(one);
    if (!errors.empty())
        frag.text("Problems:\n\n" + errors);
    trajectoryPlot(o, one.front(), "trajectory_drone.png",
                   "without the added shake (the drone's own motion not known)");
    frag.text("![trajectory](trajectory_drone.png)\n\nCamera path of the shaken drone clip: raw (estimated) and "
              "smoothed (delay 20).");
    for (ClipResult &x : one)
        truth_results->push_back(std::move(x));
}

// The strong-shake section's methods: the input, vid.stab default, and ours (every planner
// but the paper's box) at delays 0, 5 and 20.
std::vector<Method> strongMethods(const std::vector<Method> &ms)
{
    std::vector<Method> m;
    for (const Method &x : atDelays(ms, {0, 5, kReferenceDelay}))
        if (x.kind == Kind::Input || x.kind == Kind::VidstabDefault ||
            (x.kind == Kind::Ours && x.config.planner != PlannerKind::Box))
            m.push_back(x);
    return m;
}

// Per shake and method: residual jitter after the first second (mean and worst seed) against
// vid.stab default's on the same seeds, jitter against the intended path, coverage and zoom.
void strongRows(const Options &o, const StrongShake &shake, const std::vector<ClipResult> &results,
                const std::vector<Method> &ms, Table *t)
{
    for (const Method &m : ms) {
        if (!ranOnAny(results, m.key))
            continue;
        std::vector<double> ratios;
        for (const ClipResult &r : results) {
            const Metrics *x = find(r, m.key), *v = find(r, "vidstab");
            if (x && v && std::isfinite(x->jitter_steady / v->jitter_steady))
                ratios.push_back(x->jitter_steady / v->jitter_steady);
        }
        const VsVidstab j = vsVidstab(results, m.key, &Metrics::jitter_steady);
        const VsVidstab pj = vsVidstab(results, m.key, &Metrics::path_jitter);
        const double worst = maxOf(collect(results, m.key, &Metrics::jitter_steady));
        const double cov_min = minOf(collect(results, m.key, &Metrics::coverage_min));
        const double zoom_max = maxOf(collect(results, m.key, &Metrics::zoom_max));
        t->row({shake.label(), m.label, delayCell(m), num(j.value) + " (" + num(worst) + ")",
                num(j.value / j.vidstab, "%.2fx") + " (" + num(maxOf(ratios), "%.2fx") + ")", num(pj.value),
                num(pj.value / pj.vidstab, "%.2fx"), num(cov_min, "%.4f"), num(zoom_max, "%.3f"),
                std::to_string(j.clips)});
        const std::string key = "quality.strong." + shake.key() + "." +
                                (m.kind == Kind::Ours ? format("%s.d%d", m.family.c_str(), m.delay) : m.key);
        putResult(o, key + ".jitter", j.value);
        putResult(o, key + ".jitter_worst", worst);
        putResult(o, key + ".jitter_vs_vidstab", j.value / j.vidstab);
        putResult(o, key + ".jitter_vs_vidstab_worst", maxOf(ratios));
        putResult(o, key + ".path_jitter", pj.value);
        putResult(o, key + ".path_jitter_vs_vidstab", pj.value / pj.vidstab);
        putResult(o, key + ".coverage_min", cov_min);
        putResult(o, key + ".zoom_max", zoom_max);
        putResult(o, key + ".seeds", j.clips);
    }
}

void sectionStrong(const Options &o, const std::vector<Method> &all)
{
    Fragment frag(o, "quality_strong");
    const std::vector<Method> ms = strongMethods(all);
    std::vector<StrongShake> shakes{{0.5, false}, {1, false}, {2, false}, {1, true}};
    std::vector<std::uint32_t> seeds{1, 2, 3};
    const int frames = 160;
    if (o.quick) {
        shakes = {{1, false}};
        seeds = {1};
    }
    std::string shakes_text, keys;
    for (const StrongShake &s : shakes) {
        shakes_text += (shakes_text.empty() ? "" : ", ") + s.label();
        keys += (keys.empty() ? "" : ",") + s.key();
        putResultText(o, "quality.strong." + s.key() + ".label", s.label());
    }
    putResultText(o, "quality.strong.shakes", keys);
    std::string ours;
    for (const OursEntry &e : oursTable())
        if (e.config.planner != PlannerKind::Box)
            ours += (ours.empty() ? "" : "; ") + e.label;
    frag.text(format(
        "Strong shake: ShakyFlight's default hover flight (the Lissajous drift and slow yaw of the synthetic "
        "section, over tests/data/aero1.jpg) at 1280x720, %d frames at 30 fps, no moving objects, seed%s %s, with "
        "the \"strong720\" shake of tests/bench/bench_path.cpp instead of the default jitter: per axis 3 px RMS "
        "white + 11 px RMS 2-8 Hz band (11.4 px RMS in all), roll 0.1 deg white + 0.5 deg band, every amplitude "
        "multiplied by the strength: %s.%s The drift keeps its speed (about 1.5 px/frame) at every strength; "
        "its amplitude shrinks to leave the shake room on the canvas. Frames are "
        "rendered and the whole stabilizer runs on them (`Stabilizer`, defaults but the planner and the delay), "
        "measured as in the synthetic section: output_to_input from registering each output frame to its input "
        "frame (ORB + RANSAC), output path = truePose_i * output_to_input_i. **Jitter after 1 s** = "
        "`synthetic::residualJitter` of the output path (RMS over the corners of the path minus its Gaussian "
        "low-pass, sigma 8 frames) over the frames after the first second; mean over the seeds and, in brackets, "
        "the worst seed. **vs vid.stab** = ours' mean / vid.stab default's (two-pass, optzoom=1, crop=black) mean "
        "over the same seeds, in brackets the worst seed's own ratio. **vs intended** = "
        "`synthetic::intendedPathJitter` (the high-pass of output against the intended path) after the first "
        "second. Coverage min and zoom max over every frame of every seed. Ours: %s, at delays 0, 5 and %d. "
        "Targets (default planner, each strength): jitter after 1 s <= 1.5x vid.stab's at delay 0, 1x at 5, 0.5x "
        "at 20; coverage min >= 0.995; zoom <= 1.10.",
        frames, seeds.size() > 1 ? "s" : "", seeds.size() > 1 ? "1, 2, 3" : "1", shakes_text.c_str(),
        o.quick ? " (Quick run: strength 1, seed 1, no vibration flight.)"
                : " The vibration flight keeps the default jitter (0.5 px white + 3 px RMS 2-8 Hz band, 0.05 + "
                  "0.3 deg) and adds bench_rolling_shutter.cpp's reference propeller vibration: sinusoids near 47 "
                  "Hz (aliased at 30 fps), 2 px RMS per axis and 0.1 deg of roll, global shutter (readout 0); its "
                  "target: the default planner no worse than the optimal planner at each delay.",
        ours.c_str(), kReferenceDelay));
    std::vector<ClipResult> results;
    std::vector<std::vector<ClipResult>> per_shake;
    for (const StrongShake &s : shakes) {
        per_shake.emplace_back();
        for (std::uint32_t seed : seeds)
            per_shake.back().push_back(evaluate(strongClip(s, seed, frames), ms, false));
    }
    Table t({"shake", "method", "delay", "jitter after 1 s px (worst seed)", "vs vid.stab (worst seed)",
             "vs intended after 1 s px", "vs vid.stab", "coverage min", "zoom max", "seeds"});
    for (std::size_t k = 0; k < shakes.size(); ++k)
        strongRows(o, shakes[k], per_shake[k], ms, &t);
    frag.table(t);
    for (std::vector<ClipResult> &group : per_shake)
        for (ClipResult &r : group)
            results.push_back(std::move(r));
    frag.text("Jitter after 1 s (px) per clip:");
    frag.table(matrixTable(results, ms, &Metrics::jitter_steady));
    frag.text("Coverage min per clip:");
    frag.table(matrixTable(results, ms, &Metrics::coverage_min, "%.4f"));
    frag.text("Zoom per clip, mean (max over the frames):");
    frag.table(matrixTable(results, ms, &Metrics::zoom_mean, "%.3f", false, &Metrics::zoom_max));
    frag.text("Cross-check of ours: the registered measurement against the stabilizer's own account "
              "(`synthetic::outputToInput(FrameStats)`; jitter over the whole clip), means over the clips; the "
              "corner gap is the measuring stick's error.");
    frag.table(crossCheckTable(results, ms));
    const std::string errors = errorsOf(results);
    if (!errors.empty())
        frag.text("Problems:\n\n" + errors);
}

void sectionReal(const Options &o, const std::vector<Method> &ms)
{
    Fragment frag(o, "quality_real");
    std::vector<std::string> files;
    if (!o.data_dir.empty())
        if (DIR *d = opendir(o.data_dir.c_str())) {
            while (dirent *e = readdir(d)) {
                const std::string n = e->d_name;
                if (n.size() > 4 && (n.substr(n.size() - 4) == ".mp4" || n.substr(n.size() - 4) == ".avi"))
                    files.push_back(n);
            }
            closedir(d);
        }
    std::sort(files.begin(), files.end());
    if (files.empty() || !haveCommand("ffmpeg")) {
        frag.text("Real clips: skipped: " +
                  std::string(files.empty() ? "no clips in " + (o.data_dir.empty() ? "(no data dir)" : o.data_dir)
                                            : "ffmpeg is needed to decode them") +
                  ".");
        return;
    }
    const int max_frames = o.quick ? 100 : 240;
    if (o.quick) {
        // Three clips no wider than 1280 (the 1080p drone clip is in the drone section).
        std::vector<std::string> small;
        for (const std::string &f : files) {
            DecodedClip info;
            if (small.size() < 3 && probeVideo(o.data_dir + "/" + f, &info) && info.width <= 1280)
                small.push_back(f);
        }
        files = small;
    }
    frag.text(format(
        "Real clips from ../shared/data (first %d frames at most). **Stability score** (Liu et al. 2013): the "
        "output's inter-frame similarity motion (ORB + RANSAC between consecutive output frames) is accumulated "
        "into a path; FFT of its translation magnitude and of its rotation angle; share of the energy in bins 1-5 "
        "among bins 1..N/2 (DC excluded); reported as translation / rotation, higher = steadier. **ITF** = mean "
        "PSNR (dB) between consecutive output frames over the central 60 %% of the luma, higher = steadier. "
        "Note: computed on the accumulated path, as in the paper, the score is dominated by intentional motion "
        "(pans, drift) on these clips (the inputs already score about 0.9), so it separates methods weakly; ITF "
        "and, where the truth is known, the residual jitter separate them better. Coverage and zoom from "
        "registering each output frame to its input frame. The input's values beside. %s To keep the run short, "
        "the stability score (one more registration per frame) is computed for ours at delay %d only; ITF, "
        "coverage and zoom at every delay.",
        max_frames, delaysText().c_str(), kReferenceDelay));
    std::vector<ClipResult> results;
    for (const std::string &f : files) {
        Clip c;
        c.name = f.substr(0, f.size() - 4);
        c.label = c.name;
        if (!decodeClip(o.data_dir + "/" + f, max_frames, &c)) {
            frag.text("Could not decode " + f + ": skipped.");
            continue;
        }
        c.label = format("%s (%dx%d, %zu fr)", c.name.c_str(), c.width, c.height, c.frames.size());
        results.push_back(evaluate(std::move(c), ms, true, false));
    }
    Table agg({"method", "delay", "stability t / r (mean)", "ITF dB (mean)", "ITF gain over input dB",
               "ITF - vid.stab dB (mean, worst clip)", "clips ITF >= vid.stab", "clips zoom <= vid.stab",
               "clips both", "coverage mean", "coverage min", "zoom mean", "zoom max"});
    const double in_itf = mean(collect(results, "input", &Metrics::itf));
    for (const Method &m : ms) {
        if (!ranOnAny(results, m.key))
            continue;
        const double st = mean(collect(results, m.key, &Metrics::stability_t));
        const double sr = mean(collect(results, m.key, &Metrics::stability_r));
        const double itf = mean(collect(results, m.key, &Metrics::itf));
        std::vector<double> diff;
        int ge = 0, zoom_le = 0, both = 0, clips = 0;
        for (const ClipResult &r : results) {
            const Metrics *x = find(r, m.key), *v = find(r, "vidstab");
            if (!x || !v || !std::isfinite(x->itf) || !std::isfinite(v->itf))
                continue;
            ++clips;
            diff.push_back(x->itf - v->itf);
            const bool a = x->itf >= v->itf, b = x->zoom_mean <= v->zoom_mean + 5e-4;
            ge += a;
            zoom_le += b;
            both += a && b;
        }
        agg.row({m.label, delayCell(m), num(st, "%.3f") + " / " + num(sr, "%.3f"), num(itf, "%.2f"),
                 num(itf - in_itf, "%+.2f"), num(mean(diff), "%+.2f") + " (" + num(minOf(diff), "%+.2f") + ")",
                 format("%d / %d", ge, clips), format("%d / %d", zoom_le, clips), format("%d / %d", both, clips),
                 num(mean(collect(results, m.key, &Metrics::coverage_mean)), "%.4f"),
                 num(minOf(collect(results, m.key, &Metrics::coverage_min)), "%.4f"),
                 num(mean(collect(results, m.key, &Metrics::zoom_mean)), "%.3f"),
                 num(maxOf(collect(results, m.key, &Metrics::zoom_max)), "%.3f")});
        // Against the Gaussian window at the reference delay (issue 20's target for the default).
        int ge_gaussian = 0, with_gaussian = 0;
        std::vector<double> diff_gaussian;
        for (const ClipResult &r : results) {
            const Metrics *x = find(r, m.key), *g = find(r, oursKey("gauss20", kReferenceDelay));
            if (!x || !g || !std::isfinite(x->itf) || !std::isfinite(g->itf))
                continue;
            ++with_gaussian;
            ge_gaussian += x->itf >= g->itf;
            diff_gaussian.push_back(x->itf - g->itf);
        }
        const std::string key = "quality.real." + m.key;
        if (with_gaussian > 0) {
            putResult(o, key + ".clips_with_gaussian", with_gaussian);
            putResult(o, key + ".clips_itf_ge_gaussian", ge_gaussian);
            putResult(o, key + ".itf_minus_gaussian_min", minOf(diff_gaussian));
            putResult(o, key + ".itf_minus_gaussian", mean(diff_gaussian));
        }
        putResult(o, key + ".stability_t", st);
        putResult(o, key + ".stability_r", sr);
        putResult(o, key + ".itf", itf);
        putResult(o, key + ".itf_minus_vidstab", mean(diff));
        putResult(o, key + ".itf_minus_vidstab_min", minOf(diff));
        putResult(o, key + ".clips", clips);
        putResult(o, key + ".clips_itf_ge_vidstab", ge);
        putResult(o, key + ".clips_zoom_le_vidstab", zoom_le);
        putResult(o, key + ".clips_both", both);
        putResult(o, key + ".coverage_min", minOf(collect(results, m.key, &Metrics::coverage_min)));
        putResult(o, key + ".zoom_max", maxOf(collect(results, m.key, &Metrics::zoom_max)));
    }
    frag.text(format("Over the %zu real clips (vid.stab = vid.stab default; \"zoom <= vid.stab\" compares the mean "
                     "registered zoom per clip, 0.0005 tolerance):",
                     results.size()));
    frag.table(agg);
    frag.text("ITF (dB) per clip:");
    frag.table(matrixTable(results, ms, &Metrics::itf));
    frag.text("ITF minus vid.stab default's (dB) per clip:");
    frag.table(matrixTable(results, ms, &Metrics::itf, "%+.2f", true));
    frag.text("Zoom per clip, mean (max over the frames):");
    frag.table(matrixTable(results, ms, &Metrics::zoom_mean, "%.3f", false, &Metrics::zoom_max));
    frag.text("Coverage min per clip:");
    frag.table(matrixTable(results, ms, &Metrics::coverage_min, "%.4f"));
    frag.text("Failed registrations (output -> input and output -> previous output) per clip:");
    frag.table(matrixTable(results, ms, &Metrics::failed_registrations, "%.0f"));
    // The zoom plot: the clip where vid.stab zooms most (its zoom follows the clip's shake).
    const ClipResult *shown = nullptr;
    double most = -1;
    for (const ClipResult &r : results)
        if (const Metrics *v = find(r, "vidstab"); v && std::isfinite(v->zoom_mean) && v->zoom_mean > most) {
            most = v->zoom_mean;
            shown = &r;
        }
    if (!shown && !results.empty())
        shown = &results.front();
    if (shown) {
        zoomPlot(o, *shown, ms, "zoom_real.png");
        frag.text(format("![zoom over time](zoom_real.png)\n\nZoom over time on %s (the clip where vid.stab default "
                         "zooms most): ours (%s at every delay, the others at delay %d) and vid.stab.",
                         shown->clip.label.c_str(), oursTable().front().label.c_str(), kReferenceDelay));
    }
    const std::string errors = errorsOf(results);
    if (!errors.empty())
        frag.text("Problems:\n\n" + errors);
}

void putMethodList(const Options &o)
{
    std::string names, delays;
    for (const OursEntry &e : oursTable()) {
        names += (names.empty() ? "" : ",") + e.name;
        putResultText(o, "quality.ours." + e.name + ".label", e.label);
    }
    for (int d : kDelays)
        delays += (delays.empty() ? "" : ",") + std::to_string(d);
    putResultText(o, "quality.ours.names", names);
    putResultText(o, "quality.ours.delays", delays);
    putResult(o, "quality.ours.reference_delay", kReferenceDelay);
}

} // namespace

int main(int argc, char **argv)
{
    try {
        const Options o = parseOptions(
            argc, argv,
            "usage: uavstab-bench-quality --out DIR [--quick] [--data DIR] [--only synthetic|manoeuvre|drone|strong|real]...\n");
        const bool deshake = ffmpegHasFilter("deshake");
        const bool vidstab = ffmpegHasFilter("vidstabdetect") && ffmpegHasFilter("vidstabtransform");
        if (!deshake)
            std::printf("ffmpeg deshake not available: the quality tables go without it\n");
        if (!vidstab)
            std::printf("ffmpeg vid.stab not available: the quality tables go without it\n");
        const std::vector<Method> ms = methods(deshake, vidstab);
        putMethodList(o);
        std::vector<ClipResult> truth_results;
        const auto t0 = Clock::now();
        auto timed = [&](const char *name, const std::function<void()> &section) {
            const auto t = Clock::now();
            section();
            const double s = secondsBetween(t, Clock::now());
            std::printf("[%s: %.0f s]\n", name, s);
            putResult(o, std::string("quality.seconds.") + name, s);
        };
        if (o.wants("synthetic"))
            timed("synthetic", [&] { sectionSynthetic(o, ms, &truth_results); });
        if (o.wants("manoeuvre"))
            timed("manoeuvre", [&] { sectionManoeuvre(o, ms, &truth_results); });
        if (o.wants("drone"))
            timed("drone", [&] { sectionDrone(o, ms, &truth_results); });
        if (o.wants("strong"))
            timed("strong", [&] { sectionStrong(o, ms); });
        if (!truth_results.empty())
            jitterPlot(o, truth_results, ms);
        if (o.wants("real"))
            timed("real", [&] { sectionReal(o, ms); });
        std::printf("[quality: %.0f s]\n", secondsBetween(t0, Clock::now()));
    } catch (const std::exception &e) {
        std::cerr << "uavstab-bench-quality: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
