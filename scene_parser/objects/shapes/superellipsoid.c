/* vbnl object layer: superellipsoid { <e, n> modifiers }
 *
 * POV-Ray 3.7's superellipsoid (super.cpp): the surface g(g(|x|, |y|, 2/e), |z|, 2/n) = 1 with
 * g(a, b, p) = (a^p + b^p)^(1/p), inside where it is below 1, in the box [-1, 1]^3. Made by dual
 * contouring (implicit.c; the near-box shapes of small exponents keep their edges) on a 32^3
 * grid refined to POV_TESS_TOL of its radius. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

typedef struct super_data {
    double pe, pn; /* 2/e and 2/n */
} super_data;

/* (a^p + b^p)^(1/p), evaluated from the larger of a and b (POV-Ray's stable form) */
static double norm_p(double a, double b, double p)
{
    double hi = fmax(a, b), lo = fmin(a, b);
    if (!(hi > 0))
        return 0;
    return hi * pow(1 + pow(lo / hi, p), 1 / p);
}

static double super_f(void *user, const double q[3])
{
    const super_data *d = user;
    return norm_p(norm_p(fabs(q[0]), fabs(q[1]), d->pe), fabs(q[2]), d->pn) - 1;
}

static int super_inside(const void *data, const double q[3]) { return super_f((void *)data, q) < 0; }

static const pov_solid_fn super_fn = {super_inside, free, NULL};

typedef struct super_shape {
    pov_mods mods;
    super_data *d;
} super_shape;

static const pov_row super_rows[] = {{NULL, NULL, 0}};
POV_SHAPE_BLOCK(super_block, super_rows);

static vbnl_result super_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    super_shape *ss = (super_shape *)mods;
    pov_implicit im;
    memset(&im, 0, sizeof im);
    im.f = super_f;
    im.user = ss->d;
    for (int k = 0; k < 3; ++k) {
        im.lo[k] = -1;
        im.hi[k] = 1;
    }
    double r = pov_box_radius(im.lo, im.hi);
    im.depth = 5;
    /* exponents 2/e, 2/n of at least 1 make the function a norm: |grad| <= 2 */
    im.lipschitz = ss->d->pe >= 1 && ss->d->pn >= 1 ? 2.0 : 0.0;
    im.tol = POV_TESS_TOL * r;
    im.grad_step = 1e-6 * r;
    return pov_shape_implicit(s, pr, &im, &super_fn, (void **)&ss->d, im.lo, im.hi);
}

vbnl_result pov_shape_superellipsoid(const pov_shape *s)
{
    pov_loader *L = s->L;
    double en[2];
    vbnl_sdl_loc at = vbnl_sdl_peek(L->c.parser)->loc;
    if (vbnl_sdl_parse_vector(L->c.parser, 2, en) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(en[0] > 0 && en[1] > 0))
        return vbnl_sdl_error(L->c.parser, &at, "superellipsoid: the exponents must be positive, got <%g, %g>", en[0],
                              en[1]);
    super_shape ss;
    memset(&ss, 0, sizeof ss);
    if (!(ss.d = malloc(sizeof *ss.d)))
        return pov_oom(L);
    ss.d->pe = 2 / en[0];
    ss.d->pn = 2 / en[1];
    vbnl_result r = pov_shape_deferred(s, &super_block, &ss.mods, super_make);
    free(ss.d);
    return r;
}
