// The Stabilizer with a lens profile (StabilizerConfig::lens_profile): what it does with the
// file, and a flight seen through a lens.
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "buffer_slot.hpp"
#include "uavstab/lens.hpp"
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
