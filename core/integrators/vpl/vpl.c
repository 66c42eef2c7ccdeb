/* `vpl`: instant radiosity (Keller 1997) with a clamped geometry term, and optionally the
 * iterative importance sampling of Georgiev & Slusallek 2010 (`acceptance`).
 *
 * prepare: one set of virtual point lights (vpl_set.h), the same for every pixel and pass;
 * render:  at the first non-delta vertex x of every camera path, direct light with the shared
 *          estimator and the sum over all VPLs of f_x G_b V f_y Phi (survey Eq. 8), one shadow ray
 *          per VPL (brute force). The error is therefore structured (the same VPLs light every
 *          pixel); averaging renders with different seeds converges to the path-traced indirect
 *          light when unclamped. */
#include <stdlib.h>
#include <string.h>

#include "vpl_set.h"

static const vbnl_param_spec vpl_params[] = {
    {"virtual_lights", VBNL_PARAM_INT, 1000, NULL, 1, 5e7, NULL,
     "VPLs to generate (accepted ones with acceptance; the VBNL paper compares at 12K); under --time "
     "sized to the budget unless set"},
    {"light_paths", VBNL_PARAM_INT, 0, NULL, 0, 1e10, NULL,
     "fixed number N of light paths instead (0 = trace until virtual_lights are stored)"},
    {"clamp", VBNL_PARAM_FLOAT, 0, NULL, 0, 1e30, NULL,
     "bound b of the geometry term cos cos / d^2 (1/scene unit^2); 0 = unclamped (the papers give none)"},
    {"rr_depth", VBNL_PARAM_INT, 0, NULL, 0, 1e6, NULL, "light-walk bounces before Russian roulette"},
    {"acceptance", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "Georgiev-Slusallek 2010 importance sampling: keep each VPL with p = min(Phi_i / Phi_v + epsilon, 1)"},
    {"epsilon", VBNL_PARAM_FLOAT, 0.05, NULL, 1e-9, 1e9, NULL, "acceptance: the additive epsilon"},
    {"camera_points", VBNL_PARAM_INT, 100, NULL, 1, 1e6, NULL, "acceptance: N_C camera points per frame"},
    {"acceptance_frames", VBNL_PARAM_INT, 2, NULL, 1, 64, NULL,
     "acceptance: frames of the iteration (frame 1 is plain IR; each uses the previous total)"},
    {"indirect_only", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "leave out emission and single scattering (compare indirect light)"},
};
#define N_PARAMS (sizeof(vpl_params) / sizeof(vpl_params[0]))

typedef struct vpl_state {
    const vbnl_scene *scene;
    vbi_vpl_params vp;
    int indirect_only;
    uint32_t stride;
    vec3 cam_forward;
    vbi_vpl_set set;
    vbnl_budget *budget;
} vpl_state;

/* Under a time budget the light count is sized by vbnl_budget_size_lights (docs/time-budget.md):
 * two samples per pixel in the budget's rendering share, a light evaluation costing about 4
 * shadow rays (measured on the Cornell box: docs/time-budget.md). */
#define VPL_LIGHT_COST 4.0

static double param(const vbnl_integrator_env *env, const char *name)
{
    return vbnl_params_number(env->params, vpl_params, N_PARAMS, name);
}

static vbnl_result vpl_create(const vbnl_integrator_env *env, void **out, vbnl_error *err)
{
    vpl_state *s = calloc(1, sizeof(*s));
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    s->scene = env->scene;
    s->budget = env->budget;
    vbi_vpl_params *vp = &s->vp;
    vp->target = (uint32_t)param(env, "virtual_lights");
    vp->light_paths = (uint64_t)param(env, "light_paths");
    vp->clamp = (float)param(env, "clamp");
    vp->rr_depth = (int)param(env, "rr_depth");
    vp->seed = env->settings->seed;
    vp->acceptance = param(env, "acceptance") != 0.0;
    vp->epsilon = (float)param(env, "epsilon");
    vp->camera_points = (uint32_t)param(env, "camera_points");
    vp->frames = (uint32_t)param(env, "acceptance_frames");
    vp->width = env->settings->width;
    vp->height = env->settings->height;
    s->indirect_only = param(env, "indirect_only") != 0.0;
    vbnl_result r = vbi_vpl_params_check(vp, "vpl", err);
    if (r != VBNL_OK) {
        free(s);
        return r;
    }
    s->stride = env->film->stride;
    s->cam_forward = v3_norm(v3_load(env->scene->camera.forward));
    *out = s;
    return VBNL_OK;
}

static void vpl_destroy(void *state)
{
    vpl_state *s = state;
    if (!s)
        return;
    vbi_vpl_set_free(&s->set);
    free(s);
}

static vbnl_result vpl_prepare(void *state, vbnl_stage_ctx *stage, vbnl_error *err)
{
    vpl_state *s = state;
    vbnl_result r = vbnl_budget_size_lights(s->budget, "virtual_lights", s->vp.target, 2.0, VPL_LIGHT_COST, 16,
                                            12000, &s->vp.target, err);
    if (r != VBNL_OK)
        return r;
    r = vbi_vpl_set_build(s->scene, &s->vp, stage, &s->set, err);
    if (r == VBNL_OK)
        vbnl_stage_set_storage(stage, (uint64_t)s->set.count * sizeof(vbi_vpl));
    return r;
}

static vec3 gather(const void *state, const vbi_bsdf *bsdf, vec3 x, const vbi_shading_frame *sf, vbi_sampler *sp,
                   vbi_thread_stats *stats)
{
    (void)sp;
    const vpl_state *s = state;
    vec3 sum = v3s(0.0f);
    for (uint32_t i = 0; i < s->set.count; ++i) {
        const vbi_vpl *v = &s->set.vpls[i];
        vec3 w;
        float dist;
        vec3 c = vbi_vpl_contribution(v, bsdf, x, sf, s->vp.clamp, &w, &dist);
        if (v3_is_black(c))
            continue;
        stats->rays++;
        if (vbi_vpl_visible(s->scene, x, sf->ng, v, w, dist))
            sum = v3_add(sum, c);
    }
    return sum;
}

static void trace(void *state, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first, float *out,
                  vbi_thread_stats *stats)
{
    const vpl_state *s = state;
    vbi_vpl_trace(s->scene, s->indirect_only, s->cam_forward, gather, s, sp, o, d, hit_ok, first, out, stats);
}

static void vpl_render_tile(void *state, vbnl_tile_job *job)
{
    const vpl_state *s = state;
    vbi_render_camera_paths(job, s->stride, trace, state);
}

const vbnl_integrator_class vbi_integrator_vpl = {
    VBNL_INTEGRATOR_ABI_MAJOR,
    VBNL_INTEGRATOR_ABI_MINOR,
    sizeof(vbnl_integrator_class),
    "vpl",
    "instant radiosity: virtual point lights from light random walks, clamped geometry term, "
    "optional Georgiev-Slusallek acceptance",
    vpl_params,
    N_PARAMS,
    vpl_create,
    vpl_prepare,
    vpl_render_tile,
    vpl_destroy,
};
