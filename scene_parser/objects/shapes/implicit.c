/* vbnl object layer: surfaces f(p) = 0 as triangles (pov_surface.h).
 *
 * Dual contouring (Ju, Losasso, Schaefer, Warren 2002) on a sparse grid:
 *  1. cells are found by descending an octree over the region: a cell whose centre value is
 *     further from 0 than the Lipschitz bound times its half diagonal cannot hold the surface and
 *     is dropped; the finest cells left are the seeds;
 *  2. from the seeds the crossed cells are grown along the surface (every cell around a grid edge
 *     whose ends differ in sign joins), so a surface found once is followed everywhere;
 *  3. each crossed cell gets one vertex, the least-squares point of the tangent planes at its
 *     edges' crossings (exact roots along the edges, normals from the gradient): on a smooth
 *     patch it is then moved onto the surface, on a sharp edge or corner it stays there;
 *  4. every grid edge whose ends differ in sign gives the quad of the four cells around it;
 *  5. the triangles are refined to the tolerance with points found on the surface.
 * Lattice values, crossings and vertices live in hash tables keyed by their grid position. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

#define NONE UINT32_MAX

/* ---- the grid ------------------------------------------------------------------------------- */

typedef struct crossing {
    double p[3], n[3];
} crossing;

typedef struct dc {
    const pov_implicit *im;
    double org[3], h;
    int n[3];            /* cells per axis */
    uint64_t evals;
    int failed;          /* 1 out of memory, 2 budget */
    pov_hmap vals;           /* lattice point -> index into fv (large grids) */
    double *fv;
    size_t nfv, capfv;
    double *dense;       /* small grids: every lattice point's value (NAN: not evaluated yet) */
    pov_hmap cells;          /* cell -> vertex id (NONE: crossed, no vertex yet / not crossed) */
    int64_t *queue;      /* cells to grow from */
    size_t nq, capq;
    pov_hmap edges;          /* edge -> index into xs */
    crossing *xs;
    size_t nxs, capxs;
    pov_smesh *m;
} dc;

static uint64_t lkey(int i, int j, int k) { return (uint64_t)(i + 1) | (uint64_t)(j + 1) << 21 | (uint64_t)(k + 1) << 42; }

static double feval(dc *d, const double p[3])
{
    d->evals++;
    if (d->im->max_evals && d->evals > d->im->max_evals && !d->failed)
        d->failed = 2;
    return d->im->f(d->im->user, p);
}

static void lpos(const dc *d, int i, int j, int k, double p[3])
{
    p[0] = d->org[0] + i * d->h;
    p[1] = d->org[1] + j * d->h;
    p[2] = d->org[2] + k * d->h;
}

/* f at a lattice point (cached). */
static double lval(dc *d, int i, int j, int k)
{
    if (d->dense) {
        double *slot = &d->dense[((size_t)k * (d->n[1] + 1) + (size_t)j) * (d->n[0] + 1) + (size_t)i];
        if (isnan(*slot)) {
            double p[3];
            lpos(d, i, j, k, p);
            double v = feval(d, p);
            *slot = isfinite(v) ? v : 1e30; /* undefined: outside */
        }
        return *slot;
    }
    int isnew;
    uint32_t *slot = pov_hmap_at(&d->vals, lkey(i, j, k), &isnew);
    if (!slot) {
        d->failed = 1;
        return 1;
    }
    if (!isnew)
        return d->fv[*slot];
    if (d->nfv == d->capfv) {
        size_t cap = d->capfv ? 2 * d->capfv : 4096;
        double *n = realloc(d->fv, cap * sizeof *n);
        if (!n) {
            d->failed = 1;
            return 1;
        }
        d->fv = n;
        d->capfv = cap;
    }
    double p[3];
    lpos(d, i, j, k, p);
    double v = feval(d, p);
    if (!isfinite(v))
        v = 1e30; /* undefined: outside */
    d->fv[d->nfv] = v;
    *slot = (uint32_t)d->nfv++;
    return v;
}

