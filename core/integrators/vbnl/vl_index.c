/* Spatial index over virtual-light spheres: multi-level grid and Embree point-query variants
 * (see vl_index.h). Used by photon splitting (Li et al. 2022, Section 3.3) and by rendering's
 * BSDF-sampling gather (Section 4.1). */
#include "vl_index.h"

#include <stdlib.h>
#include <string.h>
#if defined(__AVX2__) || defined(__BMI2__)
#include <immintrin.h>
#endif

#define MAX_LEVELS 32u
#define DEFAULT_CELL_SCALE 2.0f
#define EMPTY_KEY UINT64_MAX
#define KEY_BITS 21u /* spatial key: bits per axis (3 x 21 = 63-bit Morton code) */

/* One sphere, 32 bytes (half a cache line), stored by rank: centre and radius first (the
 * containment test), the normal (the splitting filter) and the id after them. */
typedef struct vl_rec {
    float cx, cy, cz, r;
    float nx, ny, nz;
    uint32_t id;
} vl_rec;

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
    uint32_t *items;          /* the ranks of the spheres listed in each cell, ascending */
    uint32_t *qent;           /* per listing: centre and radius quantised to 8 bits in the
                               * cell's frame (x | y << 8 | z << 16 | r << 24), see qframe */
    float q_off, q_scale;     /* cell frame: q = (v - cell origin + q_off) * q_scale */
} grid_level;

struct vbnl_vl_index {
    vbnl_vl_index_kind kind;
    uint32_t count;
    int has_normals;
    /* Spheres in Morton order of their centres (grid) or in id order (Embree): rec[rank]. A
     * cell lists 4-byte ranks instead of copies of the spheres (8 listings per sphere at the
     * default cell size: 32 bytes instead of 256), and the spheres of neighbouring cells sit
     * next to each other in rec, so a query touches few cache lines and rank-indexed data of
     * the caller (vbnl_vl_index_rank) get the same locality. */
    vl_rec *rec;
    uint32_t *rank_of;        /* id -> rank; NULL: identity (Embree) */
    /* spatial key (vbnl_vl_index_spatial_key): a cube over the centres, 2^KEY_BITS cells/axis */
    vec3 key_lo;
    float key_scale;
    /* grid */
    grid_level levels[MAX_LEVELS];
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
    vbnl_vl_found *found;     /* instead of ids/dist2 (vbnl_vl_index_query_found) */
    uint32_t max_out, n, total;
    const vbnl_vl_filter *f;  /* NULL: no filter */
    int sorted;               /* found[] is in id order (else in arrival order) */
} query_out;

/* Insertion sort by id (ids are distinct). */
static inline void found_sort(vbnl_vl_found *a, uint32_t n)
{
    for (uint32_t i = 1; i < n; ++i) {
        vbnl_vl_found v = a[i];
        uint32_t k = i;
        while (k > 0 && a[k - 1].id > v.id) {
            a[k] = a[k - 1];
            --k;
        }
        a[k] = v;
    }
}

static inline int passes(const vbnl_vl_filter *f, vec3 nj)
{
    if (f->normal_cos > -1.0f && !(v3_dot(nj, f->n) > f->normal_cos))
        return 0;
    return !f->facing || v3_dot(nj, f->wi) > 0.0f;
}

