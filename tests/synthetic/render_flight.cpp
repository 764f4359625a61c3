// Renders the synthetic shaky flight to a .y4m file (I420), with its true camera path
// as CSV beside it. Used by the demo and the benchmark.
//
//   uavstab-render-flight OUT.y4m [--width W] [--height H] [--frames N] [--fps F]
//                         [--seed S] [--objects K] [--zoom A] [--profile lissajous|manoeuvre]
//                         [--readout R] [--vibration-hz F] [--vibration-px A] [--vibration-deg A]
//                         [--lens fisheye|wide] [--lens-fov DEG] [--lens-out LENS.yml]
//                         [--truth OUT.csv]
// --profile manoeuvre: hover, accelerating pans, a yaw turn, stops, a climb (see
// shaky_flight.hpp); --zoom then has no effect. The CSV holds the intended path beside the
// true one (with --readout: the pose of each frame's middle row).
// --readout: rolling shutter, share of the frame time the rows take to read (0 = global
// shutter); --vibration-*: propeller vibration, frequency (Hz) and RMS per axis (px for x and
// y, degrees for roll), e.g. --readout 0.8 --vibration-hz 47 --vibration-px 2 --vibration-deg 0.1.
// --lens: seen through a fisheye (150 deg diagonal) or wide-angle lens (110 deg diagonal; see
// fisheyeLens and wideAngleLens in shaky_flight.hpp), --lens-fov another diagonal field of
// view; the truth CSV stays in undistorted (pinhole) coordinates. --lens-out writes the lens
// as an OpenCV calibration (.yml, .xml or .json), as uavstab::readLensProfile reads it.
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <iostream>
#include <string>

#include "shaky_flight.hpp"
#include "truth_csv.hpp"
#include "y4m.hpp"

using namespace uavstab;

int main(int argc, char **argv)
{
    synthetic::FlightOptions options;
    std::string out, truth, lens_name, lens_out;
    double lens_fov = 0.0;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        auto value = [&]() -> const char * {
            if (i + 1 >= argc) {
                std::cerr << arg << " needs a value\n";
                std::exit(2);
            }
            return argv[++i];
        };
        if (arg == "--width")
            options.width = std::atoi(value());
        else if (arg == "--height")
            options.height = std::atoi(value());
        else if (arg == "--frames")
            options.frames = std::atoi(value());
        else if (arg == "--fps")
            options.fps = std::atof(value());
        else if (arg == "--seed")
            options.seed = std::uint32_t(std::strtoul(value(), nullptr, 10));
        else if (arg == "--objects")
            options.moving_objects = std::atoi(value());
        else if (arg == "--zoom")
            options.zoom_amplitude = std::atof(value());
        else if (arg == "--readout")
            options.readout = std::atof(value());
        else if (arg == "--vibration-hz")
            options.vibration_hz = std::atof(value());
        else if (arg == "--vibration-px")
            options.vibration_px = std::atof(value());
        else if (arg == "--vibration-deg")
            options.vibration_deg = std::atof(value());
        else if (arg == "--lens")
            lens_name = value();
        else if (arg == "--lens-fov")
            lens_fov = std::atof(value());
        else if (arg == "--lens-out")
            lens_out = value();
        else if (arg == "--profile") {
            const std::string p = value();
            if (p == "lissajous")
                options.profile = synthetic::FlightProfile::Lissajous;
            else if (p == "manoeuvre" || p == "maneuver")
                options.profile = synthetic::FlightProfile::Manoeuvre;
            else {
                std::cerr << "--profile: lissajous or manoeuvre, not " << p << "\n";
                return 2;
            }
        } else if (arg == "--truth")
            truth = value();
        else if (arg == "-h" || arg == "--help") {
            std::cout << "usage: uavstab-render-flight OUT.y4m [--width W] [--height H] [--frames N] [--fps F]"
                         " [--seed S] [--objects K] [--zoom A] [--profile lissajous|manoeuvre]\n"
                         "       [--readout R] [--vibration-hz F] [--vibration-px A] [--vibration-deg A]\n"
                         "       [--lens fisheye|wide] [--lens-fov DEG] [--lens-out LENS.yml] [--truth OUT.csv]\n";
            return 0;
        } else if (out.empty() && arg[0] != '-')
            out = arg;
        else {
            std::cerr << "unknown argument " << arg << "\n";
            return 2;
        }
    }
    if (out.empty()) {
        std::cerr << "usage: uavstab-render-flight OUT.y4m [options] (--help)\n";
        return 2;
    }
    if (!lens_name.empty() && lens_name != "fisheye" && lens_name != "wide") {
        std::cerr << "--lens: fisheye or wide, not " << lens_name << "\n";
        return 2;
    }
    if ((lens_fov != 0.0 || !lens_out.empty()) && lens_name.empty()) {
        std::cerr << "--lens-fov and --lens-out need --lens\n";
        return 2;
    }
    try {
        if (lens_name == "fisheye")
            options.lens = lens_fov > 0 ? synthetic::fisheyeLens(options.width, options.height, lens_fov)
                                        : synthetic::fisheyeLens(options.width, options.height);
        else if (lens_name == "wide")
            options.lens = lens_fov > 0 ? synthetic::wideAngleLens(options.width, options.height, lens_fov)
                                        : synthetic::wideAngleLens(options.width, options.height);
        if (!lens_out.empty())
            synthetic::writeLensCalibration(lens_out, options.lens);
        options.format = PixelFormat::I420;
        const synthetic::ShakyFlight flight(options);
        synthetic::Y4mWriter writer(out, options.width, options.height, int(std::lround(options.fps * 1000)), 1000);
        for (int i = 0; i < flight.frameCount(); ++i)
            writer.write(flight.render(i).view());
        if (!truth.empty())
            synthetic::writeTruthCsv(truth, flight);
    } catch (const std::exception &e) {
        std::cerr << "uavstab-render-flight: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
