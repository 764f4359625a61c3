#include "output_channel.hpp"

GST_DEBUG_CATEGORY_EXTERN(gst_uav_stabilize_debug);
#define GST_CAT_DEFAULT gst_uav_stabilize_debug

OutputChannel::~OutputChannel()
{
    queue_.clear();
    if (pool_) {
        gst_buffer_pool_set_active(pool_, FALSE);
        gst_object_unref(pool_);
    }
}

// ---------------------------------------------------------------------------------
// Flushing and activation

void OutputChannel::startFlushing()
{
    std::lock_guard<std::mutex> lock(mutex_);
    flushing_ = true;
    // Wakes a chain blocked in acquireBuffer().
    setPoolFlushingLocked(true);
    chain_wake_.notify_all();
    task_wake_.notify_all();
}

void OutputChannel::setPoolFlushingLocked(bool flushing)
{
    if (pool_ && gst_buffer_pool_is_active(pool_))
        gst_buffer_pool_set_flushing(pool_, flushing);
}

void OutputChannel::stopDataLocked(GstFlowReturn ret)
{
    last_flow_ = ret;
    // A chain waiting for an output buffer returns (the frames holding the buffers wait
    // for the task, which has stopped).
    setPoolFlushingLocked(true);
}

void OutputChannel::letDataFlowLocked()
{
    flushing_ = false;
    pushing_ = false;
    eos_queued_ = false;
    last_flow_ = GST_FLOW_OK;
    setPoolFlushingLocked(false);
}

std::vector<EventPtr> OutputChannel::stopFlushing()
{
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<EventPtr> sticky = queue_.flush();
    // A FLUSH_STOP that comes in while the element is stopping (src pad inactive, sink pad
    // not yet) must not undo the deactivation: the task being stopped would go on
    // waiting for data, and the state change for the task.
    if (active_)
        letDataFlowLocked();
    return sticky;
}

void OutputChannel::activate()
{
    std::lock_guard<std::mutex> lock(mutex_);
    active_ = true;
    letDataFlowLocked();
}

void OutputChannel::deactivate()
{
    std::lock_guard<std::mutex> lock(mutex_);
    active_ = false;
    flushing_ = true;
    setPoolFlushingLocked(true);
    chain_wake_.notify_all();
    task_wake_.notify_all();
}

void OutputChannel::clear()
{
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.clear();
    pushing_ = false;
}

bool OutputChannel::flushing() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return flushing_;
}

// ---------------------------------------------------------------------------------
// Streaming thread

GstFlowReturn OutputChannel::flowLocked() const
{
    return flushing_ ? GST_FLOW_FLUSHING : last_flow_;
}

GstFlowReturn OutputChannel::flow() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return flowLocked();
}

GstFlowReturn OutputChannel::waitForRoom(const std::function<bool()> &has_room)
{
    std::unique_lock<std::mutex> lock(mutex_);
    chain_wake_.wait(lock, [&] { return flushing_ || last_flow_ != GST_FLOW_OK || has_room(); });
    return flowLocked();
}

GstFlowReturn OutputChannel::queueFrameWhenRoom(const std::function<bool()> &has_room)
{
    std::unique_lock<std::mutex> lock(mutex_);
    chain_wake_.wait(lock, [&] { return flushing_ || last_flow_ != GST_FLOW_OK || has_room(); });
    const GstFlowReturn ret = flowLocked();
    if (ret == GST_FLOW_OK)
        queue_.pushFrame();
    return ret;
}

OutputChannel::EventQueued OutputChannel::queueEvent(EventPtr event)
{
    const GstEventType type = GST_EVENT_TYPE(event.get());
    EventQueued result = EventQueued::Queued;
    std::lock_guard<std::mutex> lock(mutex_);
    if (flushing_)
        return EventQueued::Refused;
    if (last_flow_ == GST_FLOW_EOS && (type == GST_EVENT_STREAM_START || type == GST_EVENT_SEGMENT)) {
        // A new stream after EOS: data may flow again.
        last_flow_ = GST_FLOW_OK;
        eos_queued_ = false;
        setPoolFlushingLocked(false);
        result = EventQueued::QueuedAfterEos;
    } else if (last_flow_ != GST_FLOW_OK) {
        GST_DEBUG_OBJECT(owner_, "refusing %" GST_PTR_FORMAT ": downstream returned %s", event.get(),
                         gst_flow_get_name(last_flow_));
        return EventQueued::Refused;
    }
    if (type == GST_EVENT_EOS)
        eos_queued_ = true;
    queue_.pushEvent(std::move(event));
    task_wake_.notify_all();
    return result;
}

