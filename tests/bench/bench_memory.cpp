// Memory: peak RSS per resolution, and RSS along a long stream (320x240) to show that it
// does not grow with stream length. Each measurement runs in a child process of its own
// (peak RSS is per process), on fresh input buffers per frame (a copy of one of 24
// frames made in memory beforehand), as a decoder or camera would hand them over.
//
//   uavstab-bench-memory --out DIR [--quick] [--resolution WxH]...                    (driver: runs the children)
//   uavstab-bench-memory --child lib|element WxH FRAMES [CHECKPOINT...]
#include <algorithm>
#include <atomic>
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
// The library run's backpressure: a frame the delay lets go of is finalized (takes an output
// frame) only while fewer finalized frames than warp threads are not yet popped, as the
// element's chain does (gst/uavstabilize_element.hpp, maxFinalizedFor).
std::size_t libraryMaxFinalized()
{
    return std::size_t(std::max(1, StabilizerConfig{}.resolvedThreads()) - 1);
}
// The memory budget: the frames the delay holds and 8 more, library and element alike
// (the element's verdict leaves appsrc's queue out).
constexpr int kBudgetExtraFrames = 8;

// The verdict on the heap's frames; the element's are counted without appsrc's queue (the
// harness's frames, not the element's).
std::string withinBudget(double frames, int budget, bool element)
{
    const char *what = element ? " without appsrc's queue" : "";
    return frames <= budget ? format("yes (%.1f%s <= %d)", frames, what, budget)
                            : format("no (%.1f%s > %d)", frames, what, budget);
}

double mib(long kib)
{
    return kib / 1024.0;
}

// What each frame's worth of the peak is: frames counted at the moment the heap in use was
// highest (sampled after every push and every drained frame).
struct PeakBreakdown {
    long heap = 0;            // KiB in use, the peak
    long held_inputs = 0;     // input frames the delay holds, and the one being estimated
    long inflight_inputs = 0; // input frames finalized, their warp not done or not yet popped
    long outputs = 0;         // output frames: warps in flight, popped but not yet let go, pooled
    long queued_inputs = 0;   // element: input frames in appsrc's queue (the harness's)

    void print() const
    {
        std::printf("at_peak_held_inputs=%ld\nat_peak_inflight_inputs=%ld\nat_peak_outputs=%ld\n"
                    "at_peak_queued_inputs=%ld\n",
                    held_inputs, inflight_inputs, outputs, queued_inputs);
    }
};

// The library run's frames, counted as they come and go.
std::atomic<long> g_live_inputs{0}, g_live_outputs{0};

class CountedSlot : public FrameSlot {
public:
    explicit CountedSlot(const FrameBuffer &in) : in_(in) { ++g_live_inputs; }  // a fresh copy
    ~CountedSlot() override
    {
        --g_live_inputs;
        if (out_.width() > 0)
            --g_live_outputs;
    }
    FrameView input() override { return in_.view(); }
    std::optional<FrameView> acquireOutput() override
    {
        out_ = FrameBuffer(in_.format(), in_.width(), in_.height());
        ++g_live_outputs;
        return out_.view();
    }

private:
    FrameBuffer in_, out_;
};

// Prints "rss_at_N=KiB" at each checkpoint and "base=", "peak=", "frame_bytes=" at the end.
int childLibrary(int width, int height, long frames, const std::vector<long> &checkpoints)
{
    std::vector<FrameBuffer> pool = framesFromBgr(renderFlight(width, height, kDistinct), PixelFormat::I420);
    malloc_trim(0);
    StabilizerConfig config;
    Stabilizer stabilizer(config);
    const std::size_t max_in_flight = libraryMaxFinalized();
    resetPeakRss();
    const long base = rssKiB(), heap_base = heapInUseKiB();
    PeakBreakdown at_peak;
    at_peak.heap = heap_base;
    const bool sample_heap = frames <= 2000;  // mallinfo2 walks the heap: only on short runs
    const auto sample = [&] {
        if (!sample_heap)
            return;
        const long heap = heapInUseKiB();
        if (heap <= at_peak.heap)
            return;
        at_peak.heap = heap;
        at_peak.held_inputs = long(stabilizer.heldCount());
        at_peak.inflight_inputs = g_live_inputs.load() - at_peak.held_inputs;
        at_peak.outputs = g_live_outputs.load();
    };
    // As the element does: a frame beyond the delay is finalized (and takes an output
    // frame) only when at most max_in_flight finalized frames are not yet popped; each
    // ready frame is popped (and let go) at once.
    const auto pop_ready = [&] {
        while (auto f = stabilizer.tryPop()) {
        }
    };
    const auto wait_room = [&] {
        pop_ready();
        while (stabilizer.finalizedCount() > max_in_flight)
            stabilizer.waitPop();
    };
    std::size_t next = 0;
    for (long k = 0; k < frames; ++k) {
        stabilizer.pushHeld(std::make_unique<CountedSlot>(pool[std::size_t(pingPong(k, kDistinct))]));
        sample();
        for (;;) {
            wait_room();
            if (!stabilizer.finalizeDue())
                break;
            sample();
        }
        if (next < checkpoints.size() && k + 1 == checkpoints[next]) {
            std::printf("rss_at_%ld=%ld\n", k + 1, rssKiB());
            std::fflush(stdout);
            ++next;
        }
    }
    // Drained as the element drains at EOS: one frame at a time, with the same room.
    for (;;) {
        wait_room();
        if (!stabilizer.flushOne())
            break;
        sample();
    }
    while (auto f = stabilizer.waitPop()) {
    }
    std::printf("base=%ld\npeak=%ld\nheap_base=%ld\nheap_peak=%ld\nframe_bytes=%zu\n", base, peakRssKiB(), heap_base,
                at_peak.heap, std::size_t(width) * height * 3 / 2);
    at_peak.print();
    return 0;
}

