// Plugin registration: one element, uavstabilize, and its meta, GstUavStabMeta.
#include <gst/gst.h>

#include "gstuavstabilize.hpp"
#include "uavstab_meta.hpp"

namespace {

gboolean pluginInit(GstPlugin *plugin)
{
    // The meta first: applications find it by name once the plugin is loaded.
    if (!gstuavstab::registerStabMeta())
        return FALSE;
    return GST_ELEMENT_REGISTER(uavstabilize, plugin);
}

} // namespace

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, uavstabilize,
                  "Real-time optical-flow video stabilization for UAV footage", pluginInit, VERSION, "LGPL",
                  GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
