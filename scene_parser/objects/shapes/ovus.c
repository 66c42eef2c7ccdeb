/* vbnl object layer: the egg and the lemon, surfaces of revolution of circle arcs (revolve.c).
 *
 * ovus { bottom_radius, top_radius }  (POV-Ray 3.7, ovus.cpp): a sphere of the bottom radius at
 * the origin and one of the top radius at <0, bottom_radius, 0>, joined by the arc of radius 2 *
 * the larger of the two tangent to both (its centre beyond the axis); a top radius of twice the
 * bottom one or more gives the top sphere alone, as in POV-Ray. Inside: inside either sphere or,
 * between the arc's ends, inside the arc's circle swept around y.
 *
 * lemon { <apex>, apex_radius, <base>, base_radius, inner_radius [open] }  (POV-Ray 3.8,
 * lemon.cpp): the arc of radius inner_radius (raised to the smallest that reaches both rims,
 * with a warning) from the base's rim to the apex's, its centre beyond the axis, swept around
 * the axis; flat caps close it unless open. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

#define PI 3.14159265358979323846

/* A profile of circle arcs: centre (cr, cy), radius, angles a0 to a1 per segment. */
typedef struct arcs {
    double c[3][5]; /* cr, cy, radius, a0, a1 */
    int n;
} arcs;

static void arc_eval(void *user, int seg, double t, double *r, double *y, double *dr, double *dy)
{
    const double *a = ((const arcs *)user)->c[seg];
    double ang = a[3] + (a[4] - a[3]) * t, s = a[4] > a[3] ? 1 : -1;
    *r = a[0] + a[2] * cos(ang);
    *y = a[1] + a[2] * sin(ang);
    *dr = -sin(ang) * s;
    *dy = cos(ang) * s;
    if (fabs(*r) < 1e-12 * a[2])
        *r = 0;
}

/* ---- ovus ------------------------------------------------------------------------------------- */

typedef struct ovus_data {
    double rb, rt, cr, cv, hp, bv, tv; /* radii, connecting radius, vertical and horizontal positions, limits */
} ovus_data;

static int ovus_inside(const void *data, const double q[3])
{
    const ovus_data *d = data;
    if (pov_dot3(q, q) < d->rb * d->rb)
        return 1;
    double o[3] = {q[0], q[1] - d->rb, q[2]};
    if (pov_dot3(o, o) < d->rt * d->rt)
        return 1;
    if (q[1] > d->bv && q[1] < d->tv) {
        double h = sqrt(q[0] * q[0] + q[2] * q[2]);
        return (h + d->hp) * (h + d->hp) + (q[1] - d->cv) * (q[1] - d->cv) < d->cr * d->cr;
    }
    return 0;
}

static const pov_solid_fn ovus_fn = {ovus_inside, free, NULL};

typedef struct ovus_shape {
    pov_mods mods;
    ovus_data d;
    double a[3], b[3], ra, rb, inner; /* lemon */
    int lemon, open;
} ovus_shape;

static vbnl_result ovus_open(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((ovus_shape *)it->target)->open = 1;
    return VBNL_OK;
}

static const pov_row ovus_rows[] = {{NULL, NULL, 0}};
static const pov_row lemon_rows[] = {{"open", ovus_open, 0}, {NULL, NULL, 0}};
POV_SHAPE_BLOCK(ovus_block, ovus_rows);
POV_SHAPE_BLOCK(lemon_block, lemon_rows);

