/* What every integrator's paths and connections meet between scattering vertices: media, fog,
 * surfaces that let light through unchanged in direction, no_shadow geometry (shading.h).
 *
 * A path is the integrator's up to the next surface that scatters; between two of its vertices
 * the walk follows the ray through regions and pass-through surfaces, and when the path scatters
 * in a medium, the walk shades that point as a path tracer does: next-event estimation of the
 * real lights with the phase function, combined by the power heuristic with phase sampling,
 * which also continues the path. The integrator sees only the surface the walk reaches, with the
 * throughput the way there leaves. Connections (shadow rays, connections to virtual lights) get
 * vbnl_shadow_transmittance: the same crossings and the media's transmittance. */
#include <math.h>
#include <string.h>

#include "shading.h"

/* Crossings followed along one ray before it counts as blocked (a ray trapped between coincident
 * pass-through faces). */
#define VBNL_MAX_CROSSINGS 64

/* The BSDF at a hit if it may let light through unchanged (material.may_pass), else NULL. */
static const vbnl_bsdf *null_bsdf(const vbnl_scene *sc, const vbnl_hit *h, vbnl_bsdf *store)
{
    if (!sc->materials[h->material].may_pass)
        return NULL;
    const vbnl_bsdf *b = vbnl_surface_bsdf(sc, h, store);
    return vbnl_bsdf_is_null(b) ? b : NULL;
}

vec3 vbnl_shadow_transmittance(const vbnl_scene *sc, const vbnl_medium_stack *media, vec3 org, vec3 dir, float tmax,
                               vbnl_rand *r, vbnl_thread_stats *stats, int *nee_only)
{
    const uint32_t mask = sc->has_masks ? VBNL_RAY_SHADOW : VBNL_RAY_ANY;
    vbnl_medium_stack st;
    if (media)
        st = *media;
    else
        vbnl_medium_stack_init(&st);
    const vec3 org0 = org;
    const float tmax0 = tmax;
    vec3 T = v3s(1.0f);
    for (int k = 0;; ++k) {
        stats->rays++;
        stats->shadow_rays++;
        vbnl_hit h;
        int hit_ok;
        if (!sc->has_null) {
            if (vbnl_scene_occluded_mask(sc, org, dir, tmax, mask))
                return v3s(0.0f);
            hit_ok = 0;
        } else {
            hit_ok = vbnl_scene_intersect_mask(sc, org, dir, tmax, mask, &h);
        }
        const uint32_t region = vbnl_medium_region(&st);
        if (!hit_ok) {
            if (!vbnl_region_is_empty(sc, region))
                T = v3_mul(T, vbnl_medium_transmittance(sc, region, org, dir, tmax, r));
            break;
        }
        vbnl_bsdf store;
        const vbnl_bsdf *b = null_bsdf(sc, &h, &store);
        if (!b || k >= VBNL_MAX_CROSSINGS)
            return v3s(0.0f);
        if (!vbnl_region_is_empty(sc, region))
            T = v3_mul(T, vbnl_medium_transmittance(sc, region, org, dir, h.t, r));
        T = v3_mul(T, b->color);
        if (vbnl_is_black(T))
            return T;
        vbnl_medium_cross(sc, &st, h.material, h.ng, dir);
        org = vbnl_offset_ray_origin(h.p, h.ng, dir);
        tmax = isinf(tmax) ? tmax : tmax - h.t;
        if (!(tmax > 0.0f))
            break;
    }
    /* no_shadow geometry on the way: only next-event estimation finds this light */
    if (nee_only && sc->has_masks && !*nee_only) {
        stats->rays++;
        *nee_only = vbnl_scene_occluded_mask(sc, org0, dir, tmax0, VBNL_RAY_NO_SHADOW_PROBE);
    }
    return T;
}

