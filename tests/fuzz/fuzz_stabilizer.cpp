// libFuzzer target over the core library: random formats, sizes, strides and pixels,
// and random sequences of push / pop / flush / reset / discontinuity / config changes.
// Checks what must hold whatever the input: no crash, no memory error (ASan/UBSan), and
// every frame pushed and not dropped by reset() comes back exactly once, in order.
//
//   CXX=clang++ meson setup build-fuzz -Dfuzz=true -Db_sanitize=address,undefined
//   build-fuzz/tests/fuzz/fuzz_stabilizer -max_total_time=60 tests/fuzz/corpus
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <iterator>
#include <memory>

#include "uavstab/frame_buffer.hpp"
#include "uavstab/stabilizer.hpp"

using namespace uavstab;

namespace {

class Bytes {
public:
    Bytes(const std::uint8_t *data, std::size_t size) : data_(data), size_(size) {}
    bool empty() const { return pos_ >= size_; }
    std::uint8_t next() { return pos_ < size_ ? data_[pos_++] : 0; }
    int range(int lo, int hi) { return lo + int(next() % unsigned(hi - lo + 1)); }

private:
    const std::uint8_t *data_;
    std::size_t size_;
    std::size_t pos_ = 0;
};

constexpr PixelFormat kFormats[] = {PixelFormat::Gray8, PixelFormat::I420, PixelFormat::YV12, PixelFormat::NV12,
                                    PixelFormat::NV21,  PixelFormat::RGB,  PixelFormat::BGR,  PixelFormat::RGBA,
                                    PixelFormat::BGRA,  PixelFormat::RGBx, PixelFormat::BGRx, PixelFormat::Gray16LE,
                                    PixelFormat::Gray16BE};

class FuzzSlot : public FrameSlot {
public:
    FuzzSlot(FrameBuffer in, long id, int output_mode) : in_(std::move(in)), id_(id), output_mode_(output_mode) {}
    FrameView input() override { return in_.view(); }
    std::optional<FrameView> acquireOutput() override
    {
        switch (output_mode_) {
        case 0:
            return std::nullopt;
        case 1:
            throw std::runtime_error("no buffer");
        default:
            out_ = FrameBuffer(in_.format(), in_.width(), in_.height(), output_mode_ % 7);
            return out_.view();
        }
    }
    long id() const { return id_; }

private:
    FrameBuffer in_, out_;
    long id_;
    int output_mode_;
};

// A textured frame, optionally a shifted copy of a base pattern so that tracking finds
// something, with fuzz bytes sprinkled in.
FrameBuffer makeFrame(Bytes &b, PixelFormat format, int w, int h, int padding, int shift)
{
    FrameBuffer f(format, w, h, padding);
    const int pattern = b.range(0, 3);
    const std::uint8_t seed = b.next();
    for (int p = 0; p < f.view().planeCount(); ++p)
        for (int y = 0; y < f.view().planeHeight(p); ++y) {
            std::uint8_t *row = f.row(p, y);
            for (int x = 0; x < f.view().planeRowBytes(p); ++x) {
                const int xs = x + shift, ys = y + shift / 2;
                switch (pattern) {
                case 0:
                    row[x] = seed;  // uniform
                    break;
                case 1:
                    row[x] = std::uint8_t(((xs / 4) ^ (ys / 4)) * 37 + seed);  // checkers
                    break;
                case 2:
                    row[x] = std::uint8_t((xs * xs + ys * 7) ^ seed);
                    break;
                default:
                    row[x] = b.next();
                    break;
                }
            }
        }
    return f;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size)
{
    Bytes b(data, size);
    StabilizerConfig config;
    config.delay = b.range(0, 12);
    config.smoothing_radius = b.range(0, 12);
    config.planner = PlannerKind(b.next() % 3);
    config.max_corners = b.range(4, 80);
    config.model = ModelChoice(b.range(0, 2));
    config.dwell = b.range(1, 30);
    config.min_points = b.range(2, 20);
    config.crop = b.range(0, 40) / 100.0;
    config.border = b.next() & 1 ? BorderMode::Replicate : BorderMode::Black;
    config.analysis_width = b.range(16, 200);
    config.threads = b.range(1, 3);
    config.redetect_interval = b.range(1, 8);
    config.roi = b.range(10, 100) / 100.0;

    PixelFormat format = kFormats[b.range(0, int(std::size(kFormats)) - 1)];
    int w = b.range(1, 96), h = b.range(1, 72);
    const int padding = b.range(0, 9);

    Stabilizer stabilizer(config);
    std::deque<long> expected;  // pushed, not yet returned, not dropped
    long next_id = 0;
    auto check = [&](const StabilizedFrame &f) {
        const long id = static_cast<const FuzzSlot &>(*f.slot).id();
        if (expected.empty() || expected.front() != id)
            std::abort();  // lost, duplicated or reordered frame
        expected.pop_front();
    };

    for (int ops = 0; !b.empty() && ops < 64; ++ops) {
        switch (b.range(0, 15)) {
        case 0:
            stabilizer.flush();
            while (auto f = stabilizer.waitPop())
                check(*f);
            if (!expected.empty())
                std::abort();
            break;
        case 1:
            stabilizer.reset();
            expected.clear();
            break;
        case 2:
            stabilizer.markDiscontinuity();
            break;
        case 3: {
            StabilizerConfig c = stabilizer.config();
            c.delay = b.range(0, 12);
            c.bypass = b.next() & 1;
            c.crop = b.range(0, 40) / 100.0;
            c.model = ModelChoice(b.range(0, 2));
            stabilizer.setConfig(c);
            break;
        }
        case 4:  // new geometry mid-stream
            format = kFormats[b.range(0, int(std::size(kFormats)) - 1)];
            w = b.range(1, 96);
            h = b.range(1, 72);
            break;
        case 5:
            while (auto f = stabilizer.tryPop())
                check(*f);
            break;
        default: {
            const int shift = b.range(-6, 6);
            stabilizer.push(std::make_unique<FuzzSlot>(makeFrame(b, format, w, h, padding, shift), next_id,
                                                       b.range(0, 9)));
            expected.push_back(next_id++);
            break;
        }
        }
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        check(*f);
    if (!expected.empty())
        std::abort();
    return 0;
}
