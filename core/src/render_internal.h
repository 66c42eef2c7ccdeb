/* What the core's own integrators see of the renderer beyond the public integrator ABI
 * (vbnl/integrator.h): the tile job's fields, the per-thread statistics, the samplers (private
 * header). */
#ifndef VBI_RENDER_INTERNAL_H
#define VBI_RENDER_INTERNAL_H

#include <stdint.h>

#include "film.h"
#include "pool.h"
#include "rng.h"
#include "sampler.h"
#include "scene_internal.h"
#include "vbnl/integrator.h"

/* Per-thread counters, padded so that threads never share a cache line. */
typedef struct vbi_thread_stats {
    uint64_t rays;
    uint64_t samples;
    uint64_t camera_rays, shadow_rays; /* among rays (vbnl_render_stats) */
    char pad[32];
} vbi_thread_stats;

struct vbnl_tile_job {
    const vbnl_scene *scene;
    vbnl_film *film;
    uint32_t x0, y0, x1, y1;           /* pixel rectangle (exclusive ends), inside the crop */
    uint32_t sample_begin, sample_end; /* sample indices of this pass for every pixel */
    uint32_t width, height;            /* full image size */
    uint64_t seed;
    vbnl_sampler_kind sampler;
    unsigned thread;
    vbi_thread_stats *stats;          /* this thread's counters */
};

/* The sampler of sample `s` of pixel (x, y): independent of tiles and threads. */
static inline vbi_sampler vbi_pixel_sampler(const vbnl_tile_job *job, uint32_t x, uint32_t y, uint32_t s)
{
    return vbi_sampler_make(job->sampler, job->seed, (uint64_t)y * job->width + x, s);
}

/* ---- stages of prepare -------------------------------------------------------------------- */

struct vbnl_stage_ctx {
    vbnl_renderer *renderer;
    vbnl_progress_fn progress;
    void *user;
    double interval;
    /* current stage */
    const char *name;
    const char *unit;
    double total;
    double start;
    double work;           /* vbnl_stage_set_work, recorded by vbnl_stage_end */
    const char *work_unit;
    const char *record_as; /* non-NULL: vbnl_stage_end records every stage under this name */
    int cancelled;
};

/* The stage functions (vbnl_stage_begin ... vbnl_stage_thread_count) are public: integrator.h.
 * vbnl_work_fn and vbi_pool_fn are the same function type. */

/* Runs work items for a stage of an integrator that may also be driven without a renderer (unit
 * tests, benchmarks): through the stage when `st` is given, else on `pool` when given, else
 * serially on the calling thread (thread index 0). Returns 0, or -1 when cancelled. */
int vbi_run_items(vbnl_stage_ctx *st, vbi_pool *pool, uint64_t count, vbi_pool_fn fn, void *user);
unsigned vbi_run_thread_count(const vbnl_stage_ctx *st, const vbi_pool *pool);
uint64_t vbi_stage_seed(const vbnl_stage_ctx *st);

#endif
