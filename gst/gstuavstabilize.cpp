/**
 * SECTION:element-uavstabilize
 * @title: uavstabilize
 *
 * Real-time video stabilization for UAV footage (Lim et al., "Real-Time Optical
 * flow-based Video Stabilization for UAVs"): corners are tracked with pyramidal
 * Lucas-Kanade optical flow, a rigid or similarity motion is fitted per frame, the
 * camera path is smoothed over a window of frames and every frame is warped onto the
 * smoothed path, zoomed in by #GstUavStabilize:crop to hide the borders.
 *
 * The element holds #GstUavStabilize:delay frames so that the smoothing window can look
 * ahead; the LATENCY query reports delay × frame duration on top of upstream's latency.
 * With #GstUavStabilize:post-messages, an element message named `uavstabilize` is posted
 * per frame with the estimated motion, the camera path, the smoothed path and the applied
 * correction (angles in radians); frame_statistics.hpp lists the fields.
 *
 * ## Example launch lines
 * |[
 * gst-launch-1.0 filesrc location=flight.mp4 ! decodebin ! videoconvert ! uavstabilize ! videoconvert ! autovideosink
 * gst-launch-1.0 v4l2src ! video/x-raw,format=NV12 ! uavstabilize delay=10 crop=0.1 ! videoconvert ! autovideosink
 * gst-launch-1.0 -m filesrc location=flight.y4m ! y4mdec ! uavstabilize post-messages=true ! fakesink
 * gst-launch-1.0 filesrc location=flight.mp4 ! decodebin ! videoconvert ! video/x-raw,format=RGBA ! uavstabilize ! glupload ! glimagesink
 * ]|
 *
 * With #GstUavStabilize:render = affine-meta (or auto, when downstream's ALLOCATION answer
 * lists GstVideoAffineTransformationMeta) frames are not warped: each input buffer goes
 * downstream untouched with that meta, for a GL element to apply as it draws.
 *
 * ## Design
 * A plain element, not a base transform: base transforms forward serialized events
 * ahead of the frames they hold and drop input on QoS. The sink pad's streaming thread
 * maps each input buffer (no copy) and pushes it into the uavstab::Stabilizer, which
 * estimates motion there and warps on its worker pool. An ordered output queue records
 * "next frame" placeholders and serialized events in arrival order; a task on the src
 * pad (like `queue`) pushes each frame as soon as its warp is done, and each event once
 * the frames before it are out.
 */
#include "gstuavstabilize.hpp"

#include <memory>
#include <stdexcept>

#include <gst/video/video.h>

#include "uavstab/lens.hpp"
#include "uavstabilize_element.hpp"
#include "uavstabilize_properties.hpp"

GST_DEBUG_CATEGORY(gst_uav_stabilize_debug);
#define GST_CAT_DEFAULT gst_uav_stabilize_debug

using gstuavstab::stateOf;

namespace {

#define UAVSTABILIZE_CAPS                                                                                     \
    "video/x-raw, "                                                                                           \
    "format = (string) { I420, YV12, NV12, NV21, GRAY8, RGB, BGR, RGBA, BGRA, RGBx, BGRx, GRAY16_LE, GRAY16_BE }, " \
    "width = (int) [ 16, MAX ], height = (int) [ 16, MAX ], framerate = (fraction) [ 0/1, MAX ], "              \
    "interlace-mode = (string) progressive"

GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(UAVSTABILIZE_CAPS));
GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(UAVSTABILIZE_CAPS));

