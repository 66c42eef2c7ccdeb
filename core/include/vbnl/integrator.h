/* vbnl: the integrator ABI and registry.
 *
 * An integrator (the `path` reference, `vbnl`, the comparison methods, or one of your own) is a
 * const vbnl_integrator_class. The core's own are found by name in an immutable registry
 * (vbnl_integrator_find); any other renders through vbnl_renderer_create_with_class. Everything
 * an integrator calls is declared in the public headers (this one, render.h, scene.h, params.h,
 * result.h): tests/core/test_integrator_abi.c is an integrator compiled against them alone.
 *
 * The class table starts with its ABI version and its own size and only ever grows at the end: a
 * core built for minor version m reads the fields that existed in m, and checks `size` before
 * reading anything newer. A function's signature never changes; a changed one gets a new name.
 *
 * Life cycle, driven by vbnl_renderer (render.h), on the thread that drives the renderer unless
 * said otherwise:
 *   create(env)   reads the validated parameters (vbnl_params_number / _string with the class's
 *                 spec table), adds film layers for its AOVs (vbnl_film_add_layer), allocates its
 *                 state. Errors: a vbnl_result and a message in err; the renderer is not made.
 *   prepare()     scene-dependent work before the first pass (may be NULL), split into named
 *                 stages (vbnl_stage_begin ... vbnl_stage_end) whose work items run on the
 *                 context's workers (vbnl_stage_run); VBNL_ERR_CANCELLED when a stage was
 *                 cancelled.
 *   render_tile() called for every tile of every pass, concurrently on worker threads for
 *                 different tiles: it renders samples [begin, end) of every pixel of the tile
 *                 (vbnl_tile_job_*) and adds each one to the film (vbnl_tile_job_add_sample). It
 *                 must keep per-tile state on its stack or in per-thread scratch indexed by
 *                 vbnl_tile_job_thread, and its results must not depend on which thread rendered
 *                 which tile (use the job's sample streams for random numbers).
 *   destroy()     frees the state (accepts NULL).
 *
 * The registry is immutable: its functions may be called from any thread. */
#ifndef VBNL_INTEGRATOR_H
#define VBNL_INTEGRATOR_H

#include <stdint.h>

#include "vbnl/params.h"
#include "vbnl/render.h"
#include "vbnl/result.h"
#include "vbnl/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Minor 3: vbnl_material_desc (which vbnl_scene_get_material fills) ends with the coat fields. */
#define VBNL_INTEGRATOR_ABI_MAJOR 1u
#define VBNL_INTEGRATOR_ABI_MINOR 3u

typedef struct vbnl_tile_job vbnl_tile_job;     /* one tile of one pass (below) */
typedef struct vbnl_stage_ctx vbnl_stage_ctx;   /* progress, timing and workers for prepare */

typedef struct vbnl_budget vbnl_budget;         /* the render's time budget (below) */

/* What create() receives. Every pointer stays valid until destroy() returns. */
typedef struct vbnl_integrator_env {
    vbnl_context *ctx;
    const vbnl_scene *scene;           /* committed */
    const vbnl_params *params;         /* already validated against the class's spec table */
    const vbnl_render_settings *settings;
    vbnl_film *film;                   /* add AOV layers here with vbnl_film_add_layer */
    /* ABI minor 1 */
    vbnl_budget *budget;               /* never NULL; vbnl_budget_seconds is 0 without a budget */
} vbnl_integrator_env;

/* ---- time budget (ABI minor 1) -------------------------------------------------------------
 *
 * A render with settings.time_budget > 0 belongs to its integrators: each sizes its own work to
 * the budget (docs/time-budget.md). The renderer ends rendering at the budget (the tiles in
 * flight finish, and the first pass is always whole); preparation must keep itself within
 * vbnl_budget_prepare_limit. A parameter the user set (vbnl_params_has) is kept; when it cannot
 * fit, the integrator refuses (VBNL_ERR_INVALID_ARGUMENT) before the work it sizes starts, naming
 * the estimate and the limit. What an integrator chose is recorded with vbnl_budget_choose and
 * reported by vbnl_renderer_get_stats (and in the EXR header).
 *
 * Threads: the budget belongs to one renderer; call these from create() or prepare(), on the
 * thread that drives the renderer. They never fail (a NULL budget reads as no budget). */

/* The preparation's bound: at most this share of the budget (calibration included). */
#define VBNL_BUDGET_PREPARE_SHARE 0.25

/* Seconds of the budget; 0 = no budget. */
double vbnl_budget_seconds(const vbnl_budget *b);
/* Seconds preparation may take: VBNL_BUDGET_PREPARE_SHARE x the budget (0 without a budget). */
double vbnl_budget_prepare_limit(const vbnl_budget *b);
/* Seconds since the budget started (the first prepare or render call; 0 before). */
double vbnl_budget_elapsed(const vbnl_budget *b);
/* Pixels each pass renders (the crop, or the whole image). */
double vbnl_budget_pixels(const vbnl_budget *b);
/* Records a value the integrator chose (or kept) and why, e.g. ("virtual_lights", 20000,
 * "sized: ..."); a later call for the same name replaces the record. `name` is copied (47 bytes
 * at most), the formatted reason too (319 bytes at most, cut beyond); at most 8 names are kept,
 * later ones are dropped. */