/* Keeps the max_out smallest ids in ascending order (insertion: a query finds a handful). */
static inline void out_add(query_out *o, const vl_rec *e, uint32_t rank, double d2)
{
    uint32_t id = e->id;
    o->total++;
    uint32_t n = o->n;
    if (o->found) {
        /* Records are appended unsorted while they fit (found_finish sorts them); the capped
         * insertion starts only when more than max_out spheres contain p (rare). */
        vbnl_vl_found *a = o->found, rec = {id, rank, (float)d2, e->r};
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

/* Containment of p in sphere e, exactly as vbnl_vl_contains, with a cheap float test first
 * that only rejects spheres certainly outside: d2f (float, any rounding or contraction) is
 * within 3 ulp (2^-22.4) of the d^2 of vbnl_vl_dist2 (exact products of the same float
 * differences, summed in double), and the bound fl(fl(r r) (1 + 2^-20)) exceeds r^2 by more
 * than that; the floor 2^-100 keeps the bound valid where r r underflows. Most candidates of a
 * cell are outside, so most never reach the double test. */
static inline int rec_contains(const vl_rec *e, vec3 p, double *d2)
{
    float dx = p.x - e->cx, dy = p.y - e->cy, dz = p.z - e->cz;
    float d2f = dx * dx + dy * dy + dz * dz, r = e->r, bound = r * r * (1.0f + 0x1p-20f);
    if (!(d2f < bound) && !(d2f < 0x1p-100f)) /* also NaN */
        return 0;
    *d2 = (double)dx * dx + (double)dy * dy + (double)dz * dz; /* = vbnl_vl_dist2(p, centre) */
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
    double d2 = (double)dx * dx + (double)dy * dy + (double)dz * dz; /* = vbnl_vl_dist2(p, centre) */
    if (r > 0.0f && d2 < (double)r * r && (!o->f || passes(o->f, v3(e->nx, e->ny, e->nz))))
        out_add(o, e, rank, d2);
}

/* ---- spatial order -------------------------------------------------------------------------- */

/* The 21 low bits of v spread to every third bit. */
static inline uint64_t spread3(uint64_t v)
{
#if defined(__BMI2__)
    return _pdep_u64(v, 0x1249249249249249ull);
#endif
    v &= 0x1fffffull;
    v = (v | v << 32) & 0x1f00000000ffffull;
    v = (v | v << 16) & 0x1f0000ff0000ffull;
    v = (v | v << 8) & 0x100f00f00f00f00full;
    v = (v | v << 4) & 0x10c30c30c30c30c3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

static inline uint64_t key_coord(float v, float lo, float scale)
{
    float f = (v - lo) * scale;
    const float top = (float)((1u << KEY_BITS) - 1u);
    return !(f > 0.0f) ? 0u : (f >= top ? (uint64_t)top : (uint64_t)f); /* NaN -> 0 */
}

static inline uint64_t spatial_key(const vbnl_vl_index *x, vec3 p)
{
    return spread3(key_coord(p.x, x->key_lo.x, x->key_scale)) |
           spread3(key_coord(p.y, x->key_lo.y, x->key_scale)) << 1 |
           spread3(key_coord(p.z, x->key_lo.z, x->key_scale)) << 2;
}

/* Stable LSD radix sort of (key, value) pairs by key, 11 bits per pass; passes in which every
 * key has the same digit are skipped. tmp_* have room for n. */
static void radix_sort_pairs(uint64_t *key, uint32_t *val, uint64_t *tmp_key, uint32_t *tmp_val, size_t n,
                             size_t *count)
{
    enum { BITS = 11, BUCKETS = 1 << BITS, PASSES = (64 + BITS - 1) / BITS };
    for (unsigned pass = 0; pass < PASSES; ++pass) {
        unsigned shift = pass * BITS;
        memset(count, 0, BUCKETS * sizeof(size_t));
        for (size_t i = 0; i < n; ++i)
            count[(key[i] >> shift) & (BUCKETS - 1)]++;
        if (n == 0 || count[(key[0] >> shift) & (BUCKETS - 1)] == n)
            continue;
        size_t sum = 0;
        for (unsigned b = 0; b < BUCKETS; ++b) {
            size_t c = count[b];
            count[b] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; ++i) {
            size_t at = count[(key[i] >> shift) & (BUCKETS - 1)]++;
            tmp_key[at] = key[i];
            tmp_val[at] = val[i];
        }
        memcpy(key, tmp_key, n * sizeof(uint64_t));
        memcpy(val, tmp_val, n * sizeof(uint32_t));
    }
}

/* rec[] in Morton order of the centres (grid) or in id order (Embree), and the key cube. */
static vbnl_result order_build(vbnl_vl_index *x, const vbnl_vl_index_desc *desc, int morton)
{
    uint32_t n = desc->count;
    vec3 lo = v3s(INFINITY), hi = v3s(-INFINITY);
    for (uint32_t i = 0; i < n; ++i) {
        lo = v3_min(lo, desc->centers[i]);
        hi = v3_max(hi, desc->centers[i]);
    }
    if (!(lo.x <= hi.x)) {
        lo = v3s(0.0f);
        hi = v3s(1.0f);
    }
    float ext = fmaxf(hi.x - lo.x, fmaxf(hi.y - lo.y, hi.z - lo.z));
    ext = ext > 0.0f ? ext * 1.0001f : 1.0f;
    x->key_lo = lo;
    x->key_scale = (float)(1u << KEY_BITS) / ext;
    uint32_t *order = malloc(((size_t)n + 1) * sizeof(uint32_t));
    if (!order)
        return VBNL_ERR_OUT_OF_MEMORY;
    for (uint32_t i = 0; i < n; ++i)
        order[i] = i;
    if (morton && n > 1) {
        uint64_t *key = malloc((size_t)n * sizeof(uint64_t)), *tk = malloc((size_t)n * sizeof(uint64_t));
        uint32_t *tv = malloc((size_t)n * sizeof(uint32_t));
        size_t *count = malloc(2048 * sizeof(size_t));
        if (!key || !tk || !tv || !count) {
            free(key);
            free(tk);
            free(tv);
            free(count);
            free(order);
            return VBNL_ERR_OUT_OF_MEMORY;
        }
        for (uint32_t i = 0; i < n; ++i)
            key[i] = spatial_key(x, desc->centers[i]);
        radix_sort_pairs(key, order, tk, tv, n, count); /* stable: equal keys keep id order */
        free(key);
        free(tk);
        free(tv);
        free(count);
        x->rank_of = malloc(((size_t)n + 1) * sizeof(uint32_t));
        if (!x->rank_of) {
            free(order);
            return VBNL_ERR_OUT_OF_MEMORY;
        }
        for (uint32_t k = 0; k < n; ++k)
            x->rank_of[order[k]] = k;
        x->bytes += (size_t)n * sizeof(uint32_t);
    }
    x->rec = aligned_alloc(64, (((size_t)n * sizeof(vl_rec) + 63) / 64 + 1) * 64);
    if (!x->rec) {
        free(order);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    for (uint32_t k = 0; k < n; ++k) {
        uint32_t id = order[k];
        vec3 c = desc->centers[id], nn = desc->normals ? desc->normals[id] : v3s(0.0f);
        x->rec[k] = (vl_rec){c.x, c.y, c.z, desc->radii[id], nn.x, nn.y, nn.z, id};
    }
    x->bytes += (size_t)n * sizeof(vl_rec);
    free(order);
    return VBNL_OK;
}

/* ---- grid ---------------------------------------------------------------------------------- */

static uint64_t hash_key(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    return k;
}

static int usable(float r) { return r > 0.0f && isfinite(r); }

/* Radius class of r: the smallest L with r <= r_min 2^L (clamped to the last level). */
static uint32_t level_of(float r, float r_min)
{
    uint32_t L = 0;
    float lim = r_min;
    while (r > lim && L + 1 < MAX_LEVELS) {
        lim *= 2.0f;
        ++L;
    }
    return L;
}

/* The sphere's bounding box, padded by a few ulps of the coordinates so that any p with
 * d(p, c) < r maps (monotonically, in float) into the box's cell range despite rounding. */
static void sphere_box(vec3 c, float r, vec3 *lo, vec3 *hi)
{
    vec3 pad = v3(1e-5f * (r + fabsf(c.x)), 1e-5f * (r + fabsf(c.y)), 1e-5f * (r + fabsf(c.z)));
    *lo = v3_sub(v3_sub(c, v3s(r)), pad);
    *hi = v3_add(v3_add(c, v3s(r)), pad);
}

static inline int32_t cell_coord(const grid_level *g, float v, float lo, int a)
{
    float f = floorf((v - lo) * g->inv_cell);
    return f < 0.0f ? 0 : (f >= (float)g->n[a] ? g->n[a] - 1 : (int32_t)f);
}

static void cell_range(const grid_level *g, vec3 c, float r, int32_t lo[3], int32_t hi[3])
{
    vec3 a, b;
    sphere_box(c, r, &a, &b);
    lo[0] = cell_coord(g, a.x, g->lo.x, 0);
    lo[1] = cell_coord(g, a.y, g->lo.y, 1);
    lo[2] = cell_coord(g, a.z, g->lo.z, 2);
    hi[0] = cell_coord(g, b.x, g->lo.x, 0);
    hi[1] = cell_coord(g, b.y, g->lo.y, 1);
    hi[2] = cell_coord(g, b.z, g->lo.z, 2);
}

static inline uint64_t linear_cell(const grid_level *g, int32_t x, int32_t y, int32_t z)
{
    return (uint64_t)x + (uint64_t)g->n[0] * ((uint64_t)y + (uint64_t)g->n[1] * (uint64_t)z);
}

/* Slot of cell key in the hash (inserting it when `insert`), or UINT32_MAX. */
static uint32_t hash_find(grid_level *g, uint64_t key, int insert, uint32_t *next_slot)
{
    uint32_t h = (uint32_t)hash_key(key) & g->hash_mask;
    for (;;) {
        if (g->keys[h] == key)
            return g->slot[h];
        if (g->keys[h] == EMPTY_KEY) {
            if (!insert)
                return UINT32_MAX;
            g->keys[h] = key;
            g->slot[h] = (*next_slot)++;
            return g->slot[h];
        }
        h = (h + 1) & g->hash_mask;
    }
}

static void level_free(grid_level *g)
{
    free(g->start);
    free(g->keys);
    free(g->slot);
    free(g->items);
    free(g->qent);
}

/* ---- quantised pre-test ----------------------------------------------------------------------
 * Every listing also stores its sphere in 4 bytes: centre and radius in units h of the cell's
 * frame, whose origin is the cell's corner minus q_off (the largest radius and box padding of
 * the level) and which spans E = cell + 2 q_off = 255 h per axis, so every centre listed in the
 * cell fits in 8 bits. Centres are rounded (error <= sqrt(3)/2 h), radii rounded up. A query
 * point p at distance d_q from the quantised centre can lie inside the sphere only if
 * d_q < r_q + QSLACK (QSLACK: the centre error plus float rounding of both frames, which use
 * the same float origin and therefore the same rounding); spheres failing that are certainly
 * outside and skipped, the others get the exact test (rec_contains). A listing whose sphere
 * does not quantise within these bounds gets r_q = 255 and is always tested. 8 listings are
 * pre-tested at once with AVX2. */
#define QSLACK 0.8761f /* sqrt(3) / 2 + 0.01 */

static inline float cell_origin(const grid_level *g, int32_t c, float lo) { return lo + (float)c * g->cell; }

static uint32_t quantize_entry(const grid_level *g, vec3 c, float r, const int32_t c3[3])
{
    const float o[3] = {cell_origin(g, c3[0], g->lo.x), cell_origin(g, c3[1], g->lo.y), cell_origin(g, c3[2], g->lo.z)};
    const float v[3] = {c.x, c.y, c.z};
    uint32_t q[4];
    int ok = 1;
    for (int a = 0; a < 3; ++a) {
        float f = (v[a] - o[a] + g->q_off) * g->q_scale;
        float n = roundf(f);
        ok &= f >= -0.5f && f <= 255.5f && fabsf(f - n) <= 0.5001f && n >= 0.0f && n <= 255.0f;
        q[a] = ok ? (uint32_t)n : 0u;
    }
    float rq = ceilf(r * g->q_scale * 1.0001f);
    ok &= rq <= 254.0f;
    q[3] = ok ? (uint32_t)rq : 255u;
    if (!ok) /* always tested */
        q[0] = q[1] = q[2] = 0u;
    return q[0] | q[1] << 8 | q[2] << 16 | q[3] << 24;
}

static inline vec3 rec_center(const vl_rec *e) { return v3(e->cx, e->cy, e->cz); }

/* Builds level L from the spheres of class L (ranks in `members`, ascending). */
static vbnl_result level_build(vbnl_vl_index *x, grid_level *g, const uint32_t *members, uint32_t m, float cell)
{
    vec3 lo = v3s(INFINITY), hi = v3s(-INFINITY);
    for (uint32_t k = 0; k < m; ++k) {
        vec3 a, b;
        const vl_rec *e = x->rec + members[k];
        sphere_box(rec_center(e), e->r, &a, &b);
        lo = v3_min(lo, a);
        hi = v3_max(hi, b);
    }
    g->cell = cell;
    g->inv_cell = 1.0f / cell;
    g->lo = lo;
    g->sphere_count = m;
    const float ext[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    double cells = 1.0;
    for (int a = 0; a < 3; ++a) {
        double n = floor((double)ext[a] / cell) + 1.0;
        if (n > 1 << 30) /* absurd spread: cap (cells then merely hold more spheres) */
            n = 1 << 30;
        g->n[a] = (int32_t)n;
        cells *= n;
    }
    /* Pass 1: cells touched. Dense when the grid is small next to the number of listings. */
    uint64_t listings = 0;
    for (uint32_t k = 0; k < m; ++k) {
        int32_t a[3], b[3];
        const vl_rec *e = x->rec + members[k];
        cell_range(g, rec_center(e), e->r, a, b);
        listings += (uint64_t)(b[0] - a[0] + 1) * (uint64_t)(b[1] - a[1] + 1) * (uint64_t)(b[2] - a[2] + 1);
    }
    if (listings >= UINT32_MAX)
        return VBNL_ERR_OUT_OF_MEMORY;
    g->dense = cells <= 4.0 * (double)listings + 4096.0;
    uint32_t ncell;
    if (g->dense) {
        ncell = (uint32_t)cells;
    } else {
        uint32_t bits = 4;
        while ((1ull << bits) < 2 * listings + 16)
            ++bits;
        g->hash_mask = (uint32_t)((1ull << bits) - 1);
        g->keys = malloc(((size_t)g->hash_mask + 1) * sizeof(uint64_t));
        g->slot = malloc(((size_t)g->hash_mask + 1) * sizeof(uint32_t));
        if (!g->keys || !g->slot)
            return VBNL_ERR_OUT_OF_MEMORY;
        memset(g->keys, 0xFF, ((size_t)g->hash_mask + 1) * sizeof(uint64_t));
        ncell = 0;
        for (uint32_t k = 0; k < m; ++k) {
            int32_t a[3], b[3];
            const vl_rec *e = x->rec + members[k];
            cell_range(g, rec_center(e), e->r, a, b);
            for (int32_t z = a[2]; z <= b[2]; ++z)
                for (int32_t y = a[1]; y <= b[1]; ++y)
                    for (int32_t xx = a[0]; xx <= b[0]; ++xx)
                        hash_find(g, linear_cell(g, xx, y, z), 1, &ncell);
        }
    }
    g->start = calloc((size_t)ncell + 1, sizeof(uint32_t));
    /* 8 spare entries: the 8-wide pre-test may read past the last cell */
    g->items = calloc((size_t)listings + 8, sizeof(uint32_t));
    g->qent = calloc((size_t)listings + 8, sizeof(uint32_t));
    if (!g->start || !g->items || !g->qent)
        return VBNL_ERR_OUT_OF_MEMORY;
    float off = 0.0f;
    for (uint32_t k = 0; k < m; ++k) {
        const vl_rec *e = x->rec + members[k];
        float pad = 1e-5f * (e->r + fmaxf(fabsf(e->cx), fmaxf(fabsf(e->cy), fabsf(e->cz))));
        off = fmaxf(off, e->r + pad);
    }
    g->q_off = off * 1.001f;
    g->q_scale = 255.0f / (cell + 2.0f * g->q_off);
    /* Pass 2: counts, prefix sums, then fill in rank order (a cell's ranks ascend). */
    for (int pass = 0; pass < 2; ++pass) {
        for (uint32_t k = 0; k < m; ++k) {
            uint32_t rank = members[k];
            const vl_rec *e = x->rec + rank;
            int32_t a[3], b[3];
            cell_range(g, rec_center(e), e->r, a, b);
            for (int32_t z = a[2]; z <= b[2]; ++z)
                for (int32_t y = a[1]; y <= b[1]; ++y)
                    for (int32_t xx = a[0]; xx <= b[0]; ++xx) {
                        uint64_t lc = linear_cell(g, xx, y, z);
                        uint32_t c = g->dense ? (uint32_t)lc : hash_find(g, lc, 0, NULL);
                        if (pass == 0) {
                            g->start[c + 1]++;
                        } else {
                            const int32_t c3[3] = {xx, y, z};
                            g->qent[g->start[c]] = quantize_entry(g, rec_center(e), e->r, c3);
                            g->items[g->start[c]++] = rank;
                        }
                    }
        }
        if (pass == 0) {
            for (uint32_t c = 0; c < ncell; ++c)
                g->start[c + 1] += g->start[c];
        } else {
            /* the fill advanced every start to the next cell's start: shift back */
            for (uint32_t c = ncell; c > 0; --c)
                g->start[c] = g->start[c - 1];
            g->start[0] = 0;
        }
    }
    x->bytes += ((size_t)ncell + 1) * sizeof(uint32_t) + ((size_t)listings + 8) * 2 * sizeof(uint32_t);
    if (!g->dense)
        x->bytes += ((size_t)g->hash_mask + 1) * (sizeof(uint64_t) + sizeof(uint32_t));
    return VBNL_OK;
}

static vbnl_result grid_build(vbnl_vl_index *x, float cell_scale)
{
    float r_min = INFINITY;
    for (uint32_t k = 0; k < x->count; ++k)
        if (usable(x->rec[k].r) && x->rec[k].r < r_min)
            r_min = x->rec[k].r;
    x->r_min = r_min;
    if (!(r_min < INFINITY))
        return VBNL_OK; /* no usable sphere: every query answers 0 */
    uint32_t counts[MAX_LEVELS] = {0};
    uint8_t *cls = malloc(x->count ? x->count : 1);
    uint32_t *members = malloc(((size_t)x->count + 1) * sizeof(uint32_t));
    vbnl_result res = VBNL_OK;
    if (!cls || !members) {
        res = VBNL_ERR_OUT_OF_MEMORY;
        goto done;
    }
    for (uint32_t k = 0; k < x->count; ++k) {
        float r = x->rec[k].r;
        cls[k] = usable(r) ? (uint8_t)level_of(r, r_min) : 0xFF;
        if (cls[k] != 0xFF)
            counts[cls[k]]++;
    }
    for (uint32_t L = 0; L < MAX_LEVELS && res == VBNL_OK; ++L) {
        if (!counts[L])
            continue;
        uint32_t m = 0;
        float r_max = 0.0f;
        for (uint32_t k = 0; k < x->count; ++k)
            if (cls[k] == L) {
                members[m++] = k;
                r_max = fmaxf(r_max, x->rec[k].r);
            }
        res = level_build(x, &x->levels[x->level_count++], members, m, cell_scale * r_max);
    }
done:
    free(cls);
    free(members);
    return res;
}

/* p in cell c3's quantisation frame (see quantize_entry). */
static inline void cell_frame(const grid_level *g, vec3 p, const int32_t c3[3], float q[3])
{
    q[0] = (p.x - cell_origin(g, c3[0], g->lo.x) + g->q_off) * g->q_scale;
    q[1] = (p.y - cell_origin(g, c3[1], g->lo.y) + g->q_off) * g->q_scale;
    q[2] = (p.z - cell_origin(g, c3[2], g->lo.z) + g->q_off) * g->q_scale;
}

/* The quantised pre-test of the n listings from s0 for a point at q (cell frame): calls
 * keep(rank) for those that may contain it, in listing order. */
#define PRETEST(g, s0, n, q, KEEP)                                                                             \
    do {                                                                                                      \
        const uint32_t *qe_ = (g)->qent + (s0), *rk_ = (g)->items + (s0);                                     \
        PRETEST_BODY(n, q, KEEP);                                                                             \
    } while (0)
#if defined(__AVX2__)
#define PRETEST_BODY(n, q, KEEP)                                                                              \
    const __m256 vx_ = _mm256_set1_ps((q)[0]), vy_ = _mm256_set1_ps((q)[1]), vz_ = _mm256_set1_ps((q)[2]);   \
    const __m256 sl_ = _mm256_set1_ps(QSLACK);                                                                \
    const __m256i lane_ = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), byte_ = _mm256_set1_epi32(0xff);        \
    for (uint32_t i_ = 0; i_ < (n); i_ += 8) {                                                                \
        __m256i v_ = _mm256_loadu_si256((const __m256i *)(qe_ + i_));                                         \
        __m256 dx_ = _mm256_sub_ps(vx_, _mm256_cvtepi32_ps(_mm256_and_si256(v_, byte_)));                     \
        __m256 dy_ = _mm256_sub_ps(vy_, _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(v_, 8), byte_))); \
        __m256 dz_ = _mm256_sub_ps(vz_, _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(v_, 16), byte_))); \
        __m256 rr_ = _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(v_, 24)), sl_);                       \
        __m256 d2_ = _mm256_fmadd_ps(dz_, dz_, _mm256_fmadd_ps(dy_, dy_, _mm256_mul_ps(dx_, dx_)));           \
        __m256 in_ = _mm256_and_ps(_mm256_cmp_ps(d2_, _mm256_mul_ps(rr_, rr_), _CMP_LT_OQ),                   \
                                   _mm256_castsi256_ps(                                                       \
                                       _mm256_cmpgt_epi32(_mm256_set1_epi32((int)((n) - i_)), lane_)));       \
        unsigned bits_ = (unsigned)_mm256_movemask_ps(in_);                                                   \
        while (bits_) {                                                                                       \
            unsigned j_ = (unsigned)__builtin_ctz(bits_);                                                     \
            bits_ &= bits_ - 1;                                                                               \
            uint32_t rank_ = rk_[i_ + j_];                                                                    \
            KEEP;                                                                                             \
        }                                                                                                     \
    }
