// The manoeuvre section: ShakyFlight manoeuvre flights (hover, accelerating pans, a yaw turn,
// stops, a climb): error against the intended shake-free path, residual jitter beside, and the
// path plot (manoeuvre_path.png).
#include <algorithm>
#include <cmath>

#include "jitter_metrics.hpp"
#include "plot.hpp"

#include "bench_quality.hpp"

namespace quality {

namespace {

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

} // namespace

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
        "costs nothing; lagging behind a start or a stop, bending the manoeuvre and leftover shake cost. **Lag** "
        "(`synthetic::intendedPathMaxDeviation`): the largest distance of an output corner from its mean place "
        "relative to the intended path, worst clip, and the worst clip's ratio to vid.stab's on the same clip. "
        "**Whip** (`synthetic::pathWhip`): the output's fastest corner move over the world divided by the intended "
        "path's fastest, after the first second (corners smoothed with a Gaussian of sigma 2 frames), worst clip: "
        "above 1 the output rushes past the pilot to catch up. Residual jitter beside them (it forgives a smoother "
        "that bends the path slowly). %s",
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

} // namespace quality
