/* Pearson chi-square goodness-of-fit helpers for sampling tests (header-only, test code only).
 *
 * Usage: bin the samples, compute each bin's expected count by integrating the claimed pdf over
 * it, then call vbi_chi2_test(). Bins with small expected counts are pooled (Pearson's test
 * needs about 5 per bin), as in Mitsuba's ChiSquare class (Jakob 2010-2014). Samples in a bin
 * whose expected count is zero fail outright unless they are a vanishing fraction (1e-5) of the
 * total, which tolerates rounding at the edge of a pdf's support. */
#ifndef VBI_TEST_CHI2_H
#define VBI_TEST_CHI2_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Regularised upper incomplete gamma function Q(a, x) (Numerical Recipes 6.2: series below
 * a + 1, Lentz continued fraction above). The chi-square p-value is Q(dof / 2, chi2 / 2). */
static double vbi_chi2_gamma_q(double a, double x)
{
    if (x <= 0.0)
        return 1.0;
    double log_pref = -x + a * log(x) - lgamma(a);
    if (x < a + 1.0) {
        double ap = a, del = 1.0 / a, sum = del;
        for (int n = 0; n < 100000; ++n) {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if (fabs(del) < fabs(sum) * 1e-15)
                break;
        }
        return fmax(0.0, 1.0 - sum * exp(log_pref));
    }
    const double tiny = 1e-300;
    double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 100000; ++i) {
        double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (fabs(d) < tiny)
            d = tiny;
        c = b + an / c;
        if (fabs(c) < tiny)
            c = tiny;
        d = 1.0 / d;
        double del = d * c;
        h *= del;
        if (fabs(del - 1.0) < 1e-15)
            break;
    }
    return exp(log_pref) * h;
}

typedef struct vbi_chi2_result {
    double chi2;
    int dof;
    double p_value;  /* -1 when samples fell where none were expected */
    char msg[256];
} vbi_chi2_result;

typedef struct vbi_chi2_bin_ {
    double e;
    int i;
} vbi_chi2_bin_;

static int vbi_chi2_cmp_(const void *a, const void *b)
{
    double x = ((const vbi_chi2_bin_ *)a)->e, y = ((const vbi_chi2_bin_ *)b)->e;
    return (x > y) - (x < y);
}

/* Pearson's test of observed counts against expected counts (both over n bins, same total).
 * Returns 1 when the hypothesis survives at `significance` (e.g. 0.01), 0 otherwise; details
 * go to *res (may be NULL). */
static int vbi_chi2_test(const double *observed, const double *expected, int n,
                          double min_expected, double significance, vbi_chi2_result *res)
{
    vbi_chi2_result local;
    if (!res)
        res = &local;
    memset(res, 0, sizeof(*res));
    double total = 0.0;
    for (int i = 0; i < n; ++i)
        total += observed[i];
    /* Pool from the smallest expected count upward. */
    vbi_chi2_bin_ *idx = malloc(sizeof(*idx) * (size_t)n);
    for (int i = 0; i < n; ++i)
        idx[i] = (vbi_chi2_bin_){expected[i], i};
    qsort(idx, (size_t)n, sizeof(*idx), vbi_chi2_cmp_);

    double pooled_obs = 0.0, pooled_exp = 0.0, chi2 = 0.0;
    int cells = 0;
    for (int k = 0; k < n; ++k) {
        int i = idx[k].i;
        double o = observed[i], e = expected[i];
        if (e <= 0.0) {
            if (o > total * 1e-5) {
                snprintf(res->msg, sizeof(res->msg),
                         "%.0f samples in bin %d whose expected count is 0", o, i);
                res->p_value = -1.0;
                free(idx);
                return 0;
            }
            pooled_obs += o; /* stray rounding samples: keep them counted */
        } else if (e < min_expected || (pooled_exp > 0.0 && pooled_exp < min_expected)) {
            pooled_obs += o;
            pooled_exp += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            ++cells;
        }
    }
    free(idx);
    if (pooled_exp > 0.0) {
        chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        ++cells;
    }
    res->chi2 = chi2;
    res->dof = cells - 1;
    if (res->dof < 1) {
        snprintf(res->msg, sizeof(res->msg), "too few bins (%d) after pooling", cells);
        res->p_value = -1.0;
        return 0;
    }
    res->p_value = vbi_chi2_gamma_q(0.5 * res->dof, 0.5 * chi2);
    snprintf(res->msg, sizeof(res->msg), "chi2 = %.1f, dof = %d, p = %.4g", chi2, res->dof,
             res->p_value);
    return res->p_value >= significance;
}

