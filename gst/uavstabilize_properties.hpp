// The element's properties over UavStabilizeSettings: one per row of the library's
// parameter table (uavstab/config_params.hpp: name, range, default, description), plus
// the element's own options. Callers hold the object lock.
#pragma once

#include <string>

#include <glib-object.h>

#include "uavstab/config_params.hpp"
#include "uavstabilize_settings.hpp"

namespace gstuavstab {

void installProperties(GObjectClass *gobject_class);
// The GEnum types of the table's enum fields are plugin API (documented with the element).
void markEnumTypesAsPluginApi();
// False for an id that is not one of ours. A text the library refuses (exclude) leaves the
// setting unchanged and says why in *refusal (for the caller to warn about, unlocked).
bool setProperty(UavStabilizeSettings &settings, guint id, const GValue *value, std::string *refusal = nullptr);
bool getProperty(const UavStabilizeSettings &settings, guint id, GValue *value);
// The property of a table row: the field name with '-' for '_' ("smoothing-radius").
const char *propertyName(const uavstab::ConfigParam &param);

} // namespace gstuavstab
