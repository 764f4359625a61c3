#include "output_pool.hpp"

#include <algorithm>
#include <stdexcept>

GST_DEBUG_CATEGORY_EXTERN(gst_uav_stabilize_debug);
#define GST_CAT_DEFAULT gst_uav_stabilize_debug

namespace gstuavstab {

namespace {

bool configurePool(GstBufferPool *pool, GstCaps *caps, guint size, guint min, guint max, GstAllocator *allocator,
                   const GstAllocationParams &params, bool video_meta)
{
    GstStructure *config = gst_buffer_pool_get_config(pool);
    gst_buffer_pool_config_set_params(config, caps, size, min, max);
    gst_buffer_pool_config_set_allocator(config, allocator, &params);
    if (video_meta && gst_buffer_pool_has_option(pool, GST_BUFFER_POOL_OPTION_VIDEO_META))
        gst_buffer_pool_config_add_option(config, GST_BUFFER_POOL_OPTION_VIDEO_META);
    if (gst_buffer_pool_set_config(pool, config))
        return true;
    // The pool may have adjusted the config; take it if it still fits.
    config = gst_buffer_pool_get_config(pool);
    if (!gst_buffer_pool_config_validate_params(config, caps, size, min, max)) {
        gst_structure_free(config);
        return false;
    }
    return gst_buffer_pool_set_config(pool, config);
}

} // namespace

OutputAllocation negotiateOutputAllocation(GstPad *srcpad, GstCaps *caps, const GstVideoInfo &info, bool want_pool)
{
    GstQuery *query = gst_query_new_allocation(caps, TRUE);
    if (!gst_pad_peer_query(srcpad, query))
        GST_DEBUG_OBJECT(srcpad, "downstream did not answer the ALLOCATION query");

    GstBufferPool *pool = nullptr;
    guint size = 0, min = 0, max = 0;
    if (gst_query_get_n_allocation_pools(query) > 0)
        gst_query_parse_nth_allocation_pool(query, 0, &pool, &size, &min, &max);
    GstAllocator *allocator = nullptr;
    GstAllocationParams params;
    gst_allocation_params_init(&params);
    if (gst_query_get_n_allocation_params(query) > 0)
        gst_query_parse_nth_allocation_param(query, 0, &allocator, &params);
    const bool video_meta = gst_query_find_allocation_meta(query, GST_VIDEO_META_API_TYPE, nullptr);
    OutputAllocation result;
    result.applies_affine_meta =
        gst_query_find_allocation_meta(query, GST_VIDEO_AFFINE_TRANSFORMATION_META_API_TYPE, nullptr);
    gst_query_unref(query);
    if (!want_pool) {
        if (pool)
            gst_object_unref(pool);
        if (allocator)
            gst_object_unref(allocator);
        return result;
    }

    const guint frame_size = guint(GST_VIDEO_INFO_SIZE(&info));
    if (pool && !configurePool(pool, caps, std::max(size, frame_size), min, max, allocator, params, video_meta)) {
        GST_DEBUG_OBJECT(srcpad, "downstream's pool refused our config; using our own");
        gst_object_unref(pool);
        pool = nullptr;
    }
    if (!pool) {
        // Default layout (no video meta needed downstream).
        pool = gst_video_buffer_pool_new();
        if (!configurePool(pool, caps, frame_size, 0, 0, allocator, params, false)) {
            gst_object_unref(pool);
            pool = nullptr;
        }
    }
    if (allocator)
        gst_object_unref(allocator);
    if (!pool || !gst_buffer_pool_set_active(pool, TRUE)) {
        if (pool)
            gst_object_unref(pool);
        throw std::runtime_error("no usable output buffer pool");
    }
    GST_DEBUG_OBJECT(srcpad, "output buffers from %" GST_PTR_FORMAT, pool);
    result.pool = pool;
    return result;
}

bool proposeInputAllocation(GstQuery *query, guint min_buffers)
{
    GstCaps *caps = nullptr;
    gboolean need_pool = FALSE;
    gst_query_parse_allocation(query, &caps, &need_pool);
    GstVideoInfo info;
    if (!caps || !gst_video_info_from_caps(&info, caps))
        return false;
    const guint size = guint(GST_VIDEO_INFO_SIZE(&info));
    GstBufferPool *pool = nullptr;
    if (need_pool) {
        pool = gst_video_buffer_pool_new();
        GstStructure *config = gst_buffer_pool_get_config(pool);
        gst_buffer_pool_config_set_params(config, caps, size, min_buffers, 0);
        gst_buffer_pool_config_add_option(config, GST_BUFFER_POOL_OPTION_VIDEO_META);
        if (!gst_buffer_pool_set_config(pool, config)) {
            gst_object_unref(pool);
            return false;
        }
    }
    gst_query_add_allocation_pool(query, pool, size, min_buffers, 0);
    if (pool)
        gst_object_unref(pool);
    gst_query_add_allocation_meta(query, GST_VIDEO_META_API_TYPE, nullptr);
    return true;
}

bool forwardInputAllocation(GstPad *srcpad, GstQuery *query, guint min_buffers)
{
    GstCaps *caps = nullptr;
    gboolean need_pool = FALSE;
    gst_query_parse_allocation(query, &caps, &need_pool);
    if (!caps)
        return false;
    // A query of our own: a refusal leaves upstream's untouched for the default answer.
    GstQuery *downstream = gst_query_new_allocation(caps, need_pool);
    bool usable = gst_pad_peer_query(srcpad, downstream) && gst_query_get_n_allocation_pools(downstream) > 0;
    GstBufferPool *pool = nullptr;
    guint size = 0, min = 0, max = 0;
    if (usable) {
        gst_query_parse_nth_allocation_pool(downstream, 0, &pool, &size, &min, &max);
        // A pool that cannot hold the frames we keep would starve upstream.
        usable = max == 0 || max >= min_buffers;
    }
    if (usable) {
        gst_query_add_allocation_pool(query, pool, size, std::max(min, min_buffers), max);
        for (guint i = 0; i < gst_query_get_n_allocation_params(downstream); ++i) {
            GstAllocator *allocator = nullptr;
            GstAllocationParams params;
            gst_query_parse_nth_allocation_param(downstream, i, &allocator, &params);
            gst_query_add_allocation_param(query, allocator, &params);
            if (allocator)
                gst_object_unref(allocator);
        }
        // Only the video meta: any other meta upstream would add (a crop, an affine
        // transform) is one we do not apply before estimating.
        gst_query_add_allocation_meta(query, GST_VIDEO_META_API_TYPE, nullptr);
        GST_DEBUG_OBJECT(srcpad, "proposing downstream's pool %" GST_PTR_FORMAT " upstream", pool);
    }
    if (pool)
        gst_object_unref(pool);
    gst_query_unref(downstream);
    return usable;
}

} // namespace gstuavstab
