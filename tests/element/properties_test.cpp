// The element's properties come from the library's parameter table: for
// every row there is a property of the same name (with '-'), its type, range, default
// and mutability are the row's, and the element and the library accept and refuse the
// same values (GLib refuses an out-of-range set with a warning; validate() throws).
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_support.hpp"

#include "uavstab/config_params.hpp"

using namespace element_test;
using uavstab::ConfigParam;
using uavstab::ParamKind;

namespace {

std::string propertyName(const ConfigParam &p)
{
    std::string name = p.name;
    for (char &c : name)
        if (c == '_')
            c = '-';
    return name;
}

GParamSpec *specOf(GstElement *element, const ConfigParam &p)
{
    GParamSpec *spec = g_object_class_find_property(G_OBJECT_GET_CLASS(element), propertyName(p).c_str());
    fail_unless(spec != nullptr, "no property %s for the field %s", propertyName(p).c_str(), p.name);
    return spec;
}

bool libraryAccepts(const ConfigParam &p, double value)
{
    uavstab::StabilizerConfig config;
    p.set(config, value);
    try {
        config.validate();
        return true;
    } catch (const std::invalid_argument &) {
        return false;
    }
}

// The property's current value, as a double.
double elementValue(GstElement *element, const ConfigParam &p)
{
    GParamSpec *spec = specOf(element, p);
    GValue value = G_VALUE_INIT;
    g_value_init(&value, spec->value_type);
    g_object_get_property(G_OBJECT(element), spec->name, &value);
    double v = 0;
    if (G_VALUE_HOLDS_UINT(&value))
        v = g_value_get_uint(&value);
    else if (G_VALUE_HOLDS_INT(&value))
        v = g_value_get_int(&value);
    else if (G_VALUE_HOLDS_DOUBLE(&value))
        v = g_value_get_double(&value);
    else if (G_VALUE_HOLDS_BOOLEAN(&value))
        v = g_value_get_boolean(&value) ? 1 : 0;
    else if (G_VALUE_HOLDS_ENUM(&value))
        v = g_value_get_enum(&value);
    else if (G_VALUE_HOLDS_STRING(&value))
        v = p.get(uavstab::StabilizerConfig{});  // a text row has no number (see elementText)
    else
        fail("unexpected type for %s", spec->name);
    g_value_unset(&value);
    return v;
}

// Sets the property the way an application does (a gint64 or gdouble GValue, which GLib
// converts to the property's type) on a fresh element; true when GLib took the value
// without a warning and reads it back unchanged.
bool elementAccepts(const ConfigParam &p, double v)
{
    GstElement *element = makeStabilizer();
    GParamSpec *spec = specOf(element, p);
    GValue value = G_VALUE_INIT;
    if (p.kind == ParamKind::Double) {
        g_value_init(&value, G_TYPE_DOUBLE);
        g_value_set_double(&value, v);
    } else {
        // Out of an unsigned property's range below 0, the int64 becomes a huge guint.
        g_value_init(&value, G_TYPE_INT64);
        g_value_set_int64(&value, gint64(v));
    }
    _gst_check_expecting_log = TRUE;
    _gst_check_raised_warning = FALSE;
    _gst_check_raised_critical = FALSE;
    g_object_set_property(G_OBJECT(element), spec->name, &value);
    const bool warned = _gst_check_raised_warning || _gst_check_raised_critical;
    _gst_check_expecting_log = FALSE;
    _gst_check_raised_warning = FALSE;
    _gst_check_raised_critical = FALSE;
    g_value_unset(&value);
    const bool accepted = !warned && elementValue(element, p) == v;
    gst_object_unref(element);
    return accepted;
}

// A text property's current value.
std::string elementText(GstElement *element, const ConfigParam &p)
{
    gchar *text = nullptr;
    g_object_get(element, specOf(element, p)->name, &text, nullptr);
    std::string value = text ? text : "";
    g_free(text);
    return value;
}

// Sets a text property on `element` as gst-launch does; true when it was taken without a
// warning. A refused text must leave the value as it was.
bool elementAcceptsText(GstElement *element, const ConfigParam &p, const std::string &text)
{
    const std::string before = elementText(element, p);
    _gst_check_expecting_log = TRUE;
    _gst_check_raised_warning = FALSE;
    _gst_check_raised_critical = FALSE;
    g_object_set(element, specOf(element, p)->name, text.c_str(), nullptr);
    const bool warned = _gst_check_raised_warning || _gst_check_raised_critical;
    _gst_check_expecting_log = FALSE;
    _gst_check_raised_warning = FALSE;
    _gst_check_raised_critical = FALSE;
    if (warned) {
        const std::string now = elementText(element, p);  // named: the macro keeps the pointer
        fail_unless_equals_string(now.c_str(), before.c_str());
    }
    return !warned;
}

double below(const ConfigParam &p)
{
    return p.kind == ParamKind::Double ? std::nextafter(p.min, -std::numeric_limits<double>::infinity()) : p.min - 1;
}

double above(const ConfigParam &p)
{
    return p.kind == ParamKind::Double ? std::nextafter(p.max, std::numeric_limits<double>::infinity()) : p.max + 1;
}

// A property set to every row's min (or max) on an element that then stabilizes a few
// frames: the library takes the whole config (no "invalid settings" warning).
void runWithEveryPropertyAt(bool at_max)
{
    GstElement *element = makeStabilizer();
    for (const ConfigParam &p : uavstab::configParams()) {
        double v = at_max ? p.max : p.min;
        if (p.kind == ParamKind::Int && std::string(p.name) == "threads" && at_max)
            v = 8;  // 64 threads work too, but are slow to start under the sanitizers
        GValue value = G_VALUE_INIT;
        g_value_init(&value, specOf(element, p)->value_type);
        if (G_VALUE_HOLDS_STRING(&value))  // exclude: none, or a full frame's worth (lens-profile: lens_test.cpp)
            g_value_set_string(&value, at_max && std::string(p.name) == "exclude"
                                           ? "0,0,1,0.1;0.45,0.45,0.1,0.1;0,0.9,1,0.1;0,0,0.2,1"
                                           : "");
        else if (G_VALUE_HOLDS_UINT(&value))
            g_value_set_uint(&value, guint(v));
        else if (G_VALUE_HOLDS_INT(&value))
            g_value_set_int(&value, gint(v));
        else if (G_VALUE_HOLDS_DOUBLE(&value))
            g_value_set_double(&value, v);
        else if (G_VALUE_HOLDS_BOOLEAN(&value))
            g_value_set_boolean(&value, v != 0);
        else
            g_value_set_enum(&value, gint(v));
        g_object_set_property(G_OBJECT(element), propertyName(p).c_str(), &value);
        g_value_unset(&value);
    }
    GstHarness *h = makeHarness(element);
    GstBus *bus = gst_bus_new();
    gst_element_set_bus(h->element, bus);
    GstCaps *caps = videoCaps("I420", 64, 48);
    const GstVideoInfo info = videoInfo(caps);
    gst_harness_set_src_caps(h, caps);
    gst_harness_set_drop_buffers(h, TRUE);
    StreamLog log(h->sinkpad);
    const int frames = 6;
    for (int i = 0; i < frames; ++i)
        fail_unless_equals_int(gst_harness_push(h, makeFrame(info, i)), GST_FLOW_OK);
    fail_unless(gst_harness_push_event(h, gst_event_new_eos()));
    fail_unless(log.waitForEos());
    fail_unless_equals_int(int(log.buffers().size()), frames);
    GstMessage *message = gst_bus_pop_filtered(bus, GstMessageType(GST_MESSAGE_WARNING | GST_MESSAGE_ERROR));
    if (message) {
        GError *error = nullptr;
        gchar *debug = nullptr;
        if (GST_MESSAGE_TYPE(message) == GST_MESSAGE_WARNING)
            gst_message_parse_warning(message, &error, &debug);
        else
            gst_message_parse_error(message, &error, &debug);
        fail("every property at its %s: %s (%s)", at_max ? "max" : "min", error->message, debug);
    }
    gst_element_set_bus(h->element, nullptr);
    gst_object_unref(bus);
    gst_harness_teardown(h);
}

} // namespace