static int inside_v(double v) { return v < 0; }

/* Marks a cell crossed and queues it (once). */
static void add_cell(dc *d, int i, int j, int k)
{
    if (i < 0 || j < 0 || k < 0 || i >= d->n[0] || j >= d->n[1] || k >= d->n[2])
        return;
    int isnew;
    uint32_t *slot = pov_hmap_at(&d->cells, lkey(i, j, k), &isnew);
    if (!slot) {
        d->failed = 1;
        return;
    }
    if (!isnew)
        return;
    if (d->nq == d->capq) {
        size_t cap = d->capq ? 2 * d->capq : 1024;
        int64_t *n = realloc(d->queue, cap * 3 * sizeof *n);
        if (!n) {
            d->failed = 1;
            return;
        }
        d->queue = n;
        d->capq = cap;
    }
    d->queue[3 * d->nq] = i;
    d->queue[3 * d->nq + 1] = j;
    d->queue[3 * d->nq + 2] = k;
    d->nq++;
}

/* The octree descent: cells of size s (finest cells) at (i, j, k). */
static void descend(dc *d, int i, int j, int k, int s)
{
    if (d->failed || i >= d->n[0] || j >= d->n[1] || k >= d->n[2])
        return;
    if (d->im->excludes) {
        double lo[3] = {d->org[0] + i * d->h, d->org[1] + j * d->h, d->org[2] + k * d->h};
        double hi[3] = {lo[0] + s * d->h, lo[1] + s * d->h, lo[2] + s * d->h};
        d->evals++;
        if (d->im->excludes(d->im->user, lo, hi))
            return;
    } else if (d->im->lipschitz > 0) {
        double c[3] = {d->org[0] + (i + 0.5 * s) * d->h, d->org[1] + (j + 0.5 * s) * d->h,
                       d->org[2] + (k + 0.5 * s) * d->h};
        double v = feval(d, c), r = 0.5 * sqrt(3.0) * s * d->h;
        if (isfinite(v) && fabs(v) > d->im->lipschitz * r * 1.05)
            return;
    }
    if (s > 1) {
        int hs = s / 2;
        for (int c = 0; c < 8; ++c)
            descend(d, i + (c & 1 ? hs : 0), j + (c & 2 ? hs : 0), k + (c & 4 ? hs : 0), hs);
        return;
    }
    /* a finest cell: a seed when its corners differ in sign */
    int in = 0;
    for (int c = 0; c < 8; ++c)
        in += inside_v(lval(d, i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)));
    if (in > 0 && in < 8)
        add_cell(d, i, j, k);
}

/* The 12 edges of a cell: start corner offset and axis. */
static const int cell_edges[12][4] = {
    {0, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 1, 1, 0}, {0, 0, 0, 1}, {1, 0, 0, 1},
    {0, 0, 1, 1}, {1, 0, 1, 1}, {0, 0, 0, 2}, {1, 0, 0, 2}, {0, 1, 0, 2}, {1, 1, 0, 2},
};

/* Grows the crossed cells: the four cells around every crossed edge of a crossed cell. */
static void grow(dc *d)
{
    for (size_t q = 0; q < d->nq && !d->failed; ++q) {
        int i = (int)d->queue[3 * q], j = (int)d->queue[3 * q + 1], k = (int)d->queue[3 * q + 2];
        for (int e = 0; e < 12; ++e) {
            int a[3] = {i + cell_edges[e][0], j + cell_edges[e][1], k + cell_edges[e][2]}, ax = cell_edges[e][3];
            int b[3] = {a[0], a[1], a[2]};
            b[ax]++;
            if (inside_v(lval(d, a[0], a[1], a[2])) == inside_v(lval(d, b[0], b[1], b[2])))
                continue;
            int u = (ax + 1) % 3, v = (ax + 2) % 3;
            for (int c = 0; c < 4; ++c) {
                int cc[3] = {a[0], a[1], a[2]};
                cc[u] -= c & 1;
                cc[v] -= c >> 1;
                add_cell(d, cc[0], cc[1], cc[2]);
            }
        }
    }
}

