// Assembles OUT/REPORT.md from the run's header (OUT/header.md), the programs' markdown
// fragments (OUT/*.md) and their numbers (OUT/summary.tsv): the targets table and the
// ours-vs-peers speed ratios are computed here.
//
//   uavstab-bench-report --out DIR [--quick]
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <tuple>

#include "common.hpp"

using namespace bench;

namespace {

std::map<std::string, std::string> readSummary(const std::string &path)
{
    std::map<std::string, std::string> m;
    std::ifstream f(path);
    std::string line;
    while (std::getline(f, line)) {
        const auto tab = line.find('\t');
        if (tab != std::string::npos)
            m[line.substr(0, tab)] = line.substr(tab + 1);  // last value wins
    }
    return m;
}

std::string readFile(const std::string &path)
{
    std::ifstream f(path);
    if (!f)
        return "";
    std::ostringstream s;
    s << f.rdbuf();
    return s.str();
}

class Numbers {
public:
    explicit Numbers(std::map<std::string, std::string> m) : m_(std::move(m)) {}
    bool has(const std::string &k) const
    {
        auto it = m_.find(k);
        return it != m_.end() && std::isfinite(std::atof(it->second.c_str()));
    }
    double get(const std::string &k) const { return has(k) ? std::atof(m_.at(k).c_str()) : std::nan(""); }
    std::string text(const std::string &k) const { return m_.count(k) ? m_.at(k) : ""; }

private:
    std::map<std::string, std::string> m_;
};

std::string num(double v, const char *f)
{
    return std::isfinite(v) ? format(f, v) : "n/a";
}

std::vector<std::string> split(const std::string &s, char sep = ',')
{
    std::vector<std::string> v;
    std::stringstream in(s);
    std::string item;
    while (std::getline(in, item, sep))
        if (!item.empty())
            v.push_back(item);
    return v;
}

struct Target {
    std::string what, measured, verdict;
};

std::string verdict(bool measured, bool met)
{
    return !measured ? "not measured" : met ? "**met**" : "**not met**";
}

} // namespace

