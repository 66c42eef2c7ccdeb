/* vbnl object layer: closed 2D outlines (pov_surface.h): prism and text outlines, flattened to the
 * tolerance, filled by the even-odd rule (POV-Ray's rule for both) and tested for inside. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

void pov_outline_free(pov_outline *o)
{
    free(o->xy);
    free(o->nrm);
    free(o->start);
    memset(o, 0, sizeof *o);
}

void pov_outline_begin(pov_outline *o)
{
    if (o->oom)
        return;
    if (o->ncont == o->capcont) {
        uint32_t cap = o->capcont ? 2 * o->capcont : 16;
        uint32_t *n = realloc(o->start, cap * sizeof *n);
        if (!n) {
            o->oom = 1;
            return;
        }
        o->start = n;
        o->capcont = cap;
    }
    o->start[o->ncont++] = o->n;
}

static void add_point(pov_outline *o, double x, double y, double tx, double ty)
{
    if (o->oom)
        return;
    if (o->n == o->cap) {
        uint32_t cap = o->cap ? 2 * o->cap : 64;
        double *a = realloc(o->xy, (size_t)cap * 2 * sizeof *a);
        if (a)
            o->xy = a;
        double *b = a ? realloc(o->nrm, (size_t)cap * 2 * sizeof *b) : NULL;
        if (!b) {
            o->oom = 1;
            return;
        }
        o->nrm = b;
        o->cap = cap;
    }
    double l = sqrt(tx * tx + ty * ty);
    o->xy[2 * o->n] = x;
    o->xy[2 * o->n + 1] = y;
    o->nrm[2 * o->n] = l > 0 ? tx / l : 0;
    o->nrm[2 * o->n + 1] = l > 0 ? ty / l : 0;
    o->n++;
}

/* The first point of a segment: the last point again when the direction turns there (a corner:
 * the walls on each side get their own normal), or the point itself when the contour starts. */
static void segment_start(pov_outline *o, const double p0[2], double tx, double ty)
{
    uint32_t first = o->ncont ? o->start[o->ncont - 1] : 0;
    if (o->n > first) {
        const double *q = o->xy + 2 * (o->n - 1), *t = o->nrm + 2 * (o->n - 1);
        double l = sqrt(tx * tx + ty * ty);
        if (q[0] == p0[0] && q[1] == p0[1] && l > 0 && (t[0] * tx + t[1] * ty) / l > 0.9998)
            return; /* smooth join (within 1 degree) */
        if (q[0] == p0[0] && q[1] == p0[1] && t[0] == 0 && t[1] == 0) {
            o->nrm[2 * (o->n - 1)] = l > 0 ? tx / l : 0; /* a point without direction yet */
            o->nrm[2 * (o->n - 1) + 1] = l > 0 ? ty / l : 0;
            return;
        }
    }
    add_point(o, p0[0], p0[1], tx, ty);
}

void pov_outline_point(pov_outline *o, double x, double y, double tx, double ty) { add_point(o, x, y, tx, ty); }

void pov_outline_quad(pov_outline *o, const double p0[2], const double p1[2], const double p2[2], double tol)
{
    double ax = p0[0] - 2 * p1[0] + p2[0], ay = p0[1] - 2 * p1[1] + p2[1];
    /* chord error of a step dt: |B''| dt^2 / 8 with |B''| = 2 |p0 - 2 p1 + p2| */
    double acc = sqrt(ax * ax + ay * ay);
    int n = acc > 0 && tol > 0 ? (int)ceil(sqrt(acc / (4 * tol))) : 1;
    n = n < 1 ? 1 : n > 1024 ? 1024 : n;
    for (int i = 0; i <= n; ++i) {
        double t = (double)i / n, u = 1 - t;
        double x = u * u * p0[0] + 2 * u * t * p1[0] + t * t * p2[0];
        double y = u * u * p0[1] + 2 * u * t * p1[1] + t * t * p2[1];
        double tx = 2 * u * (p1[0] - p0[0]) + 2 * t * (p2[0] - p1[0]);
        double ty = 2 * u * (p1[1] - p0[1]) + 2 * t * (p2[1] - p1[1]);
        if (tx == 0 && ty == 0) { /* a control point on an end: the chord's direction */
            tx = p2[0] - p0[0];
            ty = p2[1] - p0[1];
        }
        if (i == 0)
            segment_start(o, p0, tx, ty);
        else
            add_point(o, x, y, tx, ty);
    }
}

