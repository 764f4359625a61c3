// The element's properties as the streaming thread and the queries read them: each read
// takes the object lock (property setters hold it too).
#include <stdexcept>

#include "uavstabilize_element.hpp"

#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace gstuavstab {

uavstab::StabilizerConfig takeConfig(GstUavStabilize *self)
{
    GST_OBJECT_LOCK(self);
    const uavstab::StabilizerConfig config = self->settings->stabilizer;
    self->settings->dirty = false;
    GST_OBJECT_UNLOCK(self);
    return config;
}

guint currentDelay(GstUavStabilize *self)
{
    GST_OBJECT_LOCK(self);
    const guint delay = guint(self->settings->stabilizer.delay);
    GST_OBJECT_UNLOCK(self);
    return delay;
}

int maxErrors(GstUavStabilize *self)
{
    GST_OBJECT_LOCK(self);
    const int max_errors = self->settings->max_errors;
    GST_OBJECT_UNLOCK(self);
    return max_errors;
}

bool postMessagesEnabled(GstUavStabilize *self)
{
    GST_OBJECT_LOCK(self);
    const bool enabled = self->settings->post_messages;
    GST_OBJECT_UNLOCK(self);
    return enabled;
}

void applyChangedSettings(GstUavStabilize *self, UavStabilizeState &s)
{
    GST_OBJECT_LOCK(self);
    const bool dirty = self->settings->dirty;
    GST_OBJECT_UNLOCK(self);
    if (!dirty)
        return;
    const uavstab::StabilizerConfig config = takeConfig(self);
    try {
        s.stabilizer->setConfig(config);
    } catch (const std::invalid_argument &e) {
        GST_ELEMENT_WARNING(self, LIBRARY, SETTINGS, ("Invalid stabilizer settings; keeping the previous ones"),
                            ("%s", e.what()));
    }
}

void postLatencyChanged(GstUavStabilize *self)
{
    gst_element_post_message(GST_ELEMENT(self), gst_message_new_latency(GST_OBJECT(self)));
}

} // namespace gstuavstab
