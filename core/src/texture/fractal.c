/* The fractal patterns of POV-Ray 3.7 (reference manual, "Mandel", "Julia", "Magnet"): escape-time
 * iteration of z -> z^n + c in the x-y plane, or of the magnet formulas, coloured by POV-Ray's
 * exterior and interior types (pattern.cpp's fractal_exterior_color / fractal_interior_color). */
#include "texture.h"

static double exterior(const vbi_pattern *pt, int iters, double a, double b)
{
    const double f = pt->u.fractal.efactor;
    switch (pt->u.fractal.exterior) {
    case 0:
        return f;
    case 1:
        return (double)iters / (double)pt->u.fractal.iterations;
    case 2:
        return a * f;
    case 3:
        return b * f;
    case 4:
        return a * a * f;
    case 5:
        return b * b * f;
    case 6:
        return sqrt(a * a + b * b) * f;
    case 7: { /* 0 .. (n - 1) / n */
        unsigned n = (unsigned)f;
        return n ? (double)((unsigned)iters % n) / f : 0.0;
    }
    case 8: { /* 0 .. 1 */
        unsigned n = (unsigned)(1.0 + f);
        return n && f != 0.0 ? (double)((unsigned)iters % n) / f : 0.0;
    }
    default:
        return 0.0;
    }
}

static double interior(const vbi_pattern *pt, double a, double b, double mindist2)
{
    const double f = pt->u.fractal.ifactor;
    switch (pt->u.fractal.interior) {
    case 0:
        return f;
    case 1:
        return sqrt(mindist2) * f;
    case 2:
        return a * f;
    case 3:
        return b * f;
    case 4:
        return a * a * f;
    case 5:
        return b * b * f;
    case 6:
        return a * a + b * b * f; /* POV-Ray's precedence: only b^2 is scaled */
    default:
        return 0.0;
    }
}

/* (a + ib)^n for n >= 2 by the binomial expansion (the signs of i^k). */
static void complex_pow(double a, double b, int n, double *ra, double *rb)
{
    double re = 0.0, im = 0.0, binom = 1.0; /* C(n, k) */
    for (int k = 0; k <= n; ++k) {
        double term = binom * pow(a, n - k) * pow(b, k);
        switch (k & 3) {
        case 0: re += term; break;
        case 1: im += term; break;
        case 2: re -= term; break;
        default: im -= term; break;
        }
        binom = binom * (n - k) / (k + 1);
    }
    *ra = re;
    *rb = im;
}

/* z -> z^n + c from z0 = (x, y) (Julia: c fixed; Mandelbrot: c = z0), escaping beyond |z| = 2. */
static double escape(const vbi_pattern *pt, dvec3 p, int julia)
{
    const int n = pt->u.fractal.exponent, it_max = pt->u.fractal.iterations;
    const double cr = julia ? pt->u.fractal.cu : p.x, ci = julia ? pt->u.fractal.cv : p.y;
    double a = p.x, b = p.y, a2 = a * a, b2 = b * b, mind = a2 + b2;
    for (int col = 0; col < it_max; ++col) {
        switch (n) {
        case 2:
            b = 2.0 * a * b + ci;
            a = a2 - b2 + cr;
            break;
        case 3:
            b = 3.0 * a2 * b - b2 * b + ci;
            a = a2 * a - 3.0 * a * b2 + cr;
            break;
        case 4:
            b = 4.0 * (a2 * a * b - a * b2 * b) + ci;
            a = a2 * a2 - 6.0 * a2 * b2 + b2 * b2 + cr;
            break;
        default: {
            double na, nb;
            complex_pow(a, b, n, &na, &nb);
            a = na + cr;
            b = nb + ci;
            break;
        }
        }
        a2 = a * a;
        b2 = b * b;
        double d2 = a2 + b2;
        if (d2 < mind)
            mind = d2;
        if (d2 > 4.0)
            return exterior(pt, col, a, b);
    }
    return interior(pt, a, b, mind);
}

/* The magnet formulas: z -> ((z^2 + c - 1) / (2z + c - 2))^2 (type 1) or the cubic type 2, until
 * |z| > 100 or z is within 0.01 of 1. */
static double magnet(const vbi_pattern *pt, dvec3 p)
{
    const int julia = pt->u.fractal.julia, type2 = pt->u.fractal.magnet == 2, it_max = pt->u.fractal.iterations;
    const double cr = julia ? pt->u.fractal.cu : p.x, ci = julia ? pt->u.fractal.cv : p.y;
    double a = julia ? p.x : 0.0, b = julia ? p.y : 0.0, a2 = a * a, b2 = b * b;
    double mind = julia ? a2 + b2 : 10000.0;
    const double c1r = cr - 1.0, c2r = cr - 2.0, c1c2r = c1r * c2r - ci * ci, c1c2i = (c1r + c2r) * ci;
    for (int col = 0; col < it_max; ++col) {
        double t1r, t1i, t2r, t2i;
        if (!type2) {
            t1r = a2 - b2 + cr - 1.0;
            t1i = 2.0 * a * b + ci;
            t2r = 2.0 * a + cr - 2.0;
            t2i = 2.0 * b + ci;
        } else {
            t1r = a2 * a - 3.0 * a * b2 + 3.0 * (a * c1r - b * ci) + c1c2r;
            t1i = 3.0 * a2 * b - b2 * b + 3.0 * (a * ci + b * c1r) + c1c2i;
            t2r = 3.0 * (a2 - b2) + 3.0 * (a * c2r - b * ci) + c1c2r + 1.0;
            t2i = 6.0 * a * b + 3.0 * (a * ci + b * c2r) + c1c2i;
        }
        double den = t2r * t2r + t2i * t2i;
        a = (t1r * t2r + t1i * t2i) / den;
        b = (t1i * t2r - t1r * t2i) / den;
        double bb = b * b;
        b = 2.0 * a * b;
        a = a * a - bb;
        a2 = a * a;
        b2 = b * b;
        double d2 = a2 + b2;
        if (d2 < mind)
            mind = d2;
        double am1 = a - 1.0;
        if (d2 > 10000.0 || am1 * am1 + b2 < 1.0 / 10000.0)
            return exterior(pt, col, a, b);
    }
    return interior(pt, a, b, mind);
}

double vbi_pattern_fractal(const vbi_pattern *pt, dvec3 p)
{
    switch (pt->kind) {
    case VBNL_PATTERN_JULIA:
        return escape(pt, p, 1);
    case VBNL_PATTERN_MANDEL:
        return escape(pt, p, 0);
    case VBNL_PATTERN_MAGNET:
        return magnet(pt, p);
    default:
        return 0.0;
    }
}
