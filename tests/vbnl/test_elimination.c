/* Tests for VBNL sample elimination (core/integrators/vbnl/elimination.h, paper section 3.2).
 *
 * Blue-noise quality is measured as the relative radius of Lagae and Dutre: a kept point's
 * nearest-neighbour distance over 2 r_max (hexagonal packing = 1, random subset ~ 0.47). The
 * metric is computed here by an independent sweep over x-sorted points, and compared once with
 * vbi_elim_measure. Inputs come from fixed seeds, so every outcome is deterministic. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "elimination.h"
#include "kdtree.h"
#include "pool.h"
#include "rng.h"

/* ---- inputs ---------------------------------------------------------------------------------- */

/* Uniform points on the unit square z = 0. With `dense_left`, x < 0.5 is 4x denser than x > 0.5. */
static vec3 *make_plane(uint32_t M, uint64_t seed, int dense_left)
{
    vec3 *p = malloc((size_t)M * sizeof(vec3));
    assert_non_null(p);
    vbi_rng rng = vbi_rng_make(seed, 11);
    for (uint32_t i = 0; i < M; ++i) {
        float x = vbi_rng_next(&rng), y = vbi_rng_next(&rng);
        if (dense_left)
            x = i < M / 5 * 4 ? 0.5f * x : 0.5f + 0.5f * x;
        p[i] = v3(x, y, 0.0f);
    }
    return p;
}

/* A bumpy height field over the unit square (a curved surface, as in the paper's scenes). */
static vec3 *make_bumpy(uint32_t M, uint64_t seed)
{
    vec3 *p = malloc((size_t)M * sizeof(vec3));
    assert_non_null(p);
    vbi_rng rng = vbi_rng_make(seed, 13);
    for (uint32_t i = 0; i < M; ++i) {
        float x = vbi_rng_next(&rng), y = vbi_rng_next(&rng);
        p[i] = v3(x, y, 0.08f * sinf(6.0f * VBI_PI * x) * sinf(4.0f * VBI_PI * y));
    }
    return p;
}

typedef struct run {
    uint32_t *kept;
    float *rmax;
    vbi_elim_stats stats;
} run;

static vbnl_result run_elim(const vec3 *pts, uint32_t M, const vbi_elim_params *p, vbi_pool *pool,
                            run *out)
{
    out->kept = malloc((size_t)p->target * sizeof(uint32_t));
    out->rmax = malloc((size_t)p->target * sizeof(float));
    assert_non_null(out->kept);
    assert_non_null(out->rmax);
    vbi_elim_exec ex = vbi_elim_exec_pool(pool);
    vbnl_error err = {0};
    vbnl_result r = vbi_eliminate(pts, M, p, &ex, out->kept, out->rmax, &out->stats, &err);
    if (r != VBNL_OK)
        print_message("# vbi_eliminate: %s\n", err.message);
    return r;
}

static void run_free(run *r)
{
    free(r->kept);
    free(r->rmax);
}

/* ---- independent quality metric ------------------------------------------------------------ */

typedef struct sx {
    vec3 p;
    float r;
} sx;

static int cmp_sx(const void *a, const void *b)
{
    float x = ((const sx *)a)->p.x, y = ((const sx *)b)->p.x;
    return (x > y) - (x < y);
}

/* Mean and minimum of NN distance / (2 r_max) by a sweep over x-sorted kept points. */
static void quality(const vec3 *pts, const run *r, uint32_t n, double *mean, double *mn)
{
    sx *s = malloc((size_t)n * sizeof(sx));
    assert_non_null(s);
    for (uint32_t i = 0; i < n; ++i) {
        s[i].p = pts[r->kept[i]];
        s[i].r = r->rmax[i];
    }
    qsort(s, n, sizeof(sx), cmp_sx);
    double sum = 0.0, lo = INFINITY;
    for (uint32_t i = 0; i < n; ++i) {
        double best = INFINITY;
        for (uint32_t j = i + 1; j < n && (double)(s[j].p.x - s[i].p.x) < best; ++j)
            best = fmin(best, (double)v3_len(v3_sub(s[j].p, s[i].p)));
        for (uint32_t j = i; j-- > 0 && (double)(s[i].p.x - s[j].p.x) < best;)
            best = fmin(best, (double)v3_len(v3_sub(s[j].p, s[i].p)));
        double rel = best / (2.0 * s[i].r);
        sum += rel;
        lo = fmin(lo, rel);
    }
    *mean = sum / n;
    *mn = lo;
    free(s);
}

