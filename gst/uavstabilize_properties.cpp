#include "uavstabilize_properties.hpp"

#include <algorithm>
#include <string>

#include <gst/gst.h>

#include "uavstab/config_params.hpp"
#include "uavstabilize_enums.hpp"

namespace gstuavstab {

namespace {

// Property ids: 1..N are the library's parameter table, row by row; the element's own
// properties follow.
guint configPropertyCount()
{
    return guint(uavstab::configParams().size());
}

guint propPostMessages()
{
    return configPropertyCount() + 1;
}

guint propMaxErrors()
{
    return configPropertyCount() + 2;
}

guint propRender()
{
    return configPropertyCount() + 3;
}

constexpr GParamFlags kPlaying =
    GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
constexpr GParamFlags kReady = GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);

// The table row behind a property id, or null for the element's own properties.
const uavstab::ConfigParam *rowFor(guint id)
{
    if (id < 1 || id > configPropertyCount())
        return nullptr;
    return &uavstab::configParams()[id - 1];
}

GParamSpec *specFor(const uavstab::ConfigParam &p)
{
    const char *name = propertyName(p);
    const GParamFlags flags = p.atStartOnly() ? kReady : kPlaying;
    const double d = p.defaultValue();
    switch (p.kind) {
    case uavstab::ParamKind::Int:
        // Unsigned where the range allows no negative value, as the properties always were.
        if (p.min >= 0)
            return g_param_spec_uint(name, p.nick, p.blurb, guint(p.min), guint(p.max), guint(d), flags);
        return g_param_spec_int(name, p.nick, p.blurb, gint(p.min), gint(p.max), gint(d), flags);
    case uavstab::ParamKind::Double:
        return g_param_spec_double(name, p.nick, p.blurb, p.min, p.max, d, flags);
    case uavstab::ParamKind::Bool:
        return g_param_spec_boolean(name, p.nick, p.blurb, d != 0.0, flags);
    case uavstab::ParamKind::String:
        return g_param_spec_string(name, p.nick, p.blurb, g_intern_string(p.defaultText().c_str()), flags);
    case uavstab::ParamKind::Enum: {
        const GType type = uavstabilize_enum_type_for_field(p.name);
        if (type == G_TYPE_INVALID)
            g_error("uavstabilize: no GEnum type for the enum field '%s' (add it to uavstabilize_enums.cpp)", p.name);
        return g_param_spec_enum(name, p.nick, p.blurb, type, gint(d), flags);
    }
    }
    g_error("uavstabilize: field '%s' has an unknown kind", p.name);
    return nullptr;
}

double valueAsDouble(const GValue *value)
{
    if (G_VALUE_HOLDS_UINT(value))
        return double(g_value_get_uint(value));
    if (G_VALUE_HOLDS_INT(value))
        return double(g_value_get_int(value));
    if (G_VALUE_HOLDS_DOUBLE(value))
        return g_value_get_double(value);
    if (G_VALUE_HOLDS_BOOLEAN(value))
        return g_value_get_boolean(value) ? 1.0 : 0.0;
    if (G_VALUE_HOLDS_ENUM(value))
        return double(g_value_get_enum(value));
    g_critical("uavstabilize: unexpected property value type %s", G_VALUE_TYPE_NAME(value));
    return 0.0;
}

void setFromDouble(GValue *value, double v)
{
    if (G_VALUE_HOLDS_UINT(value))
        g_value_set_uint(value, guint(v));
    else if (G_VALUE_HOLDS_INT(value))
        g_value_set_int(value, gint(v));
    else if (G_VALUE_HOLDS_DOUBLE(value))
        g_value_set_double(value, v);
    else if (G_VALUE_HOLDS_BOOLEAN(value))
        g_value_set_boolean(value, v != 0.0);
    else if (G_VALUE_HOLDS_ENUM(value))
        g_value_set_enum(value, gint(v));
    else
        g_critical("uavstabilize: unexpected property value type %s", G_VALUE_TYPE_NAME(value));
}

} // namespace

const char *propertyName(const uavstab::ConfigParam &param)
{
    std::string name = param.name;
    for (char &c : name)
        if (c == '_')
            c = '-';
    return g_intern_string(name.c_str());  // lives as long as the process
}

