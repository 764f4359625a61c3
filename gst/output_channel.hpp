// What the element's threads share about its output: the ordered output queue, the
// output buffer pool, and the flags that say whether data may flow (flushing, the task
// pushing an item, EOS queued, what downstream last returned), under one mutex with one
// condition. Every flag changes here, in one named operation each:
//
//   streaming thread     flow, queueFrameWhenRoom, waitForRoom, queueEvent,
//                        waitUntilDrained, replacePool, stopFlushing (FLUSH_STOP),
//                        recordError, acquireBuffer (through the frame slots)
//   src pad task         takeNext, finishPush, finishEos, abortPush
//   flushing threads     startFlushing (FLUSH_START, pad deactivation)
//   worker threads       notify (a warp is done)
//   state changes        activate / deactivate (src pad), clear and replacePool
//                        (stream stopped)
//
// The stabilizer is not part of it; operations that wait on it take a callable that is
// run under the mutex (as it always was: the mutex comes before the stabilizer's).
#pragma once

#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <vector>

#include <gst/gst.h>

#include "output_queue.hpp"
#include "uavstab/stabilizer.hpp"

class OutputChannel {
public:
    // `owner` names the element in log lines.
    explicit OutputChannel(GstObject *owner) : owner_(owner) {}
    // Releases queued events and deactivates the pool.
    ~OutputChannel();
    OutputChannel(const OutputChannel &) = delete;
    OutputChannel &operator=(const OutputChannel &) = delete;

    // --- Flushing and activation

    // Data stops: waiters wake up, a chain blocked on an output buffer returns.
    void startFlushing();
    // FLUSH_STOP: drops every queued item and lets data flow again (downstream's last
    // flow return and a queued EOS are forgotten). Hands back the queued sticky events
    // but SEGMENT and EOS: upstream holds them as delivered and does not send them
    // again, so the caller keeps them on the src pad (as queue does).
    std::vector<EventPtr> stopFlushing();
    // The src pad goes active: data may flow (the queue is empty then).
    void activate();
    // The src pad goes inactive: data stops (as startFlushing) until activate(); a
    // FLUSH_STOP meanwhile does not let it flow again.
    void deactivate();
    // The stream stopped (pads inactive): drops every queued item.
    void clear();
    bool flushing() const;

    // --- Streaming thread

    // FLUSHING while flushing, else what downstream last returned (OK if nothing bad).
    GstFlowReturn flow() const;
    // Backpressure: waits until `has_room()` (run under the mutex), flushing, or a flow
    // error, and returns flow(). queueFrameWhenRoom() also records the next frame in
    // the output order when the flow is OK.
    GstFlowReturn waitForRoom(const std::function<bool()> &has_room);
    GstFlowReturn queueFrameWhenRoom(const std::function<bool()> &has_room);
    enum class EventQueued {
        Refused,  // flushing, or downstream stopped taking data
        Queued,
        QueuedAfterEos,  // a new stream after EOS: the caller restarts the task
    };
    // A serialized event waits behind the frames queued before it.
    EventQueued queueEvent(EventPtr event);
    // Waits until every queued item is pushed and the task is idle. False when flushing
    // or when downstream stopped taking data.
    bool waitUntilDrained();
    // A C++ exception at a pad boundary: data stops as after a downstream error.
    void recordError();

    // --- Src pad task

    // The next item to push: waits for the front of the queue, an event, or a frame
    // that `try_pop()` (run under the mutex) hands back. False when flushing; otherwise
    // exactly one of `frame` and `event` is set, and the task is pushing until
    // finishPush() or abortPush().
    bool takeNext(const std::function<std::optional<uavstab::StabilizedFrame>()> &try_pop,
                  std::optional<uavstab::StabilizedFrame> &frame, EventPtr &event);
    // The push returned `ret` (remembered unless OK or flushing); when not OK, the task
    // stops: `pause_task` is run under the mutex, so that a restart for a new stream
    // (queueEvent decides it under the mutex too) cannot fall between the flow being
    // set and the pause, and be undone by it. True when upstream had already sent EOS,
    // so that no chain call will see a flow error.
    bool finishPush(GstFlowReturn ret, const std::function<void()> &pause_task);
    // The task pushed EOS: data stops (flow EOS, `pause_task` run as above) until
    // FLUSH_STOP or a new stream, whose STREAM_START restarts the task (queueEvent).
    // True when a new stream is queued behind the EOS already (its STREAM_START came
    // before the EOS went out): the task goes on with it.
    bool finishEos(const std::function<void()> &pause_task);
    // The push failed with an exception: data stops with GST_FLOW_ERROR.
    void abortPush();

    // --- Output buffers

    // Installs `pool` (may be null; takes the reference), and deactivates and releases
    // the previous one.
    void replacePool(GstBufferPool *pool);
    // A buffer from the pool; null when flushing or when there is no pool. May block
    // until downstream returns a buffer (startFlushing() wakes it).
    GstBuffer *acquireBuffer();

    // Wakes the src task (a worker finished a warp).
    void notify();

private:
    GstFlowReturn flowLocked() const;
    // Not flushing, not pushing, no EOS queued, no flow error remembered; the output pool
    // hands out buffers again.
    void letDataFlowLocked();
    // Data stops with `ret` (downstream's, or an error): remembered, and the output pool
    // set flushing so that a chain waiting for a buffer returns.
    void stopDataLocked(GstFlowReturn ret);
    void setPoolFlushingLocked(bool flushing);

    GstObject *owner_;
    mutable std::mutex mutex_;
    // Each waiter has its own: the streaming thread (room for a frame, the queue drained:
    // what the task's pushes change) and the src task (a frame ready, an event queued),
    // so that neither is woken for the other's changes. Flushing, errors: both.
    std::condition_variable chain_wake_;
    std::condition_variable task_wake_;
    OutputQueue queue_;
    bool flushing_ = true;
    bool active_ = false;      // the src pad is active (between activate and deactivate)
    bool pushing_ = false;     // the task is pushing an item it took off the queue
    bool eos_queued_ = false;  // upstream sent EOS: no chain call will see a flow error
    GstFlowReturn last_flow_ = GST_FLOW_OK;  // what downstream last returned, if not OK
    GstBufferPool *pool_ = nullptr;          // output buffers, negotiated with downstream
};