static void check_kept(const run *r, uint32_t M, uint32_t N)
{
    for (uint32_t i = 0; i < N; ++i) {
        assert_true(r->kept[i] < M);
        if (i > 0)
            assert_true(r->kept[i] > r->kept[i - 1]); /* increasing, hence unique */
        assert_true(isfinite(r->rmax[i]) && r->rmax[i] > 0.0f);
    }
}

/* ---- tests ----------------------------------------------------------------------------------- */

/* Exactly N kept, unique, valid, in every mode, serial and parallel, at sizes that give the
 * parallel variant 64, 8 and no leaf boxes. */
static void test_keeps_exactly_n(void **state)
{
    (void)state;
    vbi_pool *pool = vbi_pool_create(2);
    assert_non_null(pool);
    const uint32_t sizes[][2] = {{40000, 4000}, {5000, 777}, {300, 299}, {300, 300}, {2000, 1}};
    for (size_t s = 0; s < sizeof(sizes) / sizeof(sizes[0]); ++s) {
        uint32_t M = sizes[s][0], N = sizes[s][1];
        vec3 *pts = make_bumpy(M, 100 + s);
        for (int mode = VBI_ELIM_NONE; mode <= VBI_ELIM_ADAPTIVE; ++mode)
            for (int par = 0; par < 2; ++par) {
                vbi_elim_params p;
                vbi_elim_params_default(&p, N);
                p.mode = (vbi_elim_mode)mode;
                p.parallel = par;
                run r;
                assert_int_equal(run_elim(pts, M, &p, par ? pool : NULL, &r), VBNL_OK);
                check_kept(&r, M, N);
                if (par && mode != VBI_ELIM_NONE && N < M)
                    assert_int_equal(r.stats.levels, M >= 32768 ? 3 : (M >= 4096 ? 2 : 1));
                run_free(&r);
            }
        free(pts);
    }
    vbi_pool_destroy(pool);
}

/* 100K uniform candidates on a plane -> 10K: elimination gives blue noise (relative mean NN
 * radius >= 0.75), a random subset does not (< 0.6), so the threshold can fail. */
static void test_blue_noise_plane(void **state)
{
    (void)state;
    const uint32_t M = 100000, N = 10000;
    vec3 *pts = make_plane(M, 7, 0);
    /* blue: 1 = default (weight limiting), 2 = plain weight of the notes (limit 0.72), 0 = none */
    const struct { vbi_elim_mode mode; double area; int blue; } cases[] = {
        {VBI_ELIM_UNIFORM, 1.0, 1}, {VBI_ELIM_UNIFORM, 0.0, 1}, {VBI_ELIM_ADAPTIVE, 0.0, 1},
        {VBI_ELIM_ADAPTIVE, 0.0, 2}, {VBI_ELIM_NONE, 0.0, 0}};
    for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); ++c) {
        vbi_elim_params p;
        vbi_elim_params_default(&p, N);
        p.mode = cases[c].mode;
        p.surface_area = cases[c].area;
        p.weight_limit = cases[c].blue != 2;
        run r;
        assert_int_equal(run_elim(pts, M, &p, NULL, &r), VBNL_OK);
        double mean, mn, mean2, mn2;
        quality(pts, &r, N, &mean, &mn);
        assert_int_equal(vbi_elim_measure(pts, r.kept, r.rmax, N, &mean2, &mn2, NULL), VBNL_OK);
        assert_true(fabs(mean - mean2) < 1e-5 && fabs(mn - mn2) < 1e-5);
        print_message("#   mode %d area %.1f limit %d: mean NN/2r_max %.4f  min %.4f  (area used %.4f)\n",
                      (int)cases[c].mode, cases[c].area, p.weight_limit, mean, mn, r.stats.area);
        if (cases[c].blue == 1)
            assert_true(mean >= 0.75);
        else if (cases[c].blue == 2)
            assert_true(mean >= 0.72);
        else
            assert_true(mean < 0.6);
        if (cases[c].mode == VBI_ELIM_UNIFORM && cases[c].area == 0.0)
            assert_true(fabs(r.stats.area - 1.0) < 0.05); /* estimate of the unit square */
        run_free(&r);
    }
    free(pts);
}

