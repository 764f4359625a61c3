// Stabilizes a YUV4MPEG2 (I420) clip with the uavstab library alone, no GStreamer:
// the smallest complete use of the library API (push frames, pop results in order).
//
//   uavstab-stabilize-y4m IN.y4m OUT.y4m [--side-by-side SBS.y4m] [--truth TRUTH.csv]
//                         [--delay N] [--radius R] [--planner l1|optimal|gaussian|box] [--crop C]
//                         [--rolling-shutter auto|off]
//
// With --truth (as written by uavstab-render-flight) it also prints the true residual
// jitter of the input and of the output.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>

#include "jitter_metrics.hpp"
#include "truth_csv.hpp"
#include "uavstab/stabilizer.hpp"
#include "y4m.hpp"

using namespace uavstab;

namespace {

// One frame of the clip: the library reads `in` and writes `out`.
class ClipSlot : public FrameSlot {
public:
    ClipSlot(FrameBuffer in, long index) : in_(std::move(in)), index_(index) {}
    FrameView input() override { return in_.view(); }
    std::optional<FrameView> acquireOutput() override
    {
        out_ = FrameBuffer(in_.format(), in_.width(), in_.height());
        return out_.view();
    }
    const FrameBuffer &in() const { return in_; }
    const FrameBuffer &out() const { return out_; }
    long index() const { return index_; }

private:
    FrameBuffer in_, out_;
    long index_;
};


// Left: input, right: output, both I420.
void writeSideBySide(synthetic::Y4mWriter &writer, const FrameBuffer &left, const FrameBuffer &right)
{
    FrameBuffer both(PixelFormat::I420, 2 * left.width(), left.height());
    for (int p = 0; p < 3; ++p) {
        const int w = left.view().planeWidth(p);
        for (int y = 0; y < left.view().planeHeight(p); ++y) {
            std::memcpy(both.row(p, y), left.row(p, y), std::size_t(w));
            std::memcpy(both.row(p, y) + w, right.row(p, y), std::size_t(w));
        }
    }
    writer.write(both.view());
}

} // namespace

int main(int argc, char **argv)
{
    std::string in_path, out_path, sbs_path, truth_path;
    StabilizerConfig config;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::cerr << a << " needs a value\n";
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--side-by-side")
            sbs_path = next();
        else if (a == "--truth")
            truth_path = next();
        else if (a == "--delay")
            config.delay = std::atoi(next().c_str());
        else if (a == "--radius")
            config.smoothing_radius = std::atoi(next().c_str());
        else if (a == "--planner") {
            const std::string p = next();
            config.planner = p == "gaussian" ? PlannerKind::Gaussian
                             : p == "box"    ? PlannerKind::Box
                             : p == "optimal" ? PlannerKind::Optimal
                                              : PlannerKind::L1;
        }
        else if (a == "--crop")
            config.crop = std::atof(next().c_str());
        else if (a == "--rolling-shutter")
            config.rolling_shutter = next() == "off" ? RollingShutter::Off : RollingShutter::Auto;
        else if (in_path.empty())
            in_path = a;
        else if (out_path.empty())
            out_path = a;
        else {
            std::cerr << "usage: uavstab-stabilize-y4m IN.y4m OUT.y4m [--side-by-side SBS.y4m] [--truth CSV]"
                         " [--delay N] [--radius R] [--planner l1|optimal|gaussian|box] [--crop C]"
                         " [--rolling-shutter auto|off]\n";
            return 2;
        }
    }
    if (in_path.empty() || out_path.empty()) {
        std::cerr << "usage: uavstab-stabilize-y4m IN.y4m OUT.y4m [options]\n";
        return 2;
    }

    try {
        synthetic::Y4mReader reader(in_path);
        synthetic::Y4mWriter writer(out_path, reader.width(), reader.height(), reader.fpsNum(), reader.fpsDen());
        std::unique_ptr<synthetic::Y4mWriter> sbs;
        if (!sbs_path.empty())
            sbs = std::make_unique<synthetic::Y4mWriter>(sbs_path, 2 * reader.width(), reader.height(),
                                                         reader.fpsNum(), reader.fpsDen());
        const std::vector<Similarity> truth = truth_path.empty() ? std::vector<Similarity>{} : synthetic::readTruthCsv(truth_path);
        std::vector<Similarity> true_in, true_out;

        Stabilizer stabilizer(config);
        long frames = 0, skipped = 0;
        auto emit = [&](StabilizedFrame f) {
            const auto &slot = static_cast<const ClipSlot &>(*f.slot);
            const FrameBuffer &shown = f.outcome == Outcome::Warped ? slot.out() : slot.in();
            writer.write(shown.view());
            if (sbs)
                writeSideBySide(*sbs, slot.in(), shown);
            skipped += f.stats.skipped;
            if (std::size_t(slot.index()) < truth.size()) {
                true_in.push_back(truth[std::size_t(slot.index())]);
                true_out.push_back(truth[std::size_t(slot.index())] * synthetic::outputToInput(f.stats));
            }
            ++frames;
        };
        FrameBuffer frame;
        for (long i = 0; reader.read(frame); ++i) {
            stabilizer.push(std::make_unique<ClipSlot>(frame, i));
            while (auto f = stabilizer.tryPop())
                emit(std::move(*f));
        }
        stabilizer.flush();
        while (auto f = stabilizer.waitPop())
            emit(std::move(*f));

        std::printf("stabilized %ld frames (%ld without usable motion) -> %s\n", frames, skipped, out_path.c_str());
        if (sbs)
            std::printf("side-by-side (left input, right stabilized) -> %s\n", sbs_path.c_str());
        if (!true_in.empty()) {
            const double a = synthetic::residualJitter(true_in, reader.width(), reader.height());
            const double b = synthetic::residualJitter(true_out, reader.width(), reader.height());
            std::printf("true residual jitter: input %.2f px, output %.2f px (%.0f %% of the shake removed)\n", a, b,
                        100.0 * (1.0 - b / a));
        }
    } catch (const std::exception &e) {
        std::cerr << "uavstab-stabilize-y4m: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
