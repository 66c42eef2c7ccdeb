/* Pieces every integrator shares (private header): the camera-ray tile loop with 8-wide primary
 * packets, the shading frame, and next-event estimation of the real lights. */
#ifndef VBI_SHADING_H
#define VBI_SHADING_H

#include <string.h>

#include "render_internal.h"

/* Traces the camera path whose first hit (when hit_ok) is given and writes one sample's film
 * record into `out` (zeroed, film stride floats). */
typedef void (*vbi_camera_path_fn)(void *state, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok,
                                    const vbi_hit *hit, float *out, vbi_thread_stats *stats);

/* Renders every sample of a tile job: a camera ray per sample through a position in the pixel
 * (box filter), primary hits as 8-wide Embree packets, then fn. The first draw of each sample's
 * sampler (sampler.h) places it in the pixel. */
void vbi_render_camera_paths(vbnl_tile_job *job, uint32_t stride, vbi_camera_path_fn fn, void *state);

/* v3_is_black and v3_is_finite as the bounce loop wants them: the same answers bit for bit, with
 * fewer instructions. A float compares equal to zero exactly when all its bits but the sign are
 * 0; x * 0 is 0 for finite x and NaN for infinities and NaNs (no -ffast-math here, so the
 * compiler keeps the products). */
static inline int vbi_is_black(vec3 a)
{
    uint32_t x, y, z;
    memcpy(&x, &a.x, sizeof(x));
    memcpy(&y, &a.y, sizeof(y));
    memcpy(&z, &a.z, sizeof(z));
    return ((x | y | z) << 1) == 0u;
}
static inline int vbi_is_finite(vec3 a) { return a.x * 0.0f + a.y * 0.0f + a.z * 0.0f == 0.0f; }

/* Shading frame at a hit seen along d, on the BSDF's shading normal (the hit's, or the one a
 * normal perturbation gives there). Opaque surfaces are two-sided: ng and the shading normal are
 * flipped to face the viewer, and a shading normal that faces away falls back to ng; the
 * dielectric keeps its orientation. */
