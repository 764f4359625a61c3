// GEnum types for the element's enum properties, so that gst-launch and gst-inspect
// know them by nick ("l1", "optimal", ...). Values are the library's enum values.
#pragma once

#include <glib-object.h>

#define UAVSTABILIZE_TYPE_PLANNER (uavstabilize_planner_get_type())
#define UAVSTABILIZE_TYPE_MODEL (uavstabilize_model_get_type())
#define UAVSTABILIZE_TYPE_BORDER (uavstabilize_border_get_type())
#define UAVSTABILIZE_TYPE_ROLLING_SHUTTER (uavstabilize_rolling_shutter_get_type())
#define UAVSTABILIZE_TYPE_RENDER (uavstabilize_render_get_type())

GType uavstabilize_planner_get_type();   // uavstab::PlannerKind
GType uavstabilize_model_get_type();     // uavstab::ModelChoice
GType uavstabilize_border_get_type();  // uavstab::BorderMode
GType uavstabilize_rolling_shutter_get_type();  // uavstab::RollingShutter
GType uavstabilize_lens_output_get_type();  // uavstab::LensOutput
GType uavstabilize_render_get_type();  // RenderMode (uavstabilize_settings.hpp), the element's own

// The GEnum type of an enum field of uavstab::StabilizerConfig, by field name ("model");
// G_TYPE_INVALID for a field that has none.
GType uavstabilize_enum_type_for_field(const char *field);
