// The camera-path planners alone, on true camera paths (perfect motion estimates, no
// pixels): what a planner leaves of the shake and how it treats the intended path, at every
// delay, over several seeds and shake strengths, in seconds rather than the quality
// benchmark's minutes. For planner work; the quality benchmark (bench_quality.cpp) measures
// the whole stabilizer on rendered frames.
//
//   uavstab-bench-path [--planner l1|optimal|gaussian|box]... [--case NAME]... [--seeds N]
//                      [--strengths 0.5,1,2] [--delays 0,5,10,20] [--frames N] [--out FILE.md]
//                      [--l1 name=value,...]
//
// Cases (ShakyFlight paths; strength scales every jitter amplitude):
//   hover360   the default drifting flight, 640x360
//   hover720   the same at 1280x720
//   drone1080  1920x1080, no intended motion, ShakyFlight's jitter at 3x its pixel amplitudes
//              (the quality benchmark's drone clip's shake)
//   strong720  1280x720, ~16 px RMS of shake (11.4 px per axis) and 0.5 deg of roll
//   man360     the manoeuvre flight (hover, pans, a yaw turn, stops, a climb), 640x360
//   man720     the same at 1280x720
//   vib720     hover720 with 47 Hz propeller vibration (2 px, 0.1 deg RMS, aliased at 30 fps)
//   sway720    a handheld camera meant to be still: 20 / 12 px RMS of 0.3-1.2 Hz sway, 0.4 deg of
//              roll sway, 4 px of 2-8 Hz shake, 1280x720
// Columns: jitter = RMS high-pass (Gaussian sigma 8) of the output frame's corners against
// the intended path (output minus intended: a smooth lag is not shake), after the first
// second; first s = the same over the first second alone; lag = the largest distance of a
// corner from its mean place relative to the intended path (how far the output strays or
// trails, px, worst seed); whip = the output's fastest corner move over the intended path's
// fastest, after the first second (synthetic::pathWhip; above 1 the output rushes to catch
// up; 0 where the intended view stands still; worst seed); input = the same jitter of the
// camera itself; coverage min; plan ms mean and p99.
//   --l1 name=value,... changes the l1 planner's settings, to A/B one of its terms.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "jitter_metrics.hpp"
#include "shaky_flight.hpp"
#include "path/l1_path_planner.hpp"
#include "path/path_planner.hpp"

using namespace uavstab;

