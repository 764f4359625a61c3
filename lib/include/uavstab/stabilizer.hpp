// The online stabilizer: frames are pushed in, stabilized frames come back in input order.
//
//   push(slot) -> motion estimation (caller's thread) -> delay buffer of `delay` frames
//   -> once frame i + delay is estimated (or on flush()) frame i is final: its output is
//      acquired (caller's thread) and it is queued for planning
//   -> a worker plans the output path for it (StabilizerConfig::planner; one frame after another,
//      never two at once), then the workers warp it in stripes
//   -> tryPop()/waitPop() hand frames back in input order, with their slots.
//
// The stabilizer never pulls frames and never allocates output frames: the caller's
// FrameSlot supplies both, and carries whatever the caller needs to get back (buffers,
// timestamps). push/flush/reset/setConfig/markDiscontinuity belong to one thread (the
// "control" thread); tryPop/waitPop may be called from any thread.
//
// Public API. A user may rely on: every frame pushed (and not refused by an exception)
// comes back exactly once, in push order, with its slot, unless reset() drops it; it is
// held until `delay` more frames are pushed, flush() is called or the frame format
// changes; the thread rules above. Not promised: the same output bytes from one version to
// the next (estimation and planning are tuned).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "uavstab/config.hpp"
#include "uavstab/frame_stats.hpp"
#include "uavstab/frame_view.hpp"

namespace uavstab {

class LensMeshes;
class LensView;
struct LensProfile;
class MotionEstimator;
class PathPlanner;
class Trajectory;
class WorkerPool;

// One frame on its way through the stabilizer, owned by it until handed back.
class FrameSlot {
public:
    virtual ~FrameSlot() = default;
    // The frame to estimate and warp. Must stay valid until the slot is handed back or
    // destroyed (destroying the slot is how the stabilizer lets go of the frame).
    virtual FrameView input() = 0;
    // Called once, on the control thread, when the frame's correction is final and it is
    // about to be warped: where to write it (the input's geometry, not overlapping it),
    // or nullopt to get the frame back unwarped (Outcome::NoOutput).
    virtual std::optional<FrameView> acquireOutput() = 0;
};

enum class Outcome {
    Warped,    // the output view holds the stabilized frame
    Bypassed,  // config.bypass: the input is the output, untouched
    NoOutput,  // acquireOutput() gave no output
    Failed,    // estimation or warping failed; see error. The output is not valid.
};

struct StabilizedFrame {
    std::unique_ptr<FrameSlot> slot;
    FrameStats stats;
    Outcome outcome = Outcome::Warped;
    std::string error;
};

class Stabilizer {
public:
    // Throws std::invalid_argument for an invalid config, LensProfileError (lens.hpp) for a
    // lens profile (config.lens_profile) it cannot use.
    explicit Stabilizer(const StabilizerConfig &config = {});
    // Waits for warps in flight; frames not popped are destroyed with their slots.
    ~Stabilizer();
    Stabilizer(const Stabilizer &) = delete;
    Stabilizer &operator=(const Stabilizer &) = delete;

    // Estimates the frame's motion and queues it. A frame of another format or size than
    // the previous one first flushes the held frames and starts a new path.
    // Throws std::invalid_argument for a null slot, an invalid frame view or a frame size
    // the lens profile is not for (checkFrameSize), before the frame is queued (the slot is then destroyed, nothing else changes). Once queued, a
    // frame always comes back: estimation failures give it identity motion instead.
    void push(std::unique_ptr<FrameSlot> slot);
    // push() in two steps, for a caller that keeps few output frames in flight: pushHeld()
    // estimates the frame and holds it, and leaves frames beyond the delay held
    // (heldCount() may exceed the delay) until finalizeDue() finalizes them, oldest first,
    // one per call (false when none is due). So the caller can estimate this frame while
    // earlier warps run, and take the next output frame only once there is room for it.
    // push() is pushHeld() followed by finalizeDue() until it returns false. A frame is
    // planned and warped the same whenever it is finalized.
    void pushHeld(std::unique_ptr<FrameSlot> slot);
    bool finalizeDue();
    // Held frames beyond the delay: what finalizeDue() would finalize.
    std::size_t dueCount() const;
    // The next pushed frame starts a new path (scene cut, gap, discontinuity): no motion
    // is estimated across it and no smoothing window spans it.
    void markDiscontinuity();
    // Finalizes every held frame (truncated smoothing window) so all can be popped.
    void flush();
    // Finalizes the oldest held frame only, as flush() would; false when none is held.
    // Lets a caller drain at its own pace: each finalized frame takes an output frame.
    bool flushOne();
    // Drops every held and in-flight frame (waiting for warps that have started) and
    // starts afresh; frame indices restart at 0. Applies a changed thread count.
    void reset();

