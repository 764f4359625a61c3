// The lens model against OpenCV's own, and the calibration files it is read from.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "uavstab/lens.hpp"

namespace uavstab {
namespace {

// A strong fisheye in the manner of an FPV camera's (about 72 deg off the axis at the
// corners), one to one out to the corners, and a standard-model wide-angle lens. Neither is
// a real calibration.
LensModel strongFisheye()
{
    LensModel l;
    l.kind = LensKind::Fisheye;
    l.fx = 560.0;
    l.fy = 559.2;
    l.cx = 646.5;
    l.cy = 351.5;
    l.coeffs = {0.04, -0.01, 0.02, -0.008, 0.0};
    l.width = 1280;
    l.height = 720;
    return l;
}

// The DJI Air Unit 720p profile (Gyroflow lens_profiles, DJI/DJI_Air Unit___720p_16by9_
// 1280x720-60.00fps.json, CC0): its polynomial peaks at 69.4 deg off the axis
// (theta_d 1.138), short of the image's corners (theta_d 1.247-1.284), so the model has no
// inverse there and validate() refuses it.
LensModel airUnitFisheye()
{
    LensModel l;
    l.kind = LensKind::Fisheye;
    l.fx = 580.2469786517647;
    l.fy = 579.706624429074;
    l.cx = 647.1824726861819;
    l.cy = 351.0372168290395;
    l.coeffs = {0.030342280760628643, -0.0065809024093009955, 0.03914432580459308, -0.04619914327633287, 0.0};
    l.width = 1280;
    l.height = 720;
    return l;
}

LensModel wideStandard()
{
    LensModel l;
    l.kind = LensKind::Standard;
    l.fx = l.fy = 900.0;
    l.cx = 962.0;
    l.cy = 537.0;
    // k3 > 0: with k3 = -0.012 (as first written) the distorted radius peaks at 1.138 focal
    // lengths, short of the corners' 1.228, and validate() rightly refuses the lens.
    l.coeffs = {-0.28, 0.09, 0.0008, -0.0005, 0.004};
    l.width = 1920;
    l.height = 1080;
    return l;
}

cv::Matx33d cameraMatrix(const LensModel &l)
{
    return {l.fx, 0, l.cx, 0, l.fy, l.cy, 0, 0, 1};
}

// n random pixels of the image, then its four corner pixels.
std::vector<cv::Point2d> randomPixels(const LensModel &l, int n)
{
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> x(0.0, l.width - 1.0), y(0.0, l.height - 1.0);
    std::vector<cv::Point2d> p(static_cast<std::size_t>(n));
    for (auto &q : p)
        q = {x(rng), y(rng)};
    // and the corners, where a strong lens is hardest to invert
    for (double cx : {0.0, l.width - 1.0})
        for (double cy : {0.0, l.height - 1.0})
            p.push_back({cx, cy});
    return p;
}

TEST(LensModel, FisheyeDistortsAsOpenCv)
{
    const LensModel l = strongFisheye();
    ASSERT_NO_THROW(l.validate());
    // OpenCV distorts normalized undistorted points; ours takes pinhole pixels.
    std::vector<cv::Point2d> normalized, cv_out;
    std::vector<Point2> ours;
    for (const cv::Point2d &p : randomPixels(l, 500)) {
        const Point2 u = l.undistort({p.x, p.y});
        normalized.push_back({(u.x - l.cx) / l.fx, (u.y - l.cy) / l.fy});
        ours.push_back(l.distort(u));
        EXPECT_NEAR(ours.back().x, p.x, 1e-6);  // round trip, sub-micropixel
        EXPECT_NEAR(ours.back().y, p.y, 1e-6);
    }
    cv::fisheye::distortPoints(normalized, cv_out, cameraMatrix(l), cv::Vec4d(l.coeffs[0], l.coeffs[1], l.coeffs[2], l.coeffs[3]));
    for (std::size_t i = 0; i < ours.size(); ++i) {
        EXPECT_NEAR(ours[i].x, cv_out[i].x, 1e-3);
        EXPECT_NEAR(ours[i].y, cv_out[i].y, 1e-3);
    }
}

TEST(LensModel, FisheyeUndistortsAsOpenCv)
{
    const LensModel l = strongFisheye();
    ASSERT_NO_THROW(l.validate());
    const std::vector<cv::Point2d> pixels = randomPixels(l, 500);
    std::vector<cv::Point2d> cv_out;
    // OpenCV's Newton iteration, run to convergence (its default stops at 10 steps or 1e-8).
    cv::fisheye::undistortPoints(pixels, cv_out, cameraMatrix(l),
                                 cv::Vec4d(l.coeffs[0], l.coeffs[1], l.coeffs[2], l.coeffs[3]), cv::noArray(),
                                 cameraMatrix(l), cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
    int compared = 0;
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        // OpenCV answers (-1e6, -1e6) where its iteration did not converge or flipped.
        if (cv_out[i].x == -1e6 && cv_out[i].y == -1e6)
            continue;
        ++compared;
        const Point2 u = l.undistort({pixels[i].x, pixels[i].y});
        EXPECT_NEAR(u.x, cv_out[i].x, 1e-3);
        EXPECT_NEAR(u.y, cv_out[i].y, 1e-3);
    }
    // The lens is one to one out to the corners: OpenCV converges everywhere.
    EXPECT_EQ(compared, int(pixels.size()));
}

TEST(LensModel, StandardBothWaysAsOpenCv)
{
    const LensModel l = wideStandard();
    ASSERT_NO_THROW(l.validate());
    const std::vector<cv::Point2d> pixels = randomPixels(l, 500);
    const std::vector<double> d(l.coeffs.begin(), l.coeffs.end());
    std::vector<cv::Point2d> cv_out;
    cv::undistortPoints(pixels, cv_out, cameraMatrix(l), d, cv::noArray(), cameraMatrix(l),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
    std::vector<cv::Point3d> rays;
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        const Point2 u = l.undistort({pixels[i].x, pixels[i].y});
        EXPECT_NEAR(u.x, cv_out[i].x, 1e-3);
        EXPECT_NEAR(u.y, cv_out[i].y, 1e-3);
        rays.push_back({(u.x - l.cx) / l.fx, (u.y - l.cy) / l.fy, 1.0});
    }
    std::vector<cv::Point2d> projected;
    cv::projectPoints(rays, cv::Vec3d(), cv::Vec3d(), cameraMatrix(l), d, projected);
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        EXPECT_NEAR(projected[i].x, pixels[i].x, 1e-3);
        EXPECT_NEAR(projected[i].y, pixels[i].y, 1e-3);
    }
}

TEST(LensModel, ScalesToTheStreamAndRefusesAnotherAspect)
{
    const LensModel l = strongFisheye();
    const LensModel half = l.scaledTo(640, 360);
    EXPECT_DOUBLE_EQ(half.fx, l.fx / 2);
    EXPECT_DOUBLE_EQ(half.cx, (l.cx + 0.5) / 2 - 0.5);
    // The same scene point at either size.
    const Point2 p = l.undistort({1000.0, 600.0});
    const Point2 q = half.undistort({(1000.0 + 0.5) / 2 - 0.5, (600.0 + 0.5) / 2 - 0.5});
    EXPECT_NEAR((q.x + 0.5) * 2 - 0.5, p.x, 1e-6);
    EXPECT_NEAR((q.y + 0.5) * 2 - 0.5, p.y, 1e-6);
    EXPECT_THROW(l.scaledTo(640, 480), std::invalid_argument);
}

TEST(LensModel, ValidateNamesTheField)
{
    LensModel l = strongFisheye();
    l.fx = -1.0;
    try {
        l.validate();
        FAIL() << "a negative focal length passed";
    } catch (const std::invalid_argument &e) {
        EXPECT_NE(std::string(e.what()).find("fx"), std::string::npos) << e.what();
    }
    l = strongFisheye();
    l.coeffs[0] = -3.0;  // folds back well inside the frame
    EXPECT_THROW(l.validate(), std::invalid_argument);
    // A real profile whose polynomial folds back short of the corners.
    try {
        airUnitFisheye().validate();
        FAIL() << "the Air Unit 720p profile, which folds back at 69.4 deg, passed";
    } catch (const std::invalid_argument &e) {
        EXPECT_NE(std::string(e.what()).find("folds back at 69.4"), std::string::npos) << e.what();
    }
}

std::string writeFile(const std::string &name, const std::string &text)
{
    const std::string path = ::testing::TempDir() + name;
    std::ofstream(path) << text;
    return path;
}

const char *kGyroflowNew = R"({
  "name": "O4 wide", "calib_dimension": {"w": 3840, "h": 2160}, "frame_readout_time": null,
  "fisheye_params": {"RMS_error": 2.8, "camera_matrix": [[1600.17, 0.0, 1975.76], [0.0, 1605.33, 1137.45], [0.0, 0.0, 1.0]],
                     "distortion_coeffs": [0.4297, -0.3982, -0.0289, 0.1028], "radial_distortion_limit": null},
  "distortion_model": null, "global_shutter": false, "note": "caf\u00e9"
})";

