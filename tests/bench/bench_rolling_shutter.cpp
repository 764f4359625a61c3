// Rolling-shutter correction: how much of a rolling shutter's wobble the library
// removes, what it does to footage that has none, and what it costs. Runs the library
// directly (Stabilizer + pooled output frames, 2 threads, defaults otherwise; the cost
// section on 1 thread), auto (the default) beside rolling_shutter=off.
//
//   uavstab-bench-rolling-shutter --out DIR [--quick] [--data DIR] [--only flights|still|osd|cost]...
//
// Sections (markdown fragments in DIR, numbers in DIR/summary.tsv for the report's targets):
//   flights  rs_flights.md  synthetic 640x360 flights read out over 50 / 90 % of the frame time
//                           with propeller vibration (and the reference, 80 % at 47 Hz):
//                           wobble in and out (wobble_metric.hpp), the shake left against the
//                           same flight from a global shutter, coverage
//   still    rs_still.md    footage without a wobble, auto vs off: global-shutter flights (with
//                           and without vibration) and the real clips of --data
//   osd      rs_osd.md      hazy global-shutter flights with a burned-in flight OSD, beside the
//                           same flights without it, auto vs off (the OSD must not be taken for
//                           a rolling shutter)
//   cost     rs_cost.md     CPU per frame at 1920x1080, auto vs off, on a global-shutter and a
//                           rolling-shutter flight
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include "common.hpp"
#include "format_conversion.hpp"
#include "jitter_metrics.hpp"
#include "osd.hpp"
#include "shaky_flight.hpp"
#include "render/row_transforms.hpp"
#include "uavstab/stabilizer.hpp"
#include "wobble_metric.hpp"

using namespace uavstab;
using namespace bench;

