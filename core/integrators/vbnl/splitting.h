/* Photon splitting: the incident radiance field of every VBNL virtual light (private header).
 *
 * Li et al. 2022, Section 3.3. Photon paths are traced from the lights and never stored; at
 * every photon hit (the first one included) the photon's power is split among the virtual
 * lights (VLs) whose sphere contains the hit, with weights proportional to 1 - (d_i / r_i)^2
 * normalised to sum to one (a partition of unity: energy is preserved, and a hit with no VL
 * nearby deposits nothing). Each share is deposited into the VL's incident map
 * (profiles.h: vbi_profile_deposit_fixed) in the VL's local frame frame_from_normal(n_j), with
 * wi pointing toward where the photon came from. Conversion to emission profiles is later
 * (profiles.h).
 *
 * Photon paths: the photon walk of the integrators' common machinery (photon_walk.h: light by
 * power, importance transport, Russian roulette from bounce rr_depth with the authors' square-root
 * rule, no deposits on delta surfaces).
 *
 * Which VLs share a hit at p with unit normal n (facing the arriving photon) arriving from wi,
 * in this order:
 *   1. every VL j with d(p, y_j) < r_j (vbi_vl_contains of vl_index.h);
 *   2. the authors' filters: n_j . n > normal_cos (0.7) and, when require_facing, n_j . wi > 0;
 *   3. when more than VBI_SPLIT_QUERY_MAX pass, the VBI_SPLIT_QUERY_MAX with the smallest ids
 *      (counted in stats.overflow);
 *   4. the weight w_j = 1 - (float)d^2 / (r_j r_j) (d^2 in double as vbi_vl_dist2 gives it,
 *      then rounded to float) must be positive (d within rounding of r_j drops out);
 *   5. with `support`, the support test (vl_support.h: the hit's material, then no occluder
 *      between the hit and the VL at the test's height, which keeps the light trapped under a
 *      ceiling lamp or behind a thin wall out of the VLs beyond it);
 *   6. of those the max_vls (8) with the largest weights (ties: smaller id).
 * The kept VLs are taken in ascending rank (the index's spatial order, vl_index.h): the
 * normaliser is the float sum of their weights in that order, and the quantised power Q of the
 * hit is split exactly by the normalised weights w_j / sum (vbi_profile_split_fixed: floor(Q w)
 * each, the residue to the largest normalised weight, the first in rank order on ties). The
 * result is thus a function of the VLs and their ranks alone, whichever way a hit goes through
 * the code below. splitting_reference.c states these rules plainly, a hit at a time and a
 * brute-force search over all VLs; the tests hold vbi_split_photons to it bit for bit.
 *
 * Determinism: photon k (a global index in [0, photon_paths)) draws only from
 * vbi_rng_for(seed, k, 0); deposits are 64-bit fixed-point integer adds (profiles.h), so the
 * incident data are bit-identical for any thread count and chunking, and a run over paths
 * [0, a) merged (vbi_profile_set_merge) with a run over [a, N) equals the run over [0, N).
 *
 * Energy bookkeeping (exact): the photon power at a hit is quantised once (Q, fixed point);
 * the VLs' shares are an exact integer partition of Q (vbi_profile_split_fixed). The stats
 * count sum Q over the hits that deposited (covered_power), which therefore equals the sum of
 * all VLs' incident power sums exactly.
 *
 * How it runs (the work per hit is a handful of scattered memory accesses, so the order of the
 * work matters more than the arithmetic):
 *   - A work item traces `chunk` photon paths and records every non-delta hit (position,
 *     facing normal, wi, flux; 64 bytes, one cache line) in its thread's batch
 *     (vbi_split_batch_hits), which it deposits when full. A batch spans work items (a larger
 *     batch deposits more hits into each VL and glossy map while they are in cache); the last
 *     `threads` work items deposit their thread's batch before they return, and what a thread still holds
 *     after the run (its last item came earlier) is deposited by the caller.
 *   - Bins: when the index is one dense grid level (uniform radii, the common case) the hit's
 *     cell and its point in the cell's quantisation frame are computed when the hit is recorded
 *     (hits outside the grid, which no sphere contains, are not recorded), and the bin is the
 *     Morton code of the cell coordinates' top 4 bits per axis; otherwise the bin is the top 12
 *     bits of the index's Morton key (vl_index.h, vbi_vl_key_bin: 2^12 cubes of the VLs'
 *     bounding cube).
 *   - Deposit: the batch is counting-sorted by bin, then queried in that order through a
 *     software pipeline that prefetches each query's cell header, listings, hit record and
 *     candidate records a few queries ahead (splitting_batch.h, run_fast_pipe, for hits that carry
 *     their cell; the index's own pipeline, vl_index_pipe.h, otherwise), with the last stage
 *     (exact test, filters, weights of eight candidates at a time in AVX2) fused with the
 *     deposit. Consecutive queries then read the same cells and records, which stay in cache.
 *   - The split: the photon power is quantised, the weights normalised and the exact partition
 *     added into the sums for the three channels at once (AVX2, same bits as
 *     vbi_profile_split_fixed); the max_vls cap drops the smallest weights (or picks the
 *     largest, whichever takes fewer passes, then restores rank order).
 *   - The walk's hit set-up for triangle meshes (the shared vbi_fill_mesh_hit) and its
 *     Lambertian bounce in the world frame are inline (photon_fast.h, same values).
 *   - Phi_in goes into per-thread fixed-point sums indexed by the VLs' rank in the index's
 *     spatial order (nearby VLs, nearby sums; prefetched with the records), added to the
 *     profile set once at the end (integer adds: any order gives the same bits). Glossy VLs'
 *     direction maps: every worker splats with plain adds into its own 32-bit maps, which keep
 *     the low halves of its sums (a sum passing 2^32 adds its high part into the set's texel
 *     atomically, a rare event) and are added into the set at the end (profiles.h,
 *     vbi_profile_splat_prepare_lo32): half the memory of copies of the set's 64-bit maps,
 *     so fewer cache lines per splat; while the maps of all threads fit in
 *     VBI_SPLIT_MAX_MAP_COPY_BYTES and an eighth of the machine's memory, else atomic adds
 *     into the set's maps, the same bits; vbi_split_map_copy_bytes). A glossy VL's map slot
 *     rides in the zero lane of its sums and its normal comes from the record copy, so a splat
 *     reads nothing at random before its texels. Each splat is
 *     prepared and its texels prefetched, then applied 16 splats later, since the maps are large
 *     (3 KB per glossy VL and thread at 16 x 16) and the texels random. With AVX2 a splat is
 *     two rows (splitting_splat.h, splat_rows), and splats are prepared eight at a time
 *     (splat_queue_run): the frame, the footprint of vbi_hemioct_footprint and the exact
 *     integer parts of vbi_profile_splat_prepare_lo32 across the eight, then per row one 8-lane
 *     32-bit add over texels x0 and x0 + 1 (a row whose lane wraps past 2^32 is redone lane by
 *     lane with the carry; parts of 2^31 or more take the general form): the same bits as one
 *     splat at a time.
 *   Candidates reach the deposit in rank order from a single-level grid; the other ways (the
 *   index's plain queries, in id order; several levels, level by level; the max_vls selection
 *   when it picks the largest) put them back in rank order first (rare, or small).
 *   Memory beyond the profile set (stats.scratch_bytes): per thread 64 bytes per VL (a record
 *   copy and the sums: RGB and a zero lane, one AVX2 vector) and 80 bytes per batch entry (the
 *   record, its order, bin, cell and sorted cell: 21 MB for the 262,144 entries of a batch);
 *   for 100K VLs and 2 threads, ~55 MB in all. When the sums of all threads would exceed
 *   VBI_SPLIT_MAX_SUM_BYTES, the deposits are atomic adds into the profile set instead
 *   (slower, same bits); the 32-bit glossy maps add threads x half the set's incident maps
 *   (2 x 60 MB on the glossy-floor box with 2 threads).
 *   Each thread keeps eight paths in flight and traces their current rays as one rtcIntersect8
 *   packet (splitting_lanes.h, SPLIT_LANES). Packets of eight independent paths are faster than
 *   rtcIntersect1 one ray at a time (packets of consecutive rays of one path are not). A ray's
 *   answer does not depend on the other rays of its packet, so neither the thread count nor the
 *   chunking changes a bit; Embree's packet kernel may round a hit differently in the last bit
 *   from its single-ray kernel (vbi_photon_walk's), so the reference traces each of its rays
 *   alone in a packet.
 *   Loops whose trip counts vary from hit to hit cost more than their arithmetic (presumably
 *   their mispredicted exits; the VM the benchmarks run on has no branch counters), so the
 *   cell pipeline prefetches four listing blocks and eight candidates at once, whatever their
 *   counts, and stores every pre-test block packed.
 * Half the raw Embree rate needs the walk and the deposit together below Embree's own cost
 * (tests/vbnl/bench_splitting.c; figures in docs/performance.md). */
