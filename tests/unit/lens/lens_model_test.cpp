// The lens model against OpenCV's own, and the calibration files it is read from.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "uavstab/lens.hpp"

namespace uavstab {
namespace {

// A DJI Air Unit 720p fisheye (Gyroflow profile) and a standard-model wide-angle lens.
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
    l.coeffs = {-0.28, 0.09, 0.0008, -0.0005, -0.012};
    l.width = 1920;
    l.height = 1080;
    return l;
}

cv::Matx33d cameraMatrix(const LensModel &l)
{
    return {l.fx, 0, l.cx, 0, l.fy, l.cy, 0, 0, 1};
}

std::vector<cv::Point2d> randomPixels(const LensModel &l, int n)
{
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> x(0.0, l.width - 1.0), y(0.0, l.height - 1.0);
    std::vector<cv::Point2d> p(std::size_t(n));
    for (auto &q : p)
        q = {x(rng), y(rng)};
    return p;
}

TEST(LensModel, FisheyeDistortsAsOpenCv)
{
    const LensModel l = airUnitFisheye();
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
    const LensModel l = airUnitFisheye();
    const std::vector<cv::Point2d> pixels = randomPixels(l, 500);
    std::vector<cv::Point2d> cv_out;
    cv::fisheye::undistortPoints(pixels, cv_out, cameraMatrix(l),
                                 cv::Vec4d(l.coeffs[0], l.coeffs[1], l.coeffs[2], l.coeffs[3]), cv::noArray(),
                                 cameraMatrix(l));
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        const Point2 u = l.undistort({pixels[i].x, pixels[i].y});
        EXPECT_NEAR(u.x, cv_out[i].x, 1e-3);
        EXPECT_NEAR(u.y, cv_out[i].y, 1e-3);
    }
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
    const LensModel l = airUnitFisheye();
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
    LensModel l = airUnitFisheye();
    l.fx = -1.0;
    try {
        l.validate();
        FAIL() << "a negative focal length passed";
    } catch (const std::invalid_argument &e) {
        EXPECT_NE(std::string(e.what()).find("fx"), std::string::npos) << e.what();
    }
    l = airUnitFisheye();
    l.coeffs[0] = -3.0;  // folds back well inside the frame
    EXPECT_THROW(l.validate(), std::invalid_argument);
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
                   "distortion_coeffs": [-0.28, 0.09, 0.0008, -0.0005, -0.012]}
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
    EXPECT_DOUBLE_EQ(b.lens.coeffs[4], -0.012);
    EXPECT_DOUBLE_EQ(b.readout_time, 16.5);
}

TEST(LensProfile, ReadsAnOpenCvCalibration)
{
    const std::string path = ::testing::TempDir() + "calib.yml";
    {
        cv::FileStorage fs(path, cv::FileStorage::WRITE);
        fs << "image_width" << 1920 << "image_height" << 1080;
        fs << "camera_matrix" << cv::Mat(cameraMatrix(wideStandard()));
        fs << "distortion_coefficients" << (cv::Mat_<double>(5, 1) << -0.28, 0.09, 0.0008, -0.0005, -0.012);
    }
    const LensProfile p = readLensProfile(path);
    EXPECT_EQ(p.lens.kind, LensKind::Standard);
    EXPECT_DOUBLE_EQ(p.lens.fx, 900.0);
    EXPECT_DOUBLE_EQ(p.lens.coeffs[1], 0.09);
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

} // namespace
} // namespace uavstab
