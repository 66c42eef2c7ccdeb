/* vbnl object layer: julia_fractal { <c> [quaternion | hypercomplex]
 *     [sqr | cube | exp | ln | sin | asin | cos | acos | tan | atan | sinh | asinh | cosh | acosh |
 *      tanh | atanh | reciprocal | pwr(a, b)] [max_iteration n] [precision p] [slice <s>, d] }
 *
 * POV-Ray 3.7's 4D Julia sets (fractal.cpp, quatern.cpp, hcmplx.cpp): the point p of space is the
 * 4D point (x, y, z, w) of the slice s . (x, y, z, w) = d (s made unit, default <0,0,0,1>, 0), the
 * iteration q <- f(q) + c starts there, and p is inside when |q|^2 stays at most the bailout
 * (quaternion: R^2 with R = min(2, 1 + |c|); hypercomplex: 16) through the first max_iteration
 * values (default 20). Quaternions support sqr and cube, as in POV-Ray; hypercomplex numbers
 * every function, applied to the two complex numbers of their duplex form.
 * The surface is made by dual contouring (implicit.c) of the field
 *     max over k < max_iteration of 2^-k log(|q_k|^2 / bailout),
 * negative exactly where POV-Ray's point is inside (each term is continuous, so their maximum
 * is), on a 64^3 grid over the bounding sphere's box, refined to POV_TESS_TOL of it. `precision`
 * sets POV-Ray's ray-marching step and changes nothing here. */
#include <complex.h>
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

enum { F_SQR = 0, F_CUBE, F_RECIPROCAL, F_EXP, F_LN, F_SIN, F_ASIN, F_COS, F_ACOS, F_TAN, F_ATAN, F_SINH, F_ASINH,
       F_COSH, F_ACOSH, F_TANH, F_ATANH, F_PWR };

static const char *const fn_names[] = {"sqr", "cube", "reciprocal", "exp", "ln", "sin", "asin", "cos", "acos",
                                       "tan", "atan", "sinh", "asinh", "cosh", "acosh", "tanh", "atanh", "pwr"};

typedef struct julia_data {
    double c[4], slice[4], dist, exit_value, radius;
    int hyper, fn, iterations;
    double complex power;
} julia_data;

static double complex cfn(const julia_data *d, double complex z)
{
    switch (d->fn) {
    case F_SQR: return z * z;
    case F_CUBE: return z * z * z;
    case F_RECIPROCAL: return 1.0 / z;
    case F_EXP: return cexp(z);
    case F_LN: return clog(z);
    case F_SIN: return csin(z);
    case F_ASIN: return casin(z);
    case F_COS: return ccos(z);
    case F_ACOS: return cacos(z);
    case F_TAN: return ctan(z);
    case F_ATAN: return catan(z);
    case F_SINH: return csinh(z);
    case F_ASINH: return casinh(z);
    case F_COSH: return ccosh(z);
    case F_ACOSH: return cacosh(z);
    case F_TANH: return ctanh(z);
    case F_ATANH: return catanh(z);
    default: return cpow(z, d->power);
    }
}

/* One step q <- f(q) + c. */
static void step(const julia_data *d, double q[4])
{
    double x = q[0], y = q[1], z = q[2], w = q[3];
    if (!d->hyper) {
        if (d->fn == F_SQR) {
            double x2 = x * x, r = y * y + z * z + w * w;
            q[0] = x2 - r + d->c[0];
            q[1] = 2 * x * y + d->c[1];
            q[2] = 2 * x * z + d->c[2];
            q[3] = 2 * x * w + d->c[3];
        } else { /* cube */
            double x2 = x * x, r = y * y + z * z + w * w, t = 3 * x2 - r;
            q[0] = x * (x2 - 3 * r) + d->c[0];
            q[1] = y * t + d->c[1];
            q[2] = z * t + d->c[2];
            q[3] = w * t + d->c[3];
        }
        return;
    }
    /* hypercomplex: the duplex form (x - w) + i (y + z), (x + w) + i (y - z) */
    double complex a = cfn(d, (x - w) + I * (y + z)), b = cfn(d, (x + w) + I * (y - z));
    q[0] = 0.5 * (creal(a) + creal(b)) + d->c[0];
    q[1] = 0.5 * (cimag(a) + cimag(b)) + d->c[1];
    q[2] = 0.5 * (cimag(a) - cimag(b)) + d->c[2];
    q[3] = 0.5 * (creal(b) - creal(a)) + d->c[3];
}

static void start(const julia_data *d, const double p[3], double q[4])
{
    q[0] = p[0];
    q[1] = p[1];
    q[2] = p[2];
    q[3] = (d->dist - d->slice[0] * p[0] - d->slice[1] * p[1] - d->slice[2] * p[2]) / d->slice[3];
}

static double julia_field(void *user, const double p[3])
{
    const julia_data *d = user;
    double q[4], best = -INFINITY, weight = 1;
    start(d, p, q);
    for (int k = 0; k < d->iterations; ++k, weight *= 0.5) {
        double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
        if (!isfinite(n2) || n2 > 1e200)
            return fmax(best, 1.0); /* escaped for good: outside */
        best = fmax(best, weight * log(fmax(n2, 1e-300) / d->exit_value));
        step(d, q);
    }
    return best;
}

static int julia_inside(const void *data, const double q[3])
{
    const julia_data *d = data;
    double z[4];
    start(d, q, z);
    for (int k = 0; k < d->iterations; ++k) {
        if (!(z[0] * z[0] + z[1] * z[1] + z[2] * z[2] + z[3] * z[3] <= d->exit_value))
            return 0;
        step(d, z);
    }
    return 1;
}

static const pov_solid_fn julia_fn = {julia_inside, free, NULL};

