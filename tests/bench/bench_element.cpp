// Speed and latency of the uavstabilize element in a pipeline:
//   appsrc (frames made in memory beforehand) ! uavstabilize ! fakesink sync=false
//
//   uavstab-bench-element --out DIR [--quick] [--resolution WxH]... [--only throughput|latency|affine-meta]...
#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <thread>

#include "common.hpp"
#include "gst_bench.hpp"

using namespace uavstab;
using namespace bench;

namespace {

// Frames/s of one run; `render` is the element's render property (warp: every frame must come
// out warped; affine-meta: every frame is the input with the meta, none warped). With
// `cpu_ms`: the process's CPU time per frame over the run (every thread: the element's, its
// workers', appsrc's and the pushing one's).
double elementRun(const GstFrames &frames, long pushes, int threads, std::string *error,
                  const std::string &render = "warp", double *cpu_ms = nullptr)
{
    // The default (auto) warps in front of fakesink; naming render only when it is not the
    // warp keeps this harness usable on builds without the property (tests/bench/ab.sh).
    ElementRun run(frames, "threads=" + std::to_string(threads) + (render == "warp" ? "" : " render=" + render));
    run.start();
    const double cpu0 = cpuSeconds(CLOCK_PROCESS_CPUTIME_ID);
    const auto t0 = Clock::now();
    for (long k = 0; k < pushes; ++k)
        run.push(k);
    const bool ok = run.finish();
    const double s = secondsBetween(t0, Clock::now());
    if (cpu_ms != nullptr)
        *cpu_ms = 1000.0 * (cpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - cpu0) / double(pushes);
    if (!ok || run.received() != pushes) {
        *error = ok ? format("received %ld of %ld frames", run.received(), pushes) : run.error();
        return std::nan("");
    }
    const long expected_unwarped = render == "affine-meta" ? pushes : 0;
    if (run.passedThrough() != expected_unwarped) {
        *error = format("%ld of %ld frames came out unwarped (input buffer passed through), %ld expected",
                        run.passedThrough(), pushes, expected_unwarped);
        return std::nan("");
    }
    return double(pushes) / s;
}

// render=affine-meta (no warp: the input goes downstream with a GstVideoAffineTransformationMeta
// for a GL element to draw) against render=warp, runs alternated in one process.
void sectionAffineMeta(const Options &o, const std::vector<ResolutionPlan> &plans,
                       std::map<std::string, std::vector<cv::Mat>> &bgr)
{
    Fragment frag(o, "speed_affine_meta");
    const int runs = o.quick ? 3 : 5;
    const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
    frag.text(format("Zero-copy mode: `appsrc ! uavstabilize threads=2 render=affine-meta ! fakesink` (no warp, the input "
                     "buffer goes downstream with its GstVideoAffineTransformationMeta) against `render=warp`, I420, "
                     "runs alternated, median (min-max) of %d runs each after a warm-up. Target (issue 22): "
                     "affine-meta >= 3x the warp's frames/s at 1920x1080. **CPU ms/frame**: the process's CPU time "
                     "per frame (every thread, appsrc's included); **cores busy**: CPU time over wall time (%d "
                     "cores here). Both modes estimate and plan every frame, and only the warp mode warps, so the "
                     "fps ratio is the CPU ratio times the ratio of cores busy: the CPU ratio is what affine-meta "
                     "reaches with the cores as busy as in the warp mode, and a faster warp lowers it.",
                     runs, cores));
    Table t({"resolution", "warp fps", "affine-meta fps", "affine-meta / warp", "CPU ms/frame warp",
             "CPU ms/frame affine-meta", "CPU warp / affine-meta", "cores busy warp / affine-meta",
             "other processes"});
    for (const ResolutionPlan &p : plans) {
        const GstFrames frames(framesFromBgr(bgr[p.res.name()], PixelFormat::I420), 30);
        std::string error;
        std::vector<double> warp, meta, ratio, warp_cpu, meta_cpu, cpu_ratio, warp_busy, meta_busy;
        const double others = measureQuietly("affine-meta " + p.res.name(), [&] {
            for (auto *v : {&warp, &meta, &ratio, &warp_cpu, &meta_cpu, &cpu_ratio, &warp_busy, &meta_busy})
                v->clear();
            elementRun(frames, std::min<long>(p.pushes / 2, 60), 2, &error, "affine-meta");  // warm-up
            for (int r = 0; r < runs && error.empty(); ++r) {
                double wc = 0.0, mc = 0.0;
                const double w = elementRun(frames, p.pushes, 2, &error, "warp", &wc);
                const double m = error.empty() ? elementRun(frames, p.pushes, 2, &error, "affine-meta", &mc) : 0.0;
                if (error.empty()) {
                    warp.push_back(w);
                    meta.push_back(m);
                    ratio.push_back(m / w);
                    warp_cpu.push_back(wc);
                    meta_cpu.push_back(mc);
                    cpu_ratio.push_back(wc / mc);
                    // CPU ms per frame times frames per second: CPU seconds per second.
                    warp_busy.push_back(wc * w / 1000.0);
                    meta_busy.push_back(mc * m / 1000.0);
                }
            }
        });
        if (!error.empty()) {
            frag.text(format("**Element run failed** at %s: %s", p.res.name().c_str(), error.c_str()));
            continue;
        }
        t.row({p.res.name(), spread(warp, "%.0f"), spread(meta, "%.0f"), format("%.2fx", median(ratio)),
               format("%.2f", median(warp_cpu)), format("%.2f", median(meta_cpu)),
               format("%.2fx", median(cpu_ratio)), format("%.2f / %.2f", median(warp_busy), median(meta_busy)),
               loadCell(others)});
        const std::string key = format("element.affine_meta.%s", p.res.name().c_str());
        putResult(o, key + ".fps", median(meta));
        putResult(o, key + ".warp_fps", median(warp));
        putResult(o, key + ".ratio", median(ratio));
        putResult(o, key + ".warp_cpu_ms", median(warp_cpu));
        putResult(o, key + ".cpu_ms", median(meta_cpu));
        putResult(o, key + ".cpu_ratio", median(cpu_ratio));
        std::printf("  affine-meta %s: %s fps vs warp %s fps (%.2fx); CPU %.2f vs %.2f ms/frame (%.2fx)\n",
                    p.res.name().c_str(), spread(meta).c_str(), spread(warp).c_str(), median(ratio), median(meta_cpu),
                    median(warp_cpu), median(cpu_ratio));
    }
    frag.table(t);
}

void sectionThroughput(const Options &o, const std::vector<ResolutionPlan> &plans,
                       std::map<std::string, std::vector<cv::Mat>> &bgr)
{
    Fragment frag(o, "speed_element");
    const int runs = o.quick ? 3 : 5;
    frag.text(format("Element in a pipeline: `appsrc (frames made in memory beforehand, is-live=false, block=true, "
                     "3 frames queued at most) ! uavstabilize threads=N ! fakesink sync=false`, default properties "
                     "otherwise. Frames/s from the first push to EOS at the sink (a new pipeline per run, so each "
                     "run includes the element's start-up and the drain of the %s-frame delay), median (min-max) "
                     "of %d runs after one warm-up run. CPU ms/frame: the process's CPU time per frame (every "
                     "thread, appsrc's included), and cores busy: CPU time over wall time, medians over the runs.",
                     "20", runs));
    Table t({"resolution", "format", "threads", "frames/run", "fps median (min-max)", "ms/frame", "CPU ms/frame",
             "cores busy", "other processes"});
    for (const ResolutionPlan &p : plans) {
        for (PixelFormat fmt : {PixelFormat::I420, PixelFormat::BGRx}) {
            const GstFrames frames(framesFromBgr(bgr[p.res.name()], fmt), 30);
            for (int threads : {1, 2}) {
                std::string error;
                std::vector<double> fps, cpu, busy;
                const double others = measureQuietly("element " + p.res.name(), [&] {
                    fps.clear();
                    cpu.clear();
                    busy.clear();
                    elementRun(frames, std::min<long>(p.pushes / 2, 60), threads, &error);  // warm-up
                    for (int r = 0; r < runs && error.empty(); ++r) {
                        double c = 0.0;
                        const double v = elementRun(frames, p.pushes, threads, &error, "warp", &c);
                        if (error.empty()) {
                            fps.push_back(v);
                            cpu.push_back(c);
                            busy.push_back(c * v / 1000.0);
                        }
                    }
                });
                if (!error.empty()) {
                    frag.text(format("**Element run failed** at %s %s threads=%d: %s", p.res.name().c_str(),
                                     formatName(fmt), threads, error.c_str()));
                    continue;
                }
                const double med = median(fps);
                t.row({p.res.name(), formatName(fmt), std::to_string(threads), std::to_string(p.pushes),
                       spread(fps, "%.0f"), format("%.2f", 1000.0 / med), format("%.2f", median(cpu)),
                       format("%.2f", median(busy)), loadCell(others)});
                const std::string key = format("element.fps.%s.%s.t%d", p.res.name().c_str(), formatName(fmt), threads);
                putResult(o, key, med);
                putResult(o, key + ".min", minOf(fps));
                putResult(o, key + ".max", maxOf(fps));
                putResult(o, key + ".cpu_ms", median(cpu));
                std::printf("  element %s %s threads=%d: %s fps\n", p.res.name().c_str(), formatName(fmt), threads,
                            spread(fps).c_str());
                std::fflush(stdout);
            }
        }
    }
    frag.table(t);
}

void sectionLatency(const Options &o, const std::vector<ResolutionPlan> &plans,
                    std::map<std::string, std::vector<cv::Mat>> &bgr)
{
    Fragment frag(o, "latency_element");
    const int fps = 30;
    const long n = o.quick ? 150 : 300;
    frag.text(format("Element latency: I420 frames pushed into appsrc at %d fps (paced, %ld frames), default "
                     "properties (delay 20, 2 threads). Delay on timestamps = input frames pushed when the output "
                     "with frame i's PTS reaches the sink, minus i+1; the LATENCY query of the element's src pad "
                     "(its reported latency); processing latency = arrival of output i at the sink minus the push "
                     "of frame i+delay into appsrc (median, p99, max), beside one frame time (%.1f ms).",
                     fps, n, 1000.0 / fps));
    Table t({"resolution", "delay (frames)", "delay (ms)", "LATENCY query (ms)", "processing median ms", "p99 ms",
             "max ms", "p99 <= 1 frame", "other processes"});
    for (const ResolutionPlan &p : plans) {
        const GstFrames frames(framesFromBgr(bgr[p.res.name()], PixelFormat::I420), fps);
        const int delay = 20;
        std::vector<double> latency, delays;
        gint64 query = -1;
        std::string error;
        const double others = measureQuietly("element latency " + p.res.name(), [&] {
            latency.clear();
            delays.clear();
            ElementRun run(frames, "");
            run.start();
            const auto start = Clock::now();
            for (long k = 0; k < n; ++k) {
                std::this_thread::sleep_until(start + std::chrono::microseconds(long(1e6 * k / fps)));
                run.push(k);
                if (k == 40)
                    query = run.queryLatency();
            }
            if (!run.finish()) {
                error = run.error();
                return;
            }
            const auto &pushed = run.pushTimes();
            for (const auto &a : run.arrivals()) {
                if (a.index < 0 || a.index + delay >= n)
                    continue;  // drained at EOS
                delays.push_back(double(a.pushed - 1 - a.index));
                latency.push_back(msBetween(pushed[std::size_t(a.index + delay)], a.time));
            }
        });
        if (!error.empty()) {
            frag.text(format("**Element latency run failed** at %s: %s", p.res.name().c_str(), error.c_str()));
            continue;
        }
        const double d = median(delays);
        const double p50 = median(latency), p99 = percentile(latency, 99), mx = maxOf(latency);
        t.row({p.res.name(), format("%.0f", d), format("%.0f", d * 1000.0 / fps),
               query >= 0 ? format("%.1f", query / 1e6) : "n/a", format("%.1f", p50), format("%.1f", p99),
               format("%.1f", mx), p99 <= 1000.0 / fps ? "yes" : "no", loadCell(others)});
        const std::string key = "latency.element." + p.res.name();
        putResult(o, key + ".delay_frames", d);
        putResult(o, key + ".query_ms", query / 1e6);
        putResult(o, key + ".p50_ms", p50);
        putResult(o, key + ".p99_ms", p99);
        putResult(o, key + ".max_ms", mx);
        std::printf("  latency element %s: delay %.0f frames, query %.1f ms, processing %.1f / %.1f ms\n",
                    p.res.name().c_str(), d, query / 1e6, p50, p99);
        std::fflush(stdout);
    }
    frag.table(t);
}

} // namespace

int main(int argc, char **argv)
{
    try {
        std::string why;
        const bool ok = initElement(&argc, &argv, &why);
        const Options o = parseOptions(argc, argv, "usage: uavstab-bench-element --out DIR [--quick] [--resolution WxH]... [--only throughput|latency|affine-meta]...\n",
                                       {"throughput", "latency", "affine-meta"});
        if (!ok) {
            Fragment a(o, "speed_element"), b(o, "latency_element");
            a.text("Element throughput: skipped: " + why + ".");
            b.text("Element latency: skipped: " + why + ".");
            putResultText(o, "element.skipped", why);
            return 0;
        }
        const std::vector<ResolutionPlan> plans = benchPlans(o);
        std::map<std::string, std::vector<cv::Mat>> bgr;
        for (const ResolutionPlan &p : plans)
            bgr[p.res.name()] = renderFlight(p.res.width, p.res.height, p.distinct);
        if (o.wants("throughput"))
            sectionThroughput(o, plans, bgr);
        if (o.wants("latency"))
            sectionLatency(o, plans, bgr);
        if (o.wants("affine-meta"))
            sectionAffineMeta(o, plans, bgr);
    } catch (const std::exception &e) {
        std::cerr << "uavstab-bench-element: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
