/* vbnl object layer: what the built-in functions min_extent, max_extent, inside and trace ask about
 * an object value (vbnl_sdl_object_queries; POV-Ray 3.7 reference, "Functions").
 *
 * The answers come from the primitives the object is made of, in world (POV-Ray) coordinates:
 * - Bounding box: POV-Ray's, each primitive's box in its object space with its transform applied
 *   to the 8 corners (so a rotated box or torus gets the box of its rotated box, as in POV-Ray).
 *   Spheres use their exact box (also rotated or uniformly scaled: POV-Ray keeps them spheres),
 *   meshes (every tessellated shape, CSG results, text) the box of their vertices. Planes and
 *   unbounded shapes outside a CSG have POV-Ray's infinite box, +-1e10 on every axis (POV-Ray's
 *   BOUND_HUGE / 2). Lights, skipped shapes and mesh files
 *   (vbnl_mesh, read when the scene is built) add nothing; an object with nothing else has the
 *   box <0,0,0>..<0,0,0>.
 * - inside: the exact inside test CSG uses (pov_prim_inside); an object is the union of its
 *   primitives, and shapes without an inside (triangles, meshes, discs) are never inside.
 * - trace: the nearest hit over the primitives: spheres and planes analytically with their exact
 *   normal, meshes by their triangles (through Embree for large meshes, the hit then computed
 *   again in double precision) with the interpolated vertex normals, which are the exact normals
 *   of curved shapes at the vertices. Where the primitive hit has an exact inside test (solid
 *   shapes, CSG) the point is then moved onto the exact surface by bisection along the ray
 *   (refine_hit; the normal stays the triangles'); elsewhere it lies on the tessellation, within its documented error bound of the exact
 *   surface. Unbounded shapes outside a CSG other than planes (made when the scene is built) are
 *   not hit.
 * Every answer is a pure function of the object, so the functions are deterministic. */
#include <embree3/rtcore.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_loader.h"

#define POV_QUERY_HUGE 1e10 /* POV-Ray's infinite bounding box reaches BOUND_HUGE / 2 */
#define POV_QUERY_TMIN 1e-6 /* hits nearer to the ray's origin are not counted (world units) */
/* Meshes of at least this many triangles are traced through an Embree scene made on their first
 * trace() and kept for the load; smaller ones through a loop over their triangles, as fast for
 * them and without a scene to keep (docs/scene-language.md, "Object functions"). */
#define POV_QUERY_EMBREE_MIN 256

/* What the queries keep per mesh for the load: its box and, once traced through Embree, its
 * Embree scene. Each entry holds a reference to its mesh. */
typedef struct query_mesh {
    pov_mesh *mesh;
    double lo[3], hi[3]; /* the box of its vertices */
    RTCScene scene;      /* NULL until its first trace through Embree */
} query_mesh;

struct pov_query_cache {
    RTCDevice device;
    query_mesh *v;
    size_t n, cap;
};

static const pov_obj *query_object(const vbnl_sdl_value *v)
{
    return v->kind == VBNL_SDL_OBJECT && v->u.obj.type == &pov_object_type ? v->u.obj.ptr : NULL;
}

static void mesh_box(const pov_mesh *m, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; ++k) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (uint32_t v = 0; v < m->nv; ++v)
        for (int k = 0; k < 3; ++k) {
            double x = m->pos[3 * v + k];
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
}

/* The cache entry of a mesh (made with its box on first use); NULL when out of memory. Meshes are
 * shared between copies of an object, so every copy a scene asks about finds the same entry. */
static query_mesh *mesh_entry(pov_loader *L, pov_mesh *m)
{
    struct pov_query_cache *c = L->query_cache;
    if (!c) {
        if (!(c = calloc(1, sizeof *c)))
            return NULL;
        L->query_cache = c;
    }
    for (size_t i = c->n; i-- > 0;)
        if (c->v[i].mesh == m)
            return &c->v[i];
    if (c->n == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 8;
        query_mesh *grown = realloc(c->v, cap * sizeof *grown);
        if (!grown)
            return NULL;
        c->v = grown;
        c->cap = cap;
    }
    query_mesh *e = &c->v[c->n++];
    memset(e, 0, sizeof *e);
    e->mesh = m;
    m->refs++;
    mesh_box(m, e->lo, e->hi);
    return e;
}

