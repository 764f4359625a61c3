// Measuring a clip's outputs the same way for every method: ORB + RANSAC registration of
// each output frame to its input frame (and to the previous output frame for the stability
// score), the output path against the true and intended paths, coverage, zoom, ITF, and ours
// cross-checked against its own FrameStats.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <future>
#include <map>

#include <opencv2/core/utility.hpp>

#include "bench_quality.hpp"
#include "jitter_metrics.hpp"

namespace quality {

namespace {

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
            m.path_whip = synthetic::pathWhip(path, clip.intended, clip.width, clip.height,
                                              std::size_t(std::lround(clip.fps())));
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
        // UAVSTAB_BENCH_ZOOM_DUMP=dir: per frame, the registered zoom beside ours' own account
        // (where a registered magnification comes from: the crop, the path's scale, the
        // rolling-shutter bend, or the measurement).
        if (const char *dir = std::getenv("UAVSTAB_BENCH_ZOOM_DUMP")) {
            const std::string file = std::string(dir) + "/" + clip.name + "_" + method.key + ".tsv";
            if (std::FILE *f = std::fopen(file.c_str(), "w")) {
                std::fprintf(f, "frame\treg_zoom\treg_sim_zoom\treg_s1\treg_s2\tinliers\tstats_zoom\tcrop_zoom\t"
                                "corr_scale\ttraj_scale\tsmoothed_scale\tfraction\twobble\treadout\tskipped\n");
                for (std::size_t i = 0; i < n; ++i) {
                    const FrameStats &st = out.stats[i];
                    double s1 = kNaN, s2 = kNaN;
                    if (out2in[i].ok)
                        singularValues(out2in[i].affine, &s1, &s2);
                    std::fprintf(f, "%zu\t%.5f\t%.5f\t%.5f\t%.5f\t%d\t%.5f\t%.5f\t%.5f\t%.5f\t%.5f\t%.4f\t%.3f\t%.3f\t%d\n",
                                 i, out2in[i].ok ? 1.0 / std::sqrt(s1 * s2) : kNaN,
                                 out2in[i].ok ? 1.0 / out2in[i].similarity.scale : kNaN, s1, s2, out2in[i].inliers,
                                 1.0 / st.output_to_input.scale, st.zoom, st.correction.scale, st.trajectory.scale,
                                 st.smoothed.scale, st.correction_fraction, st.row_motion.wobble, st.readout,
                                 int(st.skipped));
                }
                std::fclose(f);
            }
        }
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

} // namespace

// real_measures: ITF and (for the input, the peers and ours at delay 20, and for ours at the
// other delays too when stability_every_delay) the stability score, which costs one more
// registration per frame.
ClipResult evaluate(Clip clip, const std::vector<Method> &ms, bool real_measures, bool stability_every_delay)
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

} // namespace quality