typedef struct vbi_shading_frame {
    frame fr;  /* z = shading normal */
    vec3 ng;   /* geometric normal used for sidedness and ray offsets */
    vec3 wo;   /* -d in the local frame */
} vbi_shading_frame;
static inline void vbi_shading_frame_make(const vbi_bsdf *bsdf, const vbi_hit *hit, vec3 d,
                                           vbi_shading_frame *sf)
{
    vec3 wo_w = v3_neg(d), ng = hit->ng, ns = vbi_bsdf_shading_normal(bsdf, hit->ns);
    if (!vbi_bsdf_is_transmissive(bsdf)) {
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

/* ---- media, pass-through surfaces and visibility (medium_path.c) ---- */

/* The light a connection from org along the unit dir over (0, tmax) lets through: 0 when an
 * opaque surface blocks it (shadow rays ignore no_shadow geometry), through surfaces that let
 * light through unchanged in direction (their tint) and the media of the regions it crosses
 * (starting in the innermost of `media`, NULL: outside). *nee_only (optional) is set to 1 when
 * only no_shadow geometry lies on the way: BSDF sampling cannot find that light, so next-event
 * estimation counts it alone; 1 on entry says the light is a delta light, which the ray also
 * reaches through reflecting dielectrics of ior 1 (vbi_bsdf_passes_straight), weighted by what
 * they let through. Random numbers (ratio tracking) from r. */
vec3 vbi_shadow_transmittance(const vbnl_scene *sc, const vbi_medium_stack *media, vec3 org, vec3 dir, float tmax,
                               vbi_rand *r, vbi_thread_stats *stats, int *nee_only);

/* Next-event estimation at a point p in a medium, scattering with the phase function (kind, g)
 * light that then travels along `out` (unit): as vbi_estimate_direct, the phase function in
 * place of the BSDF (MIS against phase sampling). */
vec3 vbi_estimate_direct_medium(const vbnl_scene *sc, const vbi_medium_stack *media, vec3 p, vec3 out,
                                 vbnl_phase_kind kind, float g, vbi_sampler *sp, vbi_thread_stats *stats);

/* A path's travel between scattering vertices, through media and pass-through surfaces, for every
 * integrator (docs/integrators.md, "Media"). The integrator fills the first fields and keeps the
 * walk across its bounces: beta is its throughput, depth its bounce count. */
typedef void (*vbi_walk_add_fn)(void *user, vec3 c, int is_direct);
typedef struct vbi_walk {
    const vbnl_scene *sc;
    vbi_sampler *sp;
    vbi_thread_stats *stats;
    int max_depth, rr_depth;     /* the integrator's rules (-1: no depth limit) */
    vbi_walk_add_fn add;        /* receives what the walk adds to the image */
    void *user;
    vbi_medium_stack media;     /* the regions the path is in */
    vec3 beta;
    int depth;
} vbi_walk;

enum {
    VBI_WALK_SURFACE = 0, /* the path reached a surface */
    VBI_WALK_ESCAPED,     /* it left the scene */
    VBI_WALK_ENDED,       /* it ended (absorbed, Russian roulette, the depth limit) */
};

/* Sets up a walk with throughput 1 outside every surface. */
void vbi_walk_init(vbi_walk *w, const vbnl_scene *sc, vbi_sampler *sp, vbi_thread_stats *stats, int max_depth,
                    int rr_depth, vbi_walk_add_fn add, void *user);

/* Follows the ray o + t d (d unit, updated) from the scattering vertex x (the direction's pdf
 * there, `specular` for a delta lobe or the camera) to the next surface that scatters: segments
 * through media are tracked (their emission and fog added, beta weighted), surfaces that let light
 * through unchanged are crossed (beta times their tint, the region stack updated), and where the
 * path scatters in a medium the walk shades that point itself (next-event estimation of the real
 * lights with the phase function, MIS against phase sampling) and goes on along a sampled
 * direction, with the integrator's Russian roulette and depth limit. `known` (optional) is the
 * ray's first hit, already traced; `mask` the Embree mask of the ray's kind (VBI_RAY_*);
 * `seg_direct` whether light arriving at x counts as direct. Returns VBI_WALK_*; on
 * VBI_WALK_SURFACE *hit is filled. *scattered is set when the path scattered in a medium: the
 * light arriving at the hit (or from the environment on escape) has then been counted by the walk,
 * and the integrator must not count it again; otherwise counting it is the integrator's, with
 * its own MIS at x and the updated beta. */
int vbi_walk_next(vbi_walk *w, vec3 o, vec3 *d, uint32_t mask, vec3 x, float pdf, int specular, int seg_direct,
                   const vbi_hit *known, vbi_hit *hit, int *scattered);

/* A whole camera path through media, pass-through surfaces and visibility flags: the path tracer
 * (next-event estimation and BSDF or phase sampling, MIS, Russian roulette after rr_depth
 * vertices, max_depth vertices at most, -1 unlimited) with the walk between its vertices. Its
 * first hit (hit_ok, first) is known. Contributions go to add (is_direct as path.c's split);
 * aov (optional) receives the albedo and normal of the first surface seen directly. Used by
 * every integrator for scenes with media (docs/integrators.md, "Media"). */
void vbi_trace_path_walk(const vbnl_scene *sc, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first,
                          int max_depth, int rr_depth, vbi_walk_add_fn add, void *user, float *aov,
                          vbi_thread_stats *stats);

/* The alpha of a camera sample (POV-Ray's Output_Alpha): 1 where the camera ray meets a surface
 * that does not let it through; along pass-through and refracting surfaces and media, 1 minus what
 * reaches the background times its transparency (1 - vbnl_scene_set_background_alpha). */
float vbi_camera_alpha(const vbnl_scene *sc, vec3 o, vec3 d, int hit_ok, const vbi_hit *first, vbi_sampler *sp);

/* The shadow ray of light sample ls from org: *dir and *tmax (INFINITY for a light at infinity).
 * It runs to the light's point offset off its own surface the same way as org, so that it ends
 * short of the emitter whatever the distance: a margin taken from the distance alone is eaten by
 * the origin's offset, which grows with the coordinates (256 ulps), and a close light then
 * shadows itself. 0 when org is at the light's point. */
static inline int vbi_shadow_segment(const vbi_light_li_sample *ls, vec3 org, vec3 *dir, float *tmax)
{
    *dir = ls->wi;
    *tmax = INFINITY;
    if (!isinf(ls->dist)) {
        vec3 end = ls->is_delta ? ls->p : vbi_offset_ray_origin(ls->p, ls->n, v3_neg(ls->wi));
        vec3 to = v3_sub(end, org);
        float len = v3_len(to);
        if (!(len > 0.0f))
            return 0;
        *dir = v3_scale(to, 1.0f / len);
        *tmax = len * (1.0f - 1e-4f);
    }
    return 1;
}

/* Next-event estimation at x (non-delta BSDF): one light picked by power, a point on it, a
 * shadow ray, MIS against BSDF sampling (power heuristic). Returns f * Li * w / pdf (not yet
 * multiplied by the path throughput). Inline, like the two functions around it: they run at
 * every path vertex, and inlined the Lambertian case needs only the z of wi in the local frame.
 * `media` is the region stack of the path at x (NULL: outside): with media, pass-through surfaces
 * or visibility flags in the scene the shadow ray is vbi_shadow_transmittance's; a shadowless
 * light traces none and counts alone. */
static inline vec3 vbi_estimate_direct_in(const vbnl_scene *sc, const vbi_medium_stack *media, const vbi_bsdf *bsdf,
                                           vec3 x, const vbi_shading_frame *sf, vbi_sampler *sp,
                                           vbi_thread_stats *stats)
{
    float pmf;
    /* one 2D number picks the light (its first coordinate, reused within the light's share of
     * [0,1)) and the point on it: with a stratified sampler the points stay stratified on each
     * light (a quad made of two triangles samples like one quad) */
    vec2 ul = vbi_sampler_next2(sp);
    uint32_t li = vbi_scene_pick_light_reuse(sc, ul.x, &pmf, &ul.x);
    vbi_light_li_sample ls;
    if (!vbi_light_sample_li(&sc->lights[li], x, ul, &ls) || !(ls.pdf > 0.0f) || vbi_is_black(ls.Li))
        return v3s(0.0f);
    vec3 wi = frame_to_local(&sf->fr, ls.wi);
    vec3 f = vbi_bsdf_eval(bsdf, sf->wo, wi);
    /* no light through the geometric back of an opaque surface */
    int side_ok = vbi_bsdf_is_transmissive(bsdf) || v3_dot(ls.wi, sf->ng) > 0.0f;
    if (!side_ok || vbi_is_black(f))
        return v3s(0.0f);
    /* opaque: side_ok has just found ng on the side of wi */
    vec3 org = vbi_bsdf_is_transmissive(bsdf) ? vbi_offset_ray_origin(x, sf->ng, ls.wi)
                                               : vbi_offset_ray_origin_along(x, sf->ng);
    vec3 dir;
    float tmax;
    if (!vbi_shadow_segment(&ls, org, &dir, &tmax))
        return v3s(0.0f);
    const vbi_light *light = &sc->lights[li];
    int nee_only = ls.is_delta || light->shadowless;
    vec3 T = v3s(1.0f);
    if (light->shadowless) {
        /* POV-Ray's shadowless: no shadow ray */
    } else if (!sc->has_media && !sc->has_null && !sc->has_masks) {
        stats->rays++;
        stats->shadow_rays++;
        if (vbi_scene_occluded_inline(sc, org, dir, tmax))
            return v3s(0.0f);
    } else {
        vbi_rand r = {sp, NULL};
        T = vbi_shadow_transmittance(sc, media, org, dir, tmax, &r, stats, &nee_only);
        if (vbi_is_black(T))
            return v3s(0.0f);
    }
    float w = nee_only ? 1.0f : power_heuristic(pmf * ls.pdf, vbi_bsdf_pdf(bsdf, sf->wo, wi));
    return v3_scale(v3_mul(v3_mul(f, ls.Li), T), w / (pmf * ls.pdf));
}

static inline vec3 vbi_estimate_direct(const vbnl_scene *sc, const vbi_bsdf *bsdf, vec3 x, const vbi_shading_frame *sf,
                                        vbi_sampler *sp, vbi_thread_stats *stats)
{
    return vbi_estimate_direct_in(sc, NULL, bsdf, x, sf, sp, stats);
}

/* MIS weight of light found by a BSDF sample from x along w (environment when !hit_ok, else the
 * emitter at y), against next-event estimation; 1 after a specular bounce. Also returns Le. */
static inline float vbi_arriving_light(const vbnl_scene *sc, int hit_ok, const vbi_hit *y, vec3 x, vec3 w,
                                        float pdf_bsdf, int specular, vec3 *Le)
{
    const vbi_light *l;
    float pl;
    *Le = v3s(0.0f);
    if (!hit_ok) {
        if (sc->env_light == VBI_NO_LIGHT)
            return 0.0f;
        l = &sc->lights[sc->env_light];
        *Le = vbi_light_Le(l, v3s(0.0f), v3_neg(w));
        pl = vbi_scene_light_pmf(sc, sc->env_light) * vbi_light_pdf_li(l, x, v3s(0.0f), v3s(0.0f), w);
    } else {
        if (y->light == VBI_NO_LIGHT)
            return 0.0f;
        l = &sc->lights[y->light];
        if (l->shadowless) /* next-event estimation counts it alone */
            return 0.0f;
        *Le = vbi_light_Le(l, y->ng, v3_neg(w));
        if (vbi_is_black(*Le))
            return 0.0f;
        pl = vbi_scene_light_pmf(sc, y->light) * vbi_light_pdf_li(l, x, y->p, y->ng, w);
    }
    return specular ? 1.0f : power_heuristic(pdf_bsdf, pl);
}

#endif
