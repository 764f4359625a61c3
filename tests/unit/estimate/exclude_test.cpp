// Excluded regions (StabilizerConfig::exclude, the element's `exclude`): the text form
// (good and bad strings, the same for the table row the element uses), the detection mask
// and track filter, and what it is for: a hazy synthetic flight with a screen-fixed OSD
// burned in (text bars, side boxes, a crosshair and a pitch ladder in the centre), whose
// residual jitter with the OSD excluded is within a small margin of the flight without OSD.
// Also the debug overlay's drawing (debug_overlay.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <optional>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "buffer_slot.hpp"
#include "format_conversion.hpp"
#include "jitter_metrics.hpp"
#include "osd.hpp"
#include "shaky_flight.hpp"
#include "uavstab/config_params.hpp"
#include "render/debug_overlay.hpp"
#include "estimate/exclude_regions.hpp"
#include "estimate/feature_tracker.hpp"
#include "uavstab/stabilizer.hpp"

using namespace uavstab;

namespace {

std::string refusal(const StabilizerConfig &config)
{
    try {
        config.validate();
        return "";
    } catch (const std::invalid_argument &e) {
        return e.what();
    }
}

bool parses(const std::string &text, std::vector<RectF> *out = nullptr)
{
    std::vector<RectF> rects;
    std::string error;
    const bool ok = parseRects(text, rects, &error);
    EXPECT_EQ(ok, error.empty()) << text;
    if (out)
        *out = rects;
    return ok;
}

} // namespace

// --- The text form ------------------------------------------------------------------

TEST(ExcludeText, GoodStrings)
{
    std::vector<RectF> r;
    ASSERT_TRUE(parses("0,0,1,0.1;0.45,0.45,0.1,0.1", &r));
    ASSERT_EQ(r.size(), 2u);
    EXPECT_EQ(r[0], (RectF{0, 0, 1, 0.1}));
    EXPECT_EQ(r[1], (RectF{0.45, 0.45, 0.1, 0.1}));
    ASSERT_TRUE(parses("", &r));
    EXPECT_TRUE(r.empty());
    ASSERT_TRUE(parses("  ;  ", &r));
    EXPECT_TRUE(r.empty());
    ASSERT_TRUE(parses(" 0.1 , 0.2,0.3 ,0.4 ; ", &r));  // spaces, a trailing ';'
    ASSERT_EQ(r.size(), 1u);
    EXPECT_EQ(r[0], (RectF{0.1, 0.2, 0.3, 0.4}));
    ASSERT_TRUE(parses("0,0,1,1;;+.5,0,5e-1,1e0", &r));  // an empty group, other spellings
    ASSERT_EQ(r.size(), 2u);
    EXPECT_EQ(r[1], (RectF{0.5, 0, 0.5, 1}));
    EXPECT_TRUE(parses("0.9,0.9,0.1,0.1"));  // reaches the corner exactly (0.9 + 0.1 in doubles)
    EXPECT_TRUE(parses("0.7,0.7,0.3,0.3"));
}

TEST(ExcludeText, BadStringsAreRefusedWithAReasonAndLeaveTheListAlone)
{
    const char *bad[] = {
        "0,0,1",           // three numbers
        "0,0,1,0.1,0.2",   // five
        "0,0,1,",          // an empty number
        "a,0,1,0.1",       // not a number
        "0,0,1,0.1x",      // trailing junk
        "0;0;1;0.1",       // wrong separators
        "0 0 1 0.1",       // spaces are not separators
        "0,0,0,0.1",       // zero width
        "0,0,0.1,0",       // zero height
        "-0.1,0,0.5,0.5",  // outside [0, 1]
        "0,0,1.5,0.1",     // too wide
        "0.6,0,0.5,0.1",   // reaches past the right edge
        "0,0.95,1,0.1",    // past the bottom
        "nan,0,1,0.1",     // NaN
        "0,0,inf,0.1",     // infinity
        "0,0,1,0.1;0,0,1", // one good, one bad: all refused
        "0,0,1,0.1;garbage",
        "0x1,0,1,0.1",
        "0,0,1e400,0.1",   // overflow
    };
    for (const char *text : bad) {
        std::vector<RectF> rects = {{0.25, 0.25, 0.5, 0.5}};
        std::string error;
        EXPECT_FALSE(parseRects(text, rects, &error)) << text;
        EXPECT_FALSE(error.empty()) << text;
        ASSERT_EQ(rects.size(), 1u) << text;
        EXPECT_EQ(rects[0], (RectF{0.25, 0.25, 0.5, 0.5})) << text;
    }
    // Too many rectangles.
    std::string many;
    for (int i = 0; i <= kMaxExcludeRects; ++i)
        many += "0,0,0.1,0.1;";
    EXPECT_FALSE(parses(many));
    many.resize(many.size() - 12);
    EXPECT_TRUE(parses(many));
}

