/* VBNL stage 1: candidate virtual-light positions from camera sub-paths (Li et al. 2022, §3.1).
 *
 * The image is split into tiles of tile_size x tile_size pixels and candidates are dealt to the
 * tiles round-robin, each from a random position inside its tile: candidates are stratified over
 * the screen. A candidate sits at the first "diffuse" vertex *after* the first diffuse vertex of a
 * camera path: the point a shading point sees indirectly, where a virtual light can serve it.
 * Vertices whose sampled lobe is specular or near-specular are passed through (the paper's Fig. 6)
 * with the same policy the renderer applies (vbi_lobe_is_near_specular), at most
 * `max_specular_chain` of them per path (the authors cap chains at 4). */
#ifndef VBI_PLACEMENT_H
#define VBI_PLACEMENT_H

#include <stdint.h>

#include "bsdf.h"
#include "pool.h"
#include "render_internal.h"
#include "scene_internal.h"

/* The one specular policy of VBNL, shared by placement and rendering: a sampled lobe that is a
 * delta, or a glossy lobe of a BSDF rougher than nothing but smoother than `threshold` (GGX
 * alpha; the authors use 0.12-0.16), continues the camera path instead of being shaded with
 * virtual lights. */
static inline int vbi_lobe_is_near_specular(const vbi_bsdf *b, uint32_t lobe, float threshold)
{
    if (lobe & VBI_LOBE_SPECULAR)
        return 1;
    return (lobe & VBI_LOBE_GLOSSY) && b->alpha < threshold;
}

typedef struct vbi_candidate {
    vec3 p;            /* position */
    vec3 n;            /* unit shading normal, facing the side the camera path arrived from */
    uint32_t material;
    vec3 tint;         /* vbi_surface_light_material's colour at the candidate */
    uint32_t tile;     /* screen tile the camera path started in */
} vbi_candidate;

typedef struct vbi_placement_params {
    uint32_t count;              /* M: camera paths to trace, one candidate attempt each */
    uint32_t tile_size;          /* pixels per tile side */
    float specular_roughness;    /* near-specular threshold (GGX alpha) */
    uint32_t max_specular_chain; /* pass-through vertices per path */
    uint32_t width, height;      /* image the camera sees */
    uint64_t seed;
} vbi_placement_params;

typedef struct vbi_placement_stats {
    uint64_t paths;              /* camera paths traced */
    uint64_t rays;
    uint32_t candidates;         /* paths that produced a candidate (the rest escaped or died) */
    uint32_t through_specular;   /* candidates reached through at least one pass-through vertex */
} vbi_placement_stats;

/* Traces params->count camera sub-paths and returns the candidates (malloc'ed, in path order, so
 * the result is the same for any thread count). Work runs through `stage`, else `pool`, else
 * serially (vbi_run_items). VBNL_ERR_CANCELLED when the stage was cancelled. */
vbnl_result vbi_place_candidates(const vbnl_scene *scene, const vbi_placement_params *params,
                                  vbnl_stage_ctx *stage, vbi_pool *pool, vbi_candidate **out,
                                  uint32_t *out_count, vbi_placement_stats *stats, vbnl_error *err);

#endif
