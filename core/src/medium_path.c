/* What every integrator's paths and connections meet between scattering vertices: media, fog,
 * surfaces that let light through unchanged in direction, no_shadow geometry (shading.h).
 *
 * A path is the integrator's up to the next surface that scatters; between two of its vertices
 * the walk follows the ray through regions and pass-through surfaces, and when the path scatters
 * in a medium, the walk shades that point as a path tracer does: next-event estimation of the
 * real lights with the phase function, combined by the power heuristic with phase sampling,
 * which also continues the path; point and spot lights are estimated along each segment by
 * equiangular sampling instead. The integrator sees only the surface the walk reaches, with the
 * throughput the way there leaves. Connections (shadow rays, connections to virtual lights) get
 * vbi_shadow_transmittance: the same crossings and the media's transmittance. */
#include <math.h>
#include <string.h>

#include "shading.h"

/* Crossings followed along one ray before it counts as blocked (a ray trapped between coincident
 * pass-through faces). */
#define VBI_MAX_CROSSINGS 64

/* The BSDF at a hit if it lets light through unchanged (material.may_pass), else NULL; with
 * `reflecting`, also a dielectric of ior 1 with a reflectance curve (vbi_bsdf_passes_straight). */
static const vbi_bsdf *null_bsdf(const vbnl_scene *sc, const vbi_hit *h, vbi_bsdf *store, int reflecting)
{
    if (!sc->materials[h->material].may_pass)
        return NULL;
    const vbi_bsdf *b = vbi_surface_bsdf(sc, h, store);
    return (reflecting ? vbi_bsdf_passes_straight(b) : vbi_bsdf_is_null(b)) ? b : NULL;
}

vec3 vbi_shadow_transmittance(const vbnl_scene *sc, const vbi_medium_stack *media, vec3 org, vec3 dir, float tmax,
                               vbi_rand *r, vbi_thread_stats *stats, int *nee_only)
{
    const uint32_t mask = sc->has_masks ? VBI_RAY_SHADOW : VBI_RAY_ANY;
    vbi_medium_stack st;
    if (media)
        st = *media;
    else
        vbi_medium_stack_init(&st);
    const vec3 org0 = org;
    const float tmax0 = tmax;
    const int delta = nee_only && *nee_only; /* a point, spot or directional light */
    vec3 T = v3s(1.0f);
    for (int k = 0;; ++k) {
        stats->rays++;
        stats->shadow_rays++;
        vbi_hit h;
        int hit_ok;
        if (!sc->has_null) {
            if (vbi_scene_occluded_mask(sc, org, dir, tmax, mask))
                return v3s(0.0f);
            hit_ok = 0;
        } else {
            hit_ok = vbi_scene_intersect_mask(sc, org, dir, tmax, mask, &h);
        }
        const uint32_t region = vbi_medium_region(&st);
        if (!hit_ok) {
            if (!vbi_region_is_empty(sc, region))
                T = v3_mul(T, vbi_medium_transmittance(sc, region, org, dir, tmax, r));
            break;
        }
        vbi_bsdf store;
        const vbi_bsdf *b = null_bsdf(sc, &h, &store, delta);
        if (!b || k >= VBI_MAX_CROSSINGS)
            return v3s(0.0f);
        if (!vbi_region_is_empty(sc, region))
            T = v3_mul(T, vbi_medium_transmittance(sc, region, org, dir, h.t, r));
        T = v3_mul(T, vbi_bsdf_pass_weight(b, v3_dot(dir, h.ns)));
        if (vbi_is_black(T))
            return T;
        vbi_medium_cross(sc, &st, h.material, h.ng, dir);
        org = vbi_offset_ray_origin(h.p, h.ng, dir);
        tmax = isinf(tmax) ? tmax : tmax - h.t;
        if (!(tmax > 0.0f))
            break;
    }
    /* no_shadow geometry on the way: only next-event estimation finds this light */
    if (nee_only && sc->has_masks && !*nee_only) {
        stats->rays++;
        *nee_only = vbi_scene_occluded_mask(sc, org0, dir, tmax0, VBI_RAY_NO_SHADOW_PROBE);
    }
    return T;
}

/* Point and spot lights: their light scattered once in a medium is estimated along the whole
 * segment a path travels in it, not at the points delta tracking stops at. */
static int is_point_light(const vbi_light *l) { return l->type == VBI_LIGHT_POINT || l->type == VBI_LIGHT_SPOT; }

