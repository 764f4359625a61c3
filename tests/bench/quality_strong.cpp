// The strong-shake section: the hover at 1280x720 under bench_path.cpp's "strong720" shake at
// several strengths, and with propeller vibration: jitter after the first second against
// vid.stab's, coverage and zoom.
#include <cmath>
#include <utility>

#include "bench_quality.hpp"

namespace quality {

namespace {

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

} // namespace

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

} // namespace quality
