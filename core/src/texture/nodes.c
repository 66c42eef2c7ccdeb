/* The scene API of scene.h's texture section: validation and storage of images, patterns,
 * pigments, normals and material nodes; the hidden leaf copies a commit makes for each node; the
 * nodes' share of the scene fingerprint; simple textures (vbnl_scene_add_texture) as pigments. */
#include <stdlib.h>
#include <string.h>

#include "desc.h"
#include "scene_internal.h"

/* ---- storage ------------------------------------------------------------------------------- */

/* Room for `n` more items in (*arr, count, cap); 0 when out of memory. */
static int reserve(void **arr, uint32_t count, uint32_t *cap, size_t item, uint32_t n)
{
    if (count + (uint64_t)n <= *cap)
        return 1;
    uint64_t ncap = *cap ? *cap : 16;
    while (ncap < count + (uint64_t)n)
        ncap *= 2;
    if (ncap > UINT32_MAX)
        return 0;
    void *p = realloc(*arr, (size_t)ncap * item);
    if (!p)
        return 0;
    *arr = p;
    *cap = (uint32_t)ncap;
    return 1;
}
#define VBI_RESERVE(ts, arr, count, cap, n) reserve((void **)&(ts)->arr, (ts)->count, &(ts)->cap, sizeof(*(ts)->arr), (n))

void vbi_texture_set_init(vbi_texture_set *ts)
{
    memset(ts, 0, sizeof(*ts));
    ts->noise = vbi_noise_tables_get();
}

void vbi_texture_set_free(vbi_texture_set *ts)
{
    for (uint32_t i = 0; i < ts->image_count; ++i) {
        free(ts->images[i].texels);
        free(ts->images[i].indices);
    }
    for (uint32_t i = 0; i < ts->pattern_count; ++i) {
        vbi_pattern *p = &ts->patterns[i];
        if (p->kind == VBNL_PATTERN_DENSITY)
            free(p->u.density.values);
        if ((p->kind == VBNL_PATTERN_FUNCTION || p->kind == VBNL_PATTERN_OBJECT) && p->u.function.destroy)
            p->u.function.destroy(p->u.function.user);
    }
    free(ts->images);
    free(ts->warps);
    free(ts->patterns);
    free(ts->pigments);
    free(ts->pigment_entries);
    free(ts->normals);
    free(ts->normal_entries);
    free(ts->slope_entries);
    free(ts->material_entries);
    memset(ts, 0, sizeof(*ts));
}

/* ---- descriptor defaults ------------------------------------------------------------------- */

static void identity16(double m[16])
{
    memset(m, 0, 16 * sizeof(double));
    m[0] = m[5] = m[10] = m[15] = 1.0f;
}

static void turbulence_default(vbnl_turbulence_desc *t)
{
    memset(t, 0, sizeof(*t));
    t->octaves = 6;
    t->omega = 0.5f;
    t->lambda = 2.0f;
}

void vbnl_image_desc_init(vbnl_image_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->channels = 3;
}

void vbnl_warp_desc_init(vbnl_warp_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->kind = VBNL_WARP_TRANSFORM;
    identity16(d->matrix);
    turbulence_default(&d->turbulence);
    d->black_hole.radius = 1.0f;
    d->black_hole.strength = 1.0f;
    d->black_hole.falloff = 2.0f;
    d->mapping.orientation[2] = 1.0f;
    d->mapping.major_radius = 1.0f;
}

void vbnl_pattern_desc_init(vbnl_pattern_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->kind = VBNL_PATTERN_BOZO;
    identity16(d->transform);
    turbulence_default(&d->turbulence);
    d->noise_generator = 2;
    d->wave = VBNL_WAVE_RAMP;
    d->frequency = 1.0f;
    d->exponent = 1.0f;
    d->gradient.direction[0] = 1.0f;
    d->brick.size[0] = 8.0f;
    d->brick.size[1] = 3.0f;
    d->brick.size[2] = 4.5f;
    d->brick.mortar = 0.5f;
    d->agate_turb = 1.0f;
    d->quilted.control0 = d->quilted.control1 = 1.0f;
    d->crackle.form[0] = -1.0f;
    d->crackle.form[1] = 1.0f;
    d->crackle.metric = 2.0f;
    d->fractal.iterations = 10;
    d->fractal.exponent = 2;
    d->fractal.magnet = 1;
    d->fractal.exterior = 1;
    d->fractal.interior_factor = d->fractal.exterior_factor = 1.0f;
    d->facets.size = 0.1f;
    d->facets.metric = 2.0f;
    d->tiling = 1;
    d->pavement.sides = 3;
    d->pavement.tiles = 1;
    d->pavement.pattern = 1;
    d->slope.direction[1] = 1.0f;
    d->image.major_radius = 1.0f;
    d->image.use = 1;
    d->waves = 10;
}

void vbnl_pigment_desc_init(vbnl_pigment_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->kind = VBNL_PIGMENT_SOLID;
}

void vbnl_normal_desc_init(vbnl_normal_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->kind = VBNL_NORMAL_PATTERN;
    d->amount = 0.5f;
    d->accuracy = 0.02f;
}

void vbnl_material_node_desc_init(vbnl_material_node_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->kind = VBNL_NODE_TEXTURED;
}

/* ---- validation helpers -------------------------------------------------------------------- */

static int finite_d(const double *v, int n)
{
    for (int i = 0; i < n; ++i)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

static int finite_n(const float *v, int n)
{
    for (int i = 0; i < n; ++i)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* A row-major 4x4 affine matrix into m and its inverse into inv; 0 when not finite or singular. */
static int affine(const double a[16], dmat *m, dmat *inv)
{
    if (!finite_d(a, 16))
        return 0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            m->m[r][c] = a[4 * r + c];
    double det = m->m[0][0] * (m->m[1][1] * m->m[2][2] - m->m[1][2] * m->m[2][1]) -
                 m->m[0][1] * (m->m[1][0] * m->m[2][2] - m->m[1][2] * m->m[2][0]) +
                 m->m[0][2] * (m->m[1][0] * m->m[2][1] - m->m[1][1] * m->m[2][0]);
    if (!(fabs(det) > 1e-30) || !isfinite(det))
        return 0;
    /* the cofactor matrix C = det(A) A^-T: C e_c is column c of C, that is row c of A^-1 times
     * det(A) */
    for (int c = 0; c < 3; ++c) {
        dvec3 e = d3(c == 0, c == 1, c == 2);
        dvec3 row = d3_scale(dmat_cofactor_vector(m, e), 1.0 / det);
        inv->m[c][0] = row.x;
        inv->m[c][1] = row.y;
        inv->m[c][2] = row.z;
    }
    for (int r = 0; r < 3; ++r)
        inv->m[r][3] = -(inv->m[r][0] * m->m[0][3] + inv->m[r][1] * m->m[1][3] + inv->m[r][2] * m->m[2][3]);
    return 1;
}

static int is_identity16(const double a[16])
{
    for (int i = 0; i < 16; ++i)
        if (a[i] != ((i % 5) == 0 ? 1.0 : 0.0))
            return 0;
    return 1;
}

static vbnl_result turb_from(const vbnl_turbulence_desc *t, vbi_turb *out, const char *what, vbnl_error *err)
{
    if (!finite_d(t->amount, 3) || !isfinite(t->omega) || !isfinite(t->lambda))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s: turbulence values must be finite", what);
    out->amount = d3(t->amount[0], t->amount[1], t->amount[2]);
    /* POV-Ray keeps octaves within 1..10 */
    out->octaves = t->octaves < 1 ? 1 : (t->octaves > 10 ? 10 : t->octaves);
    out->omega = t->omega;
    out->lambda = t->lambda;
    return VBNL_OK;
}

/* ---- images -------------------------------------------------------------------------------- */

static vbnl_result add_image(vbi_texture_set *ts, const vbnl_image_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = VBNL_OK;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_image_desc, err)) != VBNL_OK)
        return r;
    if (!d->texels || d->width == 0 || d->height == 0 || d->width > (1u << 16) || d->height > (1u << 16))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "image needs texels and a size in [1, 65536]^2 (got %u x %u)",
                              d->width, d->height);
    if (d->channels < 1 || d->channels > 4)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "image channels must be 1..4 (got %u)", d->channels);
    size_t n = (size_t)d->width * d->height * d->channels;
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(d->texels[i]))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "image texels must be finite");
    if (!VBI_RESERVE(ts, images, image_count, image_cap, 1))
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbi_image im = {d->width, d->height, d->channels, malloc(n * sizeof(float)), NULL, d->channels == 1 || d->channels == 3};
    if (d->indices)
        im.indices = malloc((size_t)d->width * d->height);
    if (!im.texels || (d->indices && !im.indices)) {
        free(im.texels);
        free(im.indices);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    memcpy(im.texels, d->texels, n * sizeof(float));
    if (d->indices)
        memcpy(im.indices, d->indices, (size_t)d->width * d->height);
    ts->images[ts->image_count] = im;
    if (out_id)
        *out_id = ts->image_count;
    ts->image_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_image(vbnl_scene *s, const vbnl_image_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_image", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_image: desc is NULL");
    return add_image(&s->tex, d, out_id, err);
}