#else
#define PRETEST_BODY(n, q, KEEP)                                                                              \
    for (uint32_t i_ = 0; i_ < (n); ++i_) {                                                                   \
        uint32_t v_ = qe_[i_];                                                                                \
        float dx_ = (q)[0] - (float)(v_ & 255u), dy_ = (q)[1] - (float)((v_ >> 8) & 255u),                    \
              dz_ = (q)[2] - (float)((v_ >> 16) & 255u), rr_ = (float)(v_ >> 24) + QSLACK;                    \
        if (dx_ * dx_ + dy_ * dy_ + dz_ * dz_ < rr_ * rr_) {                                                  \
            uint32_t rank_ = rk_[i_];                                                                         \
            KEEP;                                                                                             \
        }                                                                                                     \
    }
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

static inline __attribute__((always_inline)) void grid_query(const vbnl_vl_index *x, vec3 p, query_out *o)
{
    for (uint32_t L = 0; L < x->level_count; ++L) {
        const grid_level *g = &x->levels[L];
        int32_t c3[3];
        uint32_t c = level_cell(g, p, c3);
        if (c == UINT32_MAX)
            continue;
        uint32_t s0 = g->start[c], n = g->start[c + 1] - s0;
        if (!n)
            continue;
        float q[3];
        cell_frame(g, p, c3, q);
        PRETEST(g, s0, n, q, test_rec_exact(x->rec + rank_, rank_, p, o));
    }
}

