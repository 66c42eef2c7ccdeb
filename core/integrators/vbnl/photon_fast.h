/* Photon walk fast paths (private to splitting.h's vbnl_photon_walk_inline).
 *
 * Local, inline copies of two shared routines, restricted to the cases the photon walk meets
 * most and computing the same values:
 *   - vbnl_photon_intersect: vbnl_scene_intersect + fill_hit (scene_commit.c) for a
 *     non-instanced triangle mesh, inline; anything else (spheres, area-light quads, instances)
 *     is handed to vbnl_scene_intersect, which traces the same ray again (same hit);
 *   - vbnl_photon_offset_origin: vbnl_offset_ray_origin (scene_internal.h) in SSE, the same bits
 *     (the scales are powers of two, so products and sums round alike with or without FMA);
 *   - vbnl_photon_lambert_bounce: lambert_sample (bsdf.c) in the world frame, without the
 *     general vbnl_bsdf_sample dispatch, the sample record and the world -> local turn of wo.
 * Why local copies: the shared shading code (scene_commit.c, bsdf.c) is being reworked in
 * another branch and the walk is the hot loop of photon splitting (one call of each per
 * photon hit; callgrind: ~200 of the ~850 instructions per hit the walk spent beside Embree
 * were the out-of-line hit set-up and BSDF dispatch). Keep them in step with those files: the
 * mesh branch must fill the vbnl_hit exactly as fill_hit does. */
#ifndef VBNL_PHOTON_FAST_H
#define VBNL_PHOTON_FAST_H

#if defined(__SSE4_1__)
#include <immintrin.h>
#endif

#include "bsdf.h"
#include "sampling.h"
#include "scene_internal.h"

static inline __attribute__((always_inline)) int vbnl_photon_intersect(const vbnl_scene *s, vec3 o, vec3 d,
                                                                       vbnl_hit *h)
{
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRayHit rh;
    rh.ray.org_x = o.x;
    rh.ray.org_y = o.y;
    rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x;
    rh.ray.dir_y = d.y;
    rh.ray.dir_z = d.z;
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = INFINITY;
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xffffffffu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s->world, &ictx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return 0;
    const scene_geom *g = &s->geoms[rh.hit.geomID];
    if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID || g->kind != SCENE_GEOM_MESH)
        return vbnl_scene_intersect(s, o, d, INFINITY, h); /* the general set-up */
    /* fill_hit, SCENE_GEOM_MESH without an instance */
    float bu = rh.hit.u, bv = rh.hit.v, t = rh.ray.tfar;
    uint32_t prim = rh.hit.primID;
    const scene_mesh *m = &g->u.mesh;
    h->t = t;
    h->p = v3_fma(o, d, t);
    h->geom = rh.hit.geomID;
    h->prim = prim;
    h->light = m->face_lights ? m->face_lights[prim] : VBNL_NO_LIGHT;
    h->uv = (vec2){bu, bv};
    vec3 ng = v3_norm(v3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z)), ns = ng;
    if (m->normals || m->uvs) {
        const uint32_t *tri = m->indices + 3 * (size_t)prim;
        float b0 = 1.0f - bu - bv;
        if (m->normals) {
            ns = v3_add(v3_add(v3_scale(v3_load(m->normals + 3 * tri[0]), b0),
                               v3_scale(v3_load(m->normals + 3 * tri[1]), bu)),
                        v3_scale(v3_load(m->normals + 3 * tri[2]), bv));
            ns = v3_norm(ns);
            if (!(v3_len2(ns) > 0.5f))
                ns = ng;
            if (v3_dot(ng, ns) < 0.0f) /* pbrt: the geometric normal follows the shading side */
                ng = v3_neg(ng);
        }
        if (m->uvs) {
            const float *uv = m->uvs;
            h->uv = (vec2){b0 * uv[2 * tri[0]] + bu * uv[2 * tri[1]] + bv * uv[2 * tri[2]],
                           b0 * uv[2 * tri[0] + 1] + bu * uv[2 * tri[1] + 1] + bv * uv[2 * tri[2] + 1]};
        }
    }
    h->material = m->face_materials ? m->face_materials[prim] : m->material;
    h->ng = ng;
    h->ns = ns;
    return 1;
}

/* vbnl_offset_ray_origin, branch-free: per axis, p moved by 256 n in integer ulps (|p| >= 1/32)
 * or by n / 65536 (near the origin), n turned to w's side. */
static inline __attribute__((always_inline)) vec3 vbnl_photon_offset_origin(vec3 p, vec3 n, vec3 w)
{
#if defined(__SSE4_1__)
    __m128 pv = _mm_setr_ps(p.x, p.y, p.z, 0.0f);
    __m128 nv = _mm_setr_ps(n.x, n.y, n.z, 0.0f);
    if (v3_dot(n, w) < 0.0f)
        nv = _mm_xor_ps(nv, _mm_set1_ps(-0.0f));
    __m128i of = _mm_cvttps_epi32(_mm_mul_ps(nv, _mm_set1_ps(256.0f)));
    __m128i neg = _mm_castps_si128(_mm_cmplt_ps(pv, _mm_setzero_ps()));
    of = _mm_sub_epi32(_mm_xor_si128(of, neg), neg); /* pc < 0 ? -of : of */
    __m128 pi = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(pv), of));
    __m128 near = _mm_add_ps(pv, _mm_mul_ps(nv, _mm_set1_ps(1.0f / 65536.0f)));
    __m128 small = _mm_cmplt_ps(_mm_andnot_ps(_mm_set1_ps(-0.0f), pv), _mm_set1_ps(1.0f / 32.0f));
    __m128 r = _mm_blendv_ps(pi, near, small);
    float out[4];
    _mm_storeu_ps(out, r);
    return v3(out[0], out[1], out[2]);
#else
    return vbnl_offset_ray_origin(p, n, w);
#endif
}

/* lambert_sample (bsdf.c) for the shading normal ns facing the arriving photon (wo_w, world):
 * the direction of sample_cosine_hemisphere(u) in frame_from_normal(ns), weight = albedo
 * ((color / pi) cos / (cos / pi)). Returns 0 where lambert_sample absorbs. */
static inline __attribute__((always_inline)) int vbnl_photon_lambert_bounce(const vbnl_bsdf *b, vec3 ns,
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