/* A grid over the sphere of directions in a local frame (z = cos theta about some axis, phi in
 * [0, 2 pi)): nz x nphi bins covering z in [zmin, 1], plus one extra bin (index nz * nphi) for
 * z < zmin, so a pdf concentrated near the axis still gets fine bins. Bin areas are equal
 * solid angles because dw = dz dphi. */
typedef struct vbi_chi2_grid {
    int nz, nphi;
    double zmin;
} vbi_chi2_grid;

static inline int vbi_chi2_grid_bins(const vbi_chi2_grid *g) { return g->nz * g->nphi + 1; }

static inline int vbi_chi2_grid_bin(const vbi_chi2_grid *g, double z, double phi)
{
    if (z < g->zmin)
        return g->nz * g->nphi;
    const double two_pi = 6.283185307179586;
    phi = fmod(phi, two_pi);
    if (phi < 0.0)
        phi += two_pi;
    int iz = (int)((z - g->zmin) / (1.0 - g->zmin) * g->nz);
    int ip = (int)(phi / two_pi * g->nphi);
    iz = iz < 0 ? 0 : (iz >= g->nz ? g->nz - 1 : iz);
    ip = ip < 0 ? 0 : (ip >= g->nphi ? g->nphi - 1 : ip);
    return iz * g->nphi + ip;
}

/* Expected counts: `count` times the integral of pdf(ctx, z, phi) (a solid-angle density) over
 * each bin, by the midpoint rule on sub x sub points per bin. Midpoints keep the error small
 * for pdfs with discontinuities (light outlines); the extra bin uses a grid of the same density
 * in phi and 4 * sub rows in z. Returns the integral of the pdf over the whole sphere. */
static inline double vbi_chi2_grid_integrate(const vbi_chi2_grid *g, double (*pdf)(void *, double, double),
                                       void *ctx, int sub, double count, double *expected)
{
    const double two_pi = 6.283185307179586;
    double dz = (1.0 - g->zmin) / g->nz, dphi = two_pi / g->nphi;
    double total = 0.0;
    for (int iz = 0; iz < g->nz; ++iz)
        for (int ip = 0; ip < g->nphi; ++ip) {
            double sum = 0.0;
            for (int a = 0; a < sub; ++a)
                for (int b = 0; b < sub; ++b) {
                    double z = g->zmin + (iz + (a + 0.5) / sub) * dz;
                    double phi = (ip + (b + 0.5) / sub) * dphi;
                    sum += pdf(ctx, z, phi);
                }
            double integral = sum * dz * dphi / ((double)sub * sub);
            expected[iz * g->nphi + ip] = integral * count;
            total += integral;
        }
    double rest = 0.0;
    if (g->zmin > -1.0) {
        int nz = 4 * sub, np = g->nphi * sub;
        double rz = (g->zmin + 1.0) / nz, rp = two_pi / np;
        for (int a = 0; a < nz; ++a)
            for (int b = 0; b < np; ++b)
                rest += pdf(ctx, -1.0 + (a + 0.5) * rz, (b + 0.5) * rp);
        rest *= rz * rp;
    }
    expected[g->nz * g->nphi] = rest * count;
    return total + rest;
}

#endif