void installProperties(GObjectClass *gobject_class)
{
    for (guint id = 1; id <= configPropertyCount(); ++id)
        g_object_class_install_property(gobject_class, id, specFor(*rowFor(id)));

    g_object_class_install_property(
        gobject_class, propPostMessages(),
        g_param_spec_boolean("post-messages", "Post messages",
                             "Post an element message 'uavstabilize' per frame with the motion, path and "
                             "correction (angles in radians)",
                             FALSE, kPlaying));
    g_object_class_install_property(
        gobject_class, propMaxErrors(),
        g_param_spec_int("max-errors", "Max errors",
                         "Consecutive input buffers that cannot be read (smaller than the caps, or unmappable) "
                         "dropped with a warning; the next one is an error (-1 = never an error; like the "
                         "video decoders' max-errors)",
                         -1, G_MAXINT, kDefaultMaxErrors, kPlaying));
    g_object_class_install_property(
        gobject_class, propRender(),
        g_param_spec_enum("render", "Render",
                          "How stabilized frames are drawn. warp: on the CPU, into new buffers. affine-meta: not "
                          "at all here: each input buffer goes downstream untouched (no copy) with a "
                          "GstVideoAffineTransformationMeta that GL elements (glimagesink, glvideomixer) apply when "
                          "they draw, which leaves the CPU to the motion estimation; frames whose rolling-shutter "
                          "wobble was found get the transform of their middle row, and debug-overlay draws "
                          "nothing. auto: affine-meta when downstream's ALLOCATION answer lists that meta, else "
                          "warp; frames with a wobble to correct (and debug-overlay) are warped either way",
                          UAVSTABILIZE_TYPE_RENDER, int(RenderMode::Auto), kReady));
}

void markEnumTypesAsPluginApi()
{
    for (const uavstab::ConfigParam &p : uavstab::configParams())
        if (p.kind == uavstab::ParamKind::Enum)
            gst_type_mark_as_plugin_api(uavstabilize_enum_type_for_field(p.name), GstPluginAPIFlags(0));
    gst_type_mark_as_plugin_api(UAVSTABILIZE_TYPE_RENDER, GstPluginAPIFlags(0));
}

bool setProperty(UavStabilizeSettings &settings, guint id, const GValue *value, std::string *refusal)
{
    const uavstab::ConfigParam *text_row = rowFor(id);
    if (text_row && text_row->kind == uavstab::ParamKind::String) {
        // The library parses the text (so both accept the same strings); a refused text
        // leaves the setting as it was.
        const gchar *text = g_value_get_string(value);
        std::string why;
        if (text_row->setText(settings.stabilizer, text ? text : "", &why))
            settings.dirty = true;
        else if (refusal)
            *refusal = std::string(propertyName(*text_row)) + ": '" + (text ? text : "") + "' refused: " + why;
        return true;
    }
    if (const uavstab::ConfigParam *p = rowFor(id)) {
        // GLib 2.74 checks a double property's range in float precision
        // (param_double_is_valid), so a value just outside it (1.0000001 for max 1) gets
        // here unclamped: clamp it, as GLib means to, so that the library sees it in range.
        double v = std::clamp(valueAsDouble(value), p->min, p->max);
        if (p->odd())
            v = double(int(v) | 1);  // e.g. the tracking window has a centre pixel: round up to odd
        p->set(settings.stabilizer, v);
        settings.dirty = true;  // the streaming thread hands it to the stabilizer
    } else if (id == propPostMessages()) {
        settings.post_messages = g_value_get_boolean(value);
    } else if (id == propMaxErrors()) {
        settings.max_errors = g_value_get_int(value);
    } else if (id == propRender()) {
        settings.render = RenderMode(g_value_get_enum(value));
    } else {
        return false;
    }
    return true;
}

bool getProperty(const UavStabilizeSettings &settings, guint id, GValue *value)
{
    const uavstab::ConfigParam *p = rowFor(id);
    if (p && p->kind == uavstab::ParamKind::String)
        g_value_set_string(value, p->getText(settings.stabilizer).c_str());
    else if (p)
        setFromDouble(value, p->get(settings.stabilizer));
    else if (id == propPostMessages())
        g_value_set_boolean(value, settings.post_messages);
    else if (id == propMaxErrors())
        g_value_set_int(value, settings.max_errors);
    else if (id == propRender())
        g_value_set_enum(value, int(settings.render));
    else
        return false;
    return true;
}

} // namespace gstuavstab
