/* Tests for the sample warps and the alias table of core/src/sampling.h.
 *
 * Every warp is checked as a pair with its pdf function: samples are binned and compared with a
 * chi-square test (p >= 0.01) against the pdf integrated over each bin, and the pdf must
 * integrate to 1. Seeds are fixed, so the outcome is deterministic. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>

#include "rng.h"
#include "sampling.h"

#include "../common/chi2.h"

#define SIGNIFICANCE 0.01
#define MIN_EXPECTED 5.0

/* ---- direction warps ----------------------------------------------------------------------- */

typedef vec3 (*warp_fn)(vec2 u, const void *param);
typedef double (*warp_pdf_fn)(vec3 w, const void *param);

typedef struct warp_case {
    const char *name;
    warp_fn sample;
    warp_pdf_fn pdf;
    const void *param;
    double zmin; /* bins cover z in [zmin, 1]; everything below goes in one extra bin */
} warp_case;

static double grid_pdf(void *ctx, double z, double phi)
{
    const warp_case *c = ctx;
    double s = sqrt(fmax(0.0, 1.0 - z * z));
    return c->pdf(v3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)z), c->param);
}

/* Returns 1 when the warp passes. */
static int run_warp_chi2(const warp_case *c, int n_samples, uint64_t seed)
{
    vbi_chi2_grid g = {16, 32, c->zmin};
    int nb = vbi_chi2_grid_bins(&g);
    double *obs = calloc((size_t)nb, sizeof(double));
    double *expd = calloc((size_t)nb, sizeof(double));
    double total = vbi_chi2_grid_integrate(&g, grid_pdf, (void *)c, 8, n_samples, expd);
    vbi_rng rng = vbi_rng_make(seed, 7);
    int bad = 0;
    for (int i = 0; i < n_samples; ++i) {
        vec3 w = c->sample(vbi_rng_next2(&rng), c->param);
        if (fabsf(v3_len(w) - 1.0f) > 1e-4f || !(c->pdf(w, c->param) > 0.0))
            ++bad;
        obs[vbi_chi2_grid_bin(&g, w.z, atan2(w.y, w.x))] += 1.0;
    }
    vbi_chi2_result res;
    int ok = vbi_chi2_test(obs, expd, nb, MIN_EXPECTED, SIGNIFICANCE, &res);
    printf("#   %-28s pdf integral %.5f, %s\n", c->name, total, res.msg);
    if (bad)
        printf("#   %-28s %d samples not unit or with pdf 0\n", c->name, bad);
    free(obs);
    free(expd);
    return ok && bad == 0 && fabs(total - 1.0) < 2e-3;
}

static vec3 w_cosine(vec2 u, const void *p) { (void)p; return sample_cosine_hemisphere(u); }
static double p_cosine(vec3 w, const void *p) { (void)p; return pdf_cosine_hemisphere(w); }
static vec3 w_sphere(vec2 u, const void *p) { (void)p; return sample_uniform_sphere(u); }
static double p_sphere(vec3 w, const void *p) { (void)p; (void)w; return pdf_uniform_sphere(); }
static vec3 w_hemi(vec2 u, const void *p) { (void)p; return sample_uniform_hemisphere(u); }
static double p_hemi(vec3 w, const void *p) { (void)p; return w.z >= 0.0f ? pdf_uniform_hemisphere() : 0.0; }
static vec3 w_cone(vec2 u, const void *p) { return sample_uniform_cone(u, *(const float *)p); }
static double p_cone(vec3 w, const void *p)
{
    float cos_max = *(const float *)p;
    return w.z >= cos_max ? pdf_uniform_cone(cos_max) : 0.0;
}

static void test_cosine_hemisphere(void **state)
{
    (void)state;
    warp_case c = {"cosine hemisphere", w_cosine, p_cosine, NULL, 0.0};
    assert_true(run_warp_chi2(&c, 400000, 1));
}

static void test_uniform_sphere(void **state)
{
    (void)state;
    warp_case c = {"uniform sphere", w_sphere, p_sphere, NULL, -1.0};
    assert_true(run_warp_chi2(&c, 400000, 2));
}

