/* Spatial index over virtual-light spheres: multi-level grid and Embree point-query variants
 * (see vl_index.h). Used by photon splitting (Li et al. 2022, Section 3.3) and by rendering's
 * BSDF-sampling gather (Section 4.1). */
#include "bigalloc.h"
#include "vl_index_internal.h"

/* ---- spatial order -------------------------------------------------------------------------- */

/* The 21 low bits of v spread to every third bit. */
static inline uint64_t spread3(uint64_t v)
{
#if defined(__BMI2__)
    return _pdep_u64(v & 0x1fffffull, 0x1249249249249249ull);
#else
    v &= 0x1fffffull;
    v = (v | v << 32) & 0x1f00000000ffffull;
    v = (v | v << 16) & 0x1f0000ff0000ffull;
    v = (v | v << 8) & 0x100f00f00f00f00full;
    v = (v | v << 4) & 0x10c30c30c30c30c3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
#endif
}

static inline uint64_t key_coord(float v, float lo, float scale) { return vbi_vl_key_coord(v, lo, scale); }

static inline uint64_t spatial_key(const vbi_vl_index *x, vec3 p)
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
    enum { RADIX_BITS = 11, RADIX_BUCKETS = 1 << RADIX_BITS, RADIX_PASSES = (64 + RADIX_BITS - 1) / RADIX_BITS };
    for (unsigned pass = 0; pass < RADIX_PASSES; ++pass) {
        unsigned shift = pass * RADIX_BITS;
        memset(count, 0, RADIX_BUCKETS * sizeof(size_t));
        for (size_t i = 0; i < n; ++i)
            count[(key[i] >> shift) & (RADIX_BUCKETS - 1)]++;
        if (n == 0 || count[(key[0] >> shift) & (RADIX_BUCKETS - 1)] == n)
            continue;
        size_t sum = 0;
        for (unsigned b = 0; b < RADIX_BUCKETS; ++b) {
            size_t c = count[b];
            count[b] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; ++i) {
            size_t at = count[(key[i] >> shift) & (RADIX_BUCKETS - 1)]++;
            tmp_key[at] = key[i];
            tmp_val[at] = val[i];
        }
        memcpy(key, tmp_key, n * sizeof(uint64_t));
        memcpy(val, tmp_val, n * sizeof(uint32_t));
    }
}

/* rec[] in Morton order of the centres (grid) or in id order (Embree), and the key cube. */
static vbnl_result order_build(vbi_vl_index *x, const vbi_vl_index_desc *desc, int morton)
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
    x->key_scale = (float)(1u << VBI_VLI_KEY_BITS) / ext;
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
    x->rec = vbi_big_alloc((((size_t)n * sizeof(vl_rec) + 63) / 64 + 1) * 64);
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

static int usable(float r) { return r > 0.0f && isfinite(r); }

