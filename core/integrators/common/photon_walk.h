/* The photon walk: light random walks shared by every integrator that traces light paths (the
 * photon splitting of `vbnl`, the VPLs of `vpl`, `vsl` and `richvsl`'s photon map) (private
 * header of the integrators' common machinery).
 *
 * Importance transport (Veach 1997, ch. 5):
 *   - light j picked by power (the scene's alias table, pmf p_j), point and direction by
 *     vbi_light_sample_le; flux Phi = Le |cos| / (p_j pdf_pos pdf_dir) / N (N paths in all);
 *   - at a hit, an opaque BSDF uses a frame facing the arriving photon (two-sided surfaces, as
 *     the path tracer); the dielectric keeps its orientation;
 *   - bounce by BSDF sampling with the photon arriving along wo: the sample weight
 *     f |cos theta_i| / pdf times eta^2 for a refraction (bsdf.h weights are for radiance,
 *     which carries 1 / eta^2; flux does not) times the shading-normal correction
 *     |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|) of the adjoint BSDF (Veach 1997, Eq. 5.17);
 *   - Russian roulette from bounce rr_depth on with continuation probability
 *     q = min(1, sqrt(max(beta_new) / max(beta_old))) (rr_sqrt: the VBNL authors' rule, after
 *     bounce 5 in their code; its square root keeps photon powers from dropping as fast as the
 *     albedo) or q = min(1, max(beta_new) / max(beta_old)) (the sampled albedo: instant
 *     radiosity's rule), beta_new /= q. No depth limit (max_depth = 0), but a safety cap of
 *     VBI_PHOTON_SAFETY_DEPTH bounces for lossless traps (mirror boxes, where q stays 1);
 *   - no visit on delta surfaces (mirror, glass): no virtual light stands for them.
 *
 * Floating point: photon_walk.c and photon splitting (vbnl/splitting.c), the two places the walk
 * is compiled, are built without contracted multiply-adds (-ffp-contract=off), so the walk gives
 * the same bits wherever it is inlined; splitting's eight-wide SIMD step reproduces it operation
 * for operation.
 *
 * Threads: a walk reads the committed scene only; any number may run at once. */
#ifndef VBI_PHOTON_WALK_H
#define VBI_PHOTON_WALK_H

#include <stdint.h>

#include "bsdf.h"
#include "lights.h"
#include "photon_fast.h"
#include "rng.h"
#include "scene_internal.h"

#define VBI_PHOTON_SAFETY_DEPTH 4096 /* bounces at most, for lossless traps (mirror boxes) */

/* One photon path: `visit` is called at every non-delta hit, before the bounce, with the flux
 * arriving there. Draws from `rng` only, in a fixed order, so a path is a function of its
 * stream. */
typedef struct vbi_photon_vertex {
    const vbi_hit *hit;
    const vbi_bsdf *bsdf;  /* vbi_surface_bsdf at the hit */
    vec3 ng, ns;            /* unit normals facing the arriving photon (opaque surfaces) */
    vec3 wo;                /* unit, toward where the photon came from */
    vec3 beta;              /* flux arriving (already divided by the path count) */
    int depth;              /* 0 at the first hit */
} vbi_photon_vertex;
typedef void (*vbi_photon_visit_fn)(void *user, const vbi_photon_vertex *v);
typedef struct vbi_photon_walk_desc {
    const vbnl_scene *scene;
    float inv_paths;        /* 1 / N, the flux normalisation by the number of paths */
    int rr_depth;           /* bounces before Russian roulette */
    int max_depth;          /* 0 = unlimited (up to VBI_PHOTON_SAFETY_DEPTH) */
    int rr_sqrt;            /* 1: VBNL authors' sqrt rule; 0: survival = sampled albedo ratio */
    int visit_delta_nodes;  /* 1: also visit the delta hits of material nodes (photon splitting:
                             * a VBNL light stands for its own leaf over its whole disk, so the
                             * irradiance of the node's mirror-chosen points is its too) */
} vbi_photon_walk_desc;
typedef struct vbi_photon_walk_stats {
    uint64_t rays, hits, delta_hits;
} vbi_photon_walk_stats;
void vbi_photon_walk(const vbi_photon_walk_desc *w, vbi_rng *rng, vbi_photon_visit_fn visit, void *user,
                      vbi_photon_walk_stats *stats);
