// The element's properties: the library's config one to one, plus element-only options.
// Lives under the element's object lock; the streaming thread takes a copy when `dirty`.
#pragma once

#include "uavstab/config.hpp"

struct UavStabilizeSettings {
    uavstab::StabilizerConfig stabilizer;
    bool post_messages = false;
    // Set by every change of `stabilizer`, cleared when the streaming thread applies the
    // config, so that changes in PLAYING reach the stabilizer at the next frame.
    bool dirty = false;
};
