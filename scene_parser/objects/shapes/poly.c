/* vbnl object layer: the polynomial shapes, all P(x, y, z) = 0 with P < 0 inside (POV-Ray's
 * convention):
 *   quadric { <A,B,C>, <D,E,F>, <G,H,I>, J }   A x2 + B y2 + C z2 + D xy + E xz + F yz + G x + H y + I z + J
 *   poly { order, <c1, ..., cm> }              order 2..35, terms in POV-Ray's order (below)
 *   cubic { <c1, ..., c20> }  quartic { <c1, ..., c35> }    poly of order 3 and 4
 *   polynomial { order, xyz(i, j, k): c, ... } the terms by their powers
 * POV-Ray's term order: the x power falls from the order to 0, within it the y power, within that
 * the z power (a quartic runs x4, x3y, x3z, x3, x2y2, x2yz, x2y, x2z2, ..., z, 1).
 *
 * These shapes are unbounded, as in POV-Ray: the surface is made where a CSG, clipped_by or
 * bounded_by (which clips here, as it does in POV-Ray when the bound is smaller than the
 * shape) bounds it, else within the scene's bounds. The part of that box where the polynomial
 * may vanish is found by interval arithmetic on an octree, then polygonised there (implicit.c).
 * A quadric's inside has exact bounds (an ellipsoid's box, an infinite cylinder's two finite
 * axes), which bound the CSGs it is part of. `sturm` is accepted (roots are found by other
 * means). */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"
#include "sdl_internal.h"

#define POLY_MAX_ORDER 35

typedef struct poly_term {
    double c;
    int e[3];
} poly_term;

typedef struct poly_data {
    int order;
    poly_term *t;
    int nt;
} poly_data;

static double poly_eval(void *user, const double p[3])
{
    const poly_data *d = user;
    double pw[3][POLY_MAX_ORDER + 1];
    for (int k = 0; k < 3; ++k) {
        pw[k][0] = 1;
        for (int e = 1; e <= d->order; ++e)
            pw[k][e] = pw[k][e - 1] * p[k];
    }
    double s = 0;
    for (int i = 0; i < d->nt; ++i)
        s += d->t[i].c * pw[0][d->t[i].e[0]] * pw[1][d->t[i].e[1]] * pw[2][d->t[i].e[2]];
    return s;
}

/* [lo, hi]^e for every e up to the order, from the powers of the ends. */
static void ipow_all(double lo, double hi, int order, double *a, double *b)
{
    double pl = 1, ph = 1;
    a[0] = b[0] = 1;
    for (int e = 1; e <= order; ++e) {
        pl *= lo;
        ph *= hi;
        if (e % 2 == 1 || lo >= 0 || hi <= 0) { /* monotonic over the interval */
            a[e] = pl < ph ? pl : ph;
            b[e] = pl < ph ? ph : pl;
        } else { /* an even power over an interval holding 0 */
            a[e] = 0;
            b[e] = pl > ph ? pl : ph;
        }
    }
}

static void imul(double a0, double a1, double b0, double b1, double *c0, double *c1)
{
    double p0 = a0 * b0, p1 = a0 * b1, p2 = a1 * b0, p3 = a1 * b1;
    double lo = p0 < p1 ? p0 : p1, hi = p0 < p1 ? p1 : p0;
    lo = p2 < lo ? p2 : lo;
    hi = p2 > hi ? p2 : hi;
    *c0 = p3 < lo ? p3 : lo;
    *c1 = p3 > hi ? p3 : hi;
}

static int poly_excludes(void *user, const double lo[3], const double hi[3])
{
    const poly_data *d = user;
    double pl[3][POLY_MAX_ORDER + 1], ph[3][POLY_MAX_ORDER + 1];
    for (int k = 0; k < 3; ++k)
        ipow_all(lo[k], hi[k], d->order, pl[k], ph[k]);
    double s0 = 0, s1 = 0;
    for (int i = 0; i < d->nt; ++i) {
        const int *e = d->t[i].e;
        double a, b, c = d->t[i].c;
        imul(pl[0][e[0]], ph[0][e[0]], pl[1][e[1]], ph[1][e[1]], &a, &b);
        imul(a, b, pl[2][e[2]], ph[2][e[2]], &a, &b);
        s0 += c >= 0 ? c * a : c * b;
        s1 += c >= 0 ? c * b : c * a;
    }
    return s0 > 0 || s1 < 0;
}

