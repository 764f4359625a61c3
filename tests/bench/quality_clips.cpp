// The clips the quality benchmark runs on: rendered ShakyFlight flights and decoded real
// clips, as I420 frames in memory.
#include <utility>

#include "bench_quality.hpp"

namespace quality {

cv::Mat lumaOf(const FrameBuffer &f)
{
    return cv::Mat(f.height(), f.width(), CV_8UC1, const_cast<std::uint8_t *>(f.row(0, 0)),
                   std::size_t(f.view().planes[0].stride));
}

// A ShakyFlight's frames (I420) with its true and intended poses.
void renderInto(const synthetic::ShakyFlight &flight, Clip *c)
{
    c->width = flight.options().width;
    c->height = flight.options().height;
    for (int i = 0; i < flight.frameCount(); ++i) {
        c->frames.push_back(frameFromBgr(flight.renderBgr(i), PixelFormat::I420));
        c->truth.push_back(flight.truePose(i));
        c->intended.push_back(flight.intendedPose(i));
    }
}

Clip syntheticClip(int width, int height, std::uint32_t seed, int objects, int frames,
                   synthetic::FlightProfile profile)
{
    synthetic::FlightOptions o;
    o.width = width;
    o.height = height;
    o.frames = frames;
    o.seed = seed;
    o.moving_objects = objects;
    o.profile = profile;
    const synthetic::ShakyFlight flight(o);
    Clip c;
    if (profile == synthetic::FlightProfile::Manoeuvre) {
        c.name = format("man_%dx%d_s%u%s", width, height, seed, objects ? "_obj" : "");
        c.label = format("manoeuvre %dx%d seed %u%s", width, height, seed, objects ? ", 3 moving objects" : "");
        c.group = format("manoeuvre %dx%d%s", width, height, objects ? " / moving objects" : "");
    } else {
        c.name = format("syn_%dx%d_s%u%s", width, height, seed, objects ? "_obj" : "");
        c.label = format("synthetic %dx%d seed %u%s", width, height, seed, objects ? ", 3 moving objects" : "");
        c.group = format("%dx%d%s", width, height, objects ? " / moving objects" : "");
    }
    renderInto(flight, &c);
    return c;
}

// Decodes up to max_frames frames of a real clip to I420 in memory.
bool decodeClip(const std::string &path, int max_frames, Clip *c)
{
    DecodedClip d;
    if (!decodeI420(path, max_frames, &d))
        return false;
    c->width = d.width;
    c->height = d.height;
    c->fps_num = d.fps_num;
    c->fps_den = d.fps_den;
    c->frames = std::move(d.frames);
    return true;
}

} // namespace quality
