/* Photon walk fast paths (private to photon_walk.h's vbi_photon_walk_inline), restricted to the
 * cases the walk meets most and computing the same values as the general routines:
 *   - vbi_photon_intersect (vbi_photon_hit_from of a traced ray): vbi_scene_intersect with
 *     the set-up inline for a non-instanced triangle mesh (the shared vbi_fill_mesh_hit of
 *     scene_internal.h); anything else (spheres, area-light quads, instances) gets the general
 *     vbi_fill_hit out of line;
 *   - vbi_photon_lambert_bounce: Lambertian sampling (bsdf.h) in the world frame, without the
 *     general vbi_bsdf_sample dispatch, the sample record and the world -> local turn of wo.
 * The walk is the hot loop of photon splitting (one call of each per photon hit; callgrind:
 * ~200 of the ~850 instructions per hit the walk spent beside Embree were the out-of-line hit
 * set-up and BSDF dispatch). */
#ifndef VBI_PHOTON_FAST_H
#define VBI_PHOTON_FAST_H

#include "bsdf.h"
#include "sampling.h"
#include "scene_internal.h"

/* vbi_fill_hit out of line: the rare hits the mesh fast path below does not set up. */
static __attribute__((noinline, unused)) void vbi_photon_fill_general(const vbnl_scene *s,
                                                                       const struct RTCRayHit *rh, vec3 o, vec3 d,
                                                                       vbi_hit *h)
{
    vbi_fill_hit(s, rh->hit.geomID, rh->hit.primID, rh->hit.instID[0], rh->hit.u, rh->hit.v, rh->ray.tfar, o, d,
                  v3(rh->hit.Ng_x, rh->hit.Ng_y, rh->hit.Ng_z), h);
}

/* The hit of ray (o, d) from Embree's answer `rh` (traced from vbi_rayhit_init(rh, o, d,
 * INFINITY)): vbi_scene_intersect's set-up, 0 for a miss. */
static inline __attribute__((always_inline)) int vbi_photon_hit_from(const vbnl_scene *s, vec3 o, vec3 d,
                                                                      const struct RTCRayHit *rh, vbi_hit *h)
{
    if (rh->hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return 0;
    const scene_geom *g = &s->geoms[rh->hit.geomID];
    if (rh->hit.instID[0] != RTC_INVALID_GEOMETRY_ID || g->kind != SCENE_GEOM_MESH) {
        vbi_photon_fill_general(s, rh, o, d, h);
        return 1;
    }
    h->t = rh->ray.tfar;
    h->p = v3_fma(o, d, rh->ray.tfar);
    h->geom = rh->hit.geomID;
    h->prim = rh->hit.primID;
    vbi_fill_mesh_hit(&g->u.mesh, rh->hit.primID, rh->hit.u, rh->hit.v,
                       v3(rh->hit.Ng_x, rh->hit.Ng_y, rh->hit.Ng_z), h);
    return 1;
}

static inline __attribute__((always_inline)) int vbi_photon_intersect(const vbnl_scene *s, vec3 o, vec3 d,
                                                                       vbi_hit *h)
{
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRayHit rh;
    vbi_rayhit_init(&rh, o, d, INFINITY);
    rtcIntersect1(s->world, &ictx, &rh);
    return vbi_photon_hit_from(s, o, d, &rh, h);
}

/* lambert_sample (bsdf.c) for the shading normal ns facing the arriving photon (wo_w, world):
 * the direction of sample_cosine_hemisphere(u) in frame_from_normal(ns), weight = albedo
 * ((color / pi) cos / (cos / pi)). Returns 0 where lambert_sample absorbs. */
static inline __attribute__((always_inline)) int vbi_photon_lambert_bounce(const vbi_bsdf *b, vec3 ns,
                                                                            vec3 wo_w, vec2 u, vec3 *wi_w)
{
    if (!(v3_dot(wo_w, ns) > 0.0f)) /* wo.z <= 0 */
        return 0;
    vec3 wi = sample_cosine_hemisphere(u);
    if (wi.z <= 0.0f)
        return 0;
    frame fr = frame_from_normal(ns);
    *wi_w = frame_to_world(&fr, wi);
    (void)b;
    return 1;
}

#endif