static int poly_inside(const void *data, const double q[3]) { return poly_eval((void *)data, q) < 0; }

static void poly_destroy(void *data)
{
    poly_data *d = data;
    free(d->t);
    free(d);
}

static pov_mesh *poly_surface(const void *data, const double lo[3], const double hi[3], const char **why)
{
    pov_implicit im;
    memset(&im, 0, sizeof im);
    im.f = poly_eval;
    im.user = (void *)data;
    im.excludes = poly_excludes;
    memcpy(im.lo, lo, sizeof im.lo);
    memcpy(im.hi, hi, sizeof im.hi);
    im.max_evals = 50000000;
    double tlo[3], thi[3];
    if (!pov_implicit_bounds(&im, 7, tlo, thi))
        return pov_mesh_new(); /* no surface in the box */
    memcpy(im.lo, tlo, sizeof im.lo);
    memcpy(im.hi, thi, sizeof im.hi);
    double r = pov_box_radius(tlo, thi);
    im.depth = 6;
    im.tol = POV_TESS_TOL * r;
    im.grad_step = 1e-6 * r;
    return pov_implicit_mesh(&im, why);
}

static const pov_solid_fn poly_fn = {poly_inside, poly_destroy, poly_surface};

/* ---- a quadric's inside: exact bounds ------------------------------------------------------------ */

/* The bounds of { x^T A x + b.x + c < 0 }: finite along the axes where the quadric closes
 * (ellipsoids, the cross-section of elliptic cylinders), infinite elsewhere. 0: empty. */
static int quadric_region(const double A[3][3], const double b[3], double c, double lo[3], double hi[3])
{
    double a[3][3], w[3], V[3][3], wmax = 0;
    memcpy(a, A, sizeof a);
    pov_sym_eigen3(a, w, V);
    for (int k = 0; k < 3; ++k) {
        lo[k] = -INFINITY;
        hi[k] = INFINITY;
        wmax = fmax(wmax, fabs(w[k]));
    }
    if (!(wmax > 0))
        return 1; /* a plane's half-space (or all space) */
    double beta[3], y0[3] = {0, 0, 0}, K = -c;
    int free_dir[3];
    for (int k = 0; k < 3; ++k) {
        beta[k] = V[0][k] * b[0] + V[1][k] * b[1] + V[2][k] * b[2];
        if (w[k] < -1e-12 * wmax)
            return 1; /* a hyperboloid or cone: unbounded */
        free_dir[k] = w[k] <= 1e-12 * wmax;
        if (free_dir[k]) {
            if (fabs(beta[k]) > 1e-12 * wmax)
                return 1; /* a paraboloid: unbounded */
            continue;
        }
        y0[k] = -beta[k] / (2 * w[k]);
        K += w[k] * y0[k] * y0[k];
    }
    if (!(K > 0))
        return 0;
    for (int i = 0; i < 3; ++i) {
        double x0 = 0, e2 = 0;
        int unb = 0;
        for (int k = 0; k < 3; ++k) {
            x0 += V[i][k] * y0[k];
            if (free_dir[k])
                unb |= fabs(V[i][k]) > 1e-9;
            else
                e2 += V[i][k] * V[i][k] / w[k];
        }
        if (!unb) {
            double e = sqrt(K * e2);
            lo[i] = x0 - e;
            hi[i] = x0 + e;
        }
    }
    return 1;
}

/* ---- parsing --------------------------------------------------------------------------------- */

typedef struct poly_shape {
    pov_mods mods;
    poly_data *d;
    double lo[3], hi[3]; /* the inside's bounds */
    int empty;
} poly_shape;