/* ---- patterns ------------------------------------------------------------------------------ */

static vbnl_result warp_from(const vbnl_warp_desc *d, vbi_warp *w, vbnl_error *err)
{
    vbnl_result r = VBI_DESC_CHECK(d, vbnl_warp_desc, err);
    if (r != VBNL_OK)
        return r;
    memset(w, 0, sizeof(*w));
    w->kind = d->kind;
    switch (d->kind) {
    case VBNL_WARP_TRANSFORM:
        if (!affine(d->matrix, &w->m, &w->inv))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "warp transform is singular or not finite");
        return VBNL_OK;
    case VBNL_WARP_TURBULENCE:
        return turb_from(&d->turbulence, &w->turb, "turbulence warp", err);
    case VBNL_WARP_REPEAT:
        if (d->repeat.axis < 0 || d->repeat.axis > 2 || !(d->repeat.width != 0.0f) || !isfinite(d->repeat.width) ||
            !finite_d(d->repeat.offset, 3))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "repeat warp needs an axis 0..2 and a finite non-zero width");
        w->axis = d->repeat.axis;
        w->width = d->repeat.width;
        w->offset = d3(d->repeat.offset[0], d->repeat.offset[1], d->repeat.offset[2]);
        w->flip = d3(d->repeat.flip[0] ? -1.0 : 1.0, d->repeat.flip[1] ? -1.0 : 1.0, d->repeat.flip[2] ? -1.0 : 1.0);
        return VBNL_OK;
    case VBNL_WARP_BLACK_HOLE:
        if (!finite_d(d->black_hole.center, 3) || !(d->black_hole.radius > 0.0f) || !isfinite(d->black_hole.radius) ||
            !isfinite(d->black_hole.strength) || !isfinite(d->black_hole.falloff) || !finite_d(d->black_hole.repeat, 3) ||
            !finite_d(d->black_hole.turbulence, 3))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "black_hole warp needs a radius > 0 and finite values");
        w->center = d3(d->black_hole.center[0], d->black_hole.center[1], d->black_hole.center[2]);
        w->radius = d->black_hole.radius;
        w->strength = d->black_hole.strength;
        w->falloff = d->black_hole.falloff;
        w->inverse = d->black_hole.inverse != 0;
        w->repeat_vec = d3(d->black_hole.repeat[0], d->black_hole.repeat[1], d->black_hole.repeat[2]);
        w->jitter = d3(d->black_hole.turbulence[0], d->black_hole.turbulence[1], d->black_hole.turbulence[2]);
        w->repeat = d->black_hole.repeat[0] != 0.0f || d->black_hole.repeat[1] != 0.0f || d->black_hole.repeat[2] != 0.0f;
        w->uncertain = w->repeat && (d->black_hole.turbulence[0] != 0.0f || d->black_hole.turbulence[1] != 0.0f ||
                                     d->black_hole.turbulence[2] != 0.0f);
        return VBNL_OK;
    case VBNL_WARP_SPHERICAL:
    case VBNL_WARP_CYLINDRICAL:
    case VBNL_WARP_TOROIDAL:
    case VBNL_WARP_PLANAR: {
        dvec3 o = d3(d->mapping.orientation[0], d->mapping.orientation[1], d->mapping.orientation[2]);
        if (!finite_d(d->mapping.orientation, 3) || !(d3_len(o) > 0.0) || !isfinite(d->mapping.dist_exp) ||
            !isfinite(d->mapping.major_radius) || !isfinite(d->mapping.offset))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mapping warp needs a non-zero orientation and finite values");
        w->orient = d3_norm(o);
        w->dist_exp = d->mapping.dist_exp;
        w->major_radius = d->mapping.major_radius;
        w->plane_offset = d->mapping.offset;
        return VBNL_OK;
    }
    case VBNL_WARP_CUBIC:
        return VBNL_OK;
    }
    return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown warp kind %d", (int)d->kind);
}

static uint32_t pigment_depth(const vbi_texture_set *ts, uint32_t id_plus1)
{
    return id_plus1 ? ts->pigments[id_plus1 - 1].depth : 0;
}

static uint32_t pattern_depth(const vbi_texture_set *ts, uint32_t id_plus1)
{
    if (!id_plus1)
        return 0;
    const vbi_pattern *p = &ts->patterns[id_plus1 - 1];
    return p->kind == VBNL_PATTERN_PIGMENT ? pigment_depth(ts, p->u.pigment + 1) : 0;
}

#define VBI_BAD(...) return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, __VA_ARGS__)

