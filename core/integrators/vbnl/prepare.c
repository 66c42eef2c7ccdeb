/* VBNL preparation pipeline. */
#include "prepare.h"

#include <stdlib.h>
#include <string.h>

/* Elimination's work items through a renderer stage (progress per item). */
static int run_stage(void *ctx, uint64_t count, vbnl_pool_fn fn, void *user)
{
    return vbnl_stage_run(ctx, count, fn, user);
}

vbnl_result vbnl_prepare_lights(const vbnl_scene *scene, const vbnl_prepare_params *p,
                                vbnl_stage_ctx *stage, vbnl_pool *pool, vbnl_vl_set *vls,
                                vbnl_prepare_stats *stats, vbnl_error *err)
{
    if (!scene || !p || !vls)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_prepare_lights: NULL argument");
    if (p->virtual_lights == 0 || p->virtual_lights > p->candidates)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "virtual_lights (%u) must lie in [1, candidates = %u]", p->virtual_lights,
                              p->candidates);
    vbnl_prepare_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof(*stats));
    memset(vls, 0, sizeof(*vls));

    /* 1. placement */
    double t0 = vbnl_now();
    if (stage)
        vbnl_stage_begin(stage, "placement", p->candidates, "paths");
    vbnl_placement_params pp;
    memset(&pp, 0, sizeof(pp));
    pp.count = p->candidates;
    pp.tile_size = p->tile_size;
    pp.specular_roughness = p->specular_roughness;
    pp.max_specular_chain = p->max_specular_chain;
    pp.width = p->width;
    pp.height = p->height;
    pp.seed = p->seed;
    vbnl_candidate *cand = NULL;
    uint32_t ncand = 0;
    vbnl_result r = vbnl_place_candidates(scene, &pp, stage, pool, &cand, &ncand, &stats->placement, err);
    if (stage)
        vbnl_stage_end(stage);
    stats->seconds[0] = vbnl_now() - t0;
    stats->bytes[0] = sizeof(vbnl_candidate) * (size_t)ncand;
    if (r != VBNL_OK)
        return r;

    /* 2. elimination; fewer candidates than asked (escaped paths) lower N in proportion */
    uint32_t n = p->virtual_lights;
    if (ncand < p->candidates)
        n = (uint32_t)((double)n * ncand / p->candidates);
    if (n == 0)
        n = 1;
    t0 = vbnl_now();
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
    vbnl_elim_params ep;
    vbnl_elim_params_default(&ep, n);
    ep.mode = p->elimination;
    ep.parallel = p->parallel_elimination;
    if (p->neighbours)
        ep.neighbours = p->neighbours;
    ep.early_stop = p->early_stop;
    ep.seed = p->seed;
    vbnl_elim_exec ex = stage ? (vbnl_elim_exec){run_stage, stage} : vbnl_elim_exec_pool(pool);
    if (stage)
        vbnl_stage_begin(stage, "elimination", 0, "boxes");
    r = vbnl_eliminate(pts, ncand, &ep, &ex, kept, rmax, &stats->elimination, err);
    if (stage)
        vbnl_stage_end(stage);
    free(pts);
    if (r == VBNL_OK)
        r = vbnl_vl_set_alloc(vls, n, err);
    if (r == VBNL_OK) {
        for (uint32_t k = 0; k < n; ++k) {
            const vbnl_candidate *c = &cand[kept[k]];
            vls->position[k] = c->p;
            vls->normal[k] = c->n;
            vls->material[k] = c->material;
            vls->tint[k] = c->tint;
            vls->radius[k] = vbnl_vl_radius(rmax[k], p->radius_scale);
            vls->density[k] = vbnl_vl_density(vls->radius[k], p->radius_scale);
        }
    }
    stats->seconds[1] = vbnl_now() - t0;
    stats->bytes[1] = vbnl_vl_set_bytes(vls);
    free(kept);
    free(rmax);
    free(cand);
    return r;
}
