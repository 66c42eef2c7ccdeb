/* Tests for the packed render records of VBNL virtual lights (core/integrators/vbnl/vl_shade.h).
 *
 * A random set of Lambertian and glossy lights with random photon deposits: every record must
 * hold its light's data in the index's rank order, radiance must equal the unpacked formula
 * J(wo) tint / (pi r^2) of profiles.h, the pmf must be power / total power, and the pick must
 * draw ranks with that pmf (chi-square; a test against the wrong pmf must fail); the index's
 * candidate ranks tested on the records must give the index's own query answer. Seeds are
 * fixed. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf.h"
#include "bsdfs.h"
#include "chi2.h"
#include "octahedral.h"
#include "profiles.h"
#include "rng.h"
#include "sampling.h"
#include "vl_index.h"
#include "vl_set.h"
#include "vl_shade.h"

#define N_LIGHTS 400u

typedef struct fixture {
    vbi_hemioct *map;
    vbi_profile_kernel *kernels[2]; /* 0: Lambertian, 1: GGX conductor */
    vbi_profile_set *profiles;
    vbi_vl_set set;
    vbi_vl_index *index;
    float power[N_LIGHTS];
} fixture;

static vbi_bsdf make_bsdf(vbnl_material_type type, vec3 c, float alpha)
{
    return tb_bsdf(type, c.x, c.y, c.z, alpha, 1.5f);
}

static vec3 random_unit(vbi_rng *r) { return sample_uniform_sphere(vbi_rng_next2(r)); }

/* Every third light glossy; light 5 receives no photon (power 0). */
static void fixture_make(fixture *f)
{
    memset(f, 0, sizeof(*f));
    assert_int_equal(vbi_hemioct_create(16, &f->map), VBNL_OK);
    vbi_bsdf lam = make_bsdf(VBNL_MATERIAL_LAMBERT, v3(0.7f, 0.5f, 0.3f), 1.0f);
    vbi_bsdf ggx = make_bsdf(VBNL_MATERIAL_CONDUCTOR, v3(0.9f, 0.8f, 0.6f), 0.3f);
    assert_int_equal(vbi_profile_kernel_create(f->map, &lam, 1, &f->kernels[0]), VBNL_OK);
    assert_int_equal(vbi_profile_kernel_create(f->map, &ggx, 1, &f->kernels[1]), VBNL_OK);
    assert_int_equal(vbi_vl_set_alloc(&f->set, N_LIGHTS, NULL), VBNL_OK);
    uint8_t glossy[N_LIGHTS];
    vbi_rng rng = vbi_rng_make(11, 3);
    for (uint32_t j = 0; j < N_LIGHTS; ++j) {
        glossy[j] = j % 3 == 0;
        f->set.position[j] = v3(vbi_rng_next(&rng), vbi_rng_next(&rng), vbi_rng_next(&rng));
        f->set.normal[j] = random_unit(&rng);
        f->set.material[j] = glossy[j];
        f->set.tint[j] = v3(0.5f + 0.5f * vbi_rng_next(&rng), 1.0f, 0.25f + vbi_rng_next(&rng));
        f->set.radius[j] = 0.01f + 0.05f * vbi_rng_next(&rng);
        f->set.density[j] = 100.0f * vbi_rng_next(&rng);
    }
    assert_int_equal(vbi_profile_set_create(f->map, N_LIGHTS, glossy, &f->profiles), VBNL_OK);
    for (uint32_t j = 0; j < N_LIGHTS; ++j) {
        if (j == 5)
            continue;
        int photons = 1 + (int)(20.0f * vbi_rng_next(&rng));
        for (int p = 0; p < photons; ++p) {
            vec3 wi = sample_uniform_hemisphere(vbi_rng_next2(&rng));
            vec3 pw = v3s(0.1f + vbi_rng_next(&rng));
            vbi_profile_deposit(f->profiles, j, wi, pw);
        }
    }
    for (uint32_t j = 0; j < N_LIGHTS; ++j) {
        const vbi_profile_kernel *k = f->kernels[f->set.material[j]];
        f->power[j] = v3_max_comp(v3_mul(vbi_profile_power(f->profiles, j, k), f->set.tint[j]));
    }
    /* one level per radius class: test_candidates checks the staged lookup over several levels */
    vbi_vl_index_desc d = {f->set.position, f->set.radius, f->set.normal, N_LIGHTS, VBI_VL_INDEX_GRID, 0.0f, NULL,
                            VBI_VL_INDEX_LEVELS_CLASSES};
    assert_int_equal(vbi_vl_index_create(&d, &f->index), VBNL_OK);
}

