#include "uavstab/frame_buffer.hpp"

#include <cstring>
#include <stdexcept>

namespace uavstab {

FrameBuffer::FrameBuffer(PixelFormat format, int width, int height, int row_padding)
{
    layout(format, width, height, row_padding);
}

FrameBuffer::FrameBuffer(const FrameBuffer &other)
{
    *this = other;
}

FrameBuffer &FrameBuffer::operator=(const FrameBuffer &other)
{
    if (this != &other) {
        layout(other.format(), other.width(), other.height(), other.row_padding_);
        std::memcpy(storage_.data(), other.storage_.data(), storage_.size());
    }
    return *this;
}

void FrameBuffer::layout(PixelFormat format, int width, int height, int row_padding)
{
    if (width <= 0 || height <= 0 || row_padding < 0)
        throw std::invalid_argument("FrameBuffer: size must be positive");
    row_padding_ = row_padding;
    view_ = FrameView{};
    view_.format = format;
    view_.width = width;
    view_.height = height;
    std::size_t offsets[3] = {};
    std::size_t total = 0;
    for (int p = 0; p < view_.planeCount(); ++p) {
        view_.planes[p].stride = view_.planeRowBytes(p) + row_padding;
        offsets[p] = total;
        total += std::size_t(view_.planes[p].stride) * view_.planeHeight(p);
    }
    storage_.assign(total, 0);
    for (int p = 0; p < view_.planeCount(); ++p)
        view_.planes[p].data = storage_.data() + offsets[p];
}

void FrameBuffer::fill(std::uint8_t value)
{
    std::memset(storage_.data(), value, storage_.size());
}

void FrameBuffer::copyFrom(const FrameView &src)
{
    if (!src.sameGeometry(view_))
        throw std::invalid_argument("FrameBuffer::copyFrom: geometry differs");
    for (int p = 0; p < view_.planeCount(); ++p) {
        const int bytes = view_.planeRowBytes(p);
        for (int y = 0; y < view_.planeHeight(p); ++y)
            std::memcpy(row(p, y), src.planes[p].data + std::size_t(y) * src.planes[p].stride, bytes);
    }
}

} // namespace uavstab
