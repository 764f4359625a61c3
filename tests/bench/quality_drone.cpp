// The drone section: the real steady drone clip with a known synthetic shake added, measured
// against the truth like the synthetic clips, plus the stability score and ITF.
#include <utility>

#include <opencv2/imgproc.hpp>

#include "render/frame_warper.hpp"

#include "bench_quality.hpp"

namespace quality {

namespace {

// The steady drone clip with a known shake: shaky(q) = steady(J_i(q)), J_i = zoom * shake_i
// (zoom 0.94 reads the central 94 %, so the shake rarely reaches past the edge; where it
// does, the picture is mirrored). The shake is ShakyFlight's jitter model, scaled to 1080p.
Clip shakenDrone(const Clip &steady, std::uint32_t seed)
{
    synthetic::FlightOptions o;
    o.width = steady.width;
    o.height = steady.height;
    o.frames = int(steady.frames.size());
    o.fps = steady.fps();
    o.seed = seed;
    o.pan_speed = 0;
    o.rotation_amplitude_deg = 0;
    const double s = steady.width / 640.0;  // the model's pixels are 640-wide frames'
    o.noise_px *= s;
    o.band_px *= s;
    const synthetic::ShakyFlight flight(o);
    Clip c;
    c.name = "drone_shaken";
    c.label = format("real drone %dx%d + known shake", steady.width, steady.height);
    c.group = "drone 1080p / known shake";
    c.width = steady.width;
    c.height = steady.height;
    c.fps_num = steady.fps_num;
    c.fps_den = steady.fps_den;
    for (std::size_t i = 0; i < steady.frames.size(); ++i) {
        const Similarity shake = flight.intendedPose(int(i)).inverse() * flight.truePose(int(i));
        const Similarity j = Similarity{0, 0, 0, 0.94} * shake;
        const FrameBuffer &in = steady.frames[i];
        FrameBuffer out(PixelFormat::I420, in.width(), in.height());
        for (int p = 0; p < 3; ++p) {
            double m[6];
            FrameWarper::planeMatrix(in.view(), p, j, m);
            const cv::Mat src(in.view().planeHeight(p), in.view().planeWidth(p), CV_8UC1,
                              const_cast<std::uint8_t *>(in.row(p, 0)), std::size_t(in.view().planes[p].stride));
            cv::Mat dst(out.view().planeHeight(p), out.view().planeWidth(p), CV_8UC1, out.row(p, 0),
                        std::size_t(out.view().planes[p].stride));
            cv::warpAffine(src, dst, cv::Mat(2, 3, CV_64F, m), dst.size(), cv::INTER_CUBIC | cv::WARP_INVERSE_MAP,
                           cv::BORDER_REFLECT_101);
        }
        c.frames.push_back(std::move(out));
        c.truth.push_back(j);
        c.intended.push_back(Similarity{0, 0, 0, 0.94});
    }
    return c;
}

} // namespace

void sectionDrone(const Options &o, const std::vector<Method> &ms, std::vector<ClipResult> *truth_results)
{
    Fragment frag(o, "quality_drone");
    const std::string path = o.data_dir + "/aerial_drone_nadir_steady_1920x1080.mp4";
    Clip steady;
    if (o.data_dir.empty() || !haveCommand("ffmpeg") || !decodeClip(path, o.quick ? 60 : 1000, &steady)) {
        frag.text("Real drone clip with known shake: skipped: " + path +
                  (haveCommand("ffmpeg") ? " is not present." : " needs ffmpeg to decode."));
        return;
    }
    const Clip clip = shakenDrone(steady, 11);
    steady.frames.clear();
    frag.text(format("Real drone clip with known shake: `aerial_drone_nadir_steady_1920x1080.mp4` (%zu frames, "
                     "%.0f fps), each frame warped by a known similarity J_i = zoom 0.94 * shake_i (bicubic; the "
                     "shake is ShakyFlight's jitter model at 3x its pixel amplitudes: 1.5 px white + 9 px RMS 2-8 Hz "
                     "band, 0.05 + 0.3 deg rotation). Truth = J_i (shaky frame -> steady frame), so the residual "
                     "jitter is measured against the original steady footage; the error vs intended path takes the "
                     "steady footage as the intended path (the drone's own slow motion is in both). Also the "
                     "stability score and ITF (see the real-clip section). %s",
                     clip.frames.size(), clip.fps(), delaysText().c_str()));
    ClipResult r = evaluate(clip, ms, true);
    std::vector<ClipResult> one;
    one.push_back(std::move(r));
    frag.table(truthTable(o, "drone", one, ms, false, true));
    frag.text(boxVsGauss(one));
    frag.text("Cross-check of ours against its own FrameStats:");
    frag.table(crossCheckTable(one, ms));
    const std::string errors = errorsOf(one);
    if (!errors.empty())
        frag.text("Problems:\n\n" + errors);
    trajectoryPlot(o, one.front(), "trajectory_drone.png",
                   "without the added shake (the drone's own motion not known)");
    frag.text("![trajectory](trajectory_drone.png)\n\nCamera path of the shaken drone clip: raw (estimated) and "
              "smoothed (delay 20).");
    for (ClipResult &x : one)
        truth_results->push_back(std::move(x));
}

} // namespace quality