/* The paper's Fig. 8 case scaled to CI (130K -> 13K on a curved surface): the box-parallel
 * variant matches the serial one's quality. */
static void test_serial_vs_parallel(void **state)
{
    (void)state;
    const uint32_t M = 130000, N = 13000;
    vec3 *pts = make_bumpy(M, 8);
    vbi_pool *pool = vbi_pool_create(2);
    assert_non_null(pool);
    double mean[2], mn[2];
    for (int par = 0; par < 2; ++par) {
        vbi_elim_params p;
        vbi_elim_params_default(&p, N);
        p.parallel = par;
        run r;
        assert_int_equal(run_elim(pts, M, &p, pool, &r), VBNL_OK);
        check_kept(&r, M, N);
        quality(pts, &r, N, &mean[par], &mn[par]);
        print_message("#   %s: mean NN/2r_max %.4f  min %.4f  (%.3f s)\n", par ? "parallel" : "serial  ",
                      mean[par], mn[par], r.stats.time_radius + r.stats.time_eliminate);
        run_free(&r);
    }
    print_message("#   parallel/serial: mean %.4f  min-distance ratio %.4f\n", mean[1] / mean[0], mn[1] / mn[0]);
    assert_true(fabs(mean[1] / mean[0] - 1.0) <= 0.05);
    assert_true(mean[0] >= 0.7 && mean[1] >= 0.7);
    vbi_pool_destroy(pool);
    free(pts);
}

static void density_ratio(const vec3 *pts, const run *r, uint32_t N, double *ratio)
{
    uint32_t left = 0, right = 0;
    for (uint32_t i = 0; i < N; ++i) {
        float x = pts[r->kept[i]].x;
        left += x > 0.05f && x < 0.45f;
        right += x > 0.55f && x < 0.95f;
    }
    *ratio = (double)left / (double)(right ? right : 1);
}

/* Fig. 7: adaptive elimination keeps the candidates' density variation (4:1 here, within 15 %),
 * uniform elimination flattens it. */
static void test_adaptive_density(void **state)
{
    (void)state;
    const uint32_t M = 100000, N = 10000;
    vec3 *pts = make_plane(M, 9, 1);
    vbi_pool *pool = vbi_pool_create(2);
    assert_non_null(pool);
    const struct { vbi_elim_mode mode; int parallel; } cases[] = {
        {VBI_ELIM_ADAPTIVE, 0}, {VBI_ELIM_ADAPTIVE, 1}, {VBI_ELIM_UNIFORM, 0}, {VBI_ELIM_UNIFORM, 1}};
    for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); ++c) {
        vbi_elim_params p;
        vbi_elim_params_default(&p, N);
        p.mode = cases[c].mode;
        p.parallel = cases[c].parallel;
        p.surface_area = 1.0;
        run r;
        assert_int_equal(run_elim(pts, M, &p, pool, &r), VBNL_OK);
        double ratio, mean, mn;
        density_ratio(pts, &r, N, &ratio);
        quality(pts, &r, N, &mean, &mn);
        print_message("#   %s %s: dense/sparse kept %.3f  mean NN/2r_max %.4f\n",
                      cases[c].mode == VBI_ELIM_ADAPTIVE ? "adaptive" : "uniform ",
                      cases[c].parallel ? "parallel" : "serial  ", ratio, mean);
        if (cases[c].mode == VBI_ELIM_ADAPTIVE) {
            assert_true(fabs(ratio / 4.0 - 1.0) <= 0.15);
            assert_true(mean >= 0.7);
        } else {
            assert_true(ratio < 2.0);
        }
        run_free(&r);
    }
    vbi_pool_destroy(pool);
    free(pts);
}

