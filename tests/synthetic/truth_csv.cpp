#include "truth_csv.hpp"

#include <fstream>
#include <opencv2/core/persistence.hpp>
#include <sstream>
#include <stdexcept>

#include "shaky_flight.hpp"

namespace uavstab::synthetic {

void writeTruthCsv(const std::string &path, const ShakyFlight &flight)
{
    std::ofstream csv(path);
    if (!csv)
        throw std::runtime_error("cannot write " + path);
    csv.precision(17);
    csv << "frame,dx,dy,angle,scale,intended_dx,intended_dy,intended_angle,intended_scale\n";
    for (int i = 0; i < flight.frameCount(); ++i) {
        const Similarity t = flight.truePose(i), s = flight.intendedPose(i);
        csv << i << ',' << t.dx << ',' << t.dy << ',' << t.angle << ',' << t.scale << ',' << s.dx << ',' << s.dy
            << ',' << s.angle << ',' << s.scale << '\n';
    }
}

std::vector<Similarity> readTruthCsv(const std::string &path)
{
    std::vector<Similarity> poses;
    std::ifstream csv(path);
    std::string line;
    std::getline(csv, line);  // header
    while (std::getline(csv, line)) {
        std::istringstream s(line);
        char comma;
        long frame;
        Similarity p;
        if (s >> frame >> comma >> p.dx >> comma >> p.dy >> comma >> p.angle >> comma >> p.scale)
            poses.push_back(p);
    }
    return poses;
}

void writeLensCalibration(const std::string &path, const LensModel &lens)
{
    if (!lens.active())
        throw std::invalid_argument("writeLensCalibration: no lens");
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened())
        throw std::runtime_error("cannot write " + path);
    const cv::Mat camera = (cv::Mat_<double>(3, 3) << lens.fx, 0.0, lens.cx, 0.0, lens.fy, lens.cy, 0.0, 0.0, 1.0);
    const bool fisheye = lens.kind == LensKind::Fisheye;
    cv::Mat coeffs(1, fisheye ? 4 : 5, CV_64F);
    for (int k = 0; k < coeffs.cols; ++k)
        coeffs.at<double>(0, k) = lens.coeffs[std::size_t(k)];
    fs << "image_width" << lens.width << "image_height" << lens.height;
    fs << "distortion_model" << (fisheye ? "fisheye" : "plumb_bob");
    fs << "camera_matrix" << camera << "distortion_coefficients" << coeffs;
}

} // namespace uavstab::synthetic