/* Radius class of r: the smallest L with r <= r_min 2^L (clamped to the last level). */
static uint32_t level_of(float r, float r_min)
{
    uint32_t L = 0;
    float lim = r_min;
    while (r > lim && L + 1 < VBI_VLI_MAX_LEVELS) {
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

static void level_free(grid_level *g)
{
    free(g->start);
    free(g->keys);
    free(g->slot);
    free(g->lst);
}

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

/* The frame of a level over the spheres `members` (ranks, ascending) with cells of edge `cell`
 * (origin, cells per axis); returns the number of listings it would hold (cells overlapped by
 * the spheres' boxes, summed). */
static uint64_t level_frame(const vbi_vl_index *x, grid_level *g, const uint32_t *members, uint32_t m, float cell)
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
    for (int a = 0; a < 3; ++a) {
        double n = floor((double)ext[a] / cell) + 1.0;
        if (n > 1 << 30) /* absurd spread: cap (cells then merely hold more spheres) */
            n = 1 << 30;
        g->n[a] = (int32_t)n;
    }
    uint64_t listings = 0;
    for (uint32_t k = 0; k < m; ++k) {
        int32_t a[3], b[3];
        const vl_rec *e = x->rec + members[k];
        cell_range(g, rec_center(e), e->r, a, b);
        listings += (uint64_t)(b[0] - a[0] + 1) * (uint64_t)(b[1] - a[1] + 1) * (uint64_t)(b[2] - a[2] + 1);
    }
    return listings;
}

/* Builds a level from the spheres `members` (ranks, ascending) with cells of edge `cell`. */
static vbnl_result level_build(vbi_vl_index *x, grid_level *g, const uint32_t *members, uint32_t m, float cell)
{
    uint64_t listings = level_frame(x, g, members, m, cell);
    double cells = (double)g->n[0] * (double)g->n[1] * (double)g->n[2];
    if (listings >= UINT32_MAX)
        return VBNL_ERR_OUT_OF_MEMORY;
    /* Dense when the grid is small next to the number of listings. */
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
    g->start = vbi_big_calloc((size_t)ncell + 1, sizeof(uint32_t));
    uint32_t *fill = malloc(((size_t)ncell + 1) * sizeof(uint32_t));
    if (!g->start || !fill) {
        free(fill);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    float off = 0.0f;
    for (uint32_t k = 0; k < m; ++k) {
        const vl_rec *e = x->rec + members[k];
        float pad = 1e-5f * (e->r + fmaxf(fabsf(e->cx), fmaxf(fabsf(e->cy), fabsf(e->cz))));
        off = fmaxf(off, e->r + pad);
    }
    /* A margin of at least one unit of the frame (255 units per cell + 2 q_off; only cells far
     * larger than the spheres need the floor): the padding listings below then fail the
     * pre-test for every point of their cell. */
    g->q_off = fmaxf(off * 1.001f, cell / 250.0f);
    g->q_scale = 255.0f / (cell + 2.0f * g->q_off);
    /* Pass 2: counts, prefix sums, then fill in rank order (a cell's ranks ascend). Every
     * cell's listings start on a block boundary and fill whole blocks: the pre-test reads whole
     * blocks without lane masks. A padding listing is all zeros (centre at the frame's corner,
     * radius 0, rank 0): its pre-test bound is QSLACK < 0.88 units around the corner, and every
     * point of the cell is at least sqrt(3) units away. A point clamped into a border cell from
     * outside the grid may pass it, but lies in no sphere (the grid covers every sphere's box),
     * so rank 0's exact test rejects it, as the candidates' contract allows. */
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
                            VBI_VLI_QENT(g, fill[c]) = quantize_entry(g, rec_center(e), e->r, c3);
                            VBI_VLI_RANK(g, fill[c]) = rank;
                            fill[c]++;
                        }
                    }
        }
        if (pass == 0) {
            uint64_t total = 0;
            for (uint32_t c = 0; c < ncell; ++c) {
                const uint64_t n = g->start[c + 1];
                g->start[c] = (uint32_t)total;
                fill[c] = (uint32_t)total;
                total += (n + 7u) & ~(uint64_t)7u;
                if (total >= UINT32_MAX) {
                    free(fill);
                    return VBNL_ERR_OUT_OF_MEMORY;
                }
            }
            g->start[ncell] = (uint32_t)total;
            g->lst_bytes = (size_t)total / 8u * 64u + 64u; /* whole blocks, + 1 */
            g->lst = vbi_big_alloc(g->lst_bytes);
            if (!g->lst) {
                free(fill);
                return VBNL_ERR_OUT_OF_MEMORY;
            }
            memset(g->lst, 0, g->lst_bytes);
        }
    }
    free(fill);
    const size_t lst_bytes = g->lst_bytes;
    x->bytes += ((size_t)ncell + 1) * sizeof(uint32_t) + lst_bytes;
    if (!g->dense)
        x->bytes += ((size_t)g->hash_mask + 1) * (sizeof(uint64_t) + sizeof(uint32_t));
    return VBNL_OK;
}

#define ALL_CLASSES UINT32_MAX

/* The ranks of radius class L (every usable sphere for ALL_CLASSES), ascending, into members,
 * and their largest radius into *r_max; returns their count. */
static uint32_t class_members(const vbi_vl_index *x, const uint8_t *cls, uint32_t L, uint32_t *members, float *r_max)
{
    uint32_t m = 0;
    *r_max = 0.0f;
    for (uint32_t k = 0; k < x->count; ++k)
        if (L == ALL_CLASSES ? cls[k] != 0xFF : cls[k] == L) {
            members[m++] = k;
            *r_max = fmaxf(*r_max, x->rec[k].r);
        }
    return m;
}

/* Levels (vl_index.h, "Levels"): the radius classes, or one level for all spheres with the
 * cells of the most populated class when that level would hold at most
 * VBI_VLI_ONE_LEVEL_LISTINGS times the listings of the classes (levels == AUTO), or always
 * (ONE). */
