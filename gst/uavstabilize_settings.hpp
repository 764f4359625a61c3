// The element's properties: the library's config one to one, plus element-only options.
// Lives under the element's object lock; the streaming thread takes a copy when `dirty`.
#pragma once

#include "uavstab/config.hpp"

// Like GstVideoDecoder's max-errors: consecutive unreadable input buffers dropped with a
// warning before the next one is an error; -1 = never an error.
constexpr int kDefaultMaxErrors = 10;

struct UavStabilizeSettings {
    uavstab::StabilizerConfig stabilizer;
    bool post_messages = false;
    int max_errors = kDefaultMaxErrors;
    // Set by every change of `stabilizer`, cleared when the streaming thread applies the
    // config, so that changes in PLAYING reach the stabilizer at the next frame.
    bool dirty = false;
};
