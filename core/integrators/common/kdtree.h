/* k-d tree over points (private header of the integrators' common machinery): `vbnl`'s sample
 * elimination (its m-th neighbour distances and box gathers, elimination.h), `vsl`'s sphere radii
 * and `richvsl`'s importon, photon and light maps.
 *
 * A balanced tree built by median splits along the axis of largest extent; the points are
 * permuted into tree order, so that spatial neighbours are close in memory, and carry their
 * global index (`id`); every node keeps the bounding box of its points. Radius and k-nearest
 * queries, and gathers of the points near a box; all are exact and their results do not depend
 * on anything but the points.
 *
 * Ownership and threads: the tree does not own its points; a built tree is only read by the
 * queries, which any number of threads may run at once. */
#ifndef VBI_KDTREE_H
#define VBI_KDTREE_H

#include <math.h>
#include <stdint.h>

#define VBI_KD_LEAF 16u      /* points per leaf at most */
#define VBI_KD_LEAF_AXIS 3u  /* vbi_kd_node.axis of a leaf */

typedef struct vbi_kd_pt {
    float p[3];
    uint32_t id; /* global index (elimination also uses it as the tie-breaker) */
} vbi_kd_pt;

/* The left child is the next node (depth-first layout, so a subtree is a contiguous node range
 * and a contiguous point range); a leaf holds pts[begin, end). */
typedef struct vbi_kd_node {
    float split;
    uint32_t axis;
    uint32_t begin, end;
    uint32_t right;
} vbi_kd_node;

typedef struct vbi_kd_tree {
    vbi_kd_pt *pts; /* not owned */
    vbi_kd_node *nodes;
    float *box;      /* 6 floats per node: the bounding box of its points, lo xyz then hi xyz */
    uint32_t n, node_count;
} vbi_kd_tree;

/* A subtree left to build: node index and point range. */
typedef struct vbi_kd_subtree {
    uint32_t node, begin, end;
} vbi_kd_subtree;

static inline float vbi_kd_dist2(const float *a, const float *b)
{
    float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* Builds over pts[0..n) (filled by the caller), permuting them. 0, or -1 when out of memory. */
int vbi_kd_build(vbi_kd_tree *t, vbi_kd_pt *pts, uint32_t n);
/* Parallel build: builds the top `levels` levels only and records the (at most 2^levels)
 * subtrees below them in jobs[]; the tree is complete once vbi_kd_build_subtree ran for every
 * job, in any order or concurrently (they touch disjoint nodes and points). The result is the
 * tree vbi_kd_build makes. */
int vbi_kd_build_top(vbi_kd_tree *t, vbi_kd_pt *pts, uint32_t n, uint32_t levels,
                      vbi_kd_subtree *jobs, uint32_t *njobs);
void vbi_kd_build_subtree(vbi_kd_tree *t, const vbi_kd_subtree *job);
/* One level of a job: builds its node and leaves its (at most 2) children as jobs in out[]. */
void vbi_kd_build_split(vbi_kd_tree *t, const vbi_kd_subtree *job, vbi_kd_subtree *out,
                         uint32_t *nout);
/* Frees the nodes and boxes (not the points); t may be zeroed or already freed. */
void vbi_kd_free(vbi_kd_tree *t);

/* All points with squared distance <= r2 of q: local indices (into t->pts) and squared
 * distances, at most `cap` of them; returns the count, or cap + 1 when there were more. */
uint32_t vbi_kd_radius(const vbi_kd_tree *t, const float *q, float r2, uint32_t *out_i,
                        float *out_d2, uint32_t cap);

/* The k points nearest to q other than local point `skip` (UINT32_MAX: none), in increasing
 * order of (squared distance, id): their local indices (into t->pts) and squared distances
 * (vbi_kd_dist2(q, p)) in out_i[0..k) and out_d2[0..k). Returns how many were found: k, or
 * fewer when the tree holds fewer points. So out_d2[m - 1] is the squared distance to the m-th
 * nearest neighbour (for a point of the tree, with skip = its local index). Exact: the result
 * depends on the points only, never on the tree's shape. */
uint32_t vbi_kd_knn(const vbi_kd_tree *t, const float q[3], uint32_t k, uint32_t skip, uint32_t *out_i,
                     float *out_d2);
/* The squared distance from local point `self` to its m-th nearest other point,
 * 1 <= m <= n - 1: out_d2[m - 1] of vbi_kd_knn(t, its position, m, self), the same search
 * without sorting its answer; idx and d2 are the caller's scratch of m entries each. */
float vbi_kd_mth_dist2(const vbi_kd_tree *t, uint32_t self, uint32_t m, uint32_t *idx, float *d2);

/* Squared distance from point q to the box lo..hi (0 inside). */
static inline float vbi_kd_box_dist2(const float *lo, const float *hi, const float *q)
{
    float s = 0.0f;
    for (int a = 0; a < 3; ++a) {
        float g = lo[a] - q[a] > q[a] - hi[a] ? lo[a] - q[a] : q[a] - hi[a];
        s += g > 0.0f ? g * g : 0.0f;
    }
    return s;
}

/* All points whose squared distance to the box lo..hi is <= r2: local indices in depth-first
 * order, at most `cap`; returns the count, or cap + 1 when there were more. */
uint32_t vbi_kd_gather_box(const vbi_kd_tree *t, const float *lo, const float *hi, float r2,
                            uint32_t *out_i, uint32_t cap);

/* All points j whose squared distance to the box lo..hi is < pt_r2[j] (a per-point reach, by
 * local index): the points whose reach may cover a point of the box. node_r2[k] must bound
 * pt_r2 over node k's points from above. Same output convention as vbi_kd_gather_box. */
uint32_t vbi_kd_gather_reach(const vbi_kd_tree *t, const float *lo, const float *hi,
                              const float *node_r2, const float *pt_r2, uint32_t *out_i,
                              uint32_t cap);

#endif
