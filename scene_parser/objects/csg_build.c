/* vbnl: constructive solid geometry (intersection, difference, merge) for the object layer.
 *
 * POV-Ray evaluates CSG per ray. The core renders triangle meshes and spheres through Embree, so
 * here the CSG surface is built once, as triangles: every operand's surface is tessellated (the
 * shapes' usual tessellations; planes become large patches), and each triangle is kept, dropped
 * or cut along the other operands' boundaries by their exact inside tests (POV-Ray's `inside`
 * semantics: spheres, boxes, cylinders, cones, tori, the half-space below a plane, nested CSG,
 * `inverse`; triangles, discs, polygons and meshes have no inside). Where another operand's
 * boundary can hide inside a large triangle (a small sphere cut out of a box face), triangles that
 * overlap its bounds are split first (longest edge halved) to 1/32 of its size. Cuts follow the boundary by bisection
 * on the triangle edges, so the seam is exact at the split vertices and piecewise linear between
 * them. Each result piece carries the CSG as its solid, so CSG nests. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_object.h"

enum { SOLID_BOX = 0, SOLID_CONE, SOLID_TORUS, SOLID_CSG, SOLID_CUSTOM };
enum { TEST_SPHERE = 0, TEST_PLANE, TEST_SOLID };

typedef struct csg_test {
    int kind;
    int inverse;
    double inv[16]; /* CSG space -> the primitive's object space */
    double m[16];   /* the primitive's object space -> CSG space */
    double a[4];    /* sphere centre and radius; plane normal and distance (a.p = d) */
    pov_solid *solid;
} csg_test;

typedef struct csg_operand { /* the union of its tests */
    csg_test *t;
    size_t n, cap;
} csg_operand;

struct pov_solid {
    int refs;
    int kind;
    double p[8];       /* BOX and CUSTOM: lo, hi; CONE: base, rb, top (p[4..6]) rt (p[7]); TORUS: R, r */
    int op, inverse;   /* CSG */
    csg_operand *ops;
    size_t nops;
    const pov_solid_fn *fn; /* CUSTOM */
    void *data;
};

/* ---- solids ---------------------------------------------------------------------------------- */

static pov_solid *solid_new(int kind)
{
    pov_solid *s = calloc(1, sizeof *s);
    if (s) {
        s->refs = 1;
        s->kind = kind;
    }
    return s;
}

pov_solid *pov_solid_box(const double a[3], const double b[3])
{
    pov_solid *s = solid_new(SOLID_BOX);
    if (s)
        for (int k = 0; k < 3; ++k) {
            s->p[k] = fmin(a[k], b[k]);
            s->p[3 + k] = fmax(a[k], b[k]);
        }
    return s;
}

pov_solid *pov_solid_cone(const double b[3], double rb, const double t[3], double rt)
{
    pov_solid *s = solid_new(SOLID_CONE);
    if (s) {
        memcpy(s->p, b, 3 * sizeof(double));
        s->p[3] = rb;
        memcpy(s->p + 4, t, 3 * sizeof(double));
        s->p[7] = rt;
    }
    return s;
}

pov_solid *pov_solid_torus(double major, double minor)
{
    pov_solid *s = solid_new(SOLID_TORUS);
    if (s) {
        s->p[0] = major;
        s->p[1] = minor;
    }
    return s;
}

pov_solid *pov_solid_custom(const pov_solid_fn *fn, void *data, const double lo[3], const double hi[3])
{
    pov_solid *s = solid_new(SOLID_CUSTOM);
    if (!s) {
        if (fn->destroy)
            fn->destroy(data);
        return NULL;
    }
    s->fn = fn;
    s->data = data;
    for (int k = 0; k < 3; ++k) {
        s->p[k] = lo[k];
        s->p[3 + k] = hi[k];
    }
    return s;
}

int pov_solid_unbounded(const pov_solid *s)
{
    return s && s->kind == SOLID_CUSTOM && s->fn->surface;
}

int pov_solid_finite(const pov_solid *s)
{
    if (!s || s->kind != SOLID_CUSTOM)
        return 1;
    for (int k = 0; k < 6; ++k)
        if (!isfinite(s->p[k]))
            return 0;
    return 1;
}

pov_solid *pov_solid_ref(pov_solid *s)
{
    if (s)
        s->refs++;
    return s;
}

void pov_solid_unref(pov_solid *s)
{
    if (!s || --s->refs > 0)
        return;
    for (size_t i = 0; i < s->nops; ++i) {
        for (size_t k = 0; k < s->ops[i].n; ++k)
            pov_solid_unref(s->ops[i].t[k].solid);
        free(s->ops[i].t);
    }
    free(s->ops);
    if (s->kind == SOLID_CUSTOM && s->fn->destroy)
        s->fn->destroy(s->data);
    free(s);
}

/* ---- inside tests ---------------------------------------------------------------------------- */

static int operand_inside(const csg_operand *o, const double p[3], int depth);

