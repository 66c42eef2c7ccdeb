/* What rendering reads of each virtual light, packed (private header).
 *
 * Shading a vertex touches lights chosen at random (power-based selection, Eq. 4) or found by the
 * gather query (BSDF sampling, Section 4.1): with 40K-130K lights each one is a cache miss. Kept as
 * separate arrays (position, radius, normal, density, tint, 1 / (pi r^2), pmf, alias slot, profile)
 * one light cost up to eight misses; profiled on the glossy Cornell box at 512 x 512 with 40K
 * lights, those loads were most of vbnl's rendering time. Here every light is one 64-byte record
 * (one cache line), in the spatial order of the index (its *rank*, vl_index.h), so the lights a
 * query finds, and those of neighbouring pixels, also share pages.
 *
 * A record holds the alias-table slot of its rank as well (acceptance probability and alias):
 * picking a light by power reads the record of the slot drawn, which is the light itself with
 * the acceptance probability, so most picks cost one line.
 *
 * The record also serves the gather's exact containment and filter tests (the index lists only
 * candidate ranks, vbi_vl_index_candidates), so a gathered light costs one line, not two.
 *
 * Radiance (vbnl.c, Eq. 3): L_j(y, w) = J_j(w) tint_j / (pi r_j^2). For a Lambertian light J does
 * not depend on the direction (profiles.h), so the record stores the finished radiance; a glossy
 * light stores tint_j / (pi r_j^2) and evaluates its profile (lazily converted or not) by map slot,
 * so shading reads no per-id array. */
#ifndef VBI_VL_SHADE_H
#define VBI_VL_SHADE_H

#include <stdint.h>

#include "profiles.h"
#include "sampling.h"
#include "vbnl/result.h"
#include "vl_index.h"
#include "vl_set.h"
#include "vl_support.h"
#include "vmath.h"

typedef struct __attribute__((aligned(64))) vbi_vl_shade_rec {
    vec3 position;
    float radius;      /* r_j */
    vec3 normal;
    float density;     /* rho_j, Eq. 8 */
    vec3 radiance;     /* Lambertian: J tint / (pi r^2); glossy: tint / (pi r^2) */
    float pmf;         /* probability of power-based selection */
    uint32_t slot;     /* glossy: its emission map (vbi_profile_slot); Lambertian: VBI_PROFILE_NO_SLOT */
    uint32_t material; /* its material (a glossy light's conversion kernel) */
    float support;     /* the support test's height tau_j, 0 when clear (vl_support.h) */
} vbi_vl_shade_rec;
_Static_assert(sizeof(vbi_vl_shade_rec) == 64, "vbi_vl_shade_rec: one cache line");

/* One slot of the power-selection alias table: its acceptance probability and the other rank. */
typedef struct vbi_vl_alias {
    float prob;
    uint32_t alias;
} vbi_vl_alias;

typedef struct vbi_vl_shade {
    uint32_t n;               /* 0: no light emits (no photon landed): lights are not sampled */
    vbi_vl_shade_rec *rec;   /* by rank */
    /* by slot (= rank): 8 bytes a light, apart from the records, so that a pick reads a small
     * table that stays in cache and only the picked light's record is fetched (with the table in
     * the records a pick sent to the alias waited for two records, one after the other) */
    vbi_vl_alias *alias;
} vbi_vl_shade;

/* Builds the records of the n = set->count lights: power[id] is each light's emitted power
 * (selection weight), kernels[material] its conversion kernel, support[rank] its support test
 * data (vl_support.h; NULL: no light takes the test). Lambertian radiance is read from
 * the profiles now (no conversion needed); glossy profiles are left as they are. When every power
 * is zero, out->n = 0 and VBNL_OK. Errors: VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbi_vl_shade_build(vbi_vl_shade *out, const vbi_vl_set *set, const vbi_vl_index *index,
                                vbi_profile_set *profiles, vbi_profile_kernel *const *kernels,
                                const float *power, const vbi_vl_support *support);
void vbi_vl_shade_free(vbi_vl_shade *t);
size_t vbi_vl_shade_bytes(const vbi_vl_shade *t);

/* Power-based selection with one uniform number (the alias table's rule): a rank. Its record is
 * not read. */
