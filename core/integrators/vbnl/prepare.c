/* VBNL preparation pipeline. */
#include "prepare.h"

#include <stdlib.h>
#include <string.h>

/* Elimination's work items through a renderer stage (progress per item). */
static int run_stage(void *ctx, uint64_t count, vbi_pool_fn fn, void *user)
{
    return vbnl_stage_run(ctx, count, fn, user);
}

vbnl_result vbi_prepare_lights(const vbnl_scene *scene, const vbi_prepare_params *p,
                                vbnl_stage_ctx *stage, vbi_pool *pool, vbi_vl_set *vls,
                                vbi_prepare_stats *stats, vbnl_error *err)
{
    if (!scene || !p || !vls)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_prepare_lights: NULL argument");
    if (p->virtual_lights == 0 || p->virtual_lights > p->candidates)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "virtual_lights (%u) must lie in [1, candidates = %u]", p->virtual_lights,
                              p->candidates);
    vbi_prepare_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof(*stats));
    memset(vls, 0, sizeof(*vls));

    /* 1. placement */
    double t0 = vbi_now();
    if (stage)
        vbnl_stage_begin(stage, "placement", p->candidates, "paths");
    vbi_placement_params pp;
    memset(&pp, 0, sizeof(pp));
    pp.count = p->candidates;
    pp.tile_size = p->tile_size;
    pp.specular_roughness = p->specular_roughness;
    pp.max_specular_chain = p->max_specular_chain;
    pp.width = p->width;
    pp.height = p->height;
    pp.seed = p->seed;
    vbi_candidate *cand = NULL;
    uint32_t ncand = 0;
    vbnl_result r = vbi_place_candidates(scene, &pp, stage, pool, &cand, &ncand, &stats->placement, err);
    if (stage)
        vbnl_stage_end(stage);
    stats->seconds[0] = vbi_now() - t0;
    stats->bytes[0] = sizeof(vbi_candidate) * (size_t)ncand;
    if (r != VBNL_OK)
        return r;

    /* 2. elimination; fewer candidates than asked (escaped paths) lower N in proportion */
    uint32_t n = p->virtual_lights;
    if (ncand < p->candidates)
        n = (uint32_t)((double)n * ncand / p->candidates);
    if (n == 0)
        n = 1;
    t0 = vbi_now();
    vec3 *pts = malloc(sizeof(vec3) * ncand);
    uint32_t *kept = malloc(sizeof(uint32_t) * n);
    float *rmax = malloc(sizeof(float) * n);
    if (!pts || !kept || !rmax) {
        free(pts);
        free(kept);
        free(rmax);
        free(cand);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for sample elimination");
    }
    for (uint32_t i = 0; i < ncand; ++i)
        pts[i] = cand[i].p;
    vbi_elim_params ep;
    vbi_elim_params_default(&ep, n);
    ep.mode = p->elimination;
    ep.parallel = p->parallel_elimination;
    if (p->neighbours)
        ep.neighbours = p->neighbours;
    ep.early_stop = p->early_stop;
    ep.seed = p->seed;
    vbi_elim_exec ex = stage ? (vbi_elim_exec){run_stage, stage} : vbi_elim_exec_pool(pool);
    if (stage)
        vbnl_stage_begin(stage, "elimination", 0, "boxes");
    r = vbi_eliminate(pts, ncand, &ep, &ex, kept, rmax, &stats->elimination, err);
    if (stage)
        vbnl_stage_end(stage);
    free(pts);
    if (r == VBNL_OK)
        r = vbi_vl_set_alloc(vls, n, err);
    if (r == VBNL_OK) {
        for (uint32_t k = 0; k < n; ++k) {
            const vbi_candidate *c = &cand[kept[k]];
            vls->position[k] = c->p;
            vls->normal[k] = c->n;
            vls->material[k] = c->material;
            vls->tint[k] = c->tint;
            vls->radius[k] = vbi_vl_radius(rmax[k], p->radius_scale);
            vls->density[k] = vbi_vl_density(vls->radius[k], p->radius_scale);
        }
    }
    stats->seconds[1] = vbi_now() - t0;
    stats->bytes[1] = vbi_vl_set_bytes(vls);
    free(kept);
    free(rmax);
    free(cand);
    return r;
}
