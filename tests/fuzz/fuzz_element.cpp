// libFuzzer target over the uavstabilize element: the input decodes into the
// element's settings and a sequence of operations on it, driven through the chaos rig
// (tests/element/chaos_rig.hpp: our own source and sink pads around the element, and a
// log of what went in and out):
//
//   caps (format, width, height, framerate), buffers (size and layout relative to the
//   caps: exact, larger, short, empty, several memories, a padded video meta, a short
//   one with a meta; contents; PTS/DTS/duration, missing or backwards; flags), events
//   (GAP, TAG, custom, SEGMENT, EOS and a new stream after it, flushes, seeks), DRAIN,
//   property changes, downstream returning ERROR / NOT_LINKED / FLUSHING, state changes
//   (PAUSED, READY, NULL and back).
//
// After the sequence the element must take a flush and a clean stream and put all of it
// out; then chaos::Rig::check() must find the contract kept (no frame lost, duplicated,
// reordered or stale, timestamps and caps kept, every refusal explained, only the
// documented messages), and the leaks tracer must find nothing left. Any GLib warning or
// critical aborts. Everything runs on the fuzzer's thread (the element has its own).
//
//   CC=clang CXX=clang++ meson setup build-fuzz -Dfuzz=true -Db_sanitize=address,undefined \
//       -Db_lundef=false -Dtests=disabled
//   ninja -C build-fuzz tests/fuzz/fuzz_element
//   build-fuzz/tests/fuzz/fuzz_element -max_total_time=60 -timeout=30 CORPUS tests/fuzz/element_corpus
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <gst/gst.h>
#include <unistd.h>

#include "chaos_rig.hpp"

extern "C" void gst_plugin_uavstabilize_register(void);

using chaos::Downstream;
using chaos::FrameSpec;
using chaos::Layout;
using chaos::Rig;
using chaos::RigOptions;
using chaos::Shape;

