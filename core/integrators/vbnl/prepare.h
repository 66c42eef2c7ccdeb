/* VBNL preparation: the four stages run in order (private header).
 *
 *   1. placement     camera sub-paths -> M candidates                      (placement.h, §3.1)
 *   2. elimination   M candidates -> N virtual lights, r_i, rho_i           (elimination.h, §3.2)
 *   3. splitting     photon paths -> incident power per virtual light       (splitting.h, §3.3)
 *   4. profiles      incident power -> emission profiles, power table       (profiles.h, §3.3, §5)
 *
 * Work runs through a renderer stage (progress, cancellation, per-stage time) or, for tests and
 * benchmarks, a pool. */
#ifndef VBI_PREPARE_H
#define VBI_PREPARE_H

#include <stdint.h>

#include "elimination.h"
#include "placement.h"
#include "vl_set.h"

typedef struct vbi_prepare_params {
    uint32_t virtual_lights;     /* N */
    uint32_t candidates;         /* M >= N */
    uint32_t tile_size;
    float specular_roughness;
    uint32_t max_specular_chain;
    vbi_elim_mode elimination;
    int parallel_elimination;
    uint32_t neighbours;         /* m of Eq. 2 */
    float early_stop;
    float radius_scale;          /* alpha_r */
    uint32_t width, height;
    uint64_t seed;
} vbi_prepare_params;

typedef struct vbi_prepare_stats {
    vbi_placement_stats placement;
    vbi_elim_stats elimination;
    double seconds[4];           /* per stage, in the order above */
    size_t bytes[4];             /* memory each stage's result holds */
} vbi_prepare_stats;

/* Stages 1 and 2: fills `vls` (positions, normals, materials, r_i, rho_i). */
vbnl_result vbi_prepare_lights(const vbnl_scene *scene, const vbi_prepare_params *p,
                                vbnl_stage_ctx *stage, vbi_pool *pool, vbi_vl_set *vls,
                                vbi_prepare_stats *stats, vbnl_error *err);

#endif
