// The synthetic section: ShakyFlight "hover" clips (the default, slowly drifting flight) with
// known true motion, seeds x moving objects x 360p/720p: residual jitter, jitter and error
// against the intended path, coverage, zoom and distortion.

#include "bench_quality.hpp"

namespace quality {

namespace {

// Which of our delays run on which synthetic clips: all delays on the first `all_delay_seeds`
// seeds, delay 20 alone on the others.
std::vector<Method> forSeed(const std::vector<Method> &ms, std::uint32_t seed, std::uint32_t all_delay_seeds)
{
    return seed <= all_delay_seeds ? ms : atDelays(ms, {kReferenceDelay});
}

} // namespace

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

} // namespace quality