/* The light of a point or spot light scattered once toward the path along its segment o + t d,
 * t in (0, tmax), in `region` (a scattering medium), by equiangular sampling (Kulla and Fajardo
 * 2012, "Importance Sampling Techniques for Path Tracing in Participating Media", Sec. 4): t is
 * drawn with a pdf proportional to 1 / (distance to the light)^2, so the light's 1/r^2 peak, which
 * distances drawn by the medium's density meet rarely and then as a spike, is sampled where it
 * lies. The estimate is T(0, t) sigma_s phase Li T_shadow / (pdf(t) pmf); the vertex estimate of
 * vbi_estimate_direct_medium leaves these lights out, so each is counted once (no MIS is needed:
 * phase sampling never reaches a point light). A segment that escapes ends at the scene's far
 * bound, as the media's tracking takes it. */
static vec3 equiangular_direct(const vbnl_scene *sc, const vbi_medium_stack *media, uint32_t region, vec3 o, vec3 d,
                               float tmax, vbi_sampler *sp, vbi_thread_stats *stats)
{
    float pmf;
    vec2 u = vbi_sampler_next2(sp);
    const uint32_t li = vbi_scene_pick_light_reuse(sc, u.x, &pmf, &u.x);
    const vbi_light *light = &sc->lights[li];
    if (!is_point_light(light) || light->no_media || !(pmf > 0.0f))
        return v3s(0.0f);
    const float tend = isinf(tmax) ? sc->far_bound : tmax;
    const vec3 lo = v3_sub(light->p, o);
    const float along = v3_dot(lo, d);                              /* the closest approach's t */
    const float D = maxf(v3_len(v3_sub(lo, v3_scale(d, along))), 1e-6f * (1.0f + fabsf(along)));
    const float ta = atan2f(-along, D), tb = atan2f(tend - along, D);
    if (!(tb > ta))
        return v3s(0.0f);
    const float t = along + D * tanf(ta + u.y * (tb - ta));
    if (!(t > 0.0f && t < tend))
        return v3s(0.0f);
    const float x = t - along;
    const float pdf = D / ((tb - ta) * (D * D + x * x));
    const vec3 p = v3_fma(o, d, t);
    vbi_light_li_sample ls;
    if (!vbi_light_sample_li(light, p, (vec2){0.5f, 0.5f}, &ls) || vbi_is_black(ls.Li))
        return v3s(0.0f);
    /* light travels along -wi, then back along -d */
    const vec3 f = vbi_medium_inscatter(sc, region, p, v3_dot(ls.wi, d));
    if (vbi_is_black(f))
        return f;
    vbi_rand r = {sp, NULL};
    vec3 T = vbi_medium_transmittance(sc, region, o, d, t, &r);
    if (!light->shadowless && !vbi_is_black(T)) {
        vec3 sdir;
        float stmax;
        if (!vbi_shadow_segment(&ls, p, &sdir, &stmax))
            return v3s(0.0f);
        int delta = 1;
        T = v3_mul(T, vbi_shadow_transmittance(sc, media, p, sdir, stmax, &r, stats, &delta));
    }
    return v3_scale(v3_mul(v3_mul(ls.Li, f), T), 1.0f / (pdf * pmf));
}

vec3 vbi_estimate_direct_medium(const vbnl_scene *sc, const vbi_medium_stack *media, vec3 p, vec3 out,
                                 vbnl_phase_kind kind, float g, vbi_sampler *sp, vbi_thread_stats *stats)
{
    float pmf;
    vec2 ul = vbi_sampler_next2(sp);
    uint32_t li = vbi_scene_pick_light_reuse(sc, ul.x, &pmf, &ul.x);
    if (is_point_light(&sc->lights[li]) || sc->lights[li].no_media)
        return v3s(0.0f); /* equiangular_direct estimates it along the segment; or media ignore it */
    vbi_light_li_sample ls;
    if (!vbi_light_sample_li(&sc->lights[li], p, ul, &ls) || !(ls.pdf > 0.0f) || vbi_is_black(ls.Li))
        return v3s(0.0f);
    /* light travels along -wi, then along `out` */
    const float ph = vbi_phase_eval(kind, g, -v3_dot(ls.wi, out));
    if (!(ph > 0.0f))
        return v3s(0.0f);
    vec3 dir;
    float tmax;
    if (!vbi_shadow_segment(&ls, p, &dir, &tmax))
        return v3s(0.0f);
    const vbi_light *light = &sc->lights[li];
    int nee_only = ls.is_delta || light->shadowless;
    vec3 T = v3s(1.0f);
    if (!light->shadowless) {
        vbi_rand r = {sp, NULL};
        T = vbi_shadow_transmittance(sc, media, p, dir, tmax, &r, stats, &nee_only);
        if (vbi_is_black(T))
            return T;
    }
    float w = nee_only ? 1.0f : power_heuristic(pmf * ls.pdf, ph);
    return v3_scale(v3_mul(ls.Li, T), ph * w / (pmf * ls.pdf));
}