static vbnl_result pattern_params(const vbi_texture_set *ts, const vbnl_pattern_desc *d, vbi_pattern *p,
                                  vbnl_error *err)
{
    switch (d->kind) {
    case VBNL_PATTERN_GRADIENT: {
        dvec3 g = d3(d->gradient.direction[0], d->gradient.direction[1], d->gradient.direction[2]);
        if (!finite_d(d->gradient.direction, 3) || !(d3_len(g) > 0.0))
            VBI_BAD("gradient needs a non-zero direction");
        p->u.gradient = d3_norm(g);
        break;
    }
    case VBNL_PATTERN_BRICK:
        for (int i = 0; i < 3; ++i)
            if (!(d->brick.size[i] > 0.0f) || !isfinite(d->brick.size[i]))
                VBI_BAD("brick_size components must be > 0");
        if (!(d->brick.mortar >= 0.0f) || !isfinite(d->brick.mortar))
            VBI_BAD("mortar must be >= 0");
        p->u.brick.size = d3(d->brick.size[0], d->brick.size[1], d->brick.size[2]);
        /* POV-Ray's parser takes two epsilons off, and keeps the mortar in single precision */
        p->u.brick.mortar = (float)(d->brick.mortar - 2e-10);
        break;
    case VBNL_PATTERN_AGATE:
        if (!isfinite(d->agate_turb))
            VBI_BAD("agate_turb must be finite");
        p->u.agate_turb = d->agate_turb;
        break;
    case VBNL_PATTERN_QUILTED:
        if (!isfinite(d->quilted.control0) || !isfinite(d->quilted.control1))
            VBI_BAD("quilted controls must be finite");
        p->u.quilted.c0 = d->quilted.control0;
        p->u.quilted.c1 = d->quilted.control1;
        break;
    case VBNL_PATTERN_SPIRAL1:
    case VBNL_PATTERN_SPIRAL2:
        p->u.arms = d->spiral_arms;
        break;
    case VBNL_PATTERN_CRACKLE:
        if (!finite_d(d->crackle.form, 3) || !(d->crackle.metric > 0.0f) || !isfinite(d->crackle.metric) ||
            !isfinite(d->crackle.offset))
            VBI_BAD("crackle needs a finite form, a metric > 0 and a finite offset");
        p->u.crackle.form = d3(d->crackle.form[0], d->crackle.form[1], d->crackle.form[2]);
        p->u.crackle.metric = d->crackle.metric;
        p->u.crackle.offset = d->crackle.offset;
        p->u.crackle.solid = d->crackle.solid != 0;
        break;
    case VBNL_PATTERN_JULIA:
    case VBNL_PATTERN_MANDEL:
    case VBNL_PATTERN_MAGNET:
        if (d->fractal.iterations < 1 || d->fractal.iterations > 1000000)
            VBI_BAD("fractal iterations must be 1..1000000 (got %d)", d->fractal.iterations);
        if (d->kind != VBNL_PATTERN_MAGNET && (d->fractal.exponent < 2 || d->fractal.exponent > 33))
            VBI_BAD("fractal exponent must be 2..33 (got %d)", d->fractal.exponent);
        if (d->kind == VBNL_PATTERN_MAGNET && d->fractal.magnet != 1 && d->fractal.magnet != 2)
            VBI_BAD("magnet type must be 1 or 2 (got %d)", d->fractal.magnet);
        if (d->fractal.interior < 0 || d->fractal.interior > 6 || d->fractal.exterior < 0 || d->fractal.exterior > 8)
            VBI_BAD("fractal interior type must be 0..6 and exterior type 0..8");
        if (!finite_d(d->fractal.coord, 2) || !isfinite(d->fractal.interior_factor) ||
            !isfinite(d->fractal.exterior_factor))
            VBI_BAD("fractal values must be finite");
        p->u.fractal.iterations = d->fractal.iterations;
        p->u.fractal.exponent = d->fractal.exponent;
        p->u.fractal.magnet = d->fractal.magnet;
        p->u.fractal.julia = d->kind == VBNL_PATTERN_JULIA || d->fractal.julia != 0;
        p->u.fractal.interior = d->fractal.interior;
        p->u.fractal.exterior = d->fractal.exterior;
        p->u.fractal.cu = d->fractal.coord[0];
        p->u.fractal.cv = d->fractal.coord[1];
        p->u.fractal.ifactor = d->fractal.interior_factor;
        p->u.fractal.efactor = d->fractal.exterior_factor;
        break;
    case VBNL_PATTERN_FACETS:
        if (!isfinite(d->facets.size) || !isfinite(d->facets.coords) || !(d->facets.metric > 0.0f) ||
            !isfinite(d->facets.metric))
            VBI_BAD("facets needs finite values and a metric > 0");
        p->u.facets.size = d->facets.size;
        p->u.facets.coords = d->facets.coords;
        p->u.facets.metric = d->facets.metric;
        break;
    case VBNL_PATTERN_TILING:
        if (d->tiling < 1 || d->tiling > 24)
            VBI_BAD("tiling type must be 1..24 (got %d; POV-Ray's Penrose tilings 25..27 are not implemented)",
                     d->tiling);
        p->u.tiling = d->tiling;
        break;
    case VBNL_PATTERN_PAVEMENT:
        VBI_BAD("pavement is not implemented");
    case VBNL_PATTERN_SLOPE: {
        if (!finite_d(d->slope.direction, 3) || !finite_d(d->slope.altitude, 3) || !isfinite(d->slope.low) ||
            !isfinite(d->slope.high) || !isfinite(d->slope.alt_low) || !isfinite(d->slope.alt_high))
            VBI_BAD("slope values must be finite");
        dvec3 dir = d3(d->slope.direction[0], d->slope.direction[1], d->slope.direction[2]);
        dvec3 alt = d3(d->slope.altitude[0], d->slope.altitude[1], d->slope.altitude[2]);
        p->u.slope.point_at = d->slope.point_at != 0;
        double ls = p->u.slope.point_at ? 1.0 : d3_len(dir), la = p->u.slope.point_at ? 0.0 : d3_len(alt);
        if (!(ls + la > 0.0))
            VBI_BAD("slope needs a non-zero slope or altitude vector");
        p->u.slope.dir = p->u.slope.point_at ? dir : d3_norm(dir);
        p->u.slope.alt = d3_norm(alt);
        p->u.slope.w_slope = ls / (ls + la);
        p->u.slope.w_alt = 1.0 - p->u.slope.w_slope;
        /* POV-Ray's ranges: [low, high] unless they are equal (then ignored) */
        p->u.slope.low = d->slope.high != d->slope.low ? d->slope.low : 0.0;
        p->u.slope.span = d->slope.high != d->slope.low ? d->slope.high - d->slope.low : 0.0;
        p->u.slope.alt_low = d->slope.alt_high != d->slope.alt_low ? d->slope.alt_low : 0.0;
        p->u.slope.alt_span = d->slope.alt_high != d->slope.alt_low ? d->slope.alt_high - d->slope.alt_low : 0.0;
        break;
    }
    case VBNL_PATTERN_DENSITY: {
        const uint32_t nx = d->density.nx, ny = d->density.ny, nz = d->density.nz;
        if (!d->density.values || nx < 1 || ny < 1 || nz < 1 || nx > 65535 || ny > 65535 || nz > 65535 ||
            (uint64_t)nx * ny * nz > (1ull << 31))
            VBI_BAD("density needs values and a grid size of 1..65535 per axis");
        size_t n = (size_t)nx * ny * nz;
        for (size_t i = 0; i < n; ++i)
            if (!isfinite(d->density.values[i]))
                VBI_BAD("density values must be finite");
        p->u.density.values = malloc(n * sizeof(float));
        if (!p->u.density.values)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        memcpy(p->u.density.values, d->density.values, n * sizeof(float));
        p->u.density.nx = nx;
        p->u.density.ny = ny;
        p->u.density.nz = nz;
        p->u.density.interpolate = d->density.interpolate < 0 ? 0 : d->density.interpolate;
        break;
    }
    case VBNL_PATTERN_IMAGE:
        if (d->image.image == 0 || d->image.image > ts->image_count)
            VBI_BAD("image pattern names no image (%u; %u added, it is id + 1)", d->image.image, ts->image_count);
        if (d->image.use < 0 || d->image.use > 4 || !isfinite(d->image.filter_all) || !isfinite(d->image.transmit_all) ||
            !isfinite(d->image.major_radius))
            VBI_BAD("image pattern needs use 0..4 and finite values");
        if (d->image.map_type != 0 && d->image.map_type != 1 && d->image.map_type != 2 && d->image.map_type != 5)
            VBI_BAD("image map_type must be 0, 1, 2 or 5 (got %d)", d->image.map_type);
        p->u.image.image = d->image.image - 1;
        p->u.image.map_type = d->image.map_type;
        p->u.image.interpolate = d->image.interpolate;
        p->u.image.use = d->image.use;
        p->u.image.wrap = d->image.once ? VBI_IMAGE_ONCE : VBI_IMAGE_REPEAT;
        p->u.image.filter_all = d->image.filter_all;
        p->u.image.transmit_all = d->image.transmit_all;
        p->u.image.major_radius = d->image.major_radius;
        break;
    case VBNL_PATTERN_FUNCTION:
    case VBNL_PATTERN_OBJECT:
        if (!d->function.fn)
            VBI_BAD("function and object patterns need a callback");
        p->u.function.fn = d->function.fn;
        p->u.function.user = d->function.user;
        p->u.function.destroy = d->function.destroy;
        break;
    case VBNL_PATTERN_PIGMENT:
        if (d->pigment == 0 || d->pigment > ts->pigment_count)
            VBI_BAD("pigment pattern names no pigment (%u; %u added, it is id + 1)", d->pigment, ts->pigment_count);
        p->u.pigment = d->pigment - 1;
        break;
    case VBNL_PATTERN_RIPPLES:
    case VBNL_PATTERN_WAVES:
        if (d->waves < 1 || d->waves > VBI_NOISE_MAX_WAVES)
            VBI_BAD("number of waves must be 1..%d (got %d)", VBI_NOISE_MAX_WAVES, d->waves);
        p->u.waves = d->waves;
        break;
    default:
        break;
    }
    return VBNL_OK;
}

