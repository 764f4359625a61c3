// Queries on both pads: caps (the output caps are the input caps), accept-caps
// (progressive only), allocation (upstream's pool must cover the held frames), drain,
// and latency (delay x frame duration on top of upstream's).
#include <stdexcept>

#include "output_pool.hpp"
#include "uavstabilize_element.hpp"

#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace gstuavstab {

namespace {

// Frame duration assumed for the latency when neither caps nor buffers tell.
constexpr GstClockTime kFallbackFrameDuration = GST_SECOND / 30;

// Caps without an interlace-mode field are progressive (GstVideoInfo reads them so); the
// template names the field, so add it before comparing.
GstCaps *withInterlaceMode(GstCaps *caps)
{
    GstCaps *copy = gst_caps_copy(caps);
    for (guint i = 0; i < gst_caps_get_size(copy); ++i) {
        GstStructure *structure = gst_caps_get_structure(copy, i);
        if (!gst_structure_has_field(structure, "interlace-mode"))
            gst_structure_set(structure, "interlace-mode", G_TYPE_STRING, "progressive", nullptr);
    }
    return copy;
}

bool acceptCaps(GstUavStabilize *self, GstPad *pad, GstQuery *query)
{
    GstCaps *caps = nullptr;
    gst_query_parse_accept_caps(query, &caps);
    GstCaps *templ = gst_pad_get_pad_template_caps(pad);
    // Interlaced frames are refused: warping a frame of two fields moves each field's lines
    // into the other's, so the output would comb. A deinterlacer in front fixes that.
    GstCaps *normalized = withInterlaceMode(caps);
    bool accepted = gst_caps_is_subset(normalized, templ);
    gst_caps_unref(normalized);
    gst_caps_unref(templ);
    if (!accepted)
        GST_INFO_OBJECT(self, "refusing %" GST_PTR_FORMAT " (the template takes the listed formats, 16x16 and "
                        "up, progressive only: interlaced video needs a deinterlacer in front)", caps);
    // Output caps are the input caps, so downstream must take them too.
    if (accepted && gst_pad_is_linked(self->srcpad))
        accepted = gst_pad_peer_query_accept_caps(self->srcpad, caps);
    gst_query_set_accept_caps_result(query, accepted);
    return true;
}

bool handleSinkQuery(GstUavStabilize *self, UavStabilizeState &s, GstPad *pad, GstQuery *query)
{
    switch (GST_QUERY_TYPE(query)) {
    case GST_QUERY_CAPS:
        return gst_pad_proxy_query_caps(pad, query);
    case GST_QUERY_ACCEPT_CAPS:
        return acceptCaps(self, pad, query);
    case GST_QUERY_ALLOCATION:
        // Upstream's pool must cover the frames we hold. Frames that go downstream
        // untouched may as well be written into downstream's buffers.
        if (s.render_affine_meta.load() &&
            forwardInputAllocation(self->srcpad, query, currentDelay(self) + kExtraInputBuffers))
            return true;
        return proposeInputAllocation(query, currentDelay(self) + kExtraInputBuffers);
    case GST_QUERY_DRAIN:
        // Everything held goes out before the answer.
        if (!finalizeHeldFrames(s) || !s.output.waitUntilDrained())
            return false;
        gst_pad_peer_query(self->srcpad, query);
        return true;
    default:
        return gst_pad_query_default(pad, GST_OBJECT(self), query);
    }
}

GstClockTime frameDuration(GstUavStabilize *self, const UavStabilizeState &s)
{
    const GstClockTime duration = s.timing.frameDuration();
    if (GST_CLOCK_TIME_IS_VALID(duration))
        return duration;
    GST_WARNING_OBJECT(self, "no framerate and no buffer duration known; assuming 30 fps for the latency");
    return kFallbackFrameDuration;
}

bool handleLatency(GstUavStabilize *self, UavStabilizeState &s, GstQuery *query)
{
    if (!gst_pad_peer_query(self->sinkpad, query))
        return false;
    gboolean live = FALSE;
    GstClockTime min = 0, max = GST_CLOCK_TIME_NONE;
    gst_query_parse_latency(query, &live, &min, &max);
    const GstClockTime added = currentDelay(self) * frameDuration(self, s);
    GST_DEBUG_OBJECT(self, "upstream latency %" GST_TIME_FORMAT " - %" GST_TIME_FORMAT ", adding %" GST_TIME_FORMAT,
                     GST_TIME_ARGS(min), GST_TIME_ARGS(max), GST_TIME_ARGS(added));
    min += added;
    if (GST_CLOCK_TIME_IS_VALID(max))
        max += added;
    gst_query_set_latency(query, live, min, max);
    return true;
}

} // namespace

gboolean sinkQuery(GstPad *pad, GstObject *parent, GstQuery *query)
{
    auto *self = GST_UAV_STABILIZE(parent);
    try {
        return handleSinkQuery(self, stateOf(self), pad, query);
    } catch (const std::exception &e) {
        failStream(self, stateOf(self), "Handling a query failed", e);
        return FALSE;
    }
}

gboolean srcQuery(GstPad *pad, GstObject *parent, GstQuery *query)
{
    auto *self = GST_UAV_STABILIZE(parent);
    try {
        switch (GST_QUERY_TYPE(query)) {
        case GST_QUERY_LATENCY:
            return handleLatency(self, stateOf(self), query);
        case GST_QUERY_CAPS:
            return gst_pad_proxy_query_caps(pad, query);
        default:
            return gst_pad_query_default(pad, parent, query);
        }
    } catch (const std::exception &e) {
        GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Handling a query failed"), ("%s", e.what()));
        return FALSE;
    }
}

} // namespace gstuavstab
