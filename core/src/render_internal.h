/* What integrators see of the renderer (private header). */
#ifndef VBNL_RENDER_INTERNAL_H
#define VBNL_RENDER_INTERNAL_H

#include <stdint.h>

#include "film.h"
#include "pool.h"
#include "rng.h"
#include "sampler.h"
#include "scene_internal.h"
#include "vbnl/integrator.h"

/* Per-thread counters, padded so that threads never share a cache line. */
typedef struct vbnl_thread_stats {
    uint64_t rays;
    uint64_t samples;
    uint64_t camera_rays, shadow_rays; /* among rays (vbnl_render_stats) */
    char pad[32];
} vbnl_thread_stats;

struct vbnl_tile_job {
    const vbnl_scene *scene;
    vbnl_film *film;
    uint32_t x0, y0, x1, y1;           /* pixel rectangle (exclusive ends), inside the crop */
    uint32_t sample_begin, sample_end; /* sample indices of this pass for every pixel */
    uint32_t width, height;            /* full image size */
    uint64_t seed;
    vbnl_sampler_kind sampler;
    unsigned thread;
    vbnl_thread_stats *stats;          /* this thread's counters */
};

static inline unsigned vbnl_tile_job_thread(const vbnl_tile_job *job) { return job->thread; }

/* The sampler of sample `s` of pixel (x, y): independent of tiles and threads. */
static inline vbnl_sampler vbnl_pixel_sampler(const vbnl_tile_job *job, uint32_t x, uint32_t y, uint32_t s)
{
    return vbnl_sampler_make(job->sampler, job->seed, (uint64_t)y * job->width + x, s);
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

/* Starts a named stage (its time is recorded in the render statistics). */
void vbnl_stage_begin(vbnl_stage_ctx *st, const char *name, double total, const char *unit);
/* Runs `count` work items on the context's workers, reporting progress as items finish.
 * Returns 0, or -1 when cancelled (items in flight finish; later ones do not run). */
int vbnl_stage_run(vbnl_stage_ctx *st, uint64_t count, vbnl_pool_fn fn, void *user);
void vbnl_stage_end(vbnl_stage_ctx *st);
/* What the current stage counted (`work` in `unit`, a string literal; vbnl_stage_time.work: the
 * photon stage's rays, so that outputs can report a rate beside the time); call before
 * vbnl_stage_end. A no-op without a stage. */
void vbnl_stage_set_work(vbnl_stage_ctx *st, double work, const char *unit);
/* Records the bytes the integrator's prepared data hold (vbnl_render_stats.storage_bytes). */
void vbnl_stage_set_storage(vbnl_stage_ctx *st, uint64_t bytes);
unsigned vbnl_stage_thread_count(const vbnl_stage_ctx *st);

/* Runs work items for a stage of an integrator that may also be driven without a renderer (unit
 * tests, benchmarks): through the stage when `st` is given, else on `pool` when given, else
 * serially on the calling thread (thread index 0). Returns 0, or -1 when cancelled. */
int vbnl_run_items(vbnl_stage_ctx *st, vbnl_pool *pool, uint64_t count, vbnl_pool_fn fn, void *user);
unsigned vbnl_run_thread_count(const vbnl_stage_ctx *st, const vbnl_pool *pool);
uint64_t vbnl_stage_seed(const vbnl_stage_ctx *st);

#endif