void vbi_walk_init(vbi_walk *w, const vbnl_scene *sc, vbi_sampler *sp, vbi_thread_stats *stats, int max_depth,
                    int rr_depth, vbi_walk_add_fn add, void *user)
{
    w->sc = sc;
    w->sp = sp;
    w->stats = stats;
    w->max_depth = max_depth;
    w->rr_depth = rr_depth;
    w->add = add;
    w->user = user;
    vbi_medium_stack_init(&w->media);
    w->beta = v3s(1.0f);
    w->depth = 0;
}

static void walk_add(vbi_walk *w, vec3 c, int is_direct)
{
    if (!vbi_is_black(c) && vbi_is_finite(c))
        w->add(w->user, c, is_direct);
}

int vbi_walk_next(vbi_walk *w, vec3 o, vec3 *d, uint32_t mask, vec3 x, float pdf, int specular, int seg_direct,
                   const vbi_hit *known, vbi_hit *hit, int *scattered)
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
            hit_ok = vbi_scene_intersect_mask(sc, o, dir, INFINITY, mask, hit);
        }
        const uint32_t region = vbi_medium_region(&w->media);
        if (sc->has_media && !vbi_region_is_empty(sc, region)) {
            if (vbi_region_scatters(sc, region) && (w->max_depth < 0 || w->depth < w->max_depth))
                walk_add(w,
                         v3_mul(w->beta, equiangular_direct(sc, &w->media, region, o, dir, hit_ok ? hit->t : INFINITY,
                                                            w->sp, w->stats)),
                         specular && seg_direct);
            vbi_rand r = {w->sp, NULL};
            vec3 L = v3s(0.0f);
            vbi_medium_event ev;
            int rc = vbi_medium_track(sc, region, o, dir, hit_ok ? hit->t : INFINITY, &r, &w->beta, &L, &ev);
            walk_add(w, L, seg_direct);
            if (rc == VBI_TRACK_ABSORBED)
                return VBI_WALK_ENDED;
            if (rc == VBI_TRACK_SCATTERED) {
                /* a vertex of the path in the medium */
                if (w->max_depth >= 0 && w->depth >= w->max_depth)
                    return VBI_WALK_ENDED;
                w->depth++;
                const int vertex_direct = specular && seg_direct; /* no non-delta vertex before it */
                walk_add(w,
                         v3_mul(w->beta, vbi_estimate_direct_medium(sc, &w->media, ev.p, v3_neg(dir), ev.phase, ev.g,
                                                                     w->sp, w->stats)),
                         vertex_direct);
                float ppdf;
                vec3 nd = vbi_phase_sample(ev.phase, ev.g, dir, vbi_sampler_next2(w->sp), &ppdf);
                if (!(ppdf > 0.0f))
                    return VBI_WALK_ENDED;
                /* the phase function's sample weight is 1 */
                if (w->depth > w->rr_depth) {
                    float q = maxf(0.05f, 1.0f - v3_max_comp(w->beta));
                    if (vbi_sampler_next(w->sp) < q)
                        return VBI_WALK_ENDED;
                    w->beta = v3_scale(w->beta, 1.0f / (1.0f - q));
                }
                if (!vbi_is_finite(w->beta))
                    return VBI_WALK_ENDED;
                *scattered = 1;
                x = o = ev.p;
                dir = nd;
                pdf = ppdf;
                specular = 0;
                seg_direct = vertex_direct;
                mask = sc->has_masks ? VBI_RAY_OTHER : VBI_RAY_ANY;
                continue;
            }
        }
        *d = dir;
        if (!hit_ok) {
            if (*scattered) {
                vec3 Le;
                float mw = vbi_arriving_light(sc, 0, hit, x, dir, pdf, specular, &Le);
                if (mw > 0.0f)
                    walk_add(w, v3_scale(v3_mul(w->beta, Le), mw), seg_direct);
            }
            return VBI_WALK_ESCAPED;
        }
        vbi_bsdf store;
        const vbi_bsdf *b = sc->has_null ? null_bsdf(sc, hit, &store, 0) : NULL;
        if (b && crossings++ < VBI_MAX_CROSSINGS) {
            /* straight through: the tint, and the region on the other side */
            w->beta = v3_mul(w->beta, b->color);
            if (vbi_is_black(w->beta))
                return VBI_WALK_ENDED;
            if (sc->has_media)
                vbi_medium_cross(sc, &w->media, hit->material, hit->ng, dir);
            o = vbi_offset_ray_origin(hit->p, hit->ng, dir);
            continue;
        }
        if (*scattered) {
            vec3 Le;
            float mw = vbi_arriving_light(sc, 1, hit, x, dir, pdf, specular, &Le);
            if (mw > 0.0f)
                walk_add(w, v3_scale(v3_mul(w->beta, Le), mw), seg_direct);
        }
        return VBI_WALK_SURFACE;
    }
}