namespace {

class Bytes {
public:
    Bytes(const std::uint8_t *data, std::size_t size) : data_(data), size_(size) {}
    bool empty() const { return pos_ >= size_; }
    std::uint8_t next() { return pos_ < size_ ? data_[pos_++] : 0; }
    int range(int lo, int hi) { return lo + int(next() % unsigned(hi - lo + 1)); }
    int wide(int lo, int hi) { return lo + int((unsigned(next()) << 8 | next()) % unsigned(hi - lo + 1)); }
    bool bit() { return next() & 1; }

private:
    const std::uint8_t *data_;
    std::size_t size_;
    std::size_t pos_ = 0;
};

const char *const kFormats[] = {"I420", "YV12", "NV12", "NV21", "GRAY8",     "RGB",      "BGR",
                                "RGBA", "BGRA", "RGBx", "BGRx", "GRAY16_LE", "GRAY16_BE"};
constexpr int kFormatCount = int(sizeof kFormats / sizeof kFormats[0]);

Shape shapeFrom(Bytes &b)
{
    const int fps[] = {30, 25, 60, 15, 0};
    return Shape{kFormats[b.range(0, kFormatCount - 1)], b.range(16, 96), b.range(16, 72), fps[b.range(0, 4)], 1};
}

struct Clock {
    GstClockTime next = 0, last = 0;
};

FrameSpec frameFrom(Bytes &b, Clock &c)
{
    FrameSpec f;
    const Layout layouts[] = {Layout::Exact,      Layout::Exact, Layout::Exact, Layout::Larger,   Layout::MultiMemory,
                              Layout::PaddedMeta, Layout::Short, Layout::Empty, Layout::ShortMeta};
    f.layout = layouts[b.range(0, 8)];
    f.extra = b.wide(1, 5000);
    f.pad = b.range(0, 64);
    const GstClockTime d = GST_SECOND / 30;
    switch (b.range(0, 7)) {
    case 0:
        f.pts = GST_CLOCK_TIME_NONE;
        break;
    case 1:
        f.pts = c.next > 2 * d ? c.next - 2 * d : 0;  // backwards
        break;
    case 2:
        f.pts = c.last;  // repeated
        break;
    case 3:
        c.next += GST_SECOND * 3600;
        f.pts = c.next;
        break;
    default:
        f.pts = c.next;
        break;
    }
    if (GST_CLOCK_TIME_IS_VALID(f.pts))
        c.last = f.pts;
    c.next += d;
    f.dts = b.bit() ? f.pts : GST_CLOCK_TIME_NONE;
    f.duration = b.bit() ? d : GST_CLOCK_TIME_NONE;
    f.flags = guint(b.next()) << 6;  // DISCONT (bit 6) and up
    f.shift_x = b.range(-8, 8);
    f.shift_y = b.range(-8, 8);
    f.seed = b.next();
    return f;
}

void setProperty(Bytes &b, Rig &rig)
{
    const char *planners[] = {"optimal", "gaussian", "box"};
    const char *models[] = {"hybrid", "rigid", "similarity"};
    // Valid exclude strings only: a refused one is a g_warning (the library's parser has
    // its own tests for bad strings).
    const char *excludes[] = {"", "0,0,1,0.1", "0.4,0.4,0.2,0.2;0,0.9,1,0.1", "0,0,0.5,1"};
    const int v = b.next();
    switch (b.range(0, 14)) {
    case 0:
        rig.setProperty("delay", std::to_string(v % 10));
        break;
    case 1:
        rig.setProperty("planner", planners[v % 3]);
        break;
    case 2:
        rig.setProperty("planner-smoothness", std::to_string(1.0 + v * 4000.0));
        break;
    case 3:
        rig.setProperty("adaptive-zoom", v & 1 ? "true" : "false");
        break;
    case 4:
        rig.setProperty("crop", std::to_string((v % 50) / 100.0));
        break;
    case 5:
        rig.setProperty("bypass", v & 1 ? "true" : "false");
        break;
    case 6:
        rig.setProperty("max-errors", std::to_string(v % 6 - 1));
        break;
    case 7:
        rig.setProperty("smoothing-radius", std::to_string(v % 16));
        break;
    case 8:
        rig.setProperty("model", models[v % 3]);
        break;
    case 9:
        rig.setProperty("analysis-width", std::to_string(16 + v));
        break;
    case 10:
        rig.setProperty("border", v & 1 ? "black" : "replicate");
        break;
    case 11:
        rig.setProperty("exclude", excludes[v % 4]);
        break;
    case 12:
        rig.setProperty("exclude-static", v & 1 ? "true" : "false");
        break;
    case 13:
        rig.setProperty("debug-overlay", v & 1 ? "true" : "false");
        break;
    default:
        rig.setProperty("post-messages", v & 1 ? "true" : "false");
        break;
    }
}

// Leaks: every object created during the input is gone after it (with a little time for
// threads that are just finishing to drop their last reference).
GstTracer *leaksTracer()
{
    static GstTracer *tracer = [] {
        GstTracer *found = nullptr;
        GList *tracers = gst_tracing_get_active_tracers();
        for (GList *l = tracers; l; l = l->next)
            if (!found && g_strcmp0(G_OBJECT_TYPE_NAME(l->data), "GstLeaksTracer") == 0)
                found = GST_TRACER(gst_object_ref(l->data));
        g_list_free_full(tracers, gst_object_unref);
        return found;
    }();
    return tracer;
}

void countEntries(const GstStructure *checkpoint, const char *field, int sign, std::map<std::string, int> &alive)
{
    const GValue *list = gst_structure_get_value(checkpoint, field);
    for (guint i = 0; list && i < gst_value_list_get_size(list); ++i) {
        const GstStructure *entry = gst_value_get_structure(gst_value_list_get_value(list, i));
        alive[std::string(gst_structure_get_string(entry, "type-name")) + " " +
              gst_structure_get_string(entry, "address")] += sign;
    }
}

// Objects meant to live on (class data, caches) say so with a flag.
bool mayBeLeaked(const std::string &key)
{
    const auto space = key.find(' ');
    void *pointer = nullptr;
    if (std::sscanf(key.c_str() + space + 1, "%p", &pointer) != 1 || !pointer)
        return false;
    const GType type = g_type_from_name(key.substr(0, space).c_str());
    if (type == 0 || (g_type_is_a(type, G_TYPE_OBJECT) && !g_type_is_a(type, GST_TYPE_OBJECT)))
        return false;
    if (g_type_is_a(type, GST_TYPE_OBJECT))
        return GST_OBJECT_FLAG_IS_SET(pointer, GST_OBJECT_FLAG_MAY_BE_LEAKED);
    return GST_MINI_OBJECT_FLAG_IS_SET(pointer, GST_MINI_OBJECT_FLAG_MAY_BE_LEAKED);
}

std::string leftAlive()
{
    GstTracer *tracer = leaksTracer();
    if (!tracer)
        return {};
    std::map<std::string, int> alive;
    std::string leaks;
    for (int attempt = 0; attempt < 100; ++attempt) {
        GstStructure *checkpoint = nullptr;
        g_signal_emit_by_name(tracer, "activity-get-checkpoint", &checkpoint);
        if (checkpoint) {
            countEntries(checkpoint, "objects-created-list", +1, alive);
            countEntries(checkpoint, "objects-removed-list", -1, alive);
            gst_structure_free(checkpoint);
        }
        leaks.clear();
        for (const auto &[key, count] : alive)
            if (count > 0 && !mayBeLeaked(key))
                leaks += key + " ";
        if (leaks.empty())
            break;
        g_usleep(10 * 1000);
    }
    return leaks;
}

[[noreturn]] void fail(const std::string &what, const Rig *rig)
{
    std::fprintf(stderr, "\nfuzz_element: contract broken:\n%s", what.c_str());
    if (rig)
        std::fprintf(stderr, "last log entries:\n%s", rig->describeLog(80).c_str());
    std::fflush(stderr);
    std::abort();
}

void runOperations(Bytes &b, Rig &rig, Clock &clock)
{
    for (int ops = 0; !b.empty() && ops < 48; ++ops) {
        const int op = b.range(0, 21);
        if (op == 14 || op == 15) {  // flush or flushing seek (takes the stream lock itself)
            if (op == 14)
                rig.flush(clock.next);
            else
                rig.seek(b.bit(), GstClockTime(b.range(0, 60)) * GST_SECOND / 30);
            continue;
        }
        if (op == 16) {
            const Downstream modes[] = {Downstream::Ok, Downstream::Ok, Downstream::Error, Downstream::NotLinked,
                                        Downstream::Flushing};
            rig.setDownstream(modes[b.range(0, 4)], b.bit());
            continue;
        }
        if (op == 17) {
            const int to = b.range(0, 3);
            rig.setState(to == 0 ? GST_STATE_PAUSED : to == 1 ? GST_STATE_READY : GST_STATE_NULL);
            if (to != 3 && b.next() % 4 != 0)  // back up, or left down for a while
                rig.setState(GST_STATE_PLAYING);
            continue;
        }
        if (op == 18) {
            setProperty(b, rig);
            continue;
        }
        if (op == 19) {
            rig.queryFromDownstream();
            continue;
        }
        std::lock_guard<std::mutex> stream(rig.streamLock());
        rig.ensureStreaming();
        switch (op) {
        case 8:
            rig.pushCaps(b.bit() ? rig.shape() : shapeFrom(b));
            break;
        case 9:
            rig.pushEvent(gst_event_new_gap(clock.next, GST_SECOND / 30));
            break;
        case 10:
            rig.pushEvent(b.bit() ? gst_event_new_tag(gst_tag_list_new(GST_TAG_TITLE, "fuzz", nullptr))
                                  : gst_event_new_custom(GST_EVENT_CUSTOM_DOWNSTREAM, gst_structure_new_empty("fuzz")));
            break;
        case 11:
            rig.pushSegment(clock.next);
            break;
        case 12:
            if (rig.eosSent())
                rig.continueAfterEos();
            else
                rig.pushEos();
            break;
        case 13:
            rig.drain();
            break;
        case 20:
            if (rig.eosSent())
                rig.continueAfterEos();
            break;
        default:
            rig.pushFrame(frameFrom(b, clock));
            break;
        }
    }
}

// After the operations: whatever is held goes out on EOS, and after a flush a clean
// stream comes out whole.
void recover(Rig &rig, Clock &clock, int count)
{
    rig.setDownstream(Downstream::Ok);
    if (rig.state() != GST_STATE_PLAYING)
        rig.setState(GST_STATE_PLAYING);
    {
        std::lock_guard<std::mutex> stream(rig.streamLock());
        rig.ensureStreaming();
        const std::size_t from = rig.logSize();
        if (!rig.eosSent() && rig.pushEos() && !rig.waitForEosAfter(from, 10000))
            fail("  - EOS was taken but never came out (hang)\n", &rig);
    }
    rig.flush(0);
    std::lock_guard<std::mutex> stream(rig.streamLock());
    rig.ensureStreaming();
    const std::size_t from = rig.logSize();
    clock.next = 0;
    for (int i = 0; i < count; ++i) {
        FrameSpec f;
        f.pts = clock.next;
        f.duration = GST_SECOND / 30;
        f.shift_x = i;
        clock.next += GST_SECOND / 30;
        const GstFlowReturn ret = rig.pushFrame(f);
        if (ret != GST_FLOW_OK)
            fail(std::string("  - after the flush a frame was refused with ") + gst_flow_get_name(ret) + "\n", &rig);
    }
    if (!rig.pushEos() || !rig.waitForEosAfter(from, 10000))
        fail("  - after the flush the stream never reached EOS\n", &rig);
    if (rig.framesOutSince(from).size() != std::size_t(count))
        fail("  - after the flush " + std::to_string(count) + " frames went in and " +
                 std::to_string(rig.framesOutSince(from).size()) + " came out\n",
             &rig);
}

void runInput(const std::uint8_t *data, std::size_t size)
{
    Bytes b(data, size);
    RigOptions options;
    const char *planners[] = {"optimal", "gaussian", "box"};
    options.properties = {
        {"threads", std::to_string(b.range(1, 2))},
        {"delay", std::to_string(b.range(0, 8))},
        {"smoothing-radius", std::to_string(b.range(0, 10))},
        {"planner", planners[b.range(0, 2)]},
        {"max-errors", std::to_string(b.range(-1, 3))},
        {"bypass", b.next() % 8 == 0 ? "true" : "false"},
        {"adaptive-zoom", b.bit() ? "true" : "false"},
        {"post-messages", b.next() % 4 == 0 ? "true" : "false"},
        {"analysis-width", std::to_string(b.range(16, 160))},
    };
    const int pool = b.range(0, 3);
    options.pool_max = pool == 0 ? -1 : pool == 1 ? 0 : b.range(2, 5);
    options.video_meta = b.bit();
    options.hold_last = b.next() % 4 == 0;
    const Shape first = shapeFrom(b);
    const int final_frames = b.range(1, 10);

    Clock clock;
    Rig rig(options);
    {
        std::lock_guard<std::mutex> stream(rig.streamLock());
        rig.startStream(&first);
    }
    runOperations(b, rig, clock);
    recover(rig, clock, final_frames);
    rig.stop();
    const std::string problems = rig.check();
    if (!problems.empty())
        fail(problems, &rig);
}

void onWarning(const gchar *domain, GLogLevelFlags level, const gchar *message, gpointer)
{
    std::fprintf(stderr, "\nfuzz_element: %s %s: %s\n", domain ? domain : "", level & G_LOG_LEVEL_CRITICAL ? "CRITICAL" : "WARNING",
                 message);
    std::fflush(stderr);
    std::abort();
}

} // namespace