namespace {

struct Case {
    std::string name;
    int width = 640, height = 360, fps = 30;
    std::vector<Similarity> truth;     // frame (centred) -> world
    std::vector<Similarity> intended;  // the same without the shake
};

// Band-limited noise: a sum of sinusoids with random frequencies in [lo, hi] Hz, RMS 1.
std::vector<double> bandNoise(std::mt19937 &rng, int n, double lo, double hi, double fps)
{
    std::uniform_real_distribution<double> f(lo, hi), ph(0.0, 6.283185307);
    std::vector<double> v(std::size_t(n), 0.0);
    for (int k = 0; k < 8; ++k) {
        const double fk = f(rng), pk = ph(rng);
        for (int i = 0; i < n; ++i)
            v[std::size_t(i)] += std::sin(6.283185307 * fk * i / fps + pk) / 2.0;  // 8 x (1/2)^2 / 2 = 1
    }
    return v;
}

Case makeCase(const std::string &name, std::uint32_t seed, double strength, int frames)
{
    Case c;
    c.name = name;
    if (name == "sway720") {
        // A handheld camera meant to be still: sway of 20 px RMS at 0.3-1.2 Hz, 0.4 deg of roll
        // sway, and 4 px of 2-8 Hz shake, at 1280x720.
        c.width = 1280;
        c.height = 720;
        std::mt19937 rng(seed);
        const auto sx = bandNoise(rng, frames, 0.3, 1.2, 30), sy = bandNoise(rng, frames, 0.3, 1.2, 30);
        const auto sa = bandNoise(rng, frames, 0.3, 1.2, 30);
        const auto hx = bandNoise(rng, frames, 2.0, 8.0, 30), hy = bandNoise(rng, frames, 2.0, 8.0, 30);
        for (int i = 0; i < frames; ++i) {
            const std::size_t k = std::size_t(i);
            c.intended.push_back({0.0, 0.0, 0.0, 1.0});
            c.truth.push_back({strength * (20.0 * sx[k] + 4.0 * hx[k]), strength * (12.0 * sy[k] + 4.0 * hy[k]),
                               strength * 0.4 * 0.01745329 * sa[k], 1.0});
        }
        return c;
    }
    synthetic::FlightOptions o;
    o.seed = seed;
    o.frames = frames;
    if (name == "hover720" || name == "man720" || name == "strong720" || name == "vib720") {
        o.width = 1280;
        o.height = 720;
    }
    if (name == "man360" || name == "man720")
        o.profile = synthetic::FlightProfile::Manoeuvre;
    if (name == "drone1080") {
        o.width = 1920;
        o.height = 1080;
        o.pan_speed = 0;
        o.rotation_amplitude_deg = 0;
        o.noise_px *= 3.0;
        o.band_px *= 3.0;
    }
    if (name == "strong720") {
        // ~16 px RMS per axis at 720p and 0.5 deg of roll.
        o.noise_px = 3.0;
        o.band_px = 11.0;
        o.rotation_noise_deg = 0.1;
        o.rotation_band_deg = 0.5;
    }
    if (name == "vib720") {
        // The default jitter and bench_rolling_shutter.cpp's reference propeller vibration
        // (global shutter), as quality_strong.cpp's vibration flight; strength scales both.
        o.vibration_hz = 47;
        o.vibration_px = 2.0 * strength;
        o.vibration_deg = 0.1 * strength;
    }
    o.noise_px *= strength;
    o.band_px *= strength;
    o.rotation_noise_deg *= strength;
    o.rotation_band_deg *= strength;
    const synthetic::ShakyFlight flight(o);
    c.width = o.width;
    c.height = o.height;
    c.fps = int(std::lround(o.fps));
    for (int i = 0; i < flight.frameCount(); ++i) {
        c.truth.push_back(flight.truePose(i));
        c.intended.push_back(flight.intendedPose(i));
    }
    return c;
}

struct Result {
    double jitter = 0, first_second = 0, max_dev = 0, whip = 0, input = 0, coverage_min = 1, ms_mean = 0, ms_p99 = 0;
};

// --l1 name=value,...: the l1 planner's settings changed from their defaults, for A/B runs of
// its terms (e.g. --l1 steady_pull=0 switches the steady pull off).
L1PathPlanner::Settings l1Settings(const std::string &spec)
{
    L1PathPlanner::Settings s;
    std::map<std::string, double *> reals{
        {"velocity_weight", &s.velocity_weight}, {"acceleration_weight", &s.acceleration_weight},
        {"jerk_weight", &s.jerk_weight},         {"edge_weight", &s.edge_weight},
        {"follow_smoothness", &s.follow_smoothness}, {"catch_up_threshold", &s.catch_up_threshold},
        {"shake_margin", &s.shake_margin},       {"short_tube", &s.short_tube},
        {"steady_pull", &s.steady_pull},         {"steady_from", &s.steady_from},
        {"steady_full", &s.steady_full},         {"stiffness", &s.stiffness},
        {"young_slope_prior", &s.young_slope_prior}, {"translation_reserve", &s.translation_reserve},
        {"scale_share", &s.scale_share}, {"speed_weight", &s.speed_weight}, {"crop", &s.crop},
        {"room_per_shake", &s.room_per_shake}};
    std::map<std::string, int *> ints{{"rounds", &s.rounds},
                                      {"catch_up_window", &s.catch_up_window},
                                      {"catch_up_max_lookahead", &s.catch_up_max_lookahead},
                                      {"full_tube_lookahead", &s.full_tube_lookahead},
                                      {"steady_window", &s.steady_window},
                                      {"extension", &s.extension},
                                      {"shake_crop_frames", &s.shake_crop_frames},
                                      {"prediction_frames", &s.prediction_frames}};
    std::stringstream ss(spec);
    std::string item;
    while (std::getline(ss, item, ',')) {
        const std::size_t eq = item.find('=');
        const std::string key = item.substr(0, eq);
        const double value = eq == std::string::npos ? 0.0 : std::stod(item.substr(eq + 1));
        if (key == "shake_crop")
            s.shake_crop = value != 0.0;
        else if (reals.count(key))
            *reals[key] = value;
        else if (ints.count(key))
            *ints[key] = int(value);
        else {
            std::fprintf(stderr, "uavstab-bench-path: no l1 setting named %s\n", key.c_str());
            std::exit(2);
        }
    }
    return s;
}

std::string l1_spec;  // --l1

Result run(const Case &c, PlannerKind kind, int delay)
{
    const int n = int(c.truth.size()), w = c.width, h = c.height, fps = c.fps;
    const std::vector<Similarity> &truth = c.truth, &intended = c.intended;
    std::vector<Similarity> camera;
    for (const Similarity &t : truth)
        camera.push_back(truth.front().inverse() * t);
    StabilizerConfig config;
    config.planner = kind;
    config.delay = delay;
    std::unique_ptr<PathPlanner> planner = makePathPlanner(config);
    if (kind == PlannerKind::L1 && !l1_spec.empty())
        planner = std::make_unique<L1PathPlanner>(l1Settings(l1_spec));
    std::vector<Similarity> output_path;
    std::vector<double> ms;
    Result r;
    for (int i = 0; i < n; ++i) {
        PlanRequest req;
        req.index = i;
        req.segment_start = i == 0;
        for (int j = i; j < n && j <= i + delay; ++j)
            req.lookahead.push_back(camera[std::size_t(j)]);
        req.width = w;
        req.height = h;
        const auto t0 = std::chrono::steady_clock::now();
        const PlannedFrame p = planner->plan(req);
        ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        output_path.push_back(truth[std::size_t(i)] * p.output_to_input);
        r.coverage_min = std::min(r.coverage_min, synthetic::coverage(p.output_to_input, w, h));
        if (const char *dump = std::getenv("UAVSTAB_PATH_DUMP")) {  // per-frame poses, for a closer look
            static FILE *f = std::fopen(dump, "w");
            const Similarity e = intended[std::size_t(i)].inverse() * output_path.back();
            const Similarity t = intended[std::size_t(i)].inverse() * truth[std::size_t(i)];
            std::fprintf(f, "%d %d %.4f %.4f %.6f %.4f %.4f %.6f\n", delay, i, e.dx, e.dy, e.angle, t.dx, t.dy, t.angle);
        }
    }
    r.jitter = synthetic::intendedPathJitter(output_path, intended, w, h, std::size_t(fps));
    r.input = synthetic::intendedPathJitter(truth, intended, w, h, std::size_t(fps));
    {
        const std::vector<Similarity> first(output_path.begin(), output_path.begin() + std::min(n, fps));
        r.first_second = synthetic::intendedPathJitter(first, intended, w, h);
    }
    r.max_dev = synthetic::intendedPathMaxDeviation(output_path, intended, w, h);
    r.whip = synthetic::pathWhip(output_path, intended, w, h, std::size_t(fps));
    double sum = 0;
    for (double v : ms)
        sum += v;
    r.ms_mean = sum / double(ms.size());
    std::sort(ms.begin(), ms.end());
    r.ms_p99 = ms[std::min(ms.size() - 1, std::size_t(0.99 * double(ms.size())))];
    return r;
}

std::vector<double> numbers(const char *text)
{
    std::vector<double> v;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ','))
        v.push_back(std::stod(item));
    return v;
}