static vbnl_result add_pattern(vbi_texture_set *ts, const vbnl_pattern_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = VBNL_OK;
    if (!d)
        VBI_BAD("desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_pattern_desc, err)) != VBNL_OK)
        return r;
    if ((unsigned)d->kind >= VBNL_PATTERN_KIND_COUNT)
        VBI_BAD("unknown pattern kind %d", (int)d->kind);
    if (d->warp_count > VBNL_TEXTURE_WARP_MAX || (d->warp_count && !d->warps))
        VBI_BAD("a pattern has at most %u warps (got %u)", VBNL_TEXTURE_WARP_MAX, d->warp_count);
    if (d->noise_generator < 1 || d->noise_generator > 3)
        VBI_BAD("noise_generator must be 1, 2 or 3 (got %d)", d->noise_generator);
    if ((unsigned)d->wave > VBNL_WAVE_POLY || !isfinite(d->frequency) || !isfinite(d->phase) || !isfinite(d->exponent))
        VBI_BAD("pattern wave must be known and frequency, phase and exponent finite");
    vbi_pattern p;
    memset(&p, 0, sizeof(p));
    p.kind = d->kind;
    if (!affine(d->transform, &p.xf, &p.xf_inv))
        VBI_BAD("pattern transform is singular or not finite");
    p.has_xf = !is_identity16(d->transform);
    if ((r = turb_from(&d->turbulence, &p.turb, "pattern", err)) != VBNL_OK)
        return r;
    p.has_turb = d->turbulence.amount[0] != 0.0f || d->turbulence.amount[1] != 0.0f ||
                 d->turbulence.amount[2] != 0.0f || d->kind == VBNL_PATTERN_AGATE;
    p.generator = d->noise_generator;
    p.wave = d->wave;
    p.frequency = d->frequency;
    p.phase = d->phase;
    p.exponent = d->exponent;
    if (!VBI_RESERVE(ts, warps, warp_count, warp_cap, d->warp_count) ||
        !VBI_RESERVE(ts, patterns, pattern_count, pattern_cap, 1))
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    for (uint32_t i = 0; i < d->warp_count; ++i)
        if ((r = warp_from(&d->warps[i], &ts->warps[ts->warp_count + i], err)) != VBNL_OK)
            return r;
    if ((r = pattern_params(ts, d, &p, err)) != VBNL_OK)
        return r;
    if (d->kind == VBNL_PATTERN_PIGMENT && ts->pigments[p.u.pigment].depth + 1 > VBNL_TEXTURE_DEPTH_MAX)
        VBI_BAD("textures nested more than %u deep", VBNL_TEXTURE_DEPTH_MAX);
    p.warp_begin = ts->warp_count;
    p.warp_count = d->warp_count;
    ts->warp_count += d->warp_count;
    ts->patterns[ts->pattern_count] = p;
    if (out_id)
        *out_id = ts->pattern_count;
    ts->pattern_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_pattern(vbnl_scene *s, const vbnl_pattern_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_pattern", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_pattern: desc is NULL");
    return add_pattern(&s->tex, d, out_id, err);
}

/* ---- pigments ------------------------------------------------------------------------------ */

static vbnl_result check_pattern_ref(const vbi_texture_set *ts, uint32_t id_plus1, int required, int image,
                                     const char *what, vbnl_error *err)
{
    if (!id_plus1) {
        if (required)
            VBI_BAD("%s needs a pattern", what);
        return VBNL_OK;
    }
    if (id_plus1 > ts->pattern_count)
        VBI_BAD("%s names no pattern (%u; %u added, it is id + 1)", what, id_plus1, ts->pattern_count);
    if (image && ts->patterns[id_plus1 - 1].kind != VBNL_PATTERN_IMAGE)
        VBI_BAD("%s needs an IMAGE pattern", what);
    return VBNL_OK;
}

/* Map values sorted (maps) and finite. */
static vbnl_result check_values(const float *values, size_t stride, uint32_t n, int sorted, const char *what,
                                vbnl_error *err)
{
    for (uint32_t i = 0; i < n; ++i) {
        float v = *(const float *)((const char *)values + i * stride);
        float prev = i ? *(const float *)((const char *)values + (i - 1) * stride) : v;
        if (!isfinite(v) || (sorted && v < prev))
            VBI_BAD("%s values must be finite%s (entry %u)", what, sorted ? " and sorted" : "", i);
    }
    return VBNL_OK;
}

static vbnl_result add_pigment(vbi_texture_set *ts, const vbnl_pigment_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = VBNL_OK;
    if (!d)
        VBI_BAD("desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_pigment_desc, err)) != VBNL_OK)
        return r;
    vbi_pigment pg;
    memset(&pg, 0, sizeof(pg));
    pg.kind = d->kind;
    pg.uv = d->uv != 0;
    uint32_t depth = 0;
    switch (d->kind) {
    case VBNL_PIGMENT_SOLID:
        if (!finite_n(d->color, 5))
            VBI_BAD("pigment colour must be finite");
        memcpy(pg.color, d->color, sizeof(pg.color));
        break;
    case VBNL_PIGMENT_IMAGE:
        if ((r = check_pattern_ref(ts, d->pattern, 1, 1, "image pigment", err)) != VBNL_OK)
            return r;
        break;
    case VBNL_PIGMENT_MAP:
    case VBNL_PIGMENT_AVERAGE: {
        const int map = d->kind == VBNL_PIGMENT_MAP;
        if ((r = check_pattern_ref(ts, d->pattern, map, 0, map ? "pigment map" : "average pigment", err)) != VBNL_OK)
            return r;
        if (!d->map || d->map_count == 0 || d->map_count > VBNL_TEXTURE_MAP_MAX)
            VBI_BAD("pigment needs a map of 1..%u entries", VBNL_TEXTURE_MAP_MAX);
        if ((r = check_values(&d->map[0].value, sizeof(*d->map), d->map_count, map, "pigment map", err)) != VBNL_OK)
            return r;
        for (uint32_t i = 0; i < d->map_count; ++i) {
            if (!finite_n(d->map[i].color, 5))
                VBI_BAD("pigment map colours must be finite (entry %u)", i);
            if (d->map[i].pigment > ts->pigment_count)
                VBI_BAD("pigment map entry %u names no pigment (%u; %u added, it is id + 1)", i, d->map[i].pigment,
                         ts->pigment_count);
            uint32_t e = pigment_depth(ts, d->map[i].pigment);
            depth = e > depth ? e : depth;
        }
        if (!VBI_RESERVE(ts, pigment_entries, pigment_entry_count, pigment_entry_cap, d->map_count))
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        pg.entry_begin = ts->pigment_entry_count;
        pg.entry_count = d->map_count;
        break;
    }
    default:
        VBI_BAD("unknown pigment kind %d", (int)d->kind);
    }
    pg.pattern = d->kind == VBNL_PIGMENT_SOLID ? 0 : d->pattern;
    uint32_t pd = pattern_depth(ts, pg.pattern);
    depth = (pd > depth ? pd : depth) + 1;
    if (depth > VBNL_TEXTURE_DEPTH_MAX)
        VBI_BAD("textures nested more than %u deep", VBNL_TEXTURE_DEPTH_MAX);
    pg.depth = depth;
    if (!VBI_RESERVE(ts, pigments, pigment_count, pigment_cap, 1))
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    if (pg.entry_count) {
        memcpy(ts->pigment_entries + pg.entry_begin, d->map, sizeof(*d->map) * pg.entry_count);
        ts->pigment_entry_count += pg.entry_count;
    }
    ts->pigments[ts->pigment_count] = pg;
    if (out_id)
        *out_id = ts->pigment_count;
    ts->pigment_count++;
    return VBNL_OK;
}

vbnl_result vbnl_scene_add_pigment(vbnl_scene *s, const vbnl_pigment_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_pigment", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_scene_add_pigment: desc is NULL");
    return add_pigment(&s->tex, d, out_id, err);
}

/* ---- normals ------------------------------------------------------------------------------- */

vbnl_result vbnl_scene_add_normal(vbnl_scene *s, const vbnl_normal_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_normal", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        VBI_BAD("vbnl_scene_add_normal: desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_normal_desc, err)) != VBNL_OK)
        return r;
    vbi_texture_set *ts = &s->tex;
    if ((unsigned)d->kind > VBNL_NORMAL_IMAGE)
        VBI_BAD("unknown normal kind %d", (int)d->kind);
    if (!isfinite(d->amount) || !(d->accuracy > 0.0f) || !isfinite(d->accuracy))
        VBI_BAD("normal needs a finite amount and an accuracy > 0");
    const int needs = d->kind != VBNL_NORMAL_AVERAGE;
    if ((r = check_pattern_ref(ts, d->pattern, needs, d->kind == VBNL_NORMAL_IMAGE, "normal", err)) != VBNL_OK)
        return r;
    vbi_normal nm;
    memset(&nm, 0, sizeof(nm));
    nm.kind = d->kind;
    nm.pattern = d->pattern;
    nm.amount = d->amount;
    nm.accuracy = d->accuracy;
    nm.no_bump_scale = d->no_bump_scale != 0;
    nm.uv = d->uv != 0;
    uint32_t depth = pattern_depth(ts, d->pattern);
    if (d->slope_map_count) {
        if (!d->slope_map || d->slope_map_count > VBNL_TEXTURE_MAP_MAX)
            VBI_BAD("slope map needs 1..%u entries", VBNL_TEXTURE_MAP_MAX);
        if ((r = check_values(&d->slope_map[0].value, sizeof(*d->slope_map), d->slope_map_count, 1, "slope map",
                              err)) != VBNL_OK)
            return r;
        for (uint32_t i = 0; i < d->slope_map_count; ++i)
            if (!isfinite(d->slope_map[i].height) || !isfinite(d->slope_map[i].slope))
                VBI_BAD("slope map heights and slopes must be finite (entry %u)", i);
    }
    if (d->kind == VBNL_NORMAL_MAP || d->kind == VBNL_NORMAL_AVERAGE) {
        if (!d->map || d->map_count == 0 || d->map_count > VBNL_TEXTURE_MAP_MAX)
            VBI_BAD("normal needs a map of 1..%u entries", VBNL_TEXTURE_MAP_MAX);
        if ((r = check_values(&d->map[0].value, sizeof(*d->map), d->map_count, d->kind == VBNL_NORMAL_MAP,
                              "normal map", err)) != VBNL_OK)
            return r;
        for (uint32_t i = 0; i < d->map_count; ++i) {
            if (d->map[i].normal >= ts->normal_count)
                VBI_BAD("normal map entry %u names no normal (%u; %u added)", i, d->map[i].normal, ts->normal_count);
            uint32_t e = ts->normals[d->map[i].normal].depth;
            depth = e > depth ? e : depth;
        }
    }
    if (++depth > VBNL_TEXTURE_DEPTH_MAX)
        VBI_BAD("textures nested more than %u deep", VBNL_TEXTURE_DEPTH_MAX);
    nm.depth = depth;
    if (!VBI_RESERVE(ts, normals, normal_count, normal_cap, 1) ||
        !VBI_RESERVE(ts, slope_entries, slope_entry_count, slope_entry_cap, d->slope_map_count) ||
        !VBI_RESERVE(ts, normal_entries, normal_entry_count, normal_entry_cap, d->map_count))
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    nm.slope_begin = ts->slope_entry_count;
    nm.slope_count = d->slope_map_count;
    if (nm.slope_count)
        memcpy(ts->slope_entries + nm.slope_begin, d->slope_map, sizeof(*d->slope_map) * nm.slope_count);
    ts->slope_entry_count += nm.slope_count;
    if (d->kind == VBNL_NORMAL_MAP || d->kind == VBNL_NORMAL_AVERAGE) {
        nm.entry_begin = ts->normal_entry_count;
        nm.entry_count = d->map_count;
        memcpy(ts->normal_entries + nm.entry_begin, d->map, sizeof(*d->map) * nm.entry_count);
        ts->normal_entry_count += nm.entry_count;
    }
    ts->normals[ts->normal_count] = nm;
    if (out_id)
        *out_id = ts->normal_count;
    ts->normal_count++;
    return VBNL_OK;
}