// LeakSanitizer: GLib's and GStreamer's one-time allocations (made at load time and kept
// in places LeakSanitizer does not scan) are reported as leaks; objects the element leaks
// are the leaks tracer's job (above), which knows them by type.
extern "C" const char *__lsan_default_suppressions()
{
    return "leak:libglib-2.0.so\nleak:libgobject-2.0.so\nleak:libgstreamer-1.0.so\n";
}

// A fresh directory with a link to the system's core-tracers plugin and nothing else.
static std::string privatePluginDir()
{
    gchar *dir = g_dir_make_tmp("uavstab-fuzz-XXXXXX", nullptr);
    if (!dir) {
        std::fprintf(stderr, "fuzz_element: no temporary directory\n");
        std::abort();
    }
    std::string path(dir);
    g_free(dir);
    const std::string plugin = std::string(UAVSTAB_GST_PLUGINS_DIR) + "/libgstcoretracers.so";
    if (symlink(plugin.c_str(), (path + "/libgstcoretracers.so").c_str()) != 0) {
        std::fprintf(stderr, "fuzz_element: cannot link %s\n", plugin.c_str());
        std::abort();
    }
    static std::string removed_at_exit;
    removed_at_exit = path;
    std::atexit([] {
        for (const char *name : {"/registry.bin", "/libgstcoretracers.so"})
            std::remove((removed_at_exit + name).c_str());
        rmdir(removed_at_exit.c_str());
    });
    return path;
}