/* The object-space box of a primitive; 0 when it has none (lights, empty meshes), -1 when it is
 * unbounded. */
static int prim_box(pov_loader *L, const pov_prim *pr, double lo[3], double hi[3])
{
    switch (pr->kind) {
    case POV_PRIM_SPHERE:
        for (int k = 0; k < 3; ++k) {
            lo[k] = pr->a[k] - pr->a[3];
            hi[k] = pr->a[k] + pr->a[3];
        }
        return 1;
    case POV_PRIM_PLANE:
    case POV_PRIM_SURFACE:
        return -1;
    case POV_PRIM_MESH: {
        if (!pr->mesh || !pr->mesh->nt)
            return 0;
        query_mesh *e = mesh_entry(L, pr->mesh);
        if (!e) {
            mesh_box(pr->mesh, lo, hi);
            return 1;
        }
        memcpy(lo, e->lo, sizeof e->lo);
        memcpy(hi, e->hi, sizeof e->hi);
        return 1;
    }
    default:
        return 0;
    }
}

static int query_extent(vbnl_sdl_parser *p, const vbnl_sdl_value *obj, double lo[3], double hi[3], void *user)
{
    (void)p;
    const pov_obj *o = query_object(obj);
    if (!o)
        return 0;
    int any = 0;
    for (int k = 0; k < 3; ++k) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (size_t i = 0; i < o->n; ++i) {
        double bl[3], bh[3];
        int b = prim_box(user, &o->v[i], bl, bh);
        if (b == 0)
            continue;
        any = 1;
        if (b < 0) {
            for (int k = 0; k < 3; ++k) {
                lo[k] = -POV_QUERY_HUGE;
                hi[k] = POV_QUERY_HUGE;
            }
            break;
        }
        double sc;
        if (o->v[i].kind == POV_PRIM_SPHERE && pov_m4_is_similarity(o->v[i].m, &sc)) {
            /* a sphere rotated or scaled uniformly stays a sphere, with its exact box (POV-Ray) */
            double c[3];
            pov_m4_point(o->v[i].m, o->v[i].a, c);
            for (int k = 0; k < 3; ++k) {
                lo[k] = fmin(lo[k], c[k] - sc * o->v[i].a[3]);
                hi[k] = fmax(hi[k], c[k] + sc * o->v[i].a[3]);
            }
            continue;
        }
        for (int c = 0; c < 8; ++c) {
            double q[3] = { c & 1 ? bh[0] : bl[0], c & 2 ? bh[1] : bl[1], c & 4 ? bh[2] : bl[2] }, w[3];
            pov_m4_point(o->v[i].m, q, w);
            for (int k = 0; k < 3; ++k) {
                lo[k] = fmin(lo[k], w[k]);
                hi[k] = fmax(hi[k], w[k]);
            }
        }
    }
    for (int k = 0; k < 3 && any; ++k) { /* POV-Ray's box never reaches past its infinite one */
        lo[k] = fmax(lo[k], -POV_QUERY_HUGE);
        hi[k] = fmin(hi[k], POV_QUERY_HUGE);
    }
    if (!any) {
        memset(lo, 0, 3 * sizeof *lo);
        memset(hi, 0, 3 * sizeof *hi);
    }
    return 1;
}

static int query_inside(vbnl_sdl_parser *p, const vbnl_sdl_value *obj, const double q[3], int *in, void *user)
{
    (void)p;
    (void)user;
    const pov_obj *o = query_object(obj);
    if (!o)
        return 0;
    *in = 0;
    const pov_prim *last = NULL;
    for (size_t i = 0; i < o->n && !*in; ++i) {
        const pov_prim *pr = &o->v[i];
        /* the pieces of one CSG share its solid and transform: test it once */
        if (last && pr->kind == POV_PRIM_MESH && last->kind == POV_PRIM_MESH && pr->solid && pr->solid == last->solid &&
            pr->inverse == last->inverse && !memcmp(pr->m, last->m, sizeof pr->m))
            continue;
        last = pr;
        *in = pov_prim_inside(pr, q);
    }
    return 1;
}