TEST(ExcludeText, FormatReadsBackToTheSameNumbers)
{
    const std::vector<RectF> rects = {{0, 0, 1, 0.1}, {0.45, 0.45, 0.1, 0.1}, {1.0 / 3, 0.2, 1.0 / 7, 0.123456789}};
    const std::string text = formatRects(rects);
    EXPECT_EQ(text.substr(0, 29), "0,0,1,0.1;0.45,0.45,0.1,0.1;0");
    std::vector<RectF> back;
    ASSERT_TRUE(parses(text, &back));
    EXPECT_EQ(back, rects);
    EXPECT_EQ(formatRects({}), "");
}

TEST(ExcludeText, TheTableRowIsTheParserAndValidateChecksTheField)
{
    const ConfigParam *p = findConfigParam("exclude");
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->kind, ParamKind::String);
    EXPECT_EQ(p->defaultText(), "");
    EXPECT_FALSE(p->atStartOnly());
    StabilizerConfig c;
    std::string error;
    ASSERT_TRUE(p->setText(c, "0,0,1,0.1;0.45,0.45,0.1,0.1", &error)) << error;
    EXPECT_EQ(c.exclude.size(), 2u);
    EXPECT_EQ(p->getText(c), "0,0,1,0.1;0.45,0.45,0.1,0.1");
    EXPECT_EQ(refusal(c), "");
    EXPECT_FALSE(p->setText(c, "0,0,2,0.1", &error));
    EXPECT_EQ(c.exclude.size(), 2u);  // unchanged
    // A field set in code, not through the text, is checked by validate().
    c.exclude.push_back({0.5, 0.5, 0.6, 0.1});
    EXPECT_EQ(refusal(c).rfind("StabilizerConfig: exclude: rectangle 0.5,0.5,0.6,0.1", 0), 0u) << refusal(c);
    c.exclude.back() = {0.5, 0.5, 0.0, 0.1};
    EXPECT_NE(refusal(c), "");
    c.exclude.back() = {std::nan(""), 0.5, 0.1, 0.1};
    EXPECT_NE(refusal(c), "");
    EXPECT_THROW(Stabilizer{c}, std::invalid_argument);
    c.exclude.pop_back();
    Stabilizer s(c);
    c.exclude.push_back({0.5, 0.5, 0.6, 0.1});
    EXPECT_THROW(s.setConfig(c), std::invalid_argument);
}

// --- The mask and the filter ----------------------------------------------------------

TEST(Exclude, NoTrackInsideAnExcludedRegion)
{
    synthetic::FlightOptions options;
    options.frames = 30;
    const synthetic::ShakyFlight flight(options);
    StabilizerConfig config;
    config.exclude = {{0.0, 0.0, 0.5, 1.0}, {0.6, 0.4, 0.2, 0.2}};
    FeatureTracker tracker(config);
    const double w = options.width, h = options.height;
    int seen = 0;
    for (int i = 0; i < options.frames; ++i) {
        const PointMatches m = tracker.track(flight.render(i).view());
        for (const auto *points : {&m.previous, &m.current})
            for (const Point2 &p : *points) {
                const double fx = (p.x + (w - 1) / 2 + 0.5) / w, fy = (p.y + (h - 1) / 2 + 0.5) / h;
                for (const RectF &r : config.exclude)
                    EXPECT_FALSE(fx >= r.x && fx < r.x + r.w && fy >= r.y && fy < r.y + r.h)
                        << "frame " << i << " point at " << fx << "," << fy;
            }
        seen += int(m.current.size());
    }
    EXPECT_GT(seen, 20 * 20);  // the rest of the frame is still tracked
}

