// 16-bit thermal video (GRAY16_LE, GRAY16_BE) through the element: the caps negotiate
// as they are, and a short low-contrast clip with a hot spot, where one frame is shifted
// by (8, 4) px, comes out frame for frame with its timestamps, the shift removed, and
// every sample within the input's range (nothing clipped or rescaled).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shaky_flight.hpp"
#include "test_support.hpp"
#include "thermal.hpp"
#include "uavstab/frame_buffer.hpp"

using namespace element_test;
using uavstab::synthetic::sample16;

namespace {

constexpr int kWidth = 160;
constexpr int kHeight = 120;
constexpr int kFrames = 16;
constexpr int kShiftedFrame = 7;
constexpr int kShiftX = 8;
constexpr int kShiftY = 4;

const char *const kFormats[] = {"GRAY16_LE", "GRAY16_BE"};

// The aerial picture's luma, unrounded (0..255).
cv::Mat greyPicture()
{
    static const cv::Mat picture = [] {
        cv::Mat image = cv::imread(uavstab::synthetic::defaultCanvasPath(), cv::IMREAD_COLOR);
        fail_unless(!image.empty(), "cannot read the test picture");
        cv::Mat small, grey;
        cv::resize(image, small, cv::Size(kWidth * 2, kWidth * 2 * image.rows / image.cols), 0, 0, cv::INTER_AREA);
        small.convertTo(grey, CV_32FC3);
        cv::transform(grey, grey, cv::Matx13f(0.114f, 0.587f, 0.299f));
        return grey;
    }();
    return picture;
}

// Frame i of a still thermal clip (400 counts over 30000, noise, a hot spot crossing);
// the shifted frame looks (8, 4) px further.
uavstab::FrameBuffer thermalFrame(uavstab::PixelFormat format, int i)
{
    const bool shifted = i == kShiftedFrame;
    const int x = 40 + (shifted ? kShiftX : 0), y = 30 + (shifted ? kShiftY : 0);
    uavstab::synthetic::ThermalOptions options;
    options.format = format;
    options.hot_spots.push_back({{-50, -20}, {2, 1}, 6.0});
    const uavstab::Similarity world_from_frame{shifted ? double(kShiftX) : 0.0, shifted ? double(kShiftY) : 0.0, 0.0, 1.0};
    return uavstab::synthetic::thermalFrame(greyPicture()(cv::Rect(x, y, kWidth, kHeight)).clone(), world_from_frame, i,
                                            options);
}

// Mean absolute difference, in counts, of two 16-bit frames' interiors (16 px off every
// edge), on the background (the hot spot moves on its own).
double difference(const uavstab::FrameView &a, const uavstab::FrameView &b)
{
    double sum = 0;
    long count = 0;
    for (int y = 16; y < a.height - 16; ++y)
        for (int x = 16; x < a.width - 16; ++x) {
            const int va = sample16(a, x, y), vb = sample16(b, x, y);
            if (va > 31000 || vb > 31000)
                continue;
            sum += std::abs(va - vb);
            ++count;
        }
    fail_unless(count > 0);
    return sum / double(count);
}

void checkFormat(const char *format_name)
{
    const auto format = uavstab::pixelFormatFromString(format_name);
    fail_unless(format.has_value());
    GstCaps *caps = videoCaps(format_name, kWidth, kHeight);
    const GstVideoInfo info = videoInfo(caps);

    GstHarness *h = makeHarness(makeStabilizer(
        "threads=2 delay=5 smoothing-radius=5 model=rigid crop=0 limit-to-crop=false border=replicate"));
    StreamLog log(h->sinkpad, true);  // before the caps, to see them go through
    gst_harness_set_src_caps(h, gst_caps_ref(caps));
    gst_harness_set_drop_buffers(h, TRUE);

    std::vector<uavstab::FrameBuffer> inputs;
    for (int i = 0; i < kFrames; ++i) {
        inputs.push_back(thermalFrame(*format, i));
        GstBuffer *buffer = makeFrame(info, inputs.back().view());
        stampFrame(buffer, i);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());

    // The caps went through as they came.
    const std::vector<GstCaps *> out_caps = log.caps();
    fail_unless(!out_caps.empty());
    for (GstCaps *c : out_caps)
        fail_unless(gst_caps_is_equal(c, caps), "%s: caps changed", format_name);

    // Every frame, in order, with its timestamps.
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), kFrames);
    for (int i = 0; i < kFrames; ++i) {
        GstBuffer *expected = gst_buffer_new();
        stampFrame(expected, i);
        fail_unless_equals_uint64(buffers[i].pts, GST_BUFFER_PTS(expected));
        fail_unless_equals_uint64(buffers[i].dts, GST_BUFFER_DTS(expected));
        fail_unless_equals_uint64(buffers[i].duration, GST_BUFFER_DURATION(expected));
        fail_unless_equals_uint64(buffers[i].offset, GST_BUFFER_OFFSET(expected));
        fail_unless_equals_uint64(buffers[i].offset_end, GST_BUFFER_OFFSET_END(expected));
        gst_buffer_unref(expected);
        fail_unless_equals_int(int(buffers[i].size), int(GST_VIDEO_INFO_SIZE(&info)));

        // Nothing clipped or rescaled: the output's samples lie within the input's range.
        const MappedFrame out(info, buffers[i].buffer);
        fail_unless(out.ok());
        const auto in_range = uavstab::synthetic::sampleRange(inputs[i].view());
        const auto out_range = uavstab::synthetic::sampleRange(out.view());
        fail_unless(out_range.first >= in_range.first && out_range.second <= in_range.second,
                    "%s frame %d: output %u..%u outside the input's %u..%u", format_name, i, out_range.first,
                    out_range.second, in_range.first, in_range.second);
    }

    // The shifted frame is moved back onto its neighbours.
    const MappedFrame shifted(info, buffers[kShiftedFrame].buffer);
    for (int neighbour : {kShiftedFrame - 1, kShiftedFrame + 1}) {
        const MappedFrame other(info, buffers[neighbour].buffer);
        const double before = difference(inputs[kShiftedFrame].view(), inputs[neighbour].view());
        const double after = difference(shifted.view(), other.view());
        std::fprintf(stderr, "%s, shifted frame vs frame %d: %.2f -> %.2f counts\n", format_name, neighbour, before, after);
        fail_unless(before > 10.0, "%s: the test clip shows no shift (%.2f)", format_name, before);
        fail_unless(after < 0.2 * before, "%s: shifted frame not moved back onto frame %d (%.2f counts, input %.2f)",
                    format_name, neighbour, after, before);
    }
    gst_caps_unref(caps);
    gst_harness_teardown(h);
}

} // namespace

GST_START_TEST(warm_up)
{
    checkFormat("GRAY16_LE");
}
GST_END_TEST;

ELEMENT_TEST(pad_templates_offer_both_byte_orders)
{
    GstElement *element = makeStabilizer();
    for (const char *pad_name : {"sink", "src"}) {
        GstPad *pad = gst_element_get_static_pad(element, pad_name);
        GstCaps *templ = gst_pad_get_pad_template_caps(pad);
        for (const char *format : kFormats) {
            GstCaps *caps = videoCaps(format, 640, 512);
            fail_unless(gst_caps_can_intersect(templ, caps), "%s pad refuses %s", pad_name, format);
            gst_caps_unref(caps);
        }
        gst_caps_unref(templ);
        gst_object_unref(pad);
    }
    gst_object_unref(element);
}

ELEMENT_TEST(a_16_bit_clip_is_stabilized_frame_for_frame)
{
    for (const char *format : kFormats)
        checkFormat(format);
}

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *s = suite_create("uavstabilize-thermal");
    TCase *tc = makeTestCase("thermal");
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, pad_templates_offer_both_byte_orders);
    tcase_add_test(tc, a_16_bit_clip_is_stabilized_frame_for_frame);
    return runSuite(s) == 0 ? 0 : 1;
}