const char *kGyroflowOldStandard = R"({
  "name": "old", "calib_dimension": {"w": 1920, "h": 1080}, "frame_readout_time": 16.5,
  "use_opencv_fisheye": false, "fisheye_params": {},
  "use_opencv_standard": true,
  "calib_params": {"RMS_error": 0.3, "camera_matrix": [[900.0, 0.0, 962.0], [0.0, 900.0, 537.0], [0.0, 0.0, 1.0]],
                   "distortion_coeffs": [-0.28, 0.09, 0.0008, -0.0005, 0.004]}
})";

TEST(LensProfile, ReadsGyroflowLayouts)
{
    const LensProfile a = readLensProfile(writeFile("new.json", kGyroflowNew));
    EXPECT_EQ(a.lens.kind, LensKind::Fisheye);
    EXPECT_EQ(a.lens.width, 3840);
    EXPECT_DOUBLE_EQ(a.lens.cy, 1137.45);
    EXPECT_DOUBLE_EQ(a.lens.coeffs[3], 0.1028);
    EXPECT_EQ(a.readout_time, 0.0);
    EXPECT_EQ(a.name, "O4 wide");
    const LensProfile b = readLensProfile(writeFile("old.json", kGyroflowOldStandard));
    EXPECT_EQ(b.lens.kind, LensKind::Standard);
    EXPECT_DOUBLE_EQ(b.lens.coeffs[4], 0.004);
    EXPECT_DOUBLE_EQ(b.readout_time, 16.5);
    EXPECT_FALSE(b.readout_bottom_up);
    // A negative readout time: the rows are read from the bottom up.
    std::string bottom_up = kGyroflowOldStandard;
    bottom_up.replace(bottom_up.find("16.5"), 4, "-16.5");
    const LensProfile c = readLensProfile(writeFile("bottom_up.json", bottom_up));
    EXPECT_DOUBLE_EQ(c.readout_time, 16.5);
    EXPECT_TRUE(c.readout_bottom_up);
}