static void fixture_free(fixture *f)
{
    vbi_vl_index_destroy(f->index);
    vbi_profile_set_destroy(f->profiles);
    vbi_vl_set_free(&f->set);
    vbi_profile_kernel_destroy(f->kernels[0]);
    vbi_profile_kernel_destroy(f->kernels[1]);
    vbi_hemioct_destroy(f->map);
}

/* Records in rank order with their light's data; radiance as the unpacked formula. */
static void test_records(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f);
    vbi_vl_shade t;
    assert_int_equal(vbi_vl_shade_build(&t, &f.set, f.index, f.profiles, f.kernels, f.power, NULL), VBNL_OK);
    assert_int_equal(t.n, N_LIGHTS);
    assert_int_equal(vbi_vl_shade_bytes(&t), N_LIGHTS * (64u + 8u)); /* records and the alias table */
    assert_int_equal(sizeof(vbi_vl_shade_rec), 64);
    assert_int_equal((uintptr_t)t.rec % 64u, 0);
    double total = 0.0, pmf_sum = 0.0;
    for (uint32_t j = 0; j < N_LIGHTS; ++j)
        total += f.power[j];
    vbi_rng rng = vbi_rng_make(4, 9);
    int glossy_seen = 0, lambert_seen = 0;
    for (uint32_t r = 0; r < N_LIGHTS; ++r) {
        const vbi_vl_shade_rec *e = &t.rec[r];
        uint32_t id = vbi_vl_index_id(f.index, r);
        assert_int_equal(e->slot, vbi_profile_slot(f.profiles, id));
        assert_int_equal(e->slot != VBI_PROFILE_NO_SLOT, vbi_profile_is_glossy(f.profiles, id));
        assert_memory_equal(&e->position, &f.set.position[id], sizeof(vec3));
        assert_memory_equal(&e->normal, &f.set.normal[id], sizeof(vec3));
        assert_true(e->radius == f.set.radius[id]);
        assert_true(e->density == f.set.density[id]);
        assert_true(fabs(e->pmf - f.power[id] / total) <= 1e-6 * (f.power[id] / total) + 1e-12);
        assert_true(t.alias[r].prob >= 0.0f && t.alias[r].alias < N_LIGHTS);
        pmf_sum += e->pmf;
        int glossy = vbi_profile_is_glossy(f.profiles, id);
        assert_int_equal(e->material, f.set.material[id]);
        glossy_seen += glossy;
        lambert_seen += !glossy;
        float inv_area = 1.0f / (VBI_PI * f.set.radius[id] * f.set.radius[id]);
        frame fr = frame_from_normal(f.set.normal[id]);
        for (int k = 0; k < 40; ++k) {
            vec3 w = random_unit(&rng); /* from the shading point toward the light */
            vec3 wo = frame_to_local(&fr, v3_neg(w));
            vec3 want = wo.z <= 0.0f ? v3s(0.0f)
                                     : v3_scale(v3_mul(vbi_profile_eval(f.profiles, id, f.kernels[f.set.material[id]], wo),
                                                       f.set.tint[id]),
                                                inv_area);
            vec3 got = vbi_vl_shade_radiance(e, f.profiles, f.kernels, w);
            /* glossy: the local direction may differ in its last bits (contraction of the frame
             * arithmetic), which moves the bilinear weights on a steep lobe */
            float tol = glossy ? 2e-5f : 1e-6f;
            for (int c = 0; c < 3; ++c)
                if (!(fabsf(v3_comp(got, c) - v3_comp(want, c)) <= tol * fabsf(v3_comp(want, c))))
                    fail_msg("light %u (glossy %d) wo.z %g channel %d: %a, want %a", id, glossy, wo.z, c,
                             v3_comp(got, c), v3_comp(want, c));
        }
    }
    assert_true(glossy_seen > 100 && lambert_seen > 200);
    assert_true(fabs(pmf_sum - 1.0) < 1e-5);
    vbi_vl_shade_free(&t);
    assert_null(t.rec);
    assert_int_equal(t.n, 0);
    fixture_free(&f);
}

