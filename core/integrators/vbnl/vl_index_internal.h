/* Internals of the VL sphere index shared by vl_index.c (build, single queries, Embree) and
 * vl_index_batch.c (the pipelined batch query): the layout (vl_index.h, "Layout") and the
 * inline query helpers. Private to these two files and to vl_index_pipe.h (the batch pipeline,
 * which photon splitting runs with its own last stage). */
#ifndef VBI_VL_INDEX_INTERNAL_H
#define VBI_VL_INDEX_INTERNAL_H

#include <stdlib.h>
#include <string.h>
#if defined(__AVX2__) || defined(__BMI2__)
#include <immintrin.h>
#endif

#include "vl_index.h"

#define VBI_VLI_MAX_LEVELS 32u
#define VBI_VLI_DEFAULT_CELL_SCALE 2.0f
#define VBI_VLI_ONE_LEVEL_LISTINGS 2.0 /* AUTO levels: one level up to this many times the listings of the classes */
#define VBI_VLI_EMPTY_KEY UINT64_MAX
#define VBI_VLI_KEY_BITS VBI_VL_KEY_BITS /* spatial key: bits per axis (3 x 21 = 63-bit Morton code) */

/* One sphere, 32 bytes (half a cache line), stored by rank: centre and radius first (the
 * containment test), the normal (the splitting filter) and the id after them. */
typedef struct vl_rec {
    float cx, cy, cz, r;
    float nx, ny, nz;
    uint32_t id;
} vl_rec;

/* The exact test of a query against one record: the point lies strictly inside the sphere
 * (d^2 < r^2 in double, = vbi_vl_dist2) and the light passes the normal-cone and facing filters
 * that are on. Returns 1 and d^2. Shared by every batched query (vl_index_batch.c) and the fused
 * deposit of splitting, so both keep the same lights. */
static inline int vbi_vli_accept(const vl_rec *e, vec3 p, int use_cos, vec3 n, float ncos, int use_facing, vec3 wi,
                                  double *d2_out)
{
    float dx = p.x - e->cx, dy = p.y - e->cy, dz = p.z - e->cz, r = e->r;
    double d2 = (double)dx * dx + (double)dy * dy + (double)dz * dz;
    if (!(r > 0.0f && d2 < (double)r * r))
        return 0;
    vec3 nj = v3(e->nx, e->ny, e->nz);
    if (use_cos && !(v3_dot(nj, n) > ncos))
        return 0;
    if (use_facing && !(v3_dot(nj, wi) > 0.0f))
        return 0;
    *d2_out = d2;
    return 1;
}

typedef struct grid_level {
    float cell, inv_cell;     /* cell edge and its inverse */
    vec3 lo;                  /* grid origin (the level's bounding box minimum) */
    int32_t n[3];             /* cells per axis */
    uint32_t sphere_count;
    /* dense: start[c] .. start[c + 1] for linear cell c (n0 n1 n2 + 1 entries);
     * hashed: keys/slot of 2^hash_bits entries, start indexed by slot (occupied + 1). */
    int dense;
    uint32_t *start;
    uint64_t *keys;
    uint32_t *slot;
    uint32_t hash_mask;
    /* The listings of all cells, in blocks of 8 (VBI_VLI_QENT, VBI_VLI_RANK): a 64-byte line
     * holds the quantised spheres of 8 consecutive listings (centre and radius in 8 bits each in
     * the cell's frame, x | y << 8 | z << 16 | r << 24, see quantize_entry), then their ranks,
     * ascending within a cell. A candidate's rank thus sits in the line its pre-test read (two
     * arrays cost a second dependent miss per query). One spare block past the last listing. */
    uint32_t *lst;
    size_t lst_bytes;
    float q_off, q_scale;     /* cell frame: q = (v - cell origin + q_off) * q_scale */
} grid_level;

