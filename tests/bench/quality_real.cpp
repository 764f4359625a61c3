// The real-clip section: every clip in the data directory, measured without a truth: stability
// score (Liu et al. 2013), ITF, coverage and zoom, and the zoom plot (zoom_real.png).
#include <algorithm>
#include <cmath>

#include "plot.hpp"

#include "bench_quality.hpp"

namespace quality {

namespace {

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

} // namespace

void sectionReal(const Options &o, const std::vector<Method> &ms)
{
    Fragment frag(o, "quality_real");
    std::vector<std::string> files = o.data_dir.empty() ? std::vector<std::string>{} : realClipFiles(o.data_dir);
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
        // Against the Gaussian window at the reference delay (a target for the default).
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

} // namespace quality