static void test_uniform_hemisphere(void **state)
{
    (void)state;
    warp_case c = {"uniform hemisphere", w_hemi, p_hemi, NULL, 0.0};
    assert_true(run_warp_chi2(&c, 400000, 3));
}

static void test_uniform_cone(void **state)
{
    (void)state;
    static const float cos_max[2] = {0.3f, 0.985f}; /* about 73 and 10 degrees */
    for (int i = 0; i < 2; ++i) {
        warp_case c = {"uniform cone", w_cone, p_cone, &cos_max[i], cos_max[i]};
        assert_true(run_warp_chi2(&c, 400000, 4 + (uint64_t)i));
    }
}

/* The test must be able to fail: cosine-distributed samples are rejected against the uniform
 * hemisphere pdf, and samples of a 0.31 cone against the pdf of a 0.3 cone (a 1% change in
 * cos_max, i.e. samples missing from a thin ring at the rim). */
static void test_chi2_detects_wrong_pdf(void **state)
{
    (void)state;
    warp_case c = {"cosine vs uniform (must fail)", w_cosine, p_hemi, NULL, 0.0};
    assert_false(run_warp_chi2(&c, 100000, 9));

    static const float claimed = 0.3f, actual = 0.31f;
    warp_case e = {"cone", w_cone, p_cone, &claimed, 0.0};
    vbi_chi2_grid g = {16, 32, 0.0};
    int nb = vbi_chi2_grid_bins(&g);
    double *obs = calloc((size_t)nb, sizeof(double)), *expd = calloc((size_t)nb, sizeof(double));
    vbi_chi2_grid_integrate(&g, grid_pdf, &e, 8, 200000, expd);
    vbi_rng rng = vbi_rng_make(11, 7);
    for (int i = 0; i < 200000; ++i) {
        vec3 w = sample_uniform_cone(vbi_rng_next2(&rng), actual);
        obs[vbi_chi2_grid_bin(&g, w.z, atan2(w.y, w.x))] += 1.0;
    }
    vbi_chi2_result res;
    assert_false(vbi_chi2_test(obs, expd, nb, MIN_EXPECTED, SIGNIFICANCE, &res));
    printf("#   cone 0.31 vs 0.3 (must fail) %s\n", res.msg);
    free(obs);
    free(expd);
}

static void test_chi2_p_values(void **state)
{
    (void)state;
    /* Tabulated 1% critical values of the chi-square distribution. */
    assert_true(fabs(vbi_chi2_gamma_q(0.5, 6.635 / 2) - 0.01) < 1e-4);
    assert_true(fabs(vbi_chi2_gamma_q(5.0, 23.209 / 2) - 0.01) < 1e-4);
    assert_true(fabs(vbi_chi2_gamma_q(50.0, 135.807 / 2) - 0.01) < 1e-4);
    assert_true(fabs(vbi_chi2_gamma_q(5.0, 9.342 / 2) - 0.5) < 1e-3);
}

/* ---- disk and triangle --------------------------------------------------------------------- */

static void test_concentric_disk(void **state)
{
    (void)state;
    /* Equal-area bins: uniform in r^2 and in phi. */
    enum { NR = 16, NP = 32, N = 300000 };
    double obs[NR * NP] = {0}, expd[NR * NP];
    for (int i = 0; i < NR * NP; ++i)
        expd[i] = (double)N / (NR * NP);
    vbi_rng rng = vbi_rng_make(21, 3);
    for (int i = 0; i < N; ++i) {
        vec2 d = sample_concentric_disk(vbi_rng_next2(&rng));
        double r2 = (double)d.x * d.x + (double)d.y * d.y;
        assert_true(r2 <= 1.0 + 1e-6);
        double phi = atan2(d.y, d.x);
        if (phi < 0.0)
            phi += 2.0 * M_PI;
        int ir = (int)(r2 * NR), ip = (int)(phi / (2.0 * M_PI) * NP);
        ir = ir >= NR ? NR - 1 : ir;
        ip = ip >= NP ? NP - 1 : ip;
        obs[ir * NP + ip] += 1.0;
    }
    vbi_chi2_result res;
    int ok = vbi_chi2_test(obs, expd, NR * NP, MIN_EXPECTED, SIGNIFICANCE, &res);
    printf("#   concentric disk              %s\n", res.msg);
    assert_true(ok);
}