constexpr const char *kDescription =
    "Stabilizes shaky aerial (UAV) video in real time: tracks corners with pyramidal Lucas-Kanade "
    "optical flow, fits a rigid or similarity motion per frame, smooths the camera path over a "
    "window of frames and warps every frame onto the smoothed path, zoomed in by 'crop' to hide "
    "the borders. Output is 'delay' frames late (reported as latency) so the smoothing window can "
    "look ahead. With post-messages=true an element message 'uavstabilize' is posted per frame "
    "(motion, trajectory, smoothed path, correction; angles in radians). With render=affine-meta (or "
    "auto, in front of glimagesink or glvideomixer) frames are not warped on the CPU: each goes "
    "downstream untouched with a GstVideoAffineTransformationMeta that the GL element applies as it "
    "draws.\n"
    "\n"
    "Example launch lines:\n"
    "  gst-launch-1.0 filesrc location=flight.mp4 ! decodebin ! videoconvert ! uavstabilize ! "
    "videoconvert ! autovideosink\n"
    "  gst-launch-1.0 v4l2src ! video/x-raw,format=NV12 ! uavstabilize delay=10 crop=0.1 ! "
    "videoconvert ! autovideosink\n"
    "  gst-launch-1.0 -m filesrc location=flight.y4m ! y4mdec ! uavstabilize post-messages=true ! "
    "fakesink\n"
    "  gst-launch-1.0 filesrc location=flight.mp4 ! decodebin ! videoconvert ! video/x-raw,format=RGBA ! "
    "uavstabilize ! glupload ! glimagesink";

} // namespace

G_DEFINE_TYPE_WITH_CODE(GstUavStabilize, gst_uav_stabilize, GST_TYPE_ELEMENT,
                        GST_DEBUG_CATEGORY_INIT(gst_uav_stabilize_debug, "uavstabilize", 0,
                                                "UAV video stabilizer"));
GST_ELEMENT_REGISTER_DEFINE(uavstabilize, "uavstabilize", GST_RANK_NONE, GST_TYPE_UAV_STABILIZE);

UavStabilizeState::~UavStabilizeState()
{
    // Normally empty already (PAUSED->READY drops everything); the output channel then
    // releases queued events and the output pool.
    stabilizer.reset();
    if (caps)
        gst_caps_unref(caps);
}

namespace {

// ---------------------------------------------------------------------------------
// Pad activation and state changes

gboolean srcActivateMode(GstPad *pad, GstObject *parent, GstPadMode mode, gboolean active)
{
    auto *self = GST_UAV_STABILIZE(parent);
    UavStabilizeState &s = stateOf(self);
    if (mode != GST_PAD_MODE_PUSH)
        return FALSE;
    if (active) {
        s.output.activate();
        return gst_pad_start_task(pad, gstuavstab::srcLoop, self, nullptr);
    }
    // Wakes the task and a blocked chain; the task then pauses itself and is joined.
    s.output.deactivate();
    return gst_pad_stop_task(pad);
}

gboolean sinkActivateMode(GstPad *, GstObject *parent, GstPadMode mode, gboolean active)
{
    if (mode != GST_PAD_MODE_PUSH)
        return FALSE;
    if (!active)
        stateOf(GST_UAV_STABILIZE(parent)).output.startFlushing();  // a chain may be waiting
    return TRUE;
}

bool startStream(GstUavStabilize *self, UavStabilizeState &s)
{
    const uavstab::StabilizerConfig config = gstuavstab::takeConfig(self);
    try {
        s.stabilizer = std::make_unique<uavstab::Stabilizer>(config);
    } catch (const uavstab::LensProfileError &e) {
        GST_ELEMENT_ERROR(self, RESOURCE, SETTINGS, ("Cannot use the lens profile %s", e.file().c_str()),
                          ("%s", e.what()));
        return false;
    } catch (const std::exception &e) {
        GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Cannot create the stabilizer"), ("%s", e.what()));
        return false;
    }
    // Runs on a worker thread: only signal.
    s.stabilizer->setReadyCallback([&s] { s.output.notify(); });
    s.max_finalized = gstuavstab::maxFinalizedFor(config.resolvedThreads());
    s.max_drain_finalized = std::size_t(config.resolvedThreads()) + 2;
    gst_segment_init(&s.output_segment, GST_FORMAT_UNDEFINED);
    return true;
}

// With the pads deactivated (task stopped, no chain running): drops everything.
void stopStream(UavStabilizeState &s)
{
    s.stabilizer.reset();  // waits for warps in flight; releases every held buffer
    s.output.clear();
    s.timing.reset();
    s.output.replacePool(nullptr);
    gst_caps_replace(&s.caps, nullptr);
    gst_video_info_init(&s.info);
    s.reported_errors.clear();
    s.bad_buffers = 0;
}

GstStateChangeReturn changeState(GstElement *element, GstStateChange transition)
{
    auto *self = GST_UAV_STABILIZE(element);
    UavStabilizeState &s = stateOf(self);
    if (transition == GST_STATE_CHANGE_READY_TO_PAUSED && !startStream(self, s))
        return GST_STATE_CHANGE_FAILURE;

    const GstStateChangeReturn ret = GST_ELEMENT_CLASS(gst_uav_stabilize_parent_class)->change_state(element, transition);

    if (transition == GST_STATE_CHANGE_PAUSED_TO_READY ||
        (transition == GST_STATE_CHANGE_READY_TO_PAUSED && ret == GST_STATE_CHANGE_FAILURE))
        stopStream(s);
    return ret;
}

// ---------------------------------------------------------------------------------
// Properties

void setProperty(GObject *object, guint id, const GValue *value, GParamSpec *pspec)
{
    auto *self = GST_UAV_STABILIZE(object);
    GST_OBJECT_LOCK(self);
    const int old_delay = self->settings->stabilizer.delay;
    std::string refusal;
    const bool known = gstuavstab::setProperty(*self->settings, id, value, &refusal);
    const bool delay_changed = self->settings->stabilizer.delay != old_delay;
    GST_OBJECT_UNLOCK(self);
    if (!known)
        G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
    if (!refusal.empty())  // as GLib warns about a number out of a property's range
        g_warning("%s: %s; keeping the previous value", GST_OBJECT_NAME(self), refusal.c_str());
    if (delay_changed)
        gstuavstab::postLatencyChanged(self);
}

void getProperty(GObject *object, guint id, GValue *value, GParamSpec *pspec)
{
    auto *self = GST_UAV_STABILIZE(object);
    GST_OBJECT_LOCK(self);
    const bool known = gstuavstab::getProperty(*self->settings, id, value);
    GST_OBJECT_UNLOCK(self);
    if (!known)
        G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
}

void finalize(GObject *object)
{
    auto *self = GST_UAV_STABILIZE(object);
    delete self->state;
    delete self->settings;
    self->state = nullptr;
    self->settings = nullptr;
    G_OBJECT_CLASS(gst_uav_stabilize_parent_class)->finalize(object);
}

} // namespace