struct vbi_vl_index {
    vbi_vl_index_kind kind;
    uint32_t count;
    int has_normals;
    /* Spheres in Morton order of their centres (grid) or in id order (Embree): rec[rank]. A
     * cell lists 4-byte ranks instead of copies of the spheres (8 listings per sphere at the
     * default cell size: 32 bytes instead of 256), and the spheres of neighbouring cells sit
     * next to each other in rec, so a query touches few cache lines and rank-indexed data of
     * the caller (vbi_vl_index_rank) get the same locality. */
    vl_rec *rec;
    uint32_t *rank_of;        /* id -> rank; NULL: identity (Embree) */
    /* spatial key (vbi_vl_index_spatial_key): a cube over the centres, 2^VBI_VLI_KEY_BITS cells/axis */
    vec3 key_lo;
    float key_scale;
    /* grid */
    grid_level levels[VBI_VLI_MAX_LEVELS];
    uint32_t level_count;
    float r_min;
    size_t bytes;
    /* Embree */
    RTCScene rtc;
};

/* ---- sorted, capped output (shared by both variants) ---------------------------------------- */

typedef struct query_out {
    uint32_t *ids;
    float *dist2;
    vbi_vl_found *found;     /* instead of ids/dist2 (vbi_vl_index_query_found) */
    uint32_t max_out, n, total;
    const vbi_vl_filter *f;  /* NULL: no filter */
    int sorted;               /* found[] is in id order (else in arrival order) */
} query_out;

/* Insertion sort by id (ids are distinct). */
static inline void found_sort(vbi_vl_found *a, uint32_t n)
{
    for (uint32_t i = 1; i < n; ++i) {
        vbi_vl_found v = a[i];
        uint32_t k = i;
        while (k > 0 && a[k - 1].id > v.id) {
            a[k] = a[k - 1];
            --k;
        }
        a[k] = v;
    }
}

static inline int passes(const vbi_vl_filter *f, vec3 nj) { return vbi_vl_filter_passes(f, nj); }

/* Keeps the max_out smallest ids in ascending order (insertion: a query finds a handful). */
static inline void out_add(query_out *o, const vl_rec *e, uint32_t rank, double d2)
{
    uint32_t id = e->id;
    o->total++;
    uint32_t n = o->n;
    if (o->found) {
        /* Records are appended unsorted while they fit (found_finish sorts them); the capped
         * insertion starts only when more than max_out spheres contain p (rare). */
        vbi_vl_found *a = o->found, rec = {id, rank, (float)d2, e->r};
        if (n < o->max_out && !o->sorted) {
            a[n] = rec;
            o->n = n + 1;
            return;
        }
        if (!o->sorted) {
            found_sort(a, n);
            o->sorted = 1;
        }
        if (n == 0 || id > a[n - 1].id)
            return;
        uint32_t k = n - 1; /* drop the largest id */
        while (k > 0 && a[k - 1].id > id) {
            a[k] = a[k - 1];
            --k;
        }
        a[k] = rec;
        return;
    }
    if (n == o->max_out) {
        if (n == 0 || id > o->ids[n - 1])
            return;
        --n;
    }
    uint32_t k = n;
    while (k > 0 && o->ids[k - 1] > id) {
        o->ids[k] = o->ids[k - 1];
        if (o->dist2)
            o->dist2[k] = o->dist2[k - 1];
        --k;
    }
    o->ids[k] = id;
    if (o->dist2)
        o->dist2[k] = (float)d2;
    o->n = n + 1;
}

/* Containment of p in sphere e, exactly as vbi_vl_contains, with a cheap float test first
 * that only rejects spheres certainly outside: d2f (float, any rounding or contraction) is
 * within 3 ulp (2^-22.4) of the d^2 of vbi_vl_dist2 (exact products of the same float
 * differences, summed in double), and the bound fl(fl(r r) (1 + 2^-20)) exceeds r^2 by more
 * than that; the floor 2^-100 keeps the bound valid where r r underflows. Most candidates of a
 * cell are outside, so most never reach the double test. */
static inline int rec_contains(const vl_rec *e, vec3 p, double *d2)
{
    float dx = p.x - e->cx, dy = p.y - e->cy, dz = p.z - e->cz;
    float d2f = dx * dx + dy * dy + dz * dz, r = e->r, bound = r * r * (1.0f + 0x1p-20f);
    if (!(d2f < bound) && !(d2f < 0x1p-100f)) /* also NaN */
        return 0;
    *d2 = (double)dx * dx + (double)dy * dy + (double)dz * dz; /* = vbi_vl_dist2(p, centre) */
    return r > 0.0f && *d2 < (double)r * r;
}