// Changed on a running stabilizer, the regions apply from the next pushed frame; the
// frames' tracks (FrameStats::tracks) show it, with their inlier flags.
TEST(Exclude, ChangedWhileRunningAndVisibleInTheFramesTracks)
{
    synthetic::FlightOptions options;
    options.frames = 40;
    const synthetic::ShakyFlight flight(options);
    StabilizerConfig config;
    config.threads = 2;
    config.delay = 5;
    Stabilizer stabilizer(config);
    std::vector<StabilizedFrame> frames;
    for (int i = 0; i < flight.frameCount(); ++i) {
        if (i == 20) {
            config.exclude = {{0.0, 0.0, 0.5, 1.0}};
            stabilizer.setConfig(config);
        }
        stabilizer.push(test::BufferSlot::make(flight.render(i), i));
        while (auto f = stabilizer.tryPop())
            frames.push_back(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        frames.push_back(std::move(*f));
    ASSERT_EQ(int(frames.size()), flight.frameCount());
    int left_before = 0;
    for (const StabilizedFrame &f : frames) {
        const int id = test::BufferSlot::of(f).id();
        ASSERT_EQ(int(f.stats.tracks.size()), f.stats.points) << id;
        int inliers = 0, left = 0;
        for (const TrackedPoint &t : f.stats.tracks) {
            inliers += t.inlier;
            left += t.position.x < -0.0;
        }
        EXPECT_EQ(inliers, f.stats.inliers) << id;
        if (id < 20) {
            left_before += left;
        } else {
            EXPECT_EQ(left, 0) << "frame " << id;
        }
        if (id > 0) {
            EXPECT_GT(f.stats.points, 10) << id;
        }
    }
    EXPECT_GT(left_before, 100);
}

// --- The OSD flight -------------------------------------------------------------------

namespace {

// The OSD's regions, fractions of the frame (with a few pixels to spare).
const char *const kOsdRegions = "0,0,1,0.1;"            // timestamp, telemetry
                                "0,0.9,1,0.1;"          // status bar
                                "0.03,0.38,0.16,0.24;"  // speed box (its tape ticks are left to the robust fit)
                                "0.81,0.38,0.16,0.24;"  // altitude box
                                "0.26,0.2,0.48,0.6";    // crosshair and pitch ladder

struct FlightResult {
    double input = 0, output = 0;
    double settled = 0;  // the output's jitter from frame 30 on (after exclude_static has learnt)
    int skipped = 0;
    long points = 0;
    int rows_moved = 0;  // frames whose rows the rolling-shutter correction moved
};

// exclude_static: unset = the library's default.
FlightResult flyHazyUncached(const synthetic::ShakyFlight &flight, bool osd, const std::string &exclude,
                             std::optional<bool> exclude_static, bool haze,
                             RollingShutter rolling_shutter = StabilizerConfig{}.rolling_shutter,
                             int delay = StabilizerConfig{}.delay)
{
    StabilizerConfig config;
    config.rolling_shutter = rolling_shutter;
    config.delay = delay;
    config.threads = 2;
    if (exclude_static)
        config.exclude_static = *exclude_static;
    std::string error;
    EXPECT_TRUE(parseRects(exclude, config.exclude, &error)) << error;
    Stabilizer stabilizer(config);
    std::vector<Similarity> input_path, output_path;
    FlightResult result;
    auto collect = [&](StabilizedFrame f) {
        const int id = test::BufferSlot::of(f).id();
        EXPECT_EQ(id, int(output_path.size()));
        input_path.push_back(flight.truePose(id));
        output_path.push_back(flight.truePose(id) * synthetic::outputToInput(f.stats));
        result.skipped += f.stats.skipped;
        result.points += f.stats.points;
        result.rows_moved += f.stats.row_motion.empty() ? 0 : 1;
    };
    for (int i = 0; i < flight.frameCount(); ++i) {
        cv::Mat bgr = haze ? synthetic::hazy(flight.renderBgr(i)) : flight.renderBgr(i);
        if (osd)
            synthetic::burnOsd(bgr, i);
        FrameBuffer frame(PixelFormat::I420, bgr.cols, bgr.rows);
        synthetic::bgrToFrame(bgr, frame);
        stabilizer.push(test::BufferSlot::make(std::move(frame), i));
        while (auto f = stabilizer.tryPop())
            collect(std::move(*f));
    }
    stabilizer.flush();
    while (auto f = stabilizer.waitPop())
        collect(std::move(*f));
    EXPECT_EQ(int(output_path.size()), flight.frameCount());
    const int w = flight.options().width, h = flight.options().height;
    result.input = synthetic::residualJitter(input_path, w, h);
    result.output = synthetic::residualJitter(output_path, w, h);
    result.settled = synthetic::residualJitter({output_path.begin() + 30, output_path.end()}, w, h);
    return result;
}

// The default flight (seed 1), 150 frames, every shake amplitude times `strength`.
synthetic::FlightOptions hazyFlightWithShake(double strength)
{
    synthetic::FlightOptions options;
    options.frames = 150;
    options.noise_px *= strength;
    options.band_px *= strength;
    options.rotation_noise_deg *= strength;
    options.rotation_band_deg *= strength;
    return options;
}

// The same run twice gives the same result: the tests share them (the default flight only).
FlightResult flyHazy(const synthetic::ShakyFlight &flight, bool osd, const std::string &exclude,
                     std::optional<bool> exclude_static = false, bool haze = true)
{
    static std::map<std::string, FlightResult> cache;
    const std::string key = std::to_string(osd) + exclude + "|" +
                            (exclude_static ? std::to_string(*exclude_static) : std::string("default")) +
                            std::to_string(haze) + "|" + std::to_string(flight.frameCount());
    auto it = cache.find(key);
    if (it == cache.end())
        it = cache.emplace(key, flyHazyUncached(flight, osd, exclude, exclude_static, haze)).first;
    return it->second;
}

} // namespace

TEST(Exclude, AnExcludedOsdDoesNotPinTheHazyFlightToTheScreen)
{
    synthetic::FlightOptions options;  // 640x360, the default shake
    options.frames = 150;
    const synthetic::ShakyFlight flight(options);
    if (const char *dump = std::getenv("UAVSTAB_OSD_SAMPLE")) {  // a look at the test's input
        cv::Mat bgr = synthetic::hazy(flight.renderBgr(0));
        synthetic::burnOsd(bgr, 0);
        cv::imwrite(dump, bgr);
    }
    if (const char *dump = std::getenv("UAVSTAB_OVERLAY_SAMPLE")) {  // frame 60 stabilized, debug overlay on
        StabilizerConfig config;
        config.threads = 2;
        config.debug_overlay = true;
        ASSERT_TRUE(parseRects(kOsdRegions, config.exclude));
        Stabilizer stabilizer(config);
        for (int i = 0; i <= 60; ++i) {
            cv::Mat bgr = synthetic::hazy(flight.renderBgr(i));
            synthetic::burnOsd(bgr, i);
            FrameBuffer frame(PixelFormat::I420, bgr.cols, bgr.rows);
            synthetic::bgrToFrame(bgr, frame);
            stabilizer.push(test::BufferSlot::make(std::move(frame), i));
            while (stabilizer.tryPop()) {
            }
        }
        stabilizer.flush();
        while (auto f = stabilizer.waitPop())
            if (test::BufferSlot::of(*f).id() == 60) {
                // Posterized (steps of 10) so that the PNG stays small.
                cv::Mat bgr = synthetic::frameToBgr(test::BufferSlot::of(*f).outputBuffer().view());
                cv::Mat levels, small;
                bgr.convertTo(levels, -1, 1.0 / 10.0);  // two steps: MatExpr would fold the scales into one
                levels.convertTo(small, -1, 10.0);
                cv::imwrite(dump, small, {cv::IMWRITE_PNG_COMPRESSION, 9});
            }
    }
    const FlightResult clean = flyHazy(flight, false, "");
    const FlightResult osd = flyHazy(flight, true, "");
    const FlightResult excluded = flyHazy(flight, true, kOsdRegions);
    const FlightResult clean_excluded = flyHazy(flight, false, kOsdRegions);
    std::printf("hazy flight, residual jitter (input %.3f px): no OSD %.3f px, OSD %.3f px, OSD excluded %.3f px, "
                "no OSD with the same exclusion %.3f px; skipped frames %d / %d / %d / %d\n",
                clean.input, clean.output, osd.output, excluded.output, clean_excluded.output, clean.skipped,
                osd.skipped, excluded.skipped, clean_excluded.skipped);
    RecordProperty("no_osd", std::to_string(clean.output));
    RecordProperty("osd", std::to_string(osd.output));
    RecordProperty("osd_excluded", std::to_string(excluded.output));
    EXPECT_GT(clean.input, 2.0);
    EXPECT_LT(clean.output, 0.3 * clean.input);
    // The OSD hurts (the premise of the test) ...
    EXPECT_GT(osd.output, 2.0 * clean.output);
    // ... and excluding it gets the clean flight's jitter back, within 15 %.
    EXPECT_LE(excluded.output, 1.15 * clean.output);
}

// exclude_static: the same OSD found without being told where it is; and on the plain
// flight (no haze, no OSD) it changes nothing that matters.
TEST(Exclude, StaticTracksAreFoundByThemselves)
{
    synthetic::FlightOptions options;
    options.frames = 150;
    const synthetic::ShakyFlight flight(options);
    const FlightResult clean = flyHazy(flight, false, "");
    const FlightResult osd = flyHazy(flight, true, "");
    const FlightResult found = flyHazy(flight, true, "", true);
    const FlightResult clean_found = flyHazy(flight, false, "", true);
    const FlightResult plain = flyHazy(flight, false, "", false, false);
    const FlightResult plain_found = flyHazy(flight, false, "", true, false);
    std::printf("exclude-static, residual jitter: hazy flight no OSD %.3f px, OSD %.3f px, OSD + exclude-static "
                "%.3f px, no OSD + exclude-static %.3f px; plain flight %.3f px, + exclude-static %.3f px "
                "(points %ld / %ld); skipped frames with OSD %d, found %d; from frame 30 on: no OSD %.3f px, OSD "
                "%.3f px, found %.3f px\n",
                clean.output, osd.output, found.output, clean_found.output, plain.output, plain_found.output,
                plain.points, plain_found.points, osd.skipped, found.skipped, clean.settled, osd.settled, found.settled);
    RecordProperty("osd_exclude_static", std::to_string(found.output));
    EXPECT_GT(osd.output, 2.0 * clean.output);
    // It learns within the first frames (matching a frame again when the overlay had most
    // of its tracks), so the whole flight comes within 10 % of the clean one.
    EXPECT_LE(found.output, 1.10 * clean.output);
    EXPECT_LE(found.settled, 1.15 * clean.settled);
    EXPECT_LE(clean_found.output, 1.05 * clean.output);
    EXPECT_LE(plain_found.output, 1.05 * plain.output);
    EXPECT_EQ(plain_found.points, plain.points);  // nothing taken for an overlay
}

// The test: with default settings, the hazy flight with its OSD is stabilized
// within 10 % of the residual jitter of the same flight without the OSD.
TEST(Exclude, WithDefaultSettingsTheOsdCostsLessThanTenPercent)
{
    synthetic::FlightOptions options;
    options.frames = 150;
    const synthetic::ShakyFlight flight(options);
    const FlightResult clean = flyHazy(flight, false, "", std::nullopt);
    const FlightResult osd = flyHazy(flight, true, "", std::nullopt);
    std::printf("default settings, hazy flight: residual jitter without OSD %.3f px, with OSD %.3f px (%+.1f %%)\n",
                clean.output, osd.output, 100.0 * (osd.output / clean.output - 1.0));
    EXPECT_LE(osd.output, 1.10 * clean.output);
    EXPECT_EQ(osd.skipped, 0);
}

// A stronger shake (twice the default's) through the same haze and OSD, with defaults: the
// OSD's strokes stand still in their rows while the scene moves, which a fit of the rows'
// motion during readout could take for a rolling shutter. This flight is a global shutter's:
// the OSD costs no more than 10 % + 0.1 px of the flight without it, and the rolling-shutter
// correction (on by default) changes nothing (within 5 % of rolling_shutter=off).
TEST(Exclude, AnOsdIsNotTakenForARollingShutter)
{
    const synthetic::ShakyFlight flight(hazyFlightWithShake(2.0));
    const FlightResult clean = flyHazyUncached(flight, false, "", std::nullopt, true);
    const FlightResult osd = flyHazyUncached(flight, true, "", std::nullopt, true);
    const FlightResult off = flyHazyUncached(flight, true, "", std::nullopt, true, RollingShutter::Off);
    std::printf("hazy flight, twice the shake (input %.3f px), residual jitter from frame 30 on: without OSD %.3f px, "
                "with OSD %.3f px (rows moved in %d frames), with OSD and rolling_shutter=off %.3f px\n",
                clean.input, clean.settled, osd.settled, osd.rows_moved, off.settled);
    EXPECT_LE(osd.settled, 1.10 * clean.settled + 0.1);
    EXPECT_LE(osd.settled, 1.05 * off.settled);
    EXPECT_EQ(osd.rows_moved, 0);
    EXPECT_EQ(clean.rows_moved, 0);
}

// Three times the default shake: the scene moves ~35 px a frame under the OSD's strokes,
// which pull every tracking window that touches them (at the pyramid's coarse levels, most
// do) towards "no motion". With the strokes painted over before tracking
// (overlay_strokes.hpp), the OSD costs no more than 10 % + 0.1 px (without that: 6.7 px
// against 3.2).
TEST(Exclude, AnOsdCostsLittleUnderThreeTimesTheShake)
{
    const synthetic::ShakyFlight flight(hazyFlightWithShake(3.0));
    const FlightResult clean = flyHazyUncached(flight, false, "", std::nullopt, true);
    const FlightResult osd = flyHazyUncached(flight, true, "", std::nullopt, true);
    std::printf("hazy flight, three times the shake (input %.3f px), residual jitter from frame 30 on: without OSD "
                "%.3f px, with OSD %.3f px; frames skipped with OSD %d\n",
                clean.input, clean.settled, osd.settled, osd.skipped);
    EXPECT_LE(osd.settled, 1.10 * clean.settled + 0.1);
    EXPECT_LE(osd.skipped, 1);
}

// Twice the default shake at delay 5: in the first frames, before the OSD's strokes are
// learnt and painted over, most tracks drift onto them and one frame (6) kept only 9
// agreeing tracks of the 10 needed and was skipped (0.82 px of jitter against 0.77 without
// the OSD); matched again on twice the corners, detected afresh, it is not (0.78 px).
TEST(Exclude, AFrameWhoseTracksDriftOntoAnUnlearntOsdIsMatchedAgain)
{
    const synthetic::ShakyFlight flight(hazyFlightWithShake(2.0));
    const RollingShutter rs = StabilizerConfig{}.rolling_shutter;
    const FlightResult clean = flyHazyUncached(flight, false, "", std::nullopt, true, rs, 5);
    const FlightResult osd = flyHazyUncached(flight, true, "", std::nullopt, true, rs, 5);
    std::printf("hazy flight, twice the shake, delay 5, residual jitter from frame 30 on: without OSD %.3f px, "
                "with OSD %.3f px; frames skipped with OSD %d\n",
                clean.settled, osd.settled, osd.skipped);
    EXPECT_EQ(osd.skipped, 0);
    EXPECT_LE(osd.settled, 1.10 * clean.settled + 0.1);
}

// The case exclude_static could get wrong: a camera that holds still while objects move
// through the picture. The still scene must not be taken for an overlay (and the camera
// then made to follow the objects).
TEST(Exclude, AStillCameraWatchingMovingObjectsIsNotFooled)
{
    synthetic::FlightOptions options;
    options.frames = 120;
    options.pan_speed = 0.0;
    options.rotation_amplitude_deg = 0.0;
    options.noise_px = options.band_px = 0.0;
    options.rotation_noise_deg = options.rotation_band_deg = 0.0;
    options.moving_objects = 4;
    const synthetic::ShakyFlight flight(options);
    double worst[2] = {0.0, 0.0};
    long points[2] = {0, 0};
    for (int on = 0; on < 2; ++on) {
        StabilizerConfig config;
        config.threads = 2;
        config.exclude_static = on != 0;
        Stabilizer stabilizer(config);
        auto collect = [&](const StabilizedFrame &f) {
            const Similarity &c = f.stats.output_to_input;
            worst[on] = std::max(worst[on], std::hypot(c.dx, c.dy) + 200.0 * std::abs(c.angle));
            points[on] += f.stats.points;
        };
        for (int i = 0; i < flight.frameCount(); ++i) {
            stabilizer.push(test::BufferSlot::make(flight.render(i), i));
            while (auto f = stabilizer.tryPop())
                collect(*f);
        }
        stabilizer.flush();
        while (auto f = stabilizer.waitPop())
            collect(*f);
    }
    std::printf("still camera, moving objects: largest correction %.3f px (exclude-static off), %.3f px (on); "
                "points %ld / %ld\n",
                worst[0], worst[1], points[0], points[1]);
    EXPECT_LT(worst[1], worst[0] + 0.5);
    EXPECT_GT(points[1], points[0] * 8 / 10);
}

// --- Drawing the debug overlay --------------------------------------------------------

TEST(DebugOverlay, PixelsGetTheirColourInEveryFormat)
{
    const OverlayColor green{0, 255, 0, 255};
    for (PixelFormat format : {PixelFormat::Gray8, PixelFormat::I420, PixelFormat::YV12, PixelFormat::NV12,
                               PixelFormat::NV21, PixelFormat::RGB, PixelFormat::BGR, PixelFormat::RGBA,
                               PixelFormat::BGRx, PixelFormat::Gray16LE, PixelFormat::Gray16BE}) {
        SCOPED_TRACE(std::string(toString(format)));
        FrameBuffer f(format, 33, 17, 5);
        f.fill(128);
        putOverlayPixel(f.view(), 10, 6, green);
        putOverlayPixel(f.view(), -1, 0, green);   // ignored
        putOverlayPixel(f.view(), 33, 16, green);  // ignored
        if (is16Bit(format)) {  // white: 65535; nothing else changed
            for (int y = 0; y < 17; ++y)
                for (int x = 0; x < 33; ++x) {
                    const std::uint8_t *p = f.row(0, y) + 2 * x;
                    const bool mark = x == 10 && y == 6;
                    EXPECT_EQ(p[0], mark ? 255 : 128);
                    EXPECT_EQ(p[1], mark ? 255 : 128);
                }
            continue;
        }
        const cv::Mat bgr = synthetic::frameToBgr(f.view());
        const cv::Vec3b p = bgr.at<cv::Vec3b>(6, 10);
        if (format == PixelFormat::Gray8) {
            EXPECT_EQ(p, cv::Vec3b(255, 255, 255));
        } else {
            EXPECT_GT(p[1], 200);  // green
            EXPECT_LT(p[0], 60);
            EXPECT_LT(p[2], 60);
        }
        // Only that pixel's luma changed (chroma is shared by its 2x2 block).
        int changed = 0;
        for (int y = 0; y < 17; ++y)
            for (int x = 0; x < 33; ++x)
                changed += bgr.at<cv::Vec3b>(y, x) != bgr.at<cv::Vec3b>(0, 0);
        EXPECT_GE(changed, 1);
        EXPECT_LE(changed, 4);
    }
}

TEST(DebugOverlay, PointsRectanglesAndEdgesLandWhereTheWarpPutsThem)
{
    FrameBuffer out(PixelFormat::RGB, 200, 100);
    out.fill(0);
    FrameStats stats;
    stats.output_to_input = {10.0, 0.0, 0.0, 1.0};  // the output shows the input 10 px to the right
    stats.tracks = {{{0.0, 0.0}, true}, {{40.0, 20.0}, false}};
    drawDebugOverlay(out.view(), stats, {{0.0, 0.0, 0.5, 0.5}});
    auto rgb = [&](int x, int y) {
        const std::uint8_t *p = out.row(0, y) + 3 * x;
        return cv::Vec3b(p[0], p[1], p[2]);
    };
    // Input centre (99.5, 49.5) -> output (89.5, 49.5), rounded to (90, 50): an inlier's
    // square of radius 3 around it.
    EXPECT_EQ(rgb(87, 47), cv::Vec3b(0, 255, 0));
    EXPECT_EQ(rgb(93, 50), cv::Vec3b(0, 255, 0));
    EXPECT_EQ(rgb(89, 51), cv::Vec3b(0, 0, 0));  // hollow
    // The rejected point: input (139.5, 69.5) -> output (129.5, 69.5).
    EXPECT_EQ(rgb(127, 67), cv::Vec3b(255, 0, 0));
    // The excluded rectangle's right edge: input x = 99.5 -> output 89.5 (drawn at 90), rows 0..50.
    EXPECT_EQ(rgb(90, 20), cv::Vec3b(255, 255, 0));
    // The input's right edge (x = 199.5) lands at output 189.5: the blue line.
    EXPECT_EQ(rgb(190, 80), cv::Vec3b(0, 128, 255));
    EXPECT_EQ(rgb(150, 80), cv::Vec3b(0, 0, 0));
}