static int csg_inside(int op, const csg_operand *ops, size_t nops, size_t skip, const double p[3], int depth)
{
    /* `skip`: the operand whose surface p lies on (not tested), or nops */
    switch (op) {
    case POV_CSG_INTERSECTION:
        for (size_t j = 0; j < nops; ++j)
            if (j != skip && !operand_inside(&ops[j], p, depth))
                return 0;
        return 1;
    case POV_CSG_DIFFERENCE:
        if (skip != 0 && !operand_inside(&ops[0], p, depth))
            return 0;
        for (size_t j = 1; j < nops; ++j)
            if (j != skip && operand_inside(&ops[j], p, depth))
                return 0;
        return 1;
    default: /* merge: inside any */
        for (size_t j = 0; j < nops; ++j)
            if (j != skip && operand_inside(&ops[j], p, depth))
                return 1;
        return 0;
    }
}

static int solid_inside(const pov_solid *s, const double q[3], int depth)
{
    switch (s->kind) {
    case SOLID_BOX:
        return q[0] > s->p[0] && q[0] < s->p[3] && q[1] > s->p[1] && q[1] < s->p[4] && q[2] > s->p[2] &&
               q[2] < s->p[5];
    case SOLID_CONE: {
        double ax[3], d[3], len2 = 0, h = 0;
        for (int k = 0; k < 3; ++k) {
            ax[k] = s->p[4 + k] - s->p[k];
            d[k] = q[k] - s->p[k];
            len2 += ax[k] * ax[k];
            h += d[k] * ax[k];
        }
        if (!(len2 > 0))
            return 0;
        h /= len2; /* 0 at the base, 1 at the top */
        if (!(h > 0 && h < 1))
            return 0;
        double r = s->p[3] + (s->p[7] - s->p[3]) * h, dist2 = 0;
        for (int k = 0; k < 3; ++k) {
            double e = d[k] - h * ax[k];
            dist2 += e * e;
        }
        return dist2 < r * r;
    }
    case SOLID_TORUS: { /* POV-Ray's torus lies in the xz plane around y */
        double rr = sqrt(q[0] * q[0] + q[2] * q[2]) - s->p[0];
        return rr * rr + q[1] * q[1] < s->p[1] * s->p[1];
    }
    case SOLID_CUSTOM:
        return s->fn->inside(s->data, q);
    default:
        if (depth > 64)
            return 0;
        return csg_inside(s->op, s->ops, s->nops, s->nops, q, depth + 1) != s->inverse;
    }
}

static int test_inside(const csg_test *t, const double p[3], int depth)
{
    double q[3];
    pov_m4_point(t->inv, p, q);
    int in;
    if (t->kind == TEST_SPHERE) {
        double d2 = 0;
        for (int k = 0; k < 3; ++k)
            d2 += (q[k] - t->a[k]) * (q[k] - t->a[k]);
        in = d2 < t->a[3] * t->a[3];
    } else if (t->kind == TEST_PLANE) {
        in = t->a[0] * q[0] + t->a[1] * q[1] + t->a[2] * q[2] < t->a[3];
    } else {
        in = solid_inside(t->solid, q, depth);
    }
    return in != t->inverse;
}

static int operand_inside(const csg_operand *o, const double p[3], int depth)
{
    for (size_t i = 0; i < o->n; ++i)
        if (test_inside(&o->t[i], p, depth))
            return 1;
    return 0;
}

int pov_prim_inside(const pov_prim *pr, const double p[3])
{
    if (!(pr->kind == POV_PRIM_SPHERE || pr->kind == POV_PRIM_PLANE ||
          ((pr->kind == POV_PRIM_MESH || pr->kind == POV_PRIM_SURFACE) && pr->solid)))
        return 0;
    csg_test t;
    memset(&t, 0, sizeof t);
    t.kind = pr->kind == POV_PRIM_SPHERE ? TEST_SPHERE : pr->kind == POV_PRIM_PLANE ? TEST_PLANE : TEST_SOLID;
    if (!pov_m4_invert(pr->m, t.inv))
        return 0;
    memcpy(t.a, pr->a, sizeof t.a);
    t.inverse = pr->inverse;
    t.solid = pr->solid;
    return test_inside(&t, p, 0);
}

/* ---- the operands' tests ------------------------------------------------------------------- */

/* The inside test of one primitive (0: it has none, or out of memory with *oom set). */
static int add_test(csg_operand *o, const pov_prim *pr, int *oom)
{
    csg_test t;
    memset(&t, 0, sizeof t);
    if (pr->kind == POV_PRIM_SPHERE)
        t.kind = TEST_SPHERE;
    else if (pr->kind == POV_PRIM_PLANE)
        t.kind = TEST_PLANE;
    else if ((pr->kind == POV_PRIM_MESH || pr->kind == POV_PRIM_SURFACE) && pr->solid)
        t.kind = TEST_SOLID;
    else
        return 0;
    if (!pov_m4_invert(pr->m, t.inv))
        return 0;
    memcpy(t.m, pr->m, sizeof t.m);
    memcpy(t.a, pr->a, sizeof t.a);
    t.inverse = pr->inverse;
    /* the pieces of one CSG share its solid and transform: one test for all of them */
    for (size_t i = 0; i < o->n; ++i)
        if (o->t[i].kind == t.kind && o->t[i].solid == pr->solid && o->t[i].inverse == t.inverse &&
            !memcmp(o->t[i].m, t.m, sizeof t.m) && !memcmp(o->t[i].a, t.a, sizeof t.a))
            return 1;
    if (o->n == o->cap) {
        size_t cap = o->cap ? 2 * o->cap : 4;
        csg_test *n = realloc(o->t, cap * sizeof *n);
        if (!n) {
            *oom = 1;
            return 0;
        }
        o->t = n;
        o->cap = cap;
    }
    t.solid = pov_solid_ref(pr->solid);
    o->t[o->n++] = t;
    return 1;
}

