/* Tests for core/src/bsdf.c: sampling matches the pdf (chi-square), sample agrees with eval/pdf,
 * white-furnace energy conservation, reciprocity, and the Fresnel term. Every test draws from
 * fixed PCG32 seeds, so it is deterministic. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf.h"
#include "bsdfs.h"
#include "microfacet.h"
#include "rng.h"
#include "sampling.h"

/* ---- helpers ------------------------------------------------------------------------------ */

/* Gold, approximate RGB complex IOR (pbrt's Au spectrum at ~650/550/450 nm). */
static vbi_bsdf make_gold(float alpha)
{
    vbnl_material_desc m;
    memset(&m, 0, sizeof(m));
    m.type = VBNL_MATERIAL_CONDUCTOR;
    m.alpha = alpha;
    m.ior = 1.5f;
    m.conductor_use_ior = 1;
    const float eta[3] = {0.143f, 0.374f, 1.442f}, k[3] = {3.983f, 2.385f, 1.603f};
    memcpy(m.eta, eta, sizeof(eta));
    memcpy(m.k, k, sizeof(k));
    vbi_bsdf bsdf;
    vbi_bsdf_from_material(&bsdf, &m);
    return bsdf;
}

/* A plastic whose coat follows a reflectance curve (vbnl/scene.h, coat_curve): base colour c,
 * coat reflectance from lo (head-on) to hi (grazing). */
static vbi_bsdf make_coat(int curve, float lo, float hi, float falloff, float metallic, int conserve, float base_scale,
                          vec3 c, float alpha, float ior)
{
    vbnl_material_desc m;
    vbnl_material_desc_init(&m);
    m.type = VBNL_MATERIAL_PLASTIC;
    v3_store(m.base_color, c);
    m.alpha = alpha;
    m.ior = ior;
    m.coat_curve = curve;
    m.coat_min[0] = m.coat_min[1] = m.coat_min[2] = lo;
    m.coat_max[0] = m.coat_max[1] = m.coat_max[2] = hi;
    m.coat_falloff = falloff;
    m.coat_metallic = metallic;
    m.coat_conserve = conserve;
    m.base_scale = base_scale;
    vbi_bsdf bsdf;
    vbi_bsdf_from_material(&bsdf, &m);
    return bsdf;
}

static vec3 dir_from_theta(float theta_deg, float phi)
{
    float t = theta_deg * (float)M_PI / 180.0f;
    return v3(sinf(t) * cosf(phi), sinf(t) * sinf(phi), cosf(t));
}

static vec3 dir_from_z_phi(double z, double phi)
{
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    return v3((float)(r * cos(phi)), (float)(r * sin(phi)), (float)z);
}

/* VBNL_TEST_VERBOSE=1 prints every p-value and albedo, not only failing ones. */
static int verbose(void)
{
    const char *v = getenv("VBNL_TEST_VERBOSE");
    return v && v[0] == '1';
}

static float rel_err(float a, float b) { return fabsf(a - b) / fmaxf(fmaxf(fabsf(a), fabsf(b)), 1e-4f); }

/* ---- chi-square goodness of fit ------------------------------------------------------------
 * As in pbrt-v3's src/tests/bsdfs.cpp and Mitsuba's chi2 test: histogram sampled directions in
 * (cos theta, phi) bins, compare with N times the pdf integrated over each bin (midpoint rule on
 * a fine sub-grid; dw = dcos dphi), pool bins expected to get fewer than 5 samples, and turn the
 * statistic into a p-value with the regularised incomplete gamma function. */

#define CHI2_NT 16      /* cos theta bins over (0, 1]: every BSDF tested here is reflection-only */
#define CHI2_NP 32      /* phi bins */
#define CHI2_SUB 40     /* sub-grid per bin and axis for the pdf integration */
#define CHI2_SAMPLES 1000000
#define CHI2_TESTS 27   /* number of chi-square tests in this file, for the Sidak correction */
#define CHI2_SIGNIFICANCE 0.01

/* Regularised upper incomplete gamma Q(a, x) (Numerical Recipes 3rd ed., 6.2: series for
 * x < a + 1, Lentz continued fraction otherwise). */
static double gamma_q(double a, double x)
{
    if (x <= 0.0)
        return 1.0;
    double gln = lgamma(a);
    if (x < a + 1.0) {
        double ap = a, sum = 1.0 / a, del = sum;
        for (int n = 0; n < 10000; ++n) {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if (fabs(del) < fabs(sum) * 1e-15)
                break;
        }
        return 1.0 - sum * exp(-x + a * log(x) - gln);
    }
    double b = x + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
    for (int i = 1; i < 10000; ++i) {
        double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (fabs(d) < 1e-300)
            d = 1e-300;
        c = b + an / c;
        if (fabs(c) < 1e-300)
            c = 1e-300;
        d = 1.0 / d;
        double del = d * c;
        h *= del;
        if (fabs(del - 1.0) < 1e-15)
            break;
    }
    return exp(-x + a * log(x) - gln) * h;
}

static const double *g_sort_key; /* qsort has no context argument in C11 */
static int cmp_index(const void *a, const void *b)
{
    double x = g_sort_key[*(const int *)a], y = g_sort_key[*(const int *)b];
    return (x > y) - (x < y);
}

/* Runs the test for one BSDF and wo; returns the p-value (0 on a structural failure, with a
 * message printed). */