extern "C" int LLVMFuzzerInitialize(int *, char ***)
{
    // The plugin is linked in (instrumented for coverage) and registered here; no other
    // copy is looked for, and the leaks tracer watches every object.
    g_unsetenv("GST_PLUGIN_PATH");
    g_setenv("GST_REGISTRY_FORK", "no", TRUE);
    // A registry of its own holding only the core tracers: a scan of every system plugin
    // in this process (a fresh machine has no registry cache) runs their init code, whose
    // one-time allocations (fontconfig's, from pango) LeakSanitizer would report.
    static const std::string plugin_dir = privatePluginDir();
    g_setenv("GST_PLUGIN_SYSTEM_PATH_1_0", plugin_dir.c_str(), TRUE);
    g_setenv("GST_REGISTRY_1_0", (plugin_dir + "/registry.bin").c_str(), TRUE);
    g_setenv("GST_TRACERS", "leaks", TRUE);
    if (!g_getenv("GST_DEBUG"))
        g_setenv("GST_DEBUG", "0", TRUE);
    gst_init(nullptr, nullptr);
    gst_plugin_uavstabilize_register();
    for (const char *domain : {static_cast<const char *>(nullptr), "GStreamer", "GStreamer-Video", "GLib", "GLib-GObject"})
        g_log_set_handler(domain, GLogLevelFlags(G_LOG_LEVEL_WARNING | G_LOG_LEVEL_CRITICAL), onWarning, nullptr);
    // One run to make the class data and caches that live on, then watch for leaks.
    static const std::uint8_t warm_up[] = {1, 2, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 0, 0, 0, 0, 0, 1, 2, 3};
    runInput(warm_up, sizeof warm_up);
    GstTracer *tracer = leaksTracer();
    if (!tracer) {
        std::fprintf(stderr, "fuzz_element: the leaks tracer did not load from %s\n", UAVSTAB_GST_PLUGINS_DIR);
        std::abort();
    }
    g_signal_emit_by_name(tracer, "activity-start-tracking");
    leftAlive();
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size)
{
    leftAlive();  // a fresh checkpoint
    runInput(data, size);
    const std::string leaks = leftAlive();
    if (!leaks.empty())
        fail("  - objects leaked: " + leaks + "\n", nullptr);
    return 0;
}
