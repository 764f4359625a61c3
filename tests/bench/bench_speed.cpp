// Speed of the library alone and of the peers (ffmpeg deshake, vid.stab), on the same
// synthetic frames made in memory beforehand, so that no decoding is measured.
//
//   uavstab-bench-speed --out DIR [--quick] [--resolution WxH]... [--only lib|stages|latency|peers]...
//
// lib      Stabilizer push/pop throughput: resolutions x {I420, BGRx} x {1, 2} worker threads
// stages   per-stage cost: MotionEstimator::estimate, the path planners, FrameWarper::warp
// latency  frames pushed at 30 fps: processing latency (push of frame i+delay -> output i)
// peers    ffmpeg deshake and vidstabdetect + vidstabtransform on the same frames (raw, tmpfs)
#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <iostream>
#include <map>
#include <thread>

#include <opencv2/core/utility.hpp>

#include "common.hpp"
#include "render/frame_warper.hpp"
#include "path/framing.hpp"
#include "estimate/motion_estimator.hpp"
#include "uavstab/stabilizer.hpp"
#include "path/path_planner.hpp"

using namespace uavstab;
using namespace bench;

namespace {

// One timed run: frames/s from the first push to the last pop; with `cpu_ms`, the process's
// CPU time per frame over the run.
double libraryRun(const std::vector<FrameBuffer> &frames, long pushes, const StabilizerConfig &config, OutputPool &pool,
                  long *failed, double *cpu_ms = nullptr)
{
    Stabilizer stabilizer(config);
    // Bound the warps in flight, as a host with a fixed buffer pool would.
    const std::size_t max_in_flight = std::size_t(config.resolvedThreads()) + 2;
    long popped = 0;
    auto take = [&](std::optional<StabilizedFrame> f) {
        ++popped;
        if (f->outcome != Outcome::Warped)
            ++*failed;
    };
    const double cpu0 = cpuSeconds(CLOCK_PROCESS_CPUTIME_ID);
    const auto t0 = Clock::now();
    for (long k = 0; k < pushes; ++k) {
        const int i = pingPong(k, int(frames.size()));
        stabilizer.push(std::make_unique<PoolSlot>(frames[std::size_t(i)].view(), pool, k));
        while (auto f = stabilizer.tryPop())
            take(std::move(f));
        while (stabilizer.finalizedCount() > max_in_flight)
            if (auto f = stabilizer.waitPop())
                take(std::move(f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        take(std::move(f));
    const double s = secondsBetween(t0, Clock::now());
    if (cpu_ms != nullptr)
        *cpu_ms = 1000.0 * (cpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - cpu0) / double(pushes);
    if (popped != pushes)
        throw std::runtime_error("library run lost frames");
    return double(pushes) / s;
}

void sectionLibrary(const Options &o, const std::vector<ResolutionPlan> &plans,
                    std::map<std::string, std::vector<cv::Mat>> &bgr_cache)
{
    Fragment frag(o, "speed_lib");
    const int runs = o.quick ? 3 : 5;
    frag.text(format("Library alone: `Stabilizer` push/tryPop on frames made in memory beforehand (the synthetic "
                     "flight, played back and forth), default config (delay 20, l1 planner, analysis width 640), "
                     "output frames recycled from a pool, at most threads+2 warps in flight. Frames/s, median "
                     "(min-max) of %d runs after one warm-up run. OpenCV's own thread pool: %d threads. CPU "
                     "ms/frame: the process's CPU time per frame, and cores busy: CPU time over wall time, medians "
                     "over the runs (as in the element's table).",
                     runs, cv::getNumThreads()));
    Table t({"resolution", "format", "threads", "frames/run", "fps median (min-max)", "ms/frame", "CPU ms/frame",
             "cores busy", "other processes"});
    for (const ResolutionPlan &p : plans) {
        const auto &bgr = bgr_cache[p.res.name()];
        for (PixelFormat fmt : {PixelFormat::I420, PixelFormat::BGRx}) {
            const std::vector<FrameBuffer> frames = framesFromBgr(bgr, fmt);
            for (int threads : {1, 2}) {
                StabilizerConfig config;
                config.threads = threads;
                OutputPool pool(fmt, p.res.width, p.res.height);
                long failed = 0;
                std::vector<double> fps, cpu, busy;
                const double others = measureQuietly("library " + p.res.name(), [&] {
                    fps.clear();
                    cpu.clear();
                    busy.clear();
                    failed = 0;
                    libraryRun(frames, std::min<long>(p.pushes / 2, 60), config, pool, &failed);  // warm-up
                    for (int r = 0; r < runs; ++r) {
                        double c = 0.0;
                        fps.push_back(libraryRun(frames, p.pushes, config, pool, &failed, &c));
                        cpu.push_back(c);
                        busy.push_back(c * fps.back() / 1000.0);
                    }
                });
                const double med = median(fps);
                t.row({p.res.name(), formatName(fmt), std::to_string(threads), std::to_string(p.pushes),
                       spread(fps, "%.0f"), format("%.2f", 1000.0 / med), format("%.2f", median(cpu)),
                       format("%.2f", median(busy)), loadCell(others)});
                const std::string key = format("lib.fps.%s.%s.t%d", p.res.name().c_str(), formatName(fmt), threads);
                putResult(o, key, med);
                putResult(o, key + ".min", minOf(fps));
                putResult(o, key + ".max", maxOf(fps));
                putResult(o, key + ".cpu_ms", median(cpu));
                std::printf("  lib %s %s threads=%d: %s fps%s\n", p.res.name().c_str(), formatName(fmt), threads,
                            spread(fps).c_str(), failed ? " (FAILED FRAMES)" : "");
                std::fflush(stdout);
                if (failed)
                    frag.text(format("**%ld frames were not warped** at %s %s threads=%d.", failed,
                                     p.res.name().c_str(), formatName(fmt), threads));
            }
        }
    }
    frag.table(t);
}

void sectionStages(const Options &o, const std::vector<ResolutionPlan> &plans,
                   std::map<std::string, std::vector<cv::Mat>> &bgr_cache)
{
    Fragment frag(o, "speed_stages");
    frag.text("Per-stage cost, measured directly on the library classes on one thread: "
              "`MotionEstimator::estimate` (luma extraction/downscale, pyramid, Shi-Tomasi every 5 frames, "
              "LK forward+backward, robust fit), the path planner (`PathPlanner::plan` for each frame of a "
              "300-frame shaky path with the delay's look-ahead: the paper's box r10 and the Gaussian r20 window "
              "planners, the l1 planner (the default) and the optimal planner at delays 20 and 0; frame geometry "
              "only, so the same at every "
              "format), and `FrameWarper::warp` of a whole frame (OpenCV limited to 1 thread, and with OpenCV's "
              "default pool), beside the copy bound: a plain copy of the frame's planes input to output (row by "
              "row, one thread), timed alternately with the 1-thread warp in the same loop, and the ratio of "
              "the two means. ms/frame: mean (p95); for the planners mean (p99).");
    Table t({"resolution", "format", "estimate", "plan box r10", "plan gauss r20", "plan l1 d20", "plan l1 d0",
             "plan optimal d20", "plan optimal d0", "warp (1 cv thread)", "warp (cv default)", "copy bound", "warp / copy", "sum (1 thread)",
             "other processes"});
    const int default_threads = cv::getNumThreads();
    for (const ResolutionPlan &p : plans) {
        const auto &bgr = bgr_cache[p.res.name()];
        for (PixelFormat fmt : {PixelFormat::I420, PixelFormat::BGRx}) {
            const std::vector<FrameBuffer> frames = framesFromBgr(bgr, fmt);
            StabilizerConfig config;
            std::vector<double> est, box, gauss, l1_20, l1_0, optimal20, optimal0, warp1, warpN, copy1;
            const double others = measureQuietly("stages " + p.res.name(), [&] {
                cv::setNumThreads(1);
                // Estimation.
                MotionEstimator estimator(config);
                est.clear();
                const long n = o.quick ? 60 : 150;
                for (long k = 0; k < n + 5; ++k) {
                    const auto t0 = Clock::now();
                    estimator.estimate(frames[std::size_t(pingPong(k, int(frames.size())))].view());
                    if (k >= 5)
                        est.push_back(msBetween(t0, Clock::now()));
                }
                // Planning a realistic path: a pan with shake, frame by frame, as the stabilizer does.
                auto planCost = [&](PlannerKind kind, int radius, int delay) {
                    StabilizerConfig pc;
                    pc.planner = kind;
                    pc.smoothing_radius = radius;
                    pc.delay = delay;
                    std::vector<Similarity> path;
                    Similarity pose;
                    for (int k = 0; k < 300; ++k) {
                        pose = pose * Similarity{1.5 + 3 * std::sin(k * 0.7), 0.5 + 3 * std::cos(k * 1.3),
                                                 0.002 * std::sin(k * 0.9), 1.0 + 0.0005 * std::sin(k * 1.1)};
                        path.push_back(pose);
                    }
                    std::vector<double> ms;
                    for (int rep = 0; rep < (o.quick ? 2 : 5); ++rep) {
                        const auto planner = makePathPlanner(pc);
                        for (std::size_t i = 0; i < path.size(); ++i) {
                            PlanRequest r;
                            r.index = std::int64_t(i);
                            r.segment_start = i == 0;
                            r.lookahead.assign(path.begin() + long(i),
                                               path.begin() + long(std::min(path.size(), i + std::size_t(delay) + 1)));
                            r.width = p.res.width;
                            r.height = p.res.height;
                            const auto t0 = Clock::now();
                            const PlannedFrame planned = planner->plan(r);
                            ms.push_back(msBetween(t0, Clock::now()));
                            if (planned.zoom < 0)
                                std::abort();
                        }
                    }
                    return ms;
                };
                box = planCost(PlannerKind::Box, 10, 20);
                gauss = planCost(PlannerKind::Gaussian, 20, 20);
                l1_20 = planCost(PlannerKind::L1, 20, 20);
                l1_0 = planCost(PlannerKind::L1, 20, 0);
                optimal20 = planCost(PlannerKind::Optimal, 20, 20);
                optimal0 = planCost(PlannerKind::Optimal, 20, 0);
                // Warp.
                FrameBuffer out(fmt, p.res.width, p.res.height);
                // The copy bound: every plane's rows copied input -> output, the bytes the warp reads
                // and writes at the least. Timed alternately with the warp (copy_ms), so that both
                // see the same machine.
                auto copyFrame = [](const FrameView &in, const FrameView &dst) {
                    for (int pl = 0; pl < in.planeCount(); ++pl) {
                        const int rows = in.planeHeight(pl), bytes = in.planeRowBytes(pl);
                        for (int y = 0; y < rows; ++y)
                            std::memcpy(dst.planes[pl].data + std::size_t(y) * dst.planes[pl].stride,
                                        in.planes[pl].data + std::size_t(y) * in.planes[pl].stride, std::size_t(bytes));
                    }
                };
                auto warpCost = [&](std::vector<double> *copy_ms) {
                    const FrameWarper warper(BorderMode::Black);
                    std::vector<double> ms;
                    const int reps = o.quick ? 15 : 40;
                    for (int k = 0; k < reps + 2; ++k) {
                        const Similarity m{0.7 * std::sin(k), 1.3 * std::cos(k), 0.004 * std::sin(0.5 * k), 0.92};
                        const FrameView in = frames[std::size_t(k) % frames.size()].view();
                        if (copy_ms != nullptr) {
                            const auto c0 = Clock::now();
                            copyFrame(in, out.view());
                            if (k >= 2)
                                copy_ms->push_back(msBetween(c0, Clock::now()));
                        }
                        const auto t0 = Clock::now();
                        warper.warp(in, out.view(), m);
                        if (k >= 2)
                            ms.push_back(msBetween(t0, Clock::now()));
                    }
                    return ms;
                };
                copy1.clear();
                warp1 = warpCost(&copy1);
                cv::setNumThreads(default_threads);
                warpN = warpCost(nullptr);
            });
            auto cell = [](const std::vector<double> &v, const char *f, double pct = 95) {
                return format(f, mean(v), percentile(v, pct));
            };
            t.row({p.res.name(), formatName(fmt), cell(est, "%.2f (%.2f)"), cell(box, "%.4f (%.4f)", 99),
                   cell(gauss, "%.4f (%.4f)", 99), cell(l1_20, "%.4f (%.4f)", 99), cell(l1_0, "%.4f (%.4f)", 99),
                   cell(optimal20, "%.4f (%.4f)", 99), cell(optimal0, "%.4f (%.4f)", 99), cell(warp1, "%.2f (%.2f)"),
                   cell(warpN, "%.2f (%.2f)"), cell(copy1, "%.2f (%.2f)"), format("%.2f", mean(warp1) / mean(copy1)),
                   format("%.2f", mean(est) + mean(l1_20) + mean(warp1)),
                   loadCell(others)});
            const std::string key = format("stage.%s.%s", p.res.name().c_str(), formatName(fmt));
            putResult(o, key + ".estimate_ms", mean(est));
            putResult(o, key + ".plan_box10_ms", mean(box));
            putResult(o, key + ".plan_gauss20_ms", mean(gauss));
            putResult(o, key + ".plan_l1_20_ms", mean(l1_20));
            putResult(o, key + ".plan_l1_20_p99_ms", percentile(l1_20, 99));
            putResult(o, key + ".plan_l1_0_ms", mean(l1_0));
            putResult(o, key + ".plan_optimal20_ms", mean(optimal20));
            putResult(o, key + ".plan_optimal20_p99_ms", percentile(optimal20, 99));
            putResult(o, key + ".plan_optimal0_ms", mean(optimal0));
            putResult(o, key + ".warp1_ms", mean(warp1));
            putResult(o, key + ".warpN_ms", mean(warpN));
            putResult(o, key + ".copy1_ms", mean(copy1));
            putResult(o, key + ".warp1_over_copy", mean(warp1) / mean(copy1));
            std::printf("  stages %s %s: estimate %.2f ms, plan (l1, delay 20) %.3f ms (p99 %.3f), warp %.2f ms "
                        "(1 thread) %.2f ms (default), copy bound %.2f ms, warp/copy %.2f\n",
                        p.res.name().c_str(), formatName(fmt), mean(est), mean(l1_20), percentile(l1_20, 99),
                        mean(warp1), mean(warpN), mean(copy1), mean(warp1) / mean(copy1));
            std::fflush(stdout);
        }
    }
    cv::setNumThreads(default_threads);
    frag.table(t);
}

// Frames pushed at a camera's pace; output times taken when the ready callback fires.
void sectionLatency(const Options &o, const std::vector<ResolutionPlan> &plans,
                    std::map<std::string, std::vector<cv::Mat>> &bgr_cache)
{
    Fragment frag(o, "latency_lib");
    const double fps = 30.0;
    const long n = o.quick ? 150 : 300;
    frag.text(format("Library latency: I420 frames pushed at %.0f fps (paced, %ld frames), default config "
                     "(delay 20, 2 workers). Delay = frames pushed after frame i when output i is popped; "
                     "processing latency = time from the start of push(frame i+delay) to output i being ready "
                     "(median, p99, max), beside one frame time (%.1f ms).",
                     fps, n, 1000.0 / fps));
    Table t(
        {"resolution", "delay (frames)", "delay (ms)", "processing median ms", "p99 ms", "max ms", "p99 <= 1 frame",
         "other processes"});
    for (const ResolutionPlan &p : plans) {
        const std::vector<FrameBuffer> frames = framesFromBgr(bgr_cache[p.res.name()], PixelFormat::I420);
        StabilizerConfig config;
        std::vector<double> latency, delay_frames;
        const double others = measureQuietly("latency " + p.res.name(), [&] {
            latency.clear();
            delay_frames.clear();
            Stabilizer stabilizer(config);
            OutputPool pool(PixelFormat::I420, p.res.width, p.res.height);
            std::mutex m;
            std::condition_variable cv;
            bool ready = false;
            stabilizer.setReadyCallback([&] {
                {
                    std::lock_guard<std::mutex> lock(m);
                    ready = true;
                }
                cv.notify_one();
            });
            std::vector<Clock::time_point> pushed{std::size_t(n)};
            long pushed_count = 0;
            auto drain = [&]() {
                while (auto f = stabilizer.tryPop()) {
                    const auto now = Clock::now();
                    const long i = static_cast<const PoolSlot &>(*f->slot).index();
                    delay_frames.push_back(double(pushed_count - 1 - i));
                    const long j = i + config.delay;
                    if (j < n)
                        latency.push_back(msBetween(pushed[std::size_t(j)], now));
                }
            };
            const auto start = Clock::now();
            for (long k = 0; k < n; ++k) {
                const auto due = start + std::chrono::microseconds(long(1e6 * k / fps));
                for (;;) {
                    std::unique_lock<std::mutex> lock(m);
                    if (!cv.wait_until(lock, due, [&] { return ready; }))
                        break;
                    ready = false;
                    lock.unlock();
                    drain();
                }
                drain();
                pushed[std::size_t(k)] = Clock::now();
                stabilizer.push(
                    std::make_unique<PoolSlot>(frames[std::size_t(pingPong(k, int(frames.size())))].view(), pool, k));
                ++pushed_count;
            }
            // Collect the warps still in flight as they land (up to 1 s), then flush.
            const auto until = Clock::now() + std::chrono::seconds(1);
            while (stabilizer.finalizedCount() > 0 && Clock::now() < until) {
                std::unique_lock<std::mutex> lock(m);
                cv.wait_until(lock, until, [&] { return ready; });
                ready = false;
                lock.unlock();
                drain();
            }
            stabilizer.flush();
            while (auto f = stabilizer.waitPop()) {
            }
        });
        const double d = median(delay_frames);
        const double p50 = median(latency), p99 = percentile(latency, 99), mx = maxOf(latency);
        t.row({p.res.name(), format("%.0f", d), format("%.0f", d * 1000.0 / fps), format("%.1f", p50),
               format("%.1f", p99), format("%.1f", mx), p99 <= 1000.0 / fps ? "yes" : "no", loadCell(others)});
        const std::string key = "latency.lib." + p.res.name();
        putResult(o, key + ".delay_frames", d);
        putResult(o, key + ".p50_ms", p50);
        putResult(o, key + ".p99_ms", p99);
        putResult(o, key + ".max_ms", mx);
        std::printf("  latency lib %s: delay %.0f frames, processing %.1f / %.1f ms (median/p99)\n",
                    p.res.name().c_str(), d, p50, p99);
        std::fflush(stdout);
    }
    frag.table(t);
}

void sectionPeers(const Options &o, const std::vector<ResolutionPlan> &plans,
                  std::map<std::string, std::vector<cv::Mat>> &bgr_cache)
{
    Fragment frag(o, "speed_peers");
    const bool have_ffmpeg = haveCommand("ffmpeg");
    const bool deshake = have_ffmpeg && ffmpegHasFilter("deshake");
    const bool vidstab = have_ffmpeg && ffmpegHasFilter("vidstabdetect") && ffmpegHasFilter("vidstabtransform");
    if (!deshake && !vidstab) {
        frag.text("Peers: skipped: ffmpeg (with deshake or vid.stab) is not installed.");
        putResultText(o, "peers.skipped", "ffmpeg not installed");
        return;
    }
    const int runs = o.quick ? 3 : 5;
    frag.text(format("Peers on the same frames (I420 = yuv420p, the synthetic flight played back and forth), read by "
                     "ffmpeg as raw video from a file in tmpfs, output discarded (`-f null -`); default filter "
                     "settings. vid.stab = `vidstabdetect` pass + `vidstabtransform` pass, both counted. "
                     "Wall time of the ffmpeg process (includes its start-up, about 0.1 s), median (min-max) of %d "
                     "runs. `ffmpeg read` is the same command with no filter: the cost of reading the frames.%s%s",
                     runs, deshake ? "" : " deshake: not available in this ffmpeg.",
                     vidstab ? "" : " vid.stab: not available in this ffmpeg."));
    Table t({"resolution", "frames", "ffmpeg read fps", "deshake fps", "vid.stab fps (2 passes)", "vidstabdetect fps",
             "vidstabtransform fps", "other processes"});
    ScratchDir scratch("peers");
    for (const ResolutionPlan &p : plans) {
        const std::vector<FrameBuffer> frames = framesFromBgr(bgr_cache[p.res.name()], PixelFormat::I420);
        const std::string raw = scratch.file("in.yuv"), trf = scratch.file("t.trf");
        {
            std::FILE *f = std::fopen(raw.c_str(), "wb");
            for (int k = 0; k < p.peer_frames; ++k)
                writeRawI420(f, frames[std::size_t(pingPong(k, int(frames.size())))].view());
            std::fclose(f);
        }
        const std::string in = format("ffmpeg -hide_banner -loglevel error -nostdin -f rawvideo -pix_fmt yuv420p "
                                      "-s %dx%d -r 30 -i %s ",
                                      p.res.width, p.res.height, raw.c_str());
        auto timed = [&](const std::string &cmd) {
            double s = 0;
            if (runCommand(cmd, &s) != 0)
                throw std::runtime_error("failed: " + cmd);
            return s;
        };
        std::vector<double> read_fps, deshake_fps, vs_fps, vsd_fps, vst_fps;
        const double others = measureQuietly("peers " + p.res.name(), [&] {
            for (auto *v : {&read_fps, &deshake_fps, &vs_fps, &vsd_fps, &vst_fps})
                v->clear();
            for (int r = 0; r < runs; ++r) {
                read_fps.push_back(p.peer_frames / timed(in + "-f null -"));
                if (deshake)
                    deshake_fps.push_back(p.peer_frames / timed(in + "-vf deshake -f null -"));
                if (vidstab) {
                    const double a = timed(in + "-vf vidstabdetect=result=" + trf + " -f null -");
                    const double b = timed(in + "-vf vidstabtransform=input=" + trf + " -f null -");
                    vs_fps.push_back(p.peer_frames / (a + b));
                    vsd_fps.push_back(p.peer_frames / a);
                    vst_fps.push_back(p.peer_frames / b);
                }
            }
        });
        std::remove(raw.c_str());
        t.row({p.res.name(), std::to_string(p.peer_frames), spread(read_fps, "%.0f"),
               deshake ? spread(deshake_fps, "%.1f") : "n/a", vidstab ? spread(vs_fps, "%.1f") : "n/a",
               vidstab ? spread(vsd_fps, "%.1f") : "n/a", vidstab ? spread(vst_fps, "%.1f") : "n/a",
               loadCell(others)});
        if (deshake)
            putResult(o, "peer.deshake.fps." + p.res.name(), median(deshake_fps));
        if (vidstab)
            putResult(o, "peer.vidstab.fps." + p.res.name(), median(vs_fps));
        std::printf("  peers %s: deshake %s fps, vid.stab %s fps\n", p.res.name().c_str(),
                    spread(deshake_fps, "%.1f").c_str(), spread(vs_fps, "%.1f").c_str());
        std::fflush(stdout);
    }
    frag.table(t);
}

} // namespace

int main(int argc, char **argv)
{
    try {
        const Options o = parseOptions(argc, argv, "usage: uavstab-bench-speed --out DIR [--quick] [--only lib|stages|latency|peers]... [--cv-threads N]\n",
                                       {"lib", "stages", "latency", "peers"}, {"--cv-threads"});
        for (std::size_t i = 0; i + 1 < o.rest.size(); ++i)
            if (o.rest[i] == "--cv-threads")  // for experiments: OpenCV's pool size
                cv::setNumThreads(std::atoi(o.rest[i + 1].c_str()));
        const std::vector<ResolutionPlan> plans = benchPlans(o);
        std::map<std::string, std::vector<cv::Mat>> bgr;
        for (const ResolutionPlan &p : plans) {
            const auto t0 = Clock::now();
            bgr[p.res.name()] = renderFlight(p.res.width, p.res.height, p.distinct);
            std::printf("rendered %d frames of %s in %.1f s\n", p.distinct, p.res.name().c_str(),
                        secondsBetween(t0, Clock::now()));
            std::fflush(stdout);
        }
        if (o.wants("lib"))
            sectionLibrary(o, plans, bgr);
        if (o.wants("stages"))
            sectionStages(o, plans, bgr);
        if (o.wants("latency"))
            sectionLatency(o, plans, bgr);
        if (o.wants("peers"))
            sectionPeers(o, plans, bgr);
    } catch (const std::exception &e) {
        std::cerr << "uavstab-bench-speed: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
