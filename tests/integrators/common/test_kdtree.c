/* The integrators' k-d tree (core/integrators/common/kdtree.h): its one k-nearest query against
 * brute force (the same points in the same order of distance and id, duplicates and ties
 * included, with and without a skipped point, k beyond the point count) and its radius query. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "kdtree.h"
#include "rng.h"

typedef struct ref_nb {
    float d2;
    uint32_t id, local;
} ref_nb;

static int cmp_nb(const void *a, const void *b)
{
    const ref_nb *x = a, *y = b;
    if (x->d2 != y->d2)
        return x->d2 < y->d2 ? -1 : 1;
    return (x->id > y->id) - (x->id < y->id);
}

static void test_knn_brute_force(void **state)
{
    (void)state;
    enum { N = 3000, K = 40 };
    vbi_kd_pt *pts = malloc(N * sizeof(vbi_kd_pt));
    ref_nb *all = malloc(N * sizeof(ref_nb));
    assert_true(pts && all);
    vbi_rng rng = vbi_rng_make(3, 5);
    for (uint32_t i = 0; i < N; ++i) {
        /* on a coarse lattice: many equal distances, and duplicated points */
        for (int a = 0; a < 3; ++a)
            pts[i].p[a] = (float)vbi_rng_uniform_u32(&rng, 12) * 0.25f;
        pts[i].id = (i * 7919u) % N; /* ids not in input order */
    }
    vbi_kd_tree t;
    assert_int_equal(vbi_kd_build(&t, pts, N), 0);
    uint32_t out_i[N];
    float out_d2[N];
    for (uint32_t trial = 0; trial < 200; ++trial) {
        float q[3];
        uint32_t skip = UINT32_MAX;
        if (trial % 2) { /* a point of the tree, itself left out */
            skip = vbi_rng_uniform_u32(&rng, N);
            memcpy(q, t.pts[skip].p, sizeof(q));
        } else {
            for (int a = 0; a < 3; ++a)
                q[a] = vbi_rng_next(&rng) * 3.0f - 0.1f;
        }
        uint32_t n = 0;
        for (uint32_t i = 0; i < N; ++i)
            if (i != skip)
                all[n++] = (ref_nb){vbi_kd_dist2(q, t.pts[i].p), t.pts[i].id, i};
        qsort(all, n, sizeof(ref_nb), cmp_nb);
        const uint32_t k = trial % 7 == 0 ? 1u : (uint32_t)K;
        uint32_t got = vbi_kd_knn(&t, q, k, skip, out_i, out_d2);
        assert_int_equal(got, k);
        for (uint32_t j = 0; j < k; ++j) {
            assert_int_equal(out_i[j], all[j].local);
            assert_true(out_d2[j] == all[j].d2);
        }
        if (skip != UINT32_MAX)
            assert_true(vbi_kd_mth_dist2(&t, skip, 5, out_i, out_d2) == all[4].d2);
    }
    /* k beyond the points: all of them, sorted */
    float q[3] = {1.0f, 1.0f, 1.0f};
    assert_int_equal(vbi_kd_knn(&t, q, N + 10, UINT32_MAX, out_i, out_d2), N);
    for (uint32_t j = 1; j < N; ++j)
        assert_true(out_d2[j - 1] < out_d2[j] ||
                    (out_d2[j - 1] == out_d2[j] && t.pts[out_i[j - 1]].id < t.pts[out_i[j]].id));
    /* no points, k = 0 */
    assert_int_equal(vbi_kd_knn(&t, q, 0, UINT32_MAX, out_i, out_d2), 0);
    vbi_kd_free(&t);
    vbi_kd_tree empty;
    memset(&empty, 0, sizeof(empty));
    assert_int_equal(vbi_kd_knn(&empty, q, 3, UINT32_MAX, out_i, out_d2), 0);
    free(pts);
    free(all);
}

/* The radius query: exactly the points within r, every one once. */
static void test_radius(void **state)
{
    (void)state;
    enum { N = 2000 };
    vbi_kd_pt *pts = malloc(N * sizeof(vbi_kd_pt));
    assert_non_null(pts);
    vbi_rng rng = vbi_rng_make(9, 1);
    for (uint32_t i = 0; i < N; ++i) {
        for (int a = 0; a < 3; ++a)
            pts[i].p[a] = vbi_rng_next(&rng);
        pts[i].id = i;
    }
    vbi_kd_tree t;
    assert_int_equal(vbi_kd_build(&t, pts, N), 0);
    uint32_t idx[N];
    float d2[N];
    uint8_t seen[N];
    for (uint32_t trial = 0; trial < 50; ++trial) {
        float q[3] = {vbi_rng_next(&rng), vbi_rng_next(&rng), vbi_rng_next(&rng)};
        const float r2 = 0.01f + 0.05f * vbi_rng_next(&rng);
        uint32_t n = vbi_kd_radius(&t, q, r2, idx, d2, N);
        memset(seen, 0, sizeof(seen));
        for (uint32_t j = 0; j < n; ++j) {
            assert_false(seen[idx[j]]);
            seen[idx[j]] = 1;
            assert_true(d2[j] == vbi_kd_dist2(q, t.pts[idx[j]].p) && d2[j] <= r2);
        }
        uint32_t expect = 0;
        for (uint32_t i = 0; i < N; ++i)
            expect += vbi_kd_dist2(q, t.pts[i].p) <= r2;
        assert_int_equal(n, expect);
        if (n > 2) /* capped: cap + 1 says there were more */
            assert_int_equal(vbi_kd_radius(&t, q, r2, idx, d2, 2), 3);
    }
    vbi_kd_free(&t);
    free(pts);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_knn_brute_force),
        cmocka_unit_test(test_radius),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
