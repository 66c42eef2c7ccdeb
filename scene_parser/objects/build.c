/* vbnl object layer: building the core scene from the parsed world. Primitives are collected
 * during the parse and added here, at the end, because an infinite plane needs the bounds of
 * everything else: its patch is POV_PLANE_EXTENT times the scene's bounding radius. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_loader.h"
#include "sdl_internal.h"
#include "vbnl/mesh_import.h"

#define POV_PLANE_EXTENT 100.0

/* The visibility flags of a primitive's core geometry `id` (no_shadow). */
static vbnl_result prim_visibility(pov_loader *L, const pov_prim *pr, uint32_t id, vbnl_error *err)
{
    return pr->no_shadow ? vbnl_scene_set_visibility(L->c.scene, id, VBNL_VISIBLE_NO_SHADOW, err) : VBNL_OK;
}

/* The farthest a point of an object or a light may lie from the origin, in units. The core holds
 * geometry in single precision, where the squared distances, areas and light powers of objects far
 * beyond this overflow (a sphere of radius 1e38 has no finite area). POV-Ray counts no
 * intersection farther than 1e7 from a ray's origin (its Max_Distance), so an object wholly beyond
 * this bound is invisible there too: it is skipped with a warning. A light beyond it is an error
 * (leaving it out would change every pixel). */
#define POV_MAX_EXTENT 1e10

/* An error about the statement that placed `pr` (an object or a light): reported as the parser's
 * errors are, with file:line:col, the statement's keyword and its source line, and in *err as
 * "file:line:col: keyword: message". */
static vbnl_result prim_error(pov_loader *L, const pov_prim *pr, vbnl_result code, vbnl_error *err, const char *fmt,
                              ...) __attribute__((format(printf, 5, 6)));
static vbnl_result prim_error(pov_loader *L, const pov_prim *pr, vbnl_result code, vbnl_error *err, const char *fmt,
                              ...)
{
    static const char *const kinds[] = {"sphere", "plane", "object", "light_source", "vbnl_mesh", "object", "object"};
    char word[32], msg[VBNL_ERROR_MESSAGE_SIZE];
    const char *what = sdl_word_at(L->c.parser, &pr->loc, word, sizeof word);
    if (!what)
        what = pr->kind >= 0 && pr->kind < (int)(sizeof kinds / sizeof kinds[0]) ? kinds[pr->kind] : "object";
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    vbnl_sdl_error(L->c.parser, &pr->loc, "%s: %s", what, msg);
    L->build_error_located = 1;
    return vbnl_error_set(err, code, "%s:%d:%d: %s: %s", pr->loc.file ? pr->loc.file : "", pr->loc.line, pr->loc.col,
                          what, msg);
}

/* Where `p` (object space) lies in the world, through m: 0, or -1 when a coordinate is NaN or
 * infinite, 1 when it lies beyond POV_MAX_EXTENT. */
static int world_point(const double m[16], const double p[3], double q[3])
{
    pov_m4_point(m, p, q);
    if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2]))
        return -1;
    return fabs(q[0]) > POV_MAX_EXTENT || fabs(q[1]) > POV_MAX_EXTENT || fabs(q[2]) > POV_MAX_EXTENT;
}