static void test_uniform_triangle(void **state)
{
    (void)state;
    /* Bin the barycentrics (b1, b2) of the reference triangle on an n x n grid of the unit
     * square: cells below the diagonal hold their full area, cells the diagonal x + y = 1 cuts
     * through corner to corner hold exactly half, the rest nothing. */
    enum { G = 24, N = 300000 };
    double obs[G * G] = {0}, expd[G * G];
    for (int i = 0; i < G; ++i)
        for (int j = 0; j < G; ++j) {
            double frac = i + j + 2 <= G ? 1.0 : (i + j + 1 == G ? 0.5 : 0.0);
            expd[i * G + j] = N * frac / (G * G) / 0.5;
        }
    vbi_rng rng = vbi_rng_make(22, 3);
    int outside = 0;
    for (int k = 0; k < N; ++k) {
        vec2 b = sample_uniform_triangle(vbi_rng_next2(&rng));
        if (b.x < 0.0f || b.y < 0.0f || b.x + b.y > 1.0f)
            ++outside;
        int i = (int)(b.x * G), j = (int)(b.y * G);
        i = i < 0 ? 0 : (i >= G ? G - 1 : i);
        j = j < 0 ? 0 : (j >= G ? G - 1 : j);
        obs[i * G + j] += 1.0;
    }
    vbi_chi2_result res;
    int ok = vbi_chi2_test(obs, expd, G * G, MIN_EXPECTED, SIGNIFICANCE, &res);
    printf("#   uniform triangle             %s\n", res.msg);
    assert_int_equal(outside, 0);
    assert_true(ok);
}

/* ---- alias table --------------------------------------------------------------------------- */

static void test_alias_table_frequencies(void **state)
{
    (void)state;
    enum { N_ITEMS = 50, N = 1000000 };
    float w[N_ITEMS];
    vbi_rng rng = vbi_rng_make(31, 1);
    for (int i = 0; i < N_ITEMS; ++i) {
        /* Spread over three decades, with every seventh weight zero. */
        w[i] = i % 7 == 3 ? 0.0f : powf(10.0f, 3.0f * vbi_rng_next(&rng));
    }
    w[N_ITEMS - 1] = 0.0f; /* a zero at the very end too */
    double total = 0.0;
    for (int i = 0; i < N_ITEMS; ++i)
        total += w[i];

    vbi_alias_table t;
    assert_int_equal(vbi_alias_table_build(&t, w, N_ITEMS), 0);
    assert_int_equal(t.n, N_ITEMS);
    assert_true(fabs(t.total - total) < 1e-6 * total);
    for (int i = 0; i < N_ITEMS; ++i)
        assert_true(fabs(t.pmf[i] - w[i] / total) < 1e-6);

    double obs[N_ITEMS] = {0}, expd[N_ITEMS];
    for (int i = 0; i < N_ITEMS; ++i)
        expd[i] = N * (w[i] / total);
    int pmf_mismatch = 0;
    for (int k = 0; k < N; ++k) {
        float pmf;
        uint32_t i = vbi_alias_table_sample(&t, vbi_rng_next(&rng), &pmf);
        assert_true(i < N_ITEMS);
        if (pmf != t.pmf[i])
            ++pmf_mismatch;
        obs[i] += 1.0;
    }
    for (int i = 0; i < N_ITEMS; ++i)
        if (w[i] == 0.0f)
            assert_true(obs[i] == 0.0); /* a zero-weight item is never sampled */
    assert_int_equal(pmf_mismatch, 0);
    /* The ends of [0, 1) map to valid items with non-zero weight. */
    assert_true(t.pmf[vbi_alias_table_sample(&t, 0.0f, NULL)] > 0.0f);
    assert_true(t.pmf[vbi_alias_table_sample(&t, VBI_ONE_MINUS_EPS, NULL)] > 0.0f);

    vbi_chi2_result res;
    int ok = vbi_chi2_test(obs, expd, N_ITEMS, MIN_EXPECTED, SIGNIFICANCE, &res);
    printf("#   alias table (50 items)       %s\n", res.msg);
    assert_true(ok);
    vbi_alias_table_free(&t);
}