static vbnl_result ovus_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    ovus_shape *os = (ovus_shape *)mods;
    ovus_data *d = &os->d;
    arcs ar;
    memset(&ar, 0, sizeof ar);
    /* bottom sphere from its pole, the joining arc (centre at -hp: beyond the axis), the top sphere */
    double ab = asin(fmax(-1, fmin(1, d->bv / d->rb))), at = asin(fmax(-1, fmin(1, (d->tv - d->rb) / d->rt)));
    double pb = atan2(d->bv - d->cv, sqrt(fmax(0, d->cr * d->cr - (d->bv - d->cv) * (d->bv - d->cv)))),
           pt = atan2(d->tv - d->cv, sqrt(fmax(0, d->cr * d->cr - (d->tv - d->cv) * (d->tv - d->cv))));
    double segs[3][5] = {{0, 0, d->rb, -PI / 2, ab}, {-d->hp, d->cv, d->cr, pb, pt}, {0, d->rb, d->rt, at, PI / 2}};
    memcpy(ar.c, segs, sizeof segs);
    ar.n = 3;
    double lo[3] = {-fmax(d->rb, d->rt) * 1.5, -d->rb, -fmax(d->rb, d->rt) * 1.5},
           hi[3] = {fmax(d->rb, d->rt) * 1.5, d->rb + d->rt, fmax(d->rb, d->rt) * 1.5};
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    pov_revolve(&sm, arc_eval, &ar, ar.n, POV_TESS_TOL * pov_box_radius(lo, hi), 0);
    ovus_data *copy = malloc(sizeof *copy);
    if (copy)
        *copy = *d;
    pov_solid *solid = copy ? pov_solid_custom(&ovus_fn, copy, lo, hi) : NULL;
    if (!solid) {
        pov_smesh_free(&sm);
        return pov_oom(s->L);
    }
    return pov_shape_set_mesh(s, pr, &sm, 1, solid);
}

/* ---- lemon -------------------------------------------------------------------------------------- */

typedef struct lemon_data {
    double hp, vp, r, rb, ra; /* arc centre (hp < 0), radius; rims; in the unit-height frame */
} lemon_data;

static int lemon_inside(const void *data, const double q[3])
{
    const lemon_data *d = data;
    if (!(q[1] >= 0 && q[1] <= 1))
        return 0;
    double h = sqrt(q[0] * q[0] + q[2] * q[2]);
    return (h - d->hp) * (h - d->hp) + (q[1] - d->vp) * (q[1] - d->vp) < d->r * d->r;
}

static const pov_solid_fn lemon_fn = {lemon_inside, free, NULL};

static vbnl_result lemon_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    ovus_shape *os = (ovus_shape *)mods;
    pov_loader *L = s->L;
    double axis[3] = {os->a[0] - os->b[0], os->a[1] - os->b[1], os->a[2] - os->b[2]}, len = pov_len3(axis);
    if (!(len > 0))
        return vbnl_sdl_error(L->c.parser, &s->loc, "lemon: the apex and the base coincide");
    /* POV-Ray 3.8's frame: base at height 0, apex at 1, radii divided by the length */
    double a = os->rb / len, b = os->ra / len, r = os->inner / len;
    double low = sqrt(a * a * a * a - 2 * a * a * (b * b - 1) + (b * b + 1) * (b * b + 1)) / 2;
    if (r < low) {
        vbnl_sdl_warning(L->c.parser, &s->loc, "lemon: inner radius %g is too small to join the rims; using %g",
                         os->inner, low * len);
        r = low;
    }
    double f = sqrt(fmax(0, -(a * a - 2 * a * b + b * b - 4 * r * r + 1) / (a * a - 2 * a * b + b * b + 1)));
    lemon_data *d = malloc(sizeof *d);
    if (!d)
        return pov_oom(L);
    d->hp = (a + b - f) / 2;
    d->vp = ((b - a) * f + 1) / 2;
    d->r = r;
    d->rb = a;
    d->ra = b;
    arcs ar;
    memset(&ar, 0, sizeof ar);
    double a0 = atan2(0 - d->vp, a - d->hp), a1 = atan2(1 - d->vp, b - d->hp);
    double seg[5] = {d->hp, d->vp, r, a0, a1};
    memcpy(ar.c[0], seg, sizeof seg);
    ar.n = 1;
    double m = fmax(r + d->hp, fmax(a, b));
    double lo[3] = {-m, 0, -m}, hi[3] = {m, 1, m};
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    pov_revolve(&sm, arc_eval, &ar, 1, POV_TESS_TOL * pov_box_radius(lo, hi), 0);
    if (!os->open) {
        if (a > 0)
            pov_revolve_cap(&sm, 0, 0, 0, -1);
        if (b > 0)
            pov_revolve_cap(&sm, 0, 1, 1, 1);
    }
    pov_solid *solid = pov_solid_custom(&lemon_fn, d, lo, hi);
    if (!solid) {
        pov_smesh_free(&sm);
        return pov_oom(L);
    }
    vbnl_result res = pov_shape_set_mesh(s, pr, &sm, 1, solid);
    /* the unit frame (y from the base to the apex) into the shape's space, before its transforms */
    double w[3] = {axis[0] / len, axis[1] / len, axis[2] / len}, u[3], v[3], t[3] = {1, 0, 0}, frame[16];
    if (fabs(w[0]) > 0.6)
        pov_set3(t, 0, 0, 1);
    pov_cross3(w, t, u);
    pov_scale3(u, 1 / pov_len3(u));
    pov_cross3(u, w, v);
    pov_m4_identity(frame);
    for (int k = 0; k < 3; ++k) {
        frame[4 * k] = u[k] * len;
        frame[4 * k + 1] = w[k] * len;
        frame[4 * k + 2] = v[k] * len;
        frame[4 * k + 3] = os->b[k];
    }
    pov_m4_mul(pr->m, frame, pr->m);
    return res;
}