int main(int argc, char **argv)
{
    try {
        const Options o = parseOptions(argc, argv, "usage: uavstab-bench-report --out DIR [--quick]\n");
        const Numbers n(readSummary(o.out_dir + "/summary.tsv"));
        std::ostringstream r;
        r << readFile(o.out_dir + "/header.md") << "\n";

        // ---- targets ----------------------------------------------------------------
        const bool element = n.has("element.fps.640x480.I420.t2");
        std::vector<Target> targets;
        auto fpsTarget = [&](const std::string &res, double goal) {
            const std::string k = "element.fps." + res + ".I420.t2";
            const std::string lib = "lib.fps." + res + ".I420.t2";
            std::string m = n.has(k) ? num(n.get(k), "%.0f fps (element)") : "element not measured";
            if (n.has(lib))
                m += num(n.get(lib), "; library alone %.0f fps");
            targets.push_back({format("%s I420, element, 2 threads >= %.0f fps", res.c_str(), goal), m,
                               verdict(n.has(k), n.get(k) >= goal)});
        };
        fpsTarget("1920x1080", 200);
        {
            const double e = n.get("element.fps.1920x1080.I420.t2"), d = n.get("peer.deshake.fps.1920x1080");
            const double v = n.get("peer.vidstab.fps.1920x1080");
            std::string m = format("%s / %s deshake fps = %s", num(e, "%.0f").c_str(), num(d, "%.1f").c_str(),
                                   num(e / d, "%.1fx").c_str());
            if (std::isfinite(v))
                m += format(" (vs vid.stab 2 passes: %s)", num(e / v, "%.1fx").c_str());
            targets.push_back(
                {"1920x1080 element >= 10x ffmpeg deshake", m, verdict(std::isfinite(e / d), e / d >= 10)});
        }
        fpsTarget("1280x720", 400);
        {  // Retired: absolute fps at small sizes drift by 40 % on a shared machine; the ratios stay.
            const std::string k = "element.fps.640x480.I420.t2", lib = "lib.fps.640x480.I420.t2";
            std::string m = n.has(k) ? num(n.get(k), "%.0f fps (element)") : "element not measured";
            if (n.has(lib))
                m += num(n.get(lib), "; library alone %.0f fps");
            targets.push_back({"640x480 I420, element, 2 threads (the >= 800 fps target is retired: absolute fps at "
                               "small sizes drift by 40 % on this shared machine; see the ratios below)",
                               m, "reported"});
        }
        fpsTarget("3840x2160", 50);
        {
            const std::string k = "latency.element.1920x1080.p99_ms";
            const std::string lib = "latency.lib.1920x1080.p99_ms";
            std::string m = n.has(k) ? format("p99 %.1f ms (median %.1f ms) beyond the %.0f-frame delay, frame time "
                                              "33.3 ms",
                                              n.get(k), n.get("latency.element.1920x1080.p50_ms"),
                                              n.get("latency.element.1920x1080.delay_frames"))
                                     : "element not measured";
            if (n.has(lib))
                m += num(n.get(lib), "; library alone p99 %.1f ms");
            targets.push_back({"processing latency beyond the delay, p99 <= 1 frame time at 1080p30", m,
                               verdict(n.has(k), n.get(k) <= 1000.0 / 30)});
        }
        {
            const std::string k = "stage.1920x1080.I420.plan_l1_20";
            targets.push_back({"planner cost at delay 20 (l1, the default): mean <= 0.3 ms, p99 <= 1 ms per frame",
                               n.has(k + "_ms") ? format("mean %.3f ms, p99 %.3f ms", n.get(k + "_ms"),
                                                         n.get(k + "_p99_ms"))
                                                : "not measured",
                               verdict(n.has(k + "_ms"), n.get(k + "_ms") <= 0.3 && n.get(k + "_p99_ms") <= 1.0)});
        }
        if (n.has("streams.1080p.one_process"))
            targets.push_back({"(no target) real-time 1080p30 streams at once, live pipelines",
                               format("%.0f in one process, %.0f in separate processes",
                                      n.get("streams.1080p.one_process"), n.get("streams.1080p.processes")),
                               "reported"});
        // Live streams of this tree against a base commit's plugin, same run
        // (streams.sh --base); judged on the lower of the two ratios (one process, N processes).
        if (n.has("streams.1080p.base.one_process") || n.has("streams.1080p.base.processes")) {
            std::string m;
            double worst = HUGE_VAL;
            bool any = false, capped = false;
            for (const std::string mode : {"one_process", "processes"}) {
                if (!n.has("streams.1080p.base." + mode))
                    continue;
                const double r = n.get("streams.1080p.ratio." + mode);
                m += format("%s%s: %s vs %s = %s", m.empty() ? "" : "; ",
                            mode == "one_process" ? "one process" : "separate processes",
                            num(n.get("streams.1080p." + mode), "%.0f").c_str(),
                            num(n.get("streams.1080p.base." + mode), "%.0f").c_str(), num(r, "%.2fx").c_str());
                capped = capped || n.get("streams.1080p.ratio_capped." + mode) > 0;
                if (std::isfinite(r)) {
                    any = true;
                    worst = std::min(worst, r);
                }
            }
            if (capped)
                m += " (a count is only a bound: no run fell behind at the largest N tried)";
            targets.push_back({"live 1080p30 streams >= 1.5x base " + n.text("streams.base") +
                                   " (same run; the lower of the two ratios)",
                               m, verdict(any, worst >= 1.5)});
        }
        // Throughput. The zero-copy mode against the warp, same run.
        {
            const std::string k = "element.affine_meta.1920x1080";
            targets.push_back({"render=affine-meta >= 3x render=warp frames/s at 1920x1080 (element, I420, 2 threads)",
                               n.has(k + ".ratio") ? format("%.0f vs %.0f fps = %.2fx", n.get(k + ".fps"),
                                                            n.get(k + ".warp_fps"), n.get(k + ".ratio"))
                                                   : "not measured",
                               verdict(n.has(k + ".ratio"), n.get(k + ".ratio") >= 3.0)});
            for (const auto &[size, wanted] : {std::pair<std::string, double>{"1920x1080", 30},
                                                {"3840x2160", 30}, {"1280x720", 12}}) {
                const double e = n.get("element.fps." + size + ".I420.t2"), d = n.get("peer.deshake.fps." + size);
                targets.push_back({format("%s element >= %.0fx ffmpeg deshake (issue 22)", size.c_str(), wanted),
                                   std::isfinite(e / d) ? format("%.0f / %.1f deshake fps = %.1fx", e, d, e / d)
                                                        : "not measured",
                                   verdict(std::isfinite(e / d), e / d >= wanted)});
            }
        }
        // Per stage at 1080p on one thread (bench_speed's per-stage table).
        if (n.has("stage.1920x1080.I420.copy1_ms")) {
            std::string measured;
            bool met = true;
            for (const char *f : {"I420", "BGRx"}) {
                const std::string k = std::string("stage.1920x1080.") + f;
                const double r = n.get(k + ".warp1_over_copy");
                measured += format("%s%s: warp %.2f ms, copy %.2f ms = %.1fx", measured.empty() ? "" : "; ", f,
                                   n.get(k + ".warp1_ms"), n.get(k + ".copy1_ms"), r);
                met = met && r <= 2.0;
            }
            targets.push_back({"warp on one thread <= 2x the copy bound (the frame's planes copied, same loop) at "
                               "1920x1080, I420 and BGRx (issue 22)",
                               measured, verdict(true, met)});
            const double est = n.get("stage.1920x1080.I420.estimate_ms");
            targets.push_back({"estimation <= 1.0 ms at 1920x1080 I420, one thread (issue 22)",
                               format("%.2f ms (BGRx %.2f ms)", est, n.get("stage.1920x1080.BGRx.estimate_ms")),
                               verdict(std::isfinite(est), est <= 1.0)});
        }
        // Quality targets, for each of our configurations (bench_quality.cpp: oursTable()) at
        // the delays it ran at; vid.stab = vid.stab default (two-pass, optzoom=1), same clips.
        {
            const std::vector<std::string> names = split(n.text("quality.ours.names"));
            std::vector<int> delays;
            for (const std::string &d : split(n.text("quality.ours.delays")))
                delays.push_back(std::atoi(d.c_str()));
            const int ref = n.has("quality.ours.reference_delay") ? int(n.get("quality.ours.reference_delay")) : 20;
            auto key = [&](const std::string &name, int d) {
                return "ours_" + name + (d == ref ? std::string() : format("_d%d", d));
            };
            // Ratio targets: limit per delay (NaN = reported, not judged).
            auto ratioTarget = [&](const std::string &what, const std::string &prefix, const std::string &metric,
                                   const std::map<int, double> &limits) {
                for (const std::string &name : names) {
                    std::string measured, failed;
                    bool any = false;
                    for (int d : delays) {
                        const std::string k = "quality." + prefix + "." + key(name, d) + "." + metric;
                        if (!n.has(k))
                            continue;
                        const double r = n.get(k + "_vs_vidstab");
                        const auto lim = limits.find(d);
                        measured += format("%sd%d %.2f px = %s", measured.empty() ? "" : "; ", d, n.get(k),
                                           num(r, "%.2fx").c_str());
                        if (lim != limits.end()) {
                            any = true;
                            if (!(r <= lim->second))
                                failed += (failed.empty() ? "d" : ", d") + std::to_string(d);
                        }
                    }
                    targets.push_back({format("%s: %s", n.text("quality.ours." + name + ".label").c_str(), what.c_str()),
                                       measured.empty() ? "not measured" : measured,
                                       measured.empty()  ? "not measured"
                                       : limits.empty() ? "reported"
                                       : !any           ? "not measured"
                                       : failed.empty() ? "**met**"
                                                        : "**not met** (" + failed + ")"});
                }
            };
            // Short delays are judged after the first second; hover and manoeuvres
            // against their intended (shake-free) path.
            const std::map<int, double> hover_limits{{0, 1.5}, {5, 1.0}, {20, 0.5}};
            ratioTarget("hover (synthetic), jitter against the intended path after the first second vs vid.stab <= "
                        "1.5x at delay 0, 1x at 5, 0.5x at 20",
                        "syn", "path_jitter", hover_limits);
            ratioTarget("real drone clip with known shake, residual jitter after the first second vs vid.stab <= 1.5x "
                        "at delay 0, 1x at 5, 0.5x at 20",
                        "drone", "jitter_after_1s", hover_limits);
            ratioTarget("manoeuvre flight, jitter against the intended path after the first second vs vid.stab <= 1x "
                        "at delay 5, 0.5x at 20",
                        "man", "path_jitter", {{5, 1.0}, {20, 0.5}});
            ratioTarget("(no target) manoeuvre flight, error vs the intended path (RMS, not high-passed) vs vid.stab's",
                        "man", "path_error", {});
            // Manoeuvres as a viewer sees them: how far the output trails the pilot (lag, against
            // vid.stab's on the same flight) and whether it rushes to catch up (whip).
            for (const std::string &name : names) {
                std::string measured, failed;
                for (int d : delays) {
                    const std::string k = "quality.man." + key(name, d);
                    if (!n.has(k + ".path_whip"))
                        continue;
                    const double whip = n.get(k + ".path_whip"), lag = n.get(k + ".path_max_dev_vs_vidstab");
                    measured += format("%sd%d: whip %.2f, lag %.1f px = %s", measured.empty() ? "" : "; ", d, whip,
                                       n.get(k + ".path_max_dev"), num(lag, "%.2fx").c_str());
                    if (d == 0)
                        continue;  // judged from delay 5 on
                    const double whip_limit = d >= 20 ? 1.0 : 1.1;
                    if (!(whip <= whip_limit) || !(lag <= 1.25))
                        failed += (failed.empty() ? "d" : ", d") + std::to_string(d);
                }
                targets.push_back(
                    {format("%s: manoeuvre flight, whip (the output's fastest move over the pilot's) <= 1.0 at "
                            "delay 20 and <= 1.1 at 5-10; lag (the largest corner distance from the intended path) "
                            "<= 1.25x vid.stab's on the same flight (worst flight)",
                            n.text("quality.ours." + name + ".label").c_str()),
                     measured.empty() ? "not measured" : measured,
                     measured.empty() ? "not measured" : failed.empty() ? "**met**" : "**not met** (" + failed + ")"});
            }
            // Reported beside them: the largest deviation from the intended path, and the first
            // second on its own (there the output must be no shakier than the input).
            for (const std::string &name : names)
                for (const auto &[prefix, what] : {std::pair<const char *, const char *>{"syn", "hover"},
                                                   {"man", "manoeuvre flight"}, {"drone", "real drone clip"}}) {
                    std::string measured, failed;
                    for (int d : delays) {
                        const std::string k = std::string("quality.") + prefix + "." + key(name, d);
                        const std::string in = std::string("quality.") + prefix + ".input";
                        if (!n.has(k + ".path_jitter_first"))
                            continue;
                        const double first = n.get(k + ".path_jitter_first"), input = n.get(in + ".path_jitter_first");
                        measured += format("%sd%d: first second %.2f px (input %.2f), largest deviation %.1f px",
                                           measured.empty() ? "" : "; ", d, first, input,
                                           n.get(k + ".path_max_dev"));
                        if (!(first <= input))
                            failed += (failed.empty() ? "d" : ", d") + std::to_string(d);
                    }
                    targets.push_back(
                        {format("%s: %s, the first second no shakier than the input (jitter against the intended "
                                "path); the largest deviation from it",
                                n.text("quality.ours." + name + ".label").c_str(), what),
                         measured.empty() ? "not measured" : measured,
                         measured.empty() ? "not measured" : failed.empty() ? "**met**" : "**not met** (" + failed + ")"});
                }
            for (const std::string &name : names) {
                const std::string k = "quality.real." + key(name, ref);
                if (!n.has(k + ".clips_with_gaussian"))
                    continue;
                // ITF rewards a path that stands still and then jumps, so it is judged with a
                // margin against the Gaussian window; the whip judges the pans.
                const double clips = n.get(k + ".clips_with_gaussian"), ge = n.get(k + ".clips_itf_ge_gaussian");
                const double worst = n.get(k + ".itf_minus_gaussian_min");
                const double vs = n.has(k + ".clips_itf_ge_vidstab") ? n.get(k + ".clips_itf_ge_vidstab") : -1;
                const double real_clips = n.has(k + ".clips") ? n.get(k + ".clips") : 0;
                const bool vidstab_ok = vs >= 0 && vs >= 0.75 * real_clips;
                targets.push_back({format("%s: real clips at delay %d, ITF >= the Gaussian window's (gauss20) - 0.3 dB "
                                          "on every clip, and >= vid.stab's on at least 6 of 8",
                                          n.text("quality.ours." + name + ".label").c_str(), ref),
                                   format("%.0f / %.0f clips at or above gauss20 (%+.2f dB mean, worst %+.2f); %s",
                                          ge, clips, n.get(k + ".itf_minus_gaussian"), worst,
                                          vs >= 0 ? format("%.0f / %.0f at or above vid.stab", vs, real_clips).c_str()
                                                  : "vid.stab not measured"),
                                   worst >= -0.3 && vidstab_ok ? "**met**" : "**not met**"});
            }
            for (const std::string &name : names) {
                std::string measured, failed;
                bool any = false;
                for (int d : delays) {
                    const std::string k = "quality.real." + key(name, d);
                    if (!n.has(k + ".clips"))
                        continue;
                    any = true;
                    const int clips = int(n.get(k + ".clips")), both = int(n.get(k + ".clips_both"));
                    measured += format("%sd%d: ITF >= on %.0f/%d, zoom <= on %.0f/%d, both %d/%d (ITF %+.2f dB mean, "
                                       "worst %+.2f)",
                                       measured.empty() ? "" : "; ", d, n.get(k + ".clips_itf_ge_vidstab"), clips,
                                       n.get(k + ".clips_zoom_le_vidstab"), clips, both, clips,
                                       n.get(k + ".itf_minus_vidstab"), n.get(k + ".itf_minus_vidstab_min"));
                    if (both < clips || clips == 0)
                        failed += (failed.empty() ? "d" : ", d") + std::to_string(d);
                }
                targets.push_back({format("%s: (no target) real clips, ITF against vid.stab's, and zoom",
                                          n.text("quality.ours." + name + ".label").c_str()),
                                   any ? measured : "not measured", any ? "reported" : "not measured"});
            }
            for (const std::string &name : names) {
                std::string measured, failed;
                bool any = false;
                for (int d : delays) {
                    double cmin = 2, cmin_real = 2, zmax = 0;
                    bool seen = false;
                    for (const char *prefix : {"syn", "man", "drone", "real"}) {
                        const std::string k = std::string("quality.") + prefix + "." + key(name, d);
                        if (!n.has(k + ".coverage_min"))
                            continue;
                        seen = true;
                        double &c = std::string(prefix) == "real" ? cmin_real : cmin;
                        c = std::min(c, n.get(k + ".coverage_min"));
                        zmax = std::max(zmax, n.get(k + ".zoom_max"));
                    }
                    if (!seen)
                        continue;
                    any = true;
                    measured += format("%sd%d: coverage min %s (real %s), zoom max %.3f", measured.empty() ? "" : "; ",
                                       d, cmin <= 1 ? format("%.4f", cmin).c_str() : "-",
                                       cmin_real <= 1 ? format("%.4f", cmin_real).c_str() : "-", zmax);
                    if (!((cmin > 1 || cmin >= 0.995) && (cmin_real > 1 || cmin_real >= 0.99) && zmax <= 1.10))
                        failed += (failed.empty() ? "d" : ", d") + std::to_string(d);
                }
                targets.push_back({format("%s: coverage min >= 0.995 on synthetic clips, >= 0.99 on real ones, and "
                                          "zoom <= 1.10 (every frame)",
                                          n.text("quality.ours." + name + ".label").c_str()),
                                   any ? measured : "not measured",
                                   !any ? "not measured" : failed.empty() ? "**met**" : "**not met** (" + failed + ")"});
            }
            // Strong shake (bench_quality.cpp: sectionStrong), the default planner (the first of
            // oursTable()): the hover's limits at each strength, one row each, then the worst
            // strength per delay, then coverage and zoom. Flights with vibration are reported.
            const std::vector<std::string> shakes = split(n.text("quality.strong.shakes"));
            if (!names.empty() && !shakes.empty()) {
                const std::string def = names.front(), def_label = n.text("quality.ours." + def + ".label");
                auto strongKey = [&](const std::string &shake, int d) {
                    return format("quality.strong.%s.%s.d%d", shake.c_str(), def.c_str(), d);
                };
                struct Worst {
                    double ratio = -1, coverage = 2, zoom = 0;
                    std::string ratio_at, coverage_at, zoom_at;  // strength labels
                };
                std::map<int, Worst> worst;  // per delay, over the judged strengths
                for (const std::string &shake : shakes) {
                    const bool judged = shake.find("_vib") == std::string::npos;
                    const std::string shake_label = n.text("quality.strong." + shake + ".label");
                    std::string measured, failed;
                    double seeds = 0;
                    for (const auto &[d, limit] : hover_limits) {
                        const std::string k = strongKey(shake, d);
                        if (!n.has(k + ".jitter"))
                            continue;
                        seeds = n.get(k + ".seeds");
                        const double r = n.get(k + ".jitter_vs_vidstab");
                        measured += format("%sd%d %.2f px = %s (worst seed %s)", measured.empty() ? "" : "; ", d,
                                           n.get(k + ".jitter"), num(r, "%.2fx").c_str(),
                                           num(n.get(k + ".jitter_vs_vidstab_worst"), "%.2fx").c_str());
                        if (!judged)
                            measured += format(", coverage min %.4f, zoom max %.3f", n.get(k + ".coverage_min"),
                                               n.get(k + ".zoom_max"));
                        if (!(r <= limit))
                            failed += (failed.empty() ? "d" : ", d") + std::to_string(d);
                        if (!judged)
                            continue;
                        Worst &w = worst[d];
                        if (std::isfinite(w.ratio) && !(r <= w.ratio)) {  // a NaN (vid.stab missing) stays
                            w.ratio = r;
                            w.ratio_at = shake_label;
                        }
                        if (n.get(k + ".coverage_min") < w.coverage) {
                            w.coverage = n.get(k + ".coverage_min");
                            w.coverage_at = shake_label;
                        }
                        if (n.get(k + ".zoom_max") > w.zoom) {
                            w.zoom = n.get(k + ".zoom_max");
                            w.zoom_at = shake_label;
                        }
                    }
                    const std::string flight = format("hover 1280x720, %.0f seed%s", seeds, seeds == 1 ? "" : "s");
                    if (judged)
                        targets.push_back({format("%s: strong720 shake %s (%s), residual jitter after the first "
                                                  "second vs vid.stab <= 1.5x at delay 0, 1x at 5, 0.5x at 20",
                                                  def_label.c_str(), shake_label.c_str(), flight.c_str()),
                                           measured.empty() ? "not measured" : measured,
                                           measured.empty()  ? "not measured"
                                           : failed.empty() ? "**met**"
                                                            : "**not met** (" + failed + ")"});
                    else {
                        // The vibration flight: no worse than the optimal planner at each delay.
                        std::string against, worse;
                        for (const auto &[d, limit] : hover_limits) {
                            const std::string ours = strongKey(shake, d) + ".jitter";
                            const std::string optimal = format("quality.strong.%s.optimal.d%d.jitter", shake.c_str(), d);
                            if (!n.has(ours) || !n.has(optimal))
                                continue;
                            against += format("%sd%d %.2f vs optimal %.2f px", against.empty() ? "" : "; ", d,
                                              n.get(ours), n.get(optimal));
                            if (!(n.get(ours) <= n.get(optimal) * 1.0001))
                                worse += (worse.empty() ? "d" : ", d") + std::to_string(d);
                        }
                        targets.push_back({format("%s: %s (%s, global shutter), residual jitter after the first "
                                                  "second no worse than the optimal planner's (vid.stab beside)",
                                                  def_label.c_str(), shake_label.c_str(), flight.c_str()),
                                           against.empty() ? "not measured" : against + " (" + measured + ")",
                                           against.empty()  ? "not measured"
                                           : worse.empty() ? "**met**"
                                                           : "**not met** (" + worse + ")"});
                    }
                }
                if (!worst.empty()) {
                    std::string measured, failed, geometry, geometry_failed;
                    for (const auto &[d, w] : worst) {
                        const double limit = hover_limits.at(d);
                        measured += format("%sd%d %s (%s)", measured.empty() ? "" : "; ", d,
                                           num(w.ratio, "%.2fx").c_str(), w.ratio_at.c_str());
                        if (!(w.ratio <= limit))
                            failed += (failed.empty() ? "d" : ", d") + std::to_string(d);
                        geometry += format("%sd%d: coverage min %s (%s), zoom max %s (%s)",
                                           geometry.empty() ? "" : "; ", d,
                                           num(w.coverage <= 1 ? w.coverage : std::nan(""), "%.4f").c_str(),
                                           w.coverage_at.c_str(),
                                           num(w.zoom > 0 ? w.zoom : std::nan(""), "%.3f").c_str(), w.zoom_at.c_str());
                        if (!(w.coverage >= 0.995 && w.zoom <= 1.10))
                            geometry_failed += (geometry_failed.empty() ? "d" : ", d") + std::to_string(d);
                    }
                    targets.push_back({format("%s: strong720 shake, the worst strength per delay: residual jitter "
                                              "after the first second vs vid.stab <= 1.5x at delay 0, 1x at 5, 0.5x "
                                              "at 20",
                                              def_label.c_str()),
                                       measured, failed.empty() ? "**met**" : "**not met** (" + failed + ")"});
                    targets.push_back({format("%s: strong720 shake, every strength: coverage min >= 0.995 and zoom <= "
                                              "1.10 (every frame)",
                                              def_label.c_str()),
                                       geometry,
                                       geometry_failed.empty() ? "**met**" : "**not met** (" + geometry_failed + ")"});
                }
            }
        }
        // Rolling-shutter correction (bench_rolling_shutter.cpp), judged on every
        // flight, seed and delay (the worst), not on means.
        if (n.has("rs.flights.runs")) {
            targets.push_back({"rolling shutter (synthetic flights, readout 50-90 %, 30-60 Hz vibration, auto): wobble "
                               "out <= 0.3x in, every flight, seed and delay",
                               format("worst %.2fx (%s); mean %.2fx; rolling_shutter=off on the reference flight "
                                      "%.2fx",
                                      n.get("rs.flights.wobble_ratio_worst"),
                                      n.text("rs.flights.wobble_ratio_worst_case").c_str(),
                                      n.get("rs.flights.wobble_ratio_mean"), n.get("rs.flights.off_wobble_ratio_mean")),
                               verdict(true, n.get("rs.flights.wobble_ratio_worst") <= 0.3)});
            targets.push_back({"rolling shutter (synthetic flights): shake left (against each row's true pose) <= 1.5x "
                               "the same flight's from a global shutter, every flight, seed and delay",
                               format("worst %.2fx (%s); mean %.2fx", n.get("rs.flights.shake_ratio_worst"),
                                      n.text("rs.flights.shake_ratio_worst_case").c_str(),
                                      n.get("rs.flights.shake_ratio_mean")),
                               verdict(true, n.get("rs.flights.shake_ratio_worst") <= 1.5)});
            targets.push_back({"(no target) rolling shutter (synthetic flights): coverage min (of output_to_input; "
                               "ignores the row offsets) and picture min (1 - black pixels)",
                               format("%.4f, %.4f", n.get("rs.flights.coverage_min"), n.get("rs.flights.picture_min")),
                               "reported"});
            if (n.has("rs.flights.zoom_max"))
                targets.push_back({"rolling shutter (synthetic flights): zoom (1 / scale of output_to_input) <= 1.10, "
                                   "every frame, flight, seed and delay",
                                   format("%.3f", n.get("rs.flights.zoom_max")),
                                   verdict(true, n.get("rs.flights.zoom_max") <= 1.10)});
        }
        if (n.has("rs.still.syn.jitter_diff_worst"))
            targets.push_back({"rolling shutter auto on global-shutter flights (with and without vibration): residual "
                               "jitter within 5 % of off",
                               format("worst %.1f %%; frames corrected %.0f of %.0f",
                                      100 * n.get("rs.still.syn.jitter_diff_worst"), n.get("rs.still.syn.corrected"),
                                      n.get("rs.still.syn.frames")),
                               verdict(true, n.get("rs.still.syn.jitter_diff_worst") <= 0.05)});
        if (n.has("rs.still.real.low_wobble_clips")) {
            const double clips = n.get("rs.still.real.low_wobble_clips");
            const std::string failed = n.text("rs.still.real.low_wobble_failed");
            targets.push_back({"rolling shutter auto on real clips whose input wobble < 0.2 px: ITF within 0.1 dB of "
                               "off (delays 20 and 0)",
                               clips > 0 ? format("%.0f clips, worst |auto - off| %.3f dB%s", clips,
                                                  n.get("rs.still.real.low_wobble_itf_diff_worst"),
                                                  failed.empty() ? "" : ("; beyond: " + failed).c_str())
                                         : "no clip below 0.2 px",
                               clips > 0 ? verdict(true, failed.empty()) : "not measured"});
        }
        if (n.has("rs.still.real.picture_lost_worst"))
            targets.push_back({"(no target) rolling shutter auto on the real clips: black pixels let in beyond off's "
                               "(picture min of off - of auto, worst clip and delay; the quality section's coverage "
                               "comes from registering one similarity to the output, which per-row warps bend)",
                               format("%.4f", n.get("rs.still.real.picture_lost_worst")), "reported"});
        if (n.has("rs.still.real.itf_drop_worst")) {
            // The correction never makes a real clip worse (the AR.Drone clip's
            // wobble target was dropped: its non-rigid motion is parallax).
            const double drop = n.get("rs.still.real.itf_drop_worst");
            targets.push_back({"rolling shutter auto on every real clip (the AR.Drone clip among them): ITF no lower "
                               "than off's - 0.05 dB, picture min no lower (delays 20 and 0)",
                               format("worst ITF auto - off %+.3f dB (%s); picture lost %.4f; %.0f of %.0f clips "
                                      "corrected",
                                      -drop, n.text("rs.still.real.itf_drop_worst_case").c_str(),
                                      n.get("rs.still.real.picture_lost_worst"), n.get("rs.still.real.corrected_clips"),
                                      n.get("rs.still.real.clips")),
                               verdict(true, drop <= 0.05 && n.get("rs.still.real.picture_lost_worst") <= 1e-4)});
        }
        if (n.has("rs.osd.target_ratio_worst")) {
            targets.push_back({"rolling shutter auto, hazy global-shutter flights with a burned-in OSD (640x360 at "
                               "delays 0/5/20, 1280x720 at 20; shake x1-x3; 3 seeds): OSD <= 1.1x + 0.1 px of the "
                               "flight without it",
                               format("worst %.2f of the limit", n.get("rs.osd.target_ratio_worst")),
                               verdict(true, n.get("rs.osd.target_ratio_worst") <= 1.0)});
            targets.push_back({"rolling shutter auto on the same OSD flights: within 5 % of off, no frame's rows moved",
                               format("worst %.1f %%; frames with rows moved %.0f", 100 * n.get("rs.osd.auto_off_diff_worst"),
                                      n.get("rs.osd.rows_moved")),
                               verdict(true, n.get("rs.osd.auto_off_diff_worst") <= 0.05 && n.get("rs.osd.rows_moved") == 0)});
        }
        for (const auto &[key, what, limit] :
             {std::tuple<const char *, const char *, double>{"gs", "a global-shutter flight (nothing to correct): within "
                                                                   "5 % of off", 1.05},
              {"rs", "a rolling-shutter flight (80 %, 47 Hz): at most +25 % over off", 1.25}}) {
            const std::string k = std::string("rs.cost.") + key;
            if (!n.has(k + ".ratio"))
                continue;
            const double r = n.get(k + ".ratio");
            targets.push_back({format("rolling shutter auto, CPU per frame at 1080p on one thread, %s", what),
                               format("%.2f vs %.2f ms (%+.1f %%; estimation %.2f vs %.2f, warp %.2f vs %.2f); other "
                                      "processes %.0f %%",
                                      n.get(k + ".total_ms_auto"), n.get(k + ".total_ms_off"), 100 * (r - 1),
                                      n.get(k + ".estimate_ms_auto"), n.get(k + ".estimate_ms_off"),
                                      n.get(k + ".warp_ms_auto"), n.get(k + ".warp_ms_off"), 100 * n.get(k + ".others")),
                               verdict(true, std::string(key) == "gs" ? std::abs(r - 1) <= limit - 1 : r <= limit)});
        }
        {
            const double g = n.get("memory.long.growth_mib"), f = n.get("memory.long.frames");
            targets.push_back({format("memory flat over %s frames (320x240): RSS growth from 10k to the end <= 1 MiB",
                                      num(f, "%.0f").c_str()),
                               format("%s MiB (RSS %s -> %s MiB)", num(g, "%+.2f").c_str(),
                                      num(n.get("memory.long.rss10k_mib"), "%.1f").c_str(),
                                      num(n.get("memory.long.rss_end_mib"), "%.1f").c_str()),
                               verdict(std::isfinite(g), std::abs(g) <= 1.0)});
            // Peak heap <= delay + 8 frames at every resolution, library and element
            // (the element's without appsrc's queue: the harness's frames).
            std::string measured;
            bool met = true, any = false;
            for (const std::string mode : {"lib", "element"})
                for (const char *res : {"640x480", "1280x720", "1920x1080", "3840x2160"}) {
                    const std::string k = "memory." + mode + "." + res;
                    if (!n.has(k + ".heap_frames"))
                        continue;
                    const double frames = n.get(k + ".heap_frames") -
                                          (mode == "element" ? n.get(k + ".at_peak.queued_inputs") : 0.0);
                    const double budget = n.get(k + ".budget_frames");
                    measured += format("%s%s %s %.1f", measured.empty() ? "" : "; ",
                                       mode == "lib" ? "library" : "element", res, frames);
                    met = met && frames <= budget;
                    any = true;
                }
            targets.push_back({"peak heap <= delay + 8 = 28 frames at every resolution, library and element (the "
                               "element's without appsrc's queue; frames of the resolution, malloc'ed bytes in use)",
                               any ? measured : "not measured", any ? verdict(true, met) : "not measured"});
        }
        // Lens profiles (bench_lens.cpp): every lens, strength, seed and delay (the worst).
        if (n.has("lens.flights.ratio_worst")) {
            targets.push_back({"lens profile (synthetic flights through a 150 deg fisheye and a 110 deg wide-angle "
                               "lens, 0.5-2x shake, delays 5 and 20, 3 seeds): shake at the frame corners with the "
                               "profile <= 1.2x the same flight through a pinhole lens; coverage min >= 0.995",
                               format("worst %.2fx (%s); coverage min %.4f", n.get("lens.flights.ratio_worst"),
                                      n.text("lens.flights.ratio_worst_case").c_str(),
                                      n.get("lens.flights.coverage_min")),
                               verdict(true, n.get("lens.flights.ratio_worst") <= 1.2 &&
                                                 n.get("lens.flights.coverage_min") >= 0.995)});
        }
        for (const char *f : {"I420", "BGRx"})
            if (n.has(std::string("lens.cost.") + f + ".ratio")) {
                const std::string k = std::string("lens.cost.") + f;
                targets.push_back({format("lens profile: 1920x1080 %s warp on one thread (the fisheye's meshes built "
                                          "per frame included) <= 1.5x the warp without a lens",
                                          f),
                                   format("%.2f vs %.2f ms = %.2fx", n.get(k + ".lens_ms"), n.get(k + ".plain_ms"),
                                          n.get(k + ".ratio")),
                                   verdict(true, n.get(k + ".ratio") <= 1.5)});
            }
        r << "## Targets\n\n";
        Table tt({"target", "measured", "verdict"});
        for (const Target &t : targets)
            tt.row({t.what, t.measured, t.verdict});
        r << tt.markdown() << "\n";
        if (!element)
            r << "The element was not measured: "
              << (n.text("element.skipped").empty() ? "see below" : n.text("element.skipped")) << ".\n\n";

        // ---- speed -------------------------------------------------------------------
        r << "## Throughput\n\n";
        Table ratio({"resolution", "ours element fps", "ours library fps", "deshake fps", "vid.stab fps",
                     "element / deshake", "element / vid.stab", "library / deshake", "library / vid.stab"});
        for (const Resolution &res : benchResolutions(Options{})) {
            const std::string s = res.name();
            const double e = n.get("element.fps." + s + ".I420.t2"), l = n.get("lib.fps." + s + ".I420.t2");
            const double d = n.get("peer.deshake.fps." + s), v = n.get("peer.vidstab.fps." + s);
            if (!std::isfinite(l) && !std::isfinite(e))
                continue;
            ratio.row({s, num(e, "%.0f"), num(l, "%.0f"), num(d, "%.1f"), num(v, "%.1f"), num(e / d, "%.1fx"),
                       num(e / v, "%.1fx"), num(l / d, "%.1fx"), num(l / v, "%.1fx")});
        }
        r << "Ours (I420, 2 threads) beside the peers on the same frames, and the ratio ours / peer:\n\n"
          << ratio.markdown() << "\n";
        for (const char *frag : {"speed_element", "speed_affine_meta", "speed_lib", "speed_peers", "speed_stages"}) {
            const std::string text = readFile(o.out_dir + "/" + frag + ".md");
            if (!text.empty())
                r << "### "
                  << (std::string(frag) == "speed_element"       ? "Element"
                      : std::string(frag) == "speed_affine_meta" ? "Element, zero-copy mode for GL (render=affine-meta)"
                      : std::string(frag) == "speed_lib"         ? "Library alone"
                      : std::string(frag) == "speed_peers"       ? "Peers (ffmpeg)"
                                                                 : "Per-stage cost")
                  << "\n\n"
                  << text;
        }
        const std::string profile = readFile(o.out_dir + "/profile.md");
        if (!profile.empty())
            r << "### Profile of a 1080p stream\n\n" << profile << "\n";
        r << "## Latency\n\n";
        for (const char *frag : {"latency_element", "latency_lib"})
            r << readFile(o.out_dir + "/" + frag + ".md");
        const std::string streams = readFile(o.out_dir + "/streams.md");
        if (!streams.empty())
            r << "## Live streams at once\n\n" << streams << "\n";
        r << "## Memory\n\n" << readFile(o.out_dir + "/memory.md");
        r << "## Quality\n\n";
        if (std::ifstream(o.out_dir + "/residual_jitter.png"))
            r << "![residual jitter per method](residual_jitter.png)\n\n";
        r << "### Synthetic hover clips with known motion\n\n" << readFile(o.out_dir + "/quality_synthetic.md");
        r << "### Synthetic manoeuvre flights (error against the intended path)\n\n"
          << readFile(o.out_dir + "/quality_manoeuvre.md");
        r << "### Real drone clip with known shake\n\n" << readFile(o.out_dir + "/quality_drone.md");
        const std::string strong = readFile(o.out_dir + "/quality_strong.md");
        if (!strong.empty())
            r << "### Synthetic hover clips under strong shake\n\n" << strong;
        r << "### Real clips\n\n" << readFile(o.out_dir + "/quality_real.md");
        const std::string path = readFile(o.out_dir + "/quality_path.md");
        if (!path.empty())
            r << "### The planners alone (perfect motion estimates)\n\n" << path;
        // What the rolling-shutter correction removes, leaves alone and costs.
        const std::string rs_flights = readFile(o.out_dir + "/rs_flights.md");
        const std::string rs_still = readFile(o.out_dir + "/rs_still.md");
        const std::string rs_cost = readFile(o.out_dir + "/rs_cost.md");
        const std::string rs_osd = readFile(o.out_dir + "/rs_osd.md");
        if (!rs_flights.empty() || !rs_still.empty() || !rs_osd.empty() || !rs_cost.empty()) {
            r << "## Rolling shutter\n\n";
            if (!rs_flights.empty())
                r << "### Synthetic rolling-shutter flights\n\n" << rs_flights;
            if (!rs_still.empty())
                r << "### Footage without wobble: auto vs off\n\n" << rs_still;
            if (!rs_osd.empty())
                r << "### A burned-in OSD on a global shutter\n\n" << rs_osd;
            if (!rs_cost.empty())
                r << "### Cost at 1080p\n\n" << rs_cost;
        }
        const std::string lens_flights = readFile(o.out_dir + "/lens_flights.md");
        const std::string lens_cost = readFile(o.out_dir + "/lens_cost.md");
        if (!lens_flights.empty() || !lens_cost.empty()) {
            r << "## Lens profiles\n\n";
            if (!lens_flights.empty())
                r << "### Synthetic flights through a lens\n\n" << lens_flights;
            if (!lens_cost.empty())
                r << "### The warp's cost with a lens\n\n" << lens_cost;
        }
        const std::string reliability = readFile(o.out_dir + "/reliability.md");
        if (!reliability.empty())
            r << "## Reliability\n\n" << reliability;
        std::ofstream(o.out_dir + "/REPORT.md") << r.str();
        std::printf("wrote %s/REPORT.md\n", o.out_dir.c_str());
    } catch (const std::exception &e) {
        std::cerr << "uavstab-bench-report: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
