// The element's properties: the library's config one to one, plus element-only options.
// Lives under the element's object lock; the streaming thread takes a copy when `dirty`.
#pragma once

#include "uavstab/config.hpp"

// Like GstVideoDecoder's max-errors: consecutive unreadable input buffers dropped with a
// warning before the next one is an error; -1 = never an error.
constexpr int kDefaultMaxErrors = 10;

// How a stabilized frame reaches downstream (the `render` property).
enum class RenderMode {
    Auto = 0,        // AffineMeta where downstream applies the meta, else Warp
    Warp = 1,        // the CPU warp into a new buffer
    AffineMeta = 2,  // the input buffer, untouched, with a GstVideoAffineTransformationMeta
};

struct UavStabilizeSettings {
    uavstab::StabilizerConfig stabilizer;
    bool post_messages = false;
    int max_errors = kDefaultMaxErrors;
    RenderMode render = RenderMode::Auto;
    // Set by every change of `stabilizer`, cleared when the streaming thread applies the
    // config, so that changes in PLAYING reach the stabilizer at the next frame.
    bool dirty = false;
};