PlannerKind plannerOf(const std::string &name)
{
    if (name == "optimal")
        return PlannerKind::Optimal;
    if (name == "gaussian")
        return PlannerKind::Gaussian;
    if (name == "box")
        return PlannerKind::Box;
    return PlannerKind::L1;
}

} // namespace

int main(int argc, char **argv)
{
    std::vector<std::string> planners, cases;
    std::vector<double> strengths{0.5, 1.0, 2.0}, delays{0, 5, 10, 20};
    int seeds = 3, frames = 300, first_seed = 1;
    std::string out;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : "";
        if (a == "--planner") planners.push_back(v), ++i;
        else if (a == "--case") cases.push_back(v), ++i;
        else if (a == "--seeds") seeds = std::atoi(v), ++i;
        else if (a == "--first-seed") first_seed = std::atoi(v), ++i;
        else if (a == "--strengths") strengths = numbers(v), ++i;
        else if (a == "--delays") delays = numbers(v), ++i;
        else if (a == "--frames") frames = std::atoi(v), ++i;
        else if (a == "--out") out = v, ++i;
        else if (a == "--l1") l1_spec = v, ++i;
        else {
            std::fprintf(stderr, "usage: uavstab-bench-path [--planner l1|optimal|gaussian|box]... [--case NAME]... "
                                 "[--seeds N] [--strengths a,b] [--delays a,b] [--frames N] [--out FILE.md] [--l1 name=value,...]\n");
            return 2;
        }
    }
    if (planners.empty())
        planners = {"l1", "optimal"};
    if (cases.empty())
        cases = {"hover360", "hover720", "drone1080", "strong720", "vib720", "sway720", "man360", "man720"};

    std::ostringstream md;
    md << "The planners alone, fed the true camera path of ShakyFlight clips (perfect motion estimates, no "
          "pixels): `uavstab-bench-path` (tests/bench/bench_path.cpp), "
       << seeds << " seeds (mean and worst seed), " << frames
       << " frames (the drone case 177), every delay and shake strength. Cases: hover360/hover720 = the drifting "
          "hover at 640x360 / 1280x720; drone1080 = no intended motion, ShakyFlight's jitter at 3x its pixel "
          "amplitudes (the drone clip's shake); strong720 = ~16 px RMS of shake (11.4 px per axis) and 0.5 deg of "
          "roll at 1280x720; vib720 = hover720 with 47 Hz propeller vibration (2 px, 0.1 deg, aliased at 30 fps); man360/man720 = the manoeuvre flight; sway720 = a handheld camera meant to be still "
          "(20 / 12 px RMS of 0.3-1.2 Hz sway, 0.4 deg of roll sway, 4 px of shake), larger than the crop "
          "room. **Jitter** = `synthetic::intendedPathJitter` (high-pass of the output against the intended path, "
          "after the first second); **first second** the same over the first second alone; **lag** the "
          "largest distance of an output corner from its mean place relative to the intended path (worst seed); "
          "**whip** the output's fastest corner move over the intended path's fastest after the first second "
          "(corners smoothed with a Gaussian of sigma 2 frames; 0 where the intended view stands still; worst seed); **input** the "
          "camera's own jitter; plan ms per frame on one thread (mean / p99 over seeds).\n\n";
    md << "| case | strength | planner | delay | jitter px (mean / worst seed) | first second px | lag px | whip | "
          "input jitter px | coverage min | plan ms mean / p99 |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::string &name : cases)
        for (double strength : strengths)
            for (const std::string &pl : planners)
                for (double d : delays) {
                    Result mean;
                    double worst = 0, p99 = 0;
                    for (int s = first_seed; s < first_seed + seeds; ++s) {
                        const Case c = makeCase(name, std::uint32_t(s), strength,
                                                name == "drone1080" ? std::min(frames, 177) : frames);
                        const Result r = run(c, plannerOf(pl), int(d));
                        mean.jitter += r.jitter / seeds;
                        mean.first_second += r.first_second / seeds;
                        mean.max_dev = std::max(mean.max_dev, r.max_dev);
                        mean.whip = std::max(mean.whip, r.whip);
                        mean.input += r.input / seeds;
                        mean.coverage_min = std::min(mean.coverage_min, r.coverage_min);
                        mean.ms_mean += r.ms_mean / seeds;
                        worst = std::max(worst, r.jitter);
                        p99 = std::max(p99, r.ms_p99);
                    }
                    char line[512];
                    std::snprintf(line, sizeof line,
                                  "| %s | %.1fx | %s | %d | %.3f / %.3f | %.3f | %.1f | %.2f | %.3f | %.4f | %.3f / %.3f |\n",
                                  name.c_str(), strength, pl.c_str(), int(d), mean.jitter, worst, mean.first_second,
                                  mean.max_dev, mean.whip, mean.input, mean.coverage_min, mean.ms_mean, p99);
                    md << line;
                    std::fputs(line, stdout);
                    std::fflush(stdout);
                }
    if (!out.empty())
        std::ofstream(out) << md.str();
    return 0;
}
