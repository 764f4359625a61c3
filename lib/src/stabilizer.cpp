#include "uavstab/stabilizer.hpp"

#include <algorithm>
#include <atomic>
#include <stdexcept>

#include "estimate/motion_estimator.hpp"
#include "lens/lens_view.hpp"
#include "path/framing.hpp"
#include "path/path_planner.hpp"
#include "path/trajectory.hpp"
#include "render/debug_overlay.hpp"
#include "render/frame_warper.hpp"
#include "render/lens_meshes.hpp"
#include "uavstab/lens.hpp"
#include "worker_pool.hpp"

namespace uavstab {

namespace {
// Frames shorter than this are warped in one piece: stripes would cost more than they save.
constexpr int kMinStripeRows = 64;
// Stripe boundaries on multiples of this keep subsampled chroma rows whole.
constexpr int kStripeAlign = 16;
} // namespace

struct Stabilizer::Held {
    std::unique_ptr<FrameSlot> slot;
    FrameStats stats;
};

struct Stabilizer::Pending {
    std::unique_ptr<FrameSlot> slot;
    FrameView input;
    FrameView output;
    FrameStats stats;
    // Rolling shutter: each output row's own transform (unset: stats.output_to_input for all).
    std::optional<RowTransforms> rows;
    // The lens the frame is seen through (null: none), and then the warp's mesh per plane.
    std::shared_ptr<const LensView> lens;
    std::vector<WarpMesh> meshes;
    Outcome outcome = Outcome::Warped;
    std::string error;          // written under Stabilizer::mutex_
    std::atomic<int> stripes_left{0};
    // config.debug_overlay: the config to draw the overlay with once the warp is done.
    std::shared_ptr<const StabilizerConfig> overlay;
    bool ready = false;         // under Stabilizer::mutex_
};

struct Stabilizer::PlanJob {
    std::shared_ptr<Pending> pending;
    std::shared_ptr<const StabilizerConfig> config;
    PlanRequest request;
};

namespace {
// A config change that leaves these alone keeps the planner (and the path it is on).
bool samePlanner(const StabilizerConfig &a, const StabilizerConfig &b)
{
    return a.planner == b.planner && a.smoothing_radius == b.smoothing_radius && a.crop == b.crop &&
           a.limit_to_crop == b.limit_to_crop && a.planner_smoothness == b.planner_smoothness &&
           a.planner_manoeuvre == b.planner_manoeuvre &&
           a.adaptive_zoom == b.adaptive_zoom && a.max_zoom == b.max_zoom && a.zoom_speed == b.zoom_speed;
}
} // namespace

Stabilizer::Stabilizer(const StabilizerConfig &config) : config_(config), trajectory_(std::make_unique<Trajectory>())
{
    config_.validate();
    if (!config_.lens_profile.empty())
        lens_profile_ = std::make_unique<const LensProfile>(readLensProfile(config_.lens_profile));
    lens_output_ = config_.lens_output;
    config_ = withLens(config_);
    estimator_ = std::make_unique<MotionEstimator>(config_);
    frame_config_ = std::make_shared<const StabilizerConfig>(config_);
    pool_ = std::make_unique<WorkerPool>(config_.resolvedThreads());
    // A worker with nothing queued (no warp) joins in the estimation's downscale and
    // tracking: the same results, sooner.
    estimator_->setShareWork([this](int chunks, const std::function<void(int, int)> &work) {
        pool_->share(chunks, work);
    });
}

Stabilizer::~Stabilizer()
{
    // Queued tasks call back into this object (pool_->submit from planning): let them all
    // finish while pool_ is still set. unique_ptr::reset nulls the pointer before the old
    // pool's destructor runs what is left, so resetting first would crash.
    pool_->waitIdle();
    pool_.reset();
}

// The lens settings it was built with, and what the profile says of the sensor where the
// config leaves it open: a known readout time, a global shutter (nothing to correct).
StabilizerConfig Stabilizer::withLens(StabilizerConfig config) const
{
    config.lens_profile = config_.lens_profile;
    config.lens_output = lens_output_;
    if (lens_profile_) {
        if (config.readout_time == 0.0 && lens_profile_->readout_time > 0.0 && !lens_profile_->readout_bottom_up)
            config.readout_time = lens_profile_->readout_time;
        if (lens_profile_->global_shutter && config.readout_time == 0.0)
            config.rolling_shutter = RollingShutter::Off;
    }
    return config;
}

void Stabilizer::checkFrameSize(int width, int height) const
{
    if (!lens_profile_)
        return;
    try {
        (void)lens_profile_->lens.scaledTo(width, height);
    } catch (const std::invalid_argument &e) {
        throw std::invalid_argument(config_.lens_profile + ": calib_dimension: " + e.what());
    }
}

void Stabilizer::setConfig(const StabilizerConfig &config)
{
    config.validate();
    std::lock_guard<std::mutex> lock(mutex_);
    next_config_ = config;
}

StabilizerConfig Stabilizer::config() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return next_config_ ? *next_config_ : config_;
}