/* ---- material nodes ------------------------------------------------------------------------ */

static uint32_t material_depth(const vbnl_scene *s, uint32_t m)
{
    return s->materials[m].is_node ? s->materials[m].node.depth : 0;
}

/* The material that lets light through unchanged (a dielectric of ior 1), made once. */
static vbnl_result pass_material(vbnl_scene *s, vbnl_error *err)
{
    if (s->pass_material)
        return VBNL_OK;
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.type = VBNL_MATERIAL_DIELECTRIC;
    md.ior = 1.0f;
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 1.0f;
    uint32_t id;
    vbnl_result r = vbnl_scene_add_material(s, &md, &id, err);
    if (r == VBNL_OK)
        s->pass_material = id + 1;
    return r;
}

vbnl_result vbnl_scene_add_material_node(vbnl_scene *s, const vbnl_material_node_desc *d, uint32_t *out_id,
                                         vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_material_node", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        VBI_BAD("vbnl_scene_add_material_node: desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_material_node_desc, err)) != VBNL_OK)
        return r;
    vbi_texture_set *ts = &s->tex;
    if (!finite_n(d->emission, 3) || !(d->emission[0] >= 0.0f && d->emission[1] >= 0.0f && d->emission[2] >= 0.0f))
        VBI_BAD("material node emission must be finite and >= 0");
    vbi_mnode nd;
    memset(&nd, 0, sizeof(nd));
    nd.kind = d->kind;
    nd.uv = d->uv != 0;
    uint32_t depth = 0;
    const vbnl_material_map_entry *entries = NULL;
    uint32_t count = 0;
    switch (d->kind) {
    case VBNL_NODE_TEXTURED:
        if (d->material >= s->material_count || s->materials[d->material].is_node)
            VBI_BAD("a textured node needs a plain material (got %u of %u)", d->material, s->material_count);
        if (d->pigment > ts->pigment_count || d->normal > ts->normal_count)
            VBI_BAD("textured node names no pigment or normal (ids + 1: %u, %u)", d->pigment, d->normal);
        if (d->transmission > s->material_count || (d->transmission && s->materials[d->transmission - 1].is_node))
            VBI_BAD("textured node transmission must be a plain material (id + 1: %u)", d->transmission);
        nd.material = d->material;
        nd.pigment = d->pigment;
        nd.normal = d->normal;
        if (!d->transmission) {
            if ((r = pass_material(s, err)) != VBNL_OK)
                return r;
            nd.transmission = s->pass_material;
        } else {
            nd.transmission = d->transmission;
        }
        depth = pigment_depth(ts, d->pigment);
        if (d->normal && ts->normals[d->normal - 1].depth > depth)
            depth = ts->normals[d->normal - 1].depth;
        break;
    case VBNL_NODE_MAP:
    case VBNL_NODE_AVERAGE: {
        const int map = d->kind == VBNL_NODE_MAP;
        if ((r = check_pattern_ref(ts, d->pattern, map, 0, map ? "material map" : "material average", err)) != VBNL_OK)
            return r;
        if (!d->map || d->map_count == 0 || d->map_count > VBNL_TEXTURE_MAP_MAX)
            VBI_BAD("material node needs a map of 1..%u entries", VBNL_TEXTURE_MAP_MAX);
        if ((r = check_values(&d->map[0].value, sizeof(*d->map), d->map_count, map, "material map", err)) != VBNL_OK)
            return r;
        nd.pattern = d->pattern;
        depth = pattern_depth(ts, d->pattern);
        entries = d->map;
        count = d->map_count;
        break;
    }
    case VBNL_NODE_LAYERS:
        if (!d->layers || d->layer_count == 0 || d->layer_count > VBNL_TEXTURE_MAP_MAX)
            VBI_BAD("layers need 1..%u materials", VBNL_TEXTURE_MAP_MAX);
        count = d->layer_count;
        break;
    default:
        VBI_BAD("unknown material node kind %d", (int)d->kind);
    }
    for (uint32_t i = 0; i < count; ++i) {
        uint32_t m = entries ? entries[i].material : d->layers[i];
        if (m >= s->material_count)
            VBI_BAD("material node entry %u names no material (%u; %u added)", i, m, s->material_count);
        uint32_t e = material_depth(s, m);
        depth = e > depth ? e : depth;
    }
    if (++depth > VBNL_TEXTURE_DEPTH_MAX)
        VBI_BAD("textures nested more than %u deep", VBNL_TEXTURE_DEPTH_MAX);
    nd.depth = depth;
    if (count) {
        if (!VBI_RESERVE(ts, material_entries, material_entry_count, material_entry_cap, count))
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        nd.entry_begin = ts->material_entry_count;
        nd.entry_count = count;
        for (uint32_t i = 0; i < count; ++i)
            ts->material_entries[nd.entry_begin + i] =
                entries ? entries[i] : (vbnl_material_map_entry){(float)i, d->layers[i]};
        ts->material_entry_count += count;
    }
    /* the node is a material: its description carries the emission; its BSDF is never used */
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    memcpy(md.emission, d->emission, sizeof(md.emission));
    md.two_sided = d->two_sided;
    uint32_t id;
    if ((r = vbnl_scene_add_material(s, &md, &id, err)) != VBNL_OK)
        return r;
    scene_material *m = &s->materials[id];
    m->is_node = 1;
    m->varies = 1;
    m->node = nd;
    if (out_id)
        *out_id = id;
    return VBNL_OK;
}

