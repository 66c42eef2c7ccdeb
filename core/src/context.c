#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "atomic_file.h"
#include "context.h"
#include "desc.h"

static void embree_error_cb(void *user, enum RTCError code, const char *str)
{
    vbnl_context *ctx = user;
    snprintf(ctx->embree_error, sizeof(ctx->embree_error), "Embree error %d: %s", (int)code,
             str ? str : "(no message)");
}

void vbnl_context_desc_init(vbnl_context_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
}

vbnl_result vbnl_context_create(const vbnl_context_desc *desc, vbnl_context **out, vbnl_error *err)
{
    if (!out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_context_create: out is NULL");
    *out = NULL;
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    if (desc) {
        vbnl_result r = VBI_DESC_CHECK(desc, vbnl_context_desc, err);
        if (r != VBNL_OK)
            return r;
        d = *desc;
    }
    unsigned threads = d.threads;
    if (threads > 1024)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbnl_context_create: %u threads is more than the 1024 supported",
                              threads);
    vbnl_context *ctx = calloc(1, sizeof(*ctx));
    if (!ctx)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    ctx->pool = vbi_pool_create(threads);
    if (!ctx->pool) {
        free(ctx);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot start worker threads");
    }
    ctx->threads = vbi_pool_thread_count(ctx->pool);
    /* Embree's own task system builds BVHs; give it the same thread count. */
    char config[64];
    snprintf(config, sizeof(config), "threads=%u", ctx->threads);
    ctx->device = rtcNewDevice(config);
    if (!ctx->device) {
        vbi_pool_destroy(ctx->pool);
        free(ctx);
        return vbnl_error_set(err, VBNL_ERR_BACKEND, "cannot create the Embree device (error %d)",
                              (int)rtcGetDeviceError(NULL));
    }
    rtcSetDeviceErrorFunction(ctx->device, embree_error_cb, ctx);
    if (d.test_hooks & VBNL_TEST_HOOK_PAUSE_WRITES)
        vbi_atomic_file_set_test_pause(1);
    *out = ctx;
    return VBNL_OK;
}

void vbnl_context_destroy(vbnl_context *ctx)
{
    if (!ctx)
        return;
    vbi_pool_destroy(ctx->pool);
    if (ctx->device)
        rtcReleaseDevice(ctx->device);
    free(ctx);
}

unsigned vbnl_context_thread_count(const vbnl_context *ctx) { return ctx ? ctx->threads : 0; }
