/* `vsl`: virtual spherical lights (Hasan, Krivanek, Walter, Bala 2009), the baseline of the VBNL
 * and Rich-VPL papers.
 *
 * prepare: the VPL set of `vpl` (vpl_set.h: same walks, same flux), then a radius per light,
 *          r_i = M x the distance to its 10th nearest light (the notes' §2.3, M = 4 by default),
 *          found with the k-d tree of VBNL's elimination (exact k-nearest queries);
 * render:  at the first non-delta vertex x, direct light with the shared estimator, and for every
 *          light i
 *            L_i = V(x, y_i) Phi_i / (pi r_i^2) Int_cone f_x(w) cos_x f_i(-w) cos_i dw,
 *          the cone being the directions from x toward the sphere (every direction when x is
 *          inside it), visibility to the centre only, and only when x is in front of the light's
 *          surface and the centre in front of x's (the VPL's conditions; without them points
 *          inside a sphere but behind the light's plane are lit: light leaks around box edges). The integral is estimated with one sample of
 *          each of three strategies combined by the power heuristic: the BSDF at x, the BSDF at the
 *          light (both importance-sampled, as the Rich-VPL paper §6 states for VSLs), and a uniform
 *          direction in the cone (VBNL's Eq. 4), which keeps far lights, whose cones BSDF samples
 *          rarely hit, from being noisy. As r -> 0 the estimate becomes the VPL term
 *          f_x cos_x f_i cos_i Phi / d^2; no clamping is needed (the integral is bounded). */
#include <stdlib.h>
#include <string.h>

#include "kdtree.h"
#include "vpl_set.h"

#define VSL_RADIUS_K_MAX 1000 /* largest radius_neighbour (the search's scratch is on the stack) */

static const vbnl_param_spec vsl_params[] = {
    {"virtual_lights", VBNL_PARAM_INT, 1000, NULL, 1, 5e7, NULL,
     "lights to generate (the VBNL paper compares at 12K); under --time sized to the budget unless set"},
    {"light_paths", VBNL_PARAM_INT, 0, NULL, 0, 1e10, NULL,
     "fixed number N of light paths instead (0 = trace until virtual_lights are stored)"},
    {"rr_depth", VBNL_PARAM_INT, 0, NULL, 0, 1e6, NULL, "light-walk bounces before Russian roulette"},
    {"radius_scale", VBNL_PARAM_FLOAT, 4, NULL, 1e-3, 1e3, NULL,
     "M: radius = M x distance to the k-th nearest light (Hasan et al. 2009: 4 to 10)"},
    {"radius_neighbour", VBNL_PARAM_INT, 10, NULL, 1, VSL_RADIUS_K_MAX, NULL, "k of the radius rule (10)"},
    {"indirect_only", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "leave out emission and single scattering (compare indirect light)"},
};
#define N_PARAMS (sizeof(vsl_params) / sizeof(vsl_params[0]))

typedef struct vsl_state {
    const vbnl_scene *scene;
    vbi_vpl_params vp;
    float radius_scale;
    uint32_t neighbour;
    int indirect_only;
    uint32_t stride;
    vec3 cam_forward;
    vbi_vpl_set set;
    float *radius;
    float *inv_area; /* 1 / (pi r^2) */
    vbnl_budget *budget;
} vsl_state;

/* Under a time budget the light count is sized by vbnl_budget_size_lights (docs/time-budget.md):
 * two samples per pixel in the budget's rendering share, a light evaluation costing about 4
 * shadow rays (measured on the Cornell box: docs/time-budget.md). */
#define VSL_LIGHT_COST 4.0

static double param(const vbnl_integrator_env *env, const char *name)
{
    return vbnl_params_number(env->params, vsl_params, N_PARAMS, name);
}

static vbnl_result vsl_create(const vbnl_integrator_env *env, void **out, vbnl_error *err)
{
    vsl_state *s = calloc(1, sizeof(*s));
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    s->scene = env->scene;
    s->budget = env->budget;
    vbi_vpl_params *vp = &s->vp;
    vp->target = (uint32_t)param(env, "virtual_lights");
    vp->light_paths = (uint64_t)param(env, "light_paths");
    vp->clamp = 0.0f;
    vp->rr_depth = (int)param(env, "rr_depth");
    vp->seed = env->settings->seed;
    vp->frames = 1;
    vp->width = env->settings->width;
    vp->height = env->settings->height;
    s->radius_scale = (float)param(env, "radius_scale");
    s->neighbour = (uint32_t)param(env, "radius_neighbour");
    s->indirect_only = param(env, "indirect_only") != 0.0;
    vbnl_result r = vbi_vpl_params_check(vp, "vsl", err);
    if (r != VBNL_OK) {
        free(s);
        return r;
    }
    s->stride = env->film->stride;
    s->cam_forward = v3_norm(v3_load(env->scene->camera.forward));
    *out = s;
    return VBNL_OK;
}