#ifdef UAVSTAB_BENCH_WITH_GST
// The element run's frames: buffers are counted from when they enter uavstabilize (input)
// or first leave it (output) until they are freed. Output buffers go back to its pool,
// which keeps them and hands them out again: once seen, a pooled buffer stays counted,
// wherever it is (being warped again, pushed, or idle in the pool). Only a buffer the pool
// has just allocated goes uncounted until it leaves, at the start of the stream.
std::atomic<long> g_element_inputs{0}, g_element_outputs{0};
GQuark g_counted_quark;

void countBuffer(GstPadProbeInfo *info, std::atomic<long> &counter)
{
    GstBuffer *buffer = GST_PAD_PROBE_INFO_BUFFER(info);
    if (buffer && !gst_mini_object_get_qdata(GST_MINI_OBJECT(buffer), g_counted_quark)) {
        ++counter;
        gst_mini_object_set_qdata(GST_MINI_OBJECT(buffer), g_counted_quark, &counter,
                                  [](gpointer c) { --*static_cast<std::atomic<long> *>(c); });
    }
}

GstPadProbeReturn countInput(GstPad *, GstPadProbeInfo *info, gpointer)
{
    countBuffer(info, g_element_inputs);
    return GST_PAD_PROBE_OK;
}

GstPadProbeReturn countOutput(GstPad *, GstPadProbeInfo *info, gpointer)
{
    countBuffer(info, g_element_outputs);
    return GST_PAD_PROBE_OK;
}