/* ---- Embree -------------------------------------------------------------------------------- */

static void sphere_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const vbnl_vl_index *x = args->geometryUserPtr;
    const vl_rec *e = x->rec + args->primID;
    float r = usable(e->r) ? e->r : 0.0f;
    args->bounds_o->lower_x = e->cx - r;
    args->bounds_o->lower_y = e->cy - r;
    args->bounds_o->lower_z = e->cz - r;
    args->bounds_o->upper_x = e->cx + r;
    args->bounds_o->upper_y = e->cy + r;
    args->bounds_o->upper_z = e->cz + r;
}

/* Never traced with rays; Embree wants the callbacks of a user geometry set. */
static void sphere_intersect(const struct RTCIntersectFunctionNArguments *args) { (void)args; }
static void sphere_occluded(const struct RTCOccludedFunctionNArguments *args) { (void)args; }

typedef struct embree_query {
    const vbnl_vl_index *x;
    query_out *o;
} embree_query;

static bool sphere_point_query(struct RTCPointQueryFunctionArguments *args)
{
    const embree_query *q = args->userPtr;
    uint32_t id = args->primID; /* == rank: the Embree variant keeps id order */
    test_rec(q->x->rec + id, id, v3(args->query->x, args->query->y, args->query->z), q->o);
    return false; /* the query radius is unchanged */
}