    // The next frame in input order if its warp is done, without waiting.
    std::optional<StabilizedFrame> tryPop();
    // Waits for the next finalized frame; nullopt at once when none is finalized
    // (frames still in the delay buffer need more pushes or a flush()).
    std::optional<StabilizedFrame> waitPop();
    // Called on a worker thread (with no lock held) each time a frame becomes ready.
    void setReadyCallback(std::function<void()> callback);

    // Takes effect at the next push (delay, smoothing, estimation, framing, bypass) or at
    // reset() (threads). Throws std::invalid_argument for an invalid config.
    void setConfig(const StabilizerConfig &config);
    StabilizerConfig config() const;
    // The time between frames in ms (0: unknown), which a known sensor readout time
    // (config.readout_time) is measured against. Control thread; takes effect at once.
    void setFrameInterval(double milliseconds);

    // Throws std::invalid_argument, naming the lens profile's file and field, when frames of
    // this size cannot be seen through it (another aspect ratio than its calibration's).
    void checkFrameSize(int width, int height) const;

    std::size_t heldCount() const;      // in the delay buffer
    std::size_t finalizedCount() const; // finalized, not yet popped

private:
    struct Held;
    struct Pending;
    struct PlanJob;

    void finalizeOldest();
    void planNext();
    void planAndWarp(PlanJob &job);
    void runStripe(const std::shared_ptr<Pending> &pending, BorderMode border, int begin, int end);
    void completeStripe(const std::shared_ptr<Pending> &pending);
    StabilizedFrame take(std::unique_lock<std::mutex> &lock);
    void waitForAllFinalized(std::unique_lock<std::mutex> &lock);
    void applyConfig();
    StabilizerConfig withLens(StabilizerConfig config) const;

    // Control-thread state.
    StabilizerConfig config_;
    // The config frames are finalized under, shared by their plan jobs: the planning task
    // sees each setting change in frame order, with no per-frame copy.
    std::shared_ptr<const StabilizerConfig> frame_config_;
    std::unique_ptr<MotionEstimator> estimator_;
    std::unique_ptr<Trajectory> trajectory_;
    std::deque<Held> held_;
    bool discontinuity_ = true;
    bool have_geometry_ = false;
    FrameView geometry_;
    // config.lens_profile, read when built, and the lens at the frames' size.
    std::unique_ptr<const LensProfile> lens_profile_;
    LensOutput lens_output_ = LensOutput::Original;
    std::shared_ptr<const LensView> lens_view_;

    // Shared with workers and poppers, under mutex_.
    mutable std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<std::shared_ptr<Pending>> finalized_;
    std::deque<PlanJob> plan_queue_;
    bool planning_ = false;  // a planNext task is queued or running
    std::function<void()> ready_callback_;
    std::optional<StabilizerConfig> next_config_;

    // The planning task's own (one at a time, in frame order; reset() touches them only
    // with the pool idle).
    std::unique_ptr<PathPlanner> planner_;
    std::shared_ptr<const StabilizerConfig> planner_config_;
    std::unique_ptr<LensMeshes> lens_meshes_;  // the lens's warp, while there is one

    std::unique_ptr<WorkerPool> pool_;  // last: destroyed (joined) first
};

} // namespace uavstab