/* ---- commit: hidden leaf copies ------------------------------------------------------------ */

typedef struct leaf_list {
    uint32_t *ids;
    uint32_t count, cap;
} leaf_list;

static int leaf_add(leaf_list *l, uint32_t id)
{
    for (uint32_t i = 0; i < l->count; ++i)
        if (l->ids[i] == id)
            return 1;
    if (!reserve((void **)&l->ids, l->count, &l->cap, sizeof(uint32_t), 1))
        return 0;
    l->ids[l->count++] = id;
    return 1;
}

/* The plain materials a node may resolve to. */
static int collect_leaves(const vbnl_scene *s, uint32_t m, leaf_list *l)
{
    const scene_material *sm = &s->materials[m];
    if (!sm->is_node)
        return leaf_add(l, m);
    const vbi_mnode *nd = &sm->node;
    if (nd->kind == VBNL_NODE_TEXTURED)
        return leaf_add(l, nd->material) && leaf_add(l, nd->transmission - 1);
    for (uint32_t i = 0; i < nd->entry_count; ++i)
        if (!collect_leaves(s, s->tex.material_entries[nd->entry_begin + i].material, l))
            return 0;
    return 1;
}

vbnl_result vbi_texture_commit(vbnl_scene *s, vbnl_error *err)
{
    const uint32_t user = s->material_count;
    for (uint32_t i = 0; i < user; ++i) {
        scene_material *m = &s->materials[i];
        m->surface = m->origin = i;
        if (!m->is_node)
            m->varies = m->desc.base_texture != 0;
    }
    leaf_list l = {NULL, 0, 0};
    for (uint32_t i = 0; i < user; ++i) {
        if (!s->materials[i].is_node)
            continue;
        l.count = 0;
        if (!collect_leaves(s, i, &l) || !reserve((void **)&s->materials, s->material_count, &s->material_capacity,
                                                  sizeof(scene_material), l.count)) {
            free(l.ids);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        s->materials[i].hidden_begin = s->material_count;
        s->materials[i].hidden_count = l.count;
        for (uint32_t k = 0; k < l.count; ++k) {
            scene_material h = s->materials[l.ids[k]];
            memset(h.desc.emission, 0, sizeof(h.desc.emission));
            h.emissive = 0;
            h.surface = i;
            h.origin = l.ids[k];
            s->materials[s->material_count++] = h;
        }
    }
    free(l.ids);
    return VBNL_OK;
}

uint32_t vbi_material_hidden(const vbnl_scene *s, uint32_t node, uint32_t leaf)
{
    const scene_material *m = &s->materials[node];
    for (uint32_t k = 0; k < m->hidden_count; ++k)
        if (s->materials[m->hidden_begin + k].origin == leaf)
            return m->hidden_begin + k;
    return node;
}

/* ---- fingerprint --------------------------------------------------------------------------- */

static uint64_t fp(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; ++i) {
        h ^= b[i];
        h *= 1099511628211ull;
    }
    return h;
}
#define VBI_FP(h, v) fp((h), &(v), sizeof(v))

static uint64_t fp_dmat(uint64_t h, const dmat *m) { return fp(h, m->m, sizeof(m->m)); }
static uint64_t fp_d3(uint64_t h, dvec3 v) { return fp(fp(fp(h, &v.x, 8), &v.y, 8), &v.z, 8); }