static vbnl_result embree_build(vbnl_vl_index *x, RTCDevice device)
{
    x->rtc = rtcNewScene(device);
    if (!x->rtc)
        return VBNL_ERR_BACKEND;
    rtcSetSceneBuildQuality(x->rtc, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    if (!g)
        return VBNL_ERR_BACKEND;
    rtcSetGeometryUserPrimitiveCount(g, x->count);
    rtcSetGeometryUserData(g, x);
    rtcSetGeometryBoundsFunction(g, sphere_bounds, x);
    rtcSetGeometryIntersectFunction(g, sphere_intersect);
    rtcSetGeometryOccludedFunction(g, sphere_occluded);
    rtcCommitGeometry(g);
    rtcAttachGeometry(x->rtc, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(x->rtc);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE)
        return VBNL_ERR_BACKEND;
    x->bytes += (size_t)x->count * 64u; /* BVH estimate, see vl_index.h */
    return VBNL_OK;
}

static void embree_query_point(const vbnl_vl_index *x, vec3 p, query_out *o)
{
    struct RTCPointQuery q;
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    q.time = 0.0f;
    q.radius = 0.0f;
    struct RTCPointQueryContext ctx;
    rtcInitPointQueryContext(&ctx);
    embree_query eq = {x, o};
    rtcPointQuery(x->rtc, &q, &ctx, sphere_point_query, &eq);
}

/* ---- API ----------------------------------------------------------------------------------- */

vbnl_result vbnl_vl_index_create(const vbnl_vl_index_desc *desc, vbnl_vl_index **out)
{
    if (!out)
        return VBNL_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!desc || (desc->count && (!desc->centers || !desc->radii)) ||
        (desc->kind != VBNL_VL_INDEX_GRID && desc->kind != VBNL_VL_INDEX_EMBREE) ||
        (desc->kind == VBNL_VL_INDEX_EMBREE && !desc->device) || desc->cell_scale < 0.0f)
        return VBNL_ERR_INVALID_ARGUMENT;
    for (uint32_t i = 0; i < desc->count; ++i)
        if (!v3_is_finite(desc->centers[i]))
            return VBNL_ERR_INVALID_ARGUMENT;
    vbnl_vl_index *x = calloc(1, sizeof(*x));
    if (!x)
        return VBNL_ERR_OUT_OF_MEMORY;
    x->kind = desc->kind;
    x->count = desc->count;
    x->has_normals = desc->normals != NULL;
    x->bytes = sizeof(*x);
    vbnl_result r = order_build(x, desc, x->kind == VBNL_VL_INDEX_GRID);
    if (r == VBNL_OK)
        r = x->kind == VBNL_VL_INDEX_GRID
                ? grid_build(x, desc->cell_scale > 0.0f ? desc->cell_scale : DEFAULT_CELL_SCALE)
                : embree_build(x, desc->device);
    if (r != VBNL_OK) {
        vbnl_vl_index_destroy(x);
        return r;
    }
    *out = x;
    return VBNL_OK;
}