/* The parallel result does not depend on the number of threads (or on having a pool at all). */
static void test_determinism(void **state)
{
    (void)state;
    const uint32_t M = 60000, N = 6000;
    vec3 *pts = make_bumpy(M, 10);
    vbi_pool *p1 = vbi_pool_create(1), *p2 = vbi_pool_create(2);
    assert_non_null(p1);
    assert_non_null(p2);
    for (int mode = VBI_ELIM_NONE; mode <= VBI_ELIM_ADAPTIVE; ++mode) {
        vbi_elim_params p;
        vbi_elim_params_default(&p, N);
        p.mode = (vbi_elim_mode)mode;
        p.parallel = 1;
        p.seed = 42;
        run a, b, c;
        assert_int_equal(run_elim(pts, M, &p, p1, &a), VBNL_OK);
        assert_int_equal(run_elim(pts, M, &p, p2, &b), VBNL_OK);
        assert_int_equal(run_elim(pts, M, &p, NULL, &c), VBNL_OK);
        assert_memory_equal(a.kept, b.kept, N * sizeof(uint32_t));
        assert_memory_equal(a.rmax, b.rmax, N * sizeof(float));
        assert_memory_equal(a.kept, c.kept, N * sizeof(uint32_t));
        if (mode == VBI_ELIM_NONE) { /* the seed matters there, and only there */
            run d;
            p.seed = 43;
            assert_int_equal(run_elim(pts, M, &p, p2, &d), VBNL_OK);
            assert_true(memcmp(a.kept, d.kept, N * sizeof(uint32_t)) != 0);
            run_free(&d);
        }
        run_free(&a);
        run_free(&b);
        run_free(&c);
    }
    vbi_pool_destroy(p1);
    vbi_pool_destroy(p2);
    free(pts);
}

static void expect_error(const vec3 *pts, uint32_t M, const vbi_elim_params *p, uint32_t *kept,
                         vbnl_result code, const char *word)
{
    vbnl_error err = {0};
    vbnl_result r = vbi_eliminate(pts, M, p, NULL, kept, NULL, NULL, &err);
    assert_int_equal(r, code);
    assert_int_equal(err.code, code);
    if (!strstr(err.message, word))
        print_message("# message \"%s\" lacks \"%s\"\n", err.message, word);
    assert_non_null(strstr(err.message, word));
    /* a NULL error record is allowed too */
    assert_int_equal(vbi_eliminate(pts, M, p, NULL, kept, NULL, NULL, NULL), code);
}

static void test_bad_inputs(void **state)
{
    (void)state;
    const uint32_t M = 1000;
    vec3 *pts = make_plane(M, 12, 0);
    uint32_t kept[M];
    vbi_elim_params p, q;
    vbi_elim_params_default(&p, 100);
    vbnl_error err = {0};
    assert_int_equal(vbi_eliminate(NULL, M, &p, NULL, kept, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "points"));
    assert_int_equal(vbi_eliminate(pts, M, NULL, NULL, kept, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_eliminate(pts, M, &p, NULL, NULL, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "out_kept"));
    expect_error(pts, 0, &p, kept, VBNL_ERR_INVALID_ARGUMENT, "M = 0");
    q = p; q.target = 0;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "at least 1");
    q = p; q.target = M + 1;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "N must be <= M");
    q = p; q.neighbours = 0;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "neighbours");
    q = p; q.alpha = 0.0f;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "alpha");
    q = p; q.alpha = NAN;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "alpha");
    q = p; q.parallel = 1; q.early_stop = 0.0f;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "early_stop");
    q.early_stop = 1.5f;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "early_stop");
    q = p; q.max_radius = -1.0f;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "max_radius");
    q = p; q.surface_area = -2.0;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "surface_area");
    q = p; q.surface_area = INFINITY;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "surface_area");
    q = p; q.mode = (vbi_elim_mode)7;
    expect_error(pts, M, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "mode");
    pts[517].y = NAN;
    expect_error(pts, M, &p, kept, VBNL_ERR_INVALID_ARGUMENT, "candidate 517");
    pts[517].y = 0.5f;
    pts[3].z = -INFINITY;
    expect_error(pts, M, &p, kept, VBNL_ERR_INVALID_ARGUMENT, "not finite");
    pts[3].z = 0.0f;
    pts[9].x = -3e18f;
    expect_error(pts, M, &p, kept, VBNL_ERR_INVALID_ARGUMENT, "candidate 9");
    pts[9].x = 0.5f;
    /* One candidate: Eq. 2 has no neighbour; uniform with a given area works. */
    q = p; q.target = 1;
    expect_error(pts, 1, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "neighbour");
    q.mode = VBI_ELIM_UNIFORM;
    q.surface_area = 1.0;
    float rm;
    assert_int_equal(vbi_eliminate(pts, 1, &q, NULL, kept, &rm, NULL, NULL), VBNL_OK);
    assert_int_equal(kept[0], 0);
    /* All candidates at one spot: no area to spread lights over. */
    vec3 same[50];
    for (int i = 0; i < 50; ++i)
        same[i] = v3(1, 2, 3);
    q = p; q.target = 5;
    expect_error(same, 50, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "coincide");
    q.mode = VBI_ELIM_UNIFORM;
    expect_error(same, 50, &q, kept, VBNL_ERR_INVALID_ARGUMENT, "coincide");
    /* measure */
    double a, b;
    assert_int_equal(vbi_elim_measure(pts, kept, &rm, 1, &a, &b, NULL), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_elim_measure(NULL, kept, &rm, 5, &a, &b, NULL), VBNL_ERR_INVALID_ARGUMENT);
    free(pts);
}

