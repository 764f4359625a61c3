// The tables and plots several sections of the quality benchmark share: per-method tables
// against vid.stab, per-clip tables, the cross-check of ours, the trajectory and residual
// jitter plots.
#include <algorithm>
#include <cmath>

#include "bench_quality.hpp"
#include "plot.hpp"

namespace quality {

std::string num(double v, const char *f)
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

// The worst over the clips of ours / vid.stab's on the same clip (NaN where vid.stab did not run).
double worstClipVsVidstab(const std::vector<ClipResult> &results, const std::string &key, double Metrics::*field)
{
    double worst = kNaN;
    for (const ClipResult &r : results) {
        const Metrics *m = find(r, key), *x = find(r, "vidstab");
        if (!m || !x || !std::isfinite(m->*field) || !std::isfinite(x->*field) || x->*field <= 0.0)
            continue;
        const double ratio = m->*field / x->*field;
        worst = std::isfinite(worst) ? std::max(worst, ratio) : ratio;
    }
    return worst;
}

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
                                             "error vs intended path px", "vs vid.stab", "lag px",
                                             "lag vs vid.stab (worst clip)", "whip"};
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
        const double lag_vs_vidstab = worstClipVsVidstab(results, m.key, &Metrics::path_max_dev);
        const double whip = maxOf(collect(results, m.key, &Metrics::path_whip));
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
                                                  num(e.value / e.vidstab, "%.2fx"), num(max_dev, "%.1f"),
                                                  num(lag_vs_vidstab, "%.2fx"), num(whip, "%.2f")};
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
            putResult(o, key + ".path_max_dev_vs_vidstab", lag_vs_vidstab);
            putResult(o, key + ".path_whip", whip);
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
                  const char *number_format, bool minus_vidstab, double Metrics::*in_brackets)
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

} // namespace quality
