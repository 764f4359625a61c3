// StabilizerConfig's parameter table (config_params.hpp) and validate(): every field is
// checked against its row, at both ends of its range and just outside, with a message
// that names the field and the range. The element's side of the same contract is
// tests/element/properties_test.cpp.
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "uavstab/config.hpp"
#include "uavstab/config_params.hpp"

using namespace uavstab;

namespace {

// validate()'s message, or "" when it accepts.
std::string refusal(const StabilizerConfig &config)
{
    try {
        config.validate();
        return "";
    } catch (const std::invalid_argument &e) {
        return e.what();
    }
}

StabilizerConfig withValue(const ConfigParam &p, double value)
{
    StabilizerConfig config;
    p.set(config, value);
    return config;
}

// Just below min and just above max: the next representable value for a double, the next
// whole number otherwise.
double below(const ConfigParam &p)
{
    return p.kind == ParamKind::Double ? std::nextafter(p.min, -std::numeric_limits<double>::infinity()) : p.min - 1;
}

double above(const ConfigParam &p)
{
    return p.kind == ParamKind::Double ? std::nextafter(p.max, std::numeric_limits<double>::infinity()) : p.max + 1;
}

} // namespace

TEST(ConfigParams, RowsAreWellFormed)
{
    std::set<std::string> names;
    for (const ConfigParam &p : configParams()) {
        SCOPED_TRACE(p.name);
        EXPECT_TRUE(names.insert(p.name).second) << "duplicate row";
        EXPECT_EQ(std::string(p.name).find_first_not_of("abcdefghijklmnopqrstuvwxyz_"), std::string::npos);
        EXPECT_TRUE(p.nick && *p.nick);
        EXPECT_TRUE(p.blurb && *p.blurb);
        EXPECT_LE(p.min, p.max);
        EXPECT_TRUE(p.accepts(p.min) || p.odd());
        EXPECT_EQ(findConfigParam(p.name), &p);
        if (p.kind == ParamKind::Bool) {
            EXPECT_EQ(p.min, 0.0);
            EXPECT_EQ(p.max, 1.0);
        }
        // Text rows, and only they, have the text functions.
        const bool text = p.kind == ParamKind::String;
        EXPECT_EQ(p.getText != nullptr, text);
        EXPECT_EQ(p.setText != nullptr, text);
        EXPECT_EQ(p.checkText != nullptr, text);
    }
    EXPECT_EQ(findConfigParam("no_such_field"), nullptr);
}

TEST(ConfigParams, DefaultsAreTheStructsAndValid)
{
    const StabilizerConfig defaults;
    EXPECT_EQ(refusal(defaults), "");
    for (const ConfigParam &p : configParams()) {
        SCOPED_TRACE(p.name);
        EXPECT_EQ(p.defaultValue(), p.get(defaults));
        EXPECT_TRUE(p.accepts(p.defaultValue()));
    }
    // The documented defaults (README, config.hpp), through the table.
    EXPECT_EQ(findConfigParam("delay")->defaultValue(), 20);
    EXPECT_EQ(findConfigParam("smoothing_radius")->defaultValue(), 20);
    EXPECT_EQ(findConfigParam("planner")->defaultValue(), double(PlannerKind::L1));
    EXPECT_EQ(findConfigParam("planner_smoothness")->defaultValue(), 100000.0);
    EXPECT_EQ(findConfigParam("adaptive_zoom")->defaultValue(), 0.0);
    EXPECT_EQ(findConfigParam("max_corners")->defaultValue(), 50);
    EXPECT_EQ(findConfigParam("roi")->defaultValue(), 0.8);
    EXPECT_EQ(findConfigParam("redetect_interval")->defaultValue(), 5);
    EXPECT_EQ(findConfigParam("fb_threshold")->defaultValue(), 1.0);
    EXPECT_EQ(findConfigParam("tracking_window")->defaultValue(), 21);
    EXPECT_EQ(findConfigParam("model")->defaultValue(), double(ModelChoice::Hybrid));
    EXPECT_EQ(findConfigParam("dwell")->defaultValue(), 20);
    EXPECT_EQ(findConfigParam("min_points")->defaultValue(), 10);
    EXPECT_EQ(findConfigParam("crop")->defaultValue(), 0.08);
    EXPECT_EQ(findConfigParam("limit_to_crop")->defaultValue(), 1.0);
    EXPECT_EQ(findConfigParam("border")->defaultValue(), double(BorderMode::Black));
    EXPECT_EQ(findConfigParam("analysis_width")->defaultValue(), 640);
    EXPECT_EQ(findConfigParam("threads")->defaultValue(), 0);
    EXPECT_EQ(findConfigParam("bypass")->defaultValue(), 0.0);
    EXPECT_EQ(findConfigParam("debug_overlay")->defaultValue(), 0.0);
    EXPECT_EQ(findConfigParam("exclude")->defaultText(), "");
}

