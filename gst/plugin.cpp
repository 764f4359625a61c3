// Plugin registration: one element, uavstabilize.
#include <gst/gst.h>

#include "gstuavstabilize.hpp"

namespace {

gboolean pluginInit(GstPlugin *plugin)
{
    return GST_ELEMENT_REGISTER(uavstabilize, plugin);
}

} // namespace

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, uavstabilize,
                  "Real-time optical-flow video stabilization for UAV footage", pluginInit, VERSION, "LGPL",
                  GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
