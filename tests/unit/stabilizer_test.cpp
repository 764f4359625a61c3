#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <random>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "buffer_slot.hpp"
#include "format_conversion.hpp"
#include "shaky_flight.hpp"
#include "jitter_metrics.hpp"
#include "path/framing.hpp"
#include "render/row_transforms.hpp"
#include "uavstab/stabilizer.hpp"

using namespace uavstab;
using test::BufferSlot;

namespace {

StabilizerConfig smallConfig(int delay)
{
    StabilizerConfig c;
    c.delay = delay;
    c.threads = 2;
    return c;
}

// Pushes n frames made by `make`, flushes, and returns the ids in the order they came back.
template <typename Make>
std::vector<int> roundTrip(Stabilizer &s, int n, Make make, std::vector<StabilizedFrame> *frames = nullptr)
{
    std::vector<int> ids;
    auto take = [&](StabilizedFrame f) {
        ids.push_back(BufferSlot::of(f).id());
        if (frames)
            frames->push_back(std::move(f));
    };
    for (int i = 0; i < n; ++i) {
        s.push(BufferSlot::make(make(i), i));
        while (auto f = s.tryPop())
            take(std::move(*f));
    }
    s.flush();
    while (auto f = s.waitPop())
        take(std::move(*f));
    return ids;
}

std::vector<int> iota(int n)
{
    std::vector<int> v(std::size_t(n), 0);
    for (int i = 0; i < n; ++i)
        v[std::size_t(i)] = i;
    return v;
}

} // namespace

TEST(Stabilizer, EveryFrameComesBackOnceInOrderWhateverWhenItIsFlushed)
{
    synthetic::FlightOptions options;
    options.width = 160;
    options.height = 96;
    options.frames = 30;
    const synthetic::ShakyFlight flight(options);
    const int delay = 20;
    for (int n : {0, 1, delay - 1, delay, delay + 1, 30}) {
        Stabilizer s(smallConfig(delay));
        EXPECT_EQ(roundTrip(s, n, [&](int i) { return flight.render(i); }), iota(n)) << n << " frames";
        EXPECT_EQ(s.heldCount(), 0u);
        EXPECT_EQ(s.finalizedCount(), 0u);
    }
}

TEST(Stabilizer, HoldsExactlyDelayFrames)
{
    Stabilizer s(smallConfig(5));
    for (int i = 0; i < 5; ++i) {
        s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 64, 64, unsigned(i)), i));
        EXPECT_EQ(s.heldCount(), std::size_t(i + 1));
        EXPECT_FALSE(s.waitPop().has_value());  // nothing finalized yet: no wait
    }
    s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 64, 64, 9), 5));
    EXPECT_EQ(s.heldCount(), 5u);
    auto first = s.waitPop();
    ASSERT_TRUE(first.has_value());
    EXPECT_EQ(BufferSlot::of(*first).id(), 0);
    EXPECT_EQ(first->outcome, Outcome::Warped);
}

TEST(Stabilizer, DelayZeroReturnsEachFrameRightAway)
{
    Stabilizer s(smallConfig(0));
    for (int i = 0; i < 5; ++i) {
        s.push(BufferSlot::make(test::noiseFrame(PixelFormat::NV12, 64, 48, unsigned(i)), i));
        auto f = s.waitPop();
        ASSERT_TRUE(f.has_value());
        EXPECT_EQ(BufferSlot::of(*f).id(), i);
    }
}

TEST(Stabilizer, BlackUniformAndNoiseFramesGiveIdentityAndNoCrash)
{
    for (int kind = 0; kind < 3; ++kind) {
        Stabilizer s(smallConfig(3));
        std::vector<StabilizedFrame> frames;
        const auto ids = roundTrip(s, 12, [&](int i) {
            FrameBuffer f(PixelFormat::I420, 128, 96);
            if (kind == 0)
                f.fill(0);
            else if (kind == 1)
                f.fill(117);
            else
                f = test::noiseFrame(PixelFormat::I420, 128, 96, unsigned(100 + i));  // unrelated noise
            return f;
        }, &frames);
        EXPECT_EQ(ids, iota(12));
        for (const auto &f : frames) {
            EXPECT_EQ(f.outcome, Outcome::Warped);
            EXPECT_TRUE(f.stats.correction.isIdentity(1e-9)) << "kind " << kind << " frame " << f.stats.index;
            if (f.stats.index > 0) {
                EXPECT_TRUE(f.stats.skipped);
            }
        }
    }
}