void vbnl_budget_choose(vbnl_budget *b, const char *name, double value, const char *why_fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

/* Light count of a many-light baseline (`vpl`, `vsl`, `richvsl`), whose shading costs about one
 * shadow ray per light per camera vertex: the count with which `spp_target` samples per pixel
 * fit the budget's rendering share (1 - VBNL_BUDGET_PREPARE_SHARE) at the scene's shadow-ray
 * rate measured here (a short calibration, vbnl_scene_measure_ray_rates, recorded as the stage
 * "calibrate"), a light evaluation costing `cost` shadow rays, clamped to [lo, hi]. A count the
 * user set (the parameter `name`) is kept, and refused (VBNL_ERR_INVALID_ARGUMENT) when one pass
 * alone would not fit the time left. Without a budget, *out = `fallback` (the parameter's
 * value) and nothing is measured. Records the choice. Errors: VBNL_ERR_INVALID_ARGUMENT as
 * above, those of vbnl_scene_measure_ray_rates. Runs the calibration on the context's workers. */
vbnl_result vbnl_budget_size_lights(vbnl_budget *b, const char *name, double fallback, double spp_target,
                                    double cost, double lo, double hi, uint32_t *out, vbnl_error *err);

/* ---- stages of prepare (ABI minor 2) -------------------------------------------------------
 *
 * prepare() splits its work into named stages; each stage's time is recorded in the render
 * statistics (vbnl_render_stats.stages) and its progress reported to the caller's callback.
 * Call these from prepare(), on the thread that runs it; only the work items of
 * vbnl_stage_run run on the workers. */

/* A work item of vbnl_stage_run: item in [0, count), on worker `thread` in
 * [0, vbnl_stage_thread_count). Items run concurrently and in any order. */
typedef void (*vbnl_work_fn)(void *user, uint64_t item, unsigned thread);

/* Starts a stage named `name` (a string that outlives the renderer, e.g. a literal) whose
 * progress counts `total` units of `unit` (total 0: unknown). */
void vbnl_stage_begin(vbnl_stage_ctx *st, const char *name, double total, const char *unit);
/* Runs items 0 .. count - 1 on the context's workers and waits for them, reporting progress as
 * they finish. Returns 0, or -1 when the caller's progress callback cancelled: the items in
 * flight finish, later ones do not run (the integrator then returns VBNL_ERR_CANCELLED). */
int vbnl_stage_run(vbnl_stage_ctx *st, uint64_t count, vbnl_work_fn fn, void *user);
/* Ends the current stage and records its time. */
void vbnl_stage_end(vbnl_stage_ctx *st);
/* What the current stage counted (`work` in `unit`, a string literal; vbnl_stage_time.work: the
 * photon stage's rays, so that outputs can report a rate beside the time); call before
 * vbnl_stage_end. A no-op without a stage. */
void vbnl_stage_set_work(vbnl_stage_ctx *st, double work, const char *unit);
/* Records the bytes the integrator's prepared data hold (vbnl_render_stats.storage_bytes). */
void vbnl_stage_set_storage(vbnl_stage_ctx *st, uint64_t bytes);
/* Workers that run a stage's items (at least 1). */
unsigned vbnl_stage_thread_count(const vbnl_stage_ctx *st);

/* ---- tiles (ABI minor 2) --------------------------------------------------------------------
 *
 * A tile job is one tile of one pass, handed to render_tile() on a worker thread. The job and
 * what these functions return are valid during that call only. They may be called concurrently
 * for different jobs; a job belongs to the thread its render_tile() runs on. */

/* The tile's pixels [x0, x1) x [y0, y1) (inside the crop window; row 0 at the top). */
void vbnl_tile_job_rect(const vbnl_tile_job *job, uint32_t *x0, uint32_t *y0, uint32_t *x1, uint32_t *y1);
/* The sample indices [begin, end) every pixel of the tile takes in this pass. */
void vbnl_tile_job_samples(const vbnl_tile_job *job, uint32_t *begin, uint32_t *end);
/* The worker running the job, in [0, vbnl_context_thread_count): an index for per-thread
 * scratch. */
unsigned vbnl_tile_job_thread(const vbnl_tile_job *job);

/* The random numbers of one sample: a stream that depends only on (seed, pixel, sample index)
 * and the settings' sampler (the first draws from scrambled Sobol' points with "sobol"), never
 * on tiles or threads, so that images are the same for any thread count. Opaque: the storage of
 * the core's sampler. */
typedef struct vbnl_sample_stream {
    uint64_t opaque[8];
} vbnl_sample_stream;
/* The stream of sample `sample` of pixel (x, y). */
void vbnl_tile_job_stream(const vbnl_tile_job *job, uint32_t x, uint32_t y, uint32_t sample,
                          vbnl_sample_stream *out);
/* The stream's next number, uniform in [0, 1). */
float vbnl_sample_stream_next(vbnl_sample_stream *s);

/* The camera ray through image point (px, py) in pixels (continuous: pixel (x, y) covers
 * [x, x + 1) x [y, y + 1), row 0 at the top): origin and unit direction. */
void vbnl_tile_job_camera_ray(const vbnl_tile_job *job, float px, float py, float origin[3],
                              float direction[3]);

/* Adds one sample of pixel (x, y) (inside the tile) to the film: `record` holds
 * vbnl_film_record_size(film) floats, every layer's channels at its offset (the beauty RGBA at
 * VBNL_FILM_BEAUTY, the core's AOVs at VBNL_FILM_ALBEDO, VBNL_FILM_NORMAL, VBNL_FILM_DEPTH, an
 * integrator's own at the offsets vbnl_film_add_layer gave). A pixel's value is the mean of its
 * samples, so call this once per sample. */
void vbnl_tile_job_add_sample(vbnl_tile_job *job, uint32_t x, uint32_t y, const float *record);
/* Counts rays the integrator traced, for the render statistics (vbnl_render_stats.rays). */
void vbnl_tile_job_count_rays(vbnl_tile_job *job, uint64_t rays);

/* ---- the scene as integrators see it (ABI minor 2) -----------------------------------------
 *
 * Queries of a committed scene; any number of threads may run them at once. */

/* A ray's first hit. */
typedef struct vbnl_surface_hit {
    float t;                      /* distance along the (unit) ray direction */
    float position[3];
    float geometric_normal[3];    /* unit, the surface's own side (winding), not turned to the ray */
    float shading_normal[3];      /* unit, interpolated (= geometric where none), on its side */
    float uv[2];                  /* mesh UVs (0 where none) */
    uint32_t material;            /* the id vbnl_scene_add_material gave */
} vbnl_surface_hit;

/* The first surface along origin + t direction, 0 < t < tmax (direction of unit length; tmax may
 * be INFINITY): 1 and *hit filled, or 0 when there is none. */
int vbnl_scene_trace_ray(const vbnl_scene *scene, const float origin[3], const float direction[3], float tmax,
                         vbnl_surface_hit *hit);
/* 1 when some surface lies along origin + t direction, 0 < t < tmax, else 0. */
int vbnl_scene_ray_occluded(const vbnl_scene *scene, const float origin[3], const float direction[3],
                            float tmax);
/* The origin of a ray leaving `position` (a hit's) along `direction`, moved off the surface with
 * normal `normal` to the side the direction points to, so that the ray does not hit the surface
 * it starts on. */
void vbnl_scene_offset_origin(const float position[3], const float normal[3], const float direction[3],
                              float origin[3]);
/* The description material `id` was added with (its texture as base_texture). Errors:
 * VBNL_ERR_INVALID_ARGUMENT for a NULL argument or an unknown id. */
vbnl_result vbnl_scene_get_material(const vbnl_scene *scene, uint32_t id, vbnl_material_desc *out,
                                    vbnl_error *err);

/* ---- the class ------------------------------------------------------------------------------ */

typedef struct vbnl_integrator_class {
    uint32_t abi_major, abi_minor;
    uint32_t size;                     /* sizeof(vbnl_integrator_class) the integrator was built with */
    const char *name;
    const char *summary;               /* one line */
    const vbnl_param_spec *params;
    uint32_t param_count;
    vbnl_result (*create)(const vbnl_integrator_env *env, void **state, vbnl_error *err);
    vbnl_result (*prepare)(void *state, vbnl_stage_ctx *stage, vbnl_error *err);
    void (*render_tile)(void *state, vbnl_tile_job *job);
    void (*destroy)(void *state);
} vbnl_integrator_class;

/* The number of registered integrators. */
uint32_t vbnl_integrator_count(void);
/* Registered integrator `index`; NULL when index >= count. */
const vbnl_integrator_class *vbnl_integrator_at(uint32_t index);
/* The registered integrator of that name; NULL when none has it (or name is NULL). */
const vbnl_integrator_class *vbnl_integrator_find(const char *name);

/* vbnl_renderer_create (render.h) with an integrator class of the caller's instead of a
 * registered one (settings->integrator is ignored). The class must outlive the renderer. Errors:
 * those of vbnl_renderer_create; VBNL_ERR_INVALID_ARGUMENT for a NULL class, a table too short
 * for its fields (size), no name, create or render_tile; VBNL_ERR_UNSUPPORTED for another ABI
 * major version. */
vbnl_result vbnl_renderer_create_with_class(vbnl_context *ctx, const vbnl_scene *scene,
                                            const vbnl_render_settings *settings,
                                            const vbnl_integrator_class *cls, vbnl_renderer **out,
                                            vbnl_error *err);

#ifdef __cplusplus
}
#endif
#endif
