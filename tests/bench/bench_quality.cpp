// Quality of ours and of the peers on the same input:
//   synthetic  ShakyFlight "hover" clips (the default, slowly drifting Lissajous flight) with
//              known true motion (seeds x moving objects x 360p/720p): residual jitter (px),
//              coverage, zoom, distortion
//   manoeuvre  ShakyFlight manoeuvre flights (hover, accelerating pans, a yaw turn, stops, a
//              climb): error against the intended shake-free path (px), residual jitter beside
//   drone      the real drone clip (../shared/data/aerial_drone_nadir_steady_1920x1080.mp4) with
//              known synthetic shake added: the same, plus stability score and ITF
//   strong     hover flights at 720p under strong shake (x0.5, x1, x2 of bench_path.cpp's
//              "strong720") and with 47 Hz propeller vibration: residual jitter against
//              vid.stab's, coverage, zoom
//   real       the real clips in ../shared/data: stability score (Liu et al. 2013), ITF,
//              coverage and zoom
// Every one of our configurations (oursTable()) runs at every delay of kDelays; the peers are
// offline (no delay) and appear once beside them. Output motion is measured with ORB + RANSAC
// (registration.hpp), independently of the stabilizer's tracker; ours is also cross-checked
// against its own FrameStats.
// Each section is in quality_<section>.cpp; what they share is declared in bench_quality.hpp.
//
//   uavstab-bench-quality --out DIR [--quick] [--data DIR] [--only synthetic|manoeuvre|drone|strong|real]...
#include <cstdio>
#include <exception>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "bench_quality.hpp"

using namespace quality;

int main(int argc, char **argv)
{
    try {
        const Options o = parseOptions(
            argc, argv,
            "usage: uavstab-bench-quality --out DIR [--quick] [--data DIR] [--only synthetic|manoeuvre|drone|strong|real]...\n",
            {"synthetic", "manoeuvre", "drone", "strong", "real"});
        const bool deshake = ffmpegHasFilter("deshake");
        const bool vidstab = ffmpegHasFilter("vidstabdetect") && ffmpegHasFilter("vidstabtransform");
        if (!deshake)
            std::printf("ffmpeg deshake not available: the quality tables go without it\n");
        if (!vidstab)
            std::printf("ffmpeg vid.stab not available: the quality tables go without it\n");
        const std::vector<Method> ms = methods(deshake, vidstab);
        putMethodList(o);
        std::vector<ClipResult> truth_results;
        const auto t0 = Clock::now();
        auto timed = [&](const char *name, const std::function<void()> &section) {
            const auto t = Clock::now();
            section();
            const double s = secondsBetween(t, Clock::now());
            std::printf("[%s: %.0f s]\n", name, s);
            putResult(o, std::string("quality.seconds.") + name, s);
        };
        if (o.wants("synthetic"))
            timed("synthetic", [&] { sectionSynthetic(o, ms, &truth_results); });
        if (o.wants("manoeuvre"))
            timed("manoeuvre", [&] { sectionManoeuvre(o, ms, &truth_results); });
        if (o.wants("drone"))
            timed("drone", [&] { sectionDrone(o, ms, &truth_results); });
        if (o.wants("strong"))
            timed("strong", [&] { sectionStrong(o, ms); });
        if (!truth_results.empty())
            jitterPlot(o, truth_results, ms);
        if (o.wants("real"))
            timed("real", [&] { sectionReal(o, ms); });
        std::printf("[quality: %.0f s]\n", secondsBetween(t0, Clock::now()));
    } catch (const std::exception &e) {
        std::cerr << "uavstab-bench-quality: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
