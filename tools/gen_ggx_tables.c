/* Generates core/src/ggx_tables.c: directional-albedo tables of the GGX lobes used by bsdf.c for
 * Kulla-Conty energy compensation (Kulla & Conty 2017, "Revisiting Physically Based Shading at
 * Imageworks", SIGGRAPH course notes, Section "Energy compensation").
 *
 * Build and run from the repository root:
 *   gcc -std=gnu11 -O2 -Wall -Wextra -I core/src tools/gen_ggx_tables.c -lm -o /tmp/gen_ggx_tables
 *   /tmp/gen_ggx_tables > core/src/ggx_tables.c
 *
 * Method: for each table entry, E(mu) = int f(wo, wi) cos theta_i dwi is integrated by sampling
 * visible normals (Heitz 2018) on a deterministic stratified n x n grid of midpoints of [0,1)^2;
 * with that strategy the integrand is F(wo.h) G2(wo, wi) / G1(wo) (zero when wi is below the
 * horizon), which is smooth, so the midpoint rule converges fast. No random numbers: the output
 * is bit-for-bit reproducible. A summary of the measured accuracy (interpolation error at cell
 * centres, quadrature error against a 4x finer grid) goes to stderr and into the header comment.
 *
 * The GGX model comes from core/src/microfacet.h, the same code bsdf.c evaluates at run time. */
#include <stdio.h>
#include <stdlib.h>

#include "microfacet.h"

#define N_QUAD 128 /* stratified grid per table entry */

/* E(mu, alpha) of the GGX reflection lobe; ior <= 0 selects the white conductor (F = 1),
 * otherwise dielectric Fresnel reflection from outside an interface of that ior. */
static double albedo(float mu, float alpha, float ior, int n)
{
    vec3 wo = v3(sqrtf(fmaxf(0.0f, 1.0f - mu * mu)), 0.0f, mu);
    float g1o = ggx_g1(wo, alpha);
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            vec2 u = {((float)i + 0.5f) / (float)n, ((float)j + 0.5f) / (float)n};
            vec3 h = ggx_sample_vndf(wo, alpha, u);
            vec3 wi = reflect_about(wo, h);
            if (wi.z <= 0.0f)
                continue;
            float f = ior > 0.0f ? fresnel_dielectric_inline(v3_dot(wo, h), ior) : 1.0f;
            sum += (double)(f * ggx_g2(wo, wi, alpha) / g1o);
        }
    }
    return sum / ((double)n * n);
}

/* 2 int_0^1 E(mu) mu dmu of the interpolant through the row, which is linear in t = sqrt(mu) on
 * each segment (grid t_i = i / (N - 1)): with mu = t^2 the integral is 4 int_0^1 E(t) t^3 dt, a
 * quartic per segment, which 3-point Gauss-Legendre integrates exactly. */