static double chi2_pvalue(const vbi_bsdf *b, vec3 wo, uint64_t seed, const char *name)
{
    enum { NB = CHI2_NT * CHI2_NP };
    static double observed[NB], expected[NB];
    static int order[NB];
    memset(observed, 0, sizeof(observed));

    vbi_rng rng = vbi_rng_make(seed, 7);
    long below = 0;
    for (int s = 0; s < CHI2_SAMPLES; ++s) {
        vec2 u = vbi_rng_next2(&rng);
        vbi_bsdf_sample_rec bs;
        if (!vbi_bsdf_sample(b, wo, u, &bs))
            continue;
        if (bs.wi.z <= 0.0f) {
            ++below;
            continue;
        }
        double phi = atan2((double)bs.wi.y, (double)bs.wi.x);
        if (phi < 0.0)
            phi += 2.0 * M_PI;
        int it = (int)(bs.wi.z * CHI2_NT), ip = (int)(phi / (2.0 * M_PI) * CHI2_NP);
        it = it < CHI2_NT ? it : CHI2_NT - 1;
        ip = ip < CHI2_NP ? ip : CHI2_NP - 1;
        observed[it * CHI2_NP + ip] += 1.0;
    }
    if (below > 0) {
        printf("# %s: %ld samples below the horizon where the pdf is 0\n", name, below);
        return 0.0;
    }

    double dz = 1.0 / CHI2_NT, dp = 2.0 * M_PI / CHI2_NP;
    double hz = dz / CHI2_SUB, hp = dp / CHI2_SUB;
    for (int it = 0; it < CHI2_NT; ++it) {
        for (int ip = 0; ip < CHI2_NP; ++ip) {
            double sum = 0.0;
            for (int a = 0; a < CHI2_SUB; ++a) {
                for (int c = 0; c < CHI2_SUB; ++c) {
                    vec3 wi = dir_from_z_phi(it * dz + (a + 0.5) * hz, ip * dp + (c + 0.5) * hp);
                    sum += (double)vbi_bsdf_pdf(b, wo, wi);
                }
            }
            expected[it * CHI2_NP + ip] = sum * hz * hp * CHI2_SAMPLES;
        }
    }

    /* Pooling (pbrt-v3 Chi2Test): ascending expected counts, merge bins until >= 5 expected. */
    for (int i = 0; i < NB; ++i)
        order[i] = i;
    g_sort_key = expected;
    qsort(order, NB, sizeof(int), cmp_index);
    double chsq = 0.0, pooled_obs = 0.0, pooled_exp = 0.0;
    int dof = 0;
    for (int k = 0; k < NB; ++k) {
        int i = order[k];
        if (expected[i] == 0.0) {
            if (observed[i] > CHI2_SAMPLES * 1e-5) {
                printf("# %s: %.0f samples in a bin with expected frequency 0\n", name, observed[i]);
                return 0.0;
            }
        } else if (expected[i] < 5.0 || (pooled_exp > 0.0 && pooled_exp < 5.0)) {
            pooled_obs += observed[i];
            pooled_exp += expected[i];
        } else {
            double d = observed[i] - expected[i];
            chsq += d * d / expected[i];
            ++dof;
        }
    }
    if (pooled_exp > 0.0 || pooled_obs > 0.0) {
        double d = pooled_obs - pooled_exp;
        chsq += d * d / fmax(pooled_exp, 1e-9);
        ++dof;
    }
    dof -= 1;
    if (dof < 1) {
        printf("# %s: too few bins\n", name);
        return 0.0;
    }
    double p = gamma_q(0.5 * dof, 0.5 * chsq);
    return p;
}

static void check_chi2(const vbi_bsdf *b, const char *what, uint64_t seed)
{
    static const float thetas[3] = {10.0f, 45.0f, 80.0f};
    /* Sidak: the family of CHI2_TESTS tests fails with probability CHI2_SIGNIFICANCE. */
    double level = 1.0 - pow(1.0 - CHI2_SIGNIFICANCE, 1.0 / CHI2_TESTS);
    for (int t = 0; t < 3; ++t) {
        char name[96];
        snprintf(name, sizeof(name), "%s theta_o=%g", what, (double)thetas[t]);
        vec3 wo = dir_from_theta(thetas[t], 0.7f);
        double p = chi2_pvalue(b, wo, seed + (uint64_t)t, name);
        if (!(p >= level) || verbose())
            printf("# %s: chi-square p-value %.3g (level %.3g)\n", name, p, level);
        assert_true(p >= level);
    }
}

static void test_chi2_lambert(void **state)
{
    (void)state;
    vbi_bsdf b = tb_bsdf(VBNL_MATERIAL_LAMBERT, 0.5f, 0.6f, 0.7f, 0.1f, 1.5f);
    check_chi2(&b, "lambert", 100);
}

static void test_chi2_conductor(void **state)
{
    (void)state;
    const float alphas[3] = {0.05f, 0.3f, 0.8f};
    for (int i = 0; i < 3; ++i) {
        /* Coloured F0 so that both mixture lobes carry weight and p_cos differs from 1 - E. */
        vbi_bsdf b = tb_bsdf(VBNL_MATERIAL_CONDUCTOR, 0.95f, 0.64f, 0.54f, alphas[i], 1.5f);
        char name[64];
        snprintf(name, sizeof(name), "conductor alpha=%g", (double)alphas[i]);
        check_chi2(&b, name, 200 + 10 * (uint64_t)i);
    }
}