ELEMENT_TEST(every_config_field_is_a_property_with_its_range_and_default)
{
    GstElement *element = makeStabilizer();
    const uavstab::StabilizerConfig defaults;
    for (const ConfigParam &p : uavstab::configParams()) {
        GParamSpec *spec = specOf(element, p);
        const char *name = spec->name;
        // The table's default is the struct's, and the property's and a fresh element's.
        fail_unless_equals_float(p.defaultValue(), p.get(defaults));
        fail_unless(elementValue(element, p) == p.defaultValue(), "%s: element value %g, library default %g", name,
                    elementValue(element, p), p.defaultValue());
        fail_unless_equals_string(g_param_spec_get_nick(spec), p.nick);
        fail_unless_equals_string(g_param_spec_get_blurb(spec), p.blurb);
        const guint mutability = p.atStartOnly() ? GST_PARAM_MUTABLE_READY : GST_PARAM_MUTABLE_PLAYING;
        fail_unless((spec->flags & mutability) != 0, "%s: wrong mutability", name);
        switch (p.kind) {
        case ParamKind::Int:
            if (G_IS_PARAM_SPEC_UINT(spec)) {
                fail_unless(p.min >= 0, "%s: unsigned with a negative min", name);
                fail_unless_equals_float(G_PARAM_SPEC_UINT(spec)->minimum, p.min);
                fail_unless_equals_float(G_PARAM_SPEC_UINT(spec)->maximum, p.max);
                fail_unless_equals_float(G_PARAM_SPEC_UINT(spec)->default_value, p.defaultValue());
            } else {
                fail_unless(G_IS_PARAM_SPEC_INT(spec), "%s: not an integer property", name);
                fail_unless_equals_float(G_PARAM_SPEC_INT(spec)->minimum, p.min);
                fail_unless_equals_float(G_PARAM_SPEC_INT(spec)->maximum, p.max);
                fail_unless_equals_float(G_PARAM_SPEC_INT(spec)->default_value, p.defaultValue());
            }
            break;
        case ParamKind::Double:
            fail_unless(G_IS_PARAM_SPEC_DOUBLE(spec), "%s: not a double property", name);
            fail_unless(G_PARAM_SPEC_DOUBLE(spec)->minimum == p.min, "%s: min", name);
            fail_unless(G_PARAM_SPEC_DOUBLE(spec)->maximum == p.max, "%s: max", name);
            fail_unless(G_PARAM_SPEC_DOUBLE(spec)->default_value == p.defaultValue(), "%s: default", name);
            break;
        case ParamKind::Bool:
            fail_unless(G_IS_PARAM_SPEC_BOOLEAN(spec), "%s: not a boolean property", name);
            fail_unless_equals_int(G_PARAM_SPEC_BOOLEAN(spec)->default_value, p.defaultValue() != 0);
            break;
        case ParamKind::Enum: {
            fail_unless(G_IS_PARAM_SPEC_ENUM(spec), "%s: not an enum property", name);
            GEnumClass *klass = G_PARAM_SPEC_ENUM(spec)->enum_class;
            fail_unless_equals_int(klass->minimum, int(p.min));
            fail_unless_equals_int(klass->maximum, int(p.max));
            for (int v = int(p.min); v <= int(p.max); ++v)
                fail_unless(g_enum_get_value(klass, v) != nullptr, "%s: no enum value %d", name, v);
            fail_unless_equals_int(G_PARAM_SPEC_ENUM(spec)->default_value, int(p.defaultValue()));
            break;
        }
        case ParamKind::String:
            fail_unless(G_IS_PARAM_SPEC_STRING(spec), "%s: not a string property", name);
        {
            // Named: fail_unless_equals_string keeps the pointers past the full expression.
            const std::string default_text = p.defaultText(), element_text = elementText(element, p);
            fail_unless_equals_string(G_PARAM_SPEC_STRING(spec)->default_value, default_text.c_str());
            fail_unless_equals_string(element_text.c_str(), default_text.c_str());
            break;
        }
        }
    }
    // The element's own properties are not in the table.
    fail_unless(uavstab::findConfigParam("post_messages") == nullptr);
    fail_unless(uavstab::findConfigParam("max_errors") == nullptr);
    fail_unless(g_object_class_find_property(G_OBJECT_GET_CLASS(element), "post-messages") != nullptr);
    fail_unless(g_object_class_find_property(G_OBJECT_GET_CLASS(element), "max-errors") != nullptr);
    gst_object_unref(element);
}