/* A cancelling exec makes the call fail with VBNL_ERR_CANCELLED. */
static int cancel_run(void *ctx, uint64_t count, vbi_pool_fn fn, void *user)
{
    (void)ctx;
    (void)count;
    (void)fn;
    (void)user;
    return -1;
}

static void test_cancel(void **state)
{
    (void)state;
    const uint32_t M = 5000;
    vec3 *pts = make_plane(M, 14, 0);
    uint32_t *kept = malloc(M * sizeof(uint32_t));
    assert_non_null(kept);
    vbi_elim_params p;
    vbi_elim_params_default(&p, 500);
    vbi_elim_exec ex = {cancel_run, NULL};
    vbnl_error err = {0};
    assert_int_equal(vbi_eliminate(pts, M, &p, &ex, kept, NULL, NULL, &err), VBNL_ERR_CANCELLED);
    free(kept);
    free(pts);
}

/* Eq. 1 and Eq. 8: uniform radii tile the given area exactly; VL radius/density helpers; clamp. */
static void test_radius_density(void **state)
{
    (void)state;
    assert_float_equal(vbi_vl_radius(0.25f, VBI_VL_DEFAULT_RADIUS_SCALE), 0.5f, 1e-7);
    assert_float_equal(vbi_vl_density(0.5f, 2.0f), 4.0f / (2.0f * sqrtf(3.0f) * 0.25f), 1e-5);
    assert_float_equal(vbi_vl_density(0.0f, 2.0f), 0.0f, 0.0);
    const uint32_t M = 20000, N = 2000;
    vec3 *pts = make_plane(M, 15, 0);
    vbi_elim_params p;
    vbi_elim_params_default(&p, N);
    p.mode = VBI_ELIM_UNIFORM;
    p.surface_area = 2.0;
    run r;
    assert_int_equal(run_elim(pts, M, &p, NULL, &r), VBNL_OK);
    double area = 0.0; /* sum of 1 / rho_i over the lights = A (Eq. 1 with Eq. 8) */
    for (uint32_t i = 0; i < N; ++i)
        area += 1.0 / vbi_vl_density(vbi_vl_radius(r.rmax[i], 2.0f), 2.0f);
    assert_true(fabs(area - 2.0) < 1e-3);
    run_free(&r);
    /* Adaptive on a uniform plane: Eq. 2 radii scatter around Eq. 1's. */
    p.mode = VBI_ELIM_ADAPTIVE;
    assert_int_equal(run_elim(pts, M, &p, NULL, &r), VBNL_OK);
    double sum = 0.0, r1 = sqrt(1.0 / (2.0 * sqrt(3.0) * N));
    for (uint32_t i = 0; i < N; ++i)
        sum += r.rmax[i];
    assert_true(fabs(sum / N / r1 - 1.0) < 0.1);
    run_free(&r);
    p.max_radius = 0.5f * (float)r1;
    assert_int_equal(run_elim(pts, M, &p, NULL, &r), VBNL_OK);
    for (uint32_t i = 0; i < N; ++i)
        assert_true(r.rmax[i] <= p.max_radius);
    run_free(&r);
    free(pts);
}