static void vsl_destroy(void *state)
{
    vsl_state *s = state;
    if (!s)
        return;
    vbi_vpl_set_free(&s->set);
    free(s->radius);
    free(s->inv_area);
    free(s);
}

typedef struct radius_job {
    vsl_state *s;
    const vbi_kd_tree *tree;
    uint32_t m;
} radius_job;

#define RADIUS_CHUNK 512u

static void radius_chunk(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    radius_job *job = user;
    vsl_state *s = job->s;
    uint32_t idx[VSL_RADIUS_K_MAX];
    float d2s[VSL_RADIUS_K_MAX];
    uint32_t b = (uint32_t)item * RADIUS_CHUNK, n = job->tree->n;
    uint32_t e = b + RADIUS_CHUNK < n ? b + RADIUS_CHUNK : n;
    for (uint32_t i = b; i < e; ++i) {
        float d2 = vbi_kd_mth_dist2(job->tree, i, job->m, idx, d2s);
        uint32_t id = job->tree->pts[i].id;
        s->radius[id] = s->radius_scale * sqrtf(d2);
    }
}

static vbnl_result vsl_prepare(void *state, vbnl_stage_ctx *stage, vbnl_error *err)
{
    vsl_state *s = state;
    vbnl_result r = vbnl_budget_size_lights(s->budget, "virtual_lights", s->vp.target, 2.0, VSL_LIGHT_COST, 16,
                                            12000, &s->vp.target, err);
    if (r != VBNL_OK)
        return r;
    r = vbi_vpl_set_build(s->scene, &s->vp, stage, &s->set, err);
    if (r != VBNL_OK)
        return r;
    const uint32_t n = s->set.count;
    s->radius = calloc(n ? n : 1, sizeof(float));
    s->inv_area = calloc(n ? n : 1, sizeof(float));
    if (!s->radius || !s->inv_area)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    if (n >= 2) {
        if (stage)
            vbnl_stage_begin(stage, "radii", n, "lights");
        vbi_kd_pt *pts = malloc(sizeof(vbi_kd_pt) * n);
        vbi_kd_tree tree;
        memset(&tree, 0, sizeof(tree));
        if (!pts)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        for (uint32_t i = 0; i < n; ++i) {
            pts[i].p[0] = s->set.vpls[i].p.x;
            pts[i].p[1] = s->set.vpls[i].p.y;
            pts[i].p[2] = s->set.vpls[i].p.z;
            pts[i].id = i;
        }
        if (vbi_kd_build(&tree, pts, n) != 0) {
            free(pts);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        radius_job job = {s, &tree, s->neighbour < n - 1 ? s->neighbour : n - 1};
        int rc = vbi_run_items(stage, NULL, (n + RADIUS_CHUNK - 1) / RADIUS_CHUNK, radius_chunk, &job);
        vbi_kd_free(&tree);
        free(pts);
        if (stage)
            vbnl_stage_end(stage);
        if (rc != 0)
            return vbnl_error_set(err, VBNL_ERR_CANCELLED, "virtual spherical light radii were cancelled");
    }
    /* a light alone (or on top of k others) keeps r = 0 and acts as a point light */
    for (uint32_t i = 0; i < n; ++i)
        s->inv_area[i] = s->radius[i] > 0.0f ? 1.0f / (VBI_PI * s->radius[i] * s->radius[i]) : 0.0f;
    vbnl_stage_set_storage(stage, (uint64_t)n * (sizeof(vbi_vpl) + 2 * sizeof(float)));
    return VBNL_OK;
}

static inline float sq(float x) { return x * x; }

/* f_x cos_x f_i cos_i along w (from x toward the light), 0 outside the cone or a surface. */
static vec3 integrand(const vbi_vpl *v, const vbi_bsdf *bsdf, const vbi_shading_frame *sf, vec3 w, vec3 axis,
                      float cos_max, float *pdf_x, float *pdf_y)
{
    *pdf_x = *pdf_y = 0.0f;
    if (v3_dot(w, axis) < cos_max || v3_dot(w, sf->ng) <= 0.0f)
        return v3s(0.0f);
    vec3 wx = frame_to_local(&sf->fr, w);
    vec3 wy = frame_to_local(&v->fr, v3_neg(w));
    *pdf_x = vbi_bsdf_pdf(bsdf, sf->wo, wx);
    *pdf_y = vbi_bsdf_pdf(&v->bsdf, v->wi, wy);
    vec3 fx = vbi_bsdf_eval(bsdf, sf->wo, wx);
    if (v3_is_black(fx))
        return v3s(0.0f);
    return v3_mul(fx, vbi_bsdf_eval(&v->bsdf, v->wi, wy));
}

static vec3 gather(const void *state, const vbi_bsdf *bsdf, vec3 x, const vbi_shading_frame *sf, vbi_sampler *sp,
                   vbi_thread_stats *stats)
{
    const vsl_state *s = state;
    vec3 sum = v3s(0.0f);
    for (uint32_t i = 0; i < s->set.count; ++i) {
        const vbi_vpl *v = &s->set.vpls[i];
        /* the draws of every light are taken whether or not it contributes: fixed stream use */
        vec2 uc = vbi_sampler_next2(sp);
        vec2 ua = vbi_sampler_next2(sp), ub = vbi_sampler_next2(sp);
        float r = s->radius[i];
        vec3 to = v3_sub(v->p, x);
        float d2 = v3_len2(to);
        if (!(d2 > 0.0f))
            continue;
        float dist = sqrtf(d2);
        vec3 axis = v3_scale(to, 1.0f / dist);
        /* x in front of the light's plane and the centre in front of x's: the conditions of the
         * VPL term at the centre. Without them a point inside a sphere but behind the light's
         * surface (the top of a box lit by a light on its front face) receives light through
         * directions that never meet the light's disk. */
        if (v3_dot(axis, v->ng) >= 0.0f || v3_dot(axis, sf->ng) <= 0.0f)
            continue;
        vec3 L;
        if (!(r > 0.0f)) {
            vec3 w;
            L = vbi_vpl_contribution(v, bsdf, x, sf, 0.0f, &w, &dist);
        } else {
            float cos_max = d2 <= r * r ? -1.0f : sqrtf(1.0f - r * r / d2);
            float pc = pdf_uniform_cone(cos_max);
            vec3 est = v3s(0.0f);
            float px, py;
            /* 1: uniform in the cone */
            frame cf = frame_from_normal(axis);
            vec3 w = frame_to_world(&cf, sample_uniform_cone(uc, cos_max));
            vec3 h = integrand(v, bsdf, sf, w, axis, cos_max, &px, &py);
            if (!v3_is_black(h))
                est = v3_add(est, v3_scale(h, pc / (sq(pc) + sq(px) + sq(py))));
            /* 2: the BSDF at x */
            vbi_bsdf_sample_rec bs;
            if (vbi_bsdf_sample(bsdf, sf->wo, ua, &bs) && bs.pdf > 0.0f && !(bs.lobe & VBI_LOBE_SPECULAR)) {
                w = frame_to_world(&sf->fr, bs.wi);
                h = integrand(v, bsdf, sf, w, axis, cos_max, &px, &py);
                if (!v3_is_black(h) && px > 0.0f)
                    est = v3_add(est, v3_scale(h, px / (sq(pc) + sq(px) + sq(py))));
            }
            /* 3: the BSDF at the light (reciprocity: a direction leaving it toward x) */
            if (vbi_bsdf_sample(&v->bsdf, v->wi, ub, &bs) && bs.pdf > 0.0f && !(bs.lobe & VBI_LOBE_SPECULAR)) {
                w = v3_neg(frame_to_world(&v->fr, bs.wi));
                h = integrand(v, bsdf, sf, w, axis, cos_max, &px, &py);
                if (!v3_is_black(h) && py > 0.0f)
                    est = v3_add(est, v3_scale(h, py / (sq(pc) + sq(px) + sq(py))));
            }
            L = v3_scale(v3_mul(est, v->flux), s->inv_area[i]);
        }
        if (v3_is_black(L) || !v3_is_finite(L))
            continue;
        stats->rays++;
        if (vbi_vpl_visible(s->scene, x, sf->ng, v, axis, dist))
            sum = v3_add(sum, L);
    }
    return sum;
}

static void trace(void *state, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first, float *out,
                  vbi_thread_stats *stats)
{
    const vsl_state *s = state;
    vbi_vpl_trace(s->scene, s->indirect_only, s->cam_forward, gather, s, sp, o, d, hit_ok, first, out, stats);
}

static void vsl_render_tile(void *state, vbnl_tile_job *job)
{
    const vsl_state *s = state;
    vbi_render_camera_paths(job, s->stride, trace, state);
}

const vbnl_integrator_class vbi_integrator_vsl = {
    VBNL_INTEGRATOR_ABI_MAJOR,
    VBNL_INTEGRATOR_ABI_MINOR,
    sizeof(vbnl_integrator_class),
    "vsl",
    "virtual spherical lights: the VPLs of `vpl` spread over spheres (radius M x 10th-neighbour distance)",
    vsl_params,
    N_PARAMS,
    vsl_create,
    vsl_prepare,
    vsl_render_tile,
    vsl_destroy,
};
