/* Tests for the hemispherical octahedral maps (core/integrators/vbnl/octahedral.h).
 *
 * Every test runs at R = 8, 16 and 32 with fixed seeds, so outcomes are deterministic.
 * Statistical checks use 5-sigma bounds per texel plus a chi-square test (p >= 0.01). */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "octahedral.h"
#include "rng.h"
#include "sampling.h"

/* Only the test itself of the shared chi-square header is used here. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include "chi2.h"
#pragma GCC diagnostic pop

static const uint32_t resolutions[] = {8, 16, 32};
#define N_RES (sizeof(resolutions) / sizeof(resolutions[0]))

static vbi_hemioct *make_map(uint32_t res)
{
    vbi_hemioct *m = NULL;
    assert_int_equal(vbi_hemioct_create(res, &m), VBNL_OK);
    assert_non_null(m);
    return m;
}

/* Uniform hemisphere direction computed in double, so the test's own rounding stays far below
 * the tolerances. */
static vec3 uniform_dir(vbi_rng *r)
{
    double z = vbi_rng_next(r);
    double phi = 2.0 * M_PI * vbi_rng_next(r);
    double s = sqrt(fmax(0.0, 1.0 - z * z));
    return v3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)z);
}

static double angle_between(vec3 a, vec3 b)
{
    double ax = a.x, ay = a.y, az = a.z, bx = b.x, by = b.y, bz = b.z;
    double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    return atan2(sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz);
}

/* ---- mapping ------------------------------------------------------------------------------- */

static void test_bad_arguments(void **state)
{
    (void)state;
    vbi_hemioct *m = (vbi_hemioct *)1;
    assert_int_equal(vbi_hemioct_create(1, &m), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(m);
    assert_int_equal(vbi_hemioct_create(VBI_HEMIOCT_MAX_RES + 1, &m), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_hemioct_create(16, NULL), VBNL_ERR_INVALID_ARGUMENT);
    vbi_hemioct_destroy(NULL);
    m = make_map(8);
    float zeros[64] = {0};
    vbi_hemioct_dist *d = (vbi_hemioct_dist *)1;
    assert_int_equal(vbi_hemioct_dist_create(m, zeros, &d), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(d);
    zeros[3] = -1.0f;
    assert_int_equal(vbi_hemioct_dist_create(m, zeros, &d), VBNL_ERR_INVALID_ARGUMENT);
    vbi_hemioct_dist_destroy(NULL);
    vbi_hemioct_destroy(m);
}

static void test_roundtrip(void **state)
{
    (void)state;
    vbi_rng rng = vbi_rng_make(1, 2);
    double worst = 0.0, worst_u = 0.0;
    for (int n = 0; n < 1000000; ++n) {
        vec3 w;
        int kind = n % 4;
        if (kind == 0 || kind == 1) {
            w = uniform_dir(&rng);
        } else if (kind == 2) { /* near the horizon */
            double z = 1e-4 * vbi_rng_next(&rng), phi = 2.0 * M_PI * vbi_rng_next(&rng);
            double s = sqrt(1.0 - z * z);
            w = v3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)z);
        } else { /* near the normal and on the face boundaries (x = 0 or y = 0) */
            double z = 1.0 - 1e-3 * vbi_rng_next(&rng), s = sqrt(1.0 - z * z);
            double phi = (n & 4) ? 0.5 * M_PI * (double)(n % 5) : 2.0 * M_PI * vbi_rng_next(&rng);
            w = v3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)z);
        }
        vec2 u = vbi_hemioct_encode(w);
        assert_true(u.x >= 0.0f && u.x <= 1.0f && u.y >= 0.0f && u.y <= 1.0f);
        vec3 d = vbi_hemioct_decode(u);
        assert_true(d.z >= 0.0f);
        assert_true(fabs(v3_len(d) - 1.0) < 1e-6);
        double a = angle_between(v3_norm(w), d);
        if (a > worst)
            worst = a;
        /* The other direction: u -> w -> u. */
        vec2 uu = vbi_rng_next2(&rng);
        vec2 back = vbi_hemioct_encode(vbi_hemioct_decode(uu));
        double du = fmax(fabs(back.x - uu.x), fabs(back.y - uu.y));
        if (du > worst_u)
            worst_u = du;
    }
    print_message("# worst round-trip angle %.3g rad, worst square error %.3g\n", worst, worst_u);
    assert_true(worst < 1e-5);
    assert_true(worst_u < 1e-5);

    /* Special points: normal -> centre, the four octahedron vertices on the horizon -> corners,
     * mirror about the normal -> 1 - u. */
    vec2 c = vbi_hemioct_encode(v3(0, 0, 1));
    assert_true(fabsf(c.x - 0.5f) < 1e-7f && fabsf(c.y - 0.5f) < 1e-7f);
    vec2 px = vbi_hemioct_encode(v3(1, 0, 0));
    assert_true(px.x == 1.0f && px.y == 1.0f);
    vec2 nx = vbi_hemioct_encode(v3(-1, 0, 0));
    assert_true(nx.x == 0.0f && nx.y == 0.0f);
    for (int n = 0; n < 1000; ++n) {
        vec3 w = uniform_dir(&rng);
        vec2 a = vbi_hemioct_encode(w), b = vbi_hemioct_encode(v3(-w.x, -w.y, w.z));
        assert_true(fabsf(a.x + b.x - 1.0f) < 1e-6f && fabsf(a.y + b.y - 1.0f) < 1e-6f);
    }
    /* Below the horizon: projected onto it. */
    vec3 below = vbi_hemioct_decode(vbi_hemioct_encode(v3(0.6f, 0.0f, -0.8f)));
    assert_true(fabsf(below.x - 1.0f) < 1e-6f && fabsf(below.z) < 1e-6f);
}