void pov_field_normal(pov_field_fn f, void *user, const double p[3], double h, double n[3])
{
    double l = 0;
    for (int k = 0; k < 3; ++k) {
        double a[3] = {p[0], p[1], p[2]}, b[3] = {p[0], p[1], p[2]};
        a[k] += h;
        b[k] -= h;
        n[k] = f(user, a) - f(user, b);
        if (!isfinite(n[k]))
            n[k] = 0;
        l += n[k] * n[k];
    }
    l = sqrt(l);
    for (int k = 0; k < 3; ++k)
        n[k] = l > 0 ? n[k] / l : 0;
}

static void gradient(dc *d, const double p[3], double n[3])
{
    d->evals += 6;
    pov_field_normal(d->im->f, d->im->user, p, d->im->grad_step, n);
}

/* The root of f between a (value fa) and b (value fb) of opposite signs, by the Illinois method. */
static void root(dc *d, const double a[3], double fa, const double b[3], double fb, double out[3])
{
    double t0 = 0, t1 = 1, f0 = fa, f1 = fb, t = 0.5;
    int side = 0;
    for (int it = 0; it < 40; ++it) {
        t = f0 != f1 ? (t0 * f1 - t1 * f0) / (f1 - f0) : 0.5 * (t0 + t1);
        if (!(t > t0 && t < t1))
            t = 0.5 * (t0 + t1);
        double p[3];
        for (int k = 0; k < 3; ++k)
            p[k] = a[k] + (b[k] - a[k]) * t;
        double v = feval(d, p);
        if (!isfinite(v))
            v = 1e30;
        if (inside_v(v) == inside_v(f0)) {
            t0 = t, f0 = v;
            if (side == -1)
                f1 *= 0.5;
            side = -1;
        } else {
            t1 = t, f1 = v;
            if (side == 1)
                f0 *= 0.5;
            side = 1;
        }
        if (fabs(v) == 0 || t1 - t0 < 1e-7)
            break;
    }
    for (int k = 0; k < 3; ++k)
        out[k] = a[k] + (b[k] - a[k]) * t;
}

/* The crossing on the edge from lattice point a along axis ax (cached); NULL for none. */
static const crossing *edge_crossing(dc *d, const int a[3], int ax)
{
    int b[3] = {a[0], a[1], a[2]};
    b[ax]++;
    double fa = lval(d, a[0], a[1], a[2]), fb = lval(d, b[0], b[1], b[2]);
    if (inside_v(fa) == inside_v(fb))
        return NULL;
    int isnew;
    uint32_t *slot = pov_hmap_at(&d->edges, lkey(a[0], a[1], a[2]) * 3 + (uint64_t)ax, &isnew);
    if (!slot) {
        d->failed = 1;
        return NULL;
    }
    if (!isnew)
        return &d->xs[*slot];
    if (d->nxs == d->capxs) {
        size_t cap = d->capxs ? 2 * d->capxs : 1024;
        crossing *n = realloc(d->xs, cap * sizeof *n);
        if (!n) {
            d->failed = 1;
            return NULL;
        }
        d->xs = n;
        d->capxs = cap;
    }
    crossing *x = &d->xs[d->nxs];
    double pa[3], pb[3];
    lpos(d, a[0], a[1], a[2], pa);
    lpos(d, b[0], b[1], b[2], pb);
    root(d, pa, fa, pb, fb, x->p);
    gradient(d, x->p, x->n);
    if (x->n[0] == 0 && x->n[1] == 0 && x->n[2] == 0) /* a flat spot: the edge's direction */
        x->n[ax] = inside_v(fa) ? 1 : -1;
    *slot = (uint32_t)d->nxs++;
    return x;
}

