/* `path`: the unbiased reference. Unidirectional path tracing with next-event estimation and
 * BSDF sampling combined by multiple importance sampling (power heuristic, Veach 1997), Russian
 * roulette, unlimited depth by default. Primary rays are traced as 8-wide Embree packets. */
#include <stdlib.h>
#include <string.h>

#include "render_internal.h"

static const vbnl_param_spec path_params[] = {
    {"max_depth", VBNL_PARAM_INT, -1, NULL, -1, 1e6, NULL,
     "longest path in bounces; -1 = unlimited (Russian roulette ends paths)"},
    {"rr_depth", VBNL_PARAM_INT, 3, NULL, 0, 1e6, NULL,
     "bounces before Russian roulette starts"},
    {"split_direct", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "also write 'direct' (emission and one-bounce light) and 'indirect' layers"},
};

typedef struct path_state {
    const vbnl_scene *scene;
    int max_depth;
    int rr_depth;
    int split;
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

/* Adds a contribution to the beauty image and, when splitting, to the direct or indirect layer. */
static inline void add_L(const path_state *ps, float *out, vec3 c, int is_direct)
{
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
static void trace(const path_state *ps, vbnl_rng *rng, vec3 o, vec3 d, int hit_ok, vbnl_hit hit,
                  float *out, vbnl_thread_stats *stats)
{
    const vbnl_scene *sc = ps->scene;
    vec3 beta = v3s(1.0f);
    float prev_pdf = 0.0f;
    int specular = 1;
    vec3 prev_p = o;
    out[3] = 1.0f; /* alpha */
    for (int depth = 0;; ++depth) {
        /* Light arriving along the ray: from the environment or an emitter that was hit. The
         * MIS weight balances it against next-event estimation at the previous vertex. */
        if (!hit_ok) {
            if (sc->env_light != VBNL_NO_LIGHT) {
                const vbnl_light *l = &sc->lights[sc->env_light];
                vec3 Le = vbnl_light_Le(l, v3s(0.0f), v3_neg(d));
                float w = 1.0f;
                if (!specular) {
                    float pl = vbnl_scene_light_pmf(sc, sc->env_light) *
                               vbnl_light_pdf_li(l, prev_p, v3s(0.0f), v3s(0.0f), d);
                    w = power_heuristic(prev_pdf, pl);
                }
                add_L(ps, out, v3_scale(v3_mul(beta, Le), w), depth <= 1);
            }
            break;
        }
        const scene_material *mat = &sc->materials[hit.material];
        if (depth == 0) {
            v3_store(out + VBNL_FILM_ALBEDO, vbnl_bsdf_albedo(&mat->bsdf));
            v3_store(out + VBNL_FILM_NORMAL, hit.ns);
            out[VBNL_FILM_DEPTH] = v3_dot(v3_sub(hit.p, o), ps->cam_forward);
        }
        if (hit.light != VBNL_NO_LIGHT) {
            const vbnl_light *l = &sc->lights[hit.light];
            vec3 Le = vbnl_light_Le(l, hit.ng, v3_neg(d));
            if (!v3_is_black(Le)) {
                float w = 1.0f;
                if (!specular) {
                    float pl = vbnl_scene_light_pmf(sc, hit.light) * vbnl_light_pdf_li(l, prev_p, hit.p, hit.ng, d);
                    w = power_heuristic(prev_pdf, pl);
                }
                add_L(ps, out, v3_scale(v3_mul(beta, Le), w), depth <= 1);
            }
        }
        if (ps->max_depth >= 0 && depth >= ps->max_depth)
            break;

        /* Shading frame. Opaque surfaces are two-sided: face the frame toward the viewer. */
        const vbnl_bsdf *bsdf = &mat->bsdf;
        vec3 wo_w = v3_neg(d);
        vec3 ng = hit.ng, ns = hit.ns;
        if (!vbnl_bsdf_is_transmissive(bsdf)) {
            if (v3_dot(ng, wo_w) < 0.0f) {
                ng = v3_neg(ng);
                ns = v3_neg(ns);
            }
            if (v3_dot(ns, wo_w) <= 0.0f)
                ns = ng; /* shading normal facing away from the viewer: fall back to flat */
        }
        frame fr = frame_from_normal(ns);
        vec3 wo = frame_to_local(&fr, wo_w);

        /* Next-event estimation: one light picked by power. */
        if (!vbnl_bsdf_is_delta(bsdf)) {
            float pmf;
            uint32_t li = vbnl_scene_pick_light(sc, vbnl_rng_next(rng), &pmf);
            const vbnl_light *l = &sc->lights[li];
            vbnl_light_li_sample ls;
            vec2 ul = vbnl_rng_next2(rng);
            if (vbnl_light_sample_li(l, hit.p, ul, &ls) && ls.pdf > 0.0f && !v3_is_black(ls.Li)) {
                vec3 wi = frame_to_local(&fr, ls.wi);
                vec3 f = vbnl_bsdf_eval(bsdf, wo, wi);
                /* no light through the geometric back of an opaque surface */
                int side_ok = vbnl_bsdf_is_transmissive(bsdf) || v3_dot(ls.wi, ng) > 0.0f;
                if (side_ok && !v3_is_black(f)) {
                    vec3 org = vbnl_offset_ray_origin(hit.p, ng, ls.wi);
                    float tmax = isinf(ls.dist) ? INFINITY : ls.dist * (1.0f - 1e-4f);
                    stats->rays++;
                    if (!vbnl_scene_occluded(sc, org, ls.wi, tmax)) {
                        float w = ls.is_delta ? 1.0f
                                              : power_heuristic(pmf * ls.pdf, vbnl_bsdf_pdf(bsdf, wo, wi));
                        vec3 c = v3_scale(v3_mul(v3_mul(beta, f), ls.Li), w / (pmf * ls.pdf));
                        add_L(ps, out, c, depth == 0);
                    }
                }
            }
        }

        /* Continue by BSDF sampling. */
        vbnl_bsdf_sample_rec bs;
        float ulobe = vbnl_rng_next(rng);
        vec2 ub = vbnl_rng_next2(rng);
        if (!vbnl_bsdf_sample(bsdf, wo, ulobe, ub, &bs) || v3_is_black(bs.weight))
            break;
        vec3 wi_w = frame_to_world(&fr, bs.wi);
        /* a reflection must leave on the viewer's side of the real surface */
        if (!(bs.lobe & VBNL_LOBE_TRANSMISSION) && v3_dot(wi_w, ng) <= 0.0f)
            break;
        beta = v3_mul(beta, bs.weight);
        specular = (bs.lobe & VBNL_LOBE_SPECULAR) != 0;
        prev_pdf = bs.pdf;
        prev_p = hit.p;
        if (depth >= ps->rr_depth) {
            float q = fmaxf(0.05f, 1.0f - v3_max_comp(beta));
            if (vbnl_rng_next(rng) < q)
                break;
            beta = v3_scale(beta, 1.0f / (1.0f - q));
        }
        if (!v3_is_finite(beta))
            break;
        o = vbnl_offset_ray_origin(hit.p, hit.ng, wi_w);
        d = wi_w;
        stats->rays++;
        hit_ok = vbnl_scene_intersect(sc, o, d, INFINITY, &hit);
    }
}

static void path_render_tile(void *state, vbnl_tile_job *job)
{
    const path_state *ps = state;
    const vbnl_scene *sc = job->scene;
    const uint32_t tw = job->x1 - job->x0;
    const uint32_t npix = tw * (job->y1 - job->y0);
    float values[8][VBNL_FILM_MAX_CHANNELS];
    for (uint32_t s = job->sample_begin; s < job->sample_end; ++s) {
        for (uint32_t base = 0; base < npix; base += 8) {
            int active[8];
            vec3 o[8], d[8];
            vbnl_hit hits[8];
            int hit_mask[8];
            vbnl_rng rng[8];
            uint32_t px[8], py[8];
            for (int i = 0; i < 8; ++i) {
                uint32_t k = base + (uint32_t)i;
                active[i] = k < npix;
                if (!active[i]) {
                    o[i] = d[i] = v3s(0.0f);
                    continue;
                }
                px[i] = job->x0 + k % tw;
                py[i] = job->y0 + k / tw;
                rng[i] = vbnl_pixel_rng(job, px[i], py[i], s);
                vec2 u = vbnl_rng_next2(&rng[i]); /* box filter: uniform over the pixel */
                vbnl_camera_ray(&sc->camera, job->width, job->height, (float)px[i] + u.x,
                                (float)py[i] + u.y, &o[i], &d[i]);
            }
            vbnl_scene_intersect8(sc, active, o, d, hits, hit_mask);
            for (int i = 0; i < 8; ++i) {
                if (!active[i])
                    continue;
                job->stats->rays++;
                memset(values[i], 0, sizeof(float) * ps->stride);
                trace(ps, &rng[i], o[i], d[i], hit_mask[i], hits[i], values[i], job->stats);
                vbnl_film_add(job->film, px[i], py[i], values[i]);
            }
        }
    }
}

const vbnl_integrator_class vbnl_integrator_path = {
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