float vbi_camera_alpha(const vbnl_scene *sc, vec3 o, vec3 d, int hit_ok, const vbi_hit *first, vbi_sampler *sp)
{
    const uint32_t mask = sc->has_masks ? VBI_RAY_CAMERA : VBI_RAY_ANY;
    vbi_medium_stack st;
    vbi_medium_stack_init(&st);
    vbi_rand r = {sp, NULL};
    float T = 1.0f; /* the greyscale of what passes, as POV-Ray's transm */
    vbi_hit h;
    if (hit_ok)
        h = *first;
    for (int k = 0; k < VBI_MAX_CROSSINGS; ++k) {
        const uint32_t region = vbi_medium_region(&st);
        if (sc->has_media && !vbi_region_is_empty(sc, region))
            T *= v3_avg(vbi_medium_transmittance(sc, region, o, d, hit_ok ? h.t : INFINITY, &r));
        if (!hit_ok)
            return 1.0f - T * (1.0f - sc->background_alpha);
        const scene_material *m = &sc->materials[h.material];
        if (!(T > 0.0f) || (!vbi_bsdf_is_transmissive(&m->bsdf) && !m->may_pass && !m->varies))
            return 1.0f;
        vbi_bsdf store;
        const vbi_bsdf *b = vbi_surface_bsdf(sc, &h, &store);
        if (!vbi_bsdf_is_transmissive(b))
            return 1.0f;
        /* what the surface lets through along its refracted (or straight) direction */
        vbi_shading_frame sf;
        vbi_shading_frame_make(b, &h, d, &sf);
        float cos_o = sf.wo.z, F = vbi_fresnel_dielectric(cos_o, b->ior);
        float eta = cos_o > 0.0f ? b->ior : 1.0f / b->ior, sin2_t = (1.0f - cos_o * cos_o) / (eta * eta);
        if (sin2_t >= 1.0f)
            return 1.0f;
        float cos_t = sqrtf(1.0f - sin2_t);
        vec3 wt = frame_to_world(&sf.fr, v3(-sf.wo.x / eta, -sf.wo.y / eta, cos_o > 0.0f ? -cos_t : cos_t));
        T *= (1.0f - F) * v3_avg(b->color);
        if (sc->has_media)
            vbi_medium_cross(sc, &st, h.material, h.ng, wt);
        o = vbi_offset_ray_origin(h.p, h.ng, wt);
        d = v3_norm(wt);
        hit_ok = vbi_scene_intersect_mask(sc, o, d, INFINITY, mask, &h);
    }
    return 1.0f;
}

/* The ray mask of a path's next segment after a BSDF sample of lobe `lobe`. */
static uint32_t segment_mask(const vbnl_scene *sc, uint32_t lobe)
{
    if (!sc->has_masks)
        return VBI_RAY_ANY;
    return (lobe & VBI_LOBE_SPECULAR) && !(lobe & VBI_LOBE_TRANSMISSION) ? VBI_RAY_REFLECTED : VBI_RAY_OTHER;
}