TEST(Stabilizer, FramesWarpedInStripesEqualFramesWarpedWhole)
{
    // Two workers split a frame this size into row stripes; one worker warps it whole.
    synthetic::FlightOptions options;
    options.width = 1280;
    options.height = 832;
    options.frames = 8;
    const synthetic::ShakyFlight flight(options);
    std::vector<StabilizedFrame> results[2];
    for (int threads : {1, 2}) {
        StabilizerConfig c = smallConfig(3);
        c.threads = threads;
        Stabilizer s(c);
        const auto ids = roundTrip(s, options.frames, [&](int i) { return flight.render(i); }, &results[threads - 1]);
        ASSERT_EQ(ids, iota(options.frames));
    }
    for (int i = 0; i < options.frames; ++i) {
        const FrameBuffer &whole = BufferSlot::of(results[0][std::size_t(i)]).outputBuffer();
        const FrameBuffer &striped = BufferSlot::of(results[1][std::size_t(i)]).outputBuffer();
        ASSERT_FALSE(results[0][std::size_t(i)].stats.correction.isIdentity(1e-6)) << "frame " << i;
        for (int p = 0; p < whole.view().planeCount(); ++p) {
            const int bytes = whole.view().planeWidth(p) * planeLayout(whole.format(), p).channels;
            for (int y = 0; y < whole.view().planeHeight(p); ++y)
                ASSERT_EQ(0, std::memcmp(whole.row(p, y), striped.row(p, y), std::size_t(bytes)))
                    << "frame " << i << " plane " << p << " row " << y;
        }
    }
}

TEST(Stabilizer, TinyAndOddSizesWork)
{
    for (auto [w, h] : {std::pair{16, 16}, {17, 17}, {33, 19}, {1, 1}, {2, 3}, {641, 359}}) {
        for (PixelFormat format : {PixelFormat::I420, PixelFormat::NV21, PixelFormat::RGB, PixelFormat::Gray8}) {
            Stabilizer s(smallConfig(4));
            std::vector<StabilizedFrame> frames;
            const auto ids = roundTrip(s, 8, [&](int i) { return test::noiseFrame(format, w, h, unsigned(i)); }, &frames);
            EXPECT_EQ(ids, iota(8)) << w << "x" << h;
            for (const auto &f : frames)
                EXPECT_EQ(f.outcome, Outcome::Warped) << w << "x" << h << " " << f.error;
        }
    }
}

TEST(Stabilizer, GeometryChangeFlushesAndStartsANewPath)
{
    Stabilizer s(smallConfig(6));
    std::vector<StabilizedFrame> frames;
    const auto ids = roundTrip(s, 20, [&](int i) {
        return test::noiseFrame(i < 10 ? PixelFormat::I420 : PixelFormat::BGRx, i < 10 ? 96 : 80, 64, unsigned(i));
    }, &frames);
    EXPECT_EQ(ids, iota(20));
    EXPECT_TRUE(frames[10].stats.segment_start);
    EXPECT_EQ(BufferSlot::of(frames[10]).inputBuffer().format(), PixelFormat::BGRx);
}

TEST(Stabilizer, ResetDropsHeldFramesAndRestarts)
{
    Stabilizer s(smallConfig(5));
    for (int i = 0; i < 8; ++i)
        s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 64, 64, unsigned(i)), i));
    s.reset();
    EXPECT_EQ(s.heldCount(), 0u);
    EXPECT_EQ(s.finalizedCount(), 0u);
    EXPECT_FALSE(s.tryPop().has_value());
    const auto ids = roundTrip(s, 3, [&](int i) { return test::noiseFrame(PixelFormat::I420, 64, 64, unsigned(i)); });
    EXPECT_EQ(ids, iota(3));
}