/* ---- feature bounds -------------------------------------------------------------------------- */

typedef struct feature {
    double lo[3], hi[3];
    double target; /* longest triangle edge allowed over these bounds */
    size_t operand;
} feature;

typedef struct feature_list {
    feature *v;
    size_t n, cap;
    int oom;
    unsigned char *unbounded; /* per operand: has a plane somewhere (no bounds) */
} feature_list;

/* Bounds of the object-space box lo..hi under m. */
static void box_xf(const double m[16], const double lo[3], const double hi[3], double olo[3], double ohi[3])
{
    for (int k = 0; k < 3; ++k) {
        olo[k] = INFINITY;
        ohi[k] = -INFINITY;
    }
    for (int c = 0; c < 8; ++c) {
        double p[3] = {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]}, q[3];
        pov_m4_point(m, p, q);
        for (int k = 0; k < 3; ++k) {
            olo[k] = fmin(olo[k], q[k]);
            ohi[k] = fmax(ohi[k], q[k]);
        }
    }
}

static void feature_add(feature_list *f, const double m[16], const double lo[3], const double hi[3], size_t operand)
{
    if (f->n == f->cap) {
        size_t cap = f->cap ? 2 * f->cap : 16;
        feature *n = realloc(f->v, cap * sizeof *n);
        if (!n) {
            f->oom = 1;
            return;
        }
        f->v = n;
        f->cap = cap;
    }
    feature *e = &f->v[f->n++];
    box_xf(m, lo, hi, e->lo, e->hi);
    double d2 = 0;
    for (int k = 0; k < 3; ++k)
        d2 += (e->hi[k] - e->lo[k]) * (e->hi[k] - e->lo[k]);
    e->target = sqrt(d2) / 32.0;
    e->operand = operand;
}

/* The bounds of a solid's boundary (planes have flat boundaries: no feature). */
static void solid_features(feature_list *f, const pov_solid *s, const double m[16], size_t operand, int depth)
{
    double lo[3], hi[3];
    switch (s->kind) {
    case SOLID_BOX:
        feature_add(f, m, s->p, s->p + 3, operand);
        return;
    case SOLID_CONE: {
        double r = fmax(s->p[3], s->p[7]);
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(s->p[k], s->p[4 + k]) - r;
            hi[k] = fmax(s->p[k], s->p[4 + k]) + r;
        }
        feature_add(f, m, lo, hi, operand);
        return;
    }
    case SOLID_TORUS: {
        double R = s->p[0] + s->p[1];
        double l[3] = {-R, -s->p[1], -R}, h[3] = {R, s->p[1], R};
        feature_add(f, m, l, h, operand);
        return;
    }
    case SOLID_CUSTOM:
        for (int k = 0; k < 3; ++k)
            if (!isfinite(s->p[k]) || !isfinite(s->p[3 + k])) { /* an unbounded shape: no bounds */
                if (f->unbounded)
                    f->unbounded[operand] = 1;
                return;
            }
        feature_add(f, m, s->p, s->p + 3, operand);
        return;
    default:
        if (depth > 64)
            return;
        for (size_t i = 0; i < s->nops; ++i)
            for (size_t k = 0; k < s->ops[i].n; ++k) {
                const csg_test *t = &s->ops[i].t[k];
                double mm[16];
                pov_m4_mul(m, t->m, mm);
                if (t->kind == TEST_PLANE && f->unbounded)
                    f->unbounded[operand] = 1;
                if (t->kind == TEST_SPHERE) {
                    for (int c = 0; c < 3; ++c) {
                        lo[c] = t->a[c] - t->a[3];
                        hi[c] = t->a[c] + t->a[3];
                    }
                    feature_add(f, mm, lo, hi, operand);
                } else if (t->kind == TEST_SOLID) {
                    solid_features(f, t->solid, mm, operand, depth + 1);
                }
            }
    }
}

static void operand_features(feature_list *f, const csg_operand *o, size_t operand)
{
    static const double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    pov_solid tmp;
    memset(&tmp, 0, sizeof tmp);
    tmp.kind = SOLID_CSG;
    tmp.ops = (csg_operand *)o;
    tmp.nops = 1;
    solid_features(f, &tmp, id, operand, 0);
}

/* ---- regions --------------------------------------------------------------------------------- */

/* The axis-aligned bounds of the region a solid encloses, sides infinite where it is unbounded
 * along an axis (an infinite cylinder, the half-space below a plane normal to an axis): the box
 * in which an unbounded shape's surface is made when a CSG bounds it. */

static void region_all(double lo[3], double hi[3])
{
    for (int k = 0; k < 3; ++k) {
        lo[k] = -INFINITY;
        hi[k] = INFINITY;
    }
}