static inline void test_rec(const vl_rec *e, uint32_t rank, vec3 p, query_out *o)
{
    double d2;
    if (rec_contains(e, p, &d2) && (!o->f || passes(o->f, v3(e->nx, e->ny, e->nz))))
        out_add(o, e, rank, d2);
}

/* test_rec for a sphere that passed the quantised pre-test: the exact test alone. */
static inline void test_rec_exact(const vl_rec *e, uint32_t rank, vec3 p, query_out *o)
{
    float dx = p.x - e->cx, dy = p.y - e->cy, dz = p.z - e->cz, r = e->r;
    double d2 = (double)dx * dx + (double)dy * dy + (double)dz * dz; /* = vbi_vl_dist2(p, centre) */
    if (r > 0.0f && d2 < (double)r * r && (!o->f || passes(o->f, v3(e->nx, e->ny, e->nz))))
        out_add(o, e, rank, d2);
}

/* ---- grid cells ---------------------------------------------------------------------------- */

static inline uint64_t hash_key(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    return k;
}

static inline int32_t cell_coord(const grid_level *g, float v, float lo, int a)
{
    float f = floorf((v - lo) * g->inv_cell);
    return f < 0.0f ? 0 : (f >= (float)g->n[a] ? g->n[a] - 1 : (int32_t)f);
}

static inline uint64_t linear_cell(const grid_level *g, int32_t x, int32_t y, int32_t z)
{
    return (uint64_t)x + (uint64_t)g->n[0] * ((uint64_t)y + (uint64_t)g->n[1] * (uint64_t)z);
}

/* Slot of cell key in the hash (inserting it when `insert`), or UINT32_MAX. */
static inline uint32_t hash_find(grid_level *g, uint64_t key, int insert, uint32_t *next_slot)
{
    uint32_t h = (uint32_t)hash_key(key) & g->hash_mask;
    for (;;) {
        if (g->keys[h] == key)
            return g->slot[h];
        if (g->keys[h] == VBI_VLI_EMPTY_KEY) {
            if (!insert)
                return UINT32_MAX;
            g->keys[h] = key;
            g->slot[h] = (*next_slot)++;
            return g->slot[h];
        }
        h = (h + 1) & g->hash_mask;
    }
}

static inline vec3 rec_center(const vl_rec *e) { return v3(e->cx, e->cy, e->cz); }

/* ---- quantised pre-test ----------------------------------------------------------------------
 * Every listing also stores its sphere in 4 bytes: centre and radius in units h of the cell's
 * frame, whose origin is the cell's corner minus q_off (the largest radius and box padding of
 * the level) and which spans E = cell + 2 q_off = 255 h per axis, so every centre listed in the
 * cell fits in 8 bits. Centres are rounded (error <= sqrt(3)/2 h), radii rounded up. A query
 * point p at distance d_q from the quantised centre can lie inside the sphere only if
 * d_q < r_q + VBI_VLI_QSLACK (VBI_VLI_QSLACK: the centre error plus float rounding of both frames, which use
 * the same float origin and therefore the same rounding); spheres failing that are certainly
 * outside and skipped, the others get the exact test (rec_contains). A listing whose sphere
 * does not quantise within these bounds gets r_q = 255 and is always tested. 8 listings are
 * pre-tested at once with AVX2. */
#define VBI_VLI_QSLACK 0.8761f /* sqrt(3) / 2 + 0.01 */

static inline float cell_origin(const grid_level *g, int32_t c, float lo) { return lo + (float)c * g->cell; }

/* p in cell c3's quantisation frame (see quantize_entry). */
static inline void cell_frame(const grid_level *g, vec3 p, const int32_t c3[3], float q[3])
{
    q[0] = (p.x - cell_origin(g, c3[0], g->lo.x) + g->q_off) * g->q_scale;
    q[1] = (p.y - cell_origin(g, c3[1], g->lo.y) + g->q_off) * g->q_scale;
    q[2] = (p.z - cell_origin(g, c3[2], g->lo.z) + g->q_off) * g->q_scale;
}