#ifndef VBI_SPLITTING_H
#define VBI_SPLITTING_H

#include <stdint.h>

#include "pool.h"
#include "profiles.h"
#include "render_internal.h"
#include "scene_internal.h"
#include "vl_index.h"
#include "vl_support.h"
#include "photon_walk.h"

#define VBI_SPLIT_DEFAULT_CHUNK 16384u /* photon paths per work item (about 4 hits each here) */
#define VBI_SPLIT_BATCH_HITS 262144u   /* photon hits a thread buffers before depositing them, */
#define VBI_SPLIT_BATCH_HITS_MIN 65536u /* down to this many when the batches of all threads */
#define VBI_SPLIT_MAX_BATCH_BYTES (256u << 20) /* would take more than this */
#define VBI_SPLIT_BIN_BITS 12u         /* spatial bins of the batch sort: 2^12 (16 per axis) */
#define VBI_SPLIT_MAX_SUM_BYTES (256u << 20) /* per-thread sums of all threads, at most */
#define VBI_SPLIT_MAX_MAP_COPY_BYTES (512u << 20) /* the 32-bit incident maps of all threads */
#define VBI_SPLIT_QUERY_MAX 64u   /* candidates read from the index per hit */
#define VBI_SPLIT_MAX_VLS 64u     /* upper bound for max_vls */

