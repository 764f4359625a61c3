#include "uavstab/frame_view.hpp"

namespace uavstab {

int FrameView::planeWidth(int plane) const
{
    const PlaneLayout layout = planeLayout(format, plane);
    return (width + layout.subsample_x - 1) / layout.subsample_x;
}

int FrameView::planeHeight(int plane) const
{
    const PlaneLayout layout = planeLayout(format, plane);
    return (height + layout.subsample_y - 1) / layout.subsample_y;
}

int FrameView::planeRowBytes(int plane) const
{
    const PlaneLayout layout = planeLayout(format, plane);
    return planeWidth(plane) * layout.channels * layout.bytes_per_sample;
}

bool FrameView::valid() const
{
    if (width <= 0 || height <= 0)
        return false;
    for (int p = 0; p < planeCount(); ++p) {
        if (planes[p].data == nullptr || planes[p].stride < planeRowBytes(p))
            return false;
    }
    return true;
}

} // namespace uavstab