uint64_t vbi_texture_fingerprint(const vbnl_scene *s, uint64_t h)
{
    const vbi_texture_set *ts = &s->tex;
    h = VBI_FP(h, ts->image_count);
    for (uint32_t i = 0; i < ts->image_count; ++i) {
        const vbi_image *im = &ts->images[i];
        h = VBI_FP(VBI_FP(VBI_FP(h, im->width), im->height), im->channels);
        h = fp(h, im->texels, sizeof(float) * (size_t)im->width * im->height * im->channels);
        if (im->indices)
            h = fp(h, im->indices, (size_t)im->width * im->height);
    }
    h = VBI_FP(h, ts->warp_count);
    for (uint32_t i = 0; i < ts->warp_count; ++i) {
        const vbi_warp *w = &ts->warps[i];
        h = fp_dmat(VBI_FP(h, w->kind), &w->m);
        h = fp_d3(VBI_FP(VBI_FP(VBI_FP(h, w->turb.octaves), w->turb.omega), w->turb.lambda), w->turb.amount);
        h = fp_d3(fp_d3(VBI_FP(VBI_FP(h, w->axis), w->width), w->offset), w->flip);
        h = fp_d3(fp_d3(h, w->center), w->repeat_vec);
        h = fp_d3(VBI_FP(VBI_FP(VBI_FP(VBI_FP(h, w->radius), w->strength), w->falloff), w->inverse), w->jitter);
        h = fp_d3(VBI_FP(VBI_FP(VBI_FP(h, w->dist_exp), w->major_radius), w->plane_offset), w->orient);
    }
    h = VBI_FP(h, ts->pattern_count);
    for (uint32_t i = 0; i < ts->pattern_count; ++i) {
        const vbi_pattern *p = &ts->patterns[i];
        h = fp_dmat(VBI_FP(VBI_FP(h, p->kind), p->has_xf), &p->xf);
        h = VBI_FP(VBI_FP(VBI_FP(h, p->warp_begin), p->warp_count), p->has_turb);
        h = fp_d3(VBI_FP(VBI_FP(VBI_FP(h, p->turb.octaves), p->turb.omega), p->turb.lambda), p->turb.amount);
        h = VBI_FP(VBI_FP(VBI_FP(VBI_FP(VBI_FP(h, p->generator), p->wave), p->frequency), p->phase), p->exponent);
        /* the parameters by kind, without pointers (callbacks and voxel arrays by content or not at all) */
        switch (p->kind) {
        case VBNL_PATTERN_DENSITY:
            h = VBI_FP(VBI_FP(VBI_FP(VBI_FP(h, p->u.density.nx), p->u.density.ny), p->u.density.nz),
                        p->u.density.interpolate);
            h = fp(h, p->u.density.values,
                   sizeof(float) * (size_t)p->u.density.nx * p->u.density.ny * p->u.density.nz);
            break;
        case VBNL_PATTERN_FUNCTION:
        case VBNL_PATTERN_OBJECT:
            break;
        default: {
            /* the union's bytes: every other kind stores plain numbers, copied from zeroed memory */
            h = fp(h, &p->u, sizeof(p->u));
            break;
        }
        }
    }
    h = VBI_FP(h, ts->pigment_count);
    for (uint32_t i = 0; i < ts->pigment_count; ++i) {
        const vbi_pigment *g = &ts->pigments[i];
        h = fp(VBI_FP(h, g->kind), g->color, sizeof(g->color));
        h = VBI_FP(VBI_FP(VBI_FP(VBI_FP(h, g->pattern), g->entry_begin), g->entry_count), g->uv);
    }
    for (uint32_t i = 0; i < ts->pigment_entry_count; ++i) {
        const vbnl_pigment_map_entry *e = &ts->pigment_entries[i];
        h = VBI_FP(fp(VBI_FP(h, e->value), e->color, sizeof(e->color)), e->pigment);
    }
    h = VBI_FP(h, ts->normal_count);
    for (uint32_t i = 0; i < ts->normal_count; ++i) {
        const vbi_normal *n = &ts->normals[i];
        h = VBI_FP(VBI_FP(VBI_FP(VBI_FP(h, n->kind), n->pattern), n->amount), n->accuracy);
        h = VBI_FP(VBI_FP(VBI_FP(VBI_FP(h, n->slope_begin), n->slope_count), n->entry_begin), n->entry_count);
        h = VBI_FP(VBI_FP(h, n->no_bump_scale), n->uv);
    }
    for (uint32_t i = 0; i < ts->normal_entry_count; ++i)
        h = VBI_FP(VBI_FP(h, ts->normal_entries[i].value), ts->normal_entries[i].normal);
    for (uint32_t i = 0; i < ts->slope_entry_count; ++i) {
        const vbnl_slope_map_entry *e = &ts->slope_entries[i];
        h = VBI_FP(VBI_FP(VBI_FP(h, e->value), e->height), e->slope);
    }
    for (uint32_t i = 0; i < ts->material_entry_count; ++i)
        h = VBI_FP(VBI_FP(h, ts->material_entries[i].value), ts->material_entries[i].material);
    for (uint32_t i = 0; i < s->material_count; ++i) {
        const scene_material *m = &s->materials[i];
        h = VBI_FP(VBI_FP(VBI_FP(h, m->is_node), m->surface), m->origin);
        if (m->is_node) {
            const vbi_mnode *n = &m->node;
            h = VBI_FP(VBI_FP(VBI_FP(VBI_FP(h, n->kind), n->material), n->pigment), n->normal);
            h = VBI_FP(VBI_FP(VBI_FP(VBI_FP(h, n->transmission), n->pattern), n->entry_begin), n->entry_count);
            h = VBI_FP(h, n->uv);
        }
    }
    return h;
}

/* ---- simple textures ----------------------------------------------------------------------- */

void vbnl_texture_desc_init(vbnl_texture_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof(*d));
    d->size = sizeof(*d);
    d->kind = VBNL_TEXTURE_CHECKER;
    d->pattern_from_world[0] = d->pattern_from_world[5] = d->pattern_from_world[10] = d->pattern_from_world[15] = 1.0f;
    d->projection = VBNL_PROJECTION_UV;
    d->wrap = VBNL_WRAP_REPEAT;
    d->interpolate = 1;
    d->gradient[0] = 1.0f;
    d->brick_size[0] = 8.0f;
    d->brick_size[1] = 3.0f;
    d->brick_size[2] = 4.5f;
    d->mortar = 0.5f;
    d->frequency = 1.0f;
    d->wave = VBNL_WAVE_RAMP;
}

