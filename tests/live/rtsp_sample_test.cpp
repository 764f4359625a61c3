// The live path for real: a local RTSP server (gst-rtsp-server) streams the synthetic
// shaky flight as H.264 on 127.0.0.1; samples/rtsp_record.sh records it through
// uavstabilize for a few seconds and is stopped with Ctrl-C (SIGINT -> EOS). The file
// must be playable, hold every frame the element saw, with no timestamp gaps.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <gst/rtsp-server/rtsp-server.h>

#ifndef SOURCE_DIR
#error "SOURCE_DIR must name the project's source directory"
#endif

namespace {

constexpr int kFps = 30;

struct RtspServer {
    GMainContext *context = g_main_context_new();
    GMainLoop *loop = g_main_loop_new(context, FALSE);
    GstRTSPServer *server = gst_rtsp_server_new();
    GThread *thread = nullptr;
    std::string url;

    explicit RtspServer(const std::string &y4m)
    {
        gst_rtsp_server_set_address(server, "127.0.0.1");
        gst_rtsp_server_set_service(server, "0");  // any free port
        GstRTSPMediaFactory *factory = gst_rtsp_media_factory_new();
        const std::string launch = "( filesrc location=" + y4m +
                                   " ! y4mdec ! videoconvert ! x264enc tune=zerolatency speed-preset=ultrafast "
                                   "key-int-max=30 ! rtph264pay name=pay0 pt=96 config-interval=1 )";
        gst_rtsp_media_factory_set_launch(factory, launch.c_str());
        gst_rtsp_media_factory_set_shared(factory, TRUE);
        GstRTSPMountPoints *mounts = gst_rtsp_server_get_mount_points(server);
        gst_rtsp_mount_points_add_factory(mounts, "/flight", factory);
        g_object_unref(mounts);
        gst_rtsp_server_attach(server, context);
        url = "rtsp://127.0.0.1:" + std::to_string(gst_rtsp_server_get_bound_port(server)) + "/flight";
        thread = g_thread_new("rtsp-server", [](gpointer self) -> gpointer {
            g_main_loop_run(static_cast<RtspServer *>(self)->loop);
            return nullptr;
        }, this);
    }
    ~RtspServer()
    {
        g_main_loop_quit(loop);
        g_thread_join(thread);
        g_object_unref(server);
        g_main_loop_unref(loop);
        g_main_context_unref(context);
    }
};

struct FileCheck {
    int frames = 0;
    int gaps = 0;
    GstClockTime first = GST_CLOCK_TIME_NONE, last = GST_CLOCK_TIME_NONE;
    bool decoded = false;
};

// Decodes the whole file and looks at every frame's timestamp.
FileCheck checkFile(const std::string &path)
{
    FileCheck check;
    GError *error = nullptr;
    const std::string desc = "filesrc location=" + path + " ! qtdemux ! h264parse ! avdec_h264 ! appsink name=sink sync=false";
    GstElement *pipeline = gst_parse_launch(desc.c_str(), &error);
    // A missing element (avdec_h264 without gstreamer1.0-libav) still gives a pipeline,
    // with the error set, that would never reach EOS: fail at once instead of hanging.
    if (!pipeline || error) {
        ADD_FAILURE() << "cannot check the recording: " << (error ? error->message : "no pipeline");
        g_clear_error(&error);
        if (pipeline)
            gst_object_unref(pipeline);
        return check;
    }
    GstElement *sink = gst_bin_get_by_name(GST_BIN(pipeline), "sink");
    gst_element_set_state(pipeline, GST_STATE_PLAYING);
    const GstClockTime frame = GST_SECOND / kFps;
    while (GstSample *sample = gst_app_sink_pull_sample(GST_APP_SINK(sink))) {
        const GstClockTime pts = GST_BUFFER_PTS(gst_sample_get_buffer(sample));
        if (GST_CLOCK_TIME_IS_VALID(check.last) && pts > check.last + frame * 3 / 2)
            ++check.gaps;
        if (!GST_CLOCK_TIME_IS_VALID(check.first))
            check.first = pts;
        check.last = pts;
        ++check.frames;
        gst_sample_unref(sample);
    }
    GstMessage *msg = gst_bus_timed_pop_filtered(GST_ELEMENT_BUS(pipeline), 5 * GST_SECOND,
                                                 GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
    check.decoded = msg && GST_MESSAGE_TYPE(msg) == GST_MESSAGE_EOS;
    if (msg)
        gst_message_unref(msg);
    gst_element_set_state(pipeline, GST_STATE_NULL);
    gst_object_unref(sink);
    gst_object_unref(pipeline);
    return check;
}

} // namespace

TEST(RtspSample, RecordsAStabilizedPlayableFileWithEveryFrame)
{
    const std::string dir = g_get_tmp_dir() + std::string("/uavstab-rtsp-") + std::to_string(getpid());
    g_mkdir_with_parents(dir.c_str(), 0700);
    const std::string y4m = dir + "/flight.y4m", out = dir + "/recorded.mp4";
    // 20 s of material, far more than the recording needs, so the stream never ends first.
    const std::string render = std::string(RENDER_FLIGHT) + " " + y4m + " --width 640 --height 360 --frames 600";
    ASSERT_EQ(std::system(render.c_str()), 0);

    RtspServer server(y4m);
    const std::string script = std::string(SOURCE_DIR) + "/samples/rtsp_record.sh";
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        execl("/bin/bash", "bash", script.c_str(), server.url.c_str(), out.c_str(), "10", static_cast<char *>(nullptr));
        _exit(127);
    }
    g_usleep(6 * G_USEC_PER_SEC);  // ~4 s of video after connecting and negotiating
    kill(child, SIGINT);           // what Ctrl-C does: gst-launch -e sends EOS
    int status = 0;
    for (int i = 0; i < 200 && waitpid(child, &status, WNOHANG) == 0; ++i)
        g_usleep(100000);
    if (waitpid(child, &status, WNOHANG) == 0) {
        kill(child, SIGKILL);
        waitpid(child, &status, 0);
        FAIL() << "the recording did not stop within 20 s of SIGINT";
    }
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "rtsp_record.sh failed, status " << status;

    const FileCheck check = checkFile(out);
    EXPECT_TRUE(check.decoded) << "the recorded file does not play to its end";
    EXPECT_GE(check.frames, 2 * kFps) << "too few frames recorded";
    EXPECT_LE(check.frames, 8 * kFps);
    EXPECT_EQ(check.gaps, 0) << "timestamp gaps in the recording";
    // Every frame between the first and the last timestamp is there.
    const double span_frames = double(check.last - check.first) * kFps / GST_SECOND + 1;
    EXPECT_NEAR(double(check.frames), span_frames, 1.0);
    std::printf("recorded %d frames over %.2f s from %s\n", check.frames, span_frames / kFps, server.url.c_str());
    std::remove(y4m.c_str());
    std::remove(out.c_str());
    rmdir(dir.c_str());
}

int main(int argc, char **argv)
{
    gst_init(&argc, &argv);
    ::testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}