static vbnl_result grid_build(vbi_vl_index *x, float cell_scale, vbi_vl_index_levels levels)
{
    float r_min = INFINITY;
    for (uint32_t k = 0; k < x->count; ++k)
        if (usable(x->rec[k].r) && x->rec[k].r < r_min)
            r_min = x->rec[k].r;
    x->r_min = r_min;
    if (!(r_min < INFINITY))
        return VBNL_OK; /* no usable sphere: every query answers 0 */
    uint32_t counts[VBI_VLI_MAX_LEVELS] = {0};
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
    uint32_t classes = 0, main_class = 0;
    for (uint32_t L = 0; L < VBI_VLI_MAX_LEVELS; ++L) {
        classes += counts[L] > 0;
        if (counts[L] > counts[main_class])
            main_class = L;
    }
    if (levels != VBI_VL_INDEX_LEVELS_CLASSES && classes > 1) {
        float r_main, r_max;
        class_members(x, cls, main_class, members, &r_main);
        double split = 0.0; /* listings of one level per class (AUTO only) */
        grid_level probe;
        memset(&probe, 0, sizeof(probe));
        for (uint32_t L = 0; L < VBI_VLI_MAX_LEVELS && levels == VBI_VL_INDEX_LEVELS_AUTO; ++L)
            if (counts[L]) {
                uint32_t mc = class_members(x, cls, L, members, &r_max);
                split += (double)level_frame(x, &probe, members, mc, cell_scale * r_max);
            }
        uint32_t m = class_members(x, cls, ALL_CLASSES, members, &r_max);
        if (levels == VBI_VL_INDEX_LEVELS_ONE ||
            (double)level_frame(x, &probe, members, m, cell_scale * r_main) <= VBI_VLI_ONE_LEVEL_LISTINGS * split) {
            res = level_build(x, &x->levels[x->level_count++], members, m, cell_scale * r_main);
            goto done;
        }
    }
    for (uint32_t L = 0; L < VBI_VLI_MAX_LEVELS && res == VBNL_OK; ++L) {
        if (!counts[L])
            continue;
        float r_max;
        uint32_t m = class_members(x, cls, L, members, &r_max);
        res = level_build(x, &x->levels[x->level_count++], members, m, cell_scale * r_max);
    }
done:
    free(cls);
    free(members);
    return res;
}

/* ---- Embree -------------------------------------------------------------------------------- */

static void sphere_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const vbi_vl_index *x = args->geometryUserPtr;
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
    const vbi_vl_index *x;
    query_out *o;
} embree_query;

static bool sphere_point_query(struct RTCPointQueryFunctionArguments *args)
{
    const embree_query *q = args->userPtr;
    uint32_t id = args->primID; /* == rank: the Embree variant keeps id order */
    test_rec(q->x->rec + id, id, v3(args->query->x, args->query->y, args->query->z), q->o);
    return false; /* the query radius is unchanged */
}

static vbnl_result embree_build(vbi_vl_index *x, RTCDevice device)
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

static void embree_query_point(const vbi_vl_index *x, vec3 p, query_out *o)
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

vbnl_result vbi_vl_index_create(const vbi_vl_index_desc *desc, vbi_vl_index **out)
{
    if (!out)
        return VBNL_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!desc || (desc->count && (!desc->centers || !desc->radii)) ||
        (desc->kind != VBI_VL_INDEX_GRID && desc->kind != VBI_VL_INDEX_EMBREE) ||
        (desc->kind == VBI_VL_INDEX_EMBREE && !desc->device) || desc->cell_scale < 0.0f ||
        (unsigned)desc->levels > VBI_VL_INDEX_LEVELS_ONE)
        return VBNL_ERR_INVALID_ARGUMENT;
    for (uint32_t i = 0; i < desc->count; ++i)
        if (!v3_is_finite(desc->centers[i]))
            return VBNL_ERR_INVALID_ARGUMENT;
    vbi_vl_index *x = calloc(1, sizeof(*x));
    if (!x)
        return VBNL_ERR_OUT_OF_MEMORY;
    x->kind = desc->kind;
    x->count = desc->count;
    x->has_normals = desc->normals != NULL;
    x->bytes = sizeof(*x);
    vbnl_result r = order_build(x, desc, x->kind == VBI_VL_INDEX_GRID);
    if (r == VBNL_OK)
        r = x->kind == VBI_VL_INDEX_GRID
                ? grid_build(x, desc->cell_scale > 0.0f ? desc->cell_scale : VBI_VLI_DEFAULT_CELL_SCALE, desc->levels)
                : embree_build(x, desc->device);
    if (r != VBNL_OK) {
        vbi_vl_index_destroy(x);
        return r;
    }
    *out = x;
    return VBNL_OK;
}

void vbi_vl_index_destroy(vbi_vl_index *x)
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
static inline __attribute__((always_inline)) uint32_t run_query(const vbi_vl_index *x, vec3 p,
                                                                const vbi_vl_filter *f, uint32_t max_out,
                                                                uint32_t *ids, float *dist2,
                                                                vbi_vl_found *found)
{
    vbi_vl_filter fl;
    if (f)
        fl = *f;
    query_out o = {ids, dist2, found, max_out, 0, 0, f ? &fl : NULL, 0};
    if (x->kind == VBI_VL_INDEX_GRID)
        grid_query(x, p, &o);
    else if (x->count)
        embree_query_point(x, p, &o);
    if (found && !o.sorted)
        found_sort(found, o.n);
    return o.total;
}