/* The walk in two steps, so that a caller can keep several paths in flight and trace their rays
 * together (photon splitting): vbi_photon_emit draws the path's emission, vbi_photon_scatter
 * takes the hit of the path's current ray (o, dir), visits it and bounces. Each returns 1 when
 * the path has a next ray to trace, 0 when it has ended. */
typedef struct vbi_photon_state {
    vec3 o, dir;   /* the ray to trace next */
    vec3 beta;     /* flux it carries (already divided by the path count) */
    int depth;     /* 0 for the emitted ray */
    int max_depth;
} vbi_photon_state;

static inline __attribute__((always_inline)) int vbi_photon_emit(const vbi_photon_walk_desc *w, vbi_rng *rng,
                                                                  vbi_photon_state *ps)
{
    const vbnl_scene *sc = w->scene;
    float pmf;
    uint32_t li = vbi_scene_pick_light(sc, vbi_rng_next(rng), &pmf);
    vec2 u_pos = vbi_rng_next2(rng), u_dir = vbi_rng_next2(rng);
    vbi_light_le_sample les;
    if (!(pmf > 0.0f) || !vbi_light_sample_le(&sc->lights[li], u_pos, u_dir, &les))
        return 0;
    float den = pmf * les.pdf_pos * les.pdf_dir;
    if (!(den > 0.0f))
        return 0;
    /* Flux of the photon: Le |cos| / (p_j pdf_pos pdf_dir) / N (lights.h). */
    ps->beta = v3_scale(les.Le, les.cos_at_light / den * w->inv_paths);
    if (!v3_is_finite(ps->beta) || v3_is_black(ps->beta))
        return 0;
    ps->o = vbi_offset_ray_origin(les.p, les.n, les.dir);
    ps->dir = les.dir;
    ps->depth = 0;
    ps->max_depth = w->max_depth > 0 && w->max_depth < VBI_PHOTON_SAFETY_DEPTH ? w->max_depth
                                                                              : VBI_PHOTON_SAFETY_DEPTH;
    return 1;
}

