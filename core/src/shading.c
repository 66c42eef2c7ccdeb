#include "shading.h"

#include <string.h>

void vbnl_render_camera_paths(vbnl_tile_job *job, uint32_t stride, vbnl_camera_path_fn fn, void *state)
{
    const vbnl_scene *sc = job->scene;
    const uint32_t tw = job->x1 - job->x0;
    const uint32_t npix = tw * (job->y1 - job->y0);
    float values[8][VBNL_FILM_MAX_CHANNELS];
    for (uint32_t smp = job->sample_begin; smp < job->sample_end; ++smp) {
        for (uint32_t base = 0; base < npix; base += 8) {
            int active[8], hit_mask[8];
            vec3 o[8], d[8];
            vbnl_hit hits[8];
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
                rng[i] = vbnl_pixel_rng(job, px[i], py[i], smp);
                vec2 u = vbnl_rng_next2(&rng[i]);
                vbnl_camera_ray(&sc->camera, job->width, job->height, (float)px[i] + u.x, (float)py[i] + u.y,
                                &o[i], &d[i]);
            }
            vbnl_scene_intersect8(sc, active, o, d, hits, hit_mask);
            for (int i = 0; i < 8; ++i) {
                if (!active[i])
                    continue;
                job->stats->rays++;
                memset(values[i], 0, sizeof(float) * stride);
                fn(state, &rng[i], o[i], d[i], hit_mask[i], &hits[i], values[i], job->stats);
                vbnl_film_add(job->film, px[i], py[i], values[i]);
            }
        }
    }
}

void vbnl_shading_frame_make(const vbnl_bsdf *bsdf, const vbnl_hit *hit, vec3 d, vbnl_shading_frame *sf)
{
    vec3 wo_w = v3_neg(d), ng = hit->ng, ns = hit->ns;
    if (!vbnl_bsdf_is_transmissive(bsdf)) {
        if (v3_dot(ng, wo_w) < 0.0f) {
            ng = v3_neg(ng);
            ns = v3_neg(ns);
        }
        if (v3_dot(ns, wo_w) <= 0.0f)
            ns = ng;
    }
    sf->fr = frame_from_normal(ns);
    sf->ng = ng;
    sf->wo = frame_to_local(&sf->fr, wo_w);
}

vec3 vbnl_estimate_direct(const vbnl_scene *sc, const vbnl_bsdf *bsdf, vec3 x, const vbnl_shading_frame *sf,
                          vbnl_rng *rng, vbnl_thread_stats *stats)
{
    float pmf;
    uint32_t li = vbnl_scene_pick_light(sc, vbnl_rng_next(rng), &pmf);
    vbnl_light_li_sample ls;
    vec2 ul = vbnl_rng_next2(rng);
    if (!vbnl_light_sample_li(&sc->lights[li], x, ul, &ls) || !(ls.pdf > 0.0f) || v3_is_black(ls.Li))
        return v3s(0.0f);
    vec3 wi = frame_to_local(&sf->fr, ls.wi);
    vec3 f = vbnl_bsdf_eval(bsdf, sf->wo, wi);
    /* no light through the geometric back of an opaque surface */
    int side_ok = vbnl_bsdf_is_transmissive(bsdf) || v3_dot(ls.wi, sf->ng) > 0.0f;
    if (!side_ok || v3_is_black(f))
        return v3s(0.0f);
    vec3 org = vbnl_offset_ray_origin(x, sf->ng, ls.wi);
    float tmax = isinf(ls.dist) ? INFINITY : ls.dist * (1.0f - 1e-4f);
    stats->rays++;
    if (vbnl_scene_occluded(sc, org, ls.wi, tmax))
        return v3s(0.0f);
    float w = ls.is_delta ? 1.0f : power_heuristic(pmf * ls.pdf, vbnl_bsdf_pdf(bsdf, sf->wo, wi));
    return v3_scale(v3_mul(f, ls.Li), w / (pmf * ls.pdf));
}

float vbnl_arriving_light(const vbnl_scene *sc, int hit_ok, const vbnl_hit *y, vec3 x, vec3 w, float pdf_bsdf,
                          int specular, vec3 *Le)
{
    const vbnl_light *l;
    float pl;
    *Le = v3s(0.0f);
    if (!hit_ok) {
        if (sc->env_light == VBNL_NO_LIGHT)
            return 0.0f;
        l = &sc->lights[sc->env_light];
        *Le = vbnl_light_Le(l, v3s(0.0f), v3_neg(w));
        pl = vbnl_scene_light_pmf(sc, sc->env_light) * vbnl_light_pdf_li(l, x, v3s(0.0f), v3s(0.0f), w);
    } else {
        if (y->light == VBNL_NO_LIGHT)
            return 0.0f;
        l = &sc->lights[y->light];
        *Le = vbnl_light_Le(l, y->ng, v3_neg(w));
        if (v3_is_black(*Le))
            return 0.0f;
        pl = vbnl_scene_light_pmf(sc, y->light) * vbnl_light_pdf_li(l, x, y->p, y->ng, w);
    }
    return specular ? 1.0f : power_heuristic(pdf_bsdf, pl);
}