void Stabilizer::applyConfig()
{
    std::lock_guard<std::mutex> lock(mutex_);
    if (!next_config_)
        return;
    const int threads = config_.threads;
    config_ = withLens(*next_config_);
    config_.threads = threads;  // the pool is rebuilt only in reset()
    next_config_.reset();
    estimator_->setConfig(config_);
    frame_config_ = std::make_shared<const StabilizerConfig>(config_);
}

void Stabilizer::setFrameInterval(double milliseconds)
{
    estimator_->setFrameInterval(milliseconds);
}

void Stabilizer::setReadyCallback(std::function<void()> callback)
{
    std::lock_guard<std::mutex> lock(mutex_);
    ready_callback_ = std::move(callback);
}

std::size_t Stabilizer::heldCount() const
{
    return held_.size();
}

std::size_t Stabilizer::finalizedCount() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return finalized_.size();
}

void Stabilizer::markDiscontinuity()
{
    discontinuity_ = true;
}

void Stabilizer::push(std::unique_ptr<FrameSlot> slot)
{
    pushHeld(std::move(slot));
    while (finalizeDue()) {
    }
}

std::size_t Stabilizer::dueCount() const
{
    const std::size_t delay = std::size_t(config_.delay);
    return held_.size() > delay ? held_.size() - delay : 0;
}

bool Stabilizer::finalizeDue()
{
    if (dueCount() == 0)
        return false;
    finalizeOldest();
    return true;
}

void Stabilizer::pushHeld(std::unique_ptr<FrameSlot> slot)
{
    if (!slot)
        throw std::invalid_argument("Stabilizer::push: null slot");
    const FrameView frame = slot->input();
    if (!frame.valid())
        throw std::invalid_argument("Stabilizer::push: invalid frame view");
    const bool new_geometry = !have_geometry_ || !frame.sameGeometry(geometry_);
    std::shared_ptr<const LensView> lens_view = lens_view_;
    if (lens_profile_ && new_geometry) {
        checkFrameSize(frame.width, frame.height);
        lens_view = std::make_shared<const LensView>(lens_profile_->lens.scaledTo(frame.width, frame.height),
                                                     lens_output_, frame.width, frame.height);
    }
    applyConfig();

    if (have_geometry_ && !frame.sameGeometry(geometry_)) {
        flush();
        discontinuity_ = true;
    }
    geometry_ = frame;
    have_geometry_ = true;
    if (lens_view != lens_view_) {
        lens_view_ = std::move(lens_view);
        estimator_->setLens(lens_view_);
    }
    if (discontinuity_)
        estimator_->reset();

    Held held;
    try {
        MotionEstimate estimate = estimator_->estimate(frame);
        held.stats.motion = estimate.motion;
        held.stats.model = estimate.model;
        held.stats.points = estimate.points;
        held.stats.inliers = estimate.inliers;
        held.stats.skipped = estimate.skipped;
        held.stats.tracks = std::move(estimate.tracks);
        held.stats.row_motion = std::move(estimate.row_motion);
        held.stats.readout = estimate.readout;
        held.stats.readout_confidence = estimate.readout_confidence;
        // A lost view (scene cut, flash) starts a new path: smoothing must not pull the
        // frames of one scene towards those of another.
        discontinuity_ = discontinuity_ || estimate.lost;
    } catch (const std::exception &) {
        // A frame the estimator cannot read gets no correction; tracking restarts.
        estimator_->reset();
        held.stats.skipped = true;
    }
    held.stats.segment_start = discontinuity_;
    held.stats.index = trajectory_->append(held.stats.motion, discontinuity_);
    held.stats.trajectory = trajectory_->pose(held.stats.index);
    discontinuity_ = false;
    held.slot = std::move(slot);
    held_.push_back(std::move(held));
}

void Stabilizer::flush()
{
    while (flushOne()) {
    }
}

bool Stabilizer::flushOne()
{
    applyConfig();
    if (held_.empty())
        return false;
    finalizeOldest();
    return true;
}

