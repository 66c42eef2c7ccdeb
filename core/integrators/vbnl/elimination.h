/* VBNL stage 2: (adaptive, parallel) weighted sample elimination (private header).
 *
 * Selects N of M candidate positions so that the kept points form a blue-noise set, and gives
 * every kept point its maximum Poisson-disk radius r_max (Li et al. 2022, section 3.2; weighted
 * sample elimination of Yuksel 2015).
 *
 *   weight      w_i = sum_j (1 - d_ij / d_max,i)^alpha   over alive j with d_ij < d_max,i
 *               (with weight limiting, d_ij is first raised to d_min,i, see weight_limit)
 *   uniform     r_max   = sqrt(A / (2 sqrt(3) N))                        (Eq. 1)
 *   adaptive    r_i,max = sqrt(M A_i / (2 sqrt(3) N m)),  A_i = pi d_i^2  (Eq. 2)
 *               d_i = distance to the m-th nearest other candidate
 *   d_max,i = 2 r_i,max (r_i,max first clamped to max_radius when that is > 0)
 *
 * The point with the largest weight is removed (ties: smallest index first), its contribution is
 * subtracted from every alive j whose own d_max,j covered it, until N remain. The adaptive weight
 * is asymmetric (a point counts its neighbours within its own d_max), so the points a removal
 * updates are those whose d_max covered it: its neighbour list below.
 *
 * Parallel variant (section 3.2): the candidates are split by a balanced k-d tree (median splits
 * along the axis of largest extent) into 64 leaf boxes (8 for M < 32768, none below 4096: the
 * decomposition depends only on the input, never on the thread count). Every leaf eliminates
 * `early_stop` (80 %) of its excess over its share of N, in parallel; 8 leaves are then joined
 * under their common ancestor (three k-d levels up), weights are recomputed and 80 % of the
 * remaining excess goes again; the root finishes on the calling thread. A box's share of N is
 * proportional to the number of kept points its candidates are expected to carry,
 * sum_i A_i / (m 2 sqrt(3) r_i,max^2) (= M_box N / M for unclamped adaptive radii).
 *
 * Spatial index and neighbour lists: one balanced k-d tree (kdtree.h, the integrators' common
 * machinery) over all candidates, with a bounding box per node; its top levels are the parallel boxes, so every box
 * is a contiguous range of the tree's point order. The m-NN search of Eq. 2 runs a tree leaf at
 * a time: the leaf's queries share one candidate set (the points within an estimated radius R of
 * the leaf's box) and each query picks its m-th distance from it by brute force (vectorised),
 * counting the candidates under a few thresholds to select among only the handful near the m-th;
 * a query with fewer than m candidates within R is searched exactly in the tree. The result is
 * the exact m-th distance whatever R. Then every candidate q gets its neighbour list once: the
 * points j whose own d_max,j covers q, with q's term in w_j. A box's weights sum the terms of
 * its alive points' lists (in increasing tree position: the same sums for any thread count), a
 * removal subtracts the removed point's terms from the alive points of its list (decrease-key:
 * the heap keeps each slot's weight and every point its slot). These are the pairs the weight
 * sum needs, found once, instead of a radius query per point, per removal and per level; the
 * elimination order is the one those queries gave, up to the summation order of the weights.
 * Serially the lists of all candidates are built first (~8 bytes x 1.1 m per candidate: ~380 MB
 * for 1.3M candidates and m = 32); in parallel each leaf box builds its own in its work item,
 * eliminates while they are in cache, and keeps its survivors' lists, without its removed points
 * (~10% of the entries), for the joined boxes.
 * Measured alternatives: a lazy heap (stale keys refreshed when they reach the top; the same
 * removal order) was ~30% slower than decrease-key; a quickselect over all candidates within R
 * instead of the threshold windows took ~1.3x the m-NN instructions, a 64-bin histogram more;
 * a gather starting at the leaf's lowest enclosing node instead of the root saved nothing. A
 * uniform grid answered fixed-radius queries ~1.5x faster on a uniform thin slab (430 vs 650 ns
 * at 1.3M points, 30 neighbours), but one cell size cannot suit adaptive radii that vary with the
 * candidate density, and a dense 3D grid over a scene is mostly empty cells.
 *
 * Normals are not used: candidates on the two sides of a thin wall compete like any neighbours
 * (the paper's elimination uses positions only).
 *
 * Determinism: the result depends only on the points and the parameters (the seed only matters
 * for VBI_ELIM_NONE), never on the number of threads or on which worker ran which box.
 *
 * Thread-safety: vbi_eliminate may be called from several threads at once (no global state),
 * but not with the same vbi_pool (vbi_pool_run runs one job at a time); exec->run is called
 * from the calling thread, the work items it runs from any thread. */
#ifndef VBI_ELIMINATION_H
#define VBI_ELIMINATION_H

#include <stdint.h>

#include "pool.h"
#include "vbnl/result.h"
#include "vmath.h"

typedef enum vbi_elim_mode {
    VBI_ELIM_NONE = 0,     /* random subset of N (ablation "no elimination"); r_max by Eq. 2 */
    VBI_ELIM_UNIFORM = 1,  /* one r_max for all (Eq. 1) */
    VBI_ELIM_ADAPTIVE = 2, /* per-point r_max (Eq. 2): the paper's method */
} vbi_elim_mode;

#define VBI_ELIM_DEFAULT_NEIGHBOURS 32u
#define VBI_ELIM_DEFAULT_ALPHA 8.0f
#define VBI_ELIM_DEFAULT_EARLY_STOP 0.8f
/* alpha_r of section 3.2: VL radius r_i = alpha_r r_i,max. */
#define VBI_VL_DEFAULT_RADIUS_SCALE 2.0f