static void region_none(double lo[3], double hi[3])
{
    for (int k = 0; k < 3; ++k) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
}

/* Bounds of the box lo..hi (sides may be infinite) under m, by interval arithmetic. */
static void box_xf_inf(const double m[16], const double lo[3], const double hi[3], double olo[3], double ohi[3])
{
    if (lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]) {
        region_none(olo, ohi);
        return;
    }
    for (int r = 0; r < 3; ++r) {
        double a = m[4 * r + 3], b = m[4 * r + 3];
        for (int c = 0; c < 3; ++c) {
            double w = m[4 * r + c];
            if (w == 0)
                continue;
            double x0 = w * lo[c], x1 = w * hi[c];
            a += fmin(x0, x1);
            b += fmax(x0, x1);
        }
        olo[r] = a;
        ohi[r] = b;
    }
}

static void region_and(double lo[3], double hi[3], const double l[3], const double h[3])
{
    for (int k = 0; k < 3; ++k) {
        lo[k] = fmax(lo[k], l[k]);
        hi[k] = fmin(hi[k], h[k]);
    }
}

static void region_or(double lo[3], double hi[3], const double l[3], const double h[3])
{
    if (l[0] > h[0] || l[1] > h[1] || l[2] > h[2])
        return;
    for (int k = 0; k < 3; ++k) {
        lo[k] = fmin(lo[k], l[k]);
        hi[k] = fmax(hi[k], h[k]);
    }
}

static void node_region(int op, const csg_operand *ops, size_t nops, const double m[16], double lo[3], double hi[3],
                        int depth);

static void solid_region(const pov_solid *s, const double m[16], double lo[3], double hi[3], int depth)
{
    double l[3], h[3];
    switch (s->kind) {
    case SOLID_BOX:
    case SOLID_CUSTOM:
        box_xf_inf(m, s->p, s->p + 3, lo, hi);
        return;
    case SOLID_CONE: {
        double r = fmax(s->p[3], s->p[7]);
        for (int k = 0; k < 3; ++k) {
            l[k] = fmin(s->p[k], s->p[4 + k]) - r;
            h[k] = fmax(s->p[k], s->p[4 + k]) + r;
        }
        box_xf_inf(m, l, h, lo, hi);
        return;
    }
    case SOLID_TORUS: {
        double R = s->p[0] + s->p[1];
        double tl[3] = {-R, -s->p[1], -R}, th[3] = {R, s->p[1], R};
        box_xf_inf(m, tl, th, lo, hi);
        return;
    }
    default:
        if (s->inverse || depth > 64)
            region_all(lo, hi);
        else
            node_region(s->op, s->ops, s->nops, m, lo, hi, depth + 1);
    }
}

static void test_region(const csg_test *t, const double m[16], double lo[3], double hi[3], int depth)
{
    double mm[16];
    pov_m4_mul(m, t->m, mm);
    if (t->inverse) {
        region_all(lo, hi);
    } else if (t->kind == TEST_SPHERE) {
        double l[3], h[3];
        for (int k = 0; k < 3; ++k) {
            l[k] = t->a[k] - t->a[3];
            h[k] = t->a[k] + t->a[3];
        }
        box_xf_inf(mm, l, h, lo, hi);
    } else if (t->kind == TEST_PLANE) {
        /* a.q < d with q = inv x: (inv^T a).x < d - a.(inv's translation) */
        double inv[16], n[3], nl = 0, d = t->a[3];
        region_all(lo, hi);
        if (!pov_m4_invert(mm, inv))
            return;
        for (int k = 0; k < 3; ++k) {
            n[k] = inv[k] * t->a[0] + inv[4 + k] * t->a[1] + inv[8 + k] * t->a[2];
            nl = fmax(nl, fabs(n[k]));
            d -= t->a[k] * inv[4 * k + 3];
        }
        int axis = -1, count = 0;
        for (int k = 0; k < 3; ++k)
            if (fabs(n[k]) > 1e-9 * nl)
                axis = k, count++;
        if (count == 1) {
            if (n[axis] > 0)
                hi[axis] = d / n[axis];
            else
                lo[axis] = d / n[axis];
        }
    } else {
        solid_region(t->solid, mm, lo, hi, depth);
    }
}

static void operand_region(const csg_operand *o, const double m[16], double lo[3], double hi[3], int depth)
{
    region_none(lo, hi);
    for (size_t i = 0; i < o->n; ++i) {
        double l[3], h[3];
        test_region(&o->t[i], m, l, h, depth);
        region_or(lo, hi, l, h);
    }
}

static void node_region(int op, const csg_operand *ops, size_t nops, const double m[16], double lo[3], double hi[3],
                        int depth)
{
    double l[3], h[3];
    if (nops == 0) {
        region_none(lo, hi);
        return;
    }
    operand_region(&ops[0], m, lo, hi, depth);
    for (size_t i = 1; i < nops && op != POV_CSG_DIFFERENCE; ++i) {
        operand_region(&ops[i], m, l, h, depth);
        if (op == POV_CSG_INTERSECTION)
            region_and(lo, hi, l, h);
        else
            region_or(lo, hi, l, h);
    }
}