// Destroying a Stabilizer with warps still queued must let every queued task run while
// the pool is still there (a queued startWarp calls pool_->size(): were pool_ nulled
// first, that would be a SIGSEGV). The ready
// callback holds the single worker on the first frame so that the rest are certainly
// queued when the destructor starts.
TEST(Stabilizer, DestroyedWithWarpsQueuedFinishesThemWithoutCrashing)
{
    const FrameBuffer frame = test::noiseFrame(PixelFormat::I420, 1920, 1080, 7);
    for (int threads : {1, 2}) {
        StabilizerConfig c = smallConfig(0);
        c.threads = threads;
        std::atomic<int> ready{0};
        {
            Stabilizer s(c);
            s.setReadyCallback([&ready] {
                if (ready.fetch_add(1) == 0)
                    std::this_thread::sleep_for(std::chrono::milliseconds(300));
            });
            for (int i = 0; i < 16; ++i)
                s.push(BufferSlot::make(frame, i));
        }  // destroyed without popping
        EXPECT_EQ(ready.load(), 16) << threads << " threads: every queued frame was finished";
    }
}

// Same for reset() with a changed thread count: the old pool must be idle before it goes.
TEST(Stabilizer, ResetToAnotherThreadCountWithWarpsQueued)
{
    const FrameBuffer frame = test::noiseFrame(PixelFormat::I420, 640, 480, 3);
    StabilizerConfig c = smallConfig(0);
    c.threads = 1;
    Stabilizer s(c);
    std::atomic<int> ready{0};
    s.setReadyCallback([&ready] {
        if (ready.fetch_add(1) == 0)
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
    });
    for (int i = 0; i < 8; ++i)
        s.push(BufferSlot::make(frame, i));
    c.threads = 2;
    s.setConfig(c);
    s.reset();
    EXPECT_EQ(s.finalizedCount(), 0u);
    EXPECT_EQ(roundTrip(s, 5, [&](int) { return frame; }), iota(5));
}

TEST(Stabilizer, BypassHandsFramesBackUntouchedWithTheSameDelay)
{
    StabilizerConfig c = smallConfig(3);
    c.bypass = true;
    Stabilizer s(c);
    std::vector<StabilizedFrame> frames;
    for (int i = 0; i < 3; ++i)
        s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 64, 64, unsigned(i)), i));
    EXPECT_FALSE(s.tryPop().has_value());
    EXPECT_EQ(roundTrip(s, 2, [&](int i) { return test::noiseFrame(PixelFormat::I420, 64, 64, unsigned(i)); }, &frames),
              (std::vector<int>{0, 1, 2, 0, 1}));
    for (const auto &f : frames)
        EXPECT_EQ(f.outcome, Outcome::Bypassed);
}

TEST(Stabilizer, ConfigChangesApplyAtTheNextPush)
{
    Stabilizer s(smallConfig(10));
    for (int i = 0; i < 10; ++i)
        s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 64, 64, unsigned(i)), i));
    EXPECT_EQ(s.heldCount(), 10u);
    StabilizerConfig c = s.config();
    c.delay = 2;
    s.setConfig(c);
    s.push(BufferSlot::make(test::noiseFrame(PixelFormat::I420, 64, 64, 10), 10));
    EXPECT_EQ(s.heldCount(), 2u);  // the shorter delay releases the surplus, in order
    for (int i = 0; i < 9; ++i) {
        auto f = s.waitPop();
        ASSERT_TRUE(f.has_value());
        EXPECT_EQ(BufferSlot::of(*f).id(), i);
    }
    StabilizerConfig bad = c;
    bad.max_corners = 1000;
    EXPECT_THROW(s.setConfig(bad), std::invalid_argument);
}

