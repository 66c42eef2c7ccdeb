/* vbnl object layer: the surfaces of revolution of POV-Ray's splines.
 *   lathe { [linear_spline | quadratic_spline | cubic_spline | bezier_spline] n, <r, y> ... [sturm] }
 *   sor { n, <r, y> ... [open] [sturm] }
 * The splines are POV-Ray 3.7's (lathe.cpp, sor.cpp): each lathe segment is a cubic in t per
 * coordinate, (A t3 + B t2 + C t + D), built from the points as
 *   linear     P[i] to P[i+1]                               n - 1 segments
 *   quadratic  P[i+1] to P[i+2], slope from P[i]            n - 2 segments
 *   cubic      Catmull-Rom from P[i+1] to P[i+2]             n - 3 segments
 *   bezier     P[4k] .. P[4k+3] as Bezier control points      n / 4 segments;
 * a sor segment is r^2 = A y3 + B y2 + C y + D between P[i+1] and P[i+2], with the slopes of
 * r^2 at its ends from the neighbouring points, closed by flat caps at both ends unless open.
 * Inside (for CSG): a lathe's by counting the profile's crossings of the ray from the point away
 * from the axis (odd: inside), a sor's by r^2 < f(y) between its end heights, as POV-Ray's.
 * uv_mapping: u = angle / 2 pi from +x towards +z, v = (segment + t) / segments. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

enum { SPL_LINEAR = 0, SPL_QUADRATIC, SPL_CUBIC, SPL_BEZIER };

typedef struct lathe_data {
    int nseg;
    double (*c)[2][4]; /* per segment: r then y coefficients A B C D */
    int *flip;         /* per segment: its right side is inside */
    int sor;
    double ylo, yhi;   /* sor: the end heights */
} lathe_data;

static void seg_eval(const lathe_data *d, int seg, double t, double *r, double *y, double *dr, double *dy)
{
    const double(*c)[4] = d->c[seg];
    *r = ((c[0][0] * t + c[0][1]) * t + c[0][2]) * t + c[0][3];
    *y = ((c[1][0] * t + c[1][1]) * t + c[1][2]) * t + c[1][3];
    *dr = (3 * c[0][0] * t + 2 * c[0][1]) * t + c[0][2];
    *dy = (3 * c[1][0] * t + 2 * c[1][1]) * t + c[1][2];
}

/* sor: c[seg][0] holds r^2(y) = A y3 + B y2 + C y + D, c[seg][1][0..1] the segment's heights. */
static void sor_eval(const lathe_data *d, int seg, double t, double *r, double *y, double *dr, double *dy)
{
    const double *f = d->c[seg][0], y0 = d->c[seg][1][0], y1 = d->c[seg][1][1];
    *y = y0 + (y1 - y0) * t;
    double r2 = ((f[0] * *y + f[1]) * *y + f[2]) * *y + f[3], df = (3 * f[0] * *y + 2 * f[1]) * *y + f[2];
    *r = r2 > 0 ? sqrt(r2) : 0;
    /* dr/dy = f' / 2r: the direction (f', 2r), valid at r = 0 too */
    *dr = df;
    *dy = 2 * *r;
    if (*dr == 0 && *dy == 0)
        *dy = 1;
}

static void profile(void *user, int seg, double t, double *r, double *y, double *dr, double *dy)
{
    const lathe_data *d = user;
    if (d->sor)
        sor_eval(d, seg, t, r, y, dr, dy);
    else
        seg_eval(d, seg, t, r, y, dr, dy);
    if (d->flip[seg]) {
        *dr = -*dr;
        *dy = -*dy;
    }
}

/* Real roots in [0, 1] of a t3 + b t2 + c t + d (at most 3). */
static int cubic_roots01(double a, double b, double c, double d, double out[3])
{
    /* sign changes on a fine subdivision, each refined by bisection: robust for the small
     * cubics of profiles (multiple roots touching 0 count as none, as a tangent ray) */
    enum { N = 64 };
    int n = 0;
    double t0 = 0, f0 = d;
    for (int i = 1; i <= N && n < 3; ++i) {
        double t1 = (double)i / N, f1 = ((a * t1 + b) * t1 + c) * t1 + d;
        if ((f0 < 0) != (f1 < 0)) {
            double lo = t0, hi = t1, flo = f0;
            for (int it = 0; it < 60; ++it) {
                double m = 0.5 * (lo + hi), fm = ((a * m + b) * m + c) * m + d;
                if ((fm < 0) == (flo < 0))
                    lo = m, flo = fm;
                else
                    hi = m;
            }
            out[n++] = 0.5 * (lo + hi);
        }
        t0 = t1;
        f0 = f1;
    }
    return n;
}

