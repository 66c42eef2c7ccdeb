/* Spatial index over the spheres of VBNL virtual lights (private header).
 *
 * A virtual light (VL) j is a sphere of centre y_j and radius r_j (Li et al. 2022, Eq. 3: it
 * emits from the surface points within r_j of y_j). Two stages ask "which VLs contain point p":
 * photon splitting at every photon hit (Section 3.3, millions of queries) and rendering's BSDF
 * sampling gather (Section 4.1, Fig. 10a). Containment is strict, d < r_j, with d computed by
 * vbi_vl_dist2 (below) so that every variant and the tests agree bit for bit.
 *
 * Two interchangeable variants (same answers, bit-identical):
 *   VBI_VL_INDEX_GRID    multi-level uniform grid: the VLs are split into radius classes
 *                         (powers of two above the smallest radius); class L has cells of edge
 *                         cell_scale x its largest possible radius, and each sphere is listed in
 *                         every cell its bounding box overlaps (<= 8 cells per sphere for
 *                         cell_scale >= 2, <= 27 for 1). A query reads one cell per non-empty
 *                         class. Cells are a dense array when there are few enough, else an
 *                         open-addressing hash of the occupied cells. The default (faster in
 *                         photon splitting, tests/vbnl/bench_splitting.c; cell_scale 1 is
 *                         slower than 2 there and takes 3x the memory).
 *   VBI_VL_INDEX_EMBREE  an Embree BVH over the spheres' bounding boxes (user geometry) walked
 *                         by rtcPointQuery with a zero-radius query.
 *
 * Levels (grid): adaptive elimination (Eq. 2) gives radii over a few powers of two, and the
 * classes start at the smallest radius, so one outlier makes a class of its own: the Cornell
 * box's 75K VLs fall into 5 classes (1, 10K, 64K, 1.2K and 13 spheres), the door scene's 100K
 * into 7. With a level per class a query reads a cell per level, and photon splitting, whose
 * fast paths need one dense level (splitting.h), takes plain queries. So by default
 * (VBI_VL_INDEX_LEVELS_AUTO) all spheres go into one level with the cells of the most populated class (smaller spheres are
 * listed in <= 8 of its cells, larger ones in more) when that level holds at most
 * VBI_VLI_ONE_LEVEL_LISTINGS (2) times the listings of the classes; otherwise one level per
 * class. Answers are the same either way (only the order in which candidates are
 * met changes, which callers that sum in that order see in the last bit).
 *
 * Output order: ids ascending (never dependent on build or traversal details). When more than
 * max_out spheres contain p, the max_out smallest ids are written and the total is returned.
 *
 * Layout and spatial order (grid): the spheres are kept in one array of 32-byte records
 * (centre, radius, normal, id) sorted by the Morton code of their centres; the position of a
 * sphere in that array is its *rank*. A cell lists, for every sphere its box overlaps, the
 * 4-byte rank and a 4-byte copy of the sphere quantised to 8 bits per coordinate in the cell's
 * frame (centre and radius in units of 1/255 of the cell's reach), in blocks of 8 listings per
 * 64-byte line (8 quantised spheres, then their 8 ranks: a candidate's rank arrives with the
 * line its pre-test read). Every cell's listings start on a block boundary and fill whole
 * blocks (padding listings that the pre-test rejects for every point of the cell), so a query
 * reads whole blocks without lane masks, at the cost of the padding's memory. A query
 * pre-tests the quantised copies, 8 at a time with AVX2, with a bound that only rejects spheres certainly not
 * containing p (quantisation error and float rounding included), and runs the exact test of
 * vbi_vl_contains on the few that remain, so answers are exact. A sphere costs
 * 36 + 8 x (cells it overlaps) bytes, plus the padding (<= 100 at the default cell size), and the spheres found
 * by queries at nearby points lie next to each other in memory. Callers that keep per-sphere data (photon
 * splitting's sums) can index it by rank for the same locality, and can sort query points by
 * vbi_vl_index_spatial_key, the Morton code the ranks come from. The Embree variant keeps id
 * order (rank == id).
 *
 * Ownership and threads: the index copies centres, radii and normals at creation; afterwards it is
 * immutable and vbi_vl_index_query may be called from any number of threads. */
