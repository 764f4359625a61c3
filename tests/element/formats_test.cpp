// Every supported format is stabilized on every plane: in a still clip where one frame
// is shifted by (8, 4) px, the element moves that frame back onto its neighbours, luma
// and chroma alike. Inputs have padded strides (video meta), so planes are read with
// the strides GStreamer gives, never assumed packed.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "format_conversion.hpp"
#include "shaky_flight.hpp"
#include "test_support.hpp"
#include "uavstab/frame_buffer.hpp"

using namespace element_test;

namespace {

constexpr int kWidth = 160;
constexpr int kHeight = 120;
constexpr int kFrames = 15;
constexpr int kShiftedFrame = 7;
constexpr int kShiftX = 8;
constexpr int kShiftY = 4;
constexpr int kRowPadding = 48;  // bytes added to every row of the input planes

const char *const kFormats[] = {"I420", "YV12", "NV12", "NV21", "GRAY8", "RGB",
                                "BGR",  "RGBA", "BGRA", "RGBx", "BGRx"};

cv::Mat texture()
{
    static const cv::Mat picture = [] {
        cv::Mat image = cv::imread(uavstab::synthetic::defaultCanvasPath(), cv::IMREAD_COLOR);
        fail_unless(!image.empty(), "cannot read the test picture");
        cv::Mat small;
        cv::resize(image, small, cv::Size(kWidth * 2, kWidth * 2 * image.rows / image.cols), 0, 0, cv::INTER_AREA);
        return small;
    }();
    return picture;
}

// Frame i: a window into the picture; the shifted frame looks (8, 4) px further.
cv::Mat frameBgr(int i)
{
    const int x = 40 + (i == kShiftedFrame ? kShiftX : 0);
    const int y = 30 + (i == kShiftedFrame ? kShiftY : 0);
    return texture()(cv::Rect(x, y, kWidth, kHeight)).clone();
}

// A buffer holding `view` with padded rows, described by a video meta.
GstBuffer *paddedBuffer(const GstVideoInfo &info, const uavstab::FrameView &view)
{
    gsize offsets[GST_VIDEO_MAX_PLANES] = {};
    gint strides[GST_VIDEO_MAX_PLANES] = {};
    gsize size = 0;
    for (int p = 0; p < view.planeCount(); ++p) {
        offsets[p] = size;
        strides[p] = (view.planeRowBytes(p) + kRowPadding + 15) / 16 * 16;
        size += gsize(strides[p]) * view.planeHeight(p);
    }
    GstBuffer *buffer = gst_buffer_new_allocate(nullptr, size, nullptr);
    GstMapInfo map;
    fail_unless(gst_buffer_map(buffer, &map, GST_MAP_WRITE));
    std::memset(map.data, 0xAB, map.size);  // padding a reader must not use
    for (int p = 0; p < view.planeCount(); ++p)
        for (int y = 0; y < view.planeHeight(p); ++y)
            std::memcpy(map.data + offsets[p] + gsize(y) * strides[p], view.planes[p].data + gsize(y) * view.planes[p].stride,
                        gsize(view.planeRowBytes(p)));
    gst_buffer_unmap(buffer, &map);
    gst_buffer_add_video_meta_full(buffer, GST_VIDEO_FRAME_FLAG_NONE, GST_VIDEO_INFO_FORMAT(&info), kWidth, kHeight,
                                   guint(view.planeCount()), offsets, strides);
    return buffer;
}

// Mean absolute difference of one plane's interior (a margin off every edge).
double planeDifference(const uavstab::FrameView &a, const uavstab::FrameView &b, int plane)
{
    const uavstab::PlaneLayout layout = uavstab::planeLayout(a.format, plane);
    const int margin_x = 16 / layout.subsample_x, margin_y = 16 / layout.subsample_y;
    double sum = 0;
    long count = 0;
    for (int y = margin_y; y < a.planeHeight(plane) - margin_y; ++y) {
        const std::uint8_t *ra = a.planes[plane].data + std::size_t(y) * a.planes[plane].stride;
        const std::uint8_t *rb = b.planes[plane].data + std::size_t(y) * b.planes[plane].stride;
        for (int x = margin_x * layout.channels; x < (a.planeWidth(plane) - margin_x) * layout.channels; ++x) {
            sum += std::abs(int(ra[x]) - int(rb[x]));
            ++count;
        }
    }
    return sum / double(count);
}

void checkFormat(const char *format_name)
{
    const auto format = uavstab::pixelFormatFromString(format_name);
    fail_unless(format.has_value());
    GstCaps *caps = videoCaps(format_name, kWidth, kHeight);
    const GstVideoInfo info = videoInfo(caps);

    GstHarness *h = makeHarness(makeStabilizer(
        "threads=2 delay=10 smoothing-radius=10 model=rigid crop=0 limit-to-crop=false border=replicate"));
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad, true);

    std::vector<uavstab::FrameBuffer> inputs;
    for (int i = 0; i < kFrames; ++i) {
        inputs.emplace_back(*format, kWidth, kHeight);
        uavstab::synthetic::bgrToFrame(frameBgr(i), inputs.back());
        GstBuffer *buffer = paddedBuffer(info, inputs.back().view());
        stampFrame(buffer, i);
        fail_unless_equals_int(gst_harness_push(h, buffer), GST_FLOW_OK);
    }
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    const std::vector<LoggedItem> buffers = log.buffers();
    fail_unless_equals_int(int(buffers.size()), kFrames);

    const MappedFrame shifted(info, buffers[kShiftedFrame].buffer);
    fail_unless(shifted.ok());
    for (int neighbour : {kShiftedFrame - 1, kShiftedFrame + 1}) {
        const MappedFrame other(info, buffers[neighbour].buffer);
        fail_unless(other.ok());
        for (int p = 0; p < shifted.view().planeCount(); ++p) {
            const double before = planeDifference(inputs[kShiftedFrame].view(), inputs[neighbour].view(), p);
            const double after = planeDifference(shifted.view(), other.view(), p);
            const double kept = planeDifference(other.view(), inputs[neighbour].view(), p);
            GST_INFO("%s plane %d vs frame %d: %.2f -> %.2f (output vs input %.2f)", format_name, p, neighbour,
                     before, after, kept);
            // The shift is plain in the input (chroma of an aerial picture is faint)...
            fail_unless(before > 2.0, "%s plane %d: the test clip shows no shift (%.2f)", format_name, p, before);
            // ...gone (to interpolation noise) in the output...
            fail_unless(after < 0.2 * before,
                        "%s plane %d: shifted frame not moved back onto frame %d (difference %.2f, input %.2f)",
                        format_name, p, neighbour, after, before);
            // ...which still shows the picture (sub-pixel smoothing moves it a little).
            fail_unless(kept < 0.5 * before, "%s plane %d: output frame %d does not show its input (%.2f)",
                        format_name, p, neighbour, kept);
        }
    }
    gst_harness_teardown(h);
}

} // namespace

GST_START_TEST(warm_up)
{
    checkFormat("I420");
}
GST_END_TEST;

ELEMENT_TEST(every_format_is_corrected_on_every_plane)
{
    for (const char *format : kFormats)
        checkFormat(format);
}

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *s = suite_create("uavstabilize-formats");
    TCase *tc = makeTestCase("formats");
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, every_format_is_corrected_on_every_plane);
    return runSuite(s) == 0 ? 0 : 1;
}