static int finite_n(const double *v, int n)
{
    for (int i = 0; i < n; ++i)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* The warning for an object beyond POV_MAX_EXTENT, which is then skipped (*skip set). */
static vbnl_result prim_far(pov_loader *L, const pov_prim *pr, const char *what, double reach, int *skip)
{
    char word[32];
    const char *kw = sdl_word_at(L->c.parser, &pr->loc, word, sizeof word);
    vbnl_sdl_warning(L->c.parser, &pr->loc, "%s: %s reaches %g units from the origin, beyond the %g vbnl holds "
                     "(POV-Ray traces no farther than 1e7): the object is skipped", kw ? kw : "object", what, reach,
                     POV_MAX_EXTENT);
    *skip = 1;
    return VBNL_OK;
}

static double reach3(const double q[3]) { return fmax(fmax(fabs(q[0]), fabs(q[1])), fabs(q[2])); }

/* The checks a placed object or light must pass before the core sees it: finite numbers (a
 * `pow(-8, 1/3)` is NaN, a `scale 1e400` infinite; errors) and a world within POV_MAX_EXTENT (an
 * object beyond it is skipped, *skip set, with a warning; a light beyond it is an error). */
static vbnl_result prim_check(pov_loader *L, const pov_prim *pr, int *skip, vbnl_error *err)
{
    static const char nan_text[] = "%s is not a finite number (NaN or infinite)";
    static const char far_text[] = "%s lies beyond %g units from the origin, farther than vbnl holds";
    *skip = 0;
    if (!finite_n(pr->m, 16))
        return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, "its transformation (scale, rotate, translate, matrix)");
    double q[3];
    int w;
    switch (pr->kind) {
    case POV_PRIM_SPHERE: {
        if (!finite_n(pr->a, 4))
            return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, isfinite(pr->a[3]) ? "its centre" : "its radius");
        double s = 0;
        for (int k = 0; k < 3; ++k)
            s = fmax(s, pov_len3((double[3]){pr->m[k], pr->m[4 + k], pr->m[8 + k]}));
        if (world_point(pr->m, pr->a, q) < 0)
            return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, "its centre");
        double reach = reach3(q) + fabs(pr->a[3]) * s;
        if (!(reach <= POV_MAX_EXTENT))
            return prim_far(L, pr, "its surface", reach, skip);
        break;
    }
    case POV_PRIM_PLANE: {
        if (!finite_n(pr->a, 4))
            return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, finite_n(pr->a, 3) ? "its distance" : "its normal");
        double nl2 = pov_dot3(pr->a, pr->a), p0[3]; /* its point nearest the origin, before the transform */
        for (int k = 0; k < 3; ++k)
            p0[k] = pr->a[k] * pr->a[3] / nl2;
        if (world_point(pr->m, p0, q) < 0)
            return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, "its transformed position");
        if (reach3(q) > POV_MAX_EXTENT)
            return prim_far(L, pr, "a point of it", reach3(q), skip);
        break;
    }
    case POV_PRIM_MESH: {
        double reach = 0;
        for (uint32_t v = 0; v < pr->mesh->nv; ++v) {
            double pp[3] = {pr->mesh->pos[3 * v], pr->mesh->pos[3 * v + 1], pr->mesh->pos[3 * v + 2]};
            if (world_point(pr->m, pp, q) < 0)
                return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, "a point of its surface");
            reach = fmax(reach, reach3(q));
        }
        if (reach > POV_MAX_EXTENT)
            return prim_far(L, pr, "its surface", reach, skip);
        break;
    }
    case POV_PRIM_LIGHT: {
        const pov_light *l = &pr->light;
        if (!finite_n(l->color, 3))
            return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, "its colour");
        /* a parallel light's position gives only its direction: it may lie as far as it likes */
        if ((w = world_point(pr->m, l->pos, q)) < 0 || (w > 0 && l->type != POV_LIGHT_PARALLEL))
            return prim_error(L, pr, VBNL_ERR_PARSE, err, w < 0 ? nan_text : far_text, "its position", POV_MAX_EXTENT);
        if (l->type != POV_LIGHT_POINT && world_point(pr->m, l->point_at, q) < 0)
            return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, "its point_at");
        if (l->area && (!finite_n(l->axis1, 3) || !finite_n(l->axis2, 3)))
            return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text, "an axis of its area_light");
        double more[5] = {l->radius, l->falloff, l->tightness, l->fade_distance, l->fade_power};
        if (!finite_n(more, l->type == POV_LIGHT_SPOT ? 5 : 0) || !finite_n(more + 3, 2))
            return prim_error(L, pr, VBNL_ERR_PARSE, err, nan_text,
                              finite_n(more + 3, 2) ? "its radius, falloff or tightness" : "its fade_distance or fade_power");
        break;
    }
    default: break;
    }
    return VBNL_OK;
}

static void bounds_add(double lo[3], double hi[3], const double p[3])
{
    for (int i = 0; i < 3; ++i) {
        lo[i] = fmin(lo[i], p[i]);
        hi[i] = fmax(hi[i], p[i]);
    }
}

static void m4f(const double m[16], float out[16])
{
    for (int i = 0; i < 16; ++i)
        out[i] = (float)m[i];
}

/* The core's description of a mesh (no transform, one material). */
static void mesh_desc(const pov_mesh *m, uint32_t material, uint32_t group, vbnl_mesh_desc *d)
{
    vbnl_mesh_desc_init(d);
    d->positions = m->pos;
    d->normals = m->nrm;
    d->uvs = m->uv;
    d->vertex_count = m->nv;
    d->indices = m->idx;
    d->triangle_count = m->nt;
    d->material = material;
    d->group = group;
}