pov_mesh *pov_solid_surface(const pov_solid *s, const double m[16], const double lo[3], const double hi[3],
                            const char **why)
{
    double inv[16], ol[3], oh[3];
    *why = NULL;
    if (!pov_solid_unbounded(s) || !pov_m4_invert(m, inv))
        return pov_mesh_new();
    box_xf_inf(inv, lo, hi, ol, oh);
    /* and no further than the shape's own region */
    region_and(ol, oh, s->p, s->p + 3);
    for (int k = 0; k < 3; ++k)
        if (!(ol[k] < oh[k]) || !isfinite(ol[k]) || !isfinite(oh[k]))
            return pov_mesh_new();
    return s->fn->surface(s->data, ol, oh, why);
}

/* ---- clipping -------------------------------------------------------------------------------- */

/* Marks the clipped pieces until the CSG's node exists (never dereferenced). */
static pov_solid piece_mark;
#define PIECE (&piece_mark)

static void v3set(double o[3], double a, double b, double c)
{
    o[0] = a;
    o[1] = b;
    o[2] = c;
}

typedef struct vtx {
    double p[3], n[3], uv[2];
} vtx;

#define CSG_MAX_DEPTH 28 /* longest-edge halvings */
#define CSG_MAX_TRIANGLES 2000000u

typedef struct clipper {
    int op;
    size_t self, nops;
    const csg_operand *ops;
    const feature_list *features;
    int flip, has_n, has_uv;
    int32_t tex;
    pov_mesh *out;
    size_t *total;
    int failed; /* 1: out of memory, 2: too many triangles */
} clipper;

static int keep(const clipper *c, const double p[3])
{
    if (c->op == POV_CSG_MERGE) /* the union's outer surface: outside every other operand */
        return !csg_inside(POV_CSG_MERGE, c->ops, c->nops, c->self, p, 0);
    return csg_inside(c->op, c->ops, c->nops, c->self, p, 0);
}

static void lerp(const vtx *a, const vtx *b, double t, vtx *o)
{
    for (int k = 0; k < 3; ++k) {
        o->p[k] = a->p[k] + (b->p[k] - a->p[k]) * t;
        o->n[k] = a->n[k] + (b->n[k] - a->n[k]) * t;
    }
    for (int k = 0; k < 2; ++k)
        o->uv[k] = a->uv[k] + (b->uv[k] - a->uv[k]) * t;
}

static void emit(clipper *c, const vtx *a, const vtx *b, const vtx *d)
{
    if (c->failed)
        return;
    if (++*c->total > CSG_MAX_TRIANGLES) {
        c->failed = 2;
        return;
    }
    const vtx *v[3] = {a, c->flip ? d : b, c->flip ? b : d};
    uint32_t id[3];
    for (int i = 0; i < 3; ++i) {
        double n[3];
        double s = c->flip ? -1.0 : 1.0, len = 0;
        for (int k = 0; k < 3; ++k)
            len += v[i]->n[k] * v[i]->n[k];
        len = len > 0 ? s / sqrt(len) : 0;
        for (int k = 0; k < 3; ++k)
            n[k] = v[i]->n[k] * len;
        id[i] = pov_mesh_vertex(c->out, v[i]->p, c->has_n ? n : NULL, c->has_uv ? v[i]->uv : NULL);
        if (id[i] == UINT32_MAX) {
            c->failed = 1;
            return;
        }
    }
    if (!pov_mesh_tri(c->out, id[0], id[1], id[2], c->tex))
        c->failed = 1;
}

/* The point between a (kept = ka) and b where keep() changes, by bisection. */
static void crossing(const clipper *c, const vtx *a, const vtx *b, int ka, vtx *out)
{
    double lo = 0, hi = 1;
    vtx m;
    for (int it = 0; it < 40; ++it) {
        double t = 0.5 * (lo + hi);
        lerp(a, b, t, &m);
        if (keep(c, m.p) == ka)
            lo = t;
        else
            hi = t;
    }
    lerp(a, b, 0.5 * (lo + hi), out);
}