static int lathe_inside(const void *data, const double q[3])
{
    const lathe_data *d = data;
    double r = sqrt(q[0] * q[0] + q[2] * q[2]), y = q[1];
    if (d->sor) {
        if (!(y >= d->ylo && y <= d->yhi))
            return 0;
        for (int s = 0; s < d->nseg; ++s) {
            double y0 = d->c[s][1][0], y1 = d->c[s][1][1];
            if (y >= fmin(y0, y1) && y <= fmax(y0, y1)) {
                const double *f = d->c[s][0];
                return r * r < ((f[0] * y + f[1]) * y + f[2]) * y + f[3];
            }
        }
        return 0;
    }
    int crossings = 0;
    for (int s = 0; s < d->nseg; ++s) {
        const double(*c)[4] = d->c[s];
        double roots[3];
        int n = cubic_roots01(c[1][0], c[1][1], c[1][2], c[1][3] - y, roots);
        for (int i = 0; i < n; ++i) {
            double t = roots[i], rr = ((c[0][0] * t + c[0][1]) * t + c[0][2]) * t + c[0][3];
            crossings += rr >= r;
        }
    }
    return crossings & 1;
}

static void lathe_destroy(void *data)
{
    lathe_data *d = data;
    free(d->c);
    free(d->flip);
    free(d);
}

static const pov_solid_fn lathe_fn = {lathe_inside, lathe_destroy, NULL};

/* ---- building ---------------------------------------------------------------------------------- */

static int lathe_segments(lathe_data *d, int type, const double (*P)[2], int n)
{
    int nseg = type == SPL_LINEAR ? n - 1 : type == SPL_QUADRATIC ? n - 2 : type == SPL_CUBIC ? n - 3 : n / 4;
    if (nseg < 1)
        return 0;
    d->c = calloc((size_t)nseg, sizeof *d->c);
    d->flip = calloc((size_t)nseg, sizeof *d->flip);
    if (!d->c || !d->flip)
        return -1;
    d->nseg = nseg;
    for (int s = 0, i = 0; s < nseg; ++s, i += type == SPL_BEZIER ? 4 : 1)
        for (int k = 0; k < 2; ++k) {
            double *c = d->c[s][k], p0 = P[i][k], p1 = i + 1 < n ? P[i + 1][k] : 0, p2 = i + 2 < n ? P[i + 2][k] : 0,
                   p3 = i + 3 < n ? P[i + 3][k] : 0;
            switch (type) {
            case SPL_LINEAR:
                c[0] = 0, c[1] = 0, c[2] = p1 - p0, c[3] = p0;
                break;
            case SPL_QUADRATIC:
                c[0] = 0, c[1] = 0.5 * p0 - p1 + 0.5 * p2, c[2] = -0.5 * p0 + 0.5 * p2, c[3] = p1;
                break;
            case SPL_CUBIC:
                c[0] = -0.5 * p0 + 1.5 * p1 - 1.5 * p2 + 0.5 * p3;
                c[1] = p0 - 2.5 * p1 + 2 * p2 - 0.5 * p3;
                c[2] = -0.5 * p0 + 0.5 * p2;
                c[3] = p1;
                break;
            default:
                c[0] = p3 - 3 * p2 + 3 * p1 - p0;
                c[1] = 3 * p2 - 6 * p1 + 3 * p0;
                c[2] = 3 * p1 - 3 * p0;
                c[3] = p0;
            }
        }
    return 1;
}