int childElement(int width, int height, long frames, const std::vector<long> &checkpoints)
{
    GstFrames gst_frames(framesFromBgr(renderFlight(width, height, kDistinct), PixelFormat::I420), 30);
    malloc_trim(0);
    ElementRun run(gst_frames, "");
    run.setRecording(false);
    g_counted_quark = g_quark_from_static_string("uavstab-bench-memory-counted");
    GstElement *stab = gst_bin_get_by_name(GST_BIN(run.pipeline()), "stab");
    GstElement *src = gst_bin_get_by_name(GST_BIN(run.pipeline()), "src");
    GstPad *sinkpad = gst_element_get_static_pad(stab, "sink");
    GstPad *srcpad = gst_element_get_static_pad(stab, "src");
    gst_pad_add_probe(sinkpad, GST_PAD_PROBE_TYPE_BUFFER, countInput, nullptr, nullptr);
    gst_pad_add_probe(srcpad, GST_PAD_PROBE_TYPE_BUFFER, countOutput, nullptr, nullptr);
    gst_object_unref(sinkpad);
    gst_object_unref(srcpad);
    run.start();
    resetPeakRss();
    const long base = rssKiB(), heap_base = heapInUseKiB();
    PeakBreakdown at_peak;
    at_peak.heap = heap_base;
    std::vector<long> at_peak_outputs_seen;
    const bool sample_heap = frames <= 2000;
    std::size_t next = 0;
    for (long k = 0; k < frames; ++k) {
        run.push(k, true);  // a deep copy: new memory per frame
        if (sample_heap) {
            const long heap = heapInUseKiB();
            if (heap > at_peak.heap) {
                at_peak.heap = heap;
                guint64 level = 0;
                g_object_get(src, "current-level-bytes", &level, nullptr);
                at_peak.queued_inputs = long(level / gst_frames.frameBytes());
                at_peak.inflight_inputs = g_element_inputs.load();  // split below
                at_peak.outputs = g_element_outputs.load();
            }
        }
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
    // The element's inputs at the peak: `delay` + 1 held (the delay buffer, full from frame
    // `delay` on, and the frame being estimated) and the rest in flight.
    guint delay = 0;
    g_object_get(stab, "delay", &delay, nullptr);
    at_peak.held_inputs = std::min<long>(at_peak.inflight_inputs, long(delay) + 1);
    at_peak.inflight_inputs -= at_peak.held_inputs;
    gst_object_unref(stab);
    gst_object_unref(src);
    std::printf("base=%ld\npeak=%ld\nheap_base=%ld\nheap_peak=%ld\nframe_bytes=%zu\nreceived=%ld\n", base, peakRssKiB(),
                heap_base, at_peak.heap, gst_frames.frameBytes(), run.received());
    at_peak.print();
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
    const int budget = delay + kBudgetExtraFrames;
    frag.text(format(
        "Memory: each measurement is a process of its own; input frames are fresh buffers (a copy of one of %d frames "
        "made in memory beforehand), I420, default config (delay %d). Base = RSS after the frames were made, "
        "before the first push; peak = VmHWM (reset at the base); the difference is what the stabilizer holds "
        "(held input frames, output frames in flight, pyramids, and what the allocator keeps), also in frames of "
        "the resolution. The peak of malloc'ed bytes in use (mallinfo2, sampled after every push and every drained "
        "frame) separates what is really held from what glibc keeps mapped; budget = delay + %d = %d frames, "
        "library and element alike (the element's heap includes appsrc's queue of up to 3 frames, which the verdict leaves out: they are the harness's). Library: "
        "`Stabilizer::pushHeld`, then each frame the delay lets go of is finalized (takes an output frame) once at "
        "most %zu finalized frames (the warp threads less one) are not yet popped, as the element's chain does; the end of the stream is "
        "drained one frame at a time the same way. Element: `appsrc ! uavstabilize ! fakesink "
        "enable-last-sample=false` (the sink keeps no frame of its own), appsrc queueing at most 3 frames.",
        kDistinct, delay, kBudgetExtraFrames, budget, libraryMaxFinalized()));
    Table t({"resolution", "what", "frames", "frame MiB", "base RSS MiB", "peak RSS MiB", "peak - base MiB", "= frames",
             "peak heap in use - base MiB", "= frames", "heap within budget"});
    Table b({"resolution", "what", "peak heap = frames", "held by the delay", "inputs in flight", "outputs",
             "appsrc queue", "the rest (pyramids, scratch, allocator)", "the rest MiB"});
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
            const std::string what = mode == "lib" ? "library" : "element";
            const double fb = double(v.at("frame_bytes")) / (1024.0 * 1024.0);
            const double held = mib(v.at("peak") - v.at("base"));
            const double in_frames = held / fb;
            const double heap = mib(v.at("heap_peak") - v.at("heap_base")), heap_frames = heap / fb;
            // What each frame's worth is, counted at the moment of the peak.
            const long held_inputs = v.at("at_peak_held_inputs"), inflight = v.at("at_peak_inflight_inputs"),
                       outputs = v.at("at_peak_outputs"), queued = v.at("at_peak_queued_inputs");
            const double rest_frames = heap_frames - double(held_inputs + inflight + outputs + queued);
            t.row({r.name(), what, std::to_string(frames), format("%.2f", fb), format("%.0f", mib(v.at("base"))),
                   format("%.0f", mib(v.at("peak"))), format("%.0f", held), format("%.1f", in_frames),
                   format("%.0f", heap), format("%.1f", heap_frames),
                   withinBudget(heap_frames - (mode == "lib" ? 0.0 : double(queued)), budget, mode != "lib")});
            b.row({r.name(), what, format("%.1f", heap_frames), std::to_string(held_inputs), std::to_string(inflight),
                   std::to_string(outputs), mode == "lib" ? "-" : std::to_string(queued),
                   format("%.1f", rest_frames), format("%.1f", rest_frames * fb)});
            const std::string key = "memory." + mode + "." + r.name();
            putResult(o, key + ".heap_frames", heap_frames);
            putResult(o, key + ".heap_mib", heap);
            putResult(o, key + ".peak_mib", mib(v.at("peak")));
            putResult(o, key + ".held_frames", in_frames);
            putResult(o, key + ".budget_frames", budget);
            putResult(o, key + ".at_peak.held_inputs", held_inputs);
            putResult(o, key + ".at_peak.inflight_inputs", inflight);
            putResult(o, key + ".at_peak.outputs", outputs);
            putResult(o, key + ".at_peak.queued_inputs", queued);
            putResult(o, key + ".at_peak.rest_frames", rest_frames);
            putResult(o, key + ".at_peak.rest_mib", rest_frames * fb);
            std::printf("  memory %s %s: peak %.0f MiB, held %.0f MiB = %.1f frames; heap %.1f frames = %ld held + "
                        "%ld in flight + %ld outputs + %ld queued + %.1f rest (%.1f MiB)\n",
                        mode.c_str(), r.name().c_str(), mib(v.at("peak")), held, in_frames, heap_frames, held_inputs,
                        inflight, outputs, queued, rest_frames, rest_frames * fb);
            std::fflush(stdout);
        }
    }
    frag.table(t);
    frag.text(
        "What each frame's worth of the peak heap is, counted at the moment of the peak: held by the delay = input "
        "frames the delay holds and the one being estimated (delay + 1 at most); inputs in flight = input frames "
        "finalized whose warp is not done or that are not yet popped; outputs = output frames alive (library: "
        "warps in flight and popped frames not yet let go; element: the same, and the buffers back in its output "
        "pool, which keeps them); appsrc queue = input frames not yet taken by the element (the harness's); the rest = the "
        "peak minus those frames: the motion estimator's pyramids (two, of the analysis image at most 640 wide: "
        "about 1 MiB; on machines without AVX2 also their derivatives, 4 more), scratch, GStreamer's own and the "
        "allocator's.");
    frag.table(b);

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