void pov_outline_line(pov_outline *o, const double p0[2], const double p1[2])
{
    double c[2] = {0.5 * (p0[0] + p1[0]), 0.5 * (p0[1] + p1[1])}; /* a flat quadratic: one step */
    if (p0[0] != p1[0] || p0[1] != p1[1])
        pov_outline_quad(o, p0, c, p1, 1.0);
}

void pov_outline_cubic(pov_outline *o, const double p0[2], const double p1[2], const double p2[2], const double p3[2],
                       double tol)
{
    double a0 = hypot(p0[0] - 2 * p1[0] + p2[0], p0[1] - 2 * p1[1] + p2[1]);
    double a1 = hypot(p1[0] - 2 * p2[0] + p3[0], p1[1] - 2 * p2[1] + p3[1]);
    /* |B''| <= 6 max(a0, a1); chord error |B''| dt^2 / 8 */
    double acc = 6 * fmax(a0, a1);
    int n = acc > 0 && tol > 0 ? (int)ceil(sqrt(acc / (8 * tol))) : 1;
    n = n < 1 ? 1 : n > 1024 ? 1024 : n;
    for (int i = 0; i <= n; ++i) {
        double t = (double)i / n, u = 1 - t;
        double b0 = u * u * u, b1 = 3 * u * u * t, b2 = 3 * u * t * t, b3 = t * t * t;
        double x = b0 * p0[0] + b1 * p1[0] + b2 * p2[0] + b3 * p3[0];
        double y = b0 * p0[1] + b1 * p1[1] + b2 * p2[1] + b3 * p3[1];
        double tx = 3 * u * u * (p1[0] - p0[0]) + 6 * u * t * (p2[0] - p1[0]) + 3 * t * t * (p3[0] - p2[0]);
        double ty = 3 * u * u * (p1[1] - p0[1]) + 6 * u * t * (p2[1] - p1[1]) + 3 * t * t * (p3[1] - p2[1]);
        if (tx == 0 && ty == 0) {
            tx = (i == 0 ? p2[0] : p3[0]) - (i == 0 ? p0[0] : p1[0]);
            ty = (i == 0 ? p2[1] : p3[1]) - (i == 0 ? p0[1] : p1[1]);
            if (tx == 0 && ty == 0) {
                tx = p3[0] - p0[0];
                ty = p3[1] - p0[1];
            }
        }
        if (i == 0)
            segment_start(o, p0, tx, ty);
        else
            add_point(o, x, y, tx, ty);
    }
}

static uint32_t contour_end(const pov_outline *o, uint32_t c) { return c + 1 < o->ncont ? o->start[c + 1] : o->n; }

int pov_outline_inside(const pov_outline *o, double x, double y)
{
    int in = 0;
    for (uint32_t c = 0; c < o->ncont; ++c) {
        uint32_t s = o->start[c], e = contour_end(o, c);
        for (uint32_t i = s; i < e; ++i) {
            uint32_t j = i + 1 < e ? i + 1 : s;
            const double *a = o->xy + 2 * i, *b = o->xy + 2 * j;
            if ((a[1] > y) != (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0])
                in = !in;
        }
    }
    return in;
}

int pov_outline_finish(pov_outline *o)
{
    if (o->oom)
        return 0;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (uint32_t i = 0; i < o->n; ++i)
        for (int k = 0; k < 2; ++k) {
            lo[k] = fmin(lo[k], o->xy[2 * i + k]);
            hi[k] = fmax(hi[k], o->xy[2 * i + k]);
        }
    double eps = 1e-7 * fmax(hi[0] - lo[0], hi[1] - lo[1]);
    for (uint32_t c = 0; c < o->ncont; ++c) {
        uint32_t s = o->start[c], e = contour_end(o, c);
        /* which side of the contour is filled: tested beside its longest edge */
        double best = 0, mx = 0, my = 0, lx = 0, ly = 0;
        for (uint32_t i = s; i < e; ++i) {
            uint32_t j = i + 1 < e ? i + 1 : s;
            double dx = o->xy[2 * j] - o->xy[2 * i], dy = o->xy[2 * j + 1] - o->xy[2 * i + 1], l = hypot(dx, dy);
            if (l > best) {
                best = l;
                mx = 0.5 * (o->xy[2 * i] + o->xy[2 * j]);
                my = 0.5 * (o->xy[2 * i + 1] + o->xy[2 * j + 1]);
                lx = -dy / l;
                ly = dx / l;
            }
        }
        int left_filled = best > 0 && pov_outline_inside(o, mx + eps * lx, my + eps * ly);
        for (uint32_t i = s; i < e; ++i) { /* the tangent turned to the unfilled side */
            double tx = o->nrm[2 * i], ty = o->nrm[2 * i + 1];
            o->nrm[2 * i] = left_filled ? ty : -ty;
            o->nrm[2 * i + 1] = left_filled ? -tx : tx;
        }
    }
    return 1;
}