namespace {

const double kNaN = std::nan("");
const std::vector<int> kDelays{0, 5, 20};
constexpr int kFirstSecond = 30;  // shake is measured after it: the steady state
const char *const kArDrone = "uav_ardrone_indoor_shaky_640x360";

// ---- footage -----------------------------------------------------------------------------

struct Vibration {
    double hz = 0, px = 0, deg = 0;
    std::string label() const { return hz > 0 ? format("%.0f Hz %.0f px %.2f deg", hz, px, deg) : "none"; }
};

struct Footage {
    std::string name;
    int width = 0, height = 0;
    double fps = 30;
    std::vector<FrameBuffer> frames;  // I420
    std::vector<Similarity> truth;    // mid-exposure pose per frame (synthetic only)
    std::shared_ptr<const synthetic::ShakyFlight> flight;  // each row's pose (synthetic only)
    double wobble_in = kNaN;
};

cv::Mat lumaOf(const FrameBuffer &f)
{
    return cv::Mat(f.height(), f.width(), CV_8UC1, const_cast<std::uint8_t *>(f.row(0, 0)),
                   std::size_t(f.view().planes[0].stride));
}

// WobbleMeter's clip-level wobble (the mean over the frame pairs that could be measured), with
// the pairs measured on every core: the metric costs more than the stabilizer.
double meanWobble(const std::vector<cv::Mat> &lumas)
{
    std::vector<double> pairs(lumas.size(), kNaN);
    cv::parallel_for_(cv::Range(1, std::max(1, int(lumas.size()))), [&](const cv::Range &r) {
        for (int i = r.start; i < r.end; ++i)
            pairs[std::size_t(i)] = synthetic::wobble(lumas[std::size_t(i) - 1], lumas[std::size_t(i)]);
    });
    double sum = 0;
    int measured = 0;
    for (double w : pairs)
        if (std::isfinite(w)) {
            sum += w;
            ++measured;
        }
    return measured > 0 ? sum / measured : 0.0;
}

double meanWobbleOf(const std::vector<FrameBuffer> &frames)
{
    std::vector<cv::Mat> lumas;
    for (const FrameBuffer &f : frames)
        lumas.push_back(lumaOf(f));
    return meanWobble(lumas);
}

Footage renderFlight(int width, int height, int frames, std::uint32_t seed, double readout, const Vibration &v)
{
    synthetic::FlightOptions o;
    o.width = width;
    o.height = height;
    o.frames = frames;
    o.seed = seed;
    o.readout = readout;
    o.vibration_hz = v.hz;
    o.vibration_px = v.px;
    o.vibration_deg = v.deg;
    const auto shared_flight = std::make_shared<const synthetic::ShakyFlight>(o);
    const synthetic::ShakyFlight &flight = *shared_flight;
    Footage f;
    f.flight = shared_flight;
    f.name = format("%dx%d readout %.1f, %s, seed %u", width, height, readout, v.label().c_str(), seed);
    f.width = width;
    f.height = height;
    f.frames.resize(std::size_t(frames));
    // Each row of a rolling-shutter frame is warped on its own: render on every core.
    cv::parallel_for_(cv::Range(0, frames), [&](const cv::Range &r) {
        for (int i = r.start; i < r.end; ++i)
            f.frames[std::size_t(i)] = flight.render(i);
    });
    for (int i = 0; i < frames; ++i)
        f.truth.push_back(flight.truePose(i));
    return f;
}

// The first max_frames frames of a real clip, as I420 in memory (as bench_quality decodes them).
bool decodeClip(const std::string &path, int max_frames, Footage *f)
{
    DecodedClip d;
    if (!decodeI420(path, max_frames, &d))
        return false;
    f->width = d.width;
    f->height = d.height;
    f->fps = double(d.fps_num) / d.fps_den;
    f->frames = std::move(d.frames);
    return true;
}

// ---- one run of the stabilizer -------------------------------------------------------------

struct Run {
    double wobble_in = kNaN;      // the footage's, for tables
    double wobble_out = kNaN;
    double shake = kNaN;          // residual jitter of the output path after the first second (synthetic)
    // The same with each output corner taken through its own row's transform to the input
    // row it shows, and that row's true pose (a rolling-shutter frame has no single pose).
    double shake_rows = kNaN;
    double coverage_min = 1.0;    // synthetic::coverage of output_to_input (ignores the per-row offsets)
    double picture_min = 1.0;     // 1 - share of black (luma 16) output pixels, worst frame
    double itf = kNaN;            // mean PSNR of consecutive output frames, central 60 %
    double zoom_max = 1.0;        // largest 1 / scale of output_to_input (crop zoom with the path's scale)
    int corrected = 0;            // frames whose rows were moved (row_motion not empty)
    double reported = 0.0;        // mean row_motion.wobble over the corrected frames
    int unwarped = 0;
};

StabilizerConfig configFor(RollingShutter mode, int delay, int threads = 2)
{
    StabilizerConfig c;
    c.rolling_shutter = mode;
    c.delay = delay;
    c.threads = threads;
    return c;
}

// measure_wobble = false skips the output's wobble (the metric costs more than the stabilizer).
Run stabilize(const Footage &footage, const StabilizerConfig &config, bool measure_wobble = true)
{
    Run r;
    r.wobble_in = footage.wobble_in;
    Stabilizer stabilizer(config);
    stabilizer.setFrameInterval(1000.0 / footage.fps);
    OutputPool pool(PixelFormat::I420, footage.width, footage.height);
    std::vector<cv::Mat> output_lumas;
    std::vector<Similarity> output_path;
    std::vector<std::array<Point2, 4>> output_corners;
    double itf_sum = 0;
    int itf_pairs = 0;
    auto take = [&](StabilizedFrame f) {
        const auto &slot = static_cast<const PoolSlot &>(*f.slot);
        const std::size_t i = std::size_t(slot.index());
        const bool warped = f.outcome == Outcome::Warped;
        r.unwarped += warped ? 0 : 1;
        const cv::Mat luma = lumaOf(warped ? *slot.output() : footage.frames[i]);
        if (!output_lumas.empty()) {
            itf_sum += psnrCentral(output_lumas.back(), luma);
            ++itf_pairs;
        }
        if (measure_wobble || output_lumas.empty())
            output_lumas.push_back(luma.clone());
        else
            luma.copyTo(output_lumas.back());
        const double black = double(cv::countNonZero(luma == 16)) / double(luma.total());
        r.picture_min = std::min(r.picture_min, 1.0 - black);
        const Similarity output_to_input = synthetic::outputToInput(f.stats);
        r.coverage_min = std::min(r.coverage_min, synthetic::coverage(output_to_input, footage.width, footage.height));
        r.zoom_max = std::max(r.zoom_max, 1.0 / output_to_input.scale);
        if (!footage.truth.empty())
            output_path.push_back(footage.truth[i] * output_to_input);
        if (footage.flight) {
            const RowMatrices rows(rollingShutterWarp(f.stats.output_to_input, f.stats.row_motion, footage.width,
                                                      footage.height),
                                   footage.width, footage.height);
            const double cx = 0.5 * (footage.width - 1), cy = 0.5 * (footage.height - 1);
            std::array<Point2, 4> world;
            for (int c = 0; c < 4; ++c) {
                const double x = c % 2 ? footage.width - 1 : 0, y = c / 2 ? footage.height - 1 : 0;
                const std::array<double, 6> m = rows.at(y);
                const double qx = m[0] * x + m[1] * y + m[2], qy = m[3] * x + m[4] * y + m[5];
                world[std::size_t(c)] = footage.flight->truePoseAtRow(int(i), qy).apply({qx - cx, qy - cy});
            }
            output_corners.push_back(world);
        }
        if (!f.stats.row_motion.empty()) {
            ++r.corrected;
            r.reported += f.stats.row_motion.wobble;
        }
    };
    for (std::size_t i = 0; i < footage.frames.size(); ++i) {
        stabilizer.push(std::make_unique<PoolSlot>(footage.frames[i].view(), pool, long(i)));
        while (auto f = stabilizer.tryPop())
            take(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        take(std::move(*f));
    if (measure_wobble)
        r.wobble_out = meanWobble(output_lumas);
    r.itf = itf_pairs > 0 ? itf_sum / itf_pairs : kNaN;
    r.reported = r.corrected > 0 ? r.reported / r.corrected : 0.0;
    if (!output_path.empty())
        r.shake = synthetic::residualJitter(output_path, footage.width, footage.height, 8.0, kFirstSecond);
    if (!output_corners.empty())
        r.shake_rows = synthetic::cornerJitter(output_corners, 8.0, kFirstSecond);
    return r;
}

// ---- aggregation ---------------------------------------------------------------------------

// Mean and worst (largest, or smallest for `lower_is_worse`) over seeds.
struct Spread {
    std::vector<double> values;
    void add(double v) { values.push_back(v); }
    double avg() const { return values.empty() ? kNaN : mean(values); }
    double worst() const { return values.empty() ? kNaN : maxOf(values); }
    double least() const { return values.empty() ? kNaN : minOf(values); }
    std::string cell(const char *f) const
    {
        return values.size() > 1 ? format(f, avg()) + " / " + format(f, worst()) : format(f, avg());
    }
};

// Global-shutter runs are shared by both synthetic sections: the flights' reference and the
// still footage's auto-vs-off comparison.
struct GlobalRuns {
    std::map<std::string, Run> runs;
    static std::string key(const Vibration &v, std::uint32_t seed, int delay, RollingShutter mode)
    {
        return format("%s/%u/%d/%d", v.label().c_str(), seed, delay, int(mode));
    }
};

struct Setup {
    int frames = 150;
    std::vector<std::uint32_t> seeds{1, 2, 3};
};

Setup setupOf(const Options &o)
{
    Setup s;
    if (o.quick) {
        s.frames = 90;
        s.seeds = {1};
    }
    return s;
}

// Runs the global-shutter twin of a vibration at every delay, auto and off, unless done.
void runGlobal(GlobalRuns &g, const Setup &s, const Vibration &v, std::uint32_t seed)
{
    if (g.runs.count(GlobalRuns::key(v, seed, kDelays.front(), RollingShutter::Auto)))
        return;
    Footage f = renderFlight(640, 360, s.frames, seed, 0.0, v);
    f.wobble_in = meanWobbleOf(f.frames);
    for (int d : kDelays)
        for (RollingShutter mode : {RollingShutter::Auto, RollingShutter::Off}) {
            const Run r = stabilize(f, configFor(mode, d), false);
            std::printf("  global shutter, %s, seed %u, delay %d, %s: shake %.3f px, wobble in %.3f px, corrected %d\n",
                        v.label().c_str(), seed, d, mode == RollingShutter::Auto ? "auto" : "off", r.shake,
                        f.wobble_in, r.corrected);
            std::fflush(stdout);
            g.runs[GlobalRuns::key(v, seed, d, mode)] = r;
        }
}

// ---- section: rolling-shutter flights -------------------------------------------------------

struct FlightCase {
    double readout;
    Vibration vibration;
    bool reference;  // the reference flight: also run with rolling_shutter=off
};

void sectionFlights(const Options &o, GlobalRuns &global)
{
    Fragment frag(o, "rs_flights");
    const Setup s = setupOf(o);
    const Vibration slow{30, 1, 0.05}, fast{60, 3, 0.15}, reference{47, 2, 0.1};
    const std::vector<FlightCase> cases{{0.5, slow, false}, {0.5, fast, false}, {0.9, slow, false},
                                        {0.9, fast, false}, {0.8, reference, true}};
    frag.text(format(
        "Synthetic flights (ShakyFlight, the default Lissajous hover, 640x360, %d frames, seeds %s) seen by a "
        "rolling shutter that reads its rows over the given share of the frame time, on a camera with propeller "
        "vibration (x, y in px RMS and roll in degrees RMS near the frequency; the flight's usual 2-8 Hz jitter on "
        "top). The library as it is (`Stabilizer`, 2 threads, defaults: rolling_shutter auto, no readout time), "
        "and rolling_shutter=off on the issue's reference flight (80 %%, 47 Hz) for the before. **Wobble** = "
        "`synthetic::WobbleMeter` (the non-rigid motion between consecutive frames, px), in = the input's, out = "
        "the output's. **Shake left** = the residual jitter (`synthetic::cornerJitter`) after the first second of the "
        "output's corners in the world, each corner taken through its own output row's transform to the input "
        "row it shows and that row's true pose (a rolling-shutter frame has no single pose); **at mid-exposure** = "
        "`synthetic::residualJitter` of true mid-exposure pose x output_to_input, as before; **vs global** = that divided by the same on the same flight "
        "rendered with a global shutter (readout 0, same vibration) through the same stabilizer. **Coverage** = "
        "`synthetic::coverage` of output_to_input (it ignores the per-row offsets), **picture** = 1 - the share "
        "of black (luma 16) output pixels; both the worst frame. **Corrected** = frames whose rows were moved "
        "(row_motion not empty), of %d. **Zoom max** = the largest 1 / scale of output_to_input over the frames "
        "(the crop's zoom with the path's own scale), worst seed. Cells: mean / worst seed. Targets: wobble out "
        "<= 0.3x in; shake left <= 1.5x the global-shutter flight's; zoom <= 1.10.",
        s.frames, s.seeds.size() > 1 ? "1-3" : "1 (quick)", s.frames));
    Table t({"readout", "vibration", "rolling shutter", "delay", "wobble in px", "wobble out px", "out / in",
             "shake left px", "(at mid-exposure) px", "global shutter px", "vs global", "coverage min",
             "picture min", "zoom max", "corrected"});
    double wobble_worst = 0, shake_worst = 0, wobble_sum = 0, shake_sum = 0, coverage = 1, picture = 1;
    double zoom_worst = 1;
    double off_ratio_sum = 0;
    int runs = 0, off_runs = 0;
    std::string wobble_worst_case, shake_worst_case;
    for (const FlightCase &c : cases) {
        std::vector<RollingShutter> modes{RollingShutter::Auto};
        if (c.reference)
            modes.push_back(RollingShutter::Off);
        // Per mode (index into `modes`) and delay, over seeds.
        std::map<std::pair<int, int>, Spread> in, out, ratio, shake, shake_mid, shake_global, shake_ratio, cov, pic,
            zoom, corrected;
        for (std::uint32_t seed : s.seeds) {
            runGlobal(global, s, c.vibration, seed);
            Footage f = renderFlight(640, 360, s.frames, seed, c.readout, c.vibration);
            f.wobble_in = meanWobbleOf(f.frames);
            for (std::size_t m = 0; m < modes.size(); ++m) {
                const RollingShutter mode = modes[m];
                for (int d : kDelays) {
                    const std::pair<int, int> at{int(m), d};
                    const Run r = stabilize(f, configFor(mode, d));
                    const Run &g = global.runs.at(GlobalRuns::key(c.vibration, seed, d, RollingShutter::Auto));
                    const double wr = r.wobble_out / f.wobble_in, sr = r.shake_rows / g.shake_rows;
                    in[at].add(f.wobble_in);
                    out[at].add(r.wobble_out);
                    ratio[at].add(wr);
                    shake[at].add(r.shake_rows);
                    shake_mid[at].add(r.shake);
                    shake_global[at].add(g.shake_rows);
                    shake_ratio[at].add(sr);
                    cov[at].add(r.coverage_min);
                    pic[at].add(r.picture_min);
                    zoom[at].add(r.zoom_max);
                    corrected[at].add(r.corrected);
                    const std::string what = format("readout %.1f, %s, delay %d, seed %u", c.readout,
                                                    c.vibration.label().c_str(), d, seed);
                    std::printf("  %s, %s: wobble %.3f -> %.3f px (%.2fx), shake (rows) %.3f px vs global %.3f (%.2fx), "
                                "coverage %.4f, picture %.4f, corrected %d, reported %.3f px\n",
                                what.c_str(), mode == RollingShutter::Auto ? "auto" : "off", f.wobble_in,
                                r.wobble_out, wr, r.shake_rows, g.shake_rows, sr, r.coverage_min, r.picture_min, r.corrected,
                                r.reported);
                    std::fflush(stdout);
                    if (mode == RollingShutter::Off) {
                        off_ratio_sum += wr;
                        ++off_runs;
                        continue;
                    }
                    ++runs;
                    wobble_sum += wr;
                    shake_sum += sr;
                    coverage = std::min(coverage, r.coverage_min);
                    picture = std::min(picture, r.picture_min);
                    zoom_worst = std::max(zoom_worst, r.zoom_max);
                    if (!(wr <= wobble_worst)) {
                        wobble_worst = wr;
                        wobble_worst_case = what;
                    }
                    if (!(sr <= shake_worst)) {
                        shake_worst = sr;
                        shake_worst_case = what;
                    }
                }
            }
        }
        for (std::size_t m = 0; m < modes.size(); ++m)
            for (int d : kDelays) {
                const std::pair<int, int> at{int(m), d};
                t.row({format("%.0f %%", 100 * c.readout), c.vibration.label(),
                       modes[m] == RollingShutter::Auto ? "auto" : "**off**", std::to_string(d), in[at].cell("%.3f"),
                       out[at].cell("%.3f"), ratio[at].cell("%.2fx"), shake[at].cell("%.3f"),
                       shake_mid[at].cell("%.3f"), shake_global[at].cell("%.3f"), shake_ratio[at].cell("%.2fx"), format("%.4f", cov[at].least()),
                       format("%.4f", pic[at].least()), format("%.3f", zoom[at].worst()),
                       corrected[at].cell("%.0f")});
            }
    }
    frag.table(t);
    putResult(o, "rs.flights.runs", runs);
    putResult(o, "rs.flights.wobble_ratio_worst", wobble_worst);
    putResultText(o, "rs.flights.wobble_ratio_worst_case", wobble_worst_case);
    putResult(o, "rs.flights.wobble_ratio_mean", wobble_sum / runs);
    putResult(o, "rs.flights.shake_ratio_worst", shake_worst);
    putResultText(o, "rs.flights.shake_ratio_worst_case", shake_worst_case);
    putResult(o, "rs.flights.shake_ratio_mean", shake_sum / runs);
    putResult(o, "rs.flights.off_wobble_ratio_mean", off_ratio_sum / off_runs);
    putResult(o, "rs.flights.coverage_min", coverage);
    putResult(o, "rs.flights.picture_min", picture);
    putResult(o, "rs.flights.zoom_max", zoom_worst);
}

// ---- section: footage without a wobble ------------------------------------------------------

void sectionStillSynthetic(const Options &o, Fragment &frag, GlobalRuns &global)
{
    const Setup s = setupOf(o);
    const std::vector<Vibration> vibrations{{}, {30, 1, 0.05}, {60, 3, 0.15}, {47, 2, 0.1}};
    frag.text(format("Global-shutter flights (readout 0; 640x360, %d frames, seeds %s), without and with the "
                     "vibrations of the flights above: **residual jitter** after the first second with auto and with "
                     "off (target: auto within 5 %% of off), and the frames auto corrected (row_motion not empty; "
                     "there is no wobble to find). Cells: mean / worst seed; the difference's worst is the largest "
                     "|auto / off - 1| over seeds.",
                     s.frames, s.seeds.size() > 1 ? "1-3" : "1 (quick)"));
    Table t({"vibration", "delay", "wobble in px", "jitter off px", "jitter auto px", "auto / off - 1 (worst)",
             "frames corrected (auto)"});
    double worst_diff = 0;
    int corrected_total = 0, frames_total = 0;
    for (const Vibration &v : vibrations) {
        for (std::uint32_t seed : s.seeds)
            runGlobal(global, s, v, seed);
        for (int d : kDelays) {
            Spread in, off, on;
            double diff = 0;
            int corrected = 0;
            for (std::uint32_t seed : s.seeds) {
                const Run &a = global.runs.at(GlobalRuns::key(v, seed, d, RollingShutter::Auto));
                const Run &b = global.runs.at(GlobalRuns::key(v, seed, d, RollingShutter::Off));
                in.add(a.wobble_in);
                on.add(a.shake);
                off.add(b.shake);
                const double rel = a.shake / b.shake - 1.0;
                if (std::abs(rel) >= std::abs(diff))
                    diff = rel;
                corrected += a.corrected;
                frames_total += s.frames;
            }
            corrected_total += corrected;
            worst_diff = std::max(worst_diff, std::abs(diff));
            t.row({v.label(), std::to_string(d), in.cell("%.3f"), off.cell("%.3f"), on.cell("%.3f"),
                   format("%+.1f %%", 100 * diff),
                   format("%d of %d", corrected, int(s.frames * s.seeds.size()))});
        }
    }
    frag.table(t);
    putResult(o, "rs.still.syn.jitter_diff_worst", worst_diff);
    putResult(o, "rs.still.syn.corrected", corrected_total);
    putResult(o, "rs.still.syn.frames", frames_total);
}

void sectionStillReal(const Options &o, Fragment &frag)
{
    std::vector<std::string> files = o.data_dir.empty() ? std::vector<std::string>{} : realClipFiles(o.data_dir);
    if (files.empty() || !haveCommand("ffmpeg")) {
        frag.text("Real clips: skipped: " +
                  std::string(files.empty() ? "no clips in " + (o.data_dir.empty() ? "(no data dir)" : o.data_dir)
                                            : "ffmpeg is needed to decode them") +
                  ".");
        return;
    }
    const int max_frames = o.quick ? 100 : 240;
    if (o.quick) {  // the AR.Drone clip and two others
        std::vector<std::string> some;
        for (const std::string &f : files)
            if (f.rfind(kArDrone, 0) == 0 || (some.size() < 2 && f.find("1920x1080") == std::string::npos))
                some.push_back(f);
        files = some;
    }
    frag.text(format(
        "Real clips from ../shared/data (first %d frames; the AR.Drone clip 240), auto vs off at delays 20 and 0. **Wobble** as above "
        "(px at the clip's size). **ITF** = mean PSNR (dB) between consecutive output frames over the central 60 %% "
        "of the luma, higher = steadier. **Corrected** = frames auto moved the rows of, with the mean wobble it "
        "reported for them. **Picture min** = 1 - the share of black (luma 16) output pixels, worst frame, auto / "
        "off: borders let in by the bent rows would lower it (dark picture counts too, alike in both). Targets: on "
        "clips whose input wobble is below 0.2 px, ITF within 0.1 dB of off; on every clip (the AR.Drone clip, "
        "%s, among them) auto no worse than off: ITF no lower than off's less 0.05 dB, picture min no lower.",
        max_frames, kArDrone));
    Table t({"clip", "wobble in px", "wobble out d20 auto / off", "ITF d20 auto / off dB", "auto - off d20",
             "wobble out d0 auto / off", "ITF d0 auto / off dB", "auto - off d0", "corrected d20 (reported px)",
             "picture min d20 auto / off", "picture min d0 auto / off"});
    int low_clips = 0, corrected_clips = 0, clips_run = 0;
    double low_worst = 0, picture_lost = 0, itf_drop = -1e9;
    std::string low_failed, itf_drop_case;
    for (const std::string &file : files) {
        Footage f;
        f.name = file.substr(0, file.size() - 4);
        // The AR.Drone clip's first ~100 frames sit on the floor: even the quick run takes 240.
        const int frames = file.rfind(kArDrone, 0) == 0 ? 240 : max_frames;
        if (!decodeClip(o.data_dir + "/" + file, frames, &f)) {
            frag.text("Could not decode " + file + ": skipped.");
            continue;
        }
        f.wobble_in = meanWobbleOf(f.frames);
        ++clips_run;
        std::map<int, Run> on, off;
        for (int d : {20, 0}) {
            on[d] = stabilize(f, configFor(RollingShutter::Auto, d));
            off[d] = stabilize(f, configFor(RollingShutter::Off, d));
            std::printf("  %s delay %d: wobble in %.3f, out auto %.3f / off %.3f px; ITF auto %.3f / off %.3f dB; "
                        "corrected %d (%.3f px)\n",
                        f.name.c_str(), d, f.wobble_in, on[d].wobble_out, off[d].wobble_out, on[d].itf, off[d].itf,
                        on[d].corrected, on[d].reported);
            std::fflush(stdout);
        }
        const double diff20 = on[20].itf - off[20].itf, diff0 = on[0].itf - off[0].itf;
        t.row({format("%s (%dx%d, %zu fr)", f.name.c_str(), f.width, f.height, f.frames.size()),
               format("%.3f", f.wobble_in), format("%.3f / %.3f", on[20].wobble_out, off[20].wobble_out),
               format("%.3f / %.3f", on[20].itf, off[20].itf), format("%+.3f", diff20),
               format("%.3f / %.3f", on[0].wobble_out, off[0].wobble_out),
               format("%.3f / %.3f", on[0].itf, off[0].itf), format("%+.3f", diff0),
               format("%d of %zu (%.2f)", on[20].corrected, f.frames.size(), on[20].reported),
               format("%.4f / %.4f", on[20].picture_min, off[20].picture_min),
               format("%.4f / %.4f", on[0].picture_min, off[0].picture_min)});
        for (int d : {20, 0}) {
            picture_lost = std::max(picture_lost, off[d].picture_min - on[d].picture_min);
            if (off[d].itf - on[d].itf > itf_drop) {
                itf_drop = off[d].itf - on[d].itf;
                itf_drop_case = format("%s, delay %d", f.name.c_str(), d);
            }
            corrected_clips += on[d].corrected > 0 && d == 20 ? 1 : 0;
        }
        const std::string key = "rs.still.real." + f.name;
        putResult(o, key + ".wobble_in", f.wobble_in);
        if (f.wobble_in < 0.2) {
            ++low_clips;
            const double worst = std::max(std::abs(diff20), std::abs(diff0));
            low_worst = std::max(low_worst, worst);
            if (worst > 0.1)
                low_failed += (low_failed.empty() ? "" : ", ") + f.name;
        }
        if (f.name == kArDrone) {
            putResult(o, "rs.still.ardrone.wobble_in", f.wobble_in);
            for (int d : {20, 0}) {
                putResult(o, format("rs.still.ardrone.d%d.wobble_out", d), on[d].wobble_out);
                putResult(o, format("rs.still.ardrone.d%d.wobble_out_off", d), off[d].wobble_out);
                putResult(o, format("rs.still.ardrone.d%d.itf_minus_off", d), on[d].itf - off[d].itf);
                putResult(o, format("rs.still.ardrone.d%d.corrected", d), on[d].corrected);
            }
            putResult(o, "rs.still.ardrone.frames", double(f.frames.size()));
        }
    }
    frag.table(t);
    putResult(o, "rs.still.real.low_wobble_clips", low_clips);
    putResult(o, "rs.still.real.picture_lost_worst", picture_lost);
    putResult(o, "rs.still.real.itf_drop_worst", itf_drop);
    putResultText(o, "rs.still.real.itf_drop_worst_case", itf_drop_case.empty() ? "none" : itf_drop_case);
    putResult(o, "rs.still.real.corrected_clips", corrected_clips);
    putResult(o, "rs.still.real.clips", clips_run);
    putResult(o, "rs.still.real.low_wobble_itf_diff_worst", low_worst);
    putResultText(o, "rs.still.real.low_wobble_failed", low_failed);
}

void sectionStill(const Options &o, GlobalRuns &global)
{
    Fragment frag(o, "rs_still");
    sectionStillSynthetic(o, frag, global);
    sectionStillReal(o, frag);
}

// ---- section: a burned-in OSD on a global shutter --------------------------------------------

Footage renderHazyFlight(int width, int height, int frames, std::uint32_t seed, double strength, bool osd)
{
    synthetic::FlightOptions o;
    o.width = width;
    o.height = height;
    o.frames = frames;
    o.seed = seed;
    o.noise_px *= strength;
    o.band_px *= strength;
    o.rotation_noise_deg *= strength;
    o.rotation_band_deg *= strength;
    const synthetic::ShakyFlight flight(o);
    Footage f;
    f.width = width;
    f.height = height;
    f.frames.resize(std::size_t(frames));
    cv::parallel_for_(cv::Range(0, frames), [&](const cv::Range &r) {
        for (int i = r.start; i < r.end; ++i) {
            cv::Mat bgr = synthetic::hazy(flight.renderBgr(i));
            if (osd)
                synthetic::burnOsd(bgr, i);
            FrameBuffer frame(PixelFormat::I420, width, height);
            synthetic::bgrToFrame(bgr, frame);
            f.frames[std::size_t(i)] = std::move(frame);
        }
    });
    for (int i = 0; i < frames; ++i)
        f.truth.push_back(flight.truePose(i));
    return f;
}

void sectionOsd(const Options &o)
{
    Fragment frag(o, "rs_osd");
    const Setup s = setupOf(o);
    const std::vector<double> strengths{1.0, 2.0, 3.0};
    struct Size {
        int width, height;
        std::vector<int> delays;
    };
    const std::vector<Size> sizes{{640, 360, kDelays}, {1280, 720, {20}}};
    frag.text(format(
        "Hazy global-shutter flights (ShakyFlight through `synthetic::hazy`: contrast 0.5, blur 2 px; %d frames, "
        "seeds %s; the shake 1, 2 and 3 times the default's) with the exclude tests' burned-in flight OSD "
        "(`synthetic::burnOsd`: text bars, speed and altitude boxes with tape ticks, crosshair, pitch ladder), "
        "beside the same flights without it; defaults (rolling_shutter auto, exclude_static on) and "
        "rolling_shutter=off. **Jitter** = residual jitter after the first second (px). **Rows moved** = frames "
        "auto corrected for a rolling shutter (there is none). Cells: mean / worst seed. Targets: OSD (auto) <= "
        "1.1x + 0.1 px of no OSD; auto within 5 %% of off.",
        s.frames, s.seeds.size() > 1 ? "1-3" : "1 (quick)"));
    Table t({"size", "shake", "delay", "no OSD px", "OSD auto px", "OSD off px", "OSD auto / (1.1 no OSD + 0.1)",
             "auto / off - 1 (worst)", "rows moved (auto)"});
    double target_worst = 0, diff_worst = 0;
    int moved_total = 0;
    for (const Size &size : sizes)
        for (double strength : strengths) {
            std::map<int, Spread> clean, with, off, target;
            std::map<int, double> diff;
            std::map<int, int> moved;
            for (std::uint32_t seed : s.seeds) {
                const Footage plain = renderHazyFlight(size.width, size.height, s.frames, seed, strength, false);
                const Footage osd = renderHazyFlight(size.width, size.height, s.frames, seed, strength, true);
                for (int d : size.delays) {
                    const Run a = stabilize(plain, configFor(RollingShutter::Auto, d), false);
                    const Run b = stabilize(osd, configFor(RollingShutter::Auto, d), false);
                    const Run c = stabilize(osd, configFor(RollingShutter::Off, d), false);
                    clean[d].add(a.shake);
                    with[d].add(b.shake);
                    off[d].add(c.shake);
                    const double tr = b.shake / (1.1 * a.shake + 0.1), rel = b.shake / c.shake - 1.0;
                    target[d].add(tr);
                    if (std::abs(rel) >= std::abs(diff[d]))
                        diff[d] = rel;
                    moved[d] += b.corrected + a.corrected;
                    target_worst = std::max(target_worst, tr);
                    diff_worst = std::max(diff_worst, std::abs(rel));
                    moved_total += b.corrected + a.corrected;
                    std::printf("  osd %dx%d shake x%.0f seed %u delay %d: no OSD %.3f, OSD auto %.3f (rows moved %d), "
                                "OSD off %.3f px\n",
                                size.width, size.height, strength, seed, d, a.shake, b.shake, b.corrected, c.shake);
                    std::fflush(stdout);
                }
            }
            for (int d : size.delays)
                t.row({format("%dx%d", size.width, size.height), format("x%.0f", strength), std::to_string(d),
                       clean[d].cell("%.3f"), with[d].cell("%.3f"), off[d].cell("%.3f"), target[d].cell("%.2f"),
                       format("%+.1f %%", 100 * diff[d]), std::to_string(moved[d])});
        }
    frag.table(t);
    putResult(o, "rs.osd.target_ratio_worst", target_worst);
    putResult(o, "rs.osd.auto_off_diff_worst", diff_worst);
    putResult(o, "rs.osd.rows_moved", moved_total);
}

// ---- section: cost at 1080p -----------------------------------------------------------------

struct Cost {
    double estimate_ms = 0;  // push(): estimation, on the calling thread
    double worker_ms = 0;    // the worker thread: planning and warping
    double total_ms = 0;     // the process
    int corrected = 0;
};

// One pass over the frames on one library thread (OpenCV held to one thread too), CPU per frame.
Cost measureCost(const Footage &footage, RollingShutter mode)
{
    StabilizerConfig config = configFor(mode, 20, 1);
    Stabilizer stabilizer(config);
    stabilizer.setFrameInterval(1000.0 / footage.fps);
    OutputPool pool(PixelFormat::I420, footage.width, footage.height);
    Cost c;
    auto take = [&](StabilizedFrame f) { c.corrected += f.stats.row_motion.empty() ? 0 : 1; };
    const double process0 = cpuSeconds(CLOCK_PROCESS_CPUTIME_ID), thread0 = cpuSeconds(CLOCK_THREAD_CPUTIME_ID);
    double push = 0;
    for (std::size_t i = 0; i < footage.frames.size(); ++i) {
        const double t = cpuSeconds(CLOCK_THREAD_CPUTIME_ID);
        stabilizer.push(std::make_unique<PoolSlot>(footage.frames[i].view(), pool, long(i)));
        push += cpuSeconds(CLOCK_THREAD_CPUTIME_ID) - t;
        while (auto f = stabilizer.tryPop())
            take(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        take(std::move(*f));
    const double process = cpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - process0;
    const double main_thread = cpuSeconds(CLOCK_THREAD_CPUTIME_ID) - thread0;
    const double n = double(footage.frames.size());
    c.estimate_ms = 1000 * push / n;
    c.worker_ms = 1000 * (process - main_thread) / n;
    c.total_ms = 1000 * process / n;
    return c;
}

void sectionCost(const Options &o)
{
    Fragment frag(o, "rs_cost");
    const int frames = o.quick ? 45 : 90, repeats = o.quick ? 3 : 7;
    frag.text(format(
        "CPU per frame at 1920x1080 I420 (%d frames per run, medians of %d runs, auto and off alternated in one "
        "process, the order swapped every run; **total vs off** = the median over runs of auto / off within a run): `StabilizerConfig::threads = 1` and OpenCV held to one thread, "
        "delay 20. **Estimation** = the calling thread's CPU time inside push(); **warp** = the worker thread's "
        "(planning and warping: the process's CPU time minus the calling thread's); **total** = the process's (also "
        "the output buffers' first use and flush() on the calling thread). "
        "Flights (a) global shutter (the default hover, with the reference vibration; nothing to correct) and (b) "
        "read out over 80 %% of the frame time with 47 Hz, 2 px, 0.1 deg vibration. Targets: (a) total within 5 %% "
        "of off; (b) at most +25 %%.",
        frames, repeats));
    Table t({"flight", "rolling shutter", "estimation ms", "warp ms", "total ms", "total vs off", "frames corrected",
             "other processes"});
    const Vibration reference{47, 2, 0.1};
    const int default_threads = cv::getNumThreads();
    for (const auto &[readout, key, label] :
         {std::tuple<double, const char *, const char *>{0.0, "gs", "(a) global shutter"},
          {0.8, "rs", "(b) readout 80 %, 47 Hz"}}) {
        const Footage f = renderFlight(1920, 1080, frames, 1, readout, reference);
        std::vector<double> est[2], warp[2], total[2], paired;  // paired: auto / off within a run
        int corrected[2] = {0, 0};
        // No waiting for a quiet machine: auto and off alternate, so other work slows both
        // alike; the share it took is reported beside.
        const LoadMonitor load;
        {
            cv::setNumThreads(1);
            for (int rep = 0; rep < repeats; ++rep) {
                for (int k = 0; k < 2; ++k) {
                    const int which = (rep + k) % 2;  // 0 = off, 1 = auto
                    const Cost c = measureCost(f, which ? RollingShutter::Auto : RollingShutter::Off);
                    est[which].push_back(c.estimate_ms);
                    warp[which].push_back(c.worker_ms);
                    total[which].push_back(c.total_ms);
                    corrected[which] = c.corrected;
                    std::printf("  cost %s run %d %s: estimation %.2f ms, warp %.2f ms, total %.2f ms per frame, "
                                "corrected %d\n",
                                key, rep, which ? "auto" : "off", c.estimate_ms, c.worker_ms, c.total_ms, c.corrected);
                    std::fflush(stdout);
                }
                paired.push_back(total[1].back() / total[0].back());
            }
            cv::setNumThreads(default_threads);
        }
        const double others = load.foreignShare();
        // The machine's speed drifts from run to run: the ratio within each A/B pair, then its median.
        const double ratio = median(paired);
        for (int which : {0, 1})
            t.row({label, which ? "auto" : "off", format("%.2f", median(est[which])),
                   format("%.2f", median(warp[which])), format("%.2f", median(total[which])),
                   which ? format("%+.1f %%", 100 * (ratio - 1)) : "", format("%d of %d", corrected[which], frames),
                   loadCell(others)});
        putResult(o, format("rs.cost.%s.total_ms_off", key), median(total[0]));
        putResult(o, format("rs.cost.%s.total_ms_auto", key), median(total[1]));
        putResult(o, format("rs.cost.%s.estimate_ms_off", key), median(est[0]));
        putResult(o, format("rs.cost.%s.estimate_ms_auto", key), median(est[1]));
        putResult(o, format("rs.cost.%s.warp_ms_off", key), median(warp[0]));
        putResult(o, format("rs.cost.%s.warp_ms_auto", key), median(warp[1]));
        putResult(o, format("rs.cost.%s.ratio", key), ratio);
        putResult(o, format("rs.cost.%s.others", key), others);
    }
    frag.table(t);
}

} // namespace

int main(int argc, char **argv)
{
    try {
        const Options o = parseOptions(
            argc, argv,
            "usage: uavstab-bench-rolling-shutter --out DIR [--quick] [--data DIR] [--only flights|still|osd|cost]...\n",
            {"flights", "still", "osd", "cost"});
        GlobalRuns global;
        const auto t0 = Clock::now();
        auto timed = [&](const char *name, const std::function<void()> &section) {
            const auto t = Clock::now();
            section();
            std::printf("[%s: %.0f s]\n", name, secondsBetween(t, Clock::now()));
            std::fflush(stdout);
        };
        if (o.wants("flights"))
            timed("flights", [&] { sectionFlights(o, global); });
        if (o.wants("still"))
            timed("still", [&] { sectionStill(o, global); });
        if (o.wants("osd"))
            timed("osd", [&] { sectionOsd(o); });
        if (o.wants("cost"))
            timed("cost", [&] { sectionCost(o); });
        std::printf("[rolling shutter: %.0f s]\n", secondsBetween(t0, Clock::now()));
    } catch (const std::exception &e) {
        std::cerr << "uavstab-bench-rolling-shutter: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