TEST(ConfigParams, GetAndSetReachTheField)
{
    StabilizerConfig c;
    findConfigParam("delay")->set(c, 7);
    findConfigParam("roi")->set(c, 0.25);
    findConfigParam("model")->set(c, double(ModelChoice::Similarity));
    findConfigParam("bypass")->set(c, 1);
    findConfigParam("tracking_window")->set(c, 19);
    EXPECT_EQ(c.delay, 7);
    EXPECT_EQ(c.roi, 0.25);
    EXPECT_EQ(c.model, ModelChoice::Similarity);
    EXPECT_TRUE(c.bypass);
    EXPECT_EQ(c.tracking_window, 19);
    EXPECT_EQ(findConfigParam("roi")->get(c), 0.25);
    EXPECT_EQ(findConfigParam("model")->get(c), 2.0);
    EXPECT_EQ(StabilizerConfig().delay, 20);  // the defaults are untouched
}

// Both ends of every range are accepted, just outside is refused, with one message
// naming the field and its range.
TEST(ConfigValidate, EveryFieldAtAndJustOutsideItsRange)
{
    for (const ConfigParam &p : configParams()) {
        if (p.kind == ParamKind::Bool || p.kind == ParamKind::String)
            continue;  // a bool has no value outside its range; text: exclude_test.cpp
        SCOPED_TRACE(p.name);
        EXPECT_EQ(refusal(withValue(p, p.min)), "");
        EXPECT_EQ(refusal(withValue(p, p.max)), "");
        for (const double bad : {below(p), above(p)}) {
            const std::string message = refusal(withValue(p, bad));
            EXPECT_EQ(message.rfind(std::string("StabilizerConfig: ") + p.name + " must be " + p.rangeText(), 0), 0u)
                << message;
        }
        if (p.kind == ParamKind::Double) {
            EXPECT_NE(refusal(withValue(p, std::nan(""))), "");
        }
    }
}

TEST(ConfigValidate, MessagesNameTheFieldTheRangeAndTheValue)
{
    StabilizerConfig c;
    c.roi = 0.05;
    EXPECT_EQ(refusal(c), "StabilizerConfig: roi must be in [0.1, 1] (got 0.05)");
    c = {};
    c.analysis_width = 16385;
    EXPECT_EQ(refusal(c), "StabilizerConfig: analysis_width must be in [16, 16384] (got 16385)");
    c = {};
    c.tracking_window = 20;
    EXPECT_EQ(refusal(c), "StabilizerConfig: tracking_window must be in [7, 41] and odd (got 20)");
    c = {};
    c.model = ModelChoice(7);
    EXPECT_EQ(refusal(c), "StabilizerConfig: model must be in [0, 2] (got 7)");
}

// The table's ranges (which validate() and the element's properties both use) for the
// fields whose limits the element and the library must agree on.
TEST(ConfigValidate, TableRangesOfSharedFields)
{
    const struct {
        const char *name;
        double min, max;
    } expected[] = {
        {"roi", 0.1, 1.0},           {"fb_threshold", 0.01, 100.0}, {"analysis_width", 16, 16384},
        {"redetect_interval", 1, 1000}, {"dwell", 1, 100000},        {"min_points", 2, 200},
    };
    for (const auto &e : expected) {
        SCOPED_TRACE(e.name);
        const ConfigParam *p = findConfigParam(e.name);
        ASSERT_NE(p, nullptr);
        EXPECT_EQ(p->min, e.min);
        EXPECT_EQ(p->max, e.max);
    }
}

TEST(ConfigValidate, TrackingWindowMustBeOdd)
{
    const ConfigParam &p = *findConfigParam("tracking_window");
    EXPECT_TRUE(p.odd());
    for (int w = 7; w <= 41; ++w)
        EXPECT_EQ(refusal(withValue(p, w)).empty(), w % 2 == 1) << w;
}

TEST(ConfigValidate, OnlyThreadsAndTheLensAreFixedWhileRunning)
{
    for (const ConfigParam &p : configParams()) {
        const std::string name = p.name;
        EXPECT_EQ(p.atStartOnly(), name == "threads" || name == "lens_profile" || name == "lens_output") << name;
    }
}