vbnl_result vbnl_scene_add_texture(vbnl_scene *s, const vbnl_texture_desc *d, uint32_t *out_id, vbnl_error *err)
{
    vbnl_result r = vbi_scene_check_open(s, "vbnl_scene_add_texture", err);
    if (r != VBNL_OK)
        return r;
    if (!d)
        VBI_BAD("vbnl_scene_add_texture: desc is NULL");
    if ((r = VBI_DESC_CHECK(d, vbnl_texture_desc, err)) != VBNL_OK)
        return r;
    if ((unsigned)d->kind > VBNL_TEXTURE_BRICK)
        VBI_BAD("unknown texture kind %d", (int)d->kind);
    vbnl_pattern_desc pd;
    vbnl_pattern_desc_init(&pd);
    for (int i = 0; i < 16; ++i)
        pd.transform[i] = d->pattern_from_world[i];
    vbnl_pigment_desc gd;
    vbnl_pigment_desc_init(&gd);
    vbnl_pigment_map_entry map[VBNL_COLOR_MAP_MAX];
    uint32_t image = 0;
    if (d->kind == VBNL_TEXTURE_IMAGE) {
        if (!d->texels || d->width == 0 || d->height == 0 || d->width > (1u << 16) || d->height > (1u << 16))
            VBI_BAD("image texture needs texels and a size in [1, 65536]^2 (got %u x %u)", d->width, d->height);
        if ((unsigned)d->projection > VBNL_PROJECTION_CYLINDRICAL || (unsigned)d->wrap > VBNL_WRAP_CLAMP)
            VBI_BAD("unknown image projection or wrap mode");
        size_t n = 3 * (size_t)d->width * d->height;
        for (size_t i = 0; i < n; ++i)
            if (!(d->texels[i] >= 0.0f) || !isfinite(d->texels[i]))
                VBI_BAD("image texel values must be finite and >= 0 (got %g)", d->texels[i]);
        vbnl_image_desc id;
        vbnl_image_desc_init(&id);
        id.width = d->width;
        id.height = d->height;
        id.channels = 3;
        id.texels = d->texels;
        if ((r = vbnl_scene_add_image(s, &id, &image, err)) != VBNL_OK)
            return r;
        pd.kind = VBNL_PATTERN_IMAGE;
        pd.frequency = 0.0f;
        pd.image.image = image + 1;
        pd.image.map_type = d->projection == VBNL_PROJECTION_SPHERICAL     ? 1
                            : d->projection == VBNL_PROJECTION_CYLINDRICAL ? 2
                                                                           : 0;
        pd.image.interpolate = d->interpolate ? 2 : 0;
        gd.kind = VBNL_PIGMENT_IMAGE;
    } else {
        if (!d->color_map || d->color_map_count == 0 || d->color_map_count > VBNL_COLOR_MAP_MAX)
            VBI_BAD("pattern texture needs a colour map of 1..%u entries", VBNL_COLOR_MAP_MAX);
        for (uint32_t i = 0; i < d->color_map_count; ++i) {
            const vbnl_color_map_entry *e = &d->color_map[i];
            if (!isfinite(e->value) || (i > 0 && e->value < d->color_map[i - 1].value))
                VBI_BAD("colour map values must be finite and sorted (entry %u)", i);
            for (int c = 0; c < 3; ++c)
                if (!(e->color[c] >= 0.0f) || !isfinite(e->color[c]))
                    VBI_BAD("colour map colours must be finite and >= 0 (entry %u)", i);
            map[i] = (vbnl_pigment_map_entry){e->value, {e->color[0], e->color[1], e->color[2], 0.0f, 0.0f}, 0};
        }
        gd.kind = VBNL_PIGMENT_MAP;
        gd.map = map;
        gd.map_count = d->color_map_count;
        switch (d->kind) {
        case VBNL_TEXTURE_CHECKER:
            pd.kind = VBNL_PATTERN_CHECKER;
            pd.frequency = 0.0f;
            break;
        case VBNL_TEXTURE_BRICK:
            pd.kind = VBNL_PATTERN_BRICK;
            pd.frequency = 0.0f;
            for (int i = 0; i < 3; ++i)
                pd.brick.size[i] = d->brick_size[i];
            pd.brick.mortar = d->mortar;
            break;
        default:
            pd.kind = VBNL_PATTERN_GRADIENT;
            for (int i = 0; i < 3; ++i)
                pd.gradient.direction[i] = d->gradient[i];
            pd.frequency = d->frequency;
            pd.phase = d->phase;
            pd.wave = d->wave;
            if ((unsigned)d->wave > VBNL_WAVE_POLY)
                VBI_BAD("unknown gradient wave %d", (int)d->wave);
            break;
        }
    }
    uint32_t pattern;
    if ((r = vbnl_scene_add_pattern(s, &pd, &pattern, err)) != VBNL_OK)
        return r;
    if (d->kind == VBNL_TEXTURE_IMAGE) {
        vbi_pattern *p = &s->tex.patterns[pattern];
        p->u.image.uv = d->projection == VBNL_PROJECTION_UV;
        p->u.image.wrap = d->wrap == VBNL_WRAP_CLAMP ? VBI_IMAGE_CLAMP : VBI_IMAGE_REPEAT;
    }
    gd.pattern = pattern + 1;
    return vbnl_scene_add_pigment(s, &gd, out_id, err);
}

/* ---- sets outside a scene ------------------------------------------------------------------ */

struct vbnl_pattern_set {
    vbi_texture_set ts;
};

vbnl_result vbnl_pattern_set_create(vbnl_pattern_set **out, vbnl_error *err)
{
    if (!out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_pattern_set_create: out is NULL");
    vbnl_pattern_set *set = malloc(sizeof(*set));
    if (!set)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbi_texture_set_init(&set->ts);
    *out = set;
    return VBNL_OK;
}

void vbnl_pattern_set_destroy(vbnl_pattern_set *set)
{
    if (!set)
        return;
    vbi_texture_set_free(&set->ts);
    free(set);
}

vbnl_result vbnl_pattern_set_add_image(vbnl_pattern_set *set, const vbnl_image_desc *d, uint32_t *out_id,
                                       vbnl_error *err)
{
    if (!set)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_pattern_set_add_image: set is NULL");
    return add_image(&set->ts, d, out_id, err);
}

vbnl_result vbnl_pattern_set_add_pattern(vbnl_pattern_set *set, const vbnl_pattern_desc *d, uint32_t *out_id,
                                         vbnl_error *err)
{
    if (!set)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_pattern_set_add_pattern: set is NULL");
    return add_pattern(&set->ts, d, out_id, err);
}

vbnl_result vbnl_pattern_set_add_pigment(vbnl_pattern_set *set, const vbnl_pigment_desc *d, uint32_t *out_id,
                                         vbnl_error *err)
{
    if (!set)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_pattern_set_add_pigment: set is NULL");
    return add_pigment(&set->ts, d, out_id, err);
}

/* Evaluation without a hit: no shade point (aoi and slope give 0, uv lookups (0, 0)). */
double vbnl_pattern_set_value(const vbnl_pattern_set *set, uint32_t pattern, const double p[3])
{
    if (!set || !p || pattern >= set->ts.pattern_count)
        return 0.0;
    dvec3 w;
    return vbi_pattern_value(&set->ts, &set->ts.patterns[pattern], d3(p[0], p[1], p[2]), NULL, &w);
}

void vbnl_pattern_set_color(const vbnl_pattern_set *set, uint32_t pigment, const double p[3], float out[5])
{
    if (!out)
        return;
    memset(out, 0, 5 * sizeof(float));
    if (!set || !p || pigment >= set->ts.pigment_count)
        return;
    vbi_pigment_eval(&set->ts, pigment, d3(p[0], p[1], p[2]), NULL, out);
}

void vbnl_vturbulence(double lambda, double omega, int octaves, const double p[3], double out[3])
{
    if (!out)
        return;
    out[0] = out[1] = out[2] = 0.0;
    if (!p)
        return;
    vbi_turb t;
    memset(&t, 0, sizeof(t));
    t.amount = d3(1.0, 1.0, 1.0);
    t.octaves = octaves < 1 ? 1 : (octaves > 10 ? 10 : octaves);
    t.omega = omega;
    t.lambda = lambda;
    dvec3 v = vbi_dturbulence(vbi_noise_tables_get(), d3(p[0], p[1], p[2]), &t);
    out[0] = v.x;
    out[1] = v.y;
    out[2] = v.z;
}
