// The element's output, in input order: frames (whose pixels the stabilizer still holds)
// interleaved with the serialized events that arrived between them. An event waits
// behind the frames queued before it, so SEGMENT, TAG, GAP, EOS... keep their place.
//
// Not thread-safe: the element guards it with its own mutex.
#pragma once

#include <cstddef>
#include <deque>
#include <memory>
#include <vector>

#include <gst/gst.h>

struct EventUnref {
    void operator()(GstEvent *event) const { gst_event_unref(event); }
};
using EventPtr = std::unique_ptr<GstEvent, EventUnref>;

class OutputQueue {
public:
    // The next result the stabilizer hands back (it returns frames in push order).
    void pushFrame() { items_.emplace_back(); }
    void pushEvent(EventPtr event) { items_.push_back(std::move(event)); }

    bool empty() const { return items_.empty(); }
    std::size_t size() const { return items_.size(); }
    bool frontIsFrame() const { return !items_.empty() && !items_.front(); }
    bool frontIsEvent() const { return !items_.empty() && items_.front(); }
    bool holdsEvent(GstEventType type) const
    {
        for (const EventPtr &item : items_)
            if (item && GST_EVENT_TYPE(item.get()) == type)
                return true;
        return false;
    }

    void popFrame() { items_.pop_front(); }
    EventPtr popEvent()
    {
        EventPtr event = std::move(items_.front());
        items_.pop_front();
        return event;
    }
    // Drops every item; queued events are released.
    void clear() { items_.clear(); }
    // A flush: drops every item but hands back, in order, the queued sticky events that a
    // flush leaves standing on a pad (all but SEGMENT and EOS).
    std::vector<EventPtr> flush()
    {
        std::vector<EventPtr> kept;
        for (EventPtr &item : items_) {
            if (!item || !GST_EVENT_IS_STICKY(item.get()))
                continue;
            const GstEventType type = GST_EVENT_TYPE(item.get());
            if (type != GST_EVENT_SEGMENT && type != GST_EVENT_EOS && type != GST_EVENT_STREAM_GROUP_DONE)
                kept.push_back(std::move(item));
        }
        items_.clear();
        return kept;
    }

private:
    std::deque<EventPtr> items_;  // null = a frame
};
