// The src pad task (like `queue`'s): pushes each frame as soon as its warp is done, and
// each serialized event once the frames queued before it are out.
#include <optional>
#include <set>
#include <string>

#include "frame_statistics.hpp"
#include "uavstab_meta.hpp"
#include "uavstabilize_element.hpp"
#include "uavstabilize_render.hpp"

#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace gstuavstab {

namespace {

// Distinct warp/estimation errors reported as warnings; later ones only go to the log.
constexpr std::size_t kMaxReportedErrors = 32;

void postStatistics(GstUavStabilize *self, const UavStabilizeState &s, const uavstab::StabilizedFrame &frame,
                    GstUavStabOutcome outcome, GstClockTime pts)
{
    GstStructure *structure = frameStatistics(frame, outcome, pts, s.output_segment);
    gst_element_post_message(GST_ELEMENT(self), gst_message_new_element(GST_OBJECT(self), structure));
}

// A frame the library could not stabilize goes out uncorrected; say so once per error.
void reportFailedFrame(GstUavStabilize *self, UavStabilizeState &s, const std::string &error)
{
    if (s.reported_errors.count(error) || s.reported_errors.size() >= kMaxReportedErrors) {
        GST_DEBUG_OBJECT(self, "frame passed through uncorrected: %s", error.c_str());
        return;
    }
    s.reported_errors.insert(error);
    GST_ELEMENT_WARNING(self, STREAM, FAILED, ("A frame could not be stabilized and was passed through uncorrected"),
                        ("%s", error.c_str()));
}

GstFlowReturn pushFrame(GstUavStabilize *self, UavStabilizeState &s, uavstab::StabilizedFrame &frame)
{
    auto &slot = static_cast<GstFrameSlot &>(*frame.slot);
    const int width = slot.input().width, height = slot.input().height;
    GstBuffer *buffer = nullptr;
    bool affine_meta = false;
    switch (frame.outcome) {
    case uavstab::Outcome::Warped:
        buffer = slot.releaseOutput();
        // Regions of interest (detections upstream) follow the warp.
        if (buffer)
            mapRegionsOfInterest(slot.inputBuffer(), buffer, frame.stats.output_to_input, width, height);
        break;
    case uavstab::Outcome::Bypassed:
        break;
    case uavstab::Outcome::NoOutput:
        if (s.output.flushing())
            return GST_FLOW_OK;  // dropped with the slot: nobody wants it any more
        if (slot.leftUnwarped()) {
            if (warpsLeftUnwarpedFrame(s, frame))
                buffer = warpLeftUnwarpedFrame(self, s, frame);
            // Without an output buffer (flushing meanwhile) the meta still draws it right.
            affine_meta = buffer == nullptr;
        }
        break;
    case uavstab::Outcome::Failed:
        reportFailedFrame(self, s, frame.error);
        break;
    }
    const GstUavStabOutcome outcome = outcomeOf(frame, buffer != nullptr, affine_meta);
    if (!buffer)
        buffer = slot.releaseInput();  // bypass, pass-through, affine meta: the input, untouched
    buffer = attachStabMeta(buffer, frame, width, height, outcome);  // writable from here on
    if (affine_meta)
        addAffineTransformationMeta(buffer, frame.stats.output_to_input, width, height);
    if (postMessagesEnabled(self))
        postStatistics(self, s, frame, outcome, GST_BUFFER_PTS(buffer));
    frame.slot.reset();  // unmaps and lets go of the input before it goes downstream
    return gst_pad_push(self->srcpad, buffer);
}

void runOutputStep(GstUavStabilize *self, UavStabilizeState &s)
{
    std::optional<uavstab::StabilizedFrame> frame;
    EventPtr event;
    const auto try_pop = [&s]() -> std::optional<uavstab::StabilizedFrame> {
        if (!s.stabilizer)
            return std::nullopt;
        return s.stabilizer->tryPop();
    };
    if (!s.output.takeNext(try_pop, frame, event)) {
        GST_DEBUG_OBJECT(self, "flushing: pausing the output task");
        gst_pad_pause_task(self->srcpad);
        return;
    }

    // The task stops itself (until FLUSH_STOP or a new stream restarts it) under the
    // output's mutex: see OutputChannel::finishPush.
    const auto pause_task = [self] { gst_pad_pause_task(self->srcpad); };
    GstFlowReturn ret = GST_FLOW_OK;
    if (frame) {
        // Downstream changed (a sink swapped, a GL element linked): the task is the one
        // pushing, so its ALLOCATION query keeps its place among the buffers.
        if (gst_pad_check_reconfigure(self->srcpad))
            renegotiateOutput(self, s);
        ret = pushFrame(self, s, *frame);
    } else {
        const GstEventType type = GST_EVENT_TYPE(event.get());
        if (type == GST_EVENT_SEGMENT)
            gst_event_copy_segment(event.get(), &s.output_segment);
        GST_LOG_OBJECT(self, "pushing %" GST_PTR_FORMAT, event.get());
        gst_pad_push_event(self->srcpad, event.release());
        if (type == GST_EVENT_EOS) {
            // Nothing follows EOS until FLUSH_STOP or STREAM_START, unless a new stream
            // was queued behind it before it went out.
            if (!s.output.finishEos(pause_task))
                GST_DEBUG_OBJECT(self, "paused the output task: EOS");
            return;
        }
    }

    const bool eos_queued = s.output.finishPush(ret, pause_task);
    if (ret == GST_FLOW_OK)
        return;

    GST_DEBUG_OBJECT(self, "paused the output task: %s", gst_flow_get_name(ret));
    // Like queue: once upstream has sent EOS no chain call can report the error, so
    // tell the application and end the stream here.
    if (eos_queued && ret != GST_FLOW_EOS && (ret == GST_FLOW_NOT_LINKED || ret < GST_FLOW_EOS)) {
        GST_ELEMENT_FLOW_ERROR(self, ret);
        gst_pad_push_event(self->srcpad, gst_event_new_eos());
    }
}

} // namespace

void srcLoop(gpointer user_data)
{
    auto *self = GST_UAV_STABILIZE(user_data);
    UavStabilizeState &s = stateOf(self);
    try {
        runOutputStep(self, s);
    } catch (const std::exception &e) {
        GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Internal error while pushing stabilized frames"), ("%s", e.what()));
        s.output.abortPush();
        gst_pad_pause_task(self->srcpad);
    }
}

void startTask(GstUavStabilize *self)
{
    if (GST_PAD_MODE(self->srcpad) != GST_PAD_MODE_PUSH)
        return;  // not active (shutting down): the next activation starts it
    gst_pad_start_task(self->srcpad, srcLoop, self, nullptr);
}

} // namespace gstuavstab