/* Solves the 4x4 system m x = k (Gaussian elimination with pivoting); 0 when singular. */
static int solve4(double m[4][4], double k[4], double x[4])
{
    for (int c = 0; c < 4; ++c) {
        int piv = c;
        for (int r = c + 1; r < 4; ++r)
            if (fabs(m[r][c]) > fabs(m[piv][c]))
                piv = r;
        if (!(fabs(m[piv][c]) > 1e-300))
            return 0;
        for (int j = 0; j < 4; ++j) {
            double t = m[c][j];
            m[c][j] = m[piv][j];
            m[piv][j] = t;
        }
        double t = k[c];
        k[c] = k[piv];
        k[piv] = t;
        for (int r = c + 1; r < 4; ++r) {
            double f = m[r][c] / m[c][c];
            for (int j = c; j < 4; ++j)
                m[r][j] -= f * m[c][j];
            k[r] -= f * k[c];
        }
    }
    for (int r = 3; r >= 0; --r) {
        double s = k[r];
        for (int j = r + 1; j < 4; ++j)
            s -= m[r][j] * x[j];
        x[r] = s / m[r][r];
    }
    return 1;
}

/* The sor's cubics of r^2 in y (0: points that make no surface, as POV-Ray refuses). */
static int sor_segments(lathe_data *d, const double (*P)[2], int n)
{
    int nseg = n - 3;
    d->c = calloc((size_t)nseg, sizeof *d->c);
    d->flip = calloc((size_t)nseg, sizeof *d->flip);
    if (!d->c || !d->flip)
        return -1;
    d->nseg = nseg;
    d->sor = 1;
    for (int i = 0; i < nseg; ++i) {
        if (fabs(P[i + 2][1] - P[i][1]) < 1e-10 || fabs(P[i + 3][1] - P[i + 1][1]) < 1e-10)
            return 0;
        double k[4] = {P[i + 1][0] * P[i + 1][0], P[i + 2][0] * P[i + 2][0],
                       2 * P[i + 1][0] * (P[i + 2][0] - P[i][0]) / (P[i + 2][1] - P[i][1]),
                       2 * P[i + 2][0] * (P[i + 3][0] - P[i + 1][0]) / (P[i + 3][1] - P[i + 1][1])};
        double w0 = P[i + 1][1], w1 = P[i + 2][1];
        double m[4][4] = {{w0 * w0 * w0, w0 * w0, w0, 1}, {w1 * w1 * w1, w1 * w1, w1, 1},
                          {3 * w0 * w0, 2 * w0, 1, 0}, {3 * w1 * w1, 2 * w1, 1, 0}};
        if (!solve4(m, k, d->c[i][0]))
            return 0;
        d->c[i][1][0] = w0;
        d->c[i][1][1] = w1;
    }
    d->ylo = P[1][1];
    d->yhi = P[n - 2][1];
    return 1;
}

typedef struct lathe_shape {
    pov_mods mods;
    lathe_data *d;
    int open;
    double rmax, ylo, yhi;
} lathe_shape;

static vbnl_result lathe_open(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((lathe_shape *)it->target)->open = 1;
    return VBNL_OK;
}

static const pov_row lathe_rows[] = {{NULL, NULL, 0}};
static const pov_row sor_rows[] = {{"open", lathe_open, 0}, {NULL, NULL, 0}};
POV_SHAPE_BLOCK(lathe_block, lathe_rows);
POV_SHAPE_BLOCK(sor_block, sor_rows);

static vbnl_result lathe_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    lathe_shape *ls = (lathe_shape *)mods;
    lathe_data *d = ls->d;
    double lo[3] = {-ls->rmax, ls->ylo, -ls->rmax}, hi[3] = {ls->rmax, ls->yhi, ls->rmax};
    /* which side of each segment is outside: a point just to its right tested with the crossings */
    for (int sg = 0; sg < d->nseg; ++sg) {
        double r, y, dr, dy;
        profile(d, sg, 0.5, &r, &y, &dr, &dy);
        double l = hypot(dr, dy), e = 1e-6 * (hi[1] - lo[1] + ls->rmax);
        if (d->sor || !(l > 0))
            continue;
        double q[3] = {r + e * dy / l, y - e * dr / l, 0};
        d->flip[sg] = q[0] >= 0 && lathe_inside(d, q);
    }
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    pov_revolve(&sm, profile, d, d->nseg, POV_TESS_TOL * pov_box_radius(lo, hi), 0);
    if (d->sor && !ls->open) {
        double rb = sqrt(fmax(0, ((d->c[0][0][0] * d->ylo + d->c[0][0][1]) * d->ylo + d->c[0][0][2]) * d->ylo +
                                     d->c[0][0][3]));
        double rt, yt = d->yhi;
        const double *f = d->c[d->nseg - 1][0];
        rt = sqrt(fmax(0, ((f[0] * yt + f[1]) * yt + f[2]) * yt + f[3]));
        if (rb > 0)
            pov_revolve_cap(&sm, 0, 0, d->ylo, -1);
        if (rt > 0)
            pov_revolve_cap(&sm, 0, 1, d->yhi, 1);
    }
    pov_solid *solid = pov_solid_custom(&lathe_fn, d, lo, hi);
    ls->d = NULL;
    if (!solid) {
        pov_smesh_free(&sm);
        return pov_oom(s->L);
    }
    return pov_shape_set_mesh(s, pr, &sm, 1, solid);
}

