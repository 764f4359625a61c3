// debug-overlay (and exclude) on the element: the same flight through the element with the
// overlay off and on gives the same frames, timestamps and corrections; the pixels differ
// only where the overlay draws (some, but a small share of the frame), in YUV, RGB and
// 16-bit gray; switching it on while PLAYING reaches the frames that follow.
#include <cstdlib>
#include <string>
#include <vector>

#include "format_conversion.hpp"
#include "shaky_flight.hpp"
#include "test_support.hpp"
#include "thermal.hpp"

using namespace element_test;

namespace {

struct Run {
    std::vector<LoggedItem> buffers;  // with references, released by ~Run
    ~Run()
    {
        for (auto &b : buffers)
            gst_buffer_unref(b.buffer);
    }
};

constexpr int kFrames = 40;

// Pushes kFrames of the synthetic flight (320x240) in `format` through uavstabilize with
// `properties`; when `switch_at` >= 0, sets debug-overlay=true before that frame.
void runFlight(const char *format, const std::string &properties, Run &run, int switch_at = -1)
{
    uavstab::synthetic::FlightOptions options;
    options.width = 320;
    options.height = 240;
    options.frames = kFrames;
    options.format = *uavstab::pixelFormatFromString(format);
    if (uavstab::is16Bit(options.format))
        options.format = uavstab::PixelFormat::I420;  // the flight renders 8-bit; renderThermal makes the 16-bit frame
    const uavstab::synthetic::ShakyFlight flight(options);
    const uavstab::PixelFormat frame_format = *uavstab::pixelFormatFromString(format);

    GstHarness *h = makeHarness(makeStabilizer("threads=2 delay=5 " + properties));
    GstCaps *caps = videoCaps(format, options.width, options.height);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad, true);
    for (int i = 0; i < kFrames; ++i) {
        if (i == switch_at)
            g_object_set(h->element, "debug-overlay", TRUE, nullptr);
        uavstab::synthetic::ThermalOptions thermal;
        thermal.format = frame_format;
        const uavstab::FrameBuffer frame = uavstab::is16Bit(frame_format)
                                               ? uavstab::synthetic::renderThermal(flight, i, thermal)
                                               : flight.render(i);
        GstBuffer *buffer = makeFrame(info, frame.view());
        stampFrame(buffer, i);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    run.buffers = log.buffers();
    for (auto &b : run.buffers)
        gst_buffer_ref(b.buffer);
    gst_harness_teardown(h);
}

// Bytes that differ between two buffers of `info` (every plane, pixels only), and all bytes.
std::pair<long, long> changedBytes(const GstVideoInfo &info, GstBuffer *a, GstBuffer *b)
{
    MappedFrame fa(info, a), fb(info, b);
    fail_unless(fa.ok() && fb.ok());
    long changed = 0, total = 0;
    for (int p = 0; p < fa.view().planeCount(); ++p)
        for (int y = 0; y < fa.view().planeHeight(p); ++y) {
            const guint8 *ra = fa.view().planes[p].data + std::size_t(y) * fa.view().planes[p].stride;
            const guint8 *rb = fb.view().planes[p].data + std::size_t(y) * fb.view().planes[p].stride;
            for (int x = 0; x < fa.view().planeRowBytes(p); ++x)
                changed += ra[x] != rb[x];
            total += fa.view().planeRowBytes(p);
        }
    return {changed, total};
}

// Frames before `clean_until` must be untouched, frames from `drawn_from` on drawn over.
void compareRuns(const char *format, const Run &off, const Run &on, int clean_until, int drawn_from)
{
    GstCaps *caps = videoCaps(format, 320, 240);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    fail_unless_equals_int(int(off.buffers.size()), kFrames);
    fail_unless_equals_int(int(on.buffers.size()), kFrames);
    int drawn = 0;
    for (int i = 0; i < kFrames; ++i) {
        const LoggedItem &a = off.buffers[std::size_t(i)], &b = on.buffers[std::size_t(i)];
        fail_unless_equals_uint64(a.pts, b.pts);
        fail_unless_equals_uint64(a.dts, b.dts);
        fail_unless_equals_uint64(a.duration, b.duration);
        fail_unless_equals_uint64(a.offset, b.offset);
        fail_unless_equals_uint64(a.size, b.size);
        const auto [changed, total] = changedBytes(info, a.buffer, b.buffer);
        // Frame 0 has no tracks yet; the rest have tens of points (7x7 squares).
        fail_unless(changed < total / 10, "%s frame %d: %ld of %ld bytes changed", format, i, changed, total);
        if (i < clean_until)
            fail_unless(changed == 0, "%s frame %d: changed before the overlay was on", format, i);
        else if (i >= drawn_from)
            fail_unless(changed > 100, "%s frame %d: only %ld bytes changed", format, i, changed);
        drawn += changed > 0;
    }
    fail_unless(drawn > 0);
}

} // namespace

GST_START_TEST(warm_up)
{
    Run run;
    runFlight("I420", "", run);
}
GST_END_TEST;

ELEMENT_TEST(the_overlay_changes_only_a_few_pixels_and_nothing_else)
{
    for (const char *format : {"I420", "NV12", "RGBx", "BGR", "GRAY8", "GRAY16_LE"}) {
        Run off, on;
        runFlight(format, "debug-overlay=false", off);
        runFlight(format, "debug-overlay=true", on);
        compareRuns(format, off, on, 0, 1);  // frame 0 has no tracks, but the frame edges may show
    }
}

ELEMENT_TEST(the_overlay_can_be_switched_on_while_playing)
{
    Run off, on;
    runFlight("I420", "", off);
    runFlight("I420", "", on, 20);
    // Set before frame 20 is pushed, it reaches the frames finalized from then on: with
    // delay=5, frame 15 and later.
    compareRuns("I420", off, on, 15, 15);
}

ELEMENT_TEST(excluded_regions_show_and_are_free_of_tracks)
{
    Run off, on;
    runFlight("RGB", "debug-overlay=true", off);
    runFlight("RGB", "debug-overlay=true exclude=\"0,0,0.5,1\"", on);
    fail_unless_equals_int(int(on.buffers.size()), kFrames);
    // No point square (green or red) in the left half, well inside the excluded rectangle.
    GstCaps *caps = videoCaps("RGB", 320, 240);
    const GstVideoInfo info = videoInfo(caps);
    gst_caps_unref(caps);
    for (int i = 10; i < kFrames; ++i) {
        MappedFrame f(info, on.buffers[std::size_t(i)].buffer);
        int marks = 0;
        for (int y = 20; y < 220; ++y)
            for (int x = 20; x < 120; ++x) {
                const guint8 *p = f.view().planes[0].data + std::size_t(y) * f.view().planes[0].stride + 3 * x;
                marks += (p[0] == 0 && p[1] == 255 && p[2] == 0) || (p[0] == 255 && p[1] == 0 && p[2] == 0);
            }
        fail_unless(marks == 0, "frame %d: %d point pixels in the excluded half", i, marks);
    }
}

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *s = suite_create("uavstabilize-overlay");
    TCase *tc = makeTestCase("overlay");
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, the_overlay_changes_only_a_few_pixels_and_nothing_else);
    tcase_add_test(tc, the_overlay_can_be_switched_on_while_playing);
    tcase_add_test(tc, excluded_regions_show_and_are_free_of_tracks);
    return runSuite(s) == 0 ? 0 : 1;
}