static void test_chi2_plastic(void **state)
{
    (void)state;
    const float alphas[2] = {0.1f, 0.5f};
    for (int i = 0; i < 2; ++i) {
        vbi_bsdf b = tb_bsdf(VBNL_MATERIAL_PLASTIC, 0.2f, 0.5f, 0.8f, alphas[i], 1.5f);
        char name[64];
        snprintf(name, sizeof(name), "plastic alpha=%g", (double)alphas[i]);
        check_chi2(&b, name, 300 + 10 * (uint64_t)i);
    }
}

/* ---- consistency of sample with eval and pdf ---------------------------------------------- */

static void check_consistency(const vbi_bsdf *b, const char *name, uint64_t seed)
{
    vbi_rng rng = vbi_rng_make(seed, 11);
    int checked = 0;
    for (int s = 0; s < 20000; ++s) {
        vec3 wo = dir_from_z_phi(0.02 + 0.98 * vbi_rng_next(&rng), 2.0 * M_PI * vbi_rng_next(&rng));
        vec2 u = vbi_rng_next2(&rng);
        vbi_bsdf_sample_rec bs;
        if (!vbi_bsdf_sample(b, wo, u, &bs))
            continue;
        assert_false(bs.lobe & VBI_LOBE_SPECULAR);
        float pdf = vbi_bsdf_pdf(b, wo, bs.wi);
        vec3 f = vbi_bsdf_eval(b, wo, bs.wi);
        if (rel_err(bs.pdf, pdf) > 1e-3f || !(pdf > 0.0f)) {
            printf("# %s: sample pdf %g, pdf() %g\n", name, (double)bs.pdf, (double)pdf);
            fail();
        }
        for (int c = 0; c < 3; ++c) {
            float w = v3_comp(bs.weight, c), ref = v3_comp(f, c) / pdf;
            if (!(fabsf(w - ref) <= 1e-3f * fmaxf(1.0f, fabsf(ref)))) {
                printf("# %s: weight %g, eval/pdf %g\n", name, (double)w, (double)ref);
                fail();
            }
        }
        ++checked;
    }
    assert_true(checked > 10000);
}

static void test_sample_consistency(void **state)
{
    (void)state;
    vbi_bsdf b = tb_bsdf(VBNL_MATERIAL_LAMBERT, 0.5f, 0.6f, 0.7f, 0.1f, 1.5f);
    check_consistency(&b, "lambert", 1);
    const float alphas[4] = {0.002f, 0.05f, 0.3f, 0.8f};
    for (int i = 0; i < 4; ++i) {
        b = tb_bsdf(VBNL_MATERIAL_CONDUCTOR, 0.95f, 0.64f, 0.54f, alphas[i], 1.5f);
        check_consistency(&b, "conductor", 2 + (uint64_t)i);
        b = make_gold(alphas[i]);
        check_consistency(&b, "gold", 12 + (uint64_t)i);
        b = tb_bsdf(VBNL_MATERIAL_PLASTIC, 0.2f, 0.5f, 0.8f, alphas[i], 1.5f);
        check_consistency(&b, "plastic", 22 + (uint64_t)i);
    }
}

/* ---- white furnace -------------------------------------------------------------------------
 * Directional albedo rho(wo) = int f |cos theta_i| dwi estimated as the mean sample weight
 * (absorbed samples count as 0). */

#define FURNACE_SAMPLES 200000

static vec3 albedo_mc(const vbi_bsdf *b, vec3 wo, uint64_t seed)
{
    vbi_rng rng = vbi_rng_make(seed, 13);
    double sum[3] = {0, 0, 0};
    for (int s = 0; s < FURNACE_SAMPLES; ++s) {
        vec2 u = vbi_rng_next2(&rng);
        vbi_bsdf_sample_rec bs;
        if (!vbi_bsdf_sample(b, wo, u, &bs))
            continue;
        for (int c = 0; c < 3; ++c)
            sum[c] += v3_comp(bs.weight, c);
    }
    return v3((float)(sum[0] / FURNACE_SAMPLES), (float)(sum[1] / FURNACE_SAMPLES), (float)(sum[2] / FURNACE_SAMPLES));
}

static const float furnace_thetas[5] = {0.0f, 10.0f, 45.0f, 80.0f, 88.0f};

/* Albedo must not exceed 1 (+ tolerance); when `lossless`, it must equal 1 within `tol`. */
static void check_furnace(const vbi_bsdf *b, const char *name, int lossless, float tol, uint64_t seed)
{
    for (int t = 0; t < 5; ++t) {
        vec3 a = albedo_mc(b, dir_from_theta(furnace_thetas[t], 0.3f), seed + (uint64_t)t);
        int ok = v3_max_comp(a) <= 1.0f + tol && v3_min_comp(a) >= 0.0f;
        if (lossless)
            ok = ok && v3_min_comp(a) >= 1.0f - tol;
        if (!ok || verbose())
            printf("# %s theta_o=%g: albedo (%.4f %.4f %.4f)\n", name, (double)furnace_thetas[t], (double)a.x,
                   (double)a.y, (double)a.z);
        assert_true(ok);
    }
}