vbnl_result pov_shape_lathe(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    int sor = s->keyword[0] == 's', type = SPL_LINEAR;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        int k = pov_is_word(t, "linear_spline") ? SPL_LINEAR
                : pov_is_word(t, "quadratic_spline") ? SPL_QUADRATIC
                : pov_is_word(t, "cubic_spline") ? SPL_CUBIC
                : pov_is_word(t, "bezier_spline") ? SPL_BEZIER
                : -1;
        if (k < 0 || sor)
            break;
        type = k;
        vbnl_sdl_next(p);
    }
    double count;
    vbnl_sdl_loc at = vbnl_sdl_peek(p)->loc;
    if (pov_list_count(L, &count) != VBNL_OK)
        return VBNL_ERR_PARSE;
    static const int least[] = {2, 3, 4, 4};
    int need = sor ? 4 : least[type];
    if (!(count >= need && count <= 1e6) || count != floor(count))
        return vbnl_sdl_error(p, &at, "%s: the number of points must be a whole number of at least %d, got %g",
                              s->keyword, need, count);
    if (!sor && type == SPL_BEZIER && (int)count % 4)
        return vbnl_sdl_error(p, &at, "lathe: a bezier_spline needs four points per segment, got %g", count);
    int n = (int)count;
    double(*P)[2] = malloc(sizeof *P * (size_t)n);
    lathe_shape ls;
    memset(&ls, 0, sizeof ls);
    ls.d = calloc(1, sizeof *ls.d);
    vbnl_result r = VBNL_OK;
    if (!P || !ls.d) {
        r = pov_oom(L);
        goto done;
    }
    ls.ylo = INFINITY;
    ls.yhi = -INFINITY;
    for (int i = 0; i < n && r == VBNL_OK; ++i) {
        pov_comma(L);
        vbnl_sdl_loc pl = vbnl_sdl_peek(p)->loc;
        if (vbnl_sdl_parse_vector(p, 2, P[i]) != VBNL_OK)
            r = VBNL_ERR_PARSE;
        else if (sor && (P[i][0] < 0 || (i > 1 && i < n - 1 && P[i][1] <= P[i - 1][1])))
            r = vbnl_sdl_error(p, &pl, "sor: point %d <%g, %g>: radii must be >= 0 and heights must rise", i + 1,
                               P[i][0], P[i][1]);
        else if (!sor && i > 0 && i < n - 1 && P[i][0] < 0)
            r = vbnl_sdl_error(p, &pl, "lathe: point %d <%g, %g> has a negative radius", i + 1, P[i][0], P[i][1]);
    }
    if (r != VBNL_OK)
        goto done;
    int ok = sor ? sor_segments(ls.d, (const double(*)[2])P, n) : lathe_segments(ls.d, type, (const double(*)[2])P, n);
    if (ok < 0) {
        r = pov_oom(L);
        goto done;
    }
    if (ok == 0) {
        r = vbnl_sdl_error(p, &s->loc, "sor: two points two apart have the same height: no surface");
        goto done;
    }
    /* the bounds: the profile sampled densely (a cubic's bulge lies between its points) */
    for (int sg = 0; sg < ls.d->nseg; ++sg)
        for (int i = 0; i <= 64; ++i) {
            double rr, y, dr, dy;
            profile(ls.d, sg, i / 64.0, &rr, &y, &dr, &dy);
            ls.rmax = fmax(ls.rmax, fabs(rr));
            ls.ylo = fmin(ls.ylo, y);
            ls.yhi = fmax(ls.yhi, y);
        }
    ls.rmax *= 1.02;
    r = pov_shape_deferred(s, sor ? &sor_block : &lathe_block, &ls.mods, lathe_make);
done:
    free(P);
    if (ls.d)
        lathe_destroy(ls.d);
    return r;
}