typedef struct vbi_split_desc {
    const vbnl_scene *scene;        /* committed */
    const vbi_vl_index *index;     /* the VL spheres (ids = VL ids of `profiles`), with the same
                                     * normals when a filter is on (vl_index.h) */
    const vec3 *vl_normals;         /* unit normals n_j, index count of them */
    vbi_profile_set *profiles;     /* receives the deposits; VL count = index count */
    uint64_t photon_paths;          /* N of the flux normalisation (all runs together) */
    uint64_t first_path;            /* this call traces paths [first_path, first_path + path_count) */
    uint64_t path_count;            /* 0 = photon_paths - first_path */
    uint64_t seed;
    float normal_cos;               /* keep VLs with n_j . n > normal_cos; <= -1 disables */
    int require_facing;             /* keep VLs with n_j . wi > 0 */
    uint32_t max_vls;               /* VLs sharing one hit (1 .. VBI_SPLIT_MAX_VLS) */
    int rr_depth;                   /* bounces before Russian roulette */
    int max_depth;                  /* 0 = unlimited (up to VBI_PHOTON_SAFETY_DEPTH) */
    uint32_t chunk;                 /* photon paths per work item, 0 = default (results do not
                                     * depend on it) */
    int atomic_deposits;            /* 1: no per-thread sums, atomic adds into `profiles` (what
                                     * happens beyond VBI_SPLIT_MAX_SUM_BYTES; same bits) */
    int general_walk;               /* 1: every hit through the general walk, none through the SIMD
                                     * step (splitting_lanes.h, step_fast; same bits: tests compare) */
    const vbi_vl_support *support; /* by index rank: the support test's data (vl_support.h);
                                     * NULL: no test (the paper's rule) */
} vbi_split_desc;