static void clip_tri(clipper *c, const vtx *v0, const vtx *v1, const vtx *v2, int depth)
{
    if (c->failed)
        return;
    const vtx *v[3] = {v0, v1, v2};
    double lo[3], hi[3], e2 = 0;
    for (int k = 0; k < 3; ++k) {
        lo[k] = fmin(v0->p[k], fmin(v1->p[k], v2->p[k]));
        hi[k] = fmax(v0->p[k], fmax(v1->p[k], v2->p[k]));
    }
    for (int i = 0; i < 3; ++i) {
        double d2 = 0;
        for (int k = 0; k < 3; ++k) {
            double d = v[(i + 1) % 3]->p[k] - v[i]->p[k];
            d2 += d * d;
        }
        e2 = fmax(e2, d2);
    }
    double edge = sqrt(e2);
    if (depth < CSG_MAX_DEPTH) {
        for (size_t i = 0; i < c->features->n; ++i) {
            const feature *f = &c->features->v[i];
            if (f->operand == c->self || edge <= f->target)
                continue;
            if (lo[0] > f->hi[0] || hi[0] < f->lo[0] || lo[1] > f->hi[1] || hi[1] < f->lo[1] || lo[2] > f->hi[2] ||
                hi[2] < f->lo[2])
                continue;
            /* halve the longest edge (thin triangles stay few) */
            int e = 0;
            double best = -1;
            for (int j = 0; j < 3; ++j) {
                double d2 = 0;
                for (int k = 0; k < 3; ++k) {
                    double d = v[(j + 1) % 3]->p[k] - v[j]->p[k];
                    d2 += d * d;
                }
                if (d2 > best)
                    best = d2, e = j;
            }
            const vtx *a = v[e], *b = v[(e + 1) % 3], *o = v[(e + 2) % 3];
            vtx mid;
            lerp(a, b, 0.5, &mid);
            clip_tri(c, a, &mid, o, depth + 1);
            clip_tri(c, &mid, b, o, depth + 1);
            return;
        }
    }
    int k[3];
    for (int i = 0; i < 3; ++i)
        k[i] = keep(c, v[i]->p);
    if (k[0] == k[1] && k[1] == k[2]) {
        if (k[0])
            emit(c, v0, v1, v2);
        return;
    }
    /* the lone vertex, then the other two in winding order */
    int l = k[0] != k[1] && k[0] != k[2] ? 0 : (k[1] != k[0] && k[1] != k[2] ? 1 : 2);
    const vtx *vl = v[l], *va = v[(l + 1) % 3], *vb = v[(l + 2) % 3];
    vtx ca, cb;
    crossing(c, vl, va, k[l], &ca);
    crossing(c, vl, vb, k[l], &cb);
    if (k[l]) {
        emit(c, vl, &ca, &cb);
    } else {
        emit(c, &ca, va, vb);
        emit(c, &ca, vb, &cb);
    }
}

/* ---- building -------------------------------------------------------------------------------- */

static void vtx_from(const pov_mesh *mesh, uint32_t i, const double m[16], const double nm[9], vtx *o)
{
    double p[3] = {mesh->pos[3 * i], mesh->pos[3 * i + 1], mesh->pos[3 * i + 2]};
    pov_m4_point(m, p, o->p);
    memset(o->n, 0, sizeof o->n);
    memset(o->uv, 0, sizeof o->uv);
    if (mesh->nrm)
        for (int r = 0; r < 3; ++r)
            o->n[r] = nm[3 * r] * mesh->nrm[3 * i] + nm[3 * r + 1] * mesh->nrm[3 * i + 1] + nm[3 * r + 2] * mesh->nrm[3 * i + 2];
    if (mesh->uv) {
        o->uv[0] = mesh->uv[2 * i];
        o->uv[1] = mesh->uv[2 * i + 1];
    }
}

/* The surface of one primitive of operand `self`, clipped, as a new mesh primitive in out. */
static int clip_prim(clipper *c, const pov_prim *pr, const pov_mesh *mesh, const double m[16], pov_obj *out)
{
    double inv[16], nm[9];
    if (!pov_m4_invert(m, inv))
        return 1; /* a flat transform: nothing to see */
    for (int r = 0; r < 3; ++r) /* normals: the inverse transpose */
        for (int k = 0; k < 3; ++k)
            nm[3 * r + k] = inv[4 * k + r];
    pov_mesh *o = pov_mesh_new();
    if (!o)
        return 0;
    c->out = o;
    c->has_n = mesh->nrm != NULL;
    c->has_uv = mesh->uv != NULL;
    for (uint32_t t = 0; t < mesh->nt && !c->failed; ++t) {
        vtx v[3];
        for (int k = 0; k < 3; ++k)
            vtx_from(mesh, mesh->idx[3 * t + k], m, nm, &v[k]);
        c->tex = mesh->ftex ? mesh->ftex[t] : -1;
        clip_tri(c, &v[0], &v[1], &v[2], 0);
    }
    if (!c->failed && mesh->ntex) {
        o->texs = calloc(mesh->ntex, sizeof *o->texs);
        if (!o->texs)
            c->failed = 1;
        for (uint32_t i = 0; i < mesh->ntex && !c->failed; ++i) {
            o->ntex = i + 1;
            if (mesh->texs[i] && !(o->texs[i] = pov_appearance_copy(mesh->texs[i])))
                c->failed = 1;
        }
    }
    if (c->failed || o->nt == 0) {
        pov_mesh_unref(o);
        return !c->failed || c->failed == 2;
    }
    pov_prim *d = pov_obj_add(out, POV_PRIM_MESH, pr->loc);
    if (!d || (pr->app && !(d->app = pov_appearance_copy(pr->app)))) {
        pov_mesh_unref(o);
        return 0;
    }
    d->mesh = o;
    d->solid = PIECE; /* the CSG's node, once built */
    return 1;
}

/* A primitive whose bounds meet no other operand's boundary lies wholly inside or outside each
 * of them: kept whole (a sphere stays analytic) or dropped. 1: decided (*kept set), 0: clip it. */