/* ---- filling ----------------------------------------------------------------------------------- */

typedef struct fedge {
    double x0, y0, x1, y1; /* x0 < x1 */
} fedge;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static int cmp_edge(const void *a, const void *b)
{
    double x = ((const fedge *)a)->x0, y = ((const fedge *)b)->x0;
    return x < y ? -1 : x > y;
}

static double edge_y(const fedge *e, double x)
{
    if (x <= e->x0)
        return e->y0;
    if (x >= e->x1)
        return e->y1;
    return e->y0 + (e->y1 - e->y0) * (x - e->x0) / (e->x1 - e->x0);
}

typedef struct fill_ctx {
    pov_smesh *m;
    pov_plane_fn pos;
    void *user;
    const double *n;
} fill_ctx;

static uint32_t fill_vert(fill_ctx *f, double x, double y)
{
    pov_svert v;
    memset(&v, 0, sizeof v);
    f->pos(f->user, x, y, v.p);
    memcpy(v.n, f->n, sizeof v.n);
    v.uv[0] = x;
    v.uv[1] = y;
    return pov_smesh_vert(f->m, &v);
}

static void fill_tri(fill_ctx *f, uint32_t a, uint32_t b, uint32_t c) { pov_smesh_tri_facing(f->m, a, b, c); }

void pov_outline_fill(const pov_outline *o, pov_smesh *m, pov_plane_fn pos, void *user, const double n[3])
{
    fill_ctx f = {m, pos, user, n};
    fedge *edges = malloc(sizeof *edges * (o->n + 1));
    double *xs = malloc(sizeof *xs * (o->n + 1));
    fedge **active = malloc(sizeof *active * (o->n + 1));
    double *ym = malloc(sizeof *ym * (o->n + 1));
    if (!edges || !xs || !active || !ym) {
        m->oom = 1;
        goto done;
    }
    uint32_t ne = 0, nx = 0;
    for (uint32_t c = 0; c < o->ncont; ++c) {
        uint32_t s = o->start[c], e = contour_end(o, c);
        for (uint32_t i = s; i < e; ++i) {
            uint32_t j = i + 1 < e ? i + 1 : s;
            const double *a = o->xy + 2 * i, *b = o->xy + 2 * j;
            xs[nx++] = a[0];
            if (a[0] == b[0]) /* vertical (or empty): spans no slab */
                continue;
            fedge *ed = &edges[ne++];
            int fwd = a[0] < b[0];
            ed->x0 = fwd ? a[0] : b[0];
            ed->y0 = fwd ? a[1] : b[1];
            ed->x1 = fwd ? b[0] : a[0];
            ed->y1 = fwd ? b[1] : a[1];
        }
    }
    qsort(xs, nx, sizeof *xs, cmp_double);
    qsort(edges, ne, sizeof *edges, cmp_edge);
    uint32_t nu = 0;
    for (uint32_t i = 0; i < nx; ++i)
        if (nu == 0 || xs[i] != xs[nu - 1])
            xs[nu++] = xs[i];
    uint32_t next = 0, nact = 0;
    for (uint32_t s = 0; s + 1 < nu && !m->oom; ++s) {
        double x0 = xs[s], x1 = xs[s + 1], xm = 0.5 * (x0 + x1);
        /* the edges spanning this slab: drop the ended ones, add the starting ones */
        uint32_t k = 0;
        for (uint32_t i = 0; i < nact; ++i)
            if (active[i]->x1 > x0)
                active[k++] = active[i];
        nact = k;
        while (next < ne && edges[next].x0 <= x0) {
            if (edges[next].x1 > x0)
                active[nact++] = &edges[next];
            next++;
        }
        /* sorted by height in the slab's middle (insertion sort: nearly sorted from the last slab) */
        for (uint32_t i = 0; i < nact; ++i)
            ym[i] = edge_y(active[i], xm);
        for (uint32_t i = 1; i < nact; ++i) {
            fedge *e = active[i];
            double y = ym[i];
            uint32_t j = i;
            for (; j > 0 && ym[j - 1] > y; --j) {
                active[j] = active[j - 1];
                ym[j] = ym[j - 1];
            }
            active[j] = e;
            ym[j] = y;
        }
        for (uint32_t i = 0; i + 1 < nact; i += 2) { /* even-odd: the region between pairs */
            const fedge *lo = active[i], *hi = active[i + 1];
            double a0 = edge_y(lo, x0), a1 = edge_y(lo, x1), b0 = edge_y(hi, x0), b1 = edge_y(hi, x1);
            uint32_t va0 = fill_vert(&f, x0, a0), va1 = fill_vert(&f, x1, a1);
            uint32_t vb1 = fill_vert(&f, x1, b1), vb0 = fill_vert(&f, x0, b0);
            if (a0 != b0)
                fill_tri(&f, va0, va1, vb0);
            if (a1 != b1)
                fill_tri(&f, va1, vb1, vb0);
        }
    }
done:
    free(edges);
    free(xs);
    free(active);
    free(ym);
}