/* Bytes of the private 32-bit incident maps photon splitting allocates for a set whose maps take
 * `map_bytes` (vbi_profile_incident_bytes), run on `threads` workers: threads x map_bytes / 2
 * (a 32-bit map per thread) when that fits in VBI_SPLIT_MAX_MAP_COPY_BYTES and an eighth of
 * physical memory, else 0 (the atomic path). The one rule for the splitting and for vbnl's
 * memory check before any work. */
uint64_t vbi_split_map_copy_bytes(uint64_t map_bytes, unsigned threads);
/* Hits a thread's batch holds on `threads` workers: VBI_SPLIT_BATCH_HITS, fewer (down to
 * VBI_SPLIT_BATCH_HITS_MIN) when the batches would exceed VBI_SPLIT_MAX_BATCH_BYTES;
 * vbi_split_batch_bytes: the memory of one (records and sort keys). */
uint32_t vbi_split_batch_hits(unsigned threads);
uint64_t vbi_split_batch_bytes(uint32_t hits);

/* Defaults of the authors' code: normal_cos 0.7, facing on, 8 VLs, RR after bounce 5, unlimited
 * depth, chunks of 16384 paths. Scene, index, normals, profiles, counts and seed to be filled. */
void vbi_split_desc_init(vbi_split_desc *d);

typedef struct vbi_split_stats {
    uint64_t paths;         /* photon paths traced (emission samples; failed ones included) */
    uint64_t rays;          /* rays traced */
    uint64_t hits;          /* photon hits (surface interactions) */
    uint64_t delta_hits;    /* hits on delta surfaces (no deposit) */
    uint64_t simd_hits;     /* hits set up and bounced eight at a time (the SIMD step) */
    uint64_t covered_hits;  /* hits that deposited into at least one VL */
    uint64_t deposits;      /* VL deposits (<= max_vls per covered hit) */
    uint64_t overflow;      /* hits with more than VBI_SPLIT_QUERY_MAX containing spheres */
    uint64_t support_tests; /* hits whose VLs took the support test's rays (vl_support.h) */
    uint64_t support_rejects; /* VLs that a hit's support test removed */
    uint64_t covered_power[3]; /* sum of the quantised photon power of covered hits (fixed point) */
    uint64_t scratch_bytes; /* memory of the run beyond index and profiles: per-thread sums, batches */
    double seconds;
} vbi_split_stats;

/* The fixed-point unit for `photon_paths` photons of this scene: vbi_profile_unit_for_power of
 * the total light power (max channel) / photon_paths, the power of an emitted photon. */
double vbi_split_photon_unit(const vbnl_scene *scene, uint64_t photon_paths);

/* Traces the photon paths of `d` and deposits into d->profiles (adds to what it holds; the
 * call owns the set while it runs: nothing else may read or deposit into it meanwhile, since
 * the final merges use plain adds). Work items run on `stage`'s workers with
 * progress in photon paths when stage is not NULL (cancellation: VBNL_ERR_CANCELLED, deposits
 * of finished items stay), else on `pool` (which must then be given). With a stage, the caller
 * brackets the call with vbnl_stage_begin(stage, name, path count, "photons") and
 * vbnl_stage_end. Stats are summed from per-thread counters. Errors:
 * VBNL_ERR_INVALID_ARGUMENT, VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbi_split_photons(const vbi_split_desc *d, vbi_pool *pool, vbnl_stage_ctx *stage,
                               vbi_split_stats *stats);

#endif
