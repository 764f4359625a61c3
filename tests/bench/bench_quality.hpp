// Shared by the sources of uavstab-bench-quality (bench_quality.cpp and quality_*.cpp): the
// clips, the methods run on them (ours from oursTable() at every delay of kDelays, and the
// peers), the measurement of one clip's outputs (evaluate()), the tables and plots common to
// several sections, and the sections themselves.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common.hpp"
#include "registration.hpp"
#include "shaky_flight.hpp"
#include "uavstab/stabilizer.hpp"

namespace quality {

using namespace uavstab;
using namespace bench;

constexpr double kPi = 3.14159265358979323846;
const double kNaN = std::nan("");

// ---- clips (quality_clips.cpp) ---------------------------------------------------------

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

// The luma plane of an I420 frame, without a copy.
cv::Mat lumaOf(const FrameBuffer &f);

// A ShakyFlight's frames (I420) with its true and intended poses.
void renderInto(const synthetic::ShakyFlight &flight, Clip *c);

// A ShakyFlight clip: the hover (Lissajous) or the manoeuvre flight, named and grouped for tables.
Clip syntheticClip(int width, int height, std::uint32_t seed, int objects, int frames,
                   synthetic::FlightProfile profile = synthetic::FlightProfile::Lissajous);

// Decodes up to max_frames frames of a real clip to I420 in memory.
bool decodeClip(const std::string &path, int max_frames, Clip *c);

// ---- methods (quality_methods.cpp) -----------------------------------------------------

// Our configurations, one line each. Every entry runs at every delay of kDelays, with
// config.delay set to that delay and everything else as given here; the first entry is the
// library's default. Adding a planner is one line, e.g.
//   {"optimal_r5", "optimal, smoothness 1e4", [] { StabilizerConfig c; c.planner_smoothness = 1e4; return c; }()},
struct OursEntry {
    std::string name;   // keys: ours_<name> at delay 20, ours_<name>_d<delay> otherwise
    std::string label;  // for tables
    StabilizerConfig config;
};

// The table above; UAVSTAB_BENCH_OURS=l1,gauss20 runs only those entries.
const std::vector<OursEntry> &oursTable();

// Look-ahead frames every entry of oursTable() runs at (0 = causal); 20 is the library's default.
// UAVSTAB_BENCH_DELAYS=5,20 runs only those (for quick comparisons while tuning).
extern const std::vector<int> kDelays;
constexpr int kReferenceDelay = 20;

// The method key of an entry of oursTable() at a delay: no suffix at kReferenceDelay.
std::string oursKey(const std::string &name, int delay);

enum class Kind { Input, Ours, Deshake, VidstabDefault, VidstabZoom };

struct Method {
    std::string key, label;
    std::string short_label;  // column headers of per-clip tables
    Kind kind;
    StabilizerConfig config;
    std::string family;  // ours: OursEntry::name; the others: their key
    int delay = -1;      // ours: config.delay; -1: the input and the peers (offline, no delay)
};

// The input, ours (every entry at every delay) and the peers available (UAVSTAB_BENCH_PEERS=0: none).
std::vector<Method> methods(bool deshake, bool vidstab);

// The methods to run on a clip: the input, the peers, and ours at the given delays only.
std::vector<Method> atDelays(const std::vector<Method> &all, const std::vector<int> &delays);

// The "delay" cell of a table row: ours' delay, "-" for the input, "offline" for the peers.
std::string delayCell(const Method &m);

// The label with ours' delay, for plot legends.
std::string longLabel(const Method &m);

// The sentence naming ours and the delays, shared by every section's text.
std::string delaysText();

// The summary keys naming ours and the delays (quality.ours.*).
void putMethodList(const Options &o);

struct Output {
    std::vector<cv::Mat> luma;
    std::vector<FrameStats> stats;  // ours only
    double seconds = 0;
    std::string error;
};

// Ours: the library's Stabilizer on the clip's frames.
Output runOurs(const Clip &clip, const StabilizerConfig &config);

// A peer: ffmpeg with `filter` on the raw frames, after a first pass with `pre_filter` if given.
Output runFfmpeg(const Clip &clip, const std::string &raw, const std::string &filter, const std::string &pre_filter);

// ---- measurement (quality_measure.cpp) -------------------------------------------------

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
    double path_max_dev = kNaN;  // synthetic::intendedPathMaxDeviation (the lag)
    double path_whip = kNaN;     // synthetic::pathWhip after the first second
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

struct ClipResult {
    Clip clip;  // frames released after the run
    std::vector<Method> methods;
    std::vector<Metrics> metrics;
};

// Runs every method on the clip and measures each output (ORB + RANSAC registration).
// real_measures: ITF and (for the input, the peers and ours at delay 20, and for ours at the
// other delays too when stability_every_delay) the stability score, which costs one more
// registration per frame.
ClipResult evaluate(Clip clip, const std::vector<Method> &ms, bool real_measures, bool stability_every_delay = true);

// ---- reporting (quality_report.cpp) ----------------------------------------------------

// v in printf format f, "n/a" when not finite.
std::string num(double v, const char *f = "%.2f");

// The metrics of the method `key` on one clip, nullptr when it did not run there.
const Metrics *find(const ClipResult &r, const std::string &key);

// One "- clip, method: error" line per failed run.
std::string errorsOf(const std::vector<ClipResult> &results);

// The finite values of `field` of method `key` over the clips.
std::vector<double> collect(const std::vector<ClipResult> &results, const std::string &key, double Metrics::*field);

// Whether method `key` ran on any of the clips.
bool ranOnAny(const std::vector<ClipResult> &results, const std::string &key);

// A method's mean of `field` over the clips it ran on, and vid.stab default's mean over the
// same clips (delays other than 20 may run on fewer clips).
struct VsVidstab {
    double value = kNaN, vidstab = kNaN;
    int clips = 0;
};

VsVidstab vsVidstab(const std::vector<ClipResult> &results, const std::string &key, double Metrics::*field);

// Per-method table over a group of clips with known truth: rows = method x delay.
// path_first: the error against the intended path is the headline (manoeuvre flights).
Table truthTable(const Options &o, const std::string &prefix, const std::vector<ClipResult> &results,
                 const std::vector<Method> &ms, bool path_first, bool real_measures);

// Rows = clips, columns = methods (short labels): one measure per cell ("-": not run on it).
Table matrixTable(const std::vector<ClipResult> &results, const std::vector<Method> &ms, double Metrics::*field,
                  const char *number_format = "%.2f", bool minus_vidstab = false,
                  double Metrics::*in_brackets = nullptr);

// Ours: the registered measurement against the stabilizer's own account (FrameStats), as
// means over the clips.
Table crossCheckTable(const std::vector<ClipResult> &results, const std::vector<Method> &ms);

// "gaussian r20 vs box r10" in one sentence (both at delay 20).
std::string boxVsGauss(const std::vector<ClipResult> &results);

// One clip's trajectory figure: dx, dy, angle of the raw path and of the smoothed paths.
void trajectoryPlot(const Options &o, const ClipResult &r, const std::string &file, const std::string &truth_label);

// Residual jitter per method, one group of bars per clip group (residual_jitter.png).
void jitterPlot(const Options &o, const std::vector<ClipResult> &results, const std::vector<Method> &ms);

// ---- sections (quality_<section>.cpp) --------------------------------------------------

// The hover clips; their results are appended to truth_results (for jitterPlot).
void sectionSynthetic(const Options &o, const std::vector<Method> &ms, std::vector<ClipResult> *truth_results);

// The manoeuvre flights; their results are appended to truth_results.
void sectionManoeuvre(const Options &o, const std::vector<Method> &ms, std::vector<ClipResult> *truth_results);

// The real drone clip with a known shake added; its result is appended to truth_results.
void sectionDrone(const Options &o, const std::vector<Method> &ms, std::vector<ClipResult> *truth_results);

// The hover at 1280x720 under strong shake and under propeller vibration.
void sectionStrong(const Options &o, const std::vector<Method> &all);

// The real clips: stability score, ITF, coverage and zoom.
void sectionReal(const Options &o, const std::vector<Method> &ms);

} // namespace quality