/* The normal n (object space) of a primitive placed with m, in world space, of unit length: the
 * inverse transpose of m's linear part applied to n. */
static void normal_to_world(const double inv[16], const double n[3], double out[3])
{
    double l = 0;
    for (int k = 0; k < 3; ++k) {
        out[k] = inv[k] * n[0] + inv[4 + k] * n[1] + inv[8 + k] * n[2];
        l += out[k] * out[k];
    }
    l = sqrt(l);
    for (int k = 0; k < 3; ++k)
        out[k] = l > 0 ? out[k] / l : 0;
}

/* Slab test of the ray o + t d against the box lo..hi for t in (tmin, tmax). */
static int ray_box(const double o[3], const double d[3], const double lo[3], const double hi[3], double tmin,
                   double tmax)
{
    for (int k = 0; k < 3; ++k) {
        if (d[k] == 0) {
            if (o[k] < lo[k] || o[k] > hi[k])
                return 0;
            continue;
        }
        double t0 = (lo[k] - o[k]) / d[k], t1 = (hi[k] - o[k]) / d[k];
        if (t0 > t1) {
            double s = t0;
            t0 = t1;
            t1 = s;
        }
        tmin = fmax(tmin, t0);
        tmax = fmin(tmax, t1);
        if (tmin > tmax)
            return 0;
    }
    return 1;
}

/* Nearest hit of the object-space ray o + t d with the triangles first..end-1 of a mesh for t in
 * (POV_QUERY_TMIN, *t): updates *t and the object-space normal n; 1 when it found a nearer one. */
static int ray_tris(const pov_mesh *m, uint32_t first, uint32_t end, const double o[3], const double d[3], double *t,
                    double n[3])
{
    int found = 0;
    for (uint32_t i = first; i < end; ++i) {
        const uint32_t *ix = &m->idx[3 * i];
        double a[3], e1[3], e2[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = m->pos[3 * ix[0] + k];
            e1[k] = m->pos[3 * ix[1] + k] - a[k];
            e2[k] = m->pos[3 * ix[2] + k] - a[k];
        }
        /* Moller-Trumbore */
        double pv[3] = { d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0] };
        double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
        if (det == 0 || !isfinite(det))
            continue;
        double s[3] = { o[0] - a[0], o[1] - a[1], o[2] - a[2] };
        double u = (s[0] * pv[0] + s[1] * pv[1] + s[2] * pv[2]) / det;
        if (u < 0 || u > 1)
            continue;
        double qv[3] = { s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0] };
        double v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det;
        if (v < 0 || u + v > 1)
            continue;
        double th = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
        if (!(th > POV_QUERY_TMIN && th < *t))
            continue;
        *t = th;
        found = 1;
        if (m->nrm) {
            for (int k = 0; k < 3; ++k)
                n[k] = (1 - u - v) * m->nrm[3 * ix[0] + k] + u * m->nrm[3 * ix[1] + k] + v * m->nrm[3 * ix[2] + k];
        } else {
            n[0] = e1[1] * e2[2] - e1[2] * e2[1];
            n[1] = e1[2] * e2[0] - e1[0] * e2[2];
            n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        }
    }
    return found;
}

/* The Embree scene of a mesh (made on first use); NULL when Embree fails or memory runs out. */
static RTCScene mesh_scene(pov_loader *L, pov_mesh *m)
{
    query_mesh *e = mesh_entry(L, m);
    if (!e)
        return NULL;
    if (e->scene)
        return e->scene;
    struct pov_query_cache *c = L->query_cache;
    if (!c->device && !(c->device = rtcNewDevice("threads=1")))
        return NULL;
    RTCScene sc = rtcNewScene(c->device);
    RTCGeometry g = rtcNewGeometry(c->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *pos = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), m->nv);
    unsigned *idx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), m->nt);
    if (!sc || !pos || !idx) {
        rtcReleaseGeometry(g);
        rtcReleaseScene(sc);
        return NULL;
    }
    memcpy(pos, m->pos, (size_t)m->nv * 3 * sizeof(float));
    memcpy(idx, m->idx, (size_t)m->nt * 3 * sizeof(unsigned));
    rtcCommitGeometry(g);
    rtcAttachGeometry(sc, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(sc);
    return e->scene = sc;
}