vec3 vbnl_estimate_direct_medium(const vbnl_scene *sc, const vbnl_medium_stack *media, vec3 p, vec3 out,
                                 vbnl_phase_kind kind, float g, vbnl_sampler *sp, vbnl_thread_stats *stats)
{
    float pmf;
    vec2 ul = vbnl_sampler_next2(sp);
    uint32_t li = vbnl_scene_pick_light_reuse(sc, ul.x, &pmf, &ul.x);
    vbnl_light_li_sample ls;
    if (!vbnl_light_sample_li(&sc->lights[li], p, ul, &ls) || !(ls.pdf > 0.0f) || vbnl_is_black(ls.Li))
        return v3s(0.0f);
    /* light travels along -wi, then along `out` */
    const float ph = vbnl_phase_eval(kind, g, -v3_dot(ls.wi, out));
    if (!(ph > 0.0f))
        return v3s(0.0f);
    vec3 dir;
    float tmax;
    if (!vbnl_shadow_segment(&ls, p, &dir, &tmax))
        return v3s(0.0f);
    const vbnl_light *light = &sc->lights[li];
    int nee_only = ls.is_delta || light->shadowless;
    vec3 T = v3s(1.0f);
    if (!light->shadowless) {
        vbnl_rand r = {sp, NULL};
        T = vbnl_shadow_transmittance(sc, media, p, dir, tmax, &r, stats, &nee_only);
        if (vbnl_is_black(T))
            return T;
    }
    float w = nee_only ? 1.0f : power_heuristic(pmf * ls.pdf, ph);
    return v3_scale(v3_mul(ls.Li, T), ph * w / (pmf * ls.pdf));
}

void vbnl_walk_init(vbnl_walk *w, const vbnl_scene *sc, vbnl_sampler *sp, vbnl_thread_stats *stats, int max_depth,
                    int rr_depth, vbnl_walk_add_fn add, void *user)
{
    w->sc = sc;
    w->sp = sp;
    w->stats = stats;
    w->max_depth = max_depth;
    w->rr_depth = rr_depth;
    w->add = add;
    w->user = user;
    vbnl_medium_stack_init(&w->media);
    w->beta = v3s(1.0f);
    w->depth = 0;
}

static void walk_add(vbnl_walk *w, vec3 c, int is_direct)
{
    if (!vbnl_is_black(c) && vbnl_is_finite(c))
        w->add(w->user, c, is_direct);
}

int vbnl_walk_next(vbnl_walk *w, vec3 o, vec3 *d, uint32_t mask, vec3 x, float pdf, int specular, int seg_direct,
                   const vbnl_hit *known, vbnl_hit *hit, int *scattered)
{
    const vbnl_scene *sc = w->sc;
    *scattered = 0;
    vec3 dir = *d;
    for (int crossings = 0;;) {
        int hit_ok;
        if (known) {
            hit_ok = 1;
            *hit = *known;
            known = NULL;
        } else {
            w->stats->rays++;
            hit_ok = vbnl_scene_intersect_mask(sc, o, dir, INFINITY, mask, hit);
        }
        const uint32_t region = vbnl_medium_region(&w->media);
        if (sc->has_media && !vbnl_region_is_empty(sc, region)) {
            vbnl_rand r = {w->sp, NULL};
            vec3 L = v3s(0.0f);
            vbnl_medium_event ev;
            int rc = vbnl_medium_track(sc, region, o, dir, hit_ok ? hit->t : INFINITY, &r, &w->beta, &L, &ev);
            walk_add(w, L, seg_direct);
            if (rc == VBNL_TRACK_ABSORBED)
                return VBNL_WALK_ENDED;
            if (rc == VBNL_TRACK_SCATTERED) {
                /* a vertex of the path in the medium */
                if (w->max_depth >= 0 && w->depth >= w->max_depth)
                    return VBNL_WALK_ENDED;
                w->depth++;
                const int vertex_direct = specular && seg_direct; /* no non-delta vertex before it */
                walk_add(w,
                         v3_mul(w->beta, vbnl_estimate_direct_medium(sc, &w->media, ev.p, v3_neg(dir), ev.phase, ev.g,
                                                                     w->sp, w->stats)),
                         vertex_direct);
                float ppdf;
                vec3 nd = vbnl_phase_sample(ev.phase, ev.g, dir, vbnl_sampler_next2(w->sp), &ppdf);
                if (!(ppdf > 0.0f))
                    return VBNL_WALK_ENDED;
                /* the phase function's sample weight is 1 */
                if (w->depth > w->rr_depth) {
                    float q = maxf(0.05f, 1.0f - v3_max_comp(w->beta));
                    if (vbnl_sampler_next(w->sp) < q)
                        return VBNL_WALK_ENDED;
                    w->beta = v3_scale(w->beta, 1.0f / (1.0f - q));
                }
                if (!vbnl_is_finite(w->beta))
                    return VBNL_WALK_ENDED;
                *scattered = 1;
                x = o = ev.p;
                dir = nd;
                pdf = ppdf;
                specular = 0;
                seg_direct = vertex_direct;
                mask = sc->has_masks ? VBNL_RAY_OTHER : VBNL_RAY_ANY;
                continue;
            }
        }
        *d = dir;
        if (!hit_ok) {
            if (*scattered) {
                vec3 Le;
                float mw = vbnl_arriving_light(sc, 0, hit, x, dir, pdf, specular, &Le);
                if (mw > 0.0f)
                    walk_add(w, v3_scale(v3_mul(w->beta, Le), mw), seg_direct);
            }
            return VBNL_WALK_ESCAPED;
        }
        vbnl_bsdf store;
        const vbnl_bsdf *b = sc->has_null ? null_bsdf(sc, hit, &store) : NULL;
        if (b && crossings++ < VBNL_MAX_CROSSINGS) {
            /* straight through: the tint, and the region on the other side */
            w->beta = v3_mul(w->beta, b->color);
            if (vbnl_is_black(w->beta))
                return VBNL_WALK_ENDED;
            if (sc->has_media)
                vbnl_medium_cross(sc, &w->media, hit->material, hit->ng, dir);
            o = vbnl_offset_ray_origin(hit->p, hit->ng, dir);
            continue;
        }
        if (*scattered) {
            vec3 Le;
            float mw = vbnl_arriving_light(sc, 1, hit, x, dir, pdf, specular, &Le);
            if (mw > 0.0f)
                walk_add(w, v3_scale(v3_mul(w->beta, Le), mw), seg_direct);
        }
        return VBNL_WALK_SURFACE;
    }
}