TEST(LensProfile, ReadsAnOpenCvCalibration)
{
    const std::string path = ::testing::TempDir() + "calib.yml";
    {
        cv::FileStorage fs(path, cv::FileStorage::WRITE);
        fs << "image_width" << 1920 << "image_height" << 1080;
        fs << "camera_matrix" << cv::Mat(cameraMatrix(wideStandard()));
        fs << "distortion_coefficients" << (cv::Mat_<double>(5, 1) << -0.28, 0.09, 0.0008, -0.0005, 0.004);
    }
    const LensProfile p = readLensProfile(path);
    EXPECT_EQ(p.lens.kind, LensKind::Standard);
    EXPECT_DOUBLE_EQ(p.lens.fx, 900.0);
    EXPECT_DOUBLE_EQ(p.lens.coeffs[1], 0.09);
}

// The profile files in tests/data/lens (written for these tests in Gyroflow's two layouts,
// with every field Gyroflow writes; see the README there): each number as the file has it.
TEST(LensProfile, ReadsTheProfileFilesInTestData)
{
    const std::string dir = std::string(UAVSTAB_TEST_DATA_DIR) + "/lens/";
    struct Expected {
        std::string file, name;
        LensKind kind;
        double fx, fy, cx, cy;
        std::array<double, 5> coeffs;
        int width, height;
        double readout_time;
    };
    const std::vector<Expected> files = {
        {"gyroflow_new_layout_fisheye_3840x2160.json", "uavstab test fisheye 4k (new layout)", LensKind::Fisheye,
         1711.25, 1709.75, 1923.5, 1082.25, {0.052, -0.0134, 0.0071, -0.0023, 0.0}, 3840, 2160, 8.25},
        {"gyroflow_old_layout_fisheye_1280x720.json", "uavstab test fisheye 720p (old layout)", LensKind::Fisheye,
         571.5, 570.875, 641.25, 357.75, {0.035, -0.009, 0.015, -0.006, 0.0}, 1280, 720, 0.0},
        {"gyroflow_old_layout_standard_1920x1080.json", "uavstab test standard 1080p (old layout)",
         LensKind::Standard, 1402.5, 1401.0, 955.5, 541.25, {-0.118, 0.087, 0.00042, -0.00031, -0.021}, 1920, 1080,
         16.68},
    };
    for (const Expected &e : files) {
        SCOPED_TRACE(e.file);
        LensProfile p;
        ASSERT_NO_THROW(p = readLensProfile(dir + e.file));
        EXPECT_EQ(p.name, e.name);
        EXPECT_EQ(p.lens.kind, e.kind);
        EXPECT_DOUBLE_EQ(p.lens.fx, e.fx);
        EXPECT_DOUBLE_EQ(p.lens.fy, e.fy);
        EXPECT_DOUBLE_EQ(p.lens.cx, e.cx);
        EXPECT_DOUBLE_EQ(p.lens.cy, e.cy);
        for (std::size_t i = 0; i < 5; ++i)
            EXPECT_DOUBLE_EQ(p.lens.coeffs[i], e.coeffs[i]) << "coefficient " << i;
        EXPECT_EQ(p.lens.width, e.width);
        EXPECT_EQ(p.lens.height, e.height);
        EXPECT_DOUBLE_EQ(p.readout_time, e.readout_time);
        EXPECT_FALSE(p.global_shutter);
    }
}

