#include "uavstabilize_enums.hpp"

#include "uavstab/config.hpp"
#include "uavstabilize_settings.hpp"

namespace {

// Registers an enum type once, thread-safely.
GType registerEnum(gsize *once, const char *name, const GEnumValue *values)
{
    if (g_once_init_enter(once)) {
        const GType type = g_enum_register_static(name, values);
        g_once_init_leave(once, type);
    }
    return GType(*once);
}

} // namespace

GType uavstabilize_planner_get_type()
{
    static gsize type = 0;
    static const GEnumValue values[] = {
        {int(uavstab::PlannerKind::L1),
         "Still wherever the crop margin allows, steady motion where the camera moves further (default)", "l1"},
        {int(uavstab::PlannerKind::Optimal), "A smooth path that follows the camera's motion inside the crop",
         "optimal"},
        {int(uavstab::PlannerKind::Gaussian), "Gaussian window (sigma = radius / 2), each frame clamped to the crop",
         "gaussian"},
        {int(uavstab::PlannerKind::Box), "The paper's moving average, each frame clamped to the crop", "box"},
        {0, nullptr, nullptr},
    };
    return registerEnum(&type, "GstUavStabilizePlanner", values);
}

GType uavstabilize_model_get_type()
{
    static gsize type = 0;
    static const GEnumValue values[] = {
        {int(uavstab::ModelChoice::Hybrid), "Rigid or similarity, re-chosen every dwell frames", "hybrid"},
        {int(uavstab::ModelChoice::Rigid), "Rigid: translation and rotation (3 DOF)", "rigid"},
        {int(uavstab::ModelChoice::Similarity), "Similarity: translation, rotation and scale (4 DOF)",
         "similarity"},
        {0, nullptr, nullptr},
    };
    return registerEnum(&type, "GstUavStabilizeModel", values);
}

GType uavstabilize_rolling_shutter_get_type()
{
    static gsize type = 0;
    static const GEnumValue values[] = {
        {int(uavstab::RollingShutter::Auto),
         "Remove a rolling shutter's wobble where the footage shows one, leave other footage as it is (default)",
         "auto"},
        {int(uavstab::RollingShutter::Off), "Take every frame as one instant", "off"},
        {0, nullptr, nullptr},
    };
    return registerEnum(&type, "GstUavStabilizeRollingShutter", values);
}

GType uavstabilize_lens_output_get_type()
{
    static gsize type = 0;
    static const GEnumValue values[] = {
        {int(uavstab::LensOutput::Original), "The stabilized picture through the same lens (default)", "original"},
        {int(uavstab::LensOutput::Rectified), "The stabilized picture as a pinhole camera sees it", "rectified"},
        {0, nullptr, nullptr},
    };
    return registerEnum(&type, "GstUavStabilizeLensOutput", values);
}

GType uavstabilize_border_get_type()
{
    static gsize type = 0;
    static const GEnumValue values[] = {
        {int(uavstab::BorderMode::Black), "Uncovered pixels are black", "black"},
        {int(uavstab::BorderMode::Replicate), "Uncovered pixels repeat the nearest edge pixel", "replicate"},
        {0, nullptr, nullptr},
    };
    return registerEnum(&type, "GstUavStabilizeBorder", values);
}

GType uavstabilize_render_get_type()
{
    static gsize type = 0;
    static const GEnumValue values[] = {
        {int(RenderMode::Auto),
         "affine-meta where downstream says it applies GstVideoAffineTransformationMeta (GL elements), else warp "
         "(default)",
         "auto"},
        {int(RenderMode::Warp), "Warp every frame on the CPU into a new buffer", "warp"},
        {int(RenderMode::AffineMeta),
         "No warp: the input buffer goes downstream untouched with a GstVideoAffineTransformationMeta that a GL "
         "element applies when it draws",
         "affine-meta"},
        {0, nullptr, nullptr},
    };
    return registerEnum(&type, "GstUavStabilizeRender", values);
}

GType uavstabilize_enum_type_for_field(const char *field)
{
    // One line per enum field of uavstab::StabilizerConfig (its parameter table row).
    static const struct {
        const char *field;
        GType (*type)();
    } types[] = {
        {"planner", uavstabilize_planner_get_type},
        {"model", uavstabilize_model_get_type},
        {"border", uavstabilize_border_get_type},
        {"rolling_shutter", uavstabilize_rolling_shutter_get_type},
        {"lens_output", uavstabilize_lens_output_get_type},
    };
    for (const auto &entry : types)
        if (g_strcmp0(entry.field, field) == 0)
            return entry.type();
    return G_TYPE_INVALID;
}