// render (the element's own): auto by default, its three nicks, settable before the stream.
ELEMENT_TEST(render_is_an_enum_with_auto_by_default)
{
    GstElement *element = makeStabilizer();
    fail_unless(uavstab::findConfigParam("render") == nullptr);
    GParamSpec *spec = g_object_class_find_property(G_OBJECT_GET_CLASS(element), "render");
    fail_unless(spec != nullptr && G_IS_PARAM_SPEC_ENUM(spec));
    fail_unless(spec->flags & GST_PARAM_MUTABLE_READY);
    GEnumClass *values = G_PARAM_SPEC_ENUM(spec)->enum_class;
    fail_unless_equals_string(g_enum_get_value(values, G_PARAM_SPEC_ENUM(spec)->default_value)->value_nick, "auto");
    for (const char *nick : {"warp", "affine-meta", "auto"}) {
        const GEnumValue *value = g_enum_get_value_by_nick(values, nick);
        fail_unless(value != nullptr, "no render=%s", nick);
        setProperties(element, std::string("render=") + nick);
        gint current = -1;
        g_object_get(element, "render", &current, nullptr);
        fail_unless_equals_int(current, value->value);
    }
    gst_object_unref(element);
}

ELEMENT_TEST(element_and_library_accept_and_refuse_the_same_values)
{
    for (const ConfigParam &p : uavstab::configParams()) {
        if (p.kind != ParamKind::Int && p.kind != ParamKind::Double)
            continue;
        // Below an unsigned property's 0 (min 0) the int64 -1 turns into a guint out of
        // range, refused like any other.
        std::vector<double> values = {p.min, p.max, below(p), above(p), p.defaultValue()};
        if (p.kind == ParamKind::Double) {
            // GLib 2.74 checks double ranges in float precision: the next double outside
            // passes its check (the element clamps it), the next float outside does not.
            const float inf = std::numeric_limits<float>::infinity();
            values.push_back(double(std::nextafter(float(p.min), -inf)));
            values.push_back(double(std::nextafter(float(p.max), inf)));
        }
        for (const double v : values) {
            const bool library = libraryAccepts(p, v);
            const bool element = elementAccepts(p, v);
            fail_unless(library == element, "%s = %.17g: the library %s it, the element %s it", p.name, v,
                        library ? "accepts" : "refuses", element ? "accepts" : "refuses");
            const bool inside = v >= p.min && v <= p.max;
            fail_unless(library == inside, "%s = %.17g: %s", p.name, v, library ? "accepted" : "refused");
        }
    }
}

