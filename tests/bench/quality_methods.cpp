// The methods the quality benchmark compares: our configurations (oursTable()) at every
// delay of kDelays, the input and the peers (ffmpeg deshake, vid.stab), and how each runs on a clip.
#include <algorithm>
#include <cstdlib>
#include <sstream>

#include "bench_quality.hpp"

namespace quality {

namespace {

StabilizerConfig plannerConfig(PlannerKind kind, int radius)
{
    // Spelled out, so the rows keep their meaning when the library's defaults move.
    StabilizerConfig c;
    c.planner = kind;
    c.smoothing_radius = radius;
    return c;
}

} // namespace

// Our configurations (OursEntry in bench_quality.hpp), one line each, the library's default first.
const std::vector<OursEntry> &oursTable()
{
    static const std::vector<OursEntry> table{
        {"l1", "l1 planner (default)", plannerConfig(PlannerKind::L1, 20)},
        {"optimal", "optimal planner", plannerConfig(PlannerKind::Optimal, 20)},
        {"gauss20", "gaussian r20", plannerConfig(PlannerKind::Gaussian, 20)},
        {"box10", "box r10 (the paper's)", plannerConfig(PlannerKind::Box, 10)},
    };
    // UAVSTAB_BENCH_OURS=l1,gauss20 runs only those (for quick comparisons while tuning).
    static const std::vector<OursEntry> chosen = [] {
        const char *only = std::getenv("UAVSTAB_BENCH_OURS");
        if (!only)
            return table;
        std::vector<OursEntry> t;
        for (const OursEntry &e : table)
            if (("," + std::string(only) + ",").find("," + e.name + ",") != std::string::npos)
                t.push_back(e);
        return t;
    }();
    return chosen;
}

const std::vector<int> kDelays = [] {
    std::vector<int> d{0, 5, 10, 20};
    if (const char *only = std::getenv("UAVSTAB_BENCH_DELAYS")) {
        d.clear();
        std::stringstream ss(only);
        std::string item;
        while (std::getline(ss, item, ','))
            d.push_back(std::stoi(item));
    }
    return d;
}();

std::string oursKey(const std::string &name, int delay)
{
    return "ours_" + name + (delay == kReferenceDelay ? "" : format("_d%d", delay));
}

std::vector<Method> methods(bool deshake, bool vidstab)
{
    // Named, not `{}` in each initializer: g++ 12 warns (falsely) that the config's
    // vector member may be used uninitialized when it is brace-initialized in place.
    const StabilizerConfig unused;
    std::vector<Method> m;
    m.push_back({"input", "input (no stabilization)", "input", Kind::Input, unused, "input", -1});
    for (int delay : kDelays)
        for (const OursEntry &e : oursTable()) {
            StabilizerConfig c = e.config;
            c.delay = delay;
            m.push_back({oursKey(e.name, delay), "ours " + e.label, format("%s d%d", e.name.c_str(), delay), Kind::Ours,
                         c, e.name, delay});
        }
    // UAVSTAB_BENCH_PEERS=0 leaves the peers out (for quick comparisons while tuning).
    const char *peers = std::getenv("UAVSTAB_BENCH_PEERS");
    if (peers && std::string(peers) == "0")
        deshake = vidstab = false;
    if (vidstab) {
        m.push_back({"vidstab", "vid.stab default (optzoom=1)", "vid.stab", Kind::VidstabDefault, unused, "vidstab", -1});
        m.push_back({"vidstab_zoom", "vid.stab zoom 8.7 % (= ours)", "vid.stab z8.7", Kind::VidstabZoom, unused,
                     "vidstab_zoom", -1});
    }
    if (deshake)
        m.push_back({"deshake", "ffmpeg deshake", "deshake", Kind::Deshake, unused, "deshake", -1});
    return m;
}

std::vector<Method> atDelays(const std::vector<Method> &all, const std::vector<int> &delays)
{
    std::vector<Method> m;
    for (const Method &x : all)
        if (x.kind != Kind::Ours || std::find(delays.begin(), delays.end(), x.delay) != delays.end())
            m.push_back(x);
    return m;
}

std::string delayCell(const Method &m)
{
    return m.kind == Kind::Ours ? std::to_string(m.delay) : m.kind == Kind::Input ? "-" : "offline";
}

std::string longLabel(const Method &m)
{
    return m.kind == Kind::Ours ? format("%s, delay %d", m.label.c_str(), m.delay) : m.label;
}

std::string delaysText()
{
    std::string d;
    for (int x : kDelays)
        d += (d.empty() ? "" : ", ") + std::to_string(x);
    std::string names;
    for (const OursEntry &e : oursTable())
        names += (names.empty() ? "" : "; ") + e.label;
    return format("Ours (%s) at delays %s (config.delay, everything else default; delay 0 is causal); the peers are "
                  "offline two-pass or whole-clip filters with no delay and appear once. \"vs vid.stab\" = ours / "
                  "vid.stab default (two-pass, optzoom=1) over the same clips; for ITF the difference in dB.",
                  names.c_str(), d.c_str());
}

void putMethodList(const Options &o)
{
    std::string names, delays;
    for (const OursEntry &e : oursTable()) {
        names += (names.empty() ? "" : ",") + e.name;
        putResultText(o, "quality.ours." + e.name + ".label", e.label);
    }
    for (int d : kDelays)
        delays += (delays.empty() ? "" : ",") + std::to_string(d);
    putResultText(o, "quality.ours.names", names);
    putResultText(o, "quality.ours.delays", delays);
    putResult(o, "quality.ours.reference_delay", kReferenceDelay);
}

Output runOurs(const Clip &clip, const StabilizerConfig &config)
{
    Output out;
    Stabilizer stabilizer(config);
    OutputPool pool(PixelFormat::I420, clip.width, clip.height);
    auto take = [&](StabilizedFrame f) {
        const auto &slot = static_cast<const PoolSlot &>(*f.slot);
        const FrameBuffer &shown =
            f.outcome == Outcome::Warped ? *slot.output() : clip.frames[std::size_t(slot.index())];
        out.luma.push_back(lumaOf(shown).clone());
        out.stats.push_back(f.stats);
        if (f.outcome != Outcome::Warped && out.error.empty())
            out.error = "frame " + std::to_string(slot.index()) + " not warped: " + f.error;
    };
    const auto t0 = Clock::now();
    for (std::size_t i = 0; i < clip.frames.size(); ++i) {
        stabilizer.push(std::make_unique<PoolSlot>(clip.frames[i].view(), pool, long(i)));
        while (auto f = stabilizer.tryPop())
            take(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        take(std::move(*f));
    out.seconds = secondsBetween(t0, Clock::now());
    return out;
}

Output runFfmpeg(const Clip &clip, const std::string &raw, const std::string &filter, const std::string &pre_filter)
{
    Output out;
    const std::string in = format("ffmpeg -hide_banner -loglevel error -nostdin -f rawvideo -pix_fmt yuv420p -s %dx%d "
                                  "-framerate %d/%d -i %s ",
                                  clip.width, clip.height, clip.fps_num, clip.fps_den, raw.c_str());
    const auto t0 = Clock::now();
    if (!pre_filter.empty() && runCommand(in + "-vf " + pre_filter + " -f null -") != 0) {
        out.error = "ffmpeg failed: " + pre_filter;
        return out;
    }
    RawPipeReader reader(in + "-vf " + filter + " -fps_mode passthrough -f rawvideo -pix_fmt yuv420p -", clip.width,
                         clip.height);
    FrameBuffer f;
    while (reader.read(f))
        out.luma.push_back(lumaOf(f).clone());
    const int status = reader.close();
    out.seconds = secondsBetween(t0, Clock::now());
    if (status != 0)
        out.error = "ffmpeg exited with " + std::to_string(status) + " (" + filter + ")";
    else if (out.luma.size() != clip.frames.size())
        out.error = format("ffmpeg gave %zu frames for %zu", out.luma.size(), clip.frames.size());
    return out;
}

} // namespace quality