TEST(Stabilizer, OutputAcquisitionFailuresComeBackAsOutcomes)
{
    struct NoOutputSlot : FrameSlot {
        FrameBuffer in{PixelFormat::Gray8, 32, 32};
        bool fail;
        explicit NoOutputSlot(bool f) : fail(f) {}
        FrameView input() override { return in.view(); }
        std::optional<FrameView> acquireOutput() override
        {
            if (fail)
                throw std::runtime_error("pool is gone");
            return std::nullopt;
        }
    };
    Stabilizer s(smallConfig(0));
    s.push(std::make_unique<NoOutputSlot>(false));
    s.push(std::make_unique<NoOutputSlot>(true));
    auto a = s.waitPop(), b = s.waitPop();
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->outcome, Outcome::NoOutput);
    EXPECT_EQ(b->outcome, Outcome::Failed);
    EXPECT_NE(b->error.find("pool is gone"), std::string::npos);
}

TEST(Stabilizer, InvalidInputIsRejected)
{
    Stabilizer s(smallConfig(2));
    EXPECT_THROW(s.push(nullptr), std::invalid_argument);
    struct BadSlot : FrameSlot {
        FrameView input() override { return FrameView{PixelFormat::I420, 64, 64, {}}; }
        std::optional<FrameView> acquireOutput() override { return std::nullopt; }
    };
    EXPECT_THROW(s.push(std::make_unique<BadSlot>()), std::invalid_argument);
    StabilizerConfig c;
    c.crop = 0.9;
    EXPECT_THROW(Stabilizer{c}, std::invalid_argument);
}

TEST(Stabilizer, SceneCutStartsANewPathThatDoesNotPullOnTheOldScene)
{
    synthetic::FlightOptions a, b;
    a.frames = b.frames = 40;
    b.seed = 9;
    b.canvas = std::string(UAVSTAB_TEST_DATA_DIR) + "/aero3.jpg";
    const synthetic::ShakyFlight first(a), second(b);

    auto run = [&](bool with_second_scene) {
        Stabilizer s(smallConfig(20));
        std::vector<StabilizedFrame> frames;
        roundTrip(s, with_second_scene ? 80 : 40,
                  [&](int i) { return i < 40 ? first.render(i) : second.render(i - 40); }, &frames);
        return frames;
    };
    const auto alone = run(false), cut = run(true);
    ASSERT_EQ(cut.size(), 80u);
    EXPECT_TRUE(cut[40].stats.segment_start);
    EXPECT_TRUE(cut[40].stats.skipped);
    EXPECT_FALSE(cut[41].stats.segment_start);
    EXPECT_FALSE(cut[41].stats.skipped);
    for (int i = 0; i < 40; ++i) {
        // The first scene is corrected exactly as if the stream had ended at the cut.
        EXPECT_NEAR(cut[std::size_t(i)].stats.correction.dx, alone[std::size_t(i)].stats.correction.dx, 1e-9) << i;
        EXPECT_NEAR(cut[std::size_t(i)].stats.correction.angle, alone[std::size_t(i)].stats.correction.angle, 1e-12);
    }
}

TEST(Stabilizer, FlashesAndBlackFramesNeverCrossASmoothingWindow)
{
    synthetic::FlightOptions options;
    options.frames = 60;
    const synthetic::ShakyFlight flight(options);
    Stabilizer s(smallConfig(10));
    std::vector<StabilizedFrame> frames;
    const auto ids = roundTrip(s, 60, [&](int i) {
        FrameBuffer f = flight.render(i);
        if (i % 15 == 7)
            f.fill(i % 2 ? 255 : 0);  // a flash
        return f;
    }, &frames);
    EXPECT_EQ(ids, iota(60));
    for (const auto &f : frames)
        if (f.stats.index % 15 == 7) {
            EXPECT_TRUE(f.stats.skipped);
            EXPECT_TRUE(f.stats.segment_start);
        }
}