/* The k-d tree's radius and m-nearest queries against brute force, on points with duplicates
 * and on a tree built in parts (the parallel build). */
static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static void test_kdtree(void **state)
{
    (void)state;
    const uint32_t n = 3000;
    vec3 *src = make_bumpy(n, 16);
    for (uint32_t i = 0; i < 200; ++i)
        src[n - 1 - i] = src[i]; /* duplicates */
    for (int parts = 0; parts < 2; ++parts) {
        vbi_kd_pt *pts = malloc(n * sizeof(vbi_kd_pt));
        uint32_t *qi = malloc(n * sizeof(uint32_t));
        float *qd = malloc(n * sizeof(float)), *all = malloc(n * sizeof(float)), knn_d2[64];
        uint32_t knn_i[64];
        assert_true(pts && qi && qd && all);
        for (uint32_t i = 0; i < n; ++i) {
            pts[i].p[0] = src[i].x;
            pts[i].p[1] = src[i].y;
            pts[i].p[2] = src[i].z;
            pts[i].id = i;
        }
        vbi_kd_tree t;
        if (parts) {
            vbi_kd_subtree jobs[8];
            uint32_t nj;
            assert_int_equal(vbi_kd_build_top(&t, pts, n, 3, jobs, &nj), 0);
            assert_int_equal(nj, 8);
            for (uint32_t j = nj; j-- > 0;)
                vbi_kd_build_subtree(&t, &jobs[j]);
        } else {
            assert_int_equal(vbi_kd_build(&t, pts, n), 0);
        }
        for (uint32_t i = 0; i < n; i += 37) {
            uint32_t cnt = 0;
            for (uint32_t j = 0; j < n; ++j)
                if (j != i)
                    all[cnt++] = vbi_kd_dist2(pts[i].p, pts[j].p);
            qsort(all, cnt, sizeof(float), cmp_float);
            for (uint32_t m = 1; m <= 64; m = 2 * m + 1)
                assert_true(vbi_kd_mth_dist2(&t, i, m, knn_i, knn_d2) == all[m - 1]);
            float r2 = all[20];
            uint32_t c = vbi_kd_radius(&t, pts[i].p, r2, qi, qd, n), expect = 1; /* itself */
            for (uint32_t j = 0; j < cnt; ++j)
                expect += all[j] <= r2;
            assert_int_equal(c, expect);
            assert_int_equal(vbi_kd_radius(&t, pts[i].p, r2, qi, qd, 5), 6); /* capped */
        }
        /* Box gathers against brute force, around every leaf's box. */
        float *pr2 = malloc(n * sizeof(float)), *nr2 = malloc(t.node_count * sizeof(float));
        uint8_t *hit = malloc(n);
        assert_true(pr2 && nr2 && hit);
        for (uint32_t i = 0; i < n; ++i)
            pr2[i] = (0.002f + 0.03f * (float)(i % 7) / 6.0f) * (0.002f + 0.03f * (float)(i % 7) / 6.0f);
        for (uint32_t k = t.node_count; k-- > 0;) { /* children follow their parent */
            const vbi_kd_node *nd = &t.nodes[k];
            float r2 = 0.0f;
            if (nd->axis == VBI_KD_LEAF_AXIS)
                for (uint32_t i = nd->begin; i < nd->end; ++i)
                    r2 = pr2[i] > r2 ? pr2[i] : r2;
            else
                r2 = nr2[k + 1] > nr2[nd->right] ? nr2[k + 1] : nr2[nd->right];
            nr2[k] = r2;
        }
        for (uint32_t k = 0; k < t.node_count; k += 5) {
            if (t.nodes[k].axis != VBI_KD_LEAF_AXIS)
                continue;
            const float *lo = t.box + 6 * (size_t)k, *hi = lo + 3;
            for (uint32_t i = t.nodes[k].begin; i < t.nodes[k].end; ++i)
                for (int a = 0; a < 3; ++a)
                    assert_true(pts[i].p[a] >= lo[a] && pts[i].p[a] <= hi[a]);
            const float r2 = 0.0004f;
            uint32_t c = vbi_kd_gather_box(&t, lo, hi, r2, qi, n), expect = 0;
            memset(hit, 0, n);
            for (uint32_t j = 0; j < c; ++j) {
                assert_true(qi[j] < n && !hit[qi[j]]);
                hit[qi[j]] = 1;
            }
            for (uint32_t i = 0; i < n; ++i) {
                int in = vbi_kd_box_dist2(lo, hi, pts[i].p) <= r2;
                expect += in;
                assert_int_equal(hit[i], in);
            }
            assert_int_equal(c, expect);
            if (expect > 2)
                assert_int_equal(vbi_kd_gather_box(&t, lo, hi, r2, qi, expect - 1), expect);
            c = vbi_kd_gather_reach(&t, lo, hi, nr2, pr2, qi, n);
            memset(hit, 0, n);
            for (uint32_t j = 0; j < c; ++j)
                hit[qi[j]] = 1;
            expect = 0;
            for (uint32_t i = 0; i < n; ++i) {
                int in = vbi_kd_box_dist2(lo, hi, pts[i].p) < pr2[i];
                expect += in;
                assert_int_equal(hit[i], in);
            }
            assert_int_equal(c, expect);
        }
        free(hit);
        free(nr2);
        free(pr2);
        vbi_kd_free(&t);
        free(all);
        free(qd);
        free(qi);
        free(pts);
    }
    /* Splitting jobs level by level builds the tree vbi_kd_build makes. */
    vbi_kd_pt *a = malloc(n * sizeof(vbi_kd_pt)), *b = malloc(n * sizeof(vbi_kd_pt));
    assert_true(a && b);
    for (uint32_t i = 0; i < n; ++i) {
        a[i].p[0] = src[i].x;
        a[i].p[1] = src[i].y;
        a[i].p[2] = src[i].z;
        a[i].id = i;
    }
    memcpy(b, a, n * sizeof(vbi_kd_pt));
    vbi_kd_tree ta, tb;
    assert_int_equal(vbi_kd_build(&ta, a, n), 0);
    vbi_kd_subtree jobs[2][16];
    uint32_t nj, nout[8];
    assert_int_equal(vbi_kd_build_top(&tb, b, n, 1, jobs[0], &nj), 0);
    for (int lev = 0; lev < 3; ++lev) {
        uint32_t k = 0;
        for (uint32_t j = 0; j < nj; ++j)
            vbi_kd_build_split(&tb, &jobs[lev & 1][j], jobs[(lev + 1) & 1] + 2 * j, &nout[j]);
        for (uint32_t j = 0; j < nj; ++j)
            for (uint32_t c = 0; c < nout[j]; ++c)
                jobs[(lev + 1) & 1][k++] = jobs[(lev + 1) & 1][2 * j + c];
        nj = k;
    }
    assert_int_equal(nj, 16);
    for (uint32_t j = nj; j-- > 0;)
        vbi_kd_build_subtree(&tb, &jobs[1][j]);
    assert_int_equal(ta.node_count, tb.node_count);
    assert_memory_equal(a, b, n * sizeof(vbi_kd_pt));
    assert_memory_equal(ta.nodes, tb.nodes, ta.node_count * sizeof(vbi_kd_node));
    assert_memory_equal(ta.box, tb.box, ta.node_count * 6 * sizeof(float));
    vbi_kd_free(&ta);
    vbi_kd_free(&tb);
    free(a);
    free(b);
    free(src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_keeps_exactly_n),   cmocka_unit_test(test_blue_noise_plane),
        cmocka_unit_test(test_serial_vs_parallel), cmocka_unit_test(test_adaptive_density),
        cmocka_unit_test(test_determinism),       cmocka_unit_test(test_bad_inputs),
        cmocka_unit_test(test_cancel),            cmocka_unit_test(test_radius_density),
        cmocka_unit_test(test_kdtree),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
