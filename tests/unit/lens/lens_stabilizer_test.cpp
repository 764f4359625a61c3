// The Stabilizer with a lens profile (StabilizerConfig::lens_profile): what it does with the
// file, and a flight seen through a lens.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "buffer_slot.hpp"
#include "lens/lens_view.hpp"
#include "path/framing.hpp"
#include "lens_profile_file.hpp"
#include "shaky_flight.hpp"
#include "uavstab/lens.hpp"
#include "uavstab/pixel_format.hpp"
#include "uavstab/stabilizer.hpp"

using namespace uavstab;
using test::BufferSlot;

namespace {

const std::string kDataDir = std::string(UAVSTAB_TEST_DATA_DIR) + "/lens/";
const std::string kFisheye720 = kDataDir + "gyroflow_old_layout_fisheye_1280x720.json";

// A copy of the 720p fisheye profile with `from` replaced by `to`, in a temporary file.
std::string editedProfile(const std::string &name, const std::string &from, const std::string &to)
{
    std::ifstream in(kFisheye720);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos)
        text.replace(at, from.size(), to);
    const std::string path = testing::TempDir() + name;
    std::ofstream(path) << text;
    return path;
}

StabilizerConfig withProfile(const std::string &path)
{
    StabilizerConfig c;
    c.lens_profile = path;
    c.threads = 1;
    c.delay = 2;
    return c;
}

} // namespace

TEST(LensStabilizer, AMissingOrBrokenProfileIsRefusedWhenBuiltNamingTheFileAndField)
{
    const std::string missing = testing::TempDir() + "no_such_profile.json";
    try {
        Stabilizer s(withProfile(missing));
        FAIL() << "built with a missing profile";
    } catch (const LensProfileError &e) {
        EXPECT_EQ(e.file(), missing);
        EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    }
    const std::string bad = editedProfile("negative_focal.json", "571.5", "-571.5");
    try {
        Stabilizer s(withProfile(bad));
        FAIL() << "built with a negative focal length";
    } catch (const LensProfileError &e) {
        EXPECT_EQ(e.file(), bad);
        EXPECT_NE(std::string(e.what()).find("camera matrix fx"), std::string::npos) << e.what();
    }
}

TEST(LensStabilizer, FramesOfAnotherAspectRatioAreRefusedBeforeTheyAreQueued)
{
    Stabilizer s(withProfile(kFisheye720));
    EXPECT_NO_THROW(s.checkFrameSize(1280, 720));
    EXPECT_NO_THROW(s.checkFrameSize(640, 360));  // the same lens, scaled
    try {
        s.checkFrameSize(640, 480);
        FAIL() << "4:3 frames accepted by a 16:9 profile";
    } catch (const std::invalid_argument &e) {
        const std::string what = e.what();
        EXPECT_NE(what.find(kFisheye720), std::string::npos) << what;
        EXPECT_NE(what.find("calib_dimension"), std::string::npos) << what;
    }
    EXPECT_THROW(s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 640, 480, 1), 0)), std::invalid_argument);
    EXPECT_EQ(s.heldCount(), 0u);
    // Frames of the profile's aspect ratio go through, every one of them back.
    for (int i = 0; i < 4; ++i)
        s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 320, 180, unsigned(i)), i));
    s.flush();
    int back = 0;
    while (auto f = s.waitPop()) {
        EXPECT_EQ(BufferSlot::of(*f).id(), back);
        ++back;
    }
    EXPECT_EQ(back, 4);
}

