// The element's properties over UavStabilizeSettings: the library's config one to one
// (with its defaults), plus element options. Callers hold the object lock.
#pragma once

#include <glib-object.h>

#include "uavstabilize_settings.hpp"

namespace gstuavstab {

void installProperties(GObjectClass *gobject_class);
// False for an id that is not one of ours.
bool setProperty(UavStabilizeSettings &settings, guint id, const GValue *value);
bool getProperty(const UavStabilizeSettings &settings, guint id, GValue *value);

} // namespace gstuavstab
