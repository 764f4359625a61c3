// The table of StabilizerConfig's fields: name, description, range, kind and how to read
// and write each. It is the one source of truth for settings: StabilizerConfig::validate()
// checks every field against it, and the GStreamer element installs, gets and sets its
// properties from it (property name = field name with '-' for '_').
//
// Adding a tunable: a member of StabilizerConfig (with its default) and one row in
// lib/src/config_params.cpp. An enum field also needs its GEnum type in
// gst/uavstabilize_enums.cpp (the element looks it up by field name). A field that is not a
// number (exclude: a list of rectangles) is a text row (textParam): the library parses and
// checks its text, the element makes a string property of it.
//
// Public API: how a host (the element's properties, a command line) lists, reads and sets
// every field by its name, with the same checks as validate().
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>
#include <vector>

#include "uavstab/config.hpp"

namespace uavstab {

enum class ParamKind {
    Int,     // int field
    Double,  // double field
    Bool,    // bool field
    Enum,    // enum class field with values min..max (contiguous)
    String,  // a field read and written as text (getText/setText/checkText); min = max = 0
};

enum ParamFlags : unsigned {
    kParamNone = 0,
    kParamOdd = 1u << 0,         // an Int that must be odd (the element rounds an even value up)
    kParamAtStartOnly = 1u << 1,  // a running Stabilizer keeps the value it was built with
                                  // (setConfig ignores it until reset()); the element allows
                                  // changing it only in READY or NULL
};

struct ConfigParam {
    const char *name;   // the field's name, e.g. "smoothing_radius"
    const char *nick;   // short human name, e.g. "Smoothing radius"
    const char *blurb;  // one-line description
    ParamKind kind;
    // Inclusive range. Bool: 0..1; Enum: the first..last enumerator's value.
    double min;
    double max;
    unsigned flags;
    // The field's value as a double (bool: 0/1, enum: its underlying value), and back.
    // set() takes a value within [min, max].
    // String rows: get() is 0 and set() does nothing; the text functions below do.
    double (*get)(const StabilizerConfig &);
    void (*set)(StabilizerConfig &, double);
    // String rows only (null otherwise): the field as text; parse the text into the field
    // (false, the field untouched and the reason in *error, for a text it refuses); why the
    // field's value is invalid ("" when it is valid; validate() asks this).
    std::string (*getText)(const StabilizerConfig &) = nullptr;
    bool (*setText)(StabilizerConfig &, const std::string &, std::string *error) = nullptr;
    std::string (*checkText)(const StabilizerConfig &) = nullptr;

    // The field's value in a default-constructed StabilizerConfig (the defaults live in
    // config.hpp, next to each field).
    double defaultValue() const { return get(StabilizerConfig{}); }
    // String rows: the default as text.
    std::string defaultText() const { return getText ? getText(StabilizerConfig{}) : std::string(); }
    bool odd() const { return (flags & kParamOdd) != 0; }
    bool atStartOnly() const { return (flags & kParamAtStartOnly) != 0; }
    // Whether `value` is allowed: within [min, max] (never NaN), a whole number for
    // Int/Bool/Enum, odd where required.
    bool accepts(double value) const;
    // What accepts() allows, for messages: "in [7, 41] and odd".
    std::string rangeText() const;
};

// Every field of StabilizerConfig, in declaration order.
const std::vector<ConfigParam> &configParams();
// The row for a field name ("smoothing_radius"), or null.
const ConfigParam *findConfigParam(const std::string &name);

namespace detail {

inline double noNumber(const StabilizerConfig &)
{
    return 0.0;
}
inline void ignoreNumber(StabilizerConfig &, double) {}

template <typename C, typename T>
T fieldTypeOf(T C::*);
template <auto Member>
using FieldType = decltype(fieldTypeOf(Member));

template <typename T>
constexpr ParamKind kindOf()
{
    if constexpr (std::is_same_v<T, bool>)
        return ParamKind::Bool;
    else if constexpr (std::is_same_v<T, int>)
        return ParamKind::Int;
    else if constexpr (std::is_same_v<T, double>)
        return ParamKind::Double;
    else {
        static_assert(std::is_enum_v<T>, "StabilizerConfig fields are int, double, bool or enum");
        return ParamKind::Enum;
    }
}

template <auto Member>
double getField(const StabilizerConfig &c)
{
    return double(c.*Member);
}

template <auto Member>
void setField(StabilizerConfig &c, double value)
{
    using T = FieldType<Member>;
    if constexpr (std::is_same_v<T, double>)
        c.*Member = value;
    else if constexpr (std::is_same_v<T, bool>)
        c.*Member = value != 0.0;
    else  // int or enum: the nearest whole number, kept within int's range (NaN: 0)
        c.*Member = T(int(std::lround(std::isnan(value) ? 0.0 : std::clamp(value, -2147483648.0, 2147483647.0))));
}

} // namespace detail

// A row for an int, double or enum field: param<&StabilizerConfig::delay>("delay", ...).
template <auto Member>
ConfigParam param(const char *name, const char *nick, const char *blurb, detail::FieldType<Member> min,
                  detail::FieldType<Member> max, unsigned flags = kParamNone)
{
    using T = detail::FieldType<Member>;
    return ConfigParam{name, nick, blurb, detail::kindOf<T>(), double(min), double(max), flags,
                       &detail::getField<Member>, &detail::setField<Member>};
}

// A row for a bool field.
template <auto Member>
ConfigParam flag(const char *name, const char *nick, const char *blurb, unsigned flags = kParamNone)
{
    static_assert(std::is_same_v<detail::FieldType<Member>, bool>, "flag<> is for bool fields");
    return ConfigParam{name, nick, blurb, ParamKind::Bool, 0.0, 1.0, flags, &detail::getField<Member>,
                       &detail::setField<Member>};
}

// A row for a field kept as text: its readers and writers (see ConfigParam).
inline ConfigParam textParam(const char *name, const char *nick, const char *blurb,
                             std::string (*getText)(const StabilizerConfig &),
                             bool (*setText)(StabilizerConfig &, const std::string &, std::string *),
                             std::string (*checkText)(const StabilizerConfig &), unsigned flags = kParamNone)
{
    return ConfigParam{name,   nick, blurb, ParamKind::String, 0.0, 0.0, flags, &detail::noNumber, &detail::ignoreNumber,
                       getText, setText, checkText};
}

} // namespace uavstab