/* 1 when the transform squashes space flat (its linear part is singular). */
static int flat(const double q[16])
{
    double det = q[0] * (q[5] * q[10] - q[6] * q[9]) - q[1] * (q[4] * q[10] - q[6] * q[8]) +
                 q[2] * (q[4] * q[9] - q[5] * q[8]);
    return !(fabs(det) > 1e-12);
}

static vbnl_result emit_mesh(pov_loader *L, const pov_prim *pr, const pov_mesh *m, vbnl_error *err)
{
    if (m->nt == 0)
        return VBNL_OK;
    if (flat(pr->m)) { /* e.g. `scale <1e-16, 1, 1>` from a loop: nothing to see */
        vbnl_sdl_warning(L->c.parser, &pr->loc, "the object is scaled flat (singular transform): skipped");
        return VBNL_OK;
    }
    static const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    uint32_t mat;
    vbnl_result r = pov_appearance_material(&L->c, pr->app, ident, &mat, err);
    if (r != VBNL_OK)
        return r;
    uint32_t *fm = NULL;
    if (m->ftex) {
        uint32_t *tm = calloc(m->ntex + 1, sizeof *tm);
        fm = malloc(sizeof *fm * m->nt);
        if (!tm || !fm) {
            free(tm);
            free(fm);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        for (uint32_t i = 0; i < m->ntex && r == VBNL_OK; ++i) {
            pov_appearance *a = pov_appearance_copy(m->texs[i]);
            if (!a) {
                r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
                break;
            }
            pov_appearance_transform(a, pr->m);
            r = pov_appearance_material(&L->c, a, ident, &tm[i], err);
            pov_appearance_free(a);
        }
        for (uint32_t t = 0; t < m->nt; ++t)
            fm[t] = m->ftex[t] >= 0 ? tm[m->ftex[t]] : mat;
        free(tm);
    }
    float xf[16];
    m4f(pr->m, xf);
    vbnl_mesh_desc d;
    mesh_desc(m, mat, VBNL_GROUP_WORLD, &d);
    d.face_materials = fm;
    d.transform = xf;
    uint32_t gid;
    if (r == VBNL_OK && (r = vbnl_scene_add_mesh(L->c.scene, &d, &gid, err)) == VBNL_OK)
        r = prim_visibility(L, pr, gid, err);
    free(fm);
    return r;
}

/* A mesh several primitives of the world show (a declared object placed many times, a shape
 * made once and shared): added once, in a group of its own per material, and placed as
 * instances. A mesh placed once stays world geometry (one level of traversal less). */
typedef struct mesh_group {
    const pov_mesh *mesh;
    uint32_t material, group;
} mesh_group;

typedef struct mesh_groups {
    mesh_group *v;
    size_t n, cap;
    const pov_mesh **placed; /* the meshes of the world's primitives, sorted: how often each is placed */
    size_t nplaced;
} mesh_groups;

static int cmp_ptr(const void *a, const void *b)
{
    uintptr_t x = (uintptr_t) * (const void *const *)a, y = (uintptr_t) * (const void *const *)b;
    return x < y ? -1 : x > y;
}

/* How many of the world's primitives show this mesh. */
static size_t placements(const mesh_groups *mg, const pov_mesh *m)
{
    size_t lo = 0, hi = mg->nplaced;
    while (lo < hi) { /* the first entry not below m */
        size_t mid = (lo + hi) / 2;
        if ((uintptr_t)mg->placed[mid] < (uintptr_t)m)
            lo = mid + 1;
        else
            hi = mid;
    }
    size_t n = 0;
    while (lo + n < mg->nplaced && mg->placed[lo + n] == m)
        n++;
    return n;
}

static vbnl_result build_all(pov_loader *L, mesh_groups *mg, vbnl_error *err);

static vbnl_result emit_instance(pov_loader *L, const pov_prim *pr, mesh_groups *mg, int *done, vbnl_error *err)
{
    const pov_mesh *m = pr->mesh;
    *done = 0;
    if (placements(mg, m) < 2 || m->ftex || m->nt == 0 || flat(pr->m) || pov_appearance_is_emissive(pr->app))
        return VBNL_OK; /* emitters must be world geometry */
    static const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    uint32_t mat;
    vbnl_result r = pov_appearance_material(&L->c, pr->app, ident, &mat, err);
    if (r != VBNL_OK)
        return r;
    size_t i = 0;
    while (i < mg->n && !(mg->v[i].mesh == m && mg->v[i].material == mat))
        ++i;
    if (i == mg->n) {
        if (mg->n == mg->cap) {
            size_t cap = mg->cap ? 2 * mg->cap : 16;
            mesh_group *n = realloc(mg->v, cap * sizeof *n);
            if (!n)
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            mg->v = n;
            mg->cap = cap;
        }
        mesh_group *g = &mg->v[mg->n];
        g->mesh = m;
        g->material = mat;
        if ((r = vbnl_scene_add_group(L->c.scene, &g->group, err)) != VBNL_OK)
            return r;
        vbnl_mesh_desc d;
        mesh_desc(m, mat, g->group, &d);
        if ((r = vbnl_scene_add_mesh(L->c.scene, &d, NULL, err)) != VBNL_OK)
            return r;
        mg->n++;
    }
    float xf[16];
    m4f(pr->m, xf);
    *done = 1;
    uint32_t gid;
    if ((r = vbnl_scene_add_instance(L->c.scene, mg->v[i].group, xf, &gid, err)) != VBNL_OK)
        return r;
    return prim_visibility(L, pr, gid, err);
}

vbnl_result pov_build(pov_loader *L, vbnl_error *err)
{
    mesh_groups mg = {NULL, 0, 0, NULL, 0};
    mg.placed = malloc(sizeof *mg.placed * (L->world.n + 1));
    if (!mg.placed)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    for (size_t i = 0; i < L->world.n; ++i)
        if (L->world.v[i].kind == POV_PRIM_MESH)
            mg.placed[mg.nplaced++] = L->world.v[i].mesh;
    qsort(mg.placed, mg.nplaced, sizeof *mg.placed, cmp_ptr);
    vbnl_result res = build_all(L, &mg, err);
    free(mg.v);
    free(mg.placed);
    return res;
}

static vbnl_result build_all(pov_loader *L, mesh_groups *mg, vbnl_error *err)
{
    vbnl_result r = VBNL_OK;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    vbnl_camera_desc cd;
    pov_cam dc;
    if (!L->have_camera) {
        pov_camera_default(&dc);
        L->cam = dc;
    }
    int skip;
    for (size_t i = 0; i < L->world.n; ++i) {
        if ((r = prim_check(L, &L->world.v[i], &skip, err)) != VBNL_OK)
            return r;
        if (skip) /* too far to hold: left out of the bounds and the scene (its data freed with the world) */
            L->world.v[i].kind = POV_PRIM_SKIPPED;
    }
    vbnl_sdl_loc nowhere = {"", 0, 0};
    if ((r = pov_camera_resolve(L, &L->cam, nowhere, &cd)) != VBNL_OK)
        return vbnl_error_set(err, r, "camera: invalid vectors");
    double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < L->world.n; ++i) { /* the geometry alone (unfaded lights) */
        const pov_prim *pr = &L->world.v[i];
        double q[3];
        if (pr->kind == POV_PRIM_SPHERE) {
            pov_m4_point(pr->m, pr->a, q);
            bounds_add(glo, ghi, q);
        } else if (pr->kind == POV_PRIM_MESH) {
            for (uint32_t v = 0; v < pr->mesh->nv; ++v) {
                double pp[3] = {pr->mesh->pos[3 * v], pr->mesh->pos[3 * v + 1], pr->mesh->pos[3 * v + 2]};
                pov_m4_point(pr->m, pp, q);
                bounds_add(glo, ghi, q);
            }
        } else if (pr->kind == POV_PRIM_PLANE) { /* its point nearest the origin */
            double nl2 = pov_dot3(pr->a, pr->a), p0[3];
            for (int k = 0; k < 3; ++k)
                p0[k] = pr->a[k] * pr->a[3] / nl2;
            pov_m4_point(pr->m, p0, q);
            bounds_add(glo, ghi, q);
        }
    }
    L->have_geo = glo[0] <= ghi[0];
    for (int k = 0; k < 3; ++k)
        L->geo_centre[k] = L->have_geo ? 0.5 * (glo[k] + ghi[k]) : 0.0;
    double cp[3] = {cd.position[0], cd.position[1], cd.position[2]};
    bounds_add(lo, hi, cp);
    for (size_t i = 0; i < L->world.n; ++i) {
        const pov_prim *pr = &L->world.v[i];
        double q[3];
        if (pr->kind == POV_PRIM_SPHERE) {
            double s = 0;
            for (int k = 0; k < 3; ++k)
                s = fmax(s, pov_len3((double[3]){pr->m[k], pr->m[4 + k], pr->m[8 + k]}));
            pov_m4_point(pr->m, pr->a, q);
            for (int k = 0; k < 3; ++k) {
                double e[3] = {q[0], q[1], q[2]};
                e[k] += pr->a[3] * s;
                bounds_add(lo, hi, e);
                e[k] -= 2 * pr->a[3] * s;
                bounds_add(lo, hi, e);
            }
        } else if (pr->kind == POV_PRIM_MESH) {
            for (uint32_t v = 0; v < pr->mesh->nv; ++v) {
                double pp[3] = {pr->mesh->pos[3 * v], pr->mesh->pos[3 * v + 1], pr->mesh->pos[3 * v + 2]};
                pov_m4_point(pr->m, pp, q);
                bounds_add(lo, hi, q);
            }
        } else if (pr->kind == POV_PRIM_LIGHT && pr->light.type != POV_LIGHT_PARALLEL) {
            pov_m4_point(pr->m, pr->light.pos, q);
            bounds_add(lo, hi, q);
        }
    }
    double centre[3], radius = 0;
    for (int k = 0; k < 3; ++k) {
        centre[k] = 0.5 * (lo[k] + hi[k]);
        radius = fmax(radius, 0.5 * (hi[k] - lo[k]));
    }
    radius = fmax(radius * sqrt(3.0), 1.0);
    static const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    for (size_t i = 0; i < L->world.n && r == VBNL_OK; ++i) {
        pov_prim *pr = &L->world.v[i];
        double s;
        switch (pr->kind) {
        case POV_PRIM_SPHERE:
            if (pov_m4_is_similarity(pr->m, &s)) {
                uint32_t mat;
                double c[3];
                pov_m4_point(pr->m, pr->a, c);
                float cf[3] = {(float)c[0], (float)c[1], (float)c[2]};
                uint32_t gid;
                if ((r = pov_appearance_material(&L->c, pr->app, ident, &mat, err)) == VBNL_OK &&
                    (r = vbnl_scene_add_sphere(L->c.scene, cf, (float)(pr->a[3] * s), mat, VBNL_GROUP_WORLD, &gid,
                                               err)) == VBNL_OK)
                    r = prim_visibility(L, pr, gid, err);
            } else if (!pov_appearance_is_emissive(pr->app)) {
                /* An ellipsoid: an instance of an analytic unit sphere (exact surface and normals). */
                uint32_t mat;
                if ((r = pov_appearance_material(&L->c, pr->app, ident, &mat, err)) != VBNL_OK)
                    break;
                if (mat >= L->nsphere_groups) {
                    uint32_t *g = realloc(L->sphere_groups, sizeof *g * (mat + 1));
                    if (!g)
                        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
                    memset(g + L->nsphere_groups, 0, sizeof *g * (mat + 1 - L->nsphere_groups));
                    L->sphere_groups = g;
                    L->nsphere_groups = mat + 1;
                }
                if (!L->sphere_groups[mat]) {
                    static const float zero[3] = {0, 0, 0};
                    if ((r = vbnl_scene_add_group(L->c.scene, &L->sphere_groups[mat], err)) != VBNL_OK ||
                        (r = vbnl_scene_add_sphere(L->c.scene, zero, 1.0f, mat, L->sphere_groups[mat], NULL, err)) != VBNL_OK)
                        break;
                }
                double local[16], xf[16];
                pov_m4_scale((double[3]){pr->a[3], pr->a[3], pr->a[3]}, local);
                local[3] = pr->a[0];
                local[7] = pr->a[1];
                local[11] = pr->a[2];
                pov_m4_mul(pr->m, local, xf);
                float xff[16];
                m4f(xf, xff);
                uint32_t gid;
                if ((r = vbnl_scene_add_instance(L->c.scene, L->sphere_groups[mat], xff, &gid, err)) == VBNL_OK)
                    r = prim_visibility(L, pr, gid, err);
            } else { /* emissive: emitters must be world geometry */
                pov_mesh *m = pov_tess_sphere(pr->a, pr->a[3]);
                if (!m)
                    return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
                r = emit_mesh(L, pr, m, err);
                pov_mesh_unref(m);
            }
            break;
        case POV_PRIM_PLANE: {
            /* The patch is built in world space around the scene's centre. */
            double inv[16], n[3], p0[3], pw[3], nw[3];
            if (!pov_m4_invert(pr->m, inv))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "plane: singular transform");
            double nl = pov_len3(pr->a);
            for (int k = 0; k < 3; ++k) {
                n[k] = pr->a[k] / nl;
                p0[k] = n[k] * pr->a[3] / nl;
            }
            pov_m4_point(pr->m, p0, pw);
            for (int k = 0; k < 3; ++k) /* normal: inverse transpose */
                nw[k] = inv[k] * n[0] + inv[4 + k] * n[1] + inv[8 + k] * n[2];
            pov_mesh *m = pov_tess_plane(nw, pov_dot3(nw, pw), centre, POV_PLANE_EXTENT * radius);
            if (!m)
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            pov_prim tmp = *pr;
            memcpy(tmp.m, ident, sizeof ident);
            r = emit_mesh(L, &tmp, m, err);
            pov_mesh_unref(m);
            break;
        }
        case POV_PRIM_MESH: {
            int done;
            if ((r = emit_instance(L, pr, mg, &done, err)) == VBNL_OK && !done)
                r = emit_mesh(L, pr, pr->mesh, err);
            break;
        }
        case POV_PRIM_LIGHT:
            r = pov_light_emit(L, pr, err);
            break;
        case POV_PRIM_SKIPPED:
            break;
        case POV_PRIM_SURFACE: {
            /* an unbounded shape nothing bounds: made within the scene's bounds (the geometry and
             * the camera), half as large again on every side and at least 50 units from the
             * centre (the shape finds where it is within them) */
            double blo[3], bhi[3], cp2[3] = {cd.position[0], cd.position[1], cd.position[2]};
            for (int k = 0; k < 3; ++k) {
                blo[k] = L->have_geo ? fmin(glo[k], cp2[k]) : cp2[k];
                bhi[k] = L->have_geo ? fmax(ghi[k], cp2[k]) : cp2[k];
                double c = 0.5 * (blo[k] + bhi[k]), h = fmax(50.0, 0.75 * (bhi[k] - blo[k]));
                blo[k] = c - h;
                bhi[k] = c + h;
            }
            if (!pov_solid_finite(pr->solid))
                vbnl_sdl_warning(L->c.parser, &pr->loc,
                                 "the shape is unbounded: its surface is made within the scene's bounds "
                                 "<%g, %g, %g> to <%g, %g, %g> (bound it with clipped_by or a CSG)",
                                 blo[0], blo[1], blo[2], bhi[0], bhi[1], bhi[2]);
            const char *why = NULL;
            pov_mesh *m = pov_solid_surface(pr->solid, pr->m, blo, bhi, &why);
            if (!m && (!why || !strcmp(why, "out of memory")))
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            if (!m)
                return prim_error(L, pr, VBNL_ERR_PARSE, err, "%s", why);
            r = emit_mesh(L, pr, m, err);
            pov_mesh_unref(m);
            break;
        }
        case POV_PRIM_IMPORT: {
            float xf[16];
            m4f(pr->m, xf);
            vbnl_mesh_import_options o;
            memset(&o, 0, sizeof o);
            o.transform = xf;
            o.group = VBNL_GROUP_WORLD;
            o.two_sided_emission = 1; /* as POV-Ray's emission */
            if (pr->app) { /* the scene gave an appearance: it overrides the file's materials */
                o.override_material = 1;
                if ((r = pov_appearance_material(&L->c, pr->app, ident, &o.material, err)) != VBNL_OK)
                    break;
            }
            r = vbnl_mesh_import(L->c.scene, pr->path, &o, NULL, err);
            break;
        }
        }
        /* what the core refused, blamed on the statement that placed it */
        if (r != VBNL_OK && r != VBNL_ERR_OUT_OF_MEMORY && !L->build_error_located) {
            char msg[VBNL_ERROR_MESSAGE_SIZE];
            snprintf(msg, sizeof msg, "%s", err ? err->message : vbnl_result_name(r));
            return prim_error(L, pr, r, err, "%s", msg);
        }
    }
    if (r != VBNL_OK)
        return r;
    void *cam_storage = NULL;
    if (L->cam.projection == VBNL_CAMERA_MESH && L->cam.meshes &&
        (r = pov_camera_meshes(L, &L->cam, &cd, &cam_storage, err)) != VBNL_OK)
        return r;
    r = vbnl_scene_set_camera(L->c.scene, &cd, err);
    free(cam_storage); /* the scene keeps its own copy */
    if (r != VBNL_OK || (r = pov_environment_build(L, err)) != VBNL_OK)
        return r;
    return pov_fogs_build(L, err);
}