uint32_t vbi_vl_index_query_filtered(const vbi_vl_index *x, vec3 p, const vbi_vl_filter *f, uint32_t max_out,
                                      uint32_t *ids, float *dist2)
{
    return run_query(x, p, x->has_normals ? f : NULL, max_out, ids, dist2, NULL);
}

uint32_t vbi_vl_index_query(const vbi_vl_index *x, vec3 p, uint32_t max_out, uint32_t *ids, float *dist2)
{
    return run_query(x, p, NULL, max_out, ids, dist2, NULL);
}

uint32_t vbi_vl_index_query_found(const vbi_vl_index *x, vec3 p, const vbi_vl_filter *f, uint32_t max_out,
                                   vbi_vl_found *found)
{
    return run_query(x, p, f && x->has_normals ? f : NULL, max_out, NULL, NULL, found);
}

uint32_t vbi_vl_index_candidates(const vbi_vl_index *x, vec3 p, uint32_t max_out, uint32_t *ranks)
{
    if (x->kind != VBI_VL_INDEX_GRID) {
        vbi_vl_found f[VBI_VL_BATCH_MAX_OUT];
        uint32_t total = run_query(x, p, NULL, VBI_VL_BATCH_MAX_OUT, NULL, NULL, f);
        if (total > max_out || total > VBI_VL_BATCH_MAX_OUT)
            return max_out + 1;
        for (uint32_t k = 0; k < total; ++k)
            ranks[k] = f[k].rank;
        return total;
    }
    uint32_t n_out = 0;
    VBI_VLI_GRID_CANDIDATES(x, p, {
        if (n_out < max_out)
            ranks[n_out] = rank_;
        n_out++;
    });
    return n_out;
}

void vbi_vl_index_lookup_begin(const vbi_vl_index *x, vec3 p, vbi_vl_lookup *l)
{
    l->p = p;
    l->levels = 0;
    if (x->kind != VBI_VL_INDEX_GRID || x->level_count > VBI_VL_LOOKUP_LEVELS)
        return;
    l->levels = x->level_count;
    for (uint32_t L = 0; L < l->levels; ++L)
        l->cell[L] = vbi_vli_locate(&x->levels[L], p, l->c3[L]);
}

void vbi_vl_index_lookup_fetch(const vbi_vl_index *x, vbi_vl_lookup *l)
{
    for (uint32_t L = 0; L < l->levels; ++L)
        vbi_vli_fetch(&x->levels[L], l->cell[L], &l->s0[L], &l->n[L]);
}

uint32_t vbi_vl_index_lookup_candidates(const vbi_vl_index *x, const vbi_vl_lookup *l, uint32_t max_out,
                                         uint32_t *ranks)
{
    if (!l->levels) /* not staged (or no level: nothing is listed either way) */
        return vbi_vl_index_candidates(x, l->p, max_out, ranks);
    uint32_t n_out = 0;
    for (uint32_t L = 0; L < l->levels; ++L) {
        if (!l->n[L])
            continue;
        const grid_level *g = &x->levels[L];
        float q[3];
        cell_frame(g, l->p, l->c3[L], q);
        VBI_VLI_PRETEST(g, l->s0[L], l->n[L], q, {
            if (n_out < max_out)
                ranks[n_out] = rank_;
            n_out++;
        });
    }
    return n_out;
}

int vbi_vl_index_has_normals(const vbi_vl_index *x) { return x->has_normals; }
uint32_t vbi_vl_index_count(const vbi_vl_index *x) { return x->count; }
uint32_t vbi_vl_index_rank(const vbi_vl_index *x, uint32_t id) { return x->rank_of ? x->rank_of[id] : id; }
uint32_t vbi_vl_index_id(const vbi_vl_index *x, uint32_t rank) { return x->rec[rank].id; }
uint64_t vbi_vl_index_spatial_key(const vbi_vl_index *x, vec3 p) { return spatial_key(x, p); }
vbi_vl_key_grid vbi_vl_index_key_grid(const vbi_vl_index *x) { return (vbi_vl_key_grid){x->key_lo, x->key_scale}; }
vec3 vbi_vl_index_center(const vbi_vl_index *x, uint32_t id) { return rec_center(x->rec + vbi_vl_index_rank(x, id)); }
float vbi_vl_index_radius(const vbi_vl_index *x, uint32_t id) { return x->rec[vbi_vl_index_rank(x, id)].r; }
vbi_vl_index_kind vbi_vl_index_get_kind(const vbi_vl_index *x) { return x->kind; }
uint32_t vbi_vl_index_level_count(const vbi_vl_index *x) { return x->kind == VBI_VL_INDEX_GRID ? x->level_count : 0u; }
size_t vbi_vl_index_bytes(const vbi_vl_index *x) { return x->bytes; }