static void test_texel_lookup(void **state)
{
    (void)state;
    vbi_rng rng = vbi_rng_make(3, 4);
    for (size_t r = 0; r < N_RES; ++r) {
        uint32_t res = resolutions[r];
        vbi_hemioct *m = make_map(res);
        assert_int_equal(vbi_hemioct_res(m), res);
        assert_int_equal(vbi_hemioct_texel_count(m), res * res);
        for (int n = 0; n < 200000; ++n) {
            vec3 w = uniform_dir(&rng);
            vec2 u = vbi_hemioct_encode(w);
            uint32_t t = vbi_hemioct_texel(m, w);
            uint32_t i = (uint32_t)fminf(u.x * res, res - 1), j = (uint32_t)fminf(u.y * res, res - 1);
            assert_int_equal(t, j * res + i);
            /* The texel's centre is within half a texel of u in each coordinate. */
            vec2 cu = vbi_hemioct_encode(vbi_hemioct_texel_dir(m, t));
            assert_true(fabsf(cu.x - u.x) <= 0.5f / res + 1e-6f && fabsf(cu.y - u.y) <= 0.5f / res + 1e-6f);
        }
        for (uint32_t t = 0; t < res * res; ++t) {
            vec3 d = vbi_hemioct_texel_dir(m, t);
            assert_int_equal(vbi_hemioct_texel(m, d), t);
            vec2 cu = vbi_hemioct_encode(d);
            assert_true(fabsf(cu.x - ((t % res) + 0.5f) / res) < 1e-6f);
            assert_true(fabsf(cu.y - ((t / res) + 0.5f) / res) < 1e-6f);
            assert_true(d.z > 0.0f);
        }
        vbi_hemioct_destroy(m);
    }
}

/* ---- solid angles -------------------------------------------------------------------------- */

