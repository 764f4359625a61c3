// Memory: peak RSS per resolution, and RSS along a long stream (320x240) to show that it
// does not grow with stream length. Each measurement runs in a child process of its own
// (peak RSS is per process), on fresh input buffers per frame (a copy of one of 24
// frames made in memory beforehand), as a decoder or camera would hand them over.
//
//   uavstab-bench-memory --out DIR [--quick] [--resolution WxH]...                    (driver: runs the children)
//   uavstab-bench-memory --child lib|element WxH FRAMES [CHECKPOINT...]
#include <cmath>
#include <cstring>
#include <iostream>
#include <malloc.h>
#include <map>
#include <sstream>
#include <unistd.h>

#include "common.hpp"
#include "uavstab/stabilizer.hpp"
#ifdef UAVSTAB_BENCH_WITH_GST
#include "gst_bench.hpp"
#endif

using namespace uavstab;
using namespace bench;

namespace {

constexpr int kDistinct = 24;

double mib(long kib)
{
    return kib / 1024.0;
}

// Prints "rss_at_N=KiB" at each checkpoint and "base=", "peak=", "frame_bytes=" at the end.
int childLibrary(int width, int height, long frames, const std::vector<long> &checkpoints)
{
    std::vector<FrameBuffer> pool = framesFromBgr(renderFlight(width, height, kDistinct), PixelFormat::I420);
    malloc_trim(0);
    StabilizerConfig config;
    Stabilizer stabilizer(config);
    const std::size_t max_in_flight = std::size_t(config.resolvedThreads()) + 2;
    resetPeakRss();
    const long base = rssKiB(), heap_base = heapInUseKiB();
    long heap_peak = heap_base;
    const bool sample_heap = frames <= 2000;  // mallinfo2 walks the heap: only on short runs
    std::size_t next = 0;
    for (long k = 0; k < frames; ++k) {
        stabilizer.push(std::make_unique<OwnedSlot>(pool[std::size_t(pingPong(k, kDistinct))], k));
        if (sample_heap)
            heap_peak = std::max(heap_peak, heapInUseKiB());
        while (auto f = stabilizer.tryPop()) {
        }
        while (stabilizer.finalizedCount() > max_in_flight)
            stabilizer.waitPop();
        if (next < checkpoints.size() && k + 1 == checkpoints[next]) {
            std::printf("rss_at_%ld=%ld\n", k + 1, rssKiB());
            std::fflush(stdout);
            ++next;
        }
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop()) {
    }
    std::printf("base=%ld\npeak=%ld\nheap_base=%ld\nheap_peak=%ld\nframe_bytes=%zu\n", base, peakRssKiB(), heap_base,
                heap_peak, std::size_t(width) * height * 3 / 2);
    return 0;
}

#ifdef UAVSTAB_BENCH_WITH_GST
int childElement(int width, int height, long frames, const std::vector<long> &checkpoints)
{
    GstFrames gst_frames(framesFromBgr(renderFlight(width, height, kDistinct), PixelFormat::I420), 30);
    malloc_trim(0);
    ElementRun run(gst_frames, "");
    run.setRecording(false);
    run.start();
    resetPeakRss();
    const long base = rssKiB(), heap_base = heapInUseKiB();
    long heap_peak = heap_base;
    const bool sample_heap = frames <= 2000;
    std::size_t next = 0;
    for (long k = 0; k < frames; ++k) {
        run.push(k, true);  // a deep copy: new memory per frame
        if (sample_heap)
            heap_peak = std::max(heap_peak, heapInUseKiB());
        if (next < checkpoints.size() && k + 1 == checkpoints[next]) {
            std::printf("rss_at_%ld=%ld\n", k + 1, rssKiB());
            std::fflush(stdout);
            ++next;
        }
    }
    if (!run.finish()) {
        std::fprintf(stderr, "element run failed: %s\n", run.error().c_str());
        return 1;
    }
    std::printf("base=%ld\npeak=%ld\nheap_base=%ld\nheap_peak=%ld\nframe_bytes=%zu\nreceived=%ld\n", base, peakRssKiB(),
                heap_base, heap_peak, gst_frames.frameBytes(), run.received());
    return 0;
}
#endif

std::map<std::string, long> runChild(const std::string &mode, const Resolution &r, long frames,
                                     const std::vector<long> &checkpoints)
{
    char self[4096];
    const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0)
        throw std::runtime_error("cannot find my own executable");
    self[n] = '\0';
    std::string cmd = shellQuote(self) + " --child " + mode + " " + r.name() + " " + std::to_string(frames);
    for (long c : checkpoints)
        cmd += " " + std::to_string(c);
    std::map<std::string, long> values;
    std::istringstream out(commandOutput(cmd + " 2>&1"));
    std::string line;
    while (std::getline(out, line)) {
        const auto eq = line.find('=');
        if (eq != std::string::npos)
            values[line.substr(0, eq)] = std::atol(line.c_str() + eq + 1);
        else
            std::printf("    %s\n", line.c_str());
    }
    return values;
}