static inline uint32_t vbi_vl_shade_pick(const vbi_vl_shade *t, float u)
{
    float frac;
    uint32_t slot = vbi_alias_slot(t->n, u, &frac);
    const vbi_vl_alias *a = &t->alias[slot];
    return frac < a->prob ? slot : a->alias;
}

/* vbi_vl_shade_pick in two steps, so that its loads overlap other work: start draws the slot
 * and starts loading its alias entry and its light's record; finish resolves the rank (the
 * slot's light or its alias) and starts loading that record if it is the alias. */
typedef struct vbi_vl_pick {
    uint32_t slot;
    float frac;
} vbi_vl_pick;

static inline vbi_vl_pick vbi_vl_shade_pick_start(const vbi_vl_shade *t, float u)
{
    vbi_vl_pick p;
    p.slot = vbi_alias_slot(t->n, u, &p.frac);
    __builtin_prefetch(&t->alias[p.slot]);
    __builtin_prefetch(&t->rec[p.slot]);
    return p;
}

static inline uint32_t vbi_vl_shade_pick_finish(const vbi_vl_shade *t, vbi_vl_pick p)
{
    const vbi_vl_alias *a = &t->alias[p.slot];
    if (p.frac < a->prob)
        return p.slot;
    __builtin_prefetch(&t->rec[a->alias]);
    return a->alias;
}

/* Radiance leaving a point inside the light's sphere toward -w (w: the direction from the
 * shading point to it), in two steps so that a caller shading several lights can start every
 * glossy light's texel loads first: begin returns 0 when the radiance is zero (behind the light),
 * else 1, having started a glossy light's lookup in *l; end returns the radiance. */
static inline int vbi_vl_shade_radiance_begin(const vbi_vl_shade_rec *e, const vbi_profile_set *profiles, vec3 w,
                                               vbi_profile_lookup *l)
{
    if (e->slot == VBI_PROFILE_NO_SLOT)
        return v3_dot(v3_neg(w), e->normal) > 0.0f;
    frame f = frame_from_normal(e->normal);
    vec3 wo = frame_to_local(&f, v3_neg(w));
    if (!(wo.z > 0.0f))
        return 0;
    vbi_profile_lookup_begin(profiles, e->slot, wo, l);
    return 1;
}

static inline vec3 vbi_vl_shade_radiance_end(const vbi_vl_shade_rec *e, vbi_profile_set *profiles,
                                              vbi_profile_kernel *const *kernels, const vbi_profile_lookup *l)
{
    if (e->slot == VBI_PROFILE_NO_SLOT)
        return e->radiance;
    return v3_mul(vbi_profile_lookup_end(profiles, e->slot, kernels[e->material], l), e->radiance);
}

static inline vec3 vbi_vl_shade_radiance(const vbi_vl_shade_rec *e, vbi_profile_set *profiles,
                                          vbi_profile_kernel *const *kernels, vec3 w)
{
    vbi_profile_lookup l;
    return vbi_vl_shade_radiance_begin(e, profiles, w, &l) ? vbi_vl_shade_radiance_end(e, profiles, kernels, &l)
                                                            : v3s(0.0f);
}

/* Cos of the half-angle of the cone from x containing the light's sphere (-1 inside it). */
static inline float vbi_vl_shade_cone_cos(const vbi_vl_shade_rec *e, vec3 x)
{
    float d2 = v3_len2(v3_sub(e->position, x)), r2 = e->radius * e->radius;
    return d2 <= r2 ? -1.0f : sqrtf(1.0f - r2 / d2);
}

#endif
