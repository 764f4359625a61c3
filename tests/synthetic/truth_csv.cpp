#include "truth_csv.hpp"

#include <fstream>
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

} // namespace uavstab::synthetic
