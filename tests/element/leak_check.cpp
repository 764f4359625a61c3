#include "leak_check.hpp"

#include <cstdio>
#include <map>
#include <string>

#include <gst/gst.h>

namespace element_test {

namespace {

GstTracer *leaksTracer()
{
    static GstTracer *tracer = [] {
        GstTracer *found = nullptr;
        GList *tracers = gst_tracing_get_active_tracers();
        for (GList *l = tracers; l; l = l->next) {
            if (!found && g_strcmp0(G_OBJECT_TYPE_NAME(l->data), "GstLeaksTracer") == 0)
                found = GST_TRACER(gst_object_ref(l->data));
        }
        g_list_free_full(tracers, gst_object_unref);
        return found;
    }();
    return tracer;
}

// Counts "type@address" entries of one checkpoint list.
void countEntries(const GstStructure *checkpoint, const char *field, int sign, std::map<std::string, int> &counts)
{
    const GValue *list = gst_structure_get_value(checkpoint, field);
    if (!list)
        return;
    for (guint i = 0; i < gst_value_list_get_size(list); ++i) {
        const GstStructure *entry = gst_value_get_structure(gst_value_list_get_value(list, i));
        const std::string key = std::string(gst_structure_get_string(entry, "type-name")) + " " +
                                gst_structure_get_string(entry, "address");
        counts[key] += sign;
    }
}

// Objects that are meant to live on (class data, caches) say so with a flag.
bool mayBeLeaked(const std::string &type_name, const std::string &address)
{
    void *pointer = nullptr;
    if (std::sscanf(address.c_str(), "%p", &pointer) != 1 || !pointer)
        return false;
    const GType type = g_type_from_name(type_name.c_str());
    if (type == 0)
        return false;
    // The object is still alive: the tracer's weak reference has not fired.
    if (g_type_is_a(type, GST_TYPE_OBJECT))
        return GST_OBJECT_FLAG_IS_SET(pointer, GST_OBJECT_FLAG_MAY_BE_LEAKED);
    if (g_type_is_a(type, G_TYPE_OBJECT))
        return false;
    return GST_MINI_OBJECT_FLAG_IS_SET(pointer, GST_MINI_OBJECT_FLAG_MAY_BE_LEAKED);
}

} // namespace

bool leakTracerActive()
{
    return leaksTracer() != nullptr;
}

void startLeakTracking()
{
    GstTracer *tracer = leaksTracer();
    if (!tracer)
        return;
    g_signal_emit_by_name(tracer, "activity-stop-tracking");
    g_signal_emit_by_name(tracer, "activity-start-tracking");
}

std::string stopLeakTracking()
{
    GstTracer *tracer = leaksTracer();
    if (!tracer)
        return {};
    // A thread that has just finished (a joined task's thread, a pool worker) may drop
    // its last reference a moment later, so leftovers get a little time to go.
    std::map<std::string, int> alive;
    std::string leaks;
    for (int attempt = 0; attempt < 100; ++attempt) {
        // Let the object population settle first: mayBeLeaked() reads each survivor's
        // flags, and a survivor that another thread is still finalizing must not be
        // touched (ASan saw exactly that). Settled = a whole poll without removals.
        for (int settle = 0; settle < 50; ++settle) {
            GstStructure *checkpoint = nullptr;
            g_signal_emit_by_name(tracer, "activity-get-checkpoint", &checkpoint);
            bool removed = false;
            if (checkpoint) {
                const GValue *list = gst_structure_get_value(checkpoint, "objects-removed-list");
                removed = list && gst_value_list_get_size(list) > 0;
                countEntries(checkpoint, "objects-created-list", +1, alive);
                countEntries(checkpoint, "objects-removed-list", -1, alive);
                gst_structure_free(checkpoint);
            }
            if (!removed && settle > 0)
                break;
            g_usleep(20 * 1000);
        }
        leaks.clear();
        for (const auto &[key, count] : alive) {
            if (count <= 0)
                continue;
            const auto space = key.find(' ');
            if (mayBeLeaked(key.substr(0, space), key.substr(space + 1)))
                continue;
            leaks += (leaks.empty() ? "" : ", ") + key + (count > 1 ? " x" + std::to_string(count) : "");
        }
        if (leaks.empty())
            break;
        g_usleep(20 * 1000);
    }
    g_signal_emit_by_name(tracer, "activity-stop-tracking");
    return leaks;
}

} // namespace element_test