#ifndef VBI_VL_INDEX_H
#define VBI_VL_INDEX_H

#include <embree3/rtcore.h>
#include <stddef.h>
#include <stdint.h>
#if defined(__BMI2__)
#include <immintrin.h>
#endif

#include "vbnl/result.h"
#include "vmath.h"

typedef enum vbi_vl_index_kind {
    VBI_VL_INDEX_GRID = 0,
    VBI_VL_INDEX_EMBREE = 1,
} vbi_vl_index_kind;

/* Levels of the grid (see "Levels" above). */
typedef enum vbi_vl_index_levels {
    VBI_VL_INDEX_LEVELS_AUTO = 0,    /* one level when it costs at most 2x the classes' listings */
    VBI_VL_INDEX_LEVELS_CLASSES = 1, /* one level per radius class */
    VBI_VL_INDEX_LEVELS_ONE = 2,     /* one level, whatever it costs */
} vbi_vl_index_levels;

typedef struct vbi_vl_index_desc {
    const vec3 *centers;      /* count centres y_j */
    const float *radii;       /* count radii r_j (<= 0 or NaN: the VL contains nothing) */
    const vec3 *normals;      /* count unit normals n_j, or NULL (then filters are ignored) */
    uint32_t count;
    vbi_vl_index_kind kind;
    float cell_scale;         /* grid: cell edge / class radius, 0 = default (2) */
    RTCDevice device;         /* Embree variant only (the scene's device will do) */
    vbi_vl_index_levels levels; /* grid: 0 = AUTO */
} vbi_vl_index_desc;

typedef struct vbi_vl_index vbi_vl_index;

/* Errors: VBNL_ERR_INVALID_ARGUMENT (NULL arrays with count > 0, NULL out, no device for the
 * Embree variant, a non-finite centre), VBNL_ERR_OUT_OF_MEMORY, VBNL_ERR_BACKEND. */
vbnl_result vbi_vl_index_create(const vbi_vl_index_desc *desc, vbi_vl_index **out);
/* Accepts NULL. */
void vbi_vl_index_destroy(vbi_vl_index *idx);

/* Writes the ids of the spheres containing p (d < r, ascending ids, at most max_out of them)
 * and, if dist2 is not NULL, their squared distances d^2. Returns how many spheres contain p
 * (which may exceed max_out). Thread-safe. */
uint32_t vbi_vl_index_query(const vbi_vl_index *idx, vec3 p, uint32_t max_out, uint32_t *ids, float *dist2);

/* The query of photon splitting (Section 3.3, authors' filters): only spheres with
 * n_j . n > normal_cos (skipped when normal_cos <= -1) and, if facing, n_j . wi > 0 are counted
 * and written. Needs the normals given at creation (ignored otherwise). The normals sit next to
 * the centres in the grid cells, so the filter costs no extra memory traffic. Thread-safe. */
typedef struct vbi_vl_filter {
    vec3 n, wi;
    float normal_cos;
    int facing;
} vbi_vl_filter;
uint32_t vbi_vl_index_query_filtered(const vbi_vl_index *idx, vec3 p, const vbi_vl_filter *f, uint32_t max_out,
                                      uint32_t *ids, float *dist2);
int vbi_vl_index_has_normals(const vbi_vl_index *idx);
/* The filter's test of a light with unit normal nj (the one every query applies). */
static inline int vbi_vl_filter_passes(const vbi_vl_filter *f, vec3 nj)
{
    if (f->normal_cos > -1.0f && !(v3_dot(nj, f->n) > f->normal_cos))
        return 0;
    return !f->facing || v3_dot(nj, f->wi) > 0.0f;
}

/* The ranks of the spheres that may contain p, for callers that keep their own per-rank copy of
 * centre, radius and normal and test containment (vbi_vl_contains) and the filter themselves,
 * so that a query reads only the cells and the caller's records: every sphere containing p is
 * listed, once, with others that passed the grid's quantised pre-test (in level and listing
 * order: deterministic, a function of the index and p). Writes at most max_out ranks and returns
 * how many there are; more than max_out means they did not fit (the Embree variant lists the
 * spheres containing p, and reports max_out + 1 when more than VBI_VL_BATCH_MAX_OUT do).
 * Thread-safe. */