static void test_solid_angle_sum_and_jacobian(void **state)
{
    (void)state;
    for (size_t r = 0; r < N_RES; ++r) {
        uint32_t res = resolutions[r];
        vbi_hemioct *m = make_map(res);
        double sum = 0.0, sum_b = 0.0, sum_c = 0.0, worst = 0.0;
        for (uint32_t t = 0; t < res * res; ++t) {
            double om = vbi_hemioct_texel_solid_angle(m, t);
            sum += om;
            sum_b += vbi_hemioct_texel_bilinear_solid_angle(m, t);
            sum_c += vbi_hemioct_texel_bilinear_projected(m, t);
            /* Independent check of the exact value: integrate the Jacobian over the texel with
             * a 64 x 64 midpoint rule. */
            double q = 0.0, h = 1.0 / (res * 64.0);
            for (int y = 0; y < 64; ++y)
                for (int x = 0; x < 64; ++x) {
                    vec2 u = {(float)(((t % res) * 64 + x + 0.5) * h), (float)(((t / res) * 64 + y + 0.5) * h)};
                    q += vbi_hemioct_jacobian(u) * h * h;
                }
            worst = fmax(worst, fabs(q / om - 1.0));
        }
        print_message("# R=%u: sum Omega - 2pi = %.3g, sum B - 2pi = %.3g, sum C - pi = %.3g, "
                      "Jacobian quadrature vs exact: %.3g\n",
                      res, sum - 2.0 * M_PI, sum_b - 2.0 * M_PI, sum_c - M_PI, worst);
        assert_true(fabs(sum / (2.0 * M_PI) - 1.0) < 1e-5);
        assert_true(fabs(sum_b / (2.0 * M_PI) - 1.0) < 1e-5);
        assert_true(fabs(sum_c / M_PI - 1.0) < 1e-5);
        assert_true(worst < 1e-4);
        vbi_hemioct_destroy(m);
    }
}

static void test_solid_angle_monte_carlo(void **state)
{
    (void)state;
    const int n = 4000000;
    for (size_t r = 0; r < N_RES; ++r) {
        uint32_t res = resolutions[r], cnt = res * res;
        vbi_hemioct *m = make_map(res);
        double *obs = calloc(cnt, sizeof(double)), *expd = calloc(cnt, sizeof(double));
        vbi_rng rng = vbi_rng_make(11 + r, 5);
        for (int k = 0; k < n; ++k)
            obs[vbi_hemioct_texel(m, uniform_dir(&rng))] += 1.0;
        double worst_z = 0.0;
        for (uint32_t t = 0; t < cnt; ++t) {
            double p = vbi_hemioct_texel_solid_angle(m, t) / (2.0 * M_PI);
            expd[t] = n * p;
            double z = fabs(obs[t] - expd[t]) / sqrt(n * p * (1.0 - p));
            worst_z = fmax(worst_z, z);
        }
        vbi_chi2_result cr;
        int ok = vbi_chi2_test(obs, expd, (int)cnt, 5.0, 0.01, &cr);
        print_message("# R=%u: worst texel z-score %.2f, %s\n", res, worst_z, cr.msg);
        assert_true(worst_z < 5.0);
        assert_true(ok);
        free(obs);
        free(expd);
        vbi_hemioct_destroy(m);
    }
}

/* ---- splat and lookup ---------------------------------------------------------------------- */

static void test_splat_unit_energy(void **state)
{
    (void)state;
    vbi_rng rng = vbi_rng_make(7, 8);
    for (size_t r = 0; r < N_RES; ++r) {
        uint32_t res = resolutions[r], cnt = res * res;
        vbi_hemioct *m = make_map(res);
        float *map = calloc(3 * (size_t)cnt, sizeof(float));
        for (int n = 0; n < 20000; ++n) {
            vec3 w;
            if (n % 3 == 0) /* on the horizon: the clamped band and the corners */
                w = v3(cosf(6.2831853f * vbi_rng_next(&rng)), sinf(6.2831853f * vbi_rng_next(&rng)), 0.0f);
            else
                w = uniform_dir(&rng);
            memset(map, 0, 3 * (size_t)cnt * sizeof(float));
            vbi_hemioct_splat(m, map, w, v3(1.0f, 2.0f, 0.5f));
            double s[3] = {0, 0, 0};
            for (uint32_t t = 0; t < cnt; ++t)
                for (int c = 0; c < 3; ++c) {
                    assert_true(map[3 * t + c] >= 0.0f);
                    s[c] += map[3 * t + c];
                }
            assert_true(fabs(s[0] - 1.0) < 1e-6 && fabs(s[1] - 2.0) < 2e-6 && fabs(s[2] - 0.5) < 1e-6);
            uint32_t idx[4];
            float wgt[4];
            vbi_hemioct_bilinear(m, w, idx, wgt);
            assert_true(fabsf(wgt[0] + wgt[1] + wgt[2] + wgt[3] - 1.0f) < 1e-6f);
        }
        /* Corners exactly. */
        vec3 corners[4] = {v3(1, 0, 0), v3(-1, 0, 0), v3(0, 1, 0), v3(0, -1, 0)};
        for (int k = 0; k < 4; ++k) {
            memset(map, 0, 3 * (size_t)cnt * sizeof(float));
            vbi_hemioct_splat(m, map, corners[k], v3s(1.0f));
            float mx = 0.0f;
            for (uint32_t t = 0; t < cnt; ++t)
                mx = fmaxf(mx, map[3 * t]);
            assert_true(mx == 1.0f); /* all four footprint corners clamp to the corner texel */
        }
        free(map);
        vbi_hemioct_destroy(m);
    }
}