static void gst_uav_stabilize_class_init(GstUavStabilizeClass *klass)
{
    auto *gobject_class = G_OBJECT_CLASS(klass);
    auto *element_class = GST_ELEMENT_CLASS(klass);
    gobject_class->set_property = setProperty;
    gobject_class->get_property = getProperty;
    gobject_class->finalize = finalize;
    gstuavstab::installProperties(gobject_class);

    gst_element_class_add_static_pad_template(element_class, &sink_template);
    gst_element_class_add_static_pad_template(element_class, &src_template);
    gst_element_class_set_static_metadata(element_class, "UAV video stabilizer", "Filter/Effect/Video",
                                          kDescription, "uavstabilize contributors");
    element_class->change_state = changeState;

    gstuavstab::markEnumTypesAsPluginApi();
}

static void gst_uav_stabilize_init(GstUavStabilize *self)
{
    self->settings = new UavStabilizeSettings();
    self->state = new UavStabilizeState(GST_OBJECT(self));
    gst_video_info_init(&self->state->info);

    self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
    gst_pad_set_chain_function(self->sinkpad, gstuavstab::sinkChain);
    gst_pad_set_event_function(self->sinkpad, gstuavstab::sinkEvent);
    gst_pad_set_query_function(self->sinkpad, gstuavstab::sinkQuery);
    gst_pad_set_activatemode_function(self->sinkpad, sinkActivateMode);
    GST_PAD_SET_PROXY_CAPS(self->sinkpad);
    gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);

    self->srcpad = gst_pad_new_from_static_template(&src_template, "src");
    gst_pad_set_query_function(self->srcpad, gstuavstab::srcQuery);
    gst_pad_set_activatemode_function(self->srcpad, srcActivateMode);
    GST_PAD_SET_PROXY_CAPS(self->srcpad);
    gst_element_add_pad(GST_ELEMENT(self), self->srcpad);
}
