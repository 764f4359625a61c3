#include "lens_profile_file.hpp"

#include <fstream>
#include <iomanip>
#include <stdexcept>

namespace uavstab::synthetic {

std::string writeLensProfile(const LensModel &lens, const std::string &path, double readout_ms, bool global_shutter)
{
    std::ofstream out(path);
    if (!out)
        throw std::runtime_error("cannot write " + path);
    const bool fisheye = lens.kind == LensKind::Fisheye;
    const int count = fisheye ? 4 : 5;
    out << std::setprecision(17);
    out << "{\n  \"name\": \"uavstab synthetic " << (fisheye ? "fisheye" : "wide-angle") << "\",\n";
    out << "  \"calib_dimension\": {\"w\": " << lens.width << ", \"h\": " << lens.height << "},\n";
    out << "  \"distortion_model\": \"" << (fisheye ? "opencv_fisheye" : "opencv_standard") << "\",\n";
    out << "  \"frame_readout_time\": " << readout_ms << ",\n";
    out << "  \"global_shutter\": " << (global_shutter ? "true" : "false") << ",\n";
    out << "  \"fisheye_params\": {\n    \"camera_matrix\": [[" << lens.fx << ", 0.0, " << lens.cx << "], [0.0, "
        << lens.fy << ", " << lens.cy << "], [0.0, 0.0, 1.0]],\n    \"distortion_coeffs\": [";
    for (int i = 0; i < count; ++i)
        out << (i ? ", " : "") << lens.coeffs[std::size_t(i)];
    out << "]\n  }\n}\n";
    if (!out)
        throw std::runtime_error("cannot write " + path);
    return path;
}

} // namespace uavstab::synthetic
