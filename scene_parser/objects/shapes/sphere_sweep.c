/* vbnl object layer: sphere_sweep { linear_spline | cubic_spline | b_spline  n,
 *                                   <c1>, r1, ... [tolerance t] modifiers }
 *
 * POV-Ray 3.7's sphere sweep (sphsweep.cpp): the union of the spheres whose centre and radius
 * follow the spline through the modeling spheres (linear: from each to the next; cubic_spline:
 * Catmull-Rom, b_spline: uniform cubic B-spline, over each four in a row, n - 3 segments). The
 * union of spheres is the zero set of f(p) = min over t of (|p - c(t)| - r(t)), negative inside,
 * whose gradient is at most 1: the surface is made by dual contouring (implicit.c) with cells of
 * at most half the smallest radius, refined to POV_TESS_TOL of the sweep's radius, watertight
 * where segments and spheres meet (the joints of a linear sweep keep their creases). The minimum
 * over t is found by golden sections, over the whole segment for a linear one (where it is
 * convex), else around the best of 32 samples. `tolerance` sets POV-Ray's root finder and
 * changes nothing here. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

enum { SW_LINEAR = 0, SW_CUBIC, SW_BSPLINE };

typedef struct sweep_seg {
    double c[4][4];      /* per coordinate (x, y, z, r): A t3 + B t2 + C t + D */
    double lo[3], hi[3]; /* its reach */
    int convex;          /* linear: |p - c(t)| - r(t) is convex in t */
} sweep_seg;

typedef struct sweep_data {
    sweep_seg *s;
    int n;
} sweep_data;

static void seg_at(const sweep_seg *s, double t, double p[4])
{
    for (int k = 0; k < 4; ++k) {
        const double *c = s->c[k];
        p[k] = ((c[0] * t + c[1]) * t + c[2]) * t + c[3];
    }
}

static double seg_g(const sweep_seg *s, const double q[3], double t)
{
    double p[4];
    seg_at(s, t, p);
    return sqrt((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) + (q[2] - p[2]) * (q[2] - p[2])) - p[3];
}

/* min over t in [0, 1] of |q - c(t)| - r(t): golden sections over the whole segment when the
 * function is convex (linear), else around the best of 32 samples */
static double seg_min(const sweep_seg *s, const double q[3])
{
    double lo = 0, hi = 1, best = INFINITY;
    if (!s->convex) {
        enum { N = 32 };
        double bt = 0;
        for (int i = 0; i <= N; ++i) {
            double e = seg_g(s, q, (double)i / N);
            if (e < best)
                best = e, bt = (double)i / N;
        }
        lo = fmax(0, bt - 1.0 / N);
        hi = fmin(1, bt + 1.0 / N);
    } else {
        best = fmin(seg_g(s, q, 0), seg_g(s, q, 1));
    }
    for (int it = 0; it < 48; ++it) {
        double m1 = hi - 0.618033988749895 * (hi - lo), m2 = lo + 0.618033988749895 * (hi - lo);
        double e1 = seg_g(s, q, m1), e2 = seg_g(s, q, m2);
        best = fmin(best, fmin(e1, e2));
        if (e1 < e2)
            hi = m2;
        else
            lo = m1;
    }
    return best;
}

/* The sweep's field: negative inside some sphere of it. Away from every segment's reach, the
 * distance to the nearest reach (a lower bound of the field, so that cells can be skipped). */
static double sweep_field(void *user, const double q[3])
{
    const sweep_data *d = user;
    double best = INFINITY, away = INFINITY;
    for (int i = 0; i < d->n; ++i) {
        const sweep_seg *s = &d->s[i];
        double e2 = 0;
        for (int k = 0; k < 3; ++k) {
            double e = fmax(s->lo[k] - q[k], q[k] - s->hi[k]);
            if (e > 0)
                e2 += e * e;
        }
        if (e2 > 0)
            away = fmin(away, sqrt(e2));
        else
            best = fmin(best, seg_min(s, q));
    }
    return best < INFINITY ? best : away;
}

static int sweep_inside(const void *data, const double q[3]) { return sweep_field((void *)data, q) < 0; }

static void sweep_destroy(void *data)
{
    sweep_data *d = data;
    free(d->s);
    free(d);
}

static const pov_solid_fn sweep_fn = {sweep_inside, sweep_destroy, NULL};

typedef struct sweep_shape {
    pov_mods mods;
    int type, n;
    double (*sph)[4];
    double dummy;
} sweep_shape;

static const pov_row sweep_rows[] = {{"tolerance", pov_item_float, offsetof(sweep_shape, dummy)}, {NULL, NULL, 0}};
POV_SHAPE_BLOCK(sweep_block, sweep_rows);