static void test_splat_uniform_proportional_to_solid_angle(void **state)
{
    (void)state;
    const int n = 4000000;
    /* Documented bounds on |B_t / Omega_t - 1| (octahedral.h), plus 5 sigma of noise below. */
    const double ratio_tol[N_RES] = {0.074, 0.034, 0.016};
    for (size_t r = 0; r < N_RES; ++r) {
        uint32_t res = resolutions[r], cnt = res * res;
        vbi_hemioct *m = make_map(res);
        float *map = calloc(3 * (size_t)cnt, sizeof(float));
        vbi_rng rng = vbi_rng_make(21 + r, 9);
        for (int k = 0; k < n; ++k)
            vbi_hemioct_splat(m, map, uniform_dir(&rng), v3s(1.0f));
        double worst_z = 0.0, worst_ratio = 0.0;
        for (uint32_t t = 0; t < cnt; ++t) {
            /* E[value] = n B_t / 2pi; Var <= n E[w^2] <= n E[w] since weights are in [0, 1]. */
            double e = n * vbi_hemioct_texel_bilinear_solid_angle(m, t) / (2.0 * M_PI);
            double z = fabs(map[3 * t] - e) / sqrt(e);
            worst_z = fmax(worst_z, z);
            double omega = 2.0 * M_PI * map[3 * t] / n;
            double dev = fabs(omega / vbi_hemioct_texel_solid_angle(m, t) - 1.0);
            assert_true(dev < ratio_tol[r] + 5.0 / sqrt(e));
            worst_ratio = fmax(worst_ratio, dev);
        }
        print_message("# R=%u: splat vs B_t worst z %.2f; splat vs Omega_t worst relative %.4f\n", res,
                      worst_z, worst_ratio);
        assert_true(worst_z < 5.0);
        free(map);
        vbi_hemioct_destroy(m);
    }
}

static void test_lookup(void **state)
{
    (void)state;
    vbi_rng rng = vbi_rng_make(31, 2);
    for (size_t r = 0; r < N_RES; ++r) {
        uint32_t res = resolutions[r], cnt = res * res;
        vbi_hemioct *m = make_map(res);
        float *map = malloc(3 * (size_t)cnt * sizeof(float));
        /* Constant map: lookup is the constant everywhere. */
        for (uint32_t t = 0; t < 3 * cnt; ++t)
            map[t] = 0.25f;
        for (int n = 0; n < 10000; ++n) {
            vec3 v = vbi_hemioct_lookup(m, map, uniform_dir(&rng));
            assert_true(fabsf(v.x - 0.25f) < 1e-6f);
        }
        /* Map linear in u: bilinear interpolation reproduces it exactly away from the clamped
         * border band, and texel centres return texel values. */
        for (uint32_t t = 0; t < cnt; ++t) {
            float ux = ((t % res) + 0.5f) / res, uy = ((t / res) + 0.5f) / res;
            map[3 * t] = 2.0f * ux + 3.0f * uy;
            map[3 * t + 1] = (float)t;
            map[3 * t + 2] = 0.0f;
        }
        for (uint32_t t = 0; t < cnt; ++t) {
            vec3 v = vbi_hemioct_lookup(m, map, vbi_hemioct_texel_dir(m, t));
            assert_true(fabsf(v.y - (float)t) < 1e-3f * (1.0f + t));
        }
        for (int n = 0; n < 10000; ++n) {
            vec2 u = {0.5f / res + (1.0f - 1.0f / res) * vbi_rng_next(&rng),
                      0.5f / res + (1.0f - 1.0f / res) * vbi_rng_next(&rng)};
            vec3 w = vbi_hemioct_decode(u);
            vec2 ue = vbi_hemioct_encode(w);
            vec3 v = vbi_hemioct_lookup(m, map, w);
            assert_true(fabsf(v.x - (2.0f * ue.x + 3.0f * ue.y)) < 1e-4f);
        }
        free(map);
        vbi_hemioct_destroy(m);
    }
}