uint32_t vbi_vl_index_candidates(const vbi_vl_index *idx, vec3 p, uint32_t max_out, uint32_t *ranks);

/* vbi_vl_index_candidates in three stages, so that its dependent loads overlap the caller's
 * other work: begin locates p's cells and starts loading their headers; fetch reads the headers
 * and starts loading the cells' listings; candidates pre-tests the listings and returns what
 * vbi_vl_index_candidates(idx, p, ...) returns (the same ranks in the same order). The Embree
 * variant, and grids of more than VBI_VL_LOOKUP_LEVELS levels, run the whole query in
 * candidates. The record is the caller's (no allocation); the stages run in this order. */
#define VBI_VL_LOOKUP_LEVELS 8u
typedef struct vbi_vl_lookup {
    vec3 p;
    uint32_t levels; /* levels located (0: the whole query runs in candidates) */
    uint32_t cell[VBI_VL_LOOKUP_LEVELS];
    int32_t c3[VBI_VL_LOOKUP_LEVELS][3];
    uint32_t s0[VBI_VL_LOOKUP_LEVELS], n[VBI_VL_LOOKUP_LEVELS];
} vbi_vl_lookup;
void vbi_vl_index_lookup_begin(const vbi_vl_index *idx, vec3 p, vbi_vl_lookup *l);
void vbi_vl_index_lookup_fetch(const vbi_vl_index *idx, vbi_vl_lookup *l);
uint32_t vbi_vl_index_lookup_candidates(const vbi_vl_index *idx, const vbi_vl_lookup *l, uint32_t max_out,
                                         uint32_t *ranks);

/* What vbi_vl_index_query_found returns per sphere: id, rank, d^2 (as dist2 above) and r. */
typedef struct vbi_vl_found {
    uint32_t id, rank;
    float d2, r;
} vbi_vl_found;
/* vbi_vl_index_query_filtered (f may be NULL: no filter) with one record per sphere, in the
 * same order and with the same cap. Thread-safe. */
uint32_t vbi_vl_index_query_found(const vbi_vl_index *idx, vec3 p, const vbi_vl_filter *f, uint32_t max_out,
                                   vbi_vl_found *found);

/* Spatial order (see above): the rank of sphere `id`, the id of rank `rank` (both bijections
 * of [0, count)), and the 63-bit Morton code of p on the index's key grid (a cube over the
 * centres, 2^21 cells per axis; points outside are clamped to it). Spheres are ranked by the
 * key of their centres (ties: smaller id first). */
uint32_t vbi_vl_index_rank(const vbi_vl_index *idx, uint32_t id);
uint32_t vbi_vl_index_id(const vbi_vl_index *idx, uint32_t rank);
uint64_t vbi_vl_index_spatial_key(const vbi_vl_index *idx, vec3 p);
/* The key grid itself, for callers that need only the coarse bits of the key inline (photon
 * splitting bins every hit): vbi_vl_key_bin(g, p, b) == vbi_vl_index_spatial_key(idx, p) >>
 * (63 - 3 b) for g = vbi_vl_index_key_grid(idx), 1 <= b <= 8. */