TEST(LensStabilizer, TheProfilesSensorSettingsAreUsedUnlessTheConfigSetsThem)
{
    const std::string rolling = editedProfile("readout.json", "\"frame_readout_time\": 0.0", "\"frame_readout_time\": 21.5");
    EXPECT_DOUBLE_EQ(Stabilizer(withProfile(rolling)).config().readout_time, 21.5);
    StabilizerConfig set = withProfile(rolling);
    set.readout_time = 10.0;
    EXPECT_DOUBLE_EQ(Stabilizer(set).config().readout_time, 10.0);
    // A readout from the bottom up is not one the correction knows: left to auto.
    const std::string upward = editedProfile("upward.json", "\"frame_readout_time\": 0.0", "\"frame_readout_time\": -21.5");
    EXPECT_DOUBLE_EQ(Stabilizer(withProfile(upward)).config().readout_time, 0.0);

    const std::string global = editedProfile("global.json", "\"official\": false", "\"official\": false, \"global_shutter\": true");
    EXPECT_EQ(Stabilizer(withProfile(global)).config().rolling_shutter, RollingShutter::Off);
    EXPECT_EQ(Stabilizer(withProfile(kFisheye720)).config().rolling_shutter, RollingShutter::Auto);
    // A later config keeps the profile's settings and the lens it was built with.
    Stabilizer s(withProfile(global));
    StabilizerConfig later = s.config();
    later.lens_profile = "";
    later.rolling_shutter = RollingShutter::Auto;
    s.setConfig(later);
    s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 320, 180, 1), 0));
    EXPECT_EQ(s.config().rolling_shutter, RollingShutter::Off);
    EXPECT_EQ(s.config().lens_profile, global);
}

