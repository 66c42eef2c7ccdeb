/* `path`: the unbiased reference. Unidirectional path tracing with next-event estimation and
 * BSDF sampling combined by multiple importance sampling (power heuristic, Veach 1997), Russian
 * roulette, unlimited depth by default. Primary rays are traced as 8-wide Embree packets. */
#include <stdlib.h>
#include <string.h>

#include "render_internal.h"
#include "shading.h"

static const vbnl_param_spec path_params[] = {
    {"max_depth", VBNL_PARAM_INT, -1, NULL, -1, 1e6, NULL,
     "longest path in bounces; -1 = unlimited (Russian roulette ends paths)"},
    {"rr_depth", VBNL_PARAM_INT, 3, NULL, 0, 1e6, NULL,
     "bounces before Russian roulette starts"},
    {"split_direct", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "also write 'direct' (emission and one-bounce light) and 'indirect' layers"},
    {"indirect_only", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "leave out emission and single scattering (the 'direct' part), to compare indirect light"},
    {"clamp", VBNL_PARAM_FLOAT, 0, NULL, 0, 1e30, NULL,
     "largest contribution one path vertex adds (its largest channel); 0 = off. Removes fireflies, biased"},
};

typedef struct path_state {
    const vbnl_scene *scene;
    int max_depth;
    int rr_depth;
    int split;
    int indirect_only;
    float clamp; /* > 0: each contribution scaled down to this largest channel */
    uint32_t off_direct, off_indirect;
    uint32_t stride;
    vec3 cam_forward;
} path_state;

static vbnl_result path_create(const vbnl_integrator_env *env, void **out, vbnl_error *err)
{
    path_state *ps = calloc(1, sizeof(*ps));
    if (!ps)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    const uint32_t n = sizeof(path_params) / sizeof(path_params[0]);
    ps->scene = env->scene;
    ps->max_depth = (int)vbnl_params_number(env->params, path_params, n, "max_depth");
    ps->rr_depth = (int)vbnl_params_number(env->params, path_params, n, "rr_depth");
    ps->split = vbnl_params_number(env->params, path_params, n, "split_direct") != 0.0;
    ps->indirect_only = vbnl_params_number(env->params, path_params, n, "indirect_only") != 0.0;
    ps->clamp = (float)vbnl_params_number(env->params, path_params, n, "clamp");
    if (ps->split) {
        static const char *const rgb[] = {"R", "G", "B"};
        vbnl_result r;
        if ((r = vbnl_film_add_layer(env->film, "direct", 3, rgb, &ps->off_direct, err)) != VBNL_OK ||
            (r = vbnl_film_add_layer(env->film, "indirect", 3, rgb, &ps->off_indirect, err)) != VBNL_OK) {
            free(ps);
            return r;
        }
    }
    ps->stride = env->film->stride;
    ps->cam_forward = v3_norm(v3_load(env->scene->camera.forward));
    *out = ps;
    return VBNL_OK;
}

static void path_destroy(void *state) { free(state); }

/* Adds a contribution to the beauty image and, when splitting, to the direct or indirect layer.
 * Direct light (the same split for every integrator): emission seen directly or through delta
 * bounces, and the light scattered once at the first non-delta vertex (its next-event estimate
 * and the MIS-weighted light its BSDF sample finds). */
static inline void add_L(const path_state *ps, float *out, vec3 c, int is_direct)
{
    if (ps->indirect_only && is_direct) /* the setting first: it is the predictable test */
        return;
    if (ps->clamp > 0.0f) {
        /* the user's bias for fewer fireflies (docs/integrators.md, "path") */
        const float m = v3_max_comp(c);
        if (m > ps->clamp)
            c = v3_scale(c, ps->clamp / m);
    }
    out[0] += c.x;
    out[1] += c.y;
    out[2] += c.z;
    if (ps->split) {
        float *dst = out + (is_direct ? ps->off_direct : ps->off_indirect);
        dst[0] += c.x;
        dst[1] += c.y;
        dst[2] += c.z;
    }
}