typedef struct vbi_vl_key_grid {
    vec3 lo;
    float scale;
} vbi_vl_key_grid;
vbi_vl_key_grid vbi_vl_index_key_grid(const vbi_vl_index *idx);
#define VBI_VL_KEY_BITS 21u /* bits per axis of the spatial key */
/* Cell coordinate of v on one axis of the key grid (points outside clamped; NaN -> 0). */
static inline uint32_t vbi_vl_key_coord(float v, float lo, float scale)
{
    float f = (v - lo) * scale;
    const float top = (float)((1u << VBI_VL_KEY_BITS) - 1u);
    return !(f > 0.0f) ? 0u : (f >= top ? (uint32_t)top : (uint32_t)f);
}
static inline uint32_t vbi_vl_key_spread_bits(uint32_t v, unsigned b) /* bit i -> bit 3 i */
{
#if defined(__BMI2__)
    return _pdep_u32(v, 01111111111u & ((1u << (3 * b)) - 1u));
#else
    uint32_t out = 0;
    for (unsigned i = 0; i < b; ++i)
        out |= (v >> i & 1u) << (3 * i);
    return out;
#endif
}
static inline uint32_t vbi_vl_key_bin(const vbi_vl_key_grid *g, vec3 p, unsigned b)
{
    unsigned sh = VBI_VL_KEY_BITS - b;
    return vbi_vl_key_spread_bits(vbi_vl_key_coord(p.x, g->lo.x, g->scale) >> sh, b) |
           vbi_vl_key_spread_bits(vbi_vl_key_coord(p.y, g->lo.y, g->scale) >> sh, b) << 1 |
           vbi_vl_key_spread_bits(vbi_vl_key_coord(p.z, g->lo.z, g->scale) >> sh, b) << 2;
}

/* Batched filtered queries (photon splitting deposits sorted batches of hits): the answers of
 * vbi_vl_index_query_found for `count` points, handed to fn in point order, computed as a
 * software pipeline that overlaps the memory accesses of consecutive queries (the gain grows
 * with the index size). Same sets, total and records as one query per point, but in rank order
 * (deterministic: a function of the index and the point) instead of id order, except when
 * capped (total > max_out: then the max_out smallest ids, ascending, as the plain query).
 * Point k's record is at base + order[k] * stride (order NULL: k) and is prefetched ahead. Point k's position is the
 * vec3 at p_off in its record; with `filter`, its n and wi (vbi_vl_filter) are at n_off and
 * wi_off. rank_data (optional) is the caller's array of per-rank records (rank_stride
 * bytes each): the records of each point's candidate spheres are prefetched before fn runs.
 * max_out <= VBI_VL_BATCH_MAX_OUT. `found` is valid during the call only. Thread-safe. */
#define VBI_VL_BATCH_MAX_OUT 64u
typedef struct vbi_vl_batch {
    uint32_t count;
    const uint32_t *order;
    const void *base;
    size_t stride, p_off, n_off, wi_off;
    int filter;
    float normal_cos;
    int facing;
    uint32_t max_out;
    const void *rank_data;
    size_t rank_stride;
} vbi_vl_batch;
typedef void (*vbi_vl_batch_fn)(void *user, uint32_t k, uint32_t total, const vbi_vl_found *found, uint32_t n);
void vbi_vl_index_query_batch(const vbi_vl_index *idx, const vbi_vl_batch *b, vbi_vl_batch_fn fn, void *user);

uint32_t vbi_vl_index_count(const vbi_vl_index *idx);
vec3 vbi_vl_index_center(const vbi_vl_index *idx, uint32_t id);
float vbi_vl_index_radius(const vbi_vl_index *idx, uint32_t id);
vbi_vl_index_kind vbi_vl_index_get_kind(const vbi_vl_index *idx);
/* Grid levels (0 for the Embree variant or a grid without usable spheres). */
uint32_t vbi_vl_index_level_count(const vbi_vl_index *idx);
/* Bytes held by the index (for Embree: the records plus an estimate of the BVH, 2 x 32 B per
 * sphere, since Embree does not report it per scene). */
size_t vbi_vl_index_bytes(const vbi_vl_index *idx);

/* Squared distance used for containment, d^2 < r^2 with r^2 = (double)r * r. The differences
 * are float subtractions and the products of floats are exact in double, so the result does not
 * depend on FMA contraction or inlining: every caller gets the same bits. */
static inline double vbi_vl_dist2(vec3 a, vec3 b)
{
    float dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
    return (double)dx * dx + (double)dy * dy + (double)dz * dz;
}
static inline int vbi_vl_contains(vec3 center, float radius, vec3 p, double *d2)
{
    *d2 = vbi_vl_dist2(p, center);
    return radius > 0.0f && *d2 < (double)radius * radius; /* r <= 0 or NaN: contains nothing */
}

#endif