void pov_query_cache_free(pov_loader *L)
{
    struct pov_query_cache *c = L->query_cache;
    if (!c)
        return;
    for (size_t i = 0; i < c->n; ++i) {
        if (c->v[i].scene)
            rtcReleaseScene(c->v[i].scene);
        pov_mesh_unref(c->v[i].mesh);
    }
    free(c->v);
    if (c->device)
        rtcReleaseDevice(c->device);
    free(c);
    L->query_cache = NULL;
}

/* Nearest hit of a large mesh through its Embree scene: Embree finds the triangle, and the hit is
 * computed again in double precision on that triangle. -1 when there is no Embree scene. */
static int ray_mesh_embree(pov_loader *L, pov_mesh *m, const double o[3], const double d[3], double *t, double n[3])
{
    RTCScene sc = mesh_scene(L, m);
    if (!sc)
        return -1;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray.org_x = (float)o[0];
    rh.ray.org_y = (float)o[1];
    rh.ray.org_z = (float)o[2];
    rh.ray.dir_x = (float)d[0];
    rh.ray.dir_y = (float)d[1];
    rh.ray.dir_z = (float)d[2];
    rh.ray.tnear = (float)POV_QUERY_TMIN;
    rh.ray.tfar = isfinite(*t) ? (float)*t * (1 + 1e-6f) : INFINITY;
    rh.ray.mask = 0xffffffffu;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(sc, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return 0;
    if (ray_tris(m, rh.hit.primID, rh.hit.primID + 1, o, d, t, n))
        return 1;
    /* on an edge the double-precision test may just miss the triangle Embree hit: keep Embree's */
    if (!(rh.ray.tfar > POV_QUERY_TMIN && rh.ray.tfar < *t))
        return 0;
    const uint32_t *ix = &m->idx[3 * rh.hit.primID];
    double u = rh.hit.u, v = rh.hit.v;
    *t = rh.ray.tfar;
    for (int k = 0; k < 3; ++k)
        n[k] = m->nrm ? (1 - u - v) * m->nrm[3 * ix[0] + k] + u * m->nrm[3 * ix[1] + k] + v * m->nrm[3 * ix[2] + k]
                      : rh.hit.Ng_x * (k == 0) + rh.hit.Ng_y * (k == 1) + rh.hit.Ng_z * (k == 2);
    return 1;
}

/* Nearest hit of the object-space ray with a primitive for t in (POV_QUERY_TMIN, *t). */
static int ray_prim(pov_loader *L, const pov_prim *pr, const double o[3], const double d[3], double *t, double n[3])
{
    if (pr->kind == POV_PRIM_SPHERE) {
        double oc[3] = { o[0] - pr->a[0], o[1] - pr->a[1], o[2] - pr->a[2] };
        double A = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], B = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
        double C = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - pr->a[3] * pr->a[3], disc = B * B - A * C;
        if (!(A > 0) || disc < 0)
            return 0;
        double sq = sqrt(disc), roots[2] = { (-B - sq) / A, (-B + sq) / A };
        for (int r = 0; r < 2; ++r)
            if (roots[r] > POV_QUERY_TMIN && roots[r] < *t) {
                *t = roots[r];
                for (int k = 0; k < 3; ++k)
                    n[k] = (oc[k] + roots[r] * d[k]) / pr->a[3];
                return 1;
            }
        return 0;
    }
    if (pr->kind == POV_PRIM_PLANE) {
        double dn = pr->a[0] * d[0] + pr->a[1] * d[1] + pr->a[2] * d[2];
        if (dn == 0)
            return 0;
        double th = (pr->a[3] - (pr->a[0] * o[0] + pr->a[1] * o[1] + pr->a[2] * o[2])) / dn;
        if (!(th > POV_QUERY_TMIN && th < *t))
            return 0;
        *t = th;
        memcpy(n, pr->a, 3 * sizeof *n);
        return 1;
    }
    double lo[3], hi[3];
    if (pr->kind != POV_PRIM_MESH || !pr->mesh || !pr->mesh->nt)
        return 0;
    if (pr->mesh->nt >= POV_QUERY_EMBREE_MIN) {
        int r = ray_mesh_embree(L, pr->mesh, o, d, t, n);
        if (r >= 0)
            return r;
    }
    if (prim_box(L, pr, lo, hi) != 1 || !ray_box(o, d, lo, hi, 0, *t))
        return 0;
    return ray_tris(pr->mesh, 0, pr->mesh->nt, o, d, t, n);
}

