// Long runs of uavstabilize in a real pipeline: frames in = frames out, and memory that
// does not grow with stream length. Not a test (too long for CI): run it by hand, e.g.
//   uavstab-soak --frames 100000 --width 320 --height 240          (as fast as it goes)
//   uavstab-soak --live --seconds 3600 --width 1280 --height 720   (one hour of live 720p30)
// Prints RSS at regular points and a verdict; exit status 1 if frames were lost.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <unistd.h>

#include <gst/gst.h>

namespace {

long rssKiB()
{
    long pages = 0, resident = 0;
    if (FILE *f = std::fopen("/proc/self/statm", "r")) {
        if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2)
            resident = 0;
        std::fclose(f);
    }
    return resident * (sysconf(_SC_PAGESIZE) / 1024);
}

GstPadProbeReturn count(GstPad *, GstPadProbeInfo *info, gpointer counter)
{
    if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER)
        static_cast<std::atomic<long> *>(counter)->fetch_add(1);
    return GST_PAD_PROBE_OK;
}

} // namespace

int main(int argc, char **argv)
{
    // The plugin of this build first, so that no GST_PLUGIN_PATH is needed.
    const char *old_path = std::getenv("GST_PLUGIN_PATH");
    std::string plugin_path = UAVSTAB_GST_PLUGIN_DIR;
    if (old_path && *old_path)
        plugin_path += std::string(":") + old_path;
    setenv("GST_PLUGIN_PATH", plugin_path.c_str(), 1);
    gst_init(&argc, &argv);
    bool live = false;
    long frames = 100000, seconds = 0;
    int width = 320, height = 240, fps = 30;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&] { return i + 1 < argc ? std::atol(argv[++i]) : 0L; };
        if (a == "--live")
            live = true;
        else if (a == "--frames")
            frames = next();
        else if (a == "--seconds")
            seconds = next();
        else if (a == "--width")
            width = int(next());
        else if (a == "--height")
            height = int(next());
        else if (a == "--fps")
            fps = int(next());
        else {
            std::fprintf(stderr, "usage: uavstab-soak [--live] [--frames N | --seconds S] [--width W] [--height H] [--fps F]\n");
            return 2;
        }
    }
    if (seconds > 0)
        frames = seconds * fps;
    const std::string description =
        std::string("videotestsrc pattern=ball is-live=") + (live ? "true" : "false") +
        " num-buffers=" + std::to_string(frames) + " ! video/x-raw,format=I420,width=" + std::to_string(width) +
        ",height=" + std::to_string(height) + ",framerate=" + std::to_string(fps) +
        "/1 ! uavstabilize name=stab ! fakesink sync=" + (live ? "true" : "false");
    GError *error = nullptr;
    GstElement *pipeline = gst_parse_launch(description.c_str(), &error);
    if (!pipeline) {
        std::fprintf(stderr, "uavstab-soak: %s\n", error->message);
        return 2;
    }
    GstElement *stab = gst_bin_get_by_name(GST_BIN(pipeline), "stab");
    std::atomic<long> in{0}, out{0};
    GstPad *sink = gst_element_get_static_pad(stab, "sink"), *src = gst_element_get_static_pad(stab, "src");
    gst_pad_add_probe(sink, GST_PAD_PROBE_TYPE_BUFFER, count, &in, nullptr);
    gst_pad_add_probe(src, GST_PAD_PROBE_TYPE_BUFFER, count, &out, nullptr);

    std::printf("# %s\n# %ld frames %dx%d%s\n", description.c_str(), frames, width, height, live ? " live" : "");
    std::printf("%10s %10s %10s %10s %12s\n", "elapsed_s", "frames_in", "frames_out", "rss_kib", "fps");
    const auto start = std::chrono::steady_clock::now();
    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    GstBus *bus = gst_element_get_bus(pipeline);
    long rss_first = 0, rss_max = 0, rss_last = 0;
    long next_report = std::max(1L, frames / 10);
    bool ok = true;
    for (bool done = false; !done;) {
        GstMessage *m = gst_bus_timed_pop_filtered(bus, 200 * GST_MSECOND,
                                                   GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
        if (m) {
            if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR) {
                GError *e = nullptr;
                gst_message_parse_error(m, &e, nullptr);
                std::fprintf(stderr, "error: %s\n", e->message);
                g_clear_error(&e);
                ok = false;
            }
            done = true;
            gst_message_unref(m);
        }
        const long n = out.load();
        if (n >= next_report || done) {
            const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            rss_last = rssKiB();
            if (rss_first == 0)
                rss_first = rss_last;
            rss_max = std::max(rss_max, rss_last);
            std::printf("%10.1f %10ld %10ld %10ld %12.1f\n", t, in.load(), n, rss_last, n / std::max(t, 1e-9));
            std::fflush(stdout);
            next_report += std::max(1L, frames / 10);
        }
    }
    gst_element_set_state(pipeline, GST_STATE_NULL);
    const bool all = in.load() == frames && out.load() == frames;
    std::printf("frames in %ld, out %ld, expected %ld: %s\n", in.load(), out.load(), frames, all ? "none lost" : "LOST FRAMES");
    std::printf("RSS first report %ld KiB, last %ld KiB, max %ld KiB (growth %+ld KiB)\n", rss_first, rss_last, rss_max,
                rss_last - rss_first);
    gst_object_unref(bus);
    gst_object_unref(sink);
    gst_object_unref(src);
    gst_object_unref(stab);
    gst_object_unref(pipeline);
    return ok && all ? 0 : 1;
}
