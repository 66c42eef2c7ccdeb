/* Tests for the camera-sample samplers of core/src/sampler.h.
 *
 * The `sobol` sampler must give (a) stratified points: every aligned block of 2^m samples of a
 * pixel's slot is a (0,m,1)-net (1D draws) or a (0,m,2)-net (2D draws), so progressive passes of
 * any length keep the stratification; (b) uniform numbers, independent between slots and between
 * pixels (chi-square tests); (c) unbiased estimates with a far smaller error than independent
 * numbers on a smooth integrand. The `random` sampler must be the PCG stream of (seed, pixel,
 * sample), bit for bit. Seeds are fixed, so every outcome is deterministic. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sampler.h"

#include "../common/chi2.h"

#define SEED 0x5eedull

/* Draws `count` numbers of slot `slot` (its kind: 1 or 2 numbers) of sample `sample`. */
static void draw_slot(uint64_t pixel, uint32_t sample, uint32_t slot, int two, float *u)
{
    vbi_sampler s = vbi_sampler_make(VBNL_SAMPLER_SOBOL, SEED, pixel, sample);
    /* earlier slots of the same kind, so that slot numbers line up */
    for (uint32_t k = 0; k < slot; ++k)
        (void)vbi_sampler_next(&s);
    if (two) {
        vec2 v = vbi_sampler_next2(&s);
        u[0] = v.x;
        u[1] = v.y;
    } else {
        u[0] = vbi_sampler_next(&s);
    }
}

/* Every elementary interval of the block's 2^m points (all shapes 2^a x 2^(m-a)) holds exactly
 * one point. Returns the number of intervals that do not. */
static int net_defects(const float *pts, int dims, int m)
{
    int n = 1 << m, bad = 0;
    int *count = malloc(sizeof(int) * (size_t)n);
    for (int a = 0; a <= (dims == 2 ? m : 0); ++a) {
        int nx = dims == 2 ? 1 << a : n, ny = dims == 2 ? 1 << (m - a) : 1;
        memset(count, 0, sizeof(int) * (size_t)n);
        for (int i = 0; i < n; ++i) {
            int cx = (int)(pts[dims * i] * (float)nx);
            int cy = dims == 2 ? (int)(pts[dims * i + 1] * (float)ny) : 0;
            count[cy * nx + cx]++;
        }
        for (int c = 0; c < n; ++c)
            bad += count[c] != 1;
    }
    free(count);
    return bad;
}

static void test_blocks_are_nets(void **state)
{
    (void)state;
    float *pts = malloc(sizeof(float) * 2 * 4096);
    int checked = 0;
    for (uint64_t pixel = 0; pixel < 3; ++pixel)
        for (uint32_t slot = 0; slot < VBI_SOBOL_SLOTS; ++slot)
            for (int two = 0; two <= 1; ++two)
                for (int m = 2; m <= 12; m += 5) {
                    int n = 1 << m;
                    /* the first block and a later one (a later progressive pass) */
                    for (uint32_t first = 0; first <= (uint32_t)(3 * n); first += (uint32_t)(3 * n)) {
                        for (int i = 0; i < n; ++i)
                            draw_slot(pixel, first + (uint32_t)i, slot, two, pts + (two ? 2 : 1) * i);
                        int bad = net_defects(pts, two ? 2 : 1, m);
                        if (bad)
                            printf("# pixel %llu slot %u %dD: samples %u..%u are not a (0,%d)-net (%d intervals)\n",
                                   (unsigned long long)pixel, slot, two ? 2 : 1, first, first + (uint32_t)n - 1, m,
                                   bad);
                        assert_int_equal(bad, 0);
                        ++checked;
                    }
                }
    free(pts);
    printf("# %d blocks checked\n", checked);
}

/* The net test must be able to fail: independent numbers are not nets. */
static void test_random_is_not_a_net(void **state)
{
    (void)state;
    float pts[2 * 256];
    vbi_rng r = vbi_rng_make(SEED, 3);
    for (int i = 0; i < 256; ++i) {
        pts[2 * i] = vbi_rng_next(&r);
        pts[2 * i + 1] = vbi_rng_next(&r);
    }
    assert_true(net_defects(pts, 2, 8) > 0);
}

/* Beyond the slots, and for the random sampler throughout, the numbers are the PCG stream of
 * (seed, pixel, sample): the random sampler is the renderer's former sampling, bit for bit. */