/* A hit t on the triangles of a primitive with an exact inside test, moved onto the exact surface:
 * the nearest bracket t -+ delta (delta growing from 1e-4 to 0.1 of the mesh's size along the ray)
 * whose ends the inside test tells apart, then 60 bisection steps. t unchanged when no bracket
 * is found (the exact surface does not cross the ray there). */
static double refine_hit(pov_loader *L, const pov_prim *pr, const double org[3], const double dir[3], const double ld[3], double t)
{
    double lo[3], hi[3], size = 0, dl = sqrt(ld[0] * ld[0] + ld[1] * ld[1] + ld[2] * ld[2]);
    if (prim_box(L, pr, lo, hi) != 1 || !(dl > 0))
        return t;
    for (int k = 0; k < 3; ++k)
        size = fmax(size, hi[k] - lo[k]);
    size /= dl; /* in units of t */
    for (double delta = 1e-4 * size; delta <= 0.1 * size; delta *= 4) {
        double a = fmax(t - delta, POV_QUERY_TMIN), b = t + delta, q[3];
        for (int k = 0; k < 3; ++k)
            q[k] = org[k] + a * dir[k];
        int ina = pov_prim_inside(pr, q);
        for (int k = 0; k < 3; ++k)
            q[k] = org[k] + b * dir[k];
        if (ina == pov_prim_inside(pr, q))
            continue;
        for (int it = 0; it < 60; ++it) {
            double m = 0.5 * (a + b);
            for (int k = 0; k < 3; ++k)
                q[k] = org[k] + m * dir[k];
            if (pov_prim_inside(pr, q) == ina)
                a = m;
            else
                b = m;
        }
        return 0.5 * (a + b);
    }
    return t;
}

static int query_trace(vbnl_sdl_parser *p, const vbnl_sdl_value *obj, const double org[3], const double dir[3],
                       double hit[3], double normal[3], int *found, void *user)
{
    (void)p;
    const pov_obj *o = query_object(obj);
    if (!o)
        return 0;
    double best = INFINITY, best_ld[3] = { 0, 0, 0 };
    const pov_prim *best_pr = NULL;
    *found = 0;
    for (size_t i = 0; i < o->n; ++i) {
        const pov_prim *pr = &o->v[i];
        double inv[16], lo[3], ld[3], n[3];
        if (!pov_m4_invert(pr->m, inv))
            continue;
        /* an affine map keeps the ray parameter: t is the world distance along the unit dir */
        pov_m4_point(inv, org, lo);
        pov_m4_dir(inv, dir, ld);
        if (ray_prim(user, pr, lo, ld, &best, n)) {
            *found = 1;
            normal_to_world(inv, n, normal);
            best_pr = pr;
            memcpy(best_ld, ld, sizeof best_ld);
        }
    }
    /* the nearest hit on the triangles, then onto the exact surface (keeping its normal) */
    if (best_pr && best_pr->kind == POV_PRIM_MESH && best_pr->solid)
        best = refine_hit(user, best_pr, org, dir, best_ld, best);
    if (*found)
        for (int k = 0; k < 3; ++k)
            hit[k] = org[k] + best * dir[k];
    return 1;
}

void pov_queries_install(pov_loader *L)
{
    vbnl_sdl_object_queries q = { L, query_extent, query_inside, query_trace };
    vbnl_sdl_set_object_queries(L->c.parser, &q);
}
