/* Spatial index over virtual-light spheres: multi-level grid and Embree point-query variants
 * (see vl_index.h). Used by photon splitting (Li et al. 2022, Section 3.3) and by rendering's
 * BSDF-sampling gather (Section 4.1). */
#include "vl_index.h"

#include <stdlib.h>
#include <string.h>

#define MAX_LEVELS 32u
#define DEFAULT_CELL_SCALE 2.0f
#define EMPTY_KEY UINT64_MAX

/* A sphere as listed in a cell: centre, radius and id side by side so a query touches one
 * contiguous run of memory per cell. */
typedef struct cell_entry {
    float cx, cy, cz, r;
    float nx, ny, nz;
    uint32_t id;
} cell_entry;

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
    cell_entry *entries;
} grid_level;

struct vbnl_vl_index {
    vbnl_vl_index_kind kind;
    uint32_t count;
    vec3 *centers;
    float *radii;
    vec3 *normals;            /* NULL when not given */
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
    uint32_t max_out, n, total;
    const vbnl_vl_filter *f;  /* NULL: no filter */
} query_out;

static inline int passes(const vbnl_vl_filter *f, vec3 nj)
{
    if (f->normal_cos > -1.0f && !(v3_dot(nj, f->n) > f->normal_cos))
        return 0;
    return !f->facing || v3_dot(nj, f->wi) > 0.0f;
}

/* Keeps the max_out smallest ids in ascending order; ids arrive mostly ascending (cells are
 * filled in id order), so the insertion is O(1) in the common case. */