/* ---- walls ------------------------------------------------------------------------------------- */

/* The outline's distinct x values, sorted (the fill's slab boundaries); NULL when out of memory. */
static double *slab_xs(const pov_outline *o, uint32_t *n)
{
    double *xs = malloc(sizeof *xs * (o->n + 1));
    if (!xs)
        return NULL;
    for (uint32_t i = 0; i < o->n; ++i)
        xs[i] = o->xy[2 * i];
    qsort(xs, o->n, sizeof *xs, cmp_double);
    uint32_t nu = 0;
    for (uint32_t i = 0; i < o->n; ++i)
        if (nu == 0 || xs[i] != xs[nu - 1])
            xs[nu++] = xs[i];
    *n = nu;
    return xs;
}

/* One wall vertex: the outline point (x, y) with the normal nrm, at the sweep's start or end. */
static uint32_t wall_vert(pov_smesh *m, pov_sweep_fn sweep, void *user, double x, double y, const double nrm[2], int h)
{
    pov_svert v;
    memset(&v, 0, sizeof v);
    double xy[2] = {x, y};
    sweep(user, xy, nrm, h, v.p, v.n);
    v.uv[0] = x;
    v.uv[1] = h;
    return pov_smesh_vert(m, &v);
}

static int cmp_up(const void *a, const void *b) { return cmp_double(a, b); }

/* The wall of a vertical outline edge a-b: the caps' trapezoids have corners on its line at the
 * heights of every other edge that spans it, so the wall is cut there too. */
static void vertical_wall(const pov_outline *o, pov_smesh *m, pov_sweep_fn sweep, void *user, const double a[2],
                          const double b[2], const double na[2], const double nb[2])
{
    double x = a[0], ylo = fmin(a[1], b[1]), yhi = fmax(a[1], b[1]);
    uint32_t n = 0, cap = 16;
    double *ys = malloc(sizeof *ys * cap);
    for (uint32_t c = 0; c < o->ncont && ys; ++c) {
        uint32_t s = o->start[c], e = contour_end(o, c);
        for (uint32_t i = s; i < e && ys; ++i) {
            uint32_t j = i + 1 < e ? i + 1 : s;
            const double *p = o->xy + 2 * i, *q = o->xy + 2 * j;
            if (p[0] == q[0])
                continue;
            fedge fe = {fmin(p[0], q[0]), p[0] < q[0] ? p[1] : q[1], fmax(p[0], q[0]), p[0] < q[0] ? q[1] : p[1]};
            if (!(fe.x0 <= x && x <= fe.x1))
                continue;
            double y = edge_y(&fe, x);
            if (!(y > ylo && y < yhi))
                continue;
            if (n == cap) {
                double *g = realloc(ys, sizeof *ys * (cap *= 2));
                if (!g) {
                    free(ys);
                    ys = NULL;
                    break;
                }
                ys = g;
            }
            ys[n++] = y;
        }
    }
    if (!ys) {
        m->oom = 1;
        return;
    }
    qsort(ys, n, sizeof *ys, cmp_up);
    uint32_t p0 = wall_vert(m, sweep, user, a[0], a[1], na, 0), p1 = wall_vert(m, sweep, user, a[0], a[1], na, 1);
    for (uint32_t q = 0; q <= n && !m->oom; ++q) {
        double y = q == n ? b[1] : a[1] < b[1] ? ys[q] : ys[n - 1 - q];
        if (q < n && q > 0 && y == (a[1] < b[1] ? ys[q - 1] : ys[n - q]))
            continue; /* the same height twice */
        const double *nrm = q == n ? nb : na;
        uint32_t c0 = wall_vert(m, sweep, user, x, y, nrm, 0), c1 = wall_vert(m, sweep, user, x, y, nrm, 1);
        pov_smesh_tri_facing(m, p0, c0, c1);
        pov_smesh_tri_facing(m, p0, c1, p1);
        p0 = c0;
        p1 = c1;
    }
    free(ys);
}