static void test_streams(void **state)
{
    (void)state;
    for (uint32_t sample = 0; sample < 5; ++sample) {
        vbi_rng ref = vbi_rng_for(SEED, 77, sample);
        vbi_sampler rnd = vbi_sampler_make(VBNL_SAMPLER_RANDOM, SEED, 77, sample);
        for (int k = 0; k < 40; ++k) {
            float a = vbi_rng_next(&ref), b = vbi_sampler_next(&rnd);
            assert_memory_equal(&a, &b, sizeof(a));
        }
        ref = vbi_rng_for(SEED, 77, sample);
        vbi_sampler sob = vbi_sampler_make(VBNL_SAMPLER_SOBOL, SEED, 77, sample);
        for (uint32_t k = 0; k < VBI_SOBOL_SLOTS; ++k)
            (void)vbi_sampler_next2(&sob);
        for (int k = 0; k < 20; ++k) {
            float a = vbi_rng_next(&ref), b = vbi_sampler_next(&sob);
            assert_memory_equal(&a, &b, sizeof(a));
        }
        /* the same (seed, pixel, sample) gives the same numbers */
        vbi_sampler s1 = vbi_sampler_make(VBNL_SAMPLER_SOBOL, SEED, 77, sample);
        vbi_sampler s2 = vbi_sampler_make(VBNL_SAMPLER_SOBOL, SEED, 77, sample);
        for (int k = 0; k < 12; ++k) {
            vec2 a = vbi_sampler_next2(&s1), b = vbi_sampler_next2(&s2);
            assert_memory_equal(&a, &b, sizeof(a));
        }
    }
}

/* Chi-square on a 16 x 16 grid: the pairs must be uniform on the square. */
static int uniform_pairs(const float *u, const float *v, int n, const char *what)
{
    double obs[256] = {0}, expd[256];
    for (int i = 0; i < n; ++i) {
        int cx = (int)(u[i] * 16.0f), cy = (int)(v[i] * 16.0f);
        assert_true(u[i] >= 0.0f && u[i] < 1.0f && v[i] >= 0.0f && v[i] < 1.0f);
        obs[cy * 16 + cx] += 1.0;
    }
    for (int b = 0; b < 256; ++b)
        expd[b] = n / 256.0;
    vbi_chi2_result res;
    int ok = vbi_chi2_test(obs, expd, 256, 5.0, 0.01, &res);
    printf("#   %-44s %s\n", what, res.msg);
    return ok;
}

static void test_uniform_and_independent(void **state)
{
    (void)state;
    enum { PIXELS = 4096, SAMPLES = 4, N = PIXELS * SAMPLES };
    float *a = malloc(sizeof(float) * N), *b = malloc(sizeof(float) * N), *c = malloc(sizeof(float) * N);
    int pass = 1;
    /* the same sample index across pixels: the pixels' scrambles are independent */
    for (int p = 0; p < PIXELS; ++p) {
        vbi_sampler s = vbi_sampler_make(VBNL_SAMPLER_SOBOL, SEED, (uint64_t)p, 0);
        vec2 v = vbi_sampler_next2(&s);
        a[p] = v.x;
        b[p] = v.y;
    }
    pass &= uniform_pairs(a, b, PIXELS, "sample 0 of slot 0 across pixels");
    /* two slots of the same samples: decorrelated by the shuffles */
    for (int p = 0, i = 0; p < PIXELS; ++p)
        for (uint32_t smp = 0; smp < SAMPLES; ++smp, ++i) {
            vbi_sampler s = vbi_sampler_make(VBNL_SAMPLER_SOBOL, SEED, (uint64_t)p, smp);
            vec2 v0 = vbi_sampler_next2(&s);
            float x1 = vbi_sampler_next(&s);
            vec2 v2 = vbi_sampler_next2(&s);
            a[i] = v0.x;
            b[i] = x1;
            c[i] = v2.y;
            (void)v2;
        }
    pass &= uniform_pairs(a, b, N, "slot 0 x against slot 1 (1D)");
    pass &= uniform_pairs(b, c, N, "slot 1 (1D) against slot 2 y");
    pass &= uniform_pairs(a, c, N, "slot 0 x against slot 2 y");
    /* within one pixel, one slot's 4096 samples: x against y (a net: uniform, stratified) */
    for (uint32_t smp = 0; smp < N; ++smp) {
        vbi_sampler s = vbi_sampler_make(VBNL_SAMPLER_SOBOL, SEED, 5, smp);
        (void)vbi_sampler_next(&s);
        vec2 v = vbi_sampler_next2(&s);
        a[smp] = v.x;
        b[smp] = v.y;
    }
    pass &= uniform_pairs(a, b, N, "one pixel, slot 1 (2D)");
    free(a);
    free(b);
    free(c);
    assert_true(pass);
}

