// Test helpers: a FrameSlot over owned FrameBuffers, carrying an id (how tests feed the
// Stabilizer), and noise frames.
#pragma once

#include <memory>
#include <optional>
#include <random>

#include "uavstab/frame_buffer.hpp"
#include "uavstab/stabilizer.hpp"

namespace uavstab::test {

class BufferSlot : public FrameSlot {
public:
    BufferSlot(FrameBuffer input, int id) : input_(std::move(input)), id_(id) {}

    FrameView input() override { return input_.view(); }
    std::optional<FrameView> acquireOutput() override
    {
        output_ = FrameBuffer(input_.format(), input_.width(), input_.height(), 8);
        return output_.view();
    }

    int id() const { return id_; }
    const FrameBuffer &inputBuffer() const { return input_; }
    const FrameBuffer &outputBuffer() const { return output_; }

    static std::unique_ptr<BufferSlot> make(FrameBuffer input, int id)
    {
        return std::make_unique<BufferSlot>(std::move(input), id);
    }
    static const BufferSlot &of(const StabilizedFrame &f) { return static_cast<const BufferSlot &>(*f.slot); }

private:
    FrameBuffer input_;
    FrameBuffer output_;
    int id_;
};

// Random bytes in every plane (padding included): not a plausible picture, which makes a
// misplaced plane, channel or row show.
inline FrameBuffer noiseFrame(PixelFormat format, int w, int h, unsigned seed, int padding = 0)
{
    FrameBuffer f(format, w, h, padding);
    std::mt19937 rng(seed);
    for (int p = 0; p < f.view().planeCount(); ++p)
        for (int y = 0; y < f.view().planeHeight(p); ++y)
            for (int x = 0; x < f.view().planeRowBytes(p); ++x)
                f.row(p, y)[x] = std::uint8_t(rng());
    return f;
}

} // namespace uavstab::test