TEST(Stabilizer, HostileContentNeverLosesFramesOrShowsBorder)
{
    // Heavy blur, a fast zoom, motion larger than the frame, and a scene whose only
    // texture is one moving object: every frame comes back, in order, and the output
    // stays covered (corrections are limited to what the crop hides).
    synthetic::FlightOptions zoom;
    zoom.frames = 60;
    zoom.zoom_amplitude = 0.25;
    const synthetic::ShakyFlight zooming(zoom), plain(synthetic::FlightOptions{});
    auto blurred = [&](int i) {
        cv::Mat bgr = plain.renderBgr(i);
        cv::GaussianBlur(bgr, bgr, cv::Size(0, 0), 6.0);
        FrameBuffer f(PixelFormat::I420, bgr.cols, bgr.rows);
        synthetic::bgrToFrame(bgr, f);
        return f;
    };
    auto jumping = [&](int i) { return plain.render((i * 97) % 300); };  // huge jumps
    auto lone_object = [&](int i) {
        FrameBuffer f(PixelFormat::Gray8, 320, 240);
        f.fill(90);
        for (int y = 0; y < 40; ++y)
            for (int x = 0; x < 40; ++x)
                f.row(0, 60 + y + i % 50)[40 + x + 2 * i] = std::uint8_t(((x / 5 + y / 5) % 2) ? 220 : 30);
        return f;
    };
    const std::vector<std::function<FrameBuffer(int)>> clips = {blurred, [&](int i) { return zooming.render(i); },
                                                                jumping, lone_object};
    for (std::size_t c = 0; c < clips.size(); ++c) {
        Stabilizer s(smallConfig(10));
        std::vector<StabilizedFrame> frames;
        EXPECT_EQ(roundTrip(s, 60, clips[c], &frames), iota(60)) << "clip " << c;
        for (const auto &f : frames) {
            EXPECT_EQ(f.outcome, Outcome::Warped);
            const FrameView in = BufferSlot::of(f).inputBuffer().view();
            EXPECT_TRUE(coversFrame(f.stats.output_to_input, in.width, in.height)) << "clip " << c;
        }
    }
}

TEST(Stabilizer, DrainingOneFrameAtATimeEqualsFlush)
{
    synthetic::FlightOptions options;
    options.width = 320;
    options.height = 180;
    options.frames = 30;
    const synthetic::ShakyFlight flight(options);
    auto run = [&](bool one_at_a_time) {
        Stabilizer s(smallConfig(20));
        for (int i = 0; i < 30; ++i)
            s.push(BufferSlot::make(flight.render(i), i));
        std::vector<StabilizedFrame> frames;
        while (auto f = s.waitPop())
            frames.push_back(std::move(*f));
        if (one_at_a_time) {
            while (s.flushOne()) {
                EXPECT_LE(s.finalizedCount(), 1u);  // the caller sets the pace
                auto f = s.waitPop();
                EXPECT_TRUE(f.has_value());
                frames.push_back(std::move(*f));
            }
        } else {
            s.flush();
            while (auto f = s.waitPop())
                frames.push_back(std::move(*f));
        }
        return frames;
    };
    const auto all = run(false), paced = run(true);
    ASSERT_EQ(all.size(), 30u);
    ASSERT_EQ(paced.size(), 30u);
    for (std::size_t i = 0; i < 30; ++i) {
        EXPECT_EQ(BufferSlot::of(paced[i]).id(), int(i));
        EXPECT_DOUBLE_EQ(paced[i].stats.correction.dx, all[i].stats.correction.dx);
        EXPECT_DOUBLE_EQ(paced[i].stats.correction.angle, all[i].stats.correction.angle);
    }
}