typedef struct splat_job {
    const vbi_hemioct *map;
    float *rgb;
    uint64_t seed;
    int n;
} splat_job;

static void *splat_worker(void *arg)
{
    splat_job *j = arg;
    vbi_rng rng = vbi_rng_make(j->seed, 1);
    for (int k = 0; k < j->n; ++k)
        vbi_hemioct_splat_atomic(j->map, j->rgb, uniform_dir(&rng), v3(1.0f, 0.5f, 0.25f));
    return NULL;
}

static void test_atomic_splat_threads(void **state)
{
    (void)state;
    vbi_hemioct *m = make_map(8); /* few texels: heavy contention */
    float *a = calloc(3 * 64, sizeof(float)), *b = calloc(3 * 64, sizeof(float));
    enum { THREADS = 4, PER = 100000 };
    pthread_t th[THREADS];
    splat_job jobs[THREADS];
    for (int i = 0; i < THREADS; ++i) {
        jobs[i] = (splat_job){m, a, 100 + (uint64_t)i, PER};
        assert_int_equal(pthread_create(&th[i], NULL, splat_worker, &jobs[i]), 0);
    }
    for (int i = 0; i < THREADS; ++i)
        pthread_join(th[i], NULL);
    for (int i = 0; i < THREADS; ++i) { /* the same work sequentially, non-atomic */
        vbi_rng rng = vbi_rng_make(100 + (uint64_t)i, 1);
        for (int k = 0; k < PER; ++k)
            vbi_hemioct_splat(m, b, uniform_dir(&rng), v3(1.0f, 0.5f, 0.25f));
    }
    double sa = 0.0;
    for (int t = 0; t < 64; ++t) {
        sa += a[3 * t];
        /* Float sums in a different order: equal to rounding. */
        assert_true(fabsf(a[3 * t] - b[3 * t]) <= 1e-4f * b[3 * t] + 1e-3f);
        assert_true(fabsf(a[3 * t + 2] - 0.25f * a[3 * t]) <= 1e-4f * a[3 * t] + 1e-3f);
    }
    assert_true(fabs(sa - THREADS * PER) < 1e-4 * THREADS * PER);
    free(a);
    free(b);
    vbi_hemioct_destroy(m);
}

/* ---- sampling ------------------------------------------------------------------------------ */