namespace {

// Bilinear sample of one 8-bit plane at (x, y) (pixel centres at integers); false outside.
bool sample(const FrameView &view, int plane, double x, double y, double &value)
{
    const int w = view.planeWidth(plane), h = view.planeHeight(plane);
    if (!(x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0))
        return false;
    const int x0 = std::min(int(x), w - 2), y0 = std::min(int(y), h - 2);
    const double fx = x - x0, fy = y - y0;
    const std::uint8_t *r0 = view.planes[plane].data + std::size_t(y0) * std::size_t(view.planes[plane].stride);
    const std::uint8_t *r1 = r0 + view.planes[plane].stride;
    value = (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
    return true;
}

// Every plane of each output frame against the chain (lens_view.hpp) sampled per pixel:
// the share of pixels within 2 levels, worst plane and frame.
double worstAgreement(LensOutput output, int width, int height)
{
    synthetic::FlightOptions options;
    options.width = width;
    options.height = height;
    options.frames = 12;
    options.lens = synthetic::fisheyeLens(options.width, options.height);
    const synthetic::ShakyFlight flight(options);
    StabilizerConfig config = withProfile(
        synthetic::writeLensProfile(flight.options().lens, testing::TempDir() + "fisheye_320.json"));
    config.lens_output = output;
    Stabilizer s(config);
    const LensView view(flight.options().lens, output, options.width, options.height);
    for (int i = 0; i < flight.frameCount(); ++i)
        s.push(BufferSlot::make(flight.render(i), i));
    s.flush();
    double worst = 1.0;
    int frames = 0;
    while (auto f = s.waitPop()) {
        ++frames;
        EXPECT_EQ(f->outcome, Outcome::Warped);
        const FrameView in = BufferSlot::of(*f).inputBuffer().view();
        const FrameView out = BufferSlot::of(*f).outputBuffer().view();
        const std::array<double, 6> m = f->stats.output_to_input.pixelMatrix(in.width, in.height);
        for (int p = 0; p < in.planeCount(); ++p) {
            const PlaneLayout layout = planeLayout(in.format, p);
            const double sx = layout.subsample_x, sy = layout.subsample_y;
            const double ox = (sx - 1) * 0.5, oy = (sy - 1) * 0.5;
            int close = 0, counted = 0;
            for (int y = 0; y < in.planeHeight(p); ++y)
                for (int x = 0; x < in.planeWidth(p); ++x) {
                    const Point2 luma{sx * x + ox, sy * y + oy};
                    const Point2 src = view.viewToInput(view.outputToView(luma, f->stats.zoom), m);
                    double ref;
                    if (!sample(in, p, (src.x - ox) / sx, (src.y - oy) / sy, ref))
                        continue;
                    const double got = out.planes[p].data[std::size_t(y) * std::size_t(out.planes[p].stride) + x];
                    close += std::abs(got - ref) <= 2.0;
                    ++counted;
                }
            EXPECT_GT(counted, in.planeWidth(p) * in.planeHeight(p) * 9 / 10) << "plane " << p;
            worst = std::min(worst, double(close) / std::max(1, counted));
        }
    }
    EXPECT_EQ(frames, flight.frameCount());
    return worst;
}

} // namespace

// The picture each plane shows is the input through the whole chain, chroma included. The
// warp interpolates the chain between nodes 16 px apart: 0.007 px off at worst at 320x180
// through the lens, but 0.089 px at 640x360 rectified (the lens's squeeze at the pinhole
// view's edges), where a few percent of a sharp texture's pixels then differ by 3 levels.
TEST(LensStabilizer, EveryPlaneIsWarpedThroughTheLens)
{
    EXPECT_GE(worstAgreement(LensOutput::Original, 320, 180), 0.99);
    EXPECT_GE(worstAgreement(LensOutput::Rectified, 640, 360), 0.97);
}

// A rolling shutter seen through a fisheye: the rows' transforms and the lens's mesh in one
// warp; every frame comes back warped, and where the rows were moved the output still reads
// inside the input.
TEST(LensStabilizer, ARollingShutterFisheyeFlightComesOutWhole)
{
    synthetic::FlightOptions options;
    options.width = 320;
    options.height = 180;
    options.frames = 40;
    options.readout = 0.8;
    options.vibration_hz = 47.0;
    options.vibration_px = 2.0;
    options.vibration_deg = 0.1;
    options.lens = synthetic::fisheyeLens(options.width, options.height);
    const synthetic::ShakyFlight flight(options);
    StabilizerConfig config = withProfile(
        synthetic::writeLensProfile(flight.options().lens, testing::TempDir() + "fisheye_rs.json", 26.7));
    Stabilizer s(config);
    s.setFrameInterval(1000.0 / 30.0);
    EXPECT_DOUBLE_EQ(s.config().readout_time, 26.7);
    for (int i = 0; i < flight.frameCount(); ++i)
        s.push(BufferSlot::make(flight.render(i), i));
    s.flush();
    int frames = 0, bent = 0;
    while (auto f = s.waitPop()) {
        EXPECT_EQ(f->outcome, Outcome::Warped) << f->error;
        EXPECT_EQ(BufferSlot::of(*f).id(), frames);
        bent += f->stats.row_motion.empty() ? 0 : 1;
        ++frames;
    }
    EXPECT_EQ(frames, flight.frameCount());
    EXPECT_GT(bent, flight.frameCount() / 2);  // a known readout time: corrected throughout
}

// Framing through the lens: the still output is covered, a shift past the crop room is not,
// and the largest share of it that is covered leaves the output inside the picture.
TEST(LensStabilizer, ACorrectionIsShrunkUntilTheLensedOutputIsCovered)
{
    const int w = 640, h = 360;
    const double zoom = 1.0 / 0.92;
    const Similarity unzoom{0.0, 0.0, 0.0, 1.0 / zoom};
    for (LensOutput output : {LensOutput::Original, LensOutput::Rectified}) {
        const LensView view(synthetic::fisheyeLens(w, h), output, w, h);
        const std::vector<Point2> edge = view.edgeInView(zoom);
        EXPECT_TRUE(view.coversFrame(unzoom, edge));
        // Far past the crop room: in the pinhole view a fisheye's edges are stretched, so the
        // room there is several times the picture's 4 %.
        const Similarity correction{600.0, -250.0, 0.05, 1.0};
        EXPECT_FALSE(view.coversFrame(correction.inverse() * unzoom, edge));
        const double share = largestCoveredShare(correction, zoom, [&](const Similarity &output_to_input) {
            return view.coversFrame(output_to_input, edge);
        });
        EXPECT_GT(share, 0.05);
        EXPECT_LT(share, 1.0);
        EXPECT_TRUE(view.coversFrame(scaleCorrection(correction, share).inverse() * unzoom, edge));
        EXPECT_FALSE(view.coversFrame(scaleCorrection(correction, std::min(1.0, share + 0.01)).inverse() * unzoom, edge));
    }
}