vbnl_result pov_shape_ovus(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    ovus_shape os;
    memset(&os, 0, sizeof os);
    if (s->keyword[0] == 'l') {
        if (pov_vec3(L, os.a) != VBNL_OK || (pov_comma(L), pov_float(L, &os.ra)) != VBNL_OK ||
            (pov_comma(L), pov_vec3(L, os.b)) != VBNL_OK || (pov_comma(L), pov_float(L, &os.rb)) != VBNL_OK ||
            (pov_comma(L), pov_float(L, &os.inner)) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (os.ra < 0 || os.rb < 0 || os.inner < 0)
            return vbnl_sdl_error(p, &s->loc, "lemon: all radii must be positive");
        return pov_shape_deferred(s, &lemon_block, &os.mods, lemon_make);
    }
    ovus_data *d = &os.d;
    if (pov_float(L, &d->rb) != VBNL_OK || (pov_comma(L), pov_float(L, &d->rt)) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(d->rb > 0 && d->rt > 0))
        return vbnl_sdl_error(p, &s->loc, "ovus: both radii must be positive");
    if (d->rt >= 2 * d->rb) { /* POV-Ray substitutes the top sphere */
        vbnl_sdl_warning(p, &s->loc, "ovus: a top radius of twice the bottom one or more gives a sphere");
        double c[3] = {0, d->rb, 0};
        return pov_shape_add_analytic(s, POV_PRIM_SPHERE, c, d->rt);
    }
    /* POV-Ray's set-up (ovus.cpp): the joining arc's radius, centre and the heights it spans */
    if (d->rb > d->rt) {
        d->cr = 2 * d->rb;
        d->cv = 2 * d->rt - d->rb - d->rt * d->rt / (2 * d->rb);
        d->hp = sqrt(d->rb * d->rb - d->cv * d->cv);
        d->bv = -d->cv;
        d->tv = (d->rb - d->cv) * d->rt / (d->cr - d->rt) + d->rb;
    } else {
        d->cr = 2 * d->rt;
        d->cv = -2 * d->rt + d->rb + 1.5 * d->rt * d->rt / d->rb;
        d->hp = sqrt(d->rt * d->rt - (d->cv - d->rb) * (d->cv - d->rb));
        d->tv = 2 * d->rb - d->cv;
        d->bv = -d->cv * d->rb / (d->cr - d->rb);
    }
    return pov_shape_deferred(s, &ovus_block, &os.mods, ovus_make);
}