/* The pick draws ranks with the pmf; the same counts against a wrong pmf (uniform) fail. */
static void test_pick_frequencies(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f);
    vbi_vl_shade t;
    assert_int_equal(vbi_vl_shade_build(&t, &f.set, f.index, f.profiles, f.kernels, f.power, NULL), VBNL_OK);
    const int draws = 2000000;
    double *obs = calloc(N_LIGHTS, sizeof(double)), *exp_pmf = malloc(sizeof(double) * N_LIGHTS),
           *exp_uniform = malloc(sizeof(double) * N_LIGHTS);
    vbi_rng rng = vbi_rng_make(21, 1);
    for (int i = 0; i < draws; ++i) {
        float u = vbi_rng_next(&rng);
        uint32_t r = vbi_vl_shade_pick_finish(&t, vbi_vl_shade_pick_start(&t, u));
        assert_int_equal(r, vbi_vl_shade_pick(&t, u));
        assert_true(r < N_LIGHTS);
        obs[r] += 1.0;
    }
    for (uint32_t r = 0; r < N_LIGHTS; ++r) {
        exp_pmf[r] = t.rec[r].pmf * (double)draws;
        exp_uniform[r] = (double)draws / N_LIGHTS;
    }
    uint32_t zero_rank = vbi_vl_index_rank(f.index, 5);
    assert_true(t.rec[zero_rank].pmf == 0.0f);
    assert_true(obs[zero_rank] == 0.0); /* a light without photons is never picked */
    vbi_chi2_result res;
    int ok = vbi_chi2_test(obs, exp_pmf, N_LIGHTS, 5.0, 0.01, &res);
    print_message("# pick vs pmf: %s\n", res.msg);
    assert_true(ok);
    int wrong = vbi_chi2_test(obs, exp_uniform, N_LIGHTS, 5.0, 0.01, &res);
    print_message("# pick vs uniform (must fail): %s\n", res.msg);
    assert_false(wrong);
    free(obs);
    free(exp_pmf);
    free(exp_uniform);
    vbi_vl_shade_free(&t);
    fixture_free(&f);
}

/* The index's candidate ranks, tested on the records, give the index's own answer: the same
 * set as vbi_vl_index_query_found with and without the filter, each rank once. */
static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* Radii over more levels than a staged lookup holds, and the Embree variant: the whole query
 * runs in the last stage, with the one-shot answer. */
static void test_lookup_unstaged(void **state)
{
    (void)state;
    enum { N = 3000 };
    vec3 *c = malloc(sizeof(vec3) * N);
    float *r = malloc(sizeof(float) * N);
    vbi_rng rng = vbi_rng_make(31, 2);
    for (uint32_t j = 0; j < N; ++j) {
        c[j] = v3(vbi_rng_next(&rng), vbi_rng_next(&rng), vbi_rng_next(&rng));
        r[j] = 1e-4f * (float)(1u << (j % 12)); /* 12 radius classes */
    }
    RTCDevice dev = rtcNewDevice(NULL);
    for (int kind = 0; kind < 2; ++kind) {
        vbi_vl_index_desc d = {c, r, NULL, N, kind ? VBI_VL_INDEX_EMBREE : VBI_VL_INDEX_GRID, 0.0f, dev,
                                VBI_VL_INDEX_LEVELS_CLASSES};
        vbi_vl_index *x;
        assert_int_equal(vbi_vl_index_create(&d, &x), VBNL_OK);
        uint32_t nonempty = 0;
        for (int q = 0; q < 4000; ++q) {
            vec3 p = v3(vbi_rng_next(&rng), vbi_rng_next(&rng), vbi_rng_next(&rng));
            uint32_t a[64], b[64];
            vbi_vl_lookup lk;
            vbi_vl_index_lookup_begin(x, p, &lk);
            vbi_vl_index_lookup_fetch(x, &lk);
            assert_int_equal(lk.levels, 0);
            uint32_t na = vbi_vl_index_candidates(x, p, 64, a), nb = vbi_vl_index_lookup_candidates(x, &lk, 64, b);
            assert_int_equal(na, nb);
            assert_memory_equal(a, b, sizeof(uint32_t) * (na < 64 ? na : 64));
            nonempty += na > 0;
        }
        assert_true(nonempty > 100);
        vbi_vl_index_destroy(x);
    }
    rtcReleaseDevice(dev);
    free(c);
    free(r);
}