/* bounded_by { shapes }: the bound clips the unbounded shape (its shapes join clipped_by's) */
static vbnl_result poly_bounded_by(const pov_item *it)
{
    poly_shape *ps = it->target;
    vbnl_sdl_next(it->p);
    if (!ps->mods.clip.n)
        ps->mods.clip_loc = it->loc;
    return pov_clip_block(it->ctx, &ps->mods.clip);
}

static const pov_row poly_rows[] = {
    {"bounded_by", poly_bounded_by, 0},
    {NULL, NULL, 0},
};
POV_SHAPE_BLOCK(poly_block, poly_rows);

static vbnl_result poly_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    poly_shape *ps = (poly_shape *)mods;
    pr->kind = POV_PRIM_SURFACE;
    pr->mesh = NULL;
    if (ps->empty) {
        vbnl_sdl_warning(s->L->c.parser, &s->loc, "%s: the polynomial is positive everywhere: the shape is empty",
                         s->keyword);
        pr->kind = POV_PRIM_MESH;
        return (pr->mesh = pov_mesh_new()) ? VBNL_OK : pov_oom(s->L);
    }
    if (!(pr->solid = pov_solid_custom(&poly_fn, ps->d, ps->lo, ps->hi))) {
        ps->d = NULL;
        return pov_oom(s->L);
    }
    ps->d = NULL;
    return VBNL_OK;
}

/* POV-Ray's index of the term x^i y^j z^k in a polynomial of the given order. */
static int term_index(int order, int i, int j, int k)
{
    int idx = 0;
    for (int a = order; a >= 0; --a)
        for (int b = order - a; b >= 0; --b)
            for (int c = order - a - b; c >= 0; --c, ++idx)
                if (a == i && b == j && c == k)
                    return idx;
    return -1;
}

static int term_count(int order) { return (order + 1) * (order + 2) * (order + 3) / 6; }

/* Keeps the non-zero coefficients (all of them in POV-Ray's order). */
static vbnl_result poly_terms(pov_loader *L, poly_data *d, const double *coef)
{
    int n = term_count(d->order), idx = 0;
    d->t = malloc(sizeof *d->t * (size_t)n);
    if (!d->t)
        return pov_oom(L);
    for (int a = d->order; a >= 0; --a)
        for (int b = d->order - a; b >= 0; --b)
            for (int c = d->order - a - b; c >= 0; --c, ++idx)
                if (coef[idx] != 0) {
                    poly_term *t = &d->t[d->nt++];
                    t->c = coef[idx];
                    t->e[0] = a;
                    t->e[1] = b;
                    t->e[2] = c;
                }
    return VBNL_OK;
}

/* `<c1, ..., cn>` */
static vbnl_result coeff_list(pov_loader *L, const char *what, int n, double *coef)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '<', "to start the coefficients") != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_result r = VBNL_OK;
    p->in_vector++; /* '>' ends the list */
    for (int i = 0; i < n && r == VBNL_OK; ++i) {
        if (i)
            pov_comma(L);
        if (pov_is_punct(vbnl_sdl_peek(p), '>'))
            r = vbnl_sdl_error(p, NULL, "%s: %d coefficients given, %d needed", what, i, n);
        else
            r = pov_float(L, &coef[i]);
    }
    p->in_vector--;
    if (r == VBNL_OK)
        r = vbnl_sdl_expect(p, '>', "after the coefficients");
    return r;
}