/* A smooth integrand over two slots, the shape of a first bounce: f = (1 + cos(pi u)) v^2 + u v
 * over the unit square, whose integral is 1/3 + 1/4 = 7/12. Per pixel, N samples; over many
 * pixels: the mean is unbiased and the RMS error against `random` falls with Owen scrambling's
 * faster rate (variance ~N^-3 for smooth integrands, against N^-1). */
static double integrand(float u, float v) { return (1.0 + cos(M_PI * u)) * v * v + (double)u * v; }

static void rms_error(vbnl_sampler_kind kind, int n, int pixels, double *rms, double *mean)
{
    const double exact = 7.0 / 12.0;
    double se = 0.0, sum = 0.0;
    for (int p = 0; p < pixels; ++p) {
        double est = 0.0;
        for (int i = 0; i < n; ++i) {
            vbi_sampler s = vbi_sampler_make(kind, SEED, (uint64_t)p, (uint32_t)i);
            vec2 pix = vbi_sampler_next2(&s); /* the pixel position, unused here */
            (void)pix;
            vec2 w = vbi_sampler_next2(&s);
            est += integrand(w.x, w.y);
        }
        est /= n;
        se += (est - exact) * (est - exact);
        sum += est;
    }
    *rms = sqrt(se / pixels);
    *mean = sum / pixels;
}

static void test_convergence(void **state)
{
    (void)state;
    const int pixels = 2000;
    const double exact = 7.0 / 12.0;
    for (int n = 16; n <= 64; n *= 4) {
        double rms_s, mean_s, rms_r, mean_r;
        rms_error(VBNL_SAMPLER_SOBOL, n, pixels, &rms_s, &mean_s);
        rms_error(VBNL_SAMPLER_RANDOM, n, pixels, &rms_r, &mean_r);
        printf("# %2d samples: RMS error sobol %.2e, random %.2e (ratio %.3f); mean errors %.1e, %.1e\n", n, rms_s,
               rms_r, rms_s / rms_r, mean_s - exact, mean_r - exact);
        /* unbiased: the mean over pixels within 4 standard errors */
        assert_true(fabs(mean_s - exact) < 4.0 * rms_s / sqrt(pixels) + 1e-6);
        assert_true(fabs(mean_r - exact) < 4.0 * rms_r / sqrt(pixels));
        /* N^-1.5 against N^-0.5: already 4x at 16 samples, 8x at 64 */
        assert_true(rms_s < (n == 16 ? 0.25 : 0.125) * rms_r);
    }
}

static void test_names(void **state)
{
    (void)state;
    vbnl_sampler_kind k = VBNL_SAMPLER_RANDOM;
    vbnl_error err = {0};
    assert_int_equal(vbnl_sampler_find("sobol", &k, &err), VBNL_OK);
    assert_int_equal(k, VBNL_SAMPLER_SOBOL);
    assert_int_equal(vbnl_sampler_find("random", &k, &err), VBNL_OK);
    assert_int_equal(k, VBNL_SAMPLER_RANDOM);
    assert_string_equal(vbnl_sampler_name(VBNL_SAMPLER_SOBOL), "sobol");
    assert_string_equal(vbnl_sampler_name(VBNL_SAMPLER_RANDOM), "random");
    assert_null(vbnl_sampler_name((vbnl_sampler_kind)7));
    assert_int_equal(vbnl_sampler_find("halton", &k, &err), VBNL_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(err.message, "'halton'"));
    assert_non_null(strstr(err.message, "sobol, random"));
    assert_int_equal(vbnl_sampler_find(NULL, &k, &err), VBNL_ERR_INVALID_ARGUMENT);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_blocks_are_nets),
        cmocka_unit_test(test_random_is_not_a_net),
        cmocka_unit_test(test_streams),
        cmocka_unit_test(test_uniform_and_independent),
        cmocka_unit_test(test_convergence),
        cmocka_unit_test(test_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