void pov_sym_eigen3(double a[3][3], double w[3], double v[3][3])
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            v[i][j] = i == j;
    for (int sweep = 0; sweep < 32; ++sweep) {
        double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
        if (off < 1e-15)
            break;
        for (int p = 0; p < 2; ++p)
            for (int q = p + 1; q < 3; ++q) {
                if (fabs(a[p][q]) < 1e-300)
                    continue;
                double th = 0.5 * (a[q][q] - a[p][p]) / a[p][q];
                double t = (th >= 0 ? 1 : -1) / (fabs(th) + sqrt(th * th + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 3; ++k) {
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; ++k) {
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 3; ++k) {
                    double vkp = v[k][p], vkq = v[k][q];
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
            }
    }
    for (int i = 0; i < 3; ++i)
        w[i] = a[i][i];
}

/* Moves p onto the surface by Newton steps along the gradient, at most `reach` in all; 0 when it
 * does not converge (p unchanged). */
static int project(dc *d, double p[3], double reach)
{
    double q[3] = {p[0], p[1], p[2]}, moved = 0;
    for (int it = 0; it < 8; ++it) {
        double v = feval(d, q), g[3], gl = 0;
        if (!isfinite(v))
            return 0;
        for (int k = 0; k < 3; ++k) {
            double a[3] = {q[0], q[1], q[2]}, b[3] = {q[0], q[1], q[2]};
            a[k] += d->im->grad_step;
            b[k] -= d->im->grad_step;
            g[k] = (feval(d, a) - feval(d, b)) / (2 * d->im->grad_step);
            gl += g[k] * g[k];
        }
        if (!(gl > 0) || !isfinite(gl))
            return 0;
        double step = v / gl, sl = fabs(v) / sqrt(gl);
        if (sl < 1e-2 * d->im->tol) {
            memcpy(p, q, sizeof q);
            return 1;
        }
        moved += sl;
        if (moved > reach)
            return 0;
        for (int k = 0; k < 3; ++k)
            q[k] -= step * g[k];
    }
    return 0;
}

/* The vertex of a crossed cell (made once). */
static uint32_t cell_vertex(dc *d, int i, int j, int k)
{
    int isnew;
    uint32_t *slot = pov_hmap_at(&d->cells, lkey(i, j, k), &isnew);
    if (!slot) {
        d->failed = 1;
        return NONE;
    }
    if (*slot != NONE)
        return *slot;
    crossing xs[12]; /* copies: the table of crossings grows meanwhile */
    int nx = 0;
    for (int e = 0; e < 12; ++e) {
        int a[3] = {i + cell_edges[e][0], j + cell_edges[e][1], k + cell_edges[e][2]};
        const crossing *x = edge_crossing(d, a, cell_edges[e][3]);
        if (x)
            xs[nx++] = *x;
    }
    if (d->failed || nx == 0)
        return NONE;
    double mass[3] = {0, 0, 0}, A[3][3] = {{0}}, b[3] = {0, 0, 0}, nm[3] = {0, 0, 0};
    for (int x = 0; x < nx; ++x)
        for (int r = 0; r < 3; ++r) {
            mass[r] += xs[x].p[r] / nx;
            nm[r] += xs[x].n[r];
        }
    for (int x = 0; x < nx; ++x) {
        const double *n = xs[x].n;
        double dn = 0;
        for (int r = 0; r < 3; ++r)
            dn += n[r] * (xs[x].p[r] - mass[r]);
        for (int r = 0; r < 3; ++r) {
            b[r] += n[r] * dn;
            for (int c = 0; c < 3; ++c)
                A[r][c] += n[r] * n[c];
        }
    }
    double w[3], V[3][3], p[3];
    pov_sym_eigen3(A, w, V);
    double wmax = fmax(w[0], fmax(w[1], w[2]));
    memcpy(p, mass, sizeof p);
    for (int e = 0; e < 3; ++e) { /* the pseudo-inverse, small eigenvalues dropped */
        if (!(w[e] > 0.1 * wmax))
            continue;
        double c = (V[0][e] * b[0] + V[1][e] * b[1] + V[2][e] * b[2]) / w[e];
        for (int r = 0; r < 3; ++r)
            p[r] += c * V[r][e];
    }
    double lo[3], hi[3];
    lpos(d, i, j, k, lo);
    for (int r = 0; r < 3; ++r) {
        hi[r] = lo[r] + d->h;
        if (p[r] < lo[r] - 0.5 * d->h || p[r] > hi[r] + 0.5 * d->h) { /* a poor fit: the mean */
            memcpy(p, mass, sizeof p);
            break;
        }
    }
    /* a smooth patch (the crossings' normals close to their mean): onto the surface */
    double nl = sqrt(nm[0] * nm[0] + nm[1] * nm[1] + nm[2] * nm[2]);
    int smooth = nl > 0;
    for (int x = 0; x < nx && smooth; ++x)
        smooth = (xs[x].n[0] * nm[0] + xs[x].n[1] * nm[1] + xs[x].n[2] * nm[2]) / nl > 0.9;
    if (smooth)
        project(d, p, d->h);
    pov_svert v;
    memset(&v, 0, sizeof v);
    memcpy(v.p, p, sizeof p);
    gradient(d, p, v.n);
    if (v.n[0] == 0 && v.n[1] == 0 && v.n[2] == 0 && nl > 0)
        for (int r = 0; r < 3; ++r)
            v.n[r] = nm[r] / nl;
    uint32_t id = pov_smesh_vert(d->m, &v);
    if (id == NONE) {
        d->failed = 1;
        return NONE;
    }
    /* the table may have grown since: look the slot up again */
    slot = pov_hmap_at(&d->cells, lkey(i, j, k), &isnew);
    if (!slot) {
        d->failed = 1;
        return NONE;
    }
    *slot = id;
    return id;
}

static double d3(const double a[3], const double b[3])
{
    double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return x * x + y * y + z * z;
}

/* The quads of the crossed edges at the low corner of every crossed cell. */
static void quads(dc *d)
{
    for (size_t q = 0; q < d->nq && !d->failed; ++q) {
        int i = (int)d->queue[3 * q], j = (int)d->queue[3 * q + 1], k = (int)d->queue[3 * q + 2];
        for (int ax = 0; ax < 3 && !d->failed; ++ax) {
            int a[3] = {i, j, k}, b[3] = {i, j, k};
            b[ax]++;
            double fa = lval(d, a[0], a[1], a[2]), fb = lval(d, b[0], b[1], b[2]);
            if (inside_v(fa) == inside_v(fb))
                continue;
            int u = (ax + 1) % 3, v = (ax + 2) % 3;
            static const int off[4][2] = {{-1, -1}, {0, -1}, {0, 0}, {-1, 0}}; /* counter-clockwise in (u, v) */
            uint32_t id[4];
            int ok = 1;
            for (int c = 0; c < 4 && ok; ++c) {
                int cc[3] = {a[0], a[1], a[2]};
                cc[u] += off[c][0];
                cc[v] += off[c][1];
                if (cc[0] < 0 || cc[1] < 0 || cc[2] < 0 || cc[0] >= d->n[0] || cc[1] >= d->n[1] || cc[2] >= d->n[2])
                    ok = 0;
                else if ((id[c] = cell_vertex(d, cc[0], cc[1], cc[2])) == NONE)
                    ok = 0;
            }
            if (!ok)
                continue;
            if (!inside_v(fa)) { /* the outside is at a: the normal points along -axis */
                uint32_t t = id[1];
                id[1] = id[3];
                id[3] = t;
            }
            const pov_svert *vv = d->m->v;
            if (d3(vv[id[0]].p, vv[id[2]].p) <= d3(vv[id[1]].p, vv[id[3]].p)) {
                pov_smesh_tri(d->m, id[0], id[1], id[2]);
                pov_smesh_tri(d->m, id[0], id[2], id[3]);
            } else {
                pov_smesh_tri(d->m, id[0], id[1], id[3]);
                pov_smesh_tri(d->m, id[1], id[2], id[3]);
            }
        }
    }
}

/* ---- refinement: points on the surface -------------------------------------------------------- */

static int implicit_mid(void *user, const pov_svert *a, const pov_svert *b, pov_svert *out)
{
    dc *d = user;
    double m[3], dir[3], dl = 0, len = sqrt(d3(a->p, b->p));
    for (int k = 0; k < 3; ++k) {
        m[k] = 0.5 * (a->p[k] + b->p[k]);
        dir[k] = a->n[k] + b->n[k];
        dl += dir[k] * dir[k];
    }
    if (!(dl > 1e-6)) {
        gradient(d, m, dir);
        dl = 1;
    }
    dl = sqrt(dl);
    for (int k = 0; k < 3; ++k)
        dir[k] /= dl;
    double f0 = feval(d, m);
    if (!isfinite(f0))
        return 0;
    double best[3];
    int found = f0 == 0;
    memcpy(best, m, sizeof m);
    /* the nearest sign change along the mean normal, within the edge's length */
    static const double steps[] = {0.0625, 0.125, 0.25, 0.5, 1.0};
    double sgn = f0 > 0 ? -1.0 : 1.0; /* outside: the surface is behind, against the normal */
    for (int s = 0; s < 5 && !found; ++s)
        for (int side = 0; side < 2 && !found; ++side) {
            double t = steps[s] * len * (side ? -sgn : sgn), p[3];
            for (int k = 0; k < 3; ++k)
                p[k] = m[k] + t * dir[k];
            double fv = feval(d, p);
            if (isfinite(fv) && inside_v(fv) != inside_v(f0)) {
                root(d, m, f0, p, fv, best);
                found = 1;
            }
        }
    if (!found || d->failed)
        return 0;
    memset(out, 0, sizeof *out);
    memcpy(out->p, best, sizeof best);
    gradient(d, best, out->n);
    if (out->n[0] == 0 && out->n[1] == 0 && out->n[2] == 0)
        memcpy(out->n, dir, sizeof dir);
    return 1;
}

typedef struct bounds_walk {
    const pov_implicit *im;
    double lo[3], hi[3];
    int found;
    uint64_t visits;
} bounds_walk;

static void bounds_descend(bounds_walk *w, const double lo[3], const double hi[3], int depth)
{
    if (w->im->max_evals && ++w->visits > w->im->max_evals)
        return;
    if (w->im->excludes(w->im->user, lo, hi))
        return;
    if (depth == 0) {
        for (int k = 0; k < 3; ++k) {
            w->lo[k] = w->found ? fmin(w->lo[k], lo[k]) : lo[k];
            w->hi[k] = w->found ? fmax(w->hi[k], hi[k]) : hi[k];
        }
        w->found = 1;
        return;
    }
    /* halve the sides longer than half the longest (cells stay near cubes) */
    double ext = 0, mid[3];
    for (int k = 0; k < 3; ++k) {
        ext = fmax(ext, hi[k] - lo[k]);
        mid[k] = 0.5 * (lo[k] + hi[k]);
    }
    int split[3];
    for (int k = 0; k < 3; ++k)
        split[k] = hi[k] - lo[k] > 0.5 * ext;
    for (int c = 0; c < 8; ++c) {
        if (((c & 1) && !split[0]) || ((c & 2) && !split[1]) || ((c & 4) && !split[2]))
            continue;
        double l[3], h[3];
        for (int k = 0; k < 3; ++k) {
            int upper = c >> k & 1;
            l[k] = split[k] && upper ? mid[k] : lo[k];
            h[k] = split[k] && !upper ? mid[k] : hi[k];
        }
        bounds_descend(w, l, h, depth - 1);
    }
}

int pov_implicit_bounds(const pov_implicit *im, int depth, double lo[3], double hi[3])
{
    bounds_walk w;
    memset(&w, 0, sizeof w);
    w.im = im;
    if (!im->excludes) {
        memcpy(lo, im->lo, 3 * sizeof *lo);
        memcpy(hi, im->hi, 3 * sizeof *hi);
        return 1;
    }
    double l[3], h[3];
    memcpy(l, im->lo, sizeof l);
    memcpy(h, im->hi, sizeof h);
    /* again within the box found, until it stops shrinking: a small surface in a large region
     * gets bounds of its own size */
    for (int pass = 0; pass < 6; ++pass) {
        w.found = 0;
        bounds_descend(&w, l, h, depth);
        if (!w.found)
            return 0;
        double before = 0, after = 0;
        for (int k = 0; k < 3; ++k) {
            before = fmax(before, h[k] - l[k]);
            after = fmax(after, w.hi[k] - w.lo[k]);
        }
        memcpy(l, w.lo, sizeof l);
        memcpy(h, w.hi, sizeof h);
        if (after > 0.7 * before)
            break;
    }
    memcpy(lo, l, sizeof l);
    memcpy(hi, h, sizeof h);
    return 1;
}

pov_mesh *pov_implicit_mesh(const pov_implicit *im, const char **why)
{
    dc d;
    memset(&d, 0, sizeof d);
    d.im = im;
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    d.m = &sm;
    *why = NULL;
    double ext = 0;
    for (int k = 0; k < 3; ++k)
        ext = fmax(ext, im->hi[k] - im->lo[k]);
    int depth = im->depth < 2 ? 2 : im->depth > 9 ? 9 : im->depth;
    if (!(ext > 0) || !isfinite(ext))
        return pov_mesh_new();
    d.h = ext / (1 << depth);
    /* one cell of margin on every side: a surface on the region's faces is still crossed */
    int top = 1;
    for (int k = 0; k < 3; ++k) {
        d.org[k] = im->lo[k] - d.h;
        d.n[k] = (int)ceil((im->hi[k] - im->lo[k]) / d.h - 1e-9) + 2;
        if (d.n[k] < 1)
            d.n[k] = 1;
        while (top < d.n[k])
            top *= 2;
    }
    size_t lattice = (size_t)(d.n[0] + 1) * (d.n[1] + 1) * (d.n[2] + 1);
    /* lattice values in an array when it is small (8 MiB at most), or when nothing culls cells
     * (every point is evaluated: 32 MiB at most), else in a hash table */
    size_t dense_max = im->lipschitz <= 0 && !im->excludes ? (size_t)1 << 22 : (size_t)1 << 20;
    if (lattice <= dense_max && (d.dense = malloc(lattice * sizeof *d.dense)) != NULL)
        for (size_t i = 0; i < lattice; ++i)
            d.dense[i] = NAN;
    descend(&d, 0, 0, 0, top);
    grow(&d);
    quads(&d);
    int built = !d.failed && !sm.oom;
    if (built)
        pov_smesh_refine(&sm, 0, implicit_mid, &d, im->tol, im->refine_depth > 0 ? im->refine_depth : 8);
    pov_mesh *out = NULL;
    if (built && d.failed == 2) /* over the budget while refining: the surface as refined so far */
        d.failed = 0;
    if (d.failed == 2)
        *why = "the surface needs more evaluations of its function than the budget allows";
    else if (d.failed || sm.oom || !(out = pov_smesh_to_mesh(&sm, 0)))
        *why = "out of memory";
    pov_hmap_free(&d.vals);
    pov_hmap_free(&d.cells);
    pov_hmap_free(&d.edges);
    free(d.fv);
    free(d.dense);
    free(d.queue);
    free(d.xs);
    pov_smesh_free(&sm);
    return out;
}