void driver(const Options &o, bool element)
{
    Fragment frag(o, "memory");
    const int delay = StabilizerConfig{}.delay;
    const long frames = o.quick ? 120 : 300;
    frag.text(format(
        "Memory: each measurement is a process of its own; input frames are fresh buffers (a copy of one of %d frames "
        "made in memory beforehand), I420, default config (delay %d). Base = RSS after the frames were made, "
        "before the first push; peak = VmHWM (reset at the base); the difference is what the stabilizer holds "
        "(held input frames, output frames in flight, pyramids, and what the allocator keeps), also in frames of "
        "the resolution. The peak of malloc'ed bytes in use (mallinfo2, sampled after every push) separates "
        "what is really held from what glibc keeps mapped; budget = delay + 4 = %d frames (element: + 4 for "
        "appsrc's queue of 3 and the frame being pushed). Library: `Stabilizer` with at most threads+2 warps in "
        "flight; "
        "element: `appsrc ! uavstabilize ! fakesink`, appsrc queueing at most 3 frames (counted here too).",
        kDistinct, delay, delay + 4));
    Table t({"resolution", "what", "frames", "frame MiB", "base RSS MiB", "peak RSS MiB", "peak - base MiB", "= frames",
             "peak heap in use - base MiB", "= frames", "heap within budget"});
    std::vector<std::string> modes{"lib"};
    if (element)
        modes.push_back("element");
    for (const Resolution &r : benchResolutions(o)) {
        for (const std::string &mode : modes) {
            const auto v = runChild(mode, r, frames, {});
            if (!v.count("peak")) {
                frag.text("**Memory run failed** for " + mode + " at " + r.name());
                continue;
            }
            const double fb = double(v.at("frame_bytes")) / (1024.0 * 1024.0);
            const double held = mib(v.at("peak") - v.at("base"));
            const double in_frames = held / fb;
            // The element's own budget plus what the harness holds (appsrc's queue).
            const double budget = delay + 4 + (mode == "element" ? 4 : 0);
            const double heap = mib(v.at("heap_peak") - v.at("heap_base")), heap_frames = heap / fb;
            t.row({r.name(), mode == "lib" ? "library" : "element", std::to_string(frames), format("%.2f", fb),
                   format("%.0f", mib(v.at("base"))), format("%.0f", mib(v.at("peak"))), format("%.0f", held),
                   format("%.1f", in_frames), format("%.0f", heap), format("%.1f", heap_frames),
                   heap_frames <= budget ? format("yes (<= %.0f)", budget) : format("no (> %.0f)", budget)});
            putResult(o, "memory." + mode + "." + r.name() + ".heap_frames", heap_frames);
            putResult(o, "memory." + mode + "." + r.name() + ".peak_mib", mib(v.at("peak")));
            putResult(o, "memory." + mode + "." + r.name() + ".held_frames", in_frames);
            std::printf("  memory %s %s: peak %.0f MiB, held %.0f MiB = %.1f frames\n", mode.c_str(), r.name().c_str(),
                        mib(v.at("peak")), held, in_frames);
            std::fflush(stdout);
        }
    }
    frag.table(t);

    // Long stream.
    const Resolution small{320, 240};
    const long total = o.quick ? 30000 : 100000;
    std::vector<long> checkpoints{1000, 10000, total};
    if (o.quick)
        checkpoints = {1000, 10000, 30000};
    const std::string mode = element ? "element" : "lib";
    const auto t0 = Clock::now();
    const auto v = runChild(mode, small, total, checkpoints);
    const double secs = secondsBetween(t0, Clock::now());
    if (!v.count("peak")) {
        frag.text("**Long memory run failed** (" + mode + ")");
        return;
    }
    Table l({"what", "resolution", "RSS after 1k frames MiB", "after 10k MiB", format("after %ldk MiB", total / 1000),
             format("growth 10k -> %ldk MiB", total / 1000), "peak MiB", "fps"});
    const std::string last = "rss_at_" + std::to_string(total);
    const double growth = mib(v.at(last) - v.at("rss_at_10000"));
    l.row({mode == "lib" ? "library" : "element", small.name(), format("%.1f", mib(v.at("rss_at_1000"))),
           format("%.1f", mib(v.at("rss_at_10000"))), format("%.1f", mib(v.at(last))), format("%+.2f", growth),
           format("%.1f", mib(v.at("peak"))), format("%.0f", total / secs)});
    putResult(o, "memory.long.frames", double(total));
    putResult(o, "memory.long.rss10k_mib", mib(v.at("rss_at_10000")));
    putResult(o, "memory.long.rss_end_mib", mib(v.at(last)));
    putResult(o, "memory.long.growth_mib", growth);
    frag.text(format("Long stream (%s, %ld frames of %s, fresh input buffers):", mode == "lib" ? "library" : "element",
                     total, small.name().c_str()));
    frag.table(l);
}

} // namespace

int main(int argc, char **argv)
{
    try {
        bool element = false;
#ifdef UAVSTAB_BENCH_WITH_GST
        std::string why;
        element = initElement(&argc, &argv, &why);
#endif
        if (argc >= 5 && std::string(argv[1]) == "--child") {
            const std::string mode = argv[2];
            int w = 0, h = 0;
            std::sscanf(argv[3], "%dx%d", &w, &h);
            const long frames = std::atol(argv[4]);
            std::vector<long> checkpoints;
            for (int i = 5; i < argc; ++i)
                checkpoints.push_back(std::atol(argv[i]));
            if (mode == "lib")
                return childLibrary(w, h, frames, checkpoints);
#ifdef UAVSTAB_BENCH_WITH_GST
            if (mode == "element" && element)
                return childElement(w, h, frames, checkpoints);
#endif
            std::fprintf(stderr, "mode %s not available\n", mode.c_str());
            return 2;
        }
        const Options o = parseOptions(argc, argv, "usage: uavstab-bench-memory --out DIR [--quick]\n       uavstab-bench-memory --child lib|element WxH FRAMES [CHECKPOINT...]\n");
        driver(o, element);
    } catch (const std::exception &e) {
        std::cerr << "uavstab-bench-memory: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