void Stabilizer::finalizeOldest()
{
    Held held = std::move(held_.front());
    held_.pop_front();

    auto pending = std::make_shared<Pending>();
    pending->stats = held.stats;
    pending->input = held.slot->input();
    pending->lens = lens_view_;
    if (config_.bypass) {
        pending->outcome = Outcome::Bypassed;
    } else {
        try {
            const std::optional<FrameView> out = held.slot->acquireOutput();
            if (!out) {
                pending->outcome = Outcome::NoOutput;
            } else if (!out->valid() || !out->sameGeometry(pending->input)) {
                pending->outcome = Outcome::Failed;
                pending->error = "output frame does not match the input frame";
            } else {
                pending->output = *out;
            }
        } catch (const std::exception &e) {
            pending->outcome = Outcome::Failed;
            pending->error = std::string("acquiring the output frame failed: ") + e.what();
        }
    }
    pending->slot = std::move(held.slot);

    // Every frame is planned, bypassed or not, so that the path goes on when bypass ends.
    PlanJob job;
    job.pending = pending;
    job.config = frame_config_;
    job.request.index = held.stats.index;
    job.request.segment_start = held.stats.segment_start;
    job.request.lookahead = trajectory_->lookahead(held.stats.index, config_.delay);
    job.request.width = pending->input.width;
    job.request.height = pending->input.height;
    // The planner keeps what it needs of the past; the path is needed from the oldest
    // held frame on.
    trajectory_->dropBefore(held_.empty() ? trajectory_->next() : held_.front().stats.index);

    bool start;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        finalized_.push_back(pending);
        plan_queue_.push_back(std::move(job));
        start = !planning_;
        planning_ = true;
    }
    if (start)
        pool_->submit([this] { planNext(); });
}

// A pool task: plans the oldest queued frame and starts its warp, then queues itself
// again behind that warp's stripes while frames wait. So planning is serialized and in
// frame order, and never holds a worker while warps wait.
void Stabilizer::planNext()
{
    PlanJob job;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (plan_queue_.empty()) {
            planning_ = false;
            return;
        }
        job = std::move(plan_queue_.front());
        plan_queue_.pop_front();
    }
    planAndWarp(job);
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (plan_queue_.empty()) {
            planning_ = false;
            return;
        }
    }
    pool_->submit([this] { planNext(); });
}

namespace {

// The planners keep the crop window's corners inside the frame as a pinhole camera sees it;
// through a lens the frame's edges bend, so the correction is shrunk further where some of
// the output would still read outside the picture.
void keepInsideThroughLens(const LensView &lens, FrameStats &stats)
{
    const std::vector<Point2> edge = lens.edgeInView(stats.zoom);
    if (lens.coversFrame(stats.output_to_input, edge))
        return;
    const double share = largestCoveredShare(stats.correction, stats.zoom, [&](const Similarity &output_to_input) {
        return lens.coversFrame(output_to_input, edge);
    });
    stats.correction = scaleCorrection(stats.correction, share);
    stats.output_to_input = stats.correction.inverse() * Similarity{0.0, 0.0, 0.0, 1.0 / stats.zoom};
    stats.correction_fraction *= share;
}

} // namespace

void Stabilizer::planAndWarp(PlanJob &job)
{
    const std::shared_ptr<Pending> &pending = job.pending;
    FrameStats &stats = pending->stats;
    try {
        if (!planner_ || !samePlanner(*planner_config_, *job.config))
            planner_ = makePathPlanner(*job.config);
        planner_config_ = job.config;
        const PlannedFrame planned = planner_->plan(job.request);
        stats.smoothed = planned.smoothed;
        stats.correction = planned.correction;
        stats.zoom = planned.zoom;
        stats.correction_fraction = planned.correction_fraction;
        stats.output_to_input = planned.output_to_input;
        if (pending->lens && job.config->limit_to_crop)
            keepInsideThroughLens(*pending->lens, stats);
        if (!stats.row_motion.empty() && pending->input.height > 1)
            pending->rows = rollingShutterWarp(stats.output_to_input, stats.row_motion, pending->input.width,
                                               pending->input.height);
    } catch (const std::exception &e) {
        planner_.reset();  // start afresh with the next frame
        std::lock_guard<std::mutex> lock(mutex_);
        if (pending->outcome == Outcome::Warped) {
            pending->outcome = Outcome::Failed;
            pending->error = std::string("planning the output path failed: ") + e.what();
        }
    }

    if (pending->outcome != Outcome::Warped) {
        pending->stripes_left = 1;
        completeStripe(pending);
        return;
    }

    if (pending->lens) {
        try {
            if (!lens_meshes_ || lens_meshes_->lens() != pending->lens)
                lens_meshes_ = std::make_unique<LensMeshes>(pending->lens);
            const int width = pending->input.width, height = pending->input.height;
            const std::array<double, 6> single = stats.output_to_input.pixelMatrix(width, height);
            if (pending->rows) {
                const RowMatrices rows(*pending->rows, width, height);
                pending->meshes = lens_meshes_->meshes(pending->input, stats.zoom, &rows, single);
            } else {
                pending->meshes = lens_meshes_->meshes(pending->input, stats.zoom, nullptr, single);
            }
        } catch (const std::exception &e) {
            std::lock_guard<std::mutex> lock(mutex_);
            pending->outcome = Outcome::Failed;
            pending->error = std::string("mapping the frame through the lens failed: ") + e.what();
            pending->stripes_left = 1;
        }
        if (pending->outcome != Outcome::Warped) {
            completeStripe(pending);
            return;
        }
    }

    // Image composition, split into row stripes so that all workers share one frame and
    // the frame is ready as soon as possible.
    const BorderMode border = job.config->border;
    const int height = pending->input.height;
    const int stripes = height < 2 * kMinStripeRows ? 1 : std::min(pool_->size(), height / kMinStripeRows);
    int rows = (height + stripes - 1) / stripes;
    rows = (rows + kStripeAlign - 1) / kStripeAlign * kStripeAlign;
    const int count = (height + rows - 1) / rows;
    pending->stripes_left = count;
    if (job.config->debug_overlay)
        pending->overlay = job.config;
    for (int s = 1; s < count; ++s) {
        const int begin = s * rows, end = std::min(height, begin + rows);
        pool_->submit([this, pending, border, begin, end] { runStripe(pending, border, begin, end); });
    }
    runStripe(pending, border, 0, std::min(height, rows));
}