/* Listing i of a level: its quantised sphere and its rank (see grid_level.lst). */
#define VBI_VLI_BLOCK(g, i) ((g)->lst + (size_t)((i) >> 3) * 16u)
#define VBI_VLI_QENT(g, i) (VBI_VLI_BLOCK(g, i)[(i) & 7u])
#define VBI_VLI_RANK(g, i) (VBI_VLI_BLOCK(g, i)[8u + ((i) & 7u)])

/* The quantised pre-test of the n listings from s0 for a point at q (cell frame): calls
 * keep(rank) for those that may contain it, in listing order. A cell's listings are whole
 * blocks (s0 and n multiples of 8, the padding failing the test: level_build), which the 8-wide
 * version reads without lane masks. */
#if defined(__AVX2__)
#define VBI_VLI_PRETEST(g, s0, n, q, KEEP)                                                                   \
    do {                                                                                                      \
    const __m256 vx_ = _mm256_set1_ps((q)[0]), vy_ = _mm256_set1_ps((q)[1]), vz_ = _mm256_set1_ps((q)[2]);    \
    const __m256 sl_ = _mm256_set1_ps(VBI_VLI_QSLACK);                                                       \
    const __m256i byte_ = _mm256_set1_epi32(0xff);                                                            \
    const uint32_t b0_ = (s0) >> 3, end_ = (s0) + (n);                                                        \
    for (uint32_t b_ = b0_; b_ * 8u < end_; ++b_) {                                                           \
        const uint32_t *blk_ = (g)->lst + (size_t)b_ * 16u;                                                  \
        __m256i v_ = _mm256_load_si256((const __m256i *)blk_);                                                \
        __m256 dx_ = _mm256_sub_ps(vx_, _mm256_cvtepi32_ps(_mm256_and_si256(v_, byte_)));                     \
        __m256 dy_ = _mm256_sub_ps(vy_, _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(v_, 8), byte_))); \
        __m256 dz_ = _mm256_sub_ps(vz_, _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(v_, 16), byte_))); \
        __m256 rr_ = _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(v_, 24)), sl_);                       \
        __m256 d2_ = _mm256_fmadd_ps(dz_, dz_, _mm256_fmadd_ps(dy_, dy_, _mm256_mul_ps(dx_, dx_)));           \
        unsigned bits_ = (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(d2_, _mm256_mul_ps(rr_, rr_), _CMP_LT_OQ)); \
        while (bits_) {                                                                                       \
            unsigned j_ = (unsigned)__builtin_ctz(bits_);                                                     \
            bits_ &= bits_ - 1;                                                                               \
            uint32_t rank_ = blk_[8u + j_];                                                                   \
            KEEP;                                                                                             \
        }                                                                                                     \
    }                                                                                                         \
    } while (0)
#else
#define VBI_VLI_PRETEST(g, s0, n, q, KEEP)                                                                   \
    do {                                                                                                      \
    for (uint32_t i_ = (s0); i_ < (s0) + (n); ++i_) {                                                         \
        uint32_t v_ = VBI_VLI_QENT(g, i_);                                                                   \
        float dx_ = (q)[0] - (float)(v_ & 255u), dy_ = (q)[1] - (float)((v_ >> 8) & 255u),                    \
              dz_ = (q)[2] - (float)((v_ >> 16) & 255u), rr_ = (float)(v_ >> 24) + VBI_VLI_QSLACK;           \
        if (dx_ * dx_ + dy_ * dy_ + dz_ * dz_ < rr_ * rr_) {                                                  \
            uint32_t rank_ = VBI_VLI_RANK(g, i_);                                                            \
            KEEP;                                                                                             \
        }                                                                                                     \
    }                                                                                                         \
    } while (0)
#endif

/* Cell of p in level g: its index in start[], or UINT32_MAX when p is far outside the level or
 * in an empty hashed cell; c3 receives the cell coordinates. */