bool OutputChannel::waitUntilDrained()
{
    std::unique_lock<std::mutex> lock(mutex_);
    chain_wake_.wait(lock, [&] { return flushing_ || last_flow_ != GST_FLOW_OK || (queue_.empty() && !pushing_); });
    return !flushing_ && last_flow_ == GST_FLOW_OK;
}

void OutputChannel::recordError()
{
    std::lock_guard<std::mutex> lock(mutex_);
    stopDataLocked(GST_FLOW_ERROR);
    chain_wake_.notify_all();
    task_wake_.notify_all();
}

// ---------------------------------------------------------------------------------
// Src pad task

bool OutputChannel::takeNext(const std::function<std::optional<uavstab::StabilizedFrame>()> &try_pop,
                             std::optional<uavstab::StabilizedFrame> &frame, EventPtr &event)
{
    std::unique_lock<std::mutex> lock(mutex_);
    task_wake_.wait(lock, [&] {
        if (flushing_ || queue_.frontIsEvent())
            return true;
        if (!queue_.frontIsFrame())
            return false;
        frame = try_pop();
        return frame.has_value();
    });
    if (flushing_)
        return false;
    if (frame)
        queue_.popFrame();
    else
        event = queue_.popEvent();
    pushing_ = true;
    return true;
}

bool OutputChannel::finishPush(GstFlowReturn ret, const std::function<void()> &pause_task)
{
    bool eos_queued;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        pushing_ = false;
        if (ret != GST_FLOW_OK) {
            if (!flushing_)
                stopDataLocked(ret);
            pause_task();
        }
        eos_queued = eos_queued_;
    }
    // Outside the mutex: a waiter woken while it is held would only block on it again.
    chain_wake_.notify_all();
    return eos_queued;
}

bool OutputChannel::finishEos(const std::function<void()> &pause_task)
{
    std::lock_guard<std::mutex> lock(mutex_);
    pushing_ = false;
    chain_wake_.notify_all();
    if (!queue_.empty()) {
        // After EOS the sink pad takes nothing but STREAM_START (or a flush, which empties
        // the queue), so what is queued is a new stream: go on with it.
        eos_queued_ = queue_.holdsEvent(GST_EVENT_EOS);
        return true;
    }
    if (!flushing_)
        stopDataLocked(GST_FLOW_EOS);
    pause_task();
    return false;
}

void OutputChannel::abortPush()
{
    std::lock_guard<std::mutex> lock(mutex_);
    pushing_ = false;
    stopDataLocked(GST_FLOW_ERROR);
    chain_wake_.notify_all();
}

// ---------------------------------------------------------------------------------
// Output buffers

void OutputChannel::replacePool(GstBufferPool *pool)
{
    GstBufferPool *old;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        old = pool_;
        pool_ = pool;
    }
    if (old) {
        gst_buffer_pool_set_active(old, FALSE);
        gst_object_unref(old);
    }
}

GstBuffer *OutputChannel::acquireBuffer()
{
    GstBufferPool *current;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (flushing_ || !pool_)
            return nullptr;
        current = GST_BUFFER_POOL(gst_object_ref(pool_));
    }
    // May block until downstream returns a buffer; startFlushing() sets the pool flushing.
    GstBuffer *buffer = nullptr;
    const GstFlowReturn ret = gst_buffer_pool_acquire_buffer(current, &buffer, nullptr);
    gst_object_unref(current);
    if (ret != GST_FLOW_OK) {
        GST_DEBUG("no output buffer: %s", gst_flow_get_name(ret));
        return nullptr;
    }
    return buffer;
}

void OutputChannel::notify()
{
    // The change (a frame became ready) happened outside this mutex. Taking the mutex once
    // means a waiter that checked before the change is waiting by now, so it cannot miss the
    // notification; sending it after the mutex is released spares the woken task blocking on it.
    { std::lock_guard<std::mutex> lock(mutex_); }
    task_wake_.notify_all();
}