void Stabilizer::runStripe(const std::shared_ptr<Pending> &pending, BorderMode border, int begin, int end)
{
    try {
        if (!pending->meshes.empty())
            FrameWarper(border).warpRows(pending->input, pending->output, pending->meshes, begin, end);
        else if (pending->rows)
            FrameWarper(border).warpRows(pending->input, pending->output, *pending->rows, begin, end);
        else
            FrameWarper(border).warpRows(pending->input, pending->output, pending->stats.output_to_input, begin, end);
    } catch (const std::exception &e) {
        std::lock_guard<std::mutex> lock(mutex_);
        pending->outcome = Outcome::Failed;
        pending->error = std::string("warping failed: ") + e.what();
    }
    completeStripe(pending);
}

void Stabilizer::completeStripe(const std::shared_ptr<Pending> &pending)
{
    if (pending->stripes_left.fetch_sub(1) != 1)
        return;
    if (pending->overlay) {  // the whole frame is warped: draw over it
        bool warped;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            warped = pending->outcome == Outcome::Warped;
        }
        if (warped)
            drawDebugOverlay(pending->output, pending->stats, pending->overlay->exclude);
        pending->overlay.reset();
    }
    std::function<void()> callback;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        pending->ready = true;
        callback = ready_callback_;
    }
    ready_.notify_all();
    if (callback)
        callback();
}

StabilizedFrame Stabilizer::take(std::unique_lock<std::mutex> &)
{
    std::shared_ptr<Pending> pending = std::move(finalized_.front());
    finalized_.pop_front();
    StabilizedFrame frame;
    frame.slot = std::move(pending->slot);
    frame.stats = pending->stats;
    frame.outcome = pending->outcome;
    frame.error = std::move(pending->error);
    return frame;
}

std::optional<StabilizedFrame> Stabilizer::tryPop()
{
    std::unique_lock<std::mutex> lock(mutex_);
    if (finalized_.empty() || !finalized_.front()->ready)
        return std::nullopt;
    return take(lock);
}

std::optional<StabilizedFrame> Stabilizer::waitPop()
{
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [this] { return finalized_.empty() || finalized_.front()->ready; });
    if (finalized_.empty())
        return std::nullopt;
    return take(lock);
}

void Stabilizer::waitForAllFinalized(std::unique_lock<std::mutex> &lock)
{
    ready_.wait(lock, [this] {
        return std::all_of(finalized_.begin(), finalized_.end(), [](const auto &p) { return p->ready; });
    });
}

void Stabilizer::reset()
{
    held_.clear();
    {
        std::unique_lock<std::mutex> lock(mutex_);
        waitForAllFinalized(lock);
        // Release the frames here, not whenever a worker drops its last reference: the
        // caller may rely on every frame being gone when reset() returns.
        for (auto &pending : finalized_)
            pending->slot.reset();
        finalized_.clear();
        if (next_config_) {
            config_ = withLens(*next_config_);
            next_config_.reset();
        }
    }
    // Every frame is ready, but the planning task may still be on its way out.
    pool_->waitIdle();
    planner_.reset();
    planner_config_.reset();
    lens_meshes_.reset();
    frame_config_ = std::make_shared<const StabilizerConfig>(config_);
    estimator_->setConfig(config_);
    estimator_->reset();
    if (pool_->size() != config_.resolvedThreads())
        pool_ = std::make_unique<WorkerPool>(config_.resolvedThreads());
    trajectory_->clear();
    discontinuity_ = true;
    have_geometry_ = false;
}

} // namespace uavstab