static double row_average(const float *row)
{
    static const double gx[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
    static const double gw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    double h = 1.0 / (VBI_GGX_N_MU - 1), sum = 0.0;
    for (int i = 0; i + 1 < VBI_GGX_N_MU; ++i) {
        for (int q = 0; q < 3; ++q) {
            double f = 0.5 * (1.0 + gx[q]), t = (i + f) * h;
            double e = row[i] * (1.0 - f) + row[i + 1] * f;
            sum += 0.5 * h * gw[q] * e * t * t * t;
        }
    }
    return 4.0 * sum;
}

static float conductor_E[VBI_GGX_N_ALPHA][VBI_GGX_N_MU];
static float conductor_Eavg[VBI_GGX_N_ALPHA];
static float coat_E[VBI_GGX_N_IOR][VBI_GGX_N_ALPHA][VBI_GGX_N_MU];
static float coat_Eavg[VBI_GGX_N_IOR][VBI_GGX_N_ALPHA];

/* Multilinear interpolation of the freshly computed tables at fractional coordinates. */
static float interp2(const float t[VBI_GGX_N_ALPHA][VBI_GGX_N_MU], float xa, float xm)
{
    int ia = (int)xa, im = (int)xm;
    if (ia > VBI_GGX_N_ALPHA - 2)
        ia = VBI_GGX_N_ALPHA - 2;
    if (im > VBI_GGX_N_MU - 2)
        im = VBI_GGX_N_MU - 2;
    float fa = xa - (float)ia, fm = xm - (float)im;
    float a = t[ia][im] * (1 - fm) + t[ia][im + 1] * fm;
    float b = t[ia + 1][im] * (1 - fm) + t[ia + 1][im + 1] * fm;
    return a * (1 - fa) + b * fa;
}

/* Prints n values as rows of `row` values, each row in its own braces (or no inner braces when
 * row == n), so that the multi-dimensional initialisers are fully braced. */
static void print_array(const char *decl, const float *v, int n, int row, int rows_per_block)
{
    printf("%s = {\n", decl);
    for (int i = 0; i < n; i += row) {
        int block_start = rows_per_block > 0 && (i / row) % rows_per_block == 0;
        int block_end = rows_per_block > 0 && (i / row) % rows_per_block == rows_per_block - 1;
        if (block_start)
            printf("    {\n");
        printf(row < n ? "    {" : "   ");
        for (int j = 0; j < row; ++j)
            printf("%s%#.8gf,", j % 6 == 0 && j > 0 ? "\n     " : " ", (double)v[i + j]);
        printf(row < n ? " },\n" : "\n");
        if (block_end)
            printf("    },\n");
    }
    printf("};\n\n");
}

int main(void)
{
    /* Tables. */
    for (int a = 0; a < VBI_GGX_N_ALPHA; ++a) {
        float alpha = ggx_table_alpha_at((float)a);
        for (int m = 0; m < VBI_GGX_N_MU; ++m)
            conductor_E[a][m] = (float)albedo(ggx_table_mu_at((float)m), alpha, 0.0f, N_QUAD);
        conductor_Eavg[a] = (float)row_average(conductor_E[a]);
    }
    for (int k = 0; k < VBI_GGX_N_IOR; ++k) {
        float ior = ggx_table_ior_at((float)k);
        for (int a = 0; a < VBI_GGX_N_ALPHA; ++a) {
            float alpha = ggx_table_alpha_at((float)a);
            for (int m = 0; m < VBI_GGX_N_MU; ++m)
                coat_E[k][a][m] = (float)albedo(ggx_table_mu_at((float)m), alpha, ior, N_QUAD);
            coat_Eavg[k][a] = (float)row_average(coat_E[k][a]);
        }
    }

    /* Accuracy: interpolation error at cell centres (the worst place for linear interpolation),
     * reference integrated with the same quadrature. */
    double cond_err = 0.0, coat_err = 0.0, coat_err_ior = 0.0, cond_err_hi = 0.0, coat_err_hi = 0.0;
    for (int a = 0; a + 1 < VBI_GGX_N_ALPHA; ++a) {
        for (int m = 0; m + 1 < VBI_GGX_N_MU; ++m) {
            float xa = (float)a + 0.5f, xm = (float)m + 0.5f;
            double ref = albedo(ggx_table_mu_at(xm), ggx_table_alpha_at(xa), 0.0f, N_QUAD / 2);
            double e = fabs(ref - interp2(conductor_E, xa, xm));
            cond_err = e > cond_err ? e : cond_err;
            if (ggx_table_mu_at(xm) >= 0.1f)
                cond_err_hi = e > cond_err_hi ? e : cond_err_hi;
        }
    }
    for (int k = 0; k + 1 < VBI_GGX_N_IOR; ++k) {
        float xk = (float)k + 0.5f, ior = ggx_table_ior_at(xk);
        for (int a = 0; a + 1 < VBI_GGX_N_ALPHA; a += 2) {
            for (int m = 0; m + 1 < VBI_GGX_N_MU; m += 2) {
                float xa = (float)a + 0.5f, xm = (float)m + 0.5f;
                double ref = albedo(ggx_table_mu_at(xm), ggx_table_alpha_at(xa), ior, N_QUAD / 2);
                double v = 0.5 * (interp2(coat_E[k], xa, xm) + interp2(coat_E[k + 1], xa, xm));
                double e = fabs(ref - v);
                coat_err = e > coat_err ? e : coat_err;
                if (ggx_table_mu_at(xm) >= 0.1f)
                    coat_err_hi = e > coat_err_hi ? e : coat_err_hi;
                /* The ior axis alone: exact (mu, alpha) grid point, midway between ior slices. */
                double ref2 = albedo(ggx_table_mu_at((float)m), ggx_table_alpha_at((float)a), ior, N_QUAD / 2);
                double v2 = 0.5 * (coat_E[k][a][m] + coat_E[k + 1][a][m]);
                e = fabs(ref2 - v2);
                coat_err_ior = e > coat_err_ior ? e : coat_err_ior;
            }
        }
    }
    /* Quadrature error: a few entries against a grid four times finer in each dimension. */
    double quad_err = 0.0;
    for (int a = 0; a < VBI_GGX_N_ALPHA; a += 5) {
        for (int m = 0; m < VBI_GGX_N_MU; m += 5) {
            double fine = albedo(ggx_table_mu_at((float)m), ggx_table_alpha_at((float)a), 0.0f, N_QUAD * 4);
            double e = fabs(fine - conductor_E[a][m]);
            quad_err = e > quad_err ? e : quad_err;
            fine = albedo(ggx_table_mu_at((float)m), ggx_table_alpha_at((float)a), 1.5f, N_QUAD * 4);
            double coarse = albedo(ggx_table_mu_at((float)m), ggx_table_alpha_at((float)a), 1.5f, N_QUAD);
            e = fabs(fine - coarse);
            quad_err = e > quad_err ? e : quad_err;
        }
    }
    fprintf(stderr, "max |error|: conductor interp %.2e (mu>=0.1: %.2e), coat interp %.2e (mu>=0.1: %.2e, "
            "ior axis %.2e), quadrature %.2e\n", cond_err, cond_err_hi, coat_err, coat_err_hi, coat_err_ior, quad_err);

    printf("/* GENERATED FILE, do not edit: made by tools/gen_ggx_tables.c (see there for how to\n"
           " * rebuild it). Directional albedo E(mu, alpha) of single-scattering GGX reflection with\n"
           " * height-correlated Smith G2, and its cosine-weighted average E_avg, for the Kulla-Conty\n"
           " * energy compensation in bsdf.c. Axes and layout: core/src/microfacet.h.\n"
           " *\n"
           " * Quadrature: VNDF importance sampling on a %dx%d stratified midpoint grid per entry.\n"
           " * Measured max absolute error of the interpolated tables at cell centres (worst case):\n"
           " *   conductor E (bilinear in sqrt(mu), sqrt(alpha)):    %.1e   (%.1e for mu >= 0.1)\n"
           " *   coat E (trilinear, incl. (ior-1)/(ior+1) axis):     %.1e   (%.1e for mu >= 0.1)\n"
           " *   coat E, ior axis alone (mid-slice, grid mu/alpha):  %.1e\n"
           " *   quadrature error vs a 4x finer grid (sampled):      %.1e\n"
           " * Coat ior is clamped to [%.2f, %.2f]. */\n\n",
           N_QUAD, N_QUAD, cond_err, cond_err_hi, coat_err, coat_err_hi, coat_err_ior, quad_err, (double)VBI_GGX_IOR_MIN,
           (double)VBI_GGX_IOR_MAX);
    printf("#include \"microfacet.h\"\n\n");
    print_array("const float vbi_ggx_conductor_E[VBI_GGX_N_ALPHA][VBI_GGX_N_MU]", &conductor_E[0][0],
                VBI_GGX_N_ALPHA * VBI_GGX_N_MU, VBI_GGX_N_MU, 0);
    print_array("const float vbi_ggx_conductor_Eavg[VBI_GGX_N_ALPHA]", conductor_Eavg, VBI_GGX_N_ALPHA,
                VBI_GGX_N_ALPHA, 0);
    print_array("const float vbi_ggx_coat_E[VBI_GGX_N_IOR][VBI_GGX_N_ALPHA][VBI_GGX_N_MU]", &coat_E[0][0][0],
                VBI_GGX_N_IOR * VBI_GGX_N_ALPHA * VBI_GGX_N_MU, VBI_GGX_N_MU, VBI_GGX_N_ALPHA);
    print_array("const float vbi_ggx_coat_Eavg[VBI_GGX_N_IOR][VBI_GGX_N_ALPHA]", &coat_Eavg[0][0],
                VBI_GGX_N_IOR * VBI_GGX_N_ALPHA, VBI_GGX_N_ALPHA, 0);
    return 0;
}