typedef struct julia_shape {
    pov_mods mods;
    julia_data *d;
    double precision;
} julia_shape;

static vbnl_result julia_iterations(const pov_item *it)
{
    double n;
    vbnl_sdl_next(it->p);
    if (pov_float(it->ctx, &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(n >= 1 && n <= 1e6))
        return vbnl_sdl_error(it->p, &it->loc, "julia_fractal: max_iteration must be 1 to 1e6, got %g", n);
    ((julia_shape *)it->target)->d->iterations = (int)floor(n);
    return VBNL_OK;
}

static vbnl_result julia_slice(const pov_item *it)
{
    julia_data *d = ((julia_shape *)it->target)->d;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_vector(it->p, 4, d->slice) != VBNL_OK || (pov_comma(it->ctx), pov_float(it->ctx, &d->dist)) != VBNL_OK)
        return VBNL_ERR_PARSE;
    double l = sqrt(d->slice[0] * d->slice[0] + d->slice[1] * d->slice[1] + d->slice[2] * d->slice[2] + d->slice[3] * d->slice[3]);
    if (!(l > 1e-10))
        return vbnl_sdl_error(it->p, &it->loc, "julia_fractal: the slice vector is zero");
    if (!(fabs(d->slice[3]) > 1e-10))
        return vbnl_sdl_error(it->p, &it->loc, "julia_fractal: the slice's t component is zero");
    for (int k = 0; k < 4; ++k)
        d->slice[k] /= l;
    return VBNL_OK;
}

static vbnl_result julia_algebra(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((julia_shape *)it->target)->d->hyper = it->arg;
    return VBNL_OK;
}

static vbnl_result julia_function(const pov_item *it)
{
    julia_data *d = ((julia_shape *)it->target)->d;
    vbnl_sdl_next(it->p);
    d->fn = (int)it->arg;
    if (d->fn == F_PWR) {
        double a, b;
        if (vbnl_sdl_expect(it->p, '(', "after 'pwr'") != VBNL_OK || pov_float(it->ctx, &a) != VBNL_OK ||
            (pov_comma(it->ctx), pov_float(it->ctx, &b)) != VBNL_OK || vbnl_sdl_expect(it->p, ')', "after pwr's exponent") != VBNL_OK)
            return VBNL_ERR_PARSE;
        d->power = a + I * b;
    }
    return VBNL_OK;
}

static const pov_row julia_rows[] = {
    {"max_iteration", julia_iterations, 0},
    {"precision", pov_item_float, offsetof(julia_shape, precision)},
    {"slice", julia_slice, 0},
    {"quaternion", julia_algebra, 0},
    {"hypercomplex", julia_algebra, 1},
    {"sqr", julia_function, F_SQR},
    {"cube", julia_function, F_CUBE},
    {"reciprocal", julia_function, F_RECIPROCAL},
    {"exp", julia_function, F_EXP},
    {"ln", julia_function, F_LN},
    {"sin", julia_function, F_SIN},
    {"asin", julia_function, F_ASIN},
    {"cos", julia_function, F_COS},
    {"acos", julia_function, F_ACOS},
    {"tan", julia_function, F_TAN},
    {"atan", julia_function, F_ATAN},
    {"sinh", julia_function, F_SINH},
    {"asinh", julia_function, F_ASINH},
    {"cosh", julia_function, F_COSH},
    {"acosh", julia_function, F_ACOSH},
    {"tanh", julia_function, F_TANH},
    {"atanh", julia_function, F_ATANH},
    {"pwr", julia_function, F_PWR},
    {NULL, NULL, 0},
};
POV_SHAPE_BLOCK(julia_block, julia_rows);

static vbnl_result julia_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    julia_shape *js = (julia_shape *)mods;
    julia_data *d = js->d;
    pov_loader *L = s->L;
    if (!d->hyper && d->fn != F_SQR && d->fn != F_CUBE)
        return vbnl_sdl_error(L->c.parser, &s->loc, "julia_fractal: quaternions support sqr and cube only, not %s",
                              fn_names[d->fn]);
    if (d->hyper) {
        d->radius = 4;
        d->exit_value = 16;
    } else {
        double cl = sqrt(d->c[0] * d->c[0] + d->c[1] * d->c[1] + d->c[2] * d->c[2] + d->c[3] * d->c[3]);
        d->radius = fmin(2.0, 1 + cl + 1e-7);
        d->exit_value = d->radius * d->radius + 1e-7;
    }
    pov_implicit im;
    memset(&im, 0, sizeof im);
    im.f = julia_field;
    im.user = d;
    for (int k = 0; k < 3; ++k) {
        im.lo[k] = -d->radius;
        im.hi[k] = d->radius;
    }
    double r = pov_box_radius(im.lo, im.hi);
    im.depth = 7;
    im.refine_depth = 1;
    im.tol = POV_TESS_TOL * r;
    im.grad_step = 1e-6 * r;
    im.max_evals = 60000000;
    return pov_shape_implicit(s, pr, &im, &julia_fn, (void **)&js->d, im.lo, im.hi);
}

vbnl_result pov_shape_julia(const pov_shape *s)
{
    pov_loader *L = s->L;
    julia_shape js;
    memset(&js, 0, sizeof js);
    if (!(js.d = calloc(1, sizeof *js.d)))
        return pov_oom(L);
    js.d->iterations = 20; /* POV-Ray's defaults */
    js.d->slice[3] = 1;
    if (vbnl_sdl_parse_vector(L->c.parser, 4, js.d->c) != VBNL_OK) {
        free(js.d);
        return VBNL_ERR_PARSE;
    }
    vbnl_result r = pov_shape_deferred(s, &julia_block, &js.mods, julia_make);
    free(js.d);
    return r;
}