static inline __attribute__((always_inline)) int
vbi_photon_scatter(const vbi_photon_walk_desc *w, vbi_rng *rng, vbi_photon_state *ps, const vbi_hit *hitp,
                    vbi_photon_visit_fn visit, void *user, vbi_photon_walk_stats *st)
{
    const vbnl_scene *sc = w->scene;
    const vbi_hit *hit = hitp; /* read in place: `visit` sees the caller's record */
    const vec3 beta = ps->beta;
    st->hits++;
    vbi_bsdf bsdf_store;
    const vbi_bsdf *bsdf = vbi_surface_bsdf(sc, hit, &bsdf_store);
    vec3 wo_w = v3_neg(ps->dir); /* toward where the photon came from */
    vec3 ng = hit->ng, ns = vbi_bsdf_shading_normal(bsdf, hit->ns);
    int transmissive = vbi_bsdf_is_transmissive(bsdf);
    if (!transmissive) { /* two-sided opaque surface: frame facing the photon (path.c) */
        if (v3_dot(ng, wo_w) < 0.0f) {
            ng = v3_neg(ng);
            ns = v3_neg(ns);
        }
        if (v3_dot(ns, wo_w) <= 0.0f)
            ns = ng;
    }
    if (vbi_bsdf_is_delta(bsdf)) {
        st->delta_hits++;
        if (w->visit_delta_nodes && sc->materials[hit->material].is_node) {
            vbi_photon_vertex v = {hit, bsdf, ng, ns, wo_w, beta, ps->depth};
            visit(user, &v);
        }
    } else {
        vbi_photon_vertex v = {hit, bsdf, ng, ns, wo_w, beta, ps->depth};
        visit(user, &v);
    }

    /* Bounce (importance transport, above). The same draws for every BSDF. */
    vec2 ub = vbi_rng_next2(rng);
    vec3 wi_w, wt;
    if (bsdf->type == VBNL_MATERIAL_LAMBERT) {
        /* lambert_sample without the general dispatch (photon_fast.h) */
        if (!vbi_photon_lambert_bounce(bsdf, ns, wo_w, ub, &wi_w) || v3_is_black(bsdf->color))
            return 0;
        if (v3_dot(wi_w, ng) <= 0.0f)
            return 0; /* a reflection must leave on the photon's side of the real surface */
        wt = bsdf->color;
    } else {
        frame fr = frame_from_normal(ns);
        vec3 wo = frame_to_local(&fr, wo_w);
        vbi_bsdf_sample_rec bs;
        if (!vbi_bsdf_sample(bsdf, wo, ub, &bs) || v3_is_black(bs.weight))
            return 0;
        wi_w = frame_to_world(&fr, bs.wi);
        if (!(bs.lobe & VBI_LOBE_TRANSMISSION) && v3_dot(wi_w, ng) <= 0.0f)
            return 0; /* a reflection must leave on the photon's side of the real surface */
        wt = bs.weight;
        if (bs.lobe & VBI_LOBE_TRANSMISSION)
            wt = v3_scale(wt, bs.eta * bs.eta); /* flux is not compressed by refraction */
    }
    /* Adjoint shading-normal correction (Veach 1997, Eq. 5.17); exactly 1 when ns == ng. */
    if (ns.x != ng.x || ns.y != ng.y || ns.z != ng.z) {
        float den_c = v3_absdot(wo_w, ng) * v3_absdot(wi_w, ns);
        if (den_c > 0.0f)
            wt = v3_scale(wt, v3_absdot(wo_w, ns) * v3_absdot(wi_w, ng) / den_c);
    }
    vec3 nb = v3_mul(beta, wt);
    if (ps->depth + 1 >= w->rr_depth) {
        /* VBNL authors' rule: continue with q = sqrt(max(new) / max(old)); the plain rule
         * (q = max(new) / max(old), the sampled albedo) otherwise; at most 1. */
        float ratio = v3_max_comp(nb) / v3_max_comp(beta);
        float q = minf(1.0f, w->rr_sqrt ? sqrtf(ratio) : ratio);
        if (!(q > 0.0f) || vbi_rng_next(rng) >= q)
            return 0;
        nb = v3_scale(nb, 1.0f / q);
    }
    if (!v3_is_finite(nb) || v3_is_black(nb))
        return 0;
    if (++ps->depth >= ps->max_depth)
        return 0;
    ps->beta = nb;
    ps->o = vbi_offset_ray_origin(hit->p, hit->ng, wi_w);
    ps->dir = wi_w;
    return 1;
}

/* The same walk, inline: called with a known `visit`, the compiler inlines the visit too
 * (vbi_photon_walk is this function out of line). */
static inline __attribute__((always_inline)) void
vbi_photon_walk_inline(const vbi_photon_walk_desc *w, vbi_rng *rng, vbi_photon_visit_fn visit, void *user,
                        vbi_photon_walk_stats *st)
{
    vbi_photon_state ps;
    if (!vbi_photon_emit(w, rng, &ps))
        return;
    for (;;) {
        vbi_hit hit;
        st->rays++;
        if (!vbi_photon_intersect(w->scene, ps.o, ps.dir, &hit)) /* photon_fast.h */
            return;
        if (!vbi_photon_scatter(w, rng, &ps, &hit, visit, user, st))
            return;
    }
}

#endif