void vbnl_vl_index_destroy(vbnl_vl_index *x)
{
    if (!x)
        return;
    for (uint32_t L = 0; L < x->level_count; ++L)
        level_free(&x->levels[L]);
    if (x->rtc)
        rtcReleaseScene(x->rtc);
    free(x->rec);
    free(x->rank_of);
    free(x);
}

/* One query. The grid path keeps its query_out local (its address never escapes), so that
 * the compiler holds the counters and the filter in registers. */
static inline __attribute__((always_inline)) uint32_t run_query(const vbnl_vl_index *x, vec3 p,
                                                                const vbnl_vl_filter *f, uint32_t max_out,
                                                                uint32_t *ids, float *dist2,
                                                                vbnl_vl_found *found)
{
    vbnl_vl_filter fl;
    if (f)
        fl = *f;
    query_out o = {ids, dist2, found, max_out, 0, 0, f ? &fl : NULL, 0};
    if (x->kind == VBNL_VL_INDEX_GRID)
        grid_query(x, p, &o);
    else if (x->count)
        embree_query_point(x, p, &o);
    if (found && !o.sorted)
        found_sort(found, o.n);
    return o.total;
}

uint32_t vbnl_vl_index_query_filtered(const vbnl_vl_index *x, vec3 p, const vbnl_vl_filter *f, uint32_t max_out,
                                      uint32_t *ids, float *dist2)
{
    return run_query(x, p, x->has_normals ? f : NULL, max_out, ids, dist2, NULL);
}