/* Traces one camera path whose first hit (if any) is given; writes its sample into out. */
static inline __attribute__((always_inline)) void trace_path(const path_state *ps, vbi_sampler *sp, vec3 o, vec3 d,
                                                             int hit_ok, const vbi_hit *first, float *out,
                                                             vbi_thread_stats *stats)
{
    const vbnl_scene *sc = ps->scene;
    vbi_hit hit = *first;
    vec3 beta = v3s(1.0f);
    out[3] = 1.0f; /* alpha */
    /* what the camera sees directly */
    if (!hit_ok) {
        if (sc->env_light != VBI_NO_LIGHT)
            add_L(ps, out, vbi_light_Le(&sc->lights[sc->env_light], v3s(0.0f), v3_neg(d)), 1);
        return;
    }
    /* the BSDF of the vertex being scattered at; the first one also gives the albedo AOV */
    vbi_bsdf bsdf_store;
    const vbi_bsdf *bsdf = vbi_surface_bsdf(sc, &hit, &bsdf_store);
    v3_store(out + VBNL_FILM_ALBEDO, bsdf->type == VBNL_MATERIAL_CONDUCTOR ? vbi_bsdf_albedo(bsdf) : bsdf->color);
    v3_store(out + VBNL_FILM_NORMAL, hit.ns);
    out[VBNL_FILM_DEPTH] = v3_dot(v3_sub(hit.p, o), ps->cam_forward);
    if (hit.light != VBI_NO_LIGHT)
        add_L(ps, out, vbi_light_Le(&sc->lights[hit.light], hit.ng, v3_neg(d)), 1);
    int direct = 1; /* no non-delta vertex yet */
    for (int depth = 0;; ++depth) {
        if (ps->max_depth >= 0 && depth >= ps->max_depth)
            break;
        const int vertex_direct = direct;
        if (!vbi_bsdf_is_delta(bsdf))
            direct = 0;
        vbi_shading_frame sf;
        vbi_shading_frame_make(bsdf, &hit, d, &sf);
        const vec3 x = hit.p;
        /* next-event estimation (MIS with the BSDF sample below) */
        if (!vbi_bsdf_is_delta(bsdf))
            add_L(ps, out, v3_mul(beta, vbi_estimate_direct(sc, bsdf, x, &sf, sp, stats)), vertex_direct);
        /* continue by BSDF sampling */
        vbi_bsdf_sample_rec bs;
        vec2 ub = vbi_sampler_next2(sp);
        if (!vbi_bsdf_sample(bsdf, sf.wo, ub, &bs) || vbi_is_black(bs.weight))
            break;
        vec3 w = frame_to_world(&sf.fr, bs.wi);
        /* a reflection must leave on the viewer's side of the real surface */
        if (!(bs.lobe & VBI_LOBE_TRANSMISSION) && v3_dot(w, sf.ng) <= 0.0f)
            break;
        beta = v3_mul(beta, bs.weight);
        /* a reflection leaves on the side of sf.ng (just tested), which is hit.ng or its negation */
        o = (bs.lobe & VBI_LOBE_TRANSMISSION) ? vbi_offset_ray_origin(x, hit.ng, w)
                                               : vbi_offset_ray_origin_along(x, sf.ng);
        d = w;
        stats->rays++;
        hit_ok = vbi_scene_intersect_inline(sc, o, d, INFINITY, &hit);
        /* light arriving along the sample, MIS-weighted against the NEE above */
        vec3 Le;
        float mw = vbi_arriving_light(sc, hit_ok, &hit, x, w, bs.pdf, (bs.lobe & VBI_LOBE_SPECULAR) != 0, &Le);
        if (mw > 0.0f)
            add_L(ps, out, v3_scale(v3_mul(beta, Le), mw), vertex_direct);
        if (!hit_ok)
            break;
        if (depth >= ps->rr_depth) {
            float q = maxf(0.05f, 1.0f - v3_max_comp(beta));
            if (vbi_sampler_next(sp) < q)
                break;
            beta = v3_scale(beta, 1.0f / (1.0f - q));
        }
        if (!vbi_is_finite(beta))
            break;
        bsdf = vbi_surface_bsdf(sc, &hit, &bsdf_store);
    }
}

typedef struct path_add_ctx {
    const path_state *ps;
    float *out;
} path_add_ctx;

static void path_walk_add(void *user, vec3 c, int is_direct)
{
    const path_add_ctx *a = user;
    add_L(a->ps, a->out, c, is_direct);
}

/* Works on a copy of the sampler (written back at the end): through the pointer its state would
 * be stored and reloaded around every Embree call. */
static void trace(void *state, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first, float *out,
                  vbi_thread_stats *stats)
{
    const path_state *ps = state;
    vbi_sampler r = *sp;
    const vbnl_scene *sc = ps->scene;
    if (sc->has_media || sc->has_null || sc->has_masks) {
        /* media, pass-through surfaces or visibility flags: the walk between vertices */
        path_add_ctx a = {ps, out};
        out[3] = 1.0f;
        vbi_trace_path_walk(sc, &r, o, d, hit_ok, first, ps->max_depth, ps->rr_depth, path_walk_add, &a, out,
                             stats);
    } else {
        trace_path(ps, &r, o, d, hit_ok, first, out, stats);
    }
    *sp = r;
}

static void path_render_tile(void *state, vbnl_tile_job *job)
{
    const path_state *ps = state;
    vbi_render_camera_paths(job, ps->stride, trace, state);
}

const vbnl_integrator_class vbi_integrator_path = {
    VBNL_INTEGRATOR_ABI_MAJOR,
    VBNL_INTEGRATOR_ABI_MINOR,
    sizeof(vbnl_integrator_class),
    "path",
    "unidirectional path tracing with NEE + BSDF sampling (MIS), the unbiased reference",
    path_params,
    sizeof(path_params) / sizeof(path_params[0]),
    path_create,
    NULL,
    path_render_tile,
    path_destroy,
};
