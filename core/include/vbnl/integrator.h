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
#define VBNL_INTEGRATOR_ABI_MINOR 0u

typedef struct vbnl_tile_job vbnl_tile_job;     /* one tile of one pass (internal) */
typedef struct vbnl_stage_ctx vbnl_stage_ctx;   /* progress, timing and workers for prepare */

typedef struct vbnl_integrator_env {
    vbnl_context *ctx;
    const vbnl_scene *scene;
    const vbnl_params *params;         /* already validated against the class's spec table */
    const vbnl_render_settings *settings;
    vbnl_film *film;                   /* add AOV layers here with vbnl_film_add_layer (internal) */
} vbnl_integrator_env;

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