uint32_t vbnl_vl_index_query(const vbnl_vl_index *x, vec3 p, uint32_t max_out, uint32_t *ids, float *dist2)
{
    return run_query(x, p, NULL, max_out, ids, dist2, NULL);
}

uint32_t vbnl_vl_index_query_found(const vbnl_vl_index *x, vec3 p, const vbnl_vl_filter *f, uint32_t max_out,
                                   vbnl_vl_found *found)
{
    return run_query(x, p, f && x->has_normals ? f : NULL, max_out, NULL, NULL, found);
}

/* ---- batched queries: a software pipeline over the points ------------------------------------
 * Point k goes through four stages, PIPE_STEP points apart: (A) its cells are located and their
 * headers fetched; (B) the cells' entries are fetched; (C) the quantised pre-test picks the
 * candidates and fetches their records (and the caller's per-rank data); (D) the exact test,
 * then the callback. Each stage finds in cache what the previous one fetched, so the four
 * dependent memory accesses of a query overlap with the work on other points. The answers are
 * the sets of vbnl_vl_index_query_found: the candidates of (C) are a superset of the containing
 * spheres; (D) keeps them in candidate order (an id sort costs a third of the stage in branch
 * misses) unless the answer is capped. */
#define PIPE_STEP 4u
#define PIPE_SLOTS 16u     /* >= 3 PIPE_STEP + 1, a power of two */
#define PIPE_LEVELS 4u     /* indexes with more levels use plain queries */
#define PIPE_CAND 128u     /* more candidates: the point gets a plain query */

typedef struct pipe_slot {
    uint32_t cell[PIPE_LEVELS];
    int32_t c3[PIPE_LEVELS][3];
    uint32_t s0[PIPE_LEVELS], n[PIPE_LEVELS];
    uint32_t ncand;
    uint32_t cand[PIPE_CAND];
} pipe_slot;

static inline const char *batch_rec(const vbnl_vl_batch *b, uint32_t k)
{
    return (const char *)b->base + (size_t)(b->order ? b->order[k] : k) * b->stride;
}

static inline vec3 batch_vec(const vbnl_vl_batch *b, uint32_t k, size_t off)
{
    vec3 v;
    memcpy(&v, batch_rec(b, k) + off, sizeof(v));
    return v;
}

/* The stages take the level count `nl` as an argument so that the single-level case (uniform
 * radii, the common one) is compiled without the loops over levels. */
static inline __attribute__((always_inline)) void pipe_a(const vbnl_vl_index *x, vec3 p, pipe_slot *s, uint32_t nl)
{
    for (uint32_t L = 0; L < nl; ++L) {
        const grid_level *g = &x->levels[L];
        s->cell[L] = level_cell(g, p, s->c3[L]);
        if (s->cell[L] != UINT32_MAX)
            __builtin_prefetch(g->start + s->cell[L]);
    }
}

static inline __attribute__((always_inline)) void pipe_b(const vbnl_vl_index *x, pipe_slot *s, uint32_t nl)
{
    for (uint32_t L = 0; L < nl; ++L) {
        const grid_level *g = &x->levels[L];
        uint32_t c = s->cell[L];
        s->n[L] = 0;
        if (c == UINT32_MAX)
            continue;
        s->s0[L] = g->start[c];
        s->n[L] = g->start[c + 1] - s->s0[L];
        for (uint32_t i = 0; i < s->n[L]; i += 16) {
            __builtin_prefetch(g->qent + s->s0[L] + i);
            __builtin_prefetch(g->items + s->s0[L] + i);
        }
    }
}

static inline __attribute__((always_inline)) void pipe_c(const vbnl_vl_index *x, const vbnl_vl_batch *b, vec3 p,
                                                         pipe_slot *s, uint32_t nl)
{
    uint32_t nc = 0;
    const char *rd = b->rank_data;
    for (uint32_t L = 0; L < nl; ++L) {
        const grid_level *g = &x->levels[L];
        if (!s->n[L])
            continue;
        float q[3];
        cell_frame(g, p, s->c3[L], q);
        PRETEST(g, s->s0[L], s->n[L], q, {
            if (nc < PIPE_CAND) {
                __builtin_prefetch(x->rec + rank_);
                if (rd)
                    __builtin_prefetch(rd + (size_t)rank_ * b->rank_stride);
                s->cand[nc] = rank_;
            }
            ++nc;
        });
    }
    s->ncand = nc;
}

/* Plain query of point k (no pipeline) for the batch. */
static void batch_plain(const vbnl_vl_index *x, const vbnl_vl_batch *b, uint32_t k, vbnl_vl_found *found,
                        vbnl_vl_batch_fn fn, void *user)
{
    vbnl_vl_filter fl = {batch_vec(b, k, b->n_off), batch_vec(b, k, b->wi_off), b->normal_cos, b->facing};
    uint32_t total = vbnl_vl_index_query_found(x, batch_vec(b, k, b->p_off), b->filter ? &fl : NULL, b->max_out, found);
    fn(user, k, total, found, total < b->max_out ? total : b->max_out);
}