static void test_furnace_opaque(void **state)
{
    (void)state;
    vbi_bsdf b = tb_bsdf(VBNL_MATERIAL_LAMBERT, 1.0f, 1.0f, 1.0f, 0.1f, 1.5f);
    check_furnace(&b, "lambert white", 1, 0.01f, 1000);
    b = tb_bsdf(VBNL_MATERIAL_MIRROR, 1.0f, 1.0f, 1.0f, 0.1f, 1.5f);
    check_furnace(&b, "mirror white", 1, 1e-6f, 1100);
    const float alphas[6] = {0.001f, 0.05f, 0.1f, 0.3f, 0.6f, 1.0f};
    for (int i = 0; i < 6; ++i) {
        char name[64];
        /* F0 = 1: F = 1 at every angle, so single + multiple scattering must be exactly lossless. */
        b = tb_bsdf(VBNL_MATERIAL_CONDUCTOR, 1.0f, 1.0f, 1.0f, alphas[i], 1.5f);
        snprintf(name, sizeof(name), "conductor white alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, 1, 0.01f, 1200 + 10 * (uint64_t)i);
        b = make_gold(alphas[i]);
        snprintf(name, sizeof(name), "gold alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, 0, 0.01f, 1300 + 10 * (uint64_t)i);
        b = tb_bsdf(VBNL_MATERIAL_CONDUCTOR, 0.95f, 0.64f, 0.54f, alphas[i], 1.5f);
        snprintf(name, sizeof(name), "conductor copper-F0 alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, 0, 0.01f, 1400 + 10 * (uint64_t)i);
        /* Plastic with a white base: E_s + (1 - E_s) = 1 by construction; a tinted base is lossy. */
        b = tb_bsdf(VBNL_MATERIAL_PLASTIC, 1.0f, 1.0f, 1.0f, alphas[i], 1.5f);
        snprintf(name, sizeof(name), "plastic white alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, 0, 0.01f, 1500 + 10 * (uint64_t)i);
        b = tb_bsdf(VBNL_MATERIAL_PLASTIC, 0.2f, 0.5f, 0.8f, alphas[i], 2.5f);
        snprintf(name, sizeof(name), "plastic ior 2.5 alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, 0, 0.01f, 1600 + 10 * (uint64_t)i);
    }
}

/* Energy compensation checked independently of the BSDF's own sampling and of the tables: for a
 * white conductor, integrate single scattering (F = 1, height-correlated G2, recomputed here) and
 * the rest of eval (the multiple-scattering lobe) by cosine sampling. The lobe must carry what
 * single scattering loses (E_ms = 1 - E_ss) and must be substantial at high roughness. */
static void test_furnace_conductor_compensation(void **state)
{
    (void)state;
    const float alphas[3] = {0.3f, 0.6f, 1.0f};
    const float thetas[3] = {10.0f, 45.0f, 75.0f};
    for (int i = 0; i < 3; ++i) {
        vbi_bsdf b = tb_bsdf(VBNL_MATERIAL_CONDUCTOR, 1.0f, 1.0f, 1.0f, alphas[i], 1.5f);
        for (int t = 0; t < 3; ++t) {
            vec3 wo = dir_from_theta(thetas[t], 0.0f);
            vbi_rng rng = vbi_rng_make(5 + (uint64_t)(3 * i + t), 5);
            double ss = 0.0, ms = 0.0;
            for (int s = 0; s < FURNACE_SAMPLES; ++s) {
                vec3 wi = sample_cosine_hemisphere(vbi_rng_next2(&rng));
                if (wi.z <= 0.0f)
                    continue;
                vec3 h = v3_norm(v3_add(wo, wi));
                float f_ss = ggx_d(h, b.alpha) * ggx_g2(wo, wi, b.alpha) / (4.0f * wo.z) * wi.z;
                float pdf = pdf_cosine_hemisphere(wi);
                ss += f_ss / pdf;
                ms += (vbi_bsdf_eval(&b, wo, wi).x - f_ss) / pdf;
            }
            ss /= FURNACE_SAMPLES;
            ms /= FURNACE_SAMPLES;
            if (!(fabs(ss + ms - 1.0) < 0.015) || verbose())
                printf("# compensation alpha %g theta %g: E_ss %.4f E_ms %.4f\n", (double)alphas[i],
                       (double)thetas[t], ss, ms);
            assert_true(fabs(ss + ms - 1.0) < 0.015);
            if (alphas[i] >= 0.6f)
                assert_true(ms > 0.1);
        }
    }
}

/* Smooth dielectric, eta = 1.5, white tint, from both sides. The radiance weight of a refraction
 * is (1 - F) / (1 - F) / eta^2, so the mean radiance weight is R + T / eta^2, not 1. What is
 * checked: (a) "importance" albedo, mean of weight * eta^2 for refractions (undoing the
 * radiance scaling) and of weight for reflections, equals 1 (R + T = 1); (b) the reflection
 * fraction equals the Fresnel reflectance (binomial 5-sigma bound); (c) the refracted direction
 * obeys Snell's law and the radiance weight is exactly 1 / eta^2; (d) beyond the critical angle
 * from inside every sample reflects (TIR). */
static void test_furnace_dielectric(void **state)
{
    (void)state;
    const float ior = 1.5f;
    vbi_bsdf b = tb_bsdf(VBNL_MATERIAL_DIELECTRIC, 1.0f, 1.0f, 1.0f, 0.1f, ior);
    for (int side = 0; side < 2; ++side) {
        for (int t = 0; t < 5; ++t) {
            vec3 wo = dir_from_theta(furnace_thetas[t], 0.3f);
            if (side)
                wo.z = -wo.z;
            vbi_rng rng = vbi_rng_make(2000 + (uint64_t)(10 * side + t), 17);
            const int n = FURNACE_SAMPLES;
            double importance = 0.0;
            int reflected = 0;
            for (int s = 0; s < n; ++s) {
                vbi_bsdf_sample_rec bs = {0}; /* {0}: GCC cannot see that assert_true stops */
                assert_true(vbi_bsdf_sample(&b, wo, vbi_rng_next2(&rng), &bs));
                assert_true(bs.lobe & VBI_LOBE_SPECULAR);
                if (bs.lobe & VBI_LOBE_REFLECTION) {
                    ++reflected;
                    importance += bs.weight.x;
                    assert_true(fabsf(bs.wi.x + wo.x) < 1e-6f && fabsf(bs.wi.z - wo.z) < 1e-6f);
                } else {
                    float eta = wo.z > 0.0f ? ior : 1.0f / ior;
                    assert_true(fabsf(bs.eta - eta) < 1e-6f);
                    assert_true(bs.wi.z * wo.z < 0.0f);
                    float sin_o = sqrtf(wo.x * wo.x + wo.y * wo.y), sin_i = sqrtf(bs.wi.x * bs.wi.x + bs.wi.y * bs.wi.y);
                    assert_true(fabsf(sin_o - eta * sin_i) < 1e-5f);
                    assert_true(fabsf(bs.weight.x * eta * eta - 1.0f) < 1e-5f);
                    importance += bs.weight.x * eta * eta;
                }
            }
            double F = vbi_fresnel_dielectric(wo.z, ior);
            double frac = (double)reflected / n, sigma = sqrt(F * (1.0 - F) / n);
            if (!(fabs(frac - F) <= 5.0 * sigma + 1e-9) || !(fabs(importance / n - 1.0) < 0.01))
                printf("# dielectric side %d theta %g: R frac %.5f, F %.5f, importance albedo %.5f\n", side,
                       (double)furnace_thetas[t], frac, F, importance / n);
            assert_true(fabs(frac - F) <= 5.0 * sigma + 1e-9);
            assert_true(fabs(importance / n - 1.0) < 0.01);
            if (side && furnace_thetas[t] > 41.9f) /* critical angle asin(1/1.5) = 41.8 deg */
                assert_int_equal(reflected, n);
        }
    }
}

/* ---- reciprocity: f(wo, wi) = f(wi, wo), with eval = f |cos theta_i| ---------------------- */

static void check_reciprocity(const vbi_bsdf *b, const char *name, uint64_t seed)
{
    vbi_rng rng = vbi_rng_make(seed, 19);
    for (int s = 0; s < 5000; ++s) {
        vec3 wo = sample_uniform_hemisphere(vbi_rng_next2(&rng));
        vec3 wi = sample_uniform_hemisphere(vbi_rng_next2(&rng));
        if (wo.z < 1e-3f || wi.z < 1e-3f)
            continue;
        vec3 a = v3_scale(vbi_bsdf_eval(b, wo, wi), 1.0f / wi.z);
        vec3 c = v3_scale(vbi_bsdf_eval(b, wi, wo), 1.0f / wo.z);
        for (int k = 0; k < 3; ++k) {
            float x = v3_comp(a, k), y = v3_comp(c, k);
            if (!(fabsf(x - y) <= 2e-3f * fmaxf(fmaxf(x, y), 1e-3f))) {
                printf("# %s: f(wo,wi) %g != f(wi,wo) %g\n", name, (double)x, (double)y);
                fail();
            }
        }
    }
    /* One-sided: nothing below the surface. */
    vec3 up = v3(0.3f, 0.1f, 0.948683f), down = v3(0.3f, 0.1f, -0.948683f);
    assert_true(v3_is_black(vbi_bsdf_eval(b, down, up)));
    assert_true(v3_is_black(vbi_bsdf_eval(b, up, down)));
    assert_true(vbi_bsdf_pdf(b, down, up) == 0.0f);
}

static void test_reciprocity(void **state)
{
    (void)state;
    vbi_bsdf b = tb_bsdf(VBNL_MATERIAL_LAMBERT, 0.5f, 0.6f, 0.7f, 0.1f, 1.5f);
    check_reciprocity(&b, "lambert", 1);
    const float alphas[4] = {0.01f, 0.1f, 0.4f, 1.0f};
    for (int i = 0; i < 4; ++i) {
        b = tb_bsdf(VBNL_MATERIAL_CONDUCTOR, 0.95f, 0.64f, 0.54f, alphas[i], 1.5f);
        check_reciprocity(&b, "conductor", 10 + (uint64_t)i);
        b = make_gold(alphas[i]);
        check_reciprocity(&b, "gold", 20 + (uint64_t)i);
        b = tb_bsdf(VBNL_MATERIAL_PLASTIC, 0.2f, 0.5f, 0.8f, alphas[i], 1.5f);
        check_reciprocity(&b, "plastic", 30 + (uint64_t)i);
    }
}

/* ---- Fresnel ------------------------------------------------------------------------------ */

static void test_fresnel(void **state)
{
    (void)state;
    const float etas[4] = {1.1f, 1.33f, 1.5f, 2.4f};
    for (int i = 0; i < 4; ++i) {
        float eta = etas[i];
        float f0 = sqr((eta - 1.0f) / (eta + 1.0f));
        assert_true(fabsf(vbi_fresnel_dielectric(1.0f, eta) - f0) < 1e-6f);
        assert_true(fabsf(vbi_fresnel_dielectric(-1.0f, eta) - f0) < 1e-6f); /* from inside */
        assert_true(fabsf(vbi_fresnel_dielectric(0.0f, eta) - 1.0f) < 1e-6f); /* grazing */
        /* Beyond the critical angle from inside: total internal reflection. */
        float cos_crit = sqrtf(1.0f - 1.0f / (eta * eta));
        assert_true(vbi_fresnel_dielectric(-0.9f * cos_crit, eta) == 1.0f);
        /* Same interface seen from both sides at Snell-related angles: same reflectance. */
        float cos_i = 0.6f, sin_t = sqrtf(1.0f - cos_i * cos_i) / eta, cos_t = sqrtf(1.0f - sin_t * sin_t);
        assert_true(fabsf(vbi_fresnel_dielectric(cos_i, eta) - vbi_fresnel_dielectric(-cos_t, eta)) < 1e-5f);
        /* Monotonic towards grazing, within [f0, 1]. */
        float prev = f0;
        for (int k = 19; k >= 0; --k) {
            float f = vbi_fresnel_dielectric((float)k / 20.0f, eta);
            assert_true(f >= prev - 1e-6f && f <= 1.0f);
            prev = f;
        }
    }
    /* Known value: eta 1.5 at 45 degrees, rs^2 = 0.0920, rp^2 = 0.00847, mean 0.0503. */
    assert_true(fabsf(vbi_fresnel_dielectric(cosf((float)M_PI / 4.0f), 1.5f) - 0.0503f) < 2e-4f);
}

/* ---- coats with a reflectance curve (POV-Ray's variable reflection) -------------------------- */

/* The coat's reflectance at c = wo.h read back from the microfacet lobe: eval / (D G2 / (4 cos_o))
 * for wi the mirror of wo about z (so h = z and wo.h = cos theta_o). */
static vec3 coat_F_at(const vbi_bsdf *b, float c)
{
    vec3 wo = v3(sqrtf(1.0f - c * c), 0.0f, c), wi = reflect_z(wo), h = v3(0.0f, 0.0f, 1.0f);
    float dg = ggx_d(h, b->alpha) * ggx_g2(wo, wi, b->alpha) / (4.0f * wo.z);
    return v3_scale(vbi_bsdf_eval_microfacet(b, wo, wi), 1.0f / dg);
}

static void expect_v3(vec3 v, float a, float b, float c, float tol, const char *what)
{
    if (!(fabsf(v.x - a) <= tol && fabsf(v.y - b) <= tol && fabsf(v.z - c) <= tol)) {
        printf("# %s: (%g %g %g), expected (%g %g %g)\n", what, (double)v.x, (double)v.y, (double)v.z, (double)a,
               (double)b, (double)c);
        fail();
    }
}

static void test_coat_curve(void **state)
{
    (void)state;
    const float cosines[3] = {1.0f, 0.5f, 0.1f};
    /* min 0.01, max 0.99, falloff 5: 0.01 + 0.98 (1 - c)^5 = 0.01, 0.040625, 0.588680 */
    const float want[3] = {0.01f, 0.040625f, 0.5886802f};
    vbi_bsdf b = make_coat(VBNL_COAT_SCHLICK, 0.01f, 0.99f, 5.0f, 0.0f, 0, 0.5f, v3s(0.5f), 0.2f, 1.5f);
    for (int i = 0; i < 3; ++i)
        expect_v3(coat_F_at(&b, cosines[i]), want[i], want[i], want[i], 2e-5f, "schlick falloff 5");
    /* falloff 1 (POV-Ray's default): linear in 1 - c */
    b = make_coat(VBNL_COAT_SCHLICK, 0.2f, 0.6f, 1.0f, 0.0f, 0, 0.5f, v3s(0.5f), 0.2f, 1.5f);
    expect_v3(coat_F_at(&b, 0.25f), 0.5f, 0.5f, 0.5f, 2e-5f, "schlick falloff 1");
    /* fresnel: min + (max - min) Fr(c, ior) */
    b = make_coat(VBNL_COAT_FRESNEL, 0.1f, 0.9f, 1.0f, 0.0f, 0, 0.5f, v3s(0.5f), 0.2f, 1.33f);
    for (int i = 0; i < 3; ++i) {
        float f = 0.1f + 0.8f * vbi_fresnel_dielectric(cosines[i], 1.33f);
        expect_v3(coat_F_at(&b, cosines[i]), f, f, f, 2e-5f, "fresnel");
    }
    /* metallic 1: tinted by the surface colour head-on, untinted at grazing (POV-Ray's curve) */
    b = make_coat(VBNL_COAT_SCHLICK, 0.8f, 0.8f, 1.0f, 1.0f, 0, 0.0f, v3(0.9f, 0.6f, 0.2f), 0.2f, 1.5f);
    expect_v3(coat_F_at(&b, 1.0f), 0.72f, 0.48f, 0.16f, 1e-4f, "metallic head-on");
    expect_v3(coat_F_at(&b, 0.001f), 0.8f, 0.8f, 0.8f, 0.01f, "metallic grazing");
    /* metallic 0.5 head-on: 0.8 (1 + 0.5 (c - 1)) */
    b = make_coat(VBNL_COAT_SCHLICK, 0.8f, 0.8f, 1.0f, 0.5f, 0, 0.0f, v3(0.9f, 0.6f, 0.2f), 0.2f, 1.5f);
    expect_v3(coat_F_at(&b, 1.0f), 0.76f, 0.64f, 0.48f, 1e-4f, "metallic 0.5 head-on");
    /* the smooth coat's albedo head-on is the curve's value: reflection 0.3 over diffuse 0.6 of
     * white reflects 0.3 + 0.6 (POV-Ray adds them) */
    b = make_coat(VBNL_COAT_SCHLICK, 0.3f, 0.3f, 1.0f, 0.0f, 0, 0.6f, v3s(1.0f), 0.001f, 1.5f);
    vec3 a = albedo_mc(&b, v3(0.0f, 0.0f, 1.0f), 77);
    expect_v3(a, 0.9f, 0.9f, 0.9f, 0.01f, "reflection 0.3 + diffuse 0.6");
    /* additive beyond 1: the base gives way where the coat takes more than 1 - k, here at every
     * angle (g = 0.5 / 1): the albedo is 0.5 + 1 g(mu_o) (2 int g mu dmu) = 0.75 ... */
    b = make_coat(VBNL_COAT_SCHLICK, 0.5f, 0.5f, 1.0f, 0.0f, 0, 1.0f, v3s(1.0f), 0.001f, 1.5f);
    a = albedo_mc(&b, v3(0.0f, 0.0f, 1.0f), 78);
    expect_v3(a, 0.75f, 0.75f, 0.75f, 0.01f, "reflection 0.5 + diffuse 1");
    /* ... and only there: min 0.01 max 0.99 falloff 5 over diffuse 0.6 reflects 0.6 g_avg + 0.01
     * head-on, g = min(1, (1 - F) / 0.6) below 1 only for mu < 0.165 */
    b = make_coat(VBNL_COAT_SCHLICK, 0.01f, 0.99f, 5.0f, 0.0f, 0, 0.6f, v3s(1.0f), 0.001f, 1.5f);
    double gavg = 0.0;
    for (int i = 0; i < 100000; ++i) { /* 2 int g(mu) mu dmu by the midpoint rule */
        double mu = (i + 0.5) / 100000.0, F = 0.01 + 0.98 * pow(1.0 - mu, 5.0);
        gavg += 2.0 * mu * fmin(1.0, (1.0 - F) / 0.6) / 100000.0;
    }
    a = albedo_mc(&b, v3(0.0f, 0.0f, 1.0f), 79);
    float want_a = (float)(0.01 + 0.6 * gavg);
    expect_v3(a, want_a, want_a, want_a, 0.005f, "falloff 5 over diffuse 0.6");
    assert_true(gavg > 0.97 && gavg < 0.995);
}

static void test_coat_sampling(void **state)
{
    (void)state;
    vbi_bsdf b = make_coat(VBNL_COAT_SCHLICK, 0.01f, 0.99f, 5.0f, 0.0f, 0, 0.6f, v3(0.2f, 0.5f, 0.8f), 0.1f, 1.5f);
    check_chi2(&b, "coat schlick additive alpha=0.1", 400);
    check_consistency(&b, "coat schlick additive", 41);
    check_reciprocity(&b, "coat schlick additive", 42);
    b = make_coat(VBNL_COAT_SCHLICK, 0.05f, 0.7f, 2.0f, 0.0f, 1, 0.9f, v3(0.2f, 0.5f, 0.8f), 0.4f, 1.5f);
    check_chi2(&b, "coat schlick conserving alpha=0.4", 410);
    check_consistency(&b, "coat schlick conserving", 43);
    check_reciprocity(&b, "coat schlick conserving", 44);
    b = make_coat(VBNL_COAT_FRESNEL, 0.0f, 0.8f, 1.0f, 1.0f, 0, 0.3f, v3(0.9f, 0.6f, 0.2f), 0.25f, 1.5f);
    check_chi2(&b, "coat fresnel metallic alpha=0.25", 420);
    check_consistency(&b, "coat fresnel metallic", 45);
    check_reciprocity(&b, "coat fresnel metallic", 46);
    b = make_coat(VBNL_COAT_SCHLICK, 0.3f, 0.3f, 1.0f, 0.0f, 0, 0.6f, v3s(0.5f), 0.001f, 1.5f);
    check_consistency(&b, "coat smooth", 47);
    /* the diffuse share of the pdf is the base lobe's */
    vec3 wo = dir_from_theta(30.0f, 0.2f), wi = dir_from_theta(50.0f, 2.0f);
    float pd = vbi_bsdf_pdf_diffuse(&b, wo, wi), p = vbi_bsdf_pdf(&b, wo, wi);
    assert_true(pd > 0.0f && pd <= p * (1.0f + 1e-5f));
}

/* A smooth dielectric with a coat curve reflects F(cos) and lets 1 - F through (times 1/eta^2
 * for radiance), from either side, and reflects everything at total internal reflection. */
static void test_coat_dielectric(void **state)
{
    (void)state;
    vbnl_material_desc m;
    vbnl_material_desc_init(&m);
    m.type = VBNL_MATERIAL_DIELECTRIC;
    m.base_color[0] = m.base_color[1] = m.base_color[2] = 1.0f;
    m.ior = 1.3f;
    m.coat_curve = VBNL_COAT_SCHLICK;
    m.coat_min[0] = 0.0f, m.coat_min[1] = 0.1f, m.coat_min[2] = 0.2f;
    m.coat_max[0] = m.coat_max[1] = m.coat_max[2] = 1.0f;
    m.coat_falloff = 2.0f;
    vbi_bsdf b;
    vbi_bsdf_from_material(&b, &m);
    const float cosines[3] = {0.9f, 0.5f, -0.95f};
    for (int t = 0; t < 3; ++t) {
        float c = cosines[t], eta = c > 0.0f ? 1.3f : 1.0f / 1.3f;
        vec3 wo = v3(sqrtf(1.0f - c * c), 0.0f, c);
        double refl[3] = {0, 0, 0}, trans[3] = {0, 0, 0};
        const int n = 4000;
        for (int i = 0; i < n; ++i) {
            vbi_bsdf_sample_rec rec = {.pdf = 0.0f};
            assert_true(vbi_bsdf_sample(&b, wo, (vec2){((float)i + 0.5f) / (float)n, 0.5f}, &rec));
            double *acc = (rec.lobe & VBI_LOBE_REFLECTION) ? refl : trans;
            for (int k = 0; k < 3; ++k)
                acc[k] += v3_comp(rec.weight, k) / n;
        }
        float w = powf(1.0f - fabsf(c), 2.0f);
        for (int k = 0; k < 3; ++k) {
            float F = v3_comp(b.coat_min, k) + (1.0f - v3_comp(b.coat_min, k)) * w;
            assert_float_equal(refl[k], F, 2e-3);
            assert_float_equal(trans[k] * eta * eta, 1.0f - F, 2e-3);
        }
    }
    /* from inside beyond the critical angle (asin(1 / 1.3) = 50.3 degrees): all reflected */
    vec3 wo = v3(sinf(1.2f), 0.0f, -cosf(1.2f));
    vbi_bsdf_sample_rec rec = {.pdf = 0.0f};
    assert_true(vbi_bsdf_sample(&b, wo, (vec2){0.99f, 0.5f}, &rec));
    assert_true(rec.lobe & VBI_LOBE_REFLECTION);
    expect_v3(rec.weight, 1.0f, 1.0f, 1.0f, 1e-6f, "total internal reflection");
}

static void test_coat_furnace(void **state)
{
    (void)state;
    const float alphas[4] = {0.001f, 0.1f, 0.4f, 1.0f};
    for (int i = 0; i < 4; ++i) {
        char name[96];
        /* conserving with a white base: F + (1 - F) = 1 for the smooth coat, <= 1 for rough ones */
        vbi_bsdf b = make_coat(VBNL_COAT_SCHLICK, 0.05f, 1.0f, 5.0f, 0.0f, 1, 1.0f, v3s(1.0f), alphas[i], 1.5f);
        snprintf(name, sizeof(name), "coat conserving white alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, alphas[i] < 0.01f, 0.01f, 2000 + 10 * (uint64_t)i);
        b = make_coat(VBNL_COAT_FRESNEL, 0.0f, 1.0f, 1.0f, 0.0f, 1, 1.0f, v3s(1.0f), alphas[i], 1.5f);
        snprintf(name, sizeof(name), "coat conserving fresnel white alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, 0, 0.01f, 2100 + 10 * (uint64_t)i);
        /* additive, diffuse 1 and reflection up to 0.99: the cap keeps it within 1 */
        b = make_coat(VBNL_COAT_SCHLICK, 0.01f, 0.99f, 5.0f, 0.0f, 0, 1.0f, v3s(1.0f), alphas[i], 1.5f);
        snprintf(name, sizeof(name), "coat additive white alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, 0, 0.01f, 2200 + 10 * (uint64_t)i);
        b = make_coat(VBNL_COAT_SCHLICK, 0.8f, 0.8f, 1.0f, 1.0f, 0, 0.2f, v3(0.9f, 0.6f, 0.2f), alphas[i], 1.5f);
        snprintf(name, sizeof(name), "coat additive metallic alpha=%g", (double)alphas[i]);
        check_furnace(&b, name, 0, 0.01f, 2300 + 10 * (uint64_t)i);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fresnel),
        cmocka_unit_test(test_reciprocity),
        cmocka_unit_test(test_sample_consistency),
        cmocka_unit_test(test_furnace_opaque),
        cmocka_unit_test(test_furnace_conductor_compensation),
        cmocka_unit_test(test_furnace_dielectric),
        cmocka_unit_test(test_chi2_lambert),
        cmocka_unit_test(test_chi2_conductor),
        cmocka_unit_test(test_chi2_plastic),
        cmocka_unit_test(test_coat_curve),
        cmocka_unit_test(test_coat_sampling),
        cmocka_unit_test(test_coat_furnace),
        cmocka_unit_test(test_coat_dielectric),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