typedef struct vbi_elim_params {
    vbi_elim_mode mode;
    uint32_t target;     /* N, 1 <= N <= M */
    uint32_t neighbours; /* m of Eq. 2 (>= 1; clamped to M - 1). Default 32; the authors' GPU code
                          * uses 100-350 capped at 256, which makes the m-NN search ~6x slower
                          * here for a slightly better minimum distance (0.72 vs 0.705 relative
                          * radius at 300K -> 30K); m = 16 leaves close pairs (noisy radii). */
    float alpha;         /* weight exponent, 8 (Yuksel 2015) */
    float early_stop;    /* parallel: fraction of each box's excess eliminated, in (0, 1]; 0.8 */
    int parallel;        /* non-zero: the box-parallel variant */
    int weight_limit;    /* non-zero (default): Yuksel 2015 weight limiting, d_ij -> max(d_ij,
                          * d_min,i) with d_min,i = 0.65 (1 - (N/M)^1.5) d_max,i, as in Yuksel's
                          * reference code; 0: the plain weight above */
    float max_radius;    /* clamp of r_max (world units); 0 = none */
    double surface_area; /* A of Eq. 1 (uniform mode); 0 = estimate as sum_i pi d_i^2 / m */
    uint64_t seed;       /* only VBI_ELIM_NONE draws random numbers */
} vbi_elim_params;

/* Defaults above, adaptive mode, serial, the given target. */
void vbi_elim_params_default(vbi_elim_params *p, uint32_t target);

/* How work items are run. `run` must call fn(user, item, thread) once for every item in
 * 0..count-1 (any order, any threads) and return 0, or non-zero when cancelled. With a renderer,
 * wrap vbnl_stage_run (progress is then reported per item); a NULL exec, or NULL run, runs every
 * item on the calling thread. */
typedef int (*vbi_elim_run_fn)(void *ctx, uint64_t count, vbi_pool_fn fn, void *user);
typedef struct vbi_elim_exec {
    vbi_elim_run_fn run;
    void *ctx;
} vbi_elim_exec;

/* An exec running items on `pool` (NULL: the calling thread). */
vbi_elim_exec vbi_elim_exec_pool(vbi_pool *pool);

/* Optional timings and counters of one call. */
typedef struct vbi_elim_stats {
    double time_radius;      /* seconds: k-d tree + m-NN search + Eq. 1/2 */
    double time_tree;        /* seconds: of which building the k-d tree over all candidates */
    double time_eliminate;   /* seconds: elimination proper (all levels), lists included */
    double time_lists;       /* seconds: of which building the neighbour lists (serial variant;
                              * the parallel one builds them in its leaf boxes, time_level[0]) */
    double area;             /* A used by Eq. 1, or estimated (sum_i pi d_i^2 / m); 0 if unknown */
    uint32_t neighbours;     /* m actually used (after clamping), 0 if no m-NN search ran */
    uint32_t levels;         /* parallel levels run, root included (1 for serial) */
    uint32_t boxes[3];       /* boxes per level, leaves first */
    uint64_t removed[3];     /* points removed per level, leaves first */
    double time_level[3];    /* seconds per level (join moves between levels not included) */
} vbi_elim_stats;

/* Keeps `p->target` of the `count` candidate positions.
 *   out_kept: target entries, the kept candidate indices in increasing order (required);
 *   out_rmax: target entries or NULL, r_max of each kept point (clamped, Eq. 1 or 2; 0 for a
 *             point with more than m coincident candidates, whose d_i is 0);
 *   stats:    NULL or filled.
 * Errors: VBNL_ERR_INVALID_ARGUMENT (NULL pointers, N == 0, N > M, a point that is not finite
 * or has a coordinate beyond 1e18, bad
 * parameter, fewer than 2 candidates where Eq. 2 needs a neighbour, all candidates coincident),
 * VBNL_ERR_OUT_OF_MEMORY, VBNL_ERR_CANCELLED (exec->run returned non-zero). On error the outputs
 * are unspecified. */
vbnl_result vbi_eliminate(const vec3 *points, uint32_t count, const vbi_elim_params *p,
                           const vbi_elim_exec *exec, uint32_t *out_kept, float *out_rmax,
                           vbi_elim_stats *stats, vbnl_error *err);

/* Blue-noise quality of a kept set: for every kept point k with rmax[k] > 0, the distance to its
 * nearest other kept point over 2 rmax[k] (the relative radius of Lagae and Dutre 2008: disks of
 * radius r_max touch at distance 2 r_max, so hexagonal packing scores 1 and a random subset about
 * 0.47). Writes the mean and the minimum. n >= 2. Single-threaded, O(n log n). */
vbnl_result vbi_elim_measure(const vec3 *points, const uint32_t *kept, const float *rmax,
                              uint32_t n, double *mean_rel, double *min_rel, vbnl_error *err);

/* Section 3.2: VL radius r_i = alpha_r r_i,max (alpha_r = 2 in the paper). */
static inline float vbi_vl_radius(float rmax, float radius_scale) { return radius_scale * rmax; }

/* Eq. 8: VL density rho_i = alpha_r^2 / (2 sqrt(3) r_i^2) (= 1 / (2 sqrt(3) r_i,max^2), the density
 * of a hexagonal packing with disk radius r_i,max). 0 for r <= 0. */
static inline float vbi_vl_density(float r, float radius_scale)
{
    return r > 0.0f ? radius_scale * radius_scale / (3.46410161514f * r * r) : 0.0f;
}

#endif