static inline void out_add(query_out *o, uint32_t id, double d2)
{
    o->total++;
    uint32_t n = o->n;
    if (n == o->max_out) {
        if (n == 0 || id > o->ids[n - 1])
            return;
        --n; /* drop the largest id */
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
    free(g->entries);
}

/* Builds level L from the spheres of class L (ids in `members`, ascending). */
static vbnl_result level_build(vbnl_vl_index *x, grid_level *g, const uint32_t *members, uint32_t m, float cell)
{
    vec3 lo = v3s(INFINITY), hi = v3s(-INFINITY);
    for (uint32_t k = 0; k < m; ++k) {
        vec3 a, b;
        sphere_box(x->centers[members[k]], x->radii[members[k]], &a, &b);
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
        cell_range(g, x->centers[members[k]], x->radii[members[k]], a, b);
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
            cell_range(g, x->centers[members[k]], x->radii[members[k]], a, b);
            for (int32_t z = a[2]; z <= b[2]; ++z)
                for (int32_t y = a[1]; y <= b[1]; ++y)
                    for (int32_t xx = a[0]; xx <= b[0]; ++xx)
                        hash_find(g, linear_cell(g, xx, y, z), 1, &ncell);
        }
    }
    g->start = calloc((size_t)ncell + 1, sizeof(uint32_t));
    g->entries = malloc((size_t)(listings ? listings : 1) * sizeof(cell_entry));
    if (!g->start || !g->entries)
        return VBNL_ERR_OUT_OF_MEMORY;
    /* Pass 2: counts, prefix sums, then fill in id order (entries of a cell ascend by id). */
    for (int pass = 0; pass < 2; ++pass) {
        for (uint32_t k = 0; k < m; ++k) {
            uint32_t id = members[k];
            int32_t a[3], b[3];
            cell_range(g, x->centers[id], x->radii[id], a, b);
            for (int32_t z = a[2]; z <= b[2]; ++z)
                for (int32_t y = a[1]; y <= b[1]; ++y)
                    for (int32_t xx = a[0]; xx <= b[0]; ++xx) {
                        uint64_t lc = linear_cell(g, xx, y, z);
                        uint32_t c = g->dense ? (uint32_t)lc : hash_find(g, lc, 0, NULL);
                        if (pass == 0) {
                            g->start[c + 1]++;
                        } else {
                            vec3 ce = x->centers[id], nn = x->normals ? x->normals[id] : v3s(0.0f);
                            g->entries[g->start[c]++] =
                                (cell_entry){ce.x, ce.y, ce.z, x->radii[id], nn.x, nn.y, nn.z, id};
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
    x->bytes += ((size_t)ncell + 1) * sizeof(uint32_t) + (size_t)listings * sizeof(cell_entry);
    if (!g->dense)
        x->bytes += ((size_t)g->hash_mask + 1) * (sizeof(uint64_t) + sizeof(uint32_t));
    return VBNL_OK;
}

static vbnl_result grid_build(vbnl_vl_index *x, float cell_scale)
{
    float r_min = INFINITY;
    for (uint32_t i = 0; i < x->count; ++i)
        if (usable(x->radii[i]) && x->radii[i] < r_min)
            r_min = x->radii[i];
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
    for (uint32_t i = 0; i < x->count; ++i) {
        cls[i] = usable(x->radii[i]) ? (uint8_t)level_of(x->radii[i], r_min) : 0xFF;
        if (cls[i] != 0xFF)
            counts[cls[i]]++;
    }
    for (uint32_t L = 0; L < MAX_LEVELS && res == VBNL_OK; ++L) {
        if (!counts[L])
            continue;
        uint32_t m = 0;
        float r_max = 0.0f;
        for (uint32_t i = 0; i < x->count; ++i)
            if (cls[i] == L) {
                members[m++] = i;
                r_max = fmaxf(r_max, x->radii[i]);
            }
        res = level_build(x, &x->levels[x->level_count++], members, m, cell_scale * r_max);
    }
done:
    free(cls);
    free(members);
    return res;
}

static void grid_query(const vbnl_vl_index *x, vec3 p, query_out *o)
{
    for (uint32_t L = 0; L < x->level_count; ++L) {
        const grid_level *g = &x->levels[L];
        float fx = (p.x - g->lo.x) * g->inv_cell, fy = (p.y - g->lo.y) * g->inv_cell,
              fz = (p.z - g->lo.z) * g->inv_cell;
        /* Far outside the level's box no sphere of it can contain p (the test also drops NaN);
         * near it, the clamp below maps p like cell_range maps the spheres' boxes. */
        if (!(fx > -1.0f && fy > -1.0f && fz > -1.0f && fx < (float)g->n[0] + 1.0f &&
              fy < (float)g->n[1] + 1.0f && fz < (float)g->n[2] + 1.0f))
            continue;
        int32_t c3[3] = {cell_coord(g, p.x, g->lo.x, 0), cell_coord(g, p.y, g->lo.y, 1),
                         cell_coord(g, p.z, g->lo.z, 2)};
        uint64_t lc = linear_cell(g, c3[0], c3[1], c3[2]);
        uint32_t c;
        if (g->dense) {
            c = (uint32_t)lc;
        } else {
            c = hash_find((grid_level *)g, lc, 0, NULL);
            if (c == UINT32_MAX)
                continue;
        }
        const cell_entry *e = g->entries + g->start[c], *end = g->entries + g->start[c + 1];
        for (; e < end; ++e) {
            double d2;
            if (vbnl_vl_contains(v3(e->cx, e->cy, e->cz), e->r, p, &d2) &&
                (!o->f || passes(o->f, v3(e->nx, e->ny, e->nz))))
                out_add(o, e->id, d2);
        }
    }
}

/* ---- Embree -------------------------------------------------------------------------------- */

static void sphere_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const vbnl_vl_index *x = args->geometryUserPtr;
    vec3 c = x->centers[args->primID];
    float r = usable(x->radii[args->primID]) ? x->radii[args->primID] : 0.0f;
    args->bounds_o->lower_x = c.x - r;
    args->bounds_o->lower_y = c.y - r;
    args->bounds_o->lower_z = c.z - r;
    args->bounds_o->upper_x = c.x + r;
    args->bounds_o->upper_y = c.y + r;
    args->bounds_o->upper_z = c.z + r;
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
    uint32_t id = args->primID;
    vec3 p = v3(args->query->x, args->query->y, args->query->z);
    double d2;
    if (vbnl_vl_contains(q->x->centers[id], q->x->radii[id], p, &d2) &&
        (!q->o->f || passes(q->o->f, q->x->normals[id])))
        out_add(q->o, id, d2);
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
    x->centers = malloc(((size_t)desc->count + 1) * sizeof(vec3));
    x->radii = malloc(((size_t)desc->count + 1) * sizeof(float));
    if (!x->centers || !x->radii) {
        vbnl_vl_index_destroy(x);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    if (desc->normals) {
        x->normals = malloc(((size_t)desc->count + 1) * sizeof(vec3));
        if (!x->normals) {
            vbnl_vl_index_destroy(x);
            return VBNL_ERR_OUT_OF_MEMORY;
        }
        if (desc->count)
            memcpy(x->normals, desc->normals, desc->count * sizeof(vec3));
    }
    if (desc->count) {
        memcpy(x->centers, desc->centers, desc->count * sizeof(vec3));
        memcpy(x->radii, desc->radii, desc->count * sizeof(float));
    }
    x->bytes = sizeof(*x) + (size_t)desc->count * ((desc->normals ? 2 : 1) * sizeof(vec3) + sizeof(float));
    vbnl_result r = x->kind == VBNL_VL_INDEX_GRID
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
    free(x->centers);
    free(x->radii);
    free(x->normals);
    free(x);
}

uint32_t vbnl_vl_index_query_filtered(const vbnl_vl_index *x, vec3 p, const vbnl_vl_filter *f, uint32_t max_out,
                                      uint32_t *ids, float *dist2)
{
    query_out o = {ids, dist2, max_out, 0, 0, x->normals ? f : NULL};
    if (x->kind == VBNL_VL_INDEX_GRID)
        grid_query(x, p, &o);
    else if (x->count)
        embree_query_point(x, p, &o);
    return o.total;
}

int vbnl_vl_index_has_normals(const vbnl_vl_index *x) { return x->normals != NULL; }

uint32_t vbnl_vl_index_query(const vbnl_vl_index *x, vec3 p, uint32_t max_out, uint32_t *ids, float *dist2)
{
    query_out o = {ids, dist2, max_out, 0, 0, NULL};
    if (x->kind == VBNL_VL_INDEX_GRID)
        grid_query(x, p, &o);
    else if (x->count)
        embree_query_point(x, p, &o);
    return o.total;
}

uint32_t vbnl_vl_index_count(const vbnl_vl_index *x) { return x->count; }
vec3 vbnl_vl_index_center(const vbnl_vl_index *x, uint32_t id) { return x->centers[id]; }
float vbnl_vl_index_radius(const vbnl_vl_index *x, uint32_t id) { return x->radii[id]; }
vbnl_vl_index_kind vbnl_vl_index_get_kind(const vbnl_vl_index *x) { return x->kind; }
size_t vbnl_vl_index_bytes(const vbnl_vl_index *x) { return x->bytes; }
