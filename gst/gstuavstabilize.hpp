// The uavstabilize element: real-time video stabilization for UAV footage (see
// gstuavstabilize.cpp for the design and the documentation block).
#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

#define GST_TYPE_UAV_STABILIZE (gst_uav_stabilize_get_type())
G_DECLARE_FINAL_TYPE(GstUavStabilize, gst_uav_stabilize, GST, UAV_STABILIZE, GstElement)

GST_ELEMENT_REGISTER_DECLARE(uavstabilize);

G_END_DECLS
