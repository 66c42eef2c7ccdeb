/* Which points of its sphere a virtual light stands for (private header).
 *
 * Eq. 3 of Li et al. 2022 lets a virtual light (VL) j emit from every surface point within r_j
 * of its centre y_j, and photon splitting (Section 3.3) gives it the photons of every such point.
 * Where the sphere reaches past an occluder that is no surface of the VL's own, both are wrong:
 *   - an emitter panel hung 1 cm under a ceiling, two-sided as POV-Ray's `emission` is: the
 *     photons it sends upward land on the ceiling inside the gap, which no camera path reaches;
 *     the ceiling VLs just outside the gap take them (the partition of unity gives every photon
 *     in reach to the VLs around it) and emit that trapped light into the room. On the closed
 *     room of tests/data/rooms (32 x 32, 10K lights, 500K photon paths) the image mean is 3.4%
 *     above path tracing's without this test, 0.2% below with it;
 *   - a thin wall: the VLs on one side light the floor on the other side within r_j (the
 *     paper's Fig. 19), and take its photons.
 *   - a light panel's own face, and any other surface of another material inside the sphere:
 *     the VL converts what lands there with its own BSDF (a black emitter's photons reflected
 *     as the white ceiling around it) and shines there with its own radiance.
 * The support test removes these. A point p on a surface, with unit normal n on the side the
 * light arrives from (photon splitting) or is seen from (rendering), belongs to VL j when
 *   1. p has the VL's material (vl_set.h material; textures vary within a material);
 *   2. the space above p is open up to the test height tau_j = r_j: no surface along
 *      p + t n for t < tau_j (the gap's ceiling fails: the panel is 1 cm above it), and
 *   3. the segment from p + tau_j n to y_j + tau_j n_j is free (a wall between them fails).
 * So a VL keeps the points of its material whose air it shares up to its radius; points that
 * no VL keeps deposit nothing and are path traced when rendering reaches them (w_v = 0, Eq. 9).
 * Tests 2 and 3 cost two rays, so they run only for the VLs whose neighbourhood holds something
 * else: each VL is probed once after elimination (up from its centre, 16 rays across its disk
 * at height tau_j and 16 rays up from points of the disk, all to r_j); a VL whose probes all
 * run free is *clear* (tau stored as 0) and every point of its material in its sphere passes,
 * as in the paper. The probes only decide where the exact test runs: a probe that hits a
 * concave surface of the VL's own marks the VL for the test, which then passes its points.
 *
 * The same test filters photon splitting's deposits (splitting.c) and rendering's gathers and
 * power samples (vbnl.c), so that a VL emits only where it took its photons. It is a function of
 * the scene and the VL only: deterministic, independent of threads.
 *
 * Data: per VL by index rank (vl_index.h) its material and tau_j, 0 for clear VLs. */
#ifndef VBI_VL_SUPPORT_H
#define VBI_VL_SUPPORT_H

#include <stdint.h>

#include "pool.h"
#include "render_internal.h"
#include "vbnl/result.h"
#include "scene_internal.h"
#include "vl_index.h"
#include "vl_set.h"

typedef struct vbi_vl_support {
    float tau;         /* the height of tests 2 and 3, 0 when the VL is clear */
    uint32_t material; /* test 1 */
} vbi_vl_support;

typedef struct vbi_vl_support_stats {
    uint32_t tested; /* VLs whose points take the test (tau > 0) */
    uint64_t rays;   /* probe rays traced */
} vbi_vl_support_stats;

/* Probes every VL of `set` against the scene and writes its record by rank of `index` into
 * by_rank (set->count records, the caller's). Runs on the stage's workers when `stage` is given, else on
 * `pool`, else serially. Errors: VBNL_ERR_CANCELLED, VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbi_vl_support_build(const vbnl_scene *sc, const vbi_vl_set *set, const vbi_vl_index *index,
                                  vbnl_stage_ctx *stage, vbi_pool *pool, vbi_vl_support *by_rank,
                                  vbi_vl_support_stats *stats);

/* Open height above p along the unit normal n, up to tmax (test 2, for all VLs at p at once). */
static inline float vbi_vl_support_height(const vbnl_scene *sc, vec3 p, vec3 n, float tmax)
{
    return vbi_scene_hit_distance(sc, vbi_offset_ray_origin_along(p, n), n, tmax);
}

/* Tests 2 and 3 for a point p (normal n, open height h_p from vbi_vl_support_height with a
 * tmax of at least tau) and the VL of centre c, normal nj and test height tau > 0. */
static inline int vbi_vl_support_passes(const vbnl_scene *sc, vec3 p, vec3 n, float h_p, vec3 c, vec3 nj,
                                         float tau)
{
    if (h_p < tau)
        return 0;
    vec3 a = v3_fma(p, n, tau), ab = v3_sub(v3_fma(c, nj, tau), a);
    float len = v3_len(ab);
    return !(len > 0.0f) || !vbi_scene_occluded_inline(sc, a, v3_scale(ab, 1.0f / len), len);
}

#endif