/* sample_reuse: the same item as sample for the same u, and the rescaled rest uniform within each
 * item (chi-square over items x 10 bins of rest), independent of the item; a rest left
 * unrescaled (the slot's raw fraction) fails the same test. */
static void test_alias_table_reuse(void **state)
{
    (void)state;
    enum { N_ITEMS = 12, BINS = 10, N = 600000 };
    float w[N_ITEMS];
    vbi_rng rng = vbi_rng_make(37, 3);
    for (int i = 0; i < N_ITEMS; ++i)
        w[i] = 0.2f + 3.0f * vbi_rng_next(&rng);
    vbi_alias_table t;
    assert_int_equal(vbi_alias_table_build(&t, w, N_ITEMS), 0);
    static double obs[N_ITEMS * BINS], raw[N_ITEMS * BINS], expd[N_ITEMS * BINS];
    for (int k = 0; k < N; ++k) {
        float u = vbi_rng_next(&rng), pmf, rest, frac;
        uint32_t i = vbi_alias_table_sample_reuse(&t, u, &pmf, &rest);
        assert_int_equal(i, vbi_alias_table_sample(&t, u, NULL));
        assert_true(rest >= 0.0f && rest < 1.0f && pmf == t.pmf[i]);
        obs[i * BINS + (int)(rest * BINS)] += 1.0;
        vbi_alias_slot(t.n, u, &frac);
        raw[i * BINS + (int)(frac * BINS)] += 1.0;
    }
    for (int i = 0; i < N_ITEMS; ++i)
        for (int b = 0; b < BINS; ++b)
            expd[i * BINS + b] = N * (double)t.pmf[i] / BINS;
    vbi_chi2_result res, bad;
    int ok = vbi_chi2_test(obs, expd, N_ITEMS * BINS, MIN_EXPECTED, SIGNIFICANCE, &res);
    int raw_ok = vbi_chi2_test(raw, expd, N_ITEMS * BINS, MIN_EXPECTED, SIGNIFICANCE, &bad);
    printf("#   alias reuse (item x rest)    %s\n", res.msg);
    printf("#   raw slot fraction (must fail) %s\n", bad.msg);
    assert_true(ok);
    assert_false(raw_ok);
    vbi_alias_table_free(&t);
}

static void test_alias_table_edge_cases(void **state)
{
    (void)state;
    vbi_alias_table t;
    float zeros[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    assert_int_equal(vbi_alias_table_build(&t, zeros, 4), -1);
    assert_null(t.prob);
    assert_int_equal(t.n, 0);
    vbi_alias_table_free(&t); /* freeing a failed table is harmless */
    vbi_alias_table_free(NULL);
    assert_int_equal(vbi_alias_table_build(&t, zeros, 0), -1);

    /* Negative weights count as zero. */
    float mixed[3] = {-1.0f, 2.0f, 0.0f};
    assert_int_equal(vbi_alias_table_build(&t, mixed, 3), 0);
    for (int k = 0; k < 1000; ++k) {
        float pmf;
        assert_int_equal(vbi_alias_table_sample(&t, (k + 0.5f) / 1000.0f, &pmf), 1);
        assert_true(pmf == 1.0f);
    }
    vbi_alias_table_free(&t);

    float one = 3.0f;
    assert_int_equal(vbi_alias_table_build(&t, &one, 1), 0);
    assert_int_equal(vbi_alias_table_sample(&t, VBI_ONE_MINUS_EPS, NULL), 0);
    vbi_alias_table_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chi2_p_values),
        cmocka_unit_test(test_chi2_detects_wrong_pdf),
        cmocka_unit_test(test_cosine_hemisphere),
        cmocka_unit_test(test_uniform_sphere),
        cmocka_unit_test(test_uniform_hemisphere),
        cmocka_unit_test(test_uniform_cone),
        cmocka_unit_test(test_concentric_disk),
        cmocka_unit_test(test_uniform_triangle),
        cmocka_unit_test(test_alias_table_frequencies),
        cmocka_unit_test(test_alias_table_reuse),
        cmocka_unit_test(test_alias_table_edge_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