// Each bad profile fails with the field it is about.
TEST(LensProfile, BadProfilesNameTheField)
{
    struct Case {
        std::string text, field;
    };
    std::string no_dim = kGyroflowNew;
    no_dim.replace(no_dim.find("\"calib_dimension\""), 17, "\"calib_dim\"");
    std::string model = kGyroflowNew;
    model.replace(model.find("\"distortion_model\": null"), 24, "\"distortion_model\": \"poly3\"");
    std::string matrix = kGyroflowNew;
    matrix.replace(matrix.find("[0.0, 0.0, 1.0]"), 15, "[0.0, 0.0]");
    const std::vector<Case> cases = {{no_dim, "calib_dimension"}, {model, "distortion_model"},
                                     {matrix, "fisheye_params.camera_matrix"}, {"{\"calib_dimension\": ", ""}};
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const std::string path = writeFile("bad" + std::to_string(i) + ".json", cases[i].text);
        try {
            readLensProfile(path);
            ADD_FAILURE() << "case " << i << " was read";
        } catch (const LensProfileError &e) {
            EXPECT_EQ(e.file(), path);
            EXPECT_EQ(e.field(), cases[i].field) << e.what();
        }
    }
    EXPECT_THROW(readLensProfile(::testing::TempDir() + "missing.json"), LensProfileError);
}

// Files the lens-profile fuzzer (tests/fuzz/fuzz_lens_profile.cpp) found: each is refused
// with LensProfileError, not an OpenCV or allocation error.
TEST(LensProfile, BrokenCalibrationFilesAreRefusedAsProfiles)
{
    const std::string matrix_head = "%YAML:1.0\n---\nimage_width: 1920\nimage_height: 1080\n"
                                    "camera_matrix: !!opencv-matrix\n   rows: ";
    const std::vector<std::pair<std::string, std::string>> cases = {
        // rows x cols far beyond the data: OpenCV would allocate them first.
        {matrix_head + "300000000\n   cols: 300000000\n   dt: d\n   data: [ 1. ]\n", "camera_matrix"},
        // A YAML document whose root is not a map.
        {"%YAML:1.0\n---\n- 1\n- 2\n", ""},
        // Rows and data that disagree.
        {matrix_head + "3\n   cols: 3\n   dt: d\n   data: [ 1., 2. ]\n", "camera_matrix"},
        // Files OpenCV 4.6's YAML reader never returns on (the fuzzer's finds): a line
        // indented less than the first key, and a line beginning with "--".
        {"%YAML:1.0\n s: 0\nabc-\na: 1\n", ""},
        {"%YAML:1.0\n  a: 1\n b: -1\nc: 1\n", ""},
        {"%YAML:1.0\n a:1\n--G-\n", ""},
        {"%YAML:1.0\n s[:0\n-0G-\na\n", ""},  // an unclosed bracket hides nothing
    };
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const std::string path = writeFile("broken" + std::to_string(i) + ".yml", cases[i].first);
        try {
            readLensProfile(path);
            ADD_FAILURE() << "case " << i << " was read";
        } catch (const LensProfileError &e) {
            EXPECT_EQ(e.field(), cases[i].second) << "case " << i << ": " << e.what();
        } catch (const std::exception &e) {
            ADD_FAILURE() << "case " << i << " threw something else: " << e.what();
        }
    }
    // A file far larger than any calibration is refused unread.
    const std::string big = ::testing::TempDir() + "big.json";
    {
        std::ofstream f(big, std::ios::binary);
        f << std::string(2 << 20, ' ');
    }
    EXPECT_THROW(readLensProfile(big), LensProfileError);
}

} // namespace
} // namespace uavstab
