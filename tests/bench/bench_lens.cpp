// Footage through a wide-angle or fisheye lens, with and without its profile: synthetic
// flights rendered through the lens (tests/synthetic/shaky_flight.hpp, FlightOptions::lens)
// with known truth, against the same flight through a pinhole lens; and the warp's cost
// with a lens.
//
//   uavstab-bench-lens --out DIR [--quick] [--only flights|cost]
//
// Jitter: each output frame corner is followed to the world through the whole chain (the
// stabilizer's output -> input map, through the lens where it has the profile, then the
// flight's lens back to its pinhole view and the true pose); the RMS high-pass of that path
// (synthetic::cornerJitter, after the first second) is divided by the corner's magnification
// (world px per output px of the still chain), so that it is in px of the output picture.
// Coverage min: the share of an output grid that reads inside the input, worst frame.
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common.hpp"
#include "jitter_metrics.hpp"
#include "lens/lens_view.hpp"
#include "lens_profile_file.hpp"
#include "render/frame_warper.hpp"
#include "render/lens_meshes.hpp"
#include "shaky_flight.hpp"
#include "uavstab/lens.hpp"

using namespace uavstab;
using namespace bench;

namespace {

constexpr std::size_t kFirstSecond = 30;

enum class Lens { Fisheye, Wide };
const char *lensName(Lens l) { return l == Lens::Fisheye ? "fisheye 150 deg" : "wide-angle 110 deg"; }

LensModel lensFor(Lens l, int width, int height)
{
    return l == Lens::Fisheye ? synthetic::fisheyeLens(width, height) : synthetic::wideAngleLens(width, height);
}

synthetic::FlightOptions flightOptions(int width, int height, int frames, std::uint32_t seed, double strength)
{
    synthetic::FlightOptions o;
    o.width = width;
    o.height = height;
    o.frames = frames;
    o.seed = seed;
    o.noise_px *= strength;
    o.band_px *= strength;
    o.rotation_noise_deg *= strength;
    o.rotation_band_deg *= strength;
    return o;
}

struct Run {
    double jitter = 0.0;  // output px at the corners
    double coverage_min = 1.0;
    double zoom = 1.0;
};

// Output pixel -> input pixel of one frame, through the stabilizer's lens when it has one.
Point2 outputToInputPx(const LensView *lens, const FrameStats &stats, Point2 q, int width, int height)
{
    const std::array<double, 6> m = stats.output_to_input.pixelMatrix(width, height);
    if (lens)
        return lens->viewToInput(lens->outputToView(q, stats.zoom), m);
    return {m[0] * q.x + m[1] * q.y + m[2], m[3] * q.x + m[4] * q.y + m[5]};
}

// World px per output px at output pixel q for a still camera: the chain with no
// correction (the crop zoom, the lens's undistortion), as the square root of its Jacobian's
// determinant.
double magnification(const LensView *lens, const LensModel &flight_lens, double zoom, Point2 q, int width, int height)
{
    FrameStats still;
    still.zoom = zoom;
    still.output_to_input = Similarity{0.0, 0.0, 0.0, 1.0 / zoom};
    const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
    auto world = [&](Point2 p) {
        const Point2 s = outputToInputPx(lens, still, p, width, height);
        const Point2 u = flight_lens.active() ? flight_lens.undistort(s) : s;
        return Point2{u.x - cx, u.y - cy};
    };
    const double h = 0.5;
    const double sx = q.x < width / 2.0 ? h : -h, sy = q.y < height / 2.0 ? h : -h;
    const Point2 a = world(q), bx = world({q.x + sx, q.y}), by = world({q.x, q.y + sy});
    const double j00 = (bx.x - a.x) / sx, j10 = (bx.y - a.y) / sx, j01 = (by.x - a.x) / sy, j11 = (by.y - a.y) / sy;
    return std::sqrt(std::abs(j00 * j11 - j01 * j10));
}

// The flight through the stabilizer (2 threads, defaults, the given delay), the profile
// when `profile` is not empty.
Run stabilize(const synthetic::ShakyFlight &flight, int delay, const std::string &profile)
{
    const int width = flight.options().width, height = flight.options().height;
    const LensModel &flight_lens = flight.options().lens;
    StabilizerConfig config;
    config.delay = delay;
    config.threads = 2;
    config.lens_profile = profile;
    Stabilizer stabilizer(config);
    std::unique_ptr<LensView> lens;
    if (!profile.empty())
        lens = std::make_unique<LensView>(readLensProfile(profile).lens.scaledTo(width, height),
                                          LensOutput::Original, width, height);
    const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
    const std::array<Point2, 4> corners{Point2{0.0, 0.0}, Point2{width - 1.0, 0.0}, Point2{0.0, height - 1.0},
                                        Point2{width - 1.0, height - 1.0}};
    std::array<std::vector<std::array<Point2, 4>>, 4> world;  // per corner, the corner repeated
    Run r;
    auto take = [&](StabilizedFrame f) {
        const int i = int(static_cast<const OwnedSlot &>(*f.slot).index());
        r.zoom = std::max(r.zoom, f.stats.zoom);
        for (std::size_t c = 0; c < 4; ++c) {
            const Point2 s = outputToInputPx(lens.get(), f.stats, corners[c], width, height);
            const Point2 u = flight_lens.active() ? flight_lens.undistort(s) : s;
            const Point2 w = flight.truePose(i).apply({u.x - cx, u.y - cy});
            world[c].push_back({w, w, w, w});
        }
        int inside = 0, total = 0;
        for (int gy = 0; gy <= 18; ++gy)
            for (int gx = 0; gx <= 32; ++gx) {
                const Point2 s =
                    outputToInputPx(lens.get(), f.stats, {(width - 1) * gx / 32.0, (height - 1) * gy / 18.0}, width,
                                    height);
                inside += s.x >= -1e-6 && s.y >= -1e-6 && s.x <= width - 1 + 1e-6 && s.y <= height - 1 + 1e-6;
                ++total;
            }
        r.coverage_min = std::min(r.coverage_min, double(inside) / total);
    };
    for (int i = 0; i < flight.frameCount(); ++i) {
        stabilizer.push(std::make_unique<OwnedSlot>(flight.render(i), long(i)));
        while (auto f = stabilizer.tryPop())
            take(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        take(std::move(*f));
    double sum = 0.0;
    for (std::size_t c = 0; c < 4; ++c) {
        const double j = synthetic::cornerJitter(world[c], 8.0, kFirstSecond);
        const double g = magnification(lens.get(), flight_lens, r.zoom, corners[c], width, height);
        sum += (j / g) * (j / g);
    }
    r.jitter = std::sqrt(sum / 4.0);
    return r;
}

void sectionFlights(const Options &o)
{
    Fragment frag(o, "lens_flights");
    const int width = 640, height = 360;
    const int frames = o.quick ? 90 : 150;
    const std::vector<std::uint32_t> seeds = o.quick ? std::vector<std::uint32_t>{1} : std::vector<std::uint32_t>{1, 2, 3};
    const std::vector<double> strengths = o.quick ? std::vector<double>{1.0} : std::vector<double>{0.5, 1.0, 2.0};
    const std::vector<int> delays{5, 20};
    frag.text(format(
        "Synthetic hover flights (ShakyFlight, %dx%d, %d frames, the default jitter times the strength) rendered "
        "through a lens, stabilized by the library (2 threads, defaults) with the lens's profile (a Gyroflow JSON "
        "written from the same lens), without it, and the same flight through a pinhole lens. **Jitter** = px of "
        "shake left at the output frame's corners (each corner followed to the world through the whole chain, RMS "
        "high-pass after the first second, over the corner's magnification); **coverage min** = the share of "
        "the output reading inside the input, worst frame. Mean over %zu seed(s), the worst seed in brackets.",
        width, height, frames, seeds.size()));
    Table t({"lens", "strength", "delay", "pinhole twin px", "with the profile px", "profile / pinhole",
             "without the profile px", "coverage min (profile)", "zoom"});
    const std::string dir = o.out_dir;
    double ratio_worst = 0.0, coverage_all = 1.0;
    std::string worst_case;
    for (Lens lens : {Lens::Fisheye, Lens::Wide})
        for (double strength : strengths)
            for (int delay : delays) {
                std::vector<double> pin, with, without, ratio;
                double coverage = 1.0, zoom = 1.0;
                for (std::uint32_t seed : seeds) {
                    synthetic::FlightOptions plain = flightOptions(width, height, frames, seed, strength);
                    synthetic::FlightOptions through = plain;
                    through.lens = lensFor(lens, width, height);
                    const synthetic::ShakyFlight twin(plain), flight(through);
                    const std::string profile = synthetic::writeLensProfile(
                        flight.options().lens, dir + "/lens_profile_" + std::to_string(int(lens)) + ".json");
                    const Run a = stabilize(twin, delay, "");
                    const Run b = stabilize(flight, delay, profile);
                    const Run c = stabilize(flight, delay, "");
                    pin.push_back(a.jitter);
                    with.push_back(b.jitter);
                    without.push_back(c.jitter);
                    ratio.push_back(b.jitter / a.jitter);
                    coverage = std::min(coverage, b.coverage_min);
                    zoom = std::max(zoom, b.zoom);
                    std::printf("%s x%.1f d%d seed %u: pinhole %.3f, profile %.3f, without %.3f px, coverage %.4f\n",
                                lensName(lens), strength, delay, seed, a.jitter, b.jitter, c.jitter, b.coverage_min);
                }
                auto cell = [](const std::vector<double> &v, const char *f) {
                    return format(f, mean(v)) + format(" (%.3f)", maxOf(v));
                };
                t.row({lensName(lens), format("%.1fx", strength), std::to_string(delay), cell(pin, "%.3f"),
                       cell(with, "%.3f"), format("%.2fx", mean(ratio)) + format(" (%.2fx)", maxOf(ratio)),
                       cell(without, "%.3f"), format("%.4f", coverage), format("%.3f", zoom)});
                if (maxOf(ratio) > ratio_worst) {
                    ratio_worst = maxOf(ratio);
                    worst_case = format("%s, %.1fx, delay %d", lensName(lens), strength, delay);
                }
                coverage_all = std::min(coverage_all, coverage);
            }
    frag.table(t);
    putResult(o, "lens.flights.ratio_worst", ratio_worst);
    putResultText(o, "lens.flights.ratio_worst_case", worst_case);
    putResult(o, "lens.flights.coverage_min", coverage_all);
}

// One thread: the warp alone (the mesh built per frame included) with and without a lens, alternated.
void sectionCost(const Options &o)
{
    Fragment frag(o, "lens_cost");
    const int width = 1920, height = 1080;
    const int rounds = o.quick ? 5 : 15;
    for (PixelFormat pixel_format : {PixelFormat::I420, PixelFormat::BGRx}) {
        synthetic::FlightOptions opt = flightOptions(width, height, 2, 1, 1.0);
        opt.format = pixel_format;
        const synthetic::ShakyFlight flight(opt);
        const FrameBuffer in = flight.render(1);
        FrameBuffer out(pixel_format, width, height, 0);
        const Similarity correction{3.2, -2.1, 0.004, 1.0};
        const double zoom = 1.0 / 0.92;
        const Similarity output_to_input = correction.inverse() * Similarity{0.0, 0.0, 0.0, 1.0 / zoom};
        auto lens = std::make_shared<const LensView>(synthetic::fisheyeLens(width, height), LensOutput::Original,
                                                     width, height);
        LensMeshes meshes(lens);
        const std::array<double, 6> m = output_to_input.pixelMatrix(width, height);
        (void)meshes.meshes(in.view(), zoom, nullptr, m);  // the per-stream part
        std::vector<double> plain_ms, lens_ms, mesh_ms, ratio;
        const FrameWarper warper;
        for (int r = 0; r < rounds; ++r) {
            double t = cpuSeconds(CLOCK_THREAD_CPUTIME_ID);
            warper.warp(in.view(), out.view(), output_to_input);
            const double plain = cpuSeconds(CLOCK_THREAD_CPUTIME_ID) - t;
            t = cpuSeconds(CLOCK_THREAD_CPUTIME_ID);
            const std::vector<WarpMesh> planes = meshes.meshes(in.view(), zoom, nullptr, m);
            const double mesh = cpuSeconds(CLOCK_THREAD_CPUTIME_ID) - t;
            warper.warp(in.view(), out.view(), planes);
            const double with = cpuSeconds(CLOCK_THREAD_CPUTIME_ID) - t;
            plain_ms.push_back(1000 * plain);
            lens_ms.push_back(1000 * with);
            mesh_ms.push_back(1000 * mesh);
            ratio.push_back(with / plain);
        }
        frag.text(format("%s %dx%d, one thread, %d alternated rounds: warp %.2f ms without a lens, %.2f ms with the "
                         "fisheye (of which the meshes %.2f ms): %.2fx (median of the per-round ratios)",
                         formatName(pixel_format), width, height, rounds, median(plain_ms), median(lens_ms),
                         median(mesh_ms), median(ratio)));
        putResult(o, format("lens.cost.%s.ratio", formatName(pixel_format)), median(ratio));
        putResult(o, format("lens.cost.%s.plain_ms", formatName(pixel_format)), median(plain_ms));
        putResult(o, format("lens.cost.%s.lens_ms", formatName(pixel_format)), median(lens_ms));
    }
}

} // namespace

int main(int argc, char **argv)
{
    const Options o = parseOptions(argc, argv, "uavstab-bench-lens --out DIR [--quick] [--only flights|cost]",
                                   {"flights", "cost"});
    if (o.wants("flights"))
        sectionFlights(o);
    if (o.wants("cost"))
        sectionCost(o);
    return 0;
}