TEST(Stabilizer, PushHeldFinalizesOnlyWhenAskedAndWarpsTheSameAsPush)
{
    synthetic::FlightOptions options;
    options.width = 320;
    options.height = 180;
    options.frames = 40;
    const synthetic::ShakyFlight flight(options);
    const int delay = 20, n = 40;
    // late: frames beyond the delay wait in the delay buffer, up to three pushes long,
    // before the caller lets finalizeDue() take them.
    auto run = [&](bool split) {
        Stabilizer s(smallConfig(delay));
        std::vector<StabilizedFrame> frames;
        for (int i = 0; i < n; ++i) {
            if (!split) {
                s.push(BufferSlot::make(flight.render(i), i));
            } else {
                s.pushHeld(BufferSlot::make(flight.render(i), i));
                EXPECT_EQ(s.heldCount(), std::size_t(i + 1) - s.finalizedCount() - frames.size());
                EXPECT_EQ(s.dueCount(), i < delay ? 0u : std::size_t(i % 4 + 1)) << i;
                if (i % 4 == 3 || i == n - 1) {
                    while (s.finalizeDue()) {
                    }
                    EXPECT_EQ(s.dueCount(), 0u);
                    EXPECT_EQ(s.heldCount(), std::size_t(std::min(i + 1, delay)));
                }
            }
            while (auto f = s.tryPop())
                frames.push_back(std::move(*f));
        }
        s.flush();
        while (auto f = s.waitPop())
            frames.push_back(std::move(*f));
        return frames;
    };
    const auto whole = run(false), split = run(true);
    ASSERT_EQ(whole.size(), std::size_t(n));
    ASSERT_EQ(split.size(), std::size_t(n));
    for (std::size_t i = 0; i < whole.size(); ++i) {
        ASSERT_EQ(BufferSlot::of(split[i]).id(), int(i));
        ASSERT_EQ(split[i].outcome, Outcome::Warped);
        const FrameView a = BufferSlot::of(whole[i]).outputBuffer().view(),
                        b = BufferSlot::of(split[i]).outputBuffer().view();
        for (int p = 0; p < a.planeCount(); ++p)
            for (int y = 0; y < a.planeHeight(p); ++y)
                ASSERT_EQ(std::memcmp(a.planes[p].data + std::size_t(y) * a.planes[p].stride,
                                      b.planes[p].data + std::size_t(y) * b.planes[p].stride,
                                      std::size_t(a.planeRowBytes(p))),
                          0)
                    << "frame " << i << " plane " << p << " row " << y;
    }
}

// A rolling-shutter flight (rows read over 80 % of the frame time, 47 Hz propeller
// vibration): the output's corners, each taken through its own row's transform to the input
// row it shows and that row's true pose, keep little shake. The bench measures the same over
// seeds and delays (bench_rolling_shutter.cpp): 1.56 px on this flight, 2.18 px when the band
// fit took the bend's share a similarity can express for camera motion.
TEST(Stabilizer, ARollingShutterFlightKeepsLittleShakeAtItsCorners)
{
    synthetic::FlightOptions o;
    o.width = 640;
    o.height = 360;
    o.frames = 90;
    o.seed = 1;
    o.readout = 0.8;
    o.vibration_hz = 47.0;
    o.vibration_px = 2.0;
    o.vibration_deg = 0.1;
    const synthetic::ShakyFlight flight(o);
    StabilizerConfig config = smallConfig(20);
    config.threads = 2;
    Stabilizer s(config);
    s.setFrameInterval(1000.0 / o.fps);
    std::vector<StabilizedFrame> frames;
    ASSERT_EQ(roundTrip(s, o.frames, [&](int i) { return flight.render(i); }, &frames), iota(o.frames));
    std::vector<std::array<Point2, 4>> corners;
    int corrected = 0;
    const double cx = 0.5 * (o.width - 1), cy = 0.5 * (o.height - 1);
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const FrameStats &stats = frames[i].stats;
        corrected += stats.row_motion.empty() ? 0 : 1;
        const RowMatrices rows(rollingShutterWarp(stats.output_to_input, stats.row_motion, o.width, o.height), o.width,
                               o.height);
        std::array<Point2, 4> world;
        for (int c = 0; c < 4; ++c) {
            const double x = c % 2 ? o.width - 1 : 0, y = c / 2 ? o.height - 1 : 0;
            const std::array<double, 6> m = rows.at(y);
            const double qx = m[0] * x + m[1] * y + m[2], qy = m[3] * x + m[4] * y + m[5];
            world[std::size_t(c)] = flight.truePoseAtRow(int(i), qy).apply({qx - cx, qy - cy});
        }
        corners.push_back(world);
    }
    EXPECT_GE(corrected, 80);
    const double shake = synthetic::cornerJitter(corners, 8.0, std::size_t(o.fps));
    std::printf("shake left at the corners: %.3f px (rows moved in %d frames)\n", shake, corrected);
    EXPECT_LT(shake, 1.85);
}