/* Stage D: the exact test and the filter on the candidates, the same decisions as test_rec_exact
 * and passes, with the filter in registers. Falls back to the plain query when the answer would
 * be capped (more than max_out spheres, rare) or the candidates overflowed. */
static void pipe_d(const vbnl_vl_index *x, const vbnl_vl_batch *b, uint32_t k, const pipe_slot *s,
                   vbnl_vl_found *found, vbnl_vl_batch_fn fn, void *user)
{
    if (s->ncand > PIPE_CAND) {
        batch_plain(x, b, k, found, fn, user);
        return;
    }
    const char *rec_k = batch_rec(b, k);
    vec3 p, n = v3s(0.0f), wi = v3s(0.0f);
    memcpy(&p, rec_k + b->p_off, sizeof(p));
    const int filter = b->filter && x->has_normals;
    const int use_cos = filter && b->normal_cos > -1.0f, use_facing = filter && b->facing;
    const float ncos = b->normal_cos;
    if (filter) {
        memcpy(&n, rec_k + b->n_off, sizeof(n));
        memcpy(&wi, rec_k + b->wi_off, sizeof(wi));
    }
    uint32_t m = 0, max_out = b->max_out;
    for (uint32_t i = 0; i < s->ncand; ++i) {
        uint32_t rank = s->cand[i];
        const vl_rec *e = x->rec + rank;
        float dx = p.x - e->cx, dy = p.y - e->cy, dz = p.z - e->cz, r = e->r;
        double d2 = (double)dx * dx + (double)dy * dy + (double)dz * dz; /* = vbnl_vl_dist2(p, centre) */
        if (!(r > 0.0f && d2 < (double)r * r))
            continue;
        vec3 nj = v3(e->nx, e->ny, e->nz);
        if (use_cos && !(v3_dot(nj, n) > ncos))
            continue;
        if (use_facing && !(v3_dot(nj, wi) > 0.0f))
            continue;
        if (m == max_out) { /* capped: the plain query keeps the max_out smallest ids */
            batch_plain(x, b, k, found, fn, user);
            return;
        }
        found[m++] = (vbnl_vl_found){e->id, rank, (float)d2, r};
    }
    fn(user, k, m, found, m); /* in candidate (rank) order: see vl_index.h */
}

static inline __attribute__((always_inline)) void run_pipe(const vbnl_vl_index *x, const vbnl_vl_batch *b,
                                                           vbnl_vl_found *found, vbnl_vl_batch_fn fn, void *user,
                                                           uint32_t nl)
{
    pipe_slot ring[PIPE_SLOTS];
    const uint32_t m = PIPE_SLOTS - 1, count = b->count;
    for (uint32_t k = 0; k < count + 3 * PIPE_STEP; ++k) {
        if (k + PIPE_STEP < count) {
            const char *r = batch_rec(b, k + PIPE_STEP);
            __builtin_prefetch(r);
            __builtin_prefetch(r + b->stride - 1);
        }
        if (k < count)
            pipe_a(x, batch_vec(b, k, b->p_off), &ring[k & m], nl);
        if (k >= PIPE_STEP && k - PIPE_STEP < count)
            pipe_b(x, &ring[(k - PIPE_STEP) & m], nl);
        if (k >= 2 * PIPE_STEP && k - 2 * PIPE_STEP < count)
            pipe_c(x, b, batch_vec(b, k - 2 * PIPE_STEP, b->p_off), &ring[(k - 2 * PIPE_STEP) & m], nl);
        if (k >= 3 * PIPE_STEP)
            pipe_d(x, b, k - 3 * PIPE_STEP, &ring[(k - 3 * PIPE_STEP) & m], found, fn, user);
    }
}

void vbnl_vl_index_query_batch(const vbnl_vl_index *x, const vbnl_vl_batch *b, vbnl_vl_batch_fn fn, void *user)
{
    vbnl_vl_found found[VBNL_VL_BATCH_MAX_OUT];
    uint32_t count = b->count;
    if (x->kind != VBNL_VL_INDEX_GRID) {
        for (uint32_t k = 0; k < count; ++k)
            batch_plain(x, b, k, found, fn, user);
        return;
    }
    if (x->level_count > PIPE_LEVELS) {
        for (uint32_t k = 0; k < count; ++k)
            batch_plain(x, b, k, found, fn, user);
        return;
    }
    if (x->level_count == 1)
        run_pipe(x, b, found, fn, user, 1);
    else
        run_pipe(x, b, found, fn, user, x->level_count);
}

int vbnl_vl_index_has_normals(const vbnl_vl_index *x) { return x->has_normals; }
uint32_t vbnl_vl_index_count(const vbnl_vl_index *x) { return x->count; }
uint32_t vbnl_vl_index_rank(const vbnl_vl_index *x, uint32_t id) { return x->rank_of ? x->rank_of[id] : id; }
uint32_t vbnl_vl_index_id(const vbnl_vl_index *x, uint32_t rank) { return x->rec[rank].id; }
uint64_t vbnl_vl_index_spatial_key(const vbnl_vl_index *x, vec3 p) { return spatial_key(x, p); }
vec3 vbnl_vl_index_center(const vbnl_vl_index *x, uint32_t id) { return rec_center(x->rec + vbnl_vl_index_rank(x, id)); }
float vbnl_vl_index_radius(const vbnl_vl_index *x, uint32_t id) { return x->rec[vbnl_vl_index_rank(x, id)].r; }
vbnl_vl_index_kind vbnl_vl_index_get_kind(const vbnl_vl_index *x) { return x->kind; }
size_t vbnl_vl_index_bytes(const vbnl_vl_index *x) { return x->bytes; }