static int whole(const clipper *c, const pov_prim *pr, int *kept)
{
    if (c->flip || (pr->kind != POV_PRIM_SPHERE && pr->kind != POV_PRIM_MESH))
        return 0;
    for (size_t j = 0; j < c->nops; ++j)
        if (j != c->self && c->features->unbounded[j])
            return 0;
    double lo[3], hi[3], p[3], q[3];
    if (pr->kind == POV_PRIM_SPHERE) {
        double l[3], h[3];
        for (int k = 0; k < 3; ++k) {
            l[k] = pr->a[k] - pr->a[3];
            h[k] = pr->a[k] + pr->a[3];
        }
        box_xf(pr->m, l, h, lo, hi);
        v3set(p, pr->a[0] + pr->a[3], pr->a[1], pr->a[2]);
    } else {
        const pov_mesh *m = pr->mesh;
        if (m->nv == 0 || m->nt == 0) {
            *kept = 0;
            return 1;
        }
        double l[3] = {INFINITY, INFINITY, INFINITY}, h[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (uint32_t i = 0; i < m->nv; ++i)
            for (int k = 0; k < 3; ++k) {
                l[k] = fmin(l[k], m->pos[3 * i + k]);
                h[k] = fmax(h[k], m->pos[3 * i + k]);
            }
        box_xf(pr->m, l, h, lo, hi);
        v3set(p, m->pos[0], m->pos[1], m->pos[2]);
    }
    for (size_t i = 0; i < c->features->n; ++i) {
        const feature *f = &c->features->v[i];
        if (f->operand != c->self && !(lo[0] > f->hi[0] || hi[0] < f->lo[0] || lo[1] > f->hi[1] ||
                                       hi[1] < f->lo[1] || lo[2] > f->hi[2] || hi[2] < f->lo[2]))
            return 0;
    }
    pov_m4_point(pr->m, p, q);
    *kept = keep(c, q);
    return 1;
}

/* A copy of a primitive (appearance, path, mesh and solid referenced or copied). */
static int copy_prim(pov_obj *out, const pov_prim *pr)
{
    pov_prim *d = pov_obj_add(out, pr->kind, pr->loc);
    if (!d)
        return 0;
    *d = *pr;
    d->app = NULL;
    d->path = NULL;
    if (pr->mesh)
        pr->mesh->refs++;
    pov_solid_ref(pr->solid);
    return !((pr->app && !(d->app = pov_appearance_copy(pr->app))) || (pr->path && !(d->path = strdup(pr->path))));
}

int pov_csg_solid(int op, const pov_obj *ops, size_t nops, pov_obj *out, const char **error)
{
    return pov_csg_build_surfaces(op, ops, nops, 0, out, error);
}

int pov_csg_build(int op, const pov_obj *ops, size_t nops, pov_obj *out, const char **error)
{
    return pov_csg_build_surfaces(op, ops, nops, nops, out, error);
}

int pov_csg_build_surfaces(int op, const pov_obj *ops, size_t nops, size_t nsurf, pov_obj *out, const char **error)
{
    *error = NULL;
    int oom = 0;
    csg_operand *t = calloc(nops ? nops : 1, sizeof *t);
    feature_list f = {0};
    pov_solid *node = solid_new(SOLID_CSG);
    size_t first_piece = out->n, total = 0;
    pov_mesh **surfaces = NULL; /* the unbounded operands' surfaces, in operand order */
    size_t nsurfaces = 0, capsurfaces = 0;
    f.unbounded = calloc(nops ? nops : 1, 1);
    if (!t || !node || !f.unbounded)
        goto fail;
    for (size_t i = 0; i < nops; ++i)
        for (size_t k = 0; k < ops[i].n; ++k)
            add_test(&t[i], &ops[i].v[k], &oom);
    if (oom)
        goto fail;
    for (size_t i = 0; i < nops && !f.oom; ++i)
        operand_features(&f, &t[i], i);
    if (f.oom)
        goto fail;
    /* a size for plane patches: well beyond every finite operand */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, extent = 0;
    for (size_t i = 0; i < f.n; ++i)
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], f.v[i].lo[k]);
            hi[k] = fmax(hi[k], f.v[i].hi[k]);
        }
    double centre[3] = {0, 0, 0};
    if (f.n)
        for (int k = 0; k < 3; ++k) {
            centre[k] = 0.5 * (lo[k] + hi[k]);
            extent = fmax(extent, hi[k] - lo[k]);
        }
    double half = fmax(100.0 * extent, 1000.0);
    /* unbounded operands are made within the CSG's region, its unbounded sides as plane patches */
    static const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    double rlo[3], rhi[3];
    node_region(op, t, nops, ident, rlo, rhi, 0);
    for (int k = 0; k < 3; ++k) {
        if (!isfinite(rlo[k]))
            rlo[k] = centre[k] - half;
        if (!isfinite(rhi[k]))
            rhi[k] = centre[k] + half;
        double pad = 0.01 * (rhi[k] - rlo[k]) + 1e-9 * fmax(fabs(rlo[k]), fabs(rhi[k]));
        rlo[k] -= pad;
        rhi[k] += pad;
    }
    /* their surfaces first (of the operands that show one): their bounds are features too, so that
     * the others' large triangles are split where the unbounded shape's boundary crosses them */
    int empty_region = !(rlo[0] < rhi[0] && rlo[1] < rhi[1] && rlo[2] < rhi[2]);
    for (size_t i = 0; i < nops && !empty_region; ++i)
        for (size_t k = 0; k < ops[i].n; ++k) {
            const pov_prim *pr = &ops[i].v[k];
            if (pr->kind != POV_PRIM_SURFACE)
                continue;
            if (nsurfaces == capsurfaces) {
                size_t cap = capsurfaces ? 2 * capsurfaces : 4;
                pov_mesh **n = realloc(surfaces, cap * sizeof *n);
                if (!n)
                    goto fail;
                surfaces = n;
                capsurfaces = cap;
            }
            const char *why = NULL;
            pov_mesh *m = pov_solid_surface(pr->solid, pr->m, rlo, rhi, &why);
            if (!m) {
                *error = why ? why : "out of memory";
                goto cleanup;
            }
            surfaces[nsurfaces++] = m;
            double ml[3] = {INFINITY, INFINITY, INFINITY}, mh[3] = {-INFINITY, -INFINITY, -INFINITY};
            for (uint32_t v = 0; v < m->nv; ++v)
                for (int j = 0; j < 3; ++j) {
                    ml[j] = fmin(ml[j], m->pos[3 * v + j]);
                    mh[j] = fmax(mh[j], m->pos[3 * v + j]);
                }
            if (m->nv)
                feature_add(&f, pr->m, ml, mh, i);
            if (f.oom)
                goto fail;
        }
    size_t next_surface = 0;

    clipper c = {op, 0, nops, t, &f, 0, 0, 0, -1, NULL, &total, 0};
    for (size_t i = 0; i < nsurf && i < nops && !c.failed; ++i) {
        c.self = i;
        c.flip = op == POV_CSG_DIFFERENCE && i > 0;
        for (size_t k = 0; k < ops[i].n && !c.failed; ++k) {
            const pov_prim *pr = &ops[i].v[k];
            pov_mesh *mesh = NULL;
            double m[16];
            memcpy(m, pr->m, sizeof m);
            int kept;
            if (whole(&c, pr, &kept)) {
                if (kept && !copy_prim(out, pr))
                    goto fail;
                continue;
            }
            if (pr->kind == POV_PRIM_MESH) {
                mesh = pr->mesh;
                mesh->refs++;
            } else if (pr->kind == POV_PRIM_SURFACE) {
                if (empty_region)
                    continue;
                mesh = surfaces[next_surface++];
                mesh->refs++;
            } else if (pr->kind == POV_PRIM_SPHERE) {
                mesh = pov_tess_sphere(pr->a, pr->a[3]);
            } else if (pr->kind == POV_PRIM_PLANE) {
                double inv[16], cl[3];
                if (!pov_m4_invert(pr->m, inv))
                    continue;
                pov_m4_point(inv, centre, cl);
                double s = 0; /* the patch is sized in CSG space */
                for (int r = 0; r < 3; ++r)
                    s = fmax(s, sqrt(inv[r] * inv[r] + inv[4 + r] * inv[4 + r] + inv[8 + r] * inv[8 + r]));
                mesh = pov_tess_plane(pr->a, pr->a[3], cl, half * fmax(s, 1e-9));
            } else {
                /* lights, skipped shapes and imported meshes pass through unchanged */
                if (!copy_prim(out, pr))
                    goto fail;
                continue;
            }
            if (!mesh)
                goto fail;
            int ok = clip_prim(&c, pr, mesh, m, out);
            pov_mesh_unref(mesh);
            if (!ok)
                goto fail;
        }
    }
    if (c.failed == 2) {
        *error = "the CSG surface needs more than 2M triangles";
        goto cleanup;
    }
    if (c.failed)
        goto fail;
    if (nsurf == 0) { /* the solid alone: a primitive with an empty surface */
        pov_prim *d = pov_obj_add(out, POV_PRIM_MESH, nops && ops[0].n ? ops[0].v[0].loc : out->loc);
        if (!d || !(d->mesh = pov_mesh_new()))
            goto fail;
        d->solid = PIECE;
    }
    node->op = op;
    node->ops = t;
    node->nops = nops;
    t = NULL;
    for (size_t i = first_piece; i < out->n; ++i)
        if (out->v[i].kind == POV_PRIM_MESH && out->v[i].solid == PIECE) {
            out->v[i].solid = pov_solid_ref(node);
            out->v[i].inverse = 0;
        }
    pov_solid_unref(node);
    free(f.v);
    free(f.unbounded);
    for (size_t i = 0; i < nsurfaces; ++i)
        pov_mesh_unref(surfaces[i]);
    free(surfaces);
    return 1;
fail:
    *error = "out of memory";
cleanup:
    if (t) {
        for (size_t i = 0; i < nops; ++i) {
            for (size_t k = 0; k < t[i].n; ++k)
                pov_solid_unref(t[i].t[k].solid);
            free(t[i].t);
        }
        free(t);
    }
    for (size_t i = first_piece; i < out->n; ++i)
        if (out->v[i].solid == PIECE)
            out->v[i].solid = NULL;
    pov_solid_unref(node);
    free(f.v);
    free(f.unbounded);
    for (size_t i = 0; i < nsurfaces; ++i)
        pov_mesh_unref(surfaces[i]);
    free(surfaces);
    return 0;
}