static void test_dist_sampling(void **state)
{
    (void)state;
    for (size_t r = 0; r < N_RES; ++r) {
        uint32_t res = resolutions[r], cnt = res * res;
        vbi_hemioct *m = make_map(res);
        float *w = malloc(cnt * sizeof(float));
        vbi_rng rng = vbi_rng_make(41 + r, 3);
        /* A lobe-like target with some zero texels. */
        for (uint32_t t = 0; t < cnt; ++t) {
            vec3 d = vbi_hemioct_texel_dir(m, t);
            w[t] = (t % 7 == 3) ? 0.0f : powf(fmaxf(d.x * 0.5f + d.z * 0.866f, 0.0f), 8.0f) + 0.05f;
        }
        vbi_hemioct_dist *dist = NULL;
        assert_int_equal(vbi_hemioct_dist_create(m, w, &dist), VBNL_OK);
        const int n = 1000000;
        double *obs = calloc(cnt, sizeof(double)), *expd = calloc(cnt, sizeof(double));
        double sum_cos_over_pdf = 0.0, worst_pdf = 0.0, target = 0.0;
        for (int k = 0; k < n; ++k) {
            float pdf;
            vec3 d = vbi_hemioct_dist_sample(dist, vbi_rng_next(&rng), vbi_rng_next2(&rng), &pdf);
            assert_true(pdf > 0.0f && d.z >= 0.0f);
            uint32_t t = vbi_hemioct_texel(m, d);
            obs[t] += 1.0;
            float pdf2 = vbi_hemioct_dist_pdf(dist, d);
            /* Same texel except at texel borders, where rounding may pick the neighbour. */
            vec2 ud = vbi_hemioct_encode(d);
            float bx = ud.x * res - floorf(ud.x * res + 0.5f), by = ud.y * res - floorf(ud.y * res + 0.5f);
            if (fabsf(bx) > 1e-3f && fabsf(by) > 1e-3f)
                worst_pdf = fmax(worst_pdf, fabs(pdf2 / pdf - 1.0));
            /* Unbiasedness over the support: E[g / pdf] = integral of g over nonzero texels. */
            sum_cos_over_pdf += d.z / pdf;
        }
        for (uint32_t t = 0; t < cnt; ++t) {
            expd[t] = n * (double)vbi_hemioct_dist_pmf(dist, t);
            if (w[t] > 0.0f) {
                /* integral of cos over the texel = C_t would be the bilinear version; use a
                 * 32 x 32 midpoint rule of cos * jacobian over the texel instead. */
                double h = 1.0 / (res * 32.0);
                for (int y = 0; y < 32; ++y)
                    for (int x = 0; x < 32; ++x) {
                        vec2 u = {(float)(((t % res) * 32 + x + 0.5) * h),
                                  (float)(((t / res) * 32 + y + 0.5) * h)};
                        target += vbi_hemioct_decode(u).z * vbi_hemioct_jacobian(u) * h * h;
                    }
            } else {
                /* Only rounding at a texel border can put a sample here. */
                assert_true(vbi_hemioct_dist_pmf(dist, t) == 0.0f);
                assert_true(obs[t] <= n * 1e-5);
            }
        }
        vbi_chi2_result cr;
        int ok = vbi_chi2_test(obs, expd, (int)cnt, 5.0, 0.01, &cr);
        double est = sum_cos_over_pdf / n;
        print_message("# R=%u: %s; E[cos/pdf] = %.5f vs %.5f; pdf mismatch %.2g\n", res, cr.msg, est, target,
                      worst_pdf);
        assert_true(ok);
        assert_true(fabs(est / target - 1.0) < 0.01);
        assert_true(worst_pdf < 1e-3);
        /* The pdf integrates to one: a 512 x 512 midpoint rule of pdf(decode(u)) jacobian(u). */
        double ip = 0.0, h = 1.0 / 512.0;
        for (int y = 0; y < 512; ++y)
            for (int x = 0; x < 512; ++x) {
                vec2 u = {(float)((x + 0.5) * h), (float)((y + 0.5) * h)};
                ip += vbi_hemioct_dist_pdf(dist, vbi_hemioct_decode(u)) * vbi_hemioct_jacobian(u) * h * h;
            }
        print_message("# R=%u: integral of the pdf = %.6f\n", res, ip);
        assert_true(fabs(ip - 1.0) < 1e-4);
        free(obs);
        free(expd);
        free(w);
        vbi_hemioct_dist_destroy(dist);
        vbi_hemioct_destroy(m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_roundtrip),
        cmocka_unit_test(test_texel_lookup),
        cmocka_unit_test(test_solid_angle_sum_and_jacobian),
        cmocka_unit_test(test_solid_angle_monte_carlo),
        cmocka_unit_test(test_splat_unit_energy),
        cmocka_unit_test(test_splat_uniform_proportional_to_solid_angle),
        cmocka_unit_test(test_lookup),
        cmocka_unit_test(test_atomic_splat_threads),
        cmocka_unit_test(test_dist_sampling),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