void vbi_trace_path_walk(const vbnl_scene *sc, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first,
                          int max_depth, int rr_depth, vbi_walk_add_fn add, void *user, float *aov,
                          vbi_thread_stats *stats)
{
    vbi_walk w;
    vbi_walk_init(&w, sc, sp, stats, max_depth, rr_depth, add, user);
    vbi_hit hit;
    int scattered;
    /* the camera ray: its first hit is known; an escaped camera ray is traced again (the walk
     * needs the segment's end) */
    int rc = vbi_walk_next(&w, o, &d, sc->has_masks ? VBI_RAY_CAMERA : VBI_RAY_ANY, o, 1.0f, 1, 1,
                            hit_ok ? first : NULL, &hit, &scattered);
    if (rc == VBI_WALK_ENDED)
        return;
    if (rc == VBI_WALK_ESCAPED) {
        if (!scattered && sc->env_light != VBI_NO_LIGHT)
            walk_add(&w, v3_mul(w.beta, vbi_light_Le(&sc->lights[sc->env_light], v3s(0.0f), v3_neg(d))), 1);
        return;
    }
    vbi_bsdf bsdf_store;
    const vbi_bsdf *bsdf = vbi_surface_bsdf(sc, &hit, &bsdf_store);
    if (aov && !scattered) {
        v3_store(aov + VBNL_FILM_ALBEDO, bsdf->type == VBNL_MATERIAL_CONDUCTOR ? vbi_bsdf_albedo(bsdf) : bsdf->color);
        v3_store(aov + VBNL_FILM_NORMAL, hit.ns);
    }
    if (!scattered && hit.light != VBI_NO_LIGHT)
        walk_add(&w, v3_mul(w.beta, vbi_light_Le(&sc->lights[hit.light], hit.ng, v3_neg(d))), 1);
    int direct = !scattered; /* no non-delta vertex yet */
    for (;;) {
        const int depth = w.depth;
        if (max_depth >= 0 && depth >= max_depth)
            break;
        const int vertex_direct = direct;
        if (!vbi_bsdf_is_delta(bsdf))
            direct = 0;
        vbi_shading_frame sf;
        vbi_shading_frame_make(bsdf, &hit, d, &sf);
        const vec3 x = hit.p;
        if (!vbi_bsdf_is_delta(bsdf))
            walk_add(&w, v3_mul(w.beta, vbi_estimate_direct_in(sc, &w.media, bsdf, x, &sf, sp, stats)),
                     vertex_direct);
        vbi_bsdf_sample_rec bs;
        vec2 ub = vbi_sampler_next2(sp);
        if (!vbi_bsdf_sample(bsdf, sf.wo, ub, &bs) || vbi_is_black(bs.weight))
            break;
        vec3 wd = frame_to_world(&sf.fr, bs.wi);
        if (!(bs.lobe & VBI_LOBE_TRANSMISSION) && v3_dot(wd, sf.ng) <= 0.0f)
            break;
        w.beta = v3_mul(w.beta, bs.weight);
        if (bs.lobe & VBI_LOBE_TRANSMISSION) {
            o = vbi_offset_ray_origin(x, hit.ng, wd);
            if (sc->has_media)
                vbi_medium_cross(sc, &w.media, hit.material, hit.ng, wd);
        } else {
            o = vbi_offset_ray_origin_along(x, sf.ng);
        }
        d = wd;
        w.depth = depth + 1;
        const int specular = (bs.lobe & VBI_LOBE_SPECULAR) != 0;
        rc = vbi_walk_next(&w, o, &d, segment_mask(sc, bs.lobe), x, bs.pdf, specular, vertex_direct, NULL, &hit,
                            &scattered);
        if (scattered)
            direct = 0;
        if (rc == VBI_WALK_ENDED)
            break;
        if (!scattered) {
            /* light arriving along the sample, MIS-weighted against the next-event estimate at x */
            vec3 Le;
            float mw = vbi_arriving_light(sc, rc == VBI_WALK_SURFACE, &hit, x, d, bs.pdf, specular, &Le);
            if (mw > 0.0f)
                walk_add(&w, v3_scale(v3_mul(w.beta, Le), mw), vertex_direct);
        }
        if (rc == VBI_WALK_ESCAPED)
            break;
        if (depth >= rr_depth) {
            float q = maxf(0.05f, 1.0f - v3_max_comp(w.beta));
            if (vbi_sampler_next(sp) < q)
                break;
            w.beta = v3_scale(w.beta, 1.0f / (1.0f - q));
        }
        if (!vbi_is_finite(w.beta))
            break;
        bsdf = vbi_surface_bsdf(sc, &hit, &bsdf_store);
    }
}