static inline uint32_t level_cell(const grid_level *g, vec3 p, int32_t c3[3])
{
    float fx = (p.x - g->lo.x) * g->inv_cell, fy = (p.y - g->lo.y) * g->inv_cell, fz = (p.z - g->lo.z) * g->inv_cell;
    /* Far outside the level's box no sphere of it can contain p (the test also drops NaN);
     * near it, the clamp below maps p like cell_range maps the spheres' boxes. */
    if (!(fx > -1.0f && fy > -1.0f && fz > -1.0f && fx < (float)g->n[0] + 1.0f && fy < (float)g->n[1] + 1.0f &&
          fz < (float)g->n[2] + 1.0f))
        return UINT32_MAX;
    c3[0] = cell_coord(g, p.x, g->lo.x, 0);
    c3[1] = cell_coord(g, p.y, g->lo.y, 1);
    c3[2] = cell_coord(g, p.z, g->lo.z, 2);
    uint64_t lc = linear_cell(g, c3[0], c3[1], c3[2]);
    return g->dense ? (uint32_t)lc : hash_find((grid_level *)g, lc, 0, NULL);
}

/* The two loading stages of a lookup in level g, shared by the batch pipeline (vl_index_pipe.h),
 * the staged single lookup (vbi_vl_index_lookup_*) and photon splitting's fast path: locate
 * returns p's cell (UINT32_MAX: none) and starts loading its header; prefetch_listings starts
 * loading every block (cache line) of the listings s0 .. s0 + n - 1; fetch reads cell c's header
 * (n = 0 for UINT32_MAX) and starts loading its listings. */
static inline uint32_t vbi_vli_locate(const grid_level *g, vec3 p, int32_t c3[3])
{
    uint32_t c = level_cell(g, p, c3);
    if (c != UINT32_MAX)
        __builtin_prefetch(g->start + c);
    return c;
}

static inline void vbi_vli_prefetch_listings(const grid_level *g, uint32_t s0, uint32_t n)
{
    /* Four blocks whatever n (a loop of one to four blocks left its exit to the branch
     * predictor: photon splitting 8-10% slower; prefetching the next cells' lines, or lines
     * past the array's end, is harmless), a loop for more. */
    const uint32_t *l0 = g->lst + (size_t)(s0 >> 3) * 16u;
    __builtin_prefetch(l0);
    __builtin_prefetch(l0 + 16);
    __builtin_prefetch(l0 + 32);
    __builtin_prefetch(l0 + 48);
    for (uint32_t b = (s0 >> 3) + 4u; n && b <= (s0 + n - 1u) >> 3; ++b)
        __builtin_prefetch(g->lst + (size_t)b * 16u);
}

static inline void vbi_vli_fetch(const grid_level *g, uint32_t c, uint32_t *s0, uint32_t *n)
{
    *n = 0;
    if (c == UINT32_MAX)
        return;
    *s0 = g->start[c];
    *n = g->start[c + 1] - *s0;
    vbi_vli_prefetch_listings(g, *s0, *n);
}

/* Runs KEEP (rank_ in scope) for every sphere listed in p's cell of each level that passes the
 * quantised pre-test, level by level in listing order. */
#define VBI_VLI_GRID_CANDIDATES(x, p, KEEP)                                                                  \
    do {                                                                                                      \
        for (uint32_t L_ = 0; L_ < (x)->level_count; ++L_) {                                                  \
            const grid_level *g_ = &(x)->levels[L_];                                                          \
            int32_t c3_[3];                                                                                   \
            uint32_t c_ = level_cell(g_, (p), c3_);                                                           \
            if (c_ == UINT32_MAX)                                                                             \
                continue;                                                                                     \
            uint32_t s0_ = g_->start[c_], n_ = g_->start[c_ + 1] - s0_;                                       \
            if (!n_)                                                                                          \
                continue;                                                                                     \
            float q_[3];                                                                                      \
            cell_frame(g_, (p), c3_, q_);                                                                     \
            VBI_VLI_PRETEST(g_, s0_, n_, q_, KEEP);                                                          \
        }                                                                                                     \
    } while (0)

static inline __attribute__((always_inline)) void grid_query(const vbi_vl_index *x, vec3 p, query_out *o)
{
    VBI_VLI_GRID_CANDIDATES(x, p, test_rec_exact(x->rec + rank_, rank_, p, o));
}

#endif
