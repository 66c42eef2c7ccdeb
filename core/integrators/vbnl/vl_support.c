/* The support test's probes: which virtual lights need it (vl_support.h). */
#include "vl_support.h"

#include <math.h>
#include <stdlib.h>

#define SUPPORT_CHUNK 256u /* VLs per work item */
#define SUPPORT_DIRS 16u   /* probe directions across the disk */
#define SUPPORT_HEIGHT 1.0f /* tau_j / r_j (vl_support.h) */

typedef struct support_job {
    const vbnl_scene *sc;
    const vbi_vl_set *set;
    const vbi_vl_index *index;
    vbi_vl_support *out;
    uint32_t *tested; /* per item */
    uint64_t *rays;   /* per item */
} support_job;

/* Probes a VL: one ray up from its centre, then SUPPORT_DIRS rays across the disk at height
 * tau = SUPPORT_HEIGHT r, and one ray up from each of SUPPORT_DIRS points of the disk (two rings, at 0.5 r
 * and 0.9 r, their directions interleaved), all to r. Returns tau when any of them hit, else 0
 * (clear). */
static float probe(const vbnl_scene *sc, vec3 c, vec3 n, float r, uint64_t *rays)
{
    if (!(r > 0.0f))
        return 0.0f;
    const float tau = SUPPORT_HEIGHT * r;
    int hit = vbi_scene_occluded_inline(sc, vbi_offset_ray_origin_along(c, n), n, r);
    *rays += 1;
    frame f = frame_from_normal(n);
    const vec3 e = v3_fma(c, n, tau);
    const float lift = 1e-3f * r;
    for (uint32_t k = 0; k < SUPPORT_DIRS && !hit; ++k) {
        float phi = (float)k * (2.0f * VBI_PI / (float)SUPPORT_DIRS);
        vec3 u = v3_add(v3_scale(f.s, cosf(phi)), v3_scale(f.t, sinf(phi)));
        *rays += 1;
        if (vbi_scene_occluded_inline(sc, e, u, r)) {
            hit = 1;
            break;
        }
        float phi2 = phi + (k & 1u ? VBI_PI / (float)SUPPORT_DIRS : 0.0f);
        vec3 u2 = v3_add(v3_scale(f.s, cosf(phi2)), v3_scale(f.t, sinf(phi2)));
        vec3 q = v3_fma(v3_fma(c, u2, (k & 1u ? 0.9f : 0.5f) * r), n, lift);
        *rays += 1;
        hit = vbi_scene_occluded_inline(sc, q, n, r);
    }
    return hit ? tau : 0.0f;
}

static void support_chunk(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    support_job *job = user;
    const vbi_vl_set *set = job->set;
    uint32_t begin = (uint32_t)item * SUPPORT_CHUNK;
    uint32_t end = begin + SUPPORT_CHUNK < set->count ? begin + SUPPORT_CHUNK : set->count;
    uint32_t tested = 0;
    uint64_t rays = 0;
    for (uint32_t id = begin; id < end; ++id) {
        float tau = probe(job->sc, set->position[id], set->normal[id], set->radius[id], &rays);
        job->out[vbi_vl_index_rank(job->index, id)] = (vbi_vl_support){tau, vbi_material_surface(job->sc, set->material[id])};
        tested += tau > 0.0f;
    }
    job->tested[item] = tested;
    job->rays[item] = rays;
}

vbnl_result vbi_vl_support_build(const vbnl_scene *sc, const vbi_vl_set *set, const vbi_vl_index *index,
                                  vbnl_stage_ctx *stage, vbi_pool *pool, vbi_vl_support *by_rank,
                                  vbi_vl_support_stats *stats)
{
    uint64_t items = ((uint64_t)set->count + SUPPORT_CHUNK - 1) / SUPPORT_CHUNK;
    if (stats)
        *stats = (vbi_vl_support_stats){0, 0};
    if (items == 0)
        return VBNL_OK;
    support_job job = {sc, set, index, by_rank, calloc(items, sizeof(uint32_t)), calloc(items, sizeof(uint64_t))};
    vbnl_result r = VBNL_ERR_OUT_OF_MEMORY;
    if (job.tested && job.rays)
        r = vbi_run_items(stage, pool, items, support_chunk, &job) == 0 ? VBNL_OK : VBNL_ERR_CANCELLED;
    for (uint64_t i = 0; r == VBNL_OK && stats && i < items; ++i) {
        stats->tested += job.tested[i];
        stats->rays += job.rays[i];
    }
    free(job.tested);
    free(job.rays);
    return r;
}
