/* The render context (private header): worker threads and the Embree device. */
#ifndef VBI_CONTEXT_H
#define VBI_CONTEXT_H

#include <embree3/rtcore.h>

#include "pool.h"
#include "vbnl/render.h"

struct vbnl_context {
    vbi_pool *pool;
    RTCDevice device;
    unsigned threads;
    /* Embree reports errors through a callback: it writes the latest one here so that the call
     * that failed can quote it. Guarded by being per-context and set only on failure paths. */
    char embree_error[256];
};

#endif