static void build_segment(sweep_seg *s, int type, double (*P)[4], int i)
{
    for (int k = 0; k < 4; ++k) {
        double *c = s->c[k];
        if (type == SW_LINEAR) {
            c[0] = 0, c[1] = 0, c[2] = P[i + 1][k] - P[i][k], c[3] = P[i][k];
            continue;
        }
        double p0 = P[i][k], p1 = P[i + 1][k], p2 = P[i + 2][k], p3 = P[i + 3][k];
        if (type == SW_CUBIC) { /* Catmull-Rom from p1 to p2 */
            c[0] = -0.5 * p0 + 1.5 * p1 - 1.5 * p2 + 0.5 * p3;
            c[1] = p0 - 2.5 * p1 + 2 * p2 - 0.5 * p3;
            c[2] = -0.5 * p0 + 0.5 * p2;
            c[3] = p1;
        } else { /* uniform cubic B-spline */
            c[0] = (-p0 + 3 * p1 - 3 * p2 + p3) / 6;
            c[1] = (3 * p0 - 6 * p1 + 3 * p2) / 6;
            c[2] = (-3 * p0 + 3 * p2) / 6;
            c[3] = (p0 + 4 * p1 + p2) / 6;
        }
    }
    s->convex = type == SW_LINEAR;
    for (int k = 0; k < 3; ++k) {
        s->lo[k] = INFINITY;
        s->hi[k] = -INFINITY;
    }
    for (int j = 0; j <= 64; ++j) { /* its reach (a cubic's bulge lies between its samples' within 1%) */
        double p[4];
        seg_at(s, j / 64.0, p);
        for (int k = 0; k < 3; ++k) {
            s->lo[k] = fmin(s->lo[k], p[k] - 1.01 * fabs(p[3]));
            s->hi[k] = fmax(s->hi[k], p[k] + 1.01 * fabs(p[3]));
        }
    }
}

static vbnl_result sweep_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    sweep_shape *ss = (sweep_shape *)mods;
    pov_loader *L = s->L;
    sweep_data *d = calloc(1, sizeof *d);
    int nseg = ss->type == SW_LINEAR ? ss->n - 1 : ss->n - 3;
    if (!d || !(d->s = calloc((size_t)nseg, sizeof *d->s))) {
        free(d);
        return pov_oom(L);
    }
    d->n = nseg;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, rmin = INFINITY;
    for (int i = 0; i < nseg; ++i) {
        build_segment(&d->s[i], ss->type, ss->sph, i);
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], d->s[i].lo[k]);
            hi[k] = fmax(hi[k], d->s[i].hi[k]);
        }
        for (int j = 0; j <= 16; ++j) {
            double p[4];
            seg_at(&d->s[i], j / 16.0, p);
            if (fabs(p[3]) > 0)
                rmin = fmin(rmin, fabs(p[3]));
        }
    }
    double ext = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    int depth = isfinite(rmin) ? (int)ceil(log2(ext / (0.5 * rmin))) : 6;
    depth = depth < 5 ? 5 : depth > 8 ? 8 : depth;
    pov_implicit im;
    memset(&im, 0, sizeof im);
    im.f = sweep_field;
    im.user = d;
    memcpy(im.lo, lo, sizeof lo);
    memcpy(im.hi, hi, sizeof hi);
    double r = pov_box_radius(lo, hi);
    im.depth = depth;
    im.lipschitz = 1.0; /* |grad (|p - c| - r)| = 1 */
    im.tol = POV_TESS_TOL * r;
    im.grad_step = 1e-6 * r;
    im.max_evals = 20000000;
    vbnl_result res = pov_shape_implicit(s, pr, &im, &sweep_fn, (void **)&d, lo, hi);
    if (d)
        sweep_destroy(d);
    return res;
}

vbnl_result pov_shape_sphere_sweep(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    sweep_shape ss;
    memset(&ss, 0, sizeof ss);
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (pov_is_word(t, "linear_spline"))
        ss.type = SW_LINEAR;
    else if (pov_is_word(t, "cubic_spline"))
        ss.type = SW_CUBIC;
    else if (pov_is_word(t, "b_spline"))
        ss.type = SW_BSPLINE;
    else
        return vbnl_sdl_error(p, &t->loc, "sphere_sweep: expected linear_spline, cubic_spline or b_spline");
    vbnl_sdl_next(p);
    pov_comma(L);
    double count;
    vbnl_sdl_loc at = vbnl_sdl_peek(p)->loc;
    if (pov_list_count(L, &count) != VBNL_OK)
        return VBNL_ERR_PARSE;
    int need = ss.type == SW_LINEAR ? 2 : 4;
    if (!(count >= need && count <= 1e6) || count != floor(count))
        return vbnl_sdl_error(p, &at, "sphere_sweep: needs a whole number of at least %d spheres, got %g", need, count);
    ss.n = (int)count;
    if (!(ss.sph = malloc(sizeof *ss.sph * (size_t)ss.n)))
        return pov_oom(L);
    vbnl_result r = VBNL_OK;
    for (int i = 0; i < ss.n && r == VBNL_OK; ++i) {
        pov_comma(L);
        if (pov_vec3(L, ss.sph[i]) != VBNL_OK || (pov_comma(L), pov_float(L, &ss.sph[i][3])) != VBNL_OK)
            r = VBNL_ERR_PARSE;
    }
    if (r == VBNL_OK)
        r = pov_shape_deferred(s, &sweep_block, &ss.mods, sweep_make);
    free(ss.sph);
    return r;
}