// The one deliberate difference: the library refuses an even tracking window, the
// element rounds it up to the next odd value (a window has a centre pixel).
ELEMENT_TEST(an_even_tracking_window_is_rounded_up_by_the_element)
{
    const ConfigParam &p = *uavstab::findConfigParam("tracking_window");
    GstElement *element = makeStabilizer();
    for (int w = int(p.min); w <= int(p.max); ++w) {
        g_object_set(element, "tracking-window", guint(w), nullptr);
        const double set = elementValue(element, p);
        fail_unless_equals_int(int(set), w | 1);
        fail_unless(libraryAccepts(p, set));
        fail_unless_equals_int(libraryAccepts(p, w), w % 2 == 1);
    }
    gst_object_unref(element);
}

// Text properties (exclude): the element takes exactly the strings the library's parser
// takes, reads back the library's text of them, and refuses the others with a warning,
// keeping the previous value.
ELEMENT_TEST(element_and_library_accept_and_refuse_the_same_strings)
{
    const char *texts[] = {
        "", "0,0,1,0.1;0.45,0.45,0.1,0.1", " 0.1 , 0.2,0.3 ,0.4 ; ", ";;", "0,0,1,1", "+.5,0,5e-1,1e0",
        "0,0,1", "0,0,1,0.1,0.2", "a,0,1,0.1", "0,0,0,0.1", "-0.1,0,0.5,0.5", "0.6,0,0.5,0.1",
        "nan,0,1,0.1", "0,0,inf,0.1", "0,0,1,0.1;garbage", "0 0 1 0.1", "0,0,1,0.1x",
    };
    bool any_text_row = false;
    for (const ConfigParam &p : uavstab::configParams()) {
        if (p.kind != ParamKind::String)
            continue;
        any_text_row = true;
        GstElement *element = makeStabilizer();
        for (const char *text : texts) {
            uavstab::StabilizerConfig config;
            std::string why;
            const bool library = p.setText(config, text, &why);
            const bool element_took = elementAcceptsText(element, p, text);
            fail_unless(library == element_took, "%s = '%s': the library %s it, the element %s it", p.name, text,
                        library ? "accepts" : "refuses", element_took ? "accepts" : "refuses");
            if (library) {
                const std::string element_text = elementText(element, p), library_text = p.getText(config);
                fail_unless_equals_string(element_text.c_str(), library_text.c_str());
                config.validate();  // what the element hands on is valid
            }
        }
        gst_object_unref(element);
    }
    fail_unless(any_text_row, "no text row in the table (exclude)");
}

ELEMENT_TEST(every_property_at_its_min_runs)
{
    runWithEveryPropertyAt(false);
}

ELEMENT_TEST(every_property_at_its_max_runs)
{
    runWithEveryPropertyAt(true);
}

GST_START_TEST(warm_up)
{
    runWithEveryPropertyAt(false);
}
GST_END_TEST;

int main(int argc, char **argv)
{
    gst_check_init(&argc, &argv);
    Suite *s = suite_create("uavstabilize-properties");
    TCase *tc = makeTestCase("properties");
    suite_add_tcase(s, tc);
    tcase_add_test(tc, warm_up);
    tcase_add_test(tc, every_config_field_is_a_property_with_its_range_and_default);
    tcase_add_test(tc, element_and_library_accept_and_refuse_the_same_values);
    tcase_add_test(tc, an_even_tracking_window_is_rounded_up_by_the_element);
    tcase_add_test(tc, element_and_library_accept_and_refuse_the_same_strings);
    tcase_add_test(tc, render_is_an_enum_with_auto_by_default);
    tcase_add_test(tc, every_property_at_its_min_runs);
    tcase_add_test(tc, every_property_at_its_max_runs);
    return runSuite(s) == 0 ? 0 : 1;
}