float vbnl_camera_alpha(const vbnl_scene *sc, vec3 o, vec3 d, int hit_ok, const vbnl_hit *first, vbnl_sampler *sp)
{
    const uint32_t mask = sc->has_masks ? VBNL_RAY_CAMERA : VBNL_RAY_ANY;
    vbnl_medium_stack st;
    vbnl_medium_stack_init(&st);
    vbnl_rand r = {sp, NULL};
    float T = 1.0f; /* the greyscale of what passes, as POV-Ray's transm */
    vbnl_hit h;
    if (hit_ok)
        h = *first;
    for (int k = 0; k < VBNL_MAX_CROSSINGS; ++k) {
        const uint32_t region = vbnl_medium_region(&st);
        if (sc->has_media && !vbnl_region_is_empty(sc, region))
            T *= v3_avg(vbnl_medium_transmittance(sc, region, o, d, hit_ok ? h.t : INFINITY, &r));
        if (!hit_ok)
            return 1.0f - T * (1.0f - sc->background_alpha);
        const scene_material *m = &sc->materials[h.material];
        if (!(T > 0.0f) || (!vbnl_bsdf_is_transmissive(&m->bsdf) && !m->may_pass && !m->varies))
            return 1.0f;
        vbnl_bsdf store;
        const vbnl_bsdf *b = vbnl_surface_bsdf(sc, &h, &store);
        if (!vbnl_bsdf_is_transmissive(b))
            return 1.0f;
        /* what the surface lets through along its refracted (or straight) direction */
        vbnl_shading_frame sf;
        vbnl_shading_frame_make(b, &h, d, &sf);
        float cos_o = sf.wo.z, F = vbnl_fresnel_dielectric(cos_o, b->ior);
        float eta = cos_o > 0.0f ? b->ior : 1.0f / b->ior, sin2_t = (1.0f - cos_o * cos_o) / (eta * eta);
        if (sin2_t >= 1.0f)
            return 1.0f;
        float cos_t = sqrtf(1.0f - sin2_t);
        vec3 wt = frame_to_world(&sf.fr, v3(-sf.wo.x / eta, -sf.wo.y / eta, cos_o > 0.0f ? -cos_t : cos_t));
        T *= (1.0f - F) * v3_avg(b->color);
        if (sc->has_media)
            vbnl_medium_cross(sc, &st, h.material, h.ng, wt);
        o = vbnl_offset_ray_origin(h.p, h.ng, wt);
        d = v3_norm(wt);
        hit_ok = vbnl_scene_intersect_mask(sc, o, d, INFINITY, mask, &h);
    }
    return 1.0f;
}

/* The ray mask of a path's next segment after a BSDF sample of lobe `lobe`. */
static uint32_t segment_mask(const vbnl_scene *sc, uint32_t lobe)
{
    if (!sc->has_masks)
        return VBNL_RAY_ANY;
    return (lobe & VBNL_LOBE_SPECULAR) && !(lobe & VBNL_LOBE_TRANSMISSION) ? VBNL_RAY_REFLECTED : VBNL_RAY_OTHER;
}

