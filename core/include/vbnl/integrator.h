/* vbnl: the integrator ABI and registry.
 *
 * Every integrator (the `path` reference, `vbnl`, the comparison methods) is a const
 * vbnl_integrator_class found by name in a registry. The table starts with its ABI version and
 * its own size and only ever grows at the end: a host built against minor version m may read the
 * fields that existed in m, and must check `size` before reading anything newer.
 *
 * Life cycle, driven by vbnl_renderer (render.h):
 *   create(env)   reads the validated parameters, registers extra film layers (AOVs);
 *   prepare()     scene-dependent work before the first pass (may be NULL);
 *   render_tile() called for every tile of every pass, concurrently on worker threads for
 *                 different tiles (an integrator must keep per-tile state on the stack or in
 *                 per-thread scratch indexed by vbnl_tile_job_thread());
 *   destroy()     frees the state (accepts NULL).
 *
 * The registry is immutable: these functions may be called from any thread. */
#ifndef VBNL_INTEGRATOR_H
#define VBNL_INTEGRATOR_H

#include <stdint.h>

#include "vbnl/params.h"
#include "vbnl/render.h"
#include "vbnl/result.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VBNL_INTEGRATOR_ABI_MAJOR 1u
#define VBNL_INTEGRATOR_ABI_MINOR 1u

typedef struct vbnl_tile_job vbnl_tile_job;     /* one tile of one pass (internal) */
typedef struct vbnl_stage_ctx vbnl_stage_ctx;   /* progress, timing and workers for prepare */

typedef struct vbnl_budget vbnl_budget;         /* the render's time budget (below) */

typedef struct vbnl_integrator_env {
    vbnl_context *ctx;
    const vbnl_scene *scene;
    const vbnl_params *params;         /* already validated against the class's spec table */
    const vbnl_render_settings *settings;
    vbnl_film *film;                   /* add AOV layers here with vbnl_film_add_layer (internal) */
    /* ABI minor 1 */
    vbnl_budget *budget;               /* never NULL; vbnl_budget_seconds is 0 without a budget */
} vbnl_integrator_env;

/* ---- time budget (ABI minor 1) -------------------------------------------------------------
 *
 * A render with settings.time_budget > 0 belongs to its integrators: each sizes its own work to
 * the budget (docs/time-budget.md). The renderer ends rendering at the budget (the tiles in
 * flight finish, and the first pass is always whole); preparation must keep itself within
 * vbnl_budget_prepare_limit. A parameter the user set (vbnl_params_has) is kept; when it cannot
 * fit, the integrator refuses (VBNL_ERR_INVALID_ARGUMENT) before the work it sizes starts, naming the
 * estimate and the limit. What an integrator chose is recorded with vbnl_budget_choose and
 * reported by vbnl_renderer_get_stats (and in the EXR header). */

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
 * "sized: ..."); a later call for the same name replaces the record. */
void vbnl_budget_choose(vbnl_budget *b, const char *name, double value, const char *why_fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Light count of a many-light baseline (`vpl`, `vsl`, `richvsl`), whose shading costs about one
 * shadow ray per light per camera vertex: the count with which `spp_target` samples per pixel
 * fit the budget's rendering share (1 - VBNL_BUDGET_PREPARE_SHARE) at the scene's shadow-ray
 * rate measured here (a short calibration, vbnl_scene_measure_ray_rates, recorded as the stage
 * "calibrate"), a light evaluation costing `cost` shadow rays, clamped to [lo, hi]. A count the
 * user set (the parameter `name`) is kept, and refused (VBNL_ERR_INVALID_ARGUMENT) when one pass
 * alone would not fit the time left. Without a budget, *out = `fallback` (the parameter's
 * value) and nothing is measured. Records the choice. */
vbnl_result vbnl_budget_size_lights(vbnl_budget *b, const char *name, double fallback, double spp_target,
                                    double cost, double lo, double hi, uint32_t *out, vbnl_error *err);

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

uint32_t vbnl_integrator_count(void);
/* NULL when index >= count. */
const vbnl_integrator_class *vbnl_integrator_at(uint32_t index);
/* NULL when no integrator has that name. */
const vbnl_integrator_class *vbnl_integrator_find(const char *name);

#ifdef __cplusplus
}
#endif
#endif