vbnl_result pov_shape_poly(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    const char *w = s->keyword;
    poly_shape ps;
    memset(&ps, 0, sizeof ps);
    ps.d = calloc(1, sizeof *ps.d);
    double *coef = NULL;
    vbnl_result r = VBNL_OK;
    if (!ps.d)
        return pov_oom(L);
    for (int k = 0; k < 3; ++k) {
        ps.lo[k] = -INFINITY;
        ps.hi[k] = INFINITY;
    }
    if (!strcmp(w, "quadric")) {
        double sq[3], mx[3], ln[3], c;
        if (pov_vec3(L, sq) != VBNL_OK || (pov_comma(L), pov_vec3(L, mx)) != VBNL_OK ||
            (pov_comma(L), pov_vec3(L, ln)) != VBNL_OK || (pov_comma(L), pov_float(L, &c)) != VBNL_OK) {
            r = VBNL_ERR_PARSE;
            goto done;
        }
        ps.d->order = 2;
        double co[10] = {sq[0], mx[0], mx[1], ln[0], sq[1], mx[2], ln[1], sq[2], ln[2], c};
        double A[3][3] = {{sq[0], mx[0] / 2, mx[1] / 2}, {mx[0] / 2, sq[1], mx[2] / 2}, {mx[1] / 2, mx[2] / 2, sq[2]}};
        ps.empty = !quadric_region(A, ln, c, ps.lo, ps.hi);
        r = poly_terms(L, ps.d, co);
    } else if (!strcmp(w, "polynomial")) {
        double order;
        if (pov_float(L, &order) != VBNL_OK) {
            r = VBNL_ERR_PARSE;
            goto done;
        }
        pov_comma(L);
        if (!(order >= 2 && order <= POLY_MAX_ORDER)) {
            r = vbnl_sdl_error(p, &s->loc, "polynomial: the order must be 2 to %d, got %g", POLY_MAX_ORDER, order);
            goto done;
        }
        ps.d->order = (int)order;
        if (!(coef = calloc((size_t)term_count(ps.d->order), sizeof *coef))) {
            r = pov_oom(L);
            goto done;
        }
        while (pov_is_word(vbnl_sdl_peek(p), "xyz") && r == VBNL_OK) {
            double e[3], v;
            vbnl_sdl_loc at = vbnl_sdl_next(p)->loc;
            if (vbnl_sdl_expect(p, '(', "after 'xyz'") != VBNL_OK || pov_float(L, &e[0]) != VBNL_OK ||
                (pov_comma(L), pov_float(L, &e[1])) != VBNL_OK || (pov_comma(L), pov_float(L, &e[2])) != VBNL_OK ||
                vbnl_sdl_expect(p, ')', "after the powers") != VBNL_OK ||
                vbnl_sdl_expect(p, ':', "after 'xyz(...)'") != VBNL_OK || pov_float(L, &v) != VBNL_OK) {
                r = VBNL_ERR_PARSE;
                break;
            }
            int idx = e[0] >= 0 && e[1] >= 0 && e[2] >= 0 && e[0] + e[1] + e[2] <= ps.d->order
                          ? term_index(ps.d->order, (int)e[0], (int)e[1], (int)e[2])
                          : -1;
            if (idx < 0) {
                r = vbnl_sdl_error(p, &at, "polynomial: xyz(%g, %g, %g) is not a term of order %d", e[0], e[1], e[2],
                                   ps.d->order);
                break;
            }
            coef[idx] = v;
            pov_comma(L);
        }
        if (r == VBNL_OK)
            r = poly_terms(L, ps.d, coef);
    } else {
        double order = w[0] == 'c' ? 3 : w[0] == 'q' ? 4 : 0;
        if (order == 0) {
            if (pov_list_count(L, &order) != VBNL_OK) { /* `poly { 4 <...> }`: the '<' starts the list */
                r = VBNL_ERR_PARSE;
                goto done;
            }
            pov_comma(L);
            if (!(order >= 2 && order <= POLY_MAX_ORDER)) {
                r = vbnl_sdl_error(p, &s->loc, "poly: the order must be 2 to %d, got %g", POLY_MAX_ORDER, order);
                goto done;
            }
        }
        ps.d->order = (int)order;
        int n = term_count(ps.d->order);
        if (!(coef = calloc((size_t)n, sizeof *coef))) {
            r = pov_oom(L);
            goto done;
        }
        if ((r = coeff_list(L, w, n, coef)) == VBNL_OK)
            r = poly_terms(L, ps.d, coef);
    }
    if (r == VBNL_OK)
        r = pov_shape_deferred(s, &poly_block, &ps.mods, poly_make);
done:
    free(coef);
    if (ps.d)
        poly_destroy(ps.d);
    return r;
}