static void test_candidates(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f);
    vbi_vl_shade t;
    assert_int_equal(vbi_vl_shade_build(&t, &f.set, f.index, f.profiles, f.kernels, f.power, NULL), VBNL_OK);
    vbi_rng rng = vbi_rng_make(8, 8);
    uint32_t nonempty = 0, rejected = 0;
    for (int q = 0; q < 20000; ++q) {
        vec3 p = v3(1.2f * vbi_rng_next(&rng) - 0.1f, 1.2f * vbi_rng_next(&rng) - 0.1f, 1.2f * vbi_rng_next(&rng) - 0.1f);
        vbi_vl_filter fl = {random_unit(&rng), random_unit(&rng), 0.0f, 1};
        for (int filtered = 0; filtered < 2; ++filtered) {
            uint32_t cand[256], mine[256], theirs[64];
            uint32_t nc = vbi_vl_index_candidates(f.index, p, 256, cand);
            assert_true(nc <= 256);
            /* the staged lookup lists the same ranks in the same order */
            uint32_t staged[256];
            vbi_vl_lookup lk;
            vbi_vl_index_lookup_begin(f.index, p, &lk);
            vbi_vl_index_lookup_fetch(f.index, &lk);
            assert_true(lk.levels > 1); /* radii of several classes: several levels, staged */
            assert_int_equal(vbi_vl_index_lookup_candidates(f.index, &lk, 256, staged), nc);
            assert_memory_equal(staged, cand, sizeof(uint32_t) * nc);
            uint32_t m = 0;
            for (uint32_t k = 0; k < nc; ++k) {
                const vbi_vl_shade_rec *e = &t.rec[cand[k]];
                double d2;
                if (vbi_vl_contains(e->position, e->radius, p, &d2) &&
                    (!filtered || vbi_vl_filter_passes(&fl, e->normal)))
                    mine[m++] = cand[k];
                else
                    rejected++;
            }
            vbi_vl_found found[64];
            uint32_t n = vbi_vl_index_query_found(f.index, p, filtered ? &fl : NULL, 64, found);
            assert_true(n <= 64);
            assert_int_equal(m, n);
            for (uint32_t k = 0; k < n; ++k)
                theirs[k] = found[k].rank;
            qsort(mine, m, sizeof(uint32_t), cmp_u32);
            qsort(theirs, n, sizeof(uint32_t), cmp_u32);
            assert_memory_equal(mine, theirs, sizeof(uint32_t) * n);
            qsort(cand, nc, sizeof(uint32_t), cmp_u32);
            for (uint32_t k = 1; k < nc; ++k)
                assert_true(cand[k] != cand[k - 1]);
            nonempty += n > 0;
        }
    }
    print_message("# candidates: %u non-empty answers, %u candidates rejected by the exact test\n", nonempty,
                  rejected);
    assert_true(nonempty > 1000 && rejected > 0);
    /* too small a buffer: reported, not overrun */
    uint32_t small[1] = {UINT32_MAX};
    uint32_t big = 0;
    for (int q = 0; q < 20000 && !big; ++q) {
        vec3 p = v3(vbi_rng_next(&rng), vbi_rng_next(&rng), vbi_rng_next(&rng));
        uint32_t nc = vbi_vl_index_candidates(f.index, p, 1, small);
        big = nc > 1 ? nc : 0;
    }
    assert_true(big > 1 && small[0] < N_LIGHTS);
    vbi_vl_shade_free(&t);
    fixture_free(&f);
}

/* No light received a photon: nothing to sample, and no error. */
static void test_no_power(void **state)
{
    (void)state;
    fixture f;
    fixture_make(&f);
    memset(f.power, 0, sizeof(f.power));
    vbi_vl_shade t;
    assert_int_equal(vbi_vl_shade_build(&t, &f.set, f.index, f.profiles, f.kernels, f.power, NULL), VBNL_OK);
    assert_int_equal(t.n, 0);
    assert_null(t.rec);
    assert_int_equal(vbi_vl_shade_bytes(&t), 0);
    vbi_vl_shade_free(&t);
    fixture_free(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_records),
        cmocka_unit_test(test_pick_frequencies),
        cmocka_unit_test(test_candidates),
        cmocka_unit_test(test_lookup_unstaged),
        cmocka_unit_test(test_no_power),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