void pov_outline_walls(const pov_outline *o, pov_smesh *m, pov_sweep_fn sweep, void *user)
{
    /* each edge is cut where the caps' slabs cut it (at the same points, computed the same way),
     * so that the walls and the caps share their vertices: no T-junction along the rims */
    uint32_t nx;
    double *xs = slab_xs(o, &nx);
    if (!xs) {
        m->oom = 1;
        return;
    }
    for (uint32_t c = 0; c < o->ncont && !m->oom; ++c) {
        uint32_t s = o->start[c], e = contour_end(o, c);
        for (uint32_t i = s; i < e && !m->oom; ++i) {
            uint32_t j = i + 1 < e ? i + 1 : s;
            const double *a = o->xy + 2 * i, *b = o->xy + 2 * j, *na = o->nrm + 2 * i, *nb = o->nrm + 2 * j;
            if (a[0] == b[0] && a[1] == b[1])
                continue;
            /* the points along the edge: its ends and the slab boundaries strictly between */
            fedge fe = {fmin(a[0], b[0]), a[0] < b[0] ? a[1] : b[1], fmax(a[0], b[0]), a[0] < b[0] ? b[1] : a[1]};
            uint32_t lo = 0, hi = nx;
            while (lo < hi) { /* the first slab boundary above the edge's smaller x */
                uint32_t mid = (lo + hi) / 2;
                if (xs[mid] <= fe.x0)
                    lo = mid + 1;
                else
                    hi = mid;
            }
            uint32_t k0 = lo, k1 = k0;
            while (k1 < nx && xs[k1] < fe.x1)
                k1++;
            if (a[0] == b[0]) { /* vertical: cut where the other edges cross its slab line */
                vertical_wall(o, m, sweep, user, a, b, na, nb);
                continue;
            }
            uint32_t npts = 2 + (k1 - k0);
            uint32_t prev0 = wall_vert(m, sweep, user, a[0], a[1], na, 0), prev1 = wall_vert(m, sweep, user, a[0], a[1], na, 1);
            for (uint32_t q = 1; q < npts && !m->oom; ++q) {
                double x, y, nrm[2];
                if (q + 1 == npts) {
                    x = b[0], y = b[1];
                    nrm[0] = nb[0], nrm[1] = nb[1];
                } else { /* in the edge's direction from a: the slabs in order */
                    uint32_t k = a[0] < b[0] ? k0 + q - 1 : k1 - q;
                    x = xs[k];
                    y = edge_y(&fe, x);
                    double t = (x - a[0]) / (b[0] - a[0]), l;
                    nrm[0] = na[0] + t * (nb[0] - na[0]);
                    nrm[1] = na[1] + t * (nb[1] - na[1]);
                    l = hypot(nrm[0], nrm[1]);
                    if (l > 0)
                        nrm[0] /= l, nrm[1] /= l;
                }
                uint32_t cur0 = wall_vert(m, sweep, user, x, y, nrm, 0), cur1 = wall_vert(m, sweep, user, x, y, nrm, 1);
                pov_smesh_tri_facing(m, prev0, cur0, cur1);
                pov_smesh_tri_facing(m, prev0, cur1, prev1);
                prev0 = cur0;
                prev1 = cur1;
            }
        }
    }
    free(xs);
}