void vbnl_trace_path_walk(const vbnl_scene *sc, vbnl_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbnl_hit *first,
                          int max_depth, int rr_depth, vbnl_walk_add_fn add, void *user, float *aov,
                          vbnl_thread_stats *stats)
{
    vbnl_walk w;
    vbnl_walk_init(&w, sc, sp, stats, max_depth, rr_depth, add, user);
    vbnl_hit hit;
    int scattered;
    /* the camera ray: its first hit is known; an escaped camera ray is traced again (the walk
     * needs the segment's end) */
    int rc = vbnl_walk_next(&w, o, &d, sc->has_masks ? VBNL_RAY_CAMERA : VBNL_RAY_ANY, o, 1.0f, 1, 1,
                            hit_ok ? first : NULL, &hit, &scattered);
    if (rc == VBNL_WALK_ENDED)
        return;
    if (rc == VBNL_WALK_ESCAPED) {
        if (!scattered && sc->env_light != VBNL_NO_LIGHT)
            walk_add(&w, v3_mul(w.beta, vbnl_light_Le(&sc->lights[sc->env_light], v3s(0.0f), v3_neg(d))), 1);
        return;
    }
    vbnl_bsdf bsdf_store;
    const vbnl_bsdf *bsdf = vbnl_surface_bsdf(sc, &hit, &bsdf_store);
    if (aov && !scattered) {
        v3_store(aov + VBNL_FILM_ALBEDO, bsdf->type == VBNL_MATERIAL_CONDUCTOR ? vbnl_bsdf_albedo(bsdf) : bsdf->color);
        v3_store(aov + VBNL_FILM_NORMAL, hit.ns);
    }
    if (!scattered && hit.light != VBNL_NO_LIGHT)
        walk_add(&w, v3_mul(w.beta, vbnl_light_Le(&sc->lights[hit.light], hit.ng, v3_neg(d))), 1);
    int direct = !scattered; /* no non-delta vertex yet */
    for (;;) {
        const int depth = w.depth;
        if (max_depth >= 0 && depth >= max_depth)
            break;
        const int vertex_direct = direct;
        if (!vbnl_bsdf_is_delta(bsdf))
            direct = 0;
        vbnl_shading_frame sf;
        vbnl_shading_frame_make(bsdf, &hit, d, &sf);
        const vec3 x = hit.p;
        if (!vbnl_bsdf_is_delta(bsdf))
            walk_add(&w, v3_mul(w.beta, vbnl_estimate_direct_in(sc, &w.media, bsdf, x, &sf, sp, stats)),
                     vertex_direct);
        vbnl_bsdf_sample_rec bs;
        vec2 ub = vbnl_sampler_next2(sp);
        if (!vbnl_bsdf_sample(bsdf, sf.wo, ub, &bs) || vbnl_is_black(bs.weight))
            break;
        vec3 wd = frame_to_world(&sf.fr, bs.wi);
        if (!(bs.lobe & VBNL_LOBE_TRANSMISSION) && v3_dot(wd, sf.ng) <= 0.0f)
            break;
        w.beta = v3_mul(w.beta, bs.weight);
        if (bs.lobe & VBNL_LOBE_TRANSMISSION) {
            o = vbnl_offset_ray_origin(x, hit.ng, wd);
            if (sc->has_media)
                vbnl_medium_cross(sc, &w.media, hit.material, hit.ng, wd);
        } else {
            o = vbnl_offset_ray_origin_along(x, sf.ng);
        }
        d = wd;
        w.depth = depth + 1;
        const int specular = (bs.lobe & VBNL_LOBE_SPECULAR) != 0;
        rc = vbnl_walk_next(&w, o, &d, segment_mask(sc, bs.lobe), x, bs.pdf, specular, vertex_direct, NULL, &hit,
                            &scattered);
        if (scattered)
            direct = 0;
        if (rc == VBNL_WALK_ENDED)
            break;
        if (!scattered) {
            /* light arriving along the sample, MIS-weighted against the next-event estimate at x */
            vec3 Le;
            float mw = vbnl_arriving_light(sc, rc == VBNL_WALK_SURFACE, &hit, x, d, bs.pdf, specular, &Le);
            if (mw > 0.0f)
                walk_add(&w, v3_scale(v3_mul(w.beta, Le), mw), vertex_direct);
        }
        if (rc == VBNL_WALK_ESCAPED)
            break;
        if (depth >= rr_depth) {
            float q = maxf(0.05f, 1.0f - v3_max_comp(w.beta));
            if (vbnl_sampler_next(sp) < q)
                break;
            w.beta = v3_scale(w.beta, 1.0f / (1.0f - q));
        }
        if (!vbnl_is_finite(w.beta))
            break;
        bsdf = vbnl_surface_bsdf(sc, &hit, &bsdf_store);
    }
}
