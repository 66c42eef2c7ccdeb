/* Photon splitting (core/integrators/vbnl/splitting.h): the deposit paths agree.
 *
 * splitting.c deposits a batch of hits in one of three ways, by the index: hits that carry their
 * grid cell (one dense grid level, uniform radii), the index's batch pipeline with the fused last
 * stage (several grid levels), and the plain filtered queries (the Embree index). They apply the
 * same rules (containment, normal-cone and facing filters, 8-light cap, normalised weights,
 * exact partition), so on the same VLs and photons:
 *  - the hits, covered hits, deposits and the covered photon power are the same;
 *  - every VL's incident power agrees up to the rounding of the normalised weights (the paths
 *    sum a hit's weights in rank or id order: a few fixed-point steps per deposit);
 *  - each run's VL sums equal its covered power exactly (energy bookkeeping).
 * The box scene has a glossy floor, so the glossy deposit is covered too. Seeds are fixed. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "context.h"
#include "octahedral.h"
#include "pool.h"
#include "profiles.h"
#include "rng.h"
#include "scene_internal.h"
#include "scenes.h"
#include "splitting.h"
#include "vbnl/vbnl.h"
#include "vl_index.h"

enum { MAX_VLS = 4096 };

typedef struct vl_list {
    uint32_t n;
    vec3 c[MAX_VLS], nrm[MAX_VLS];
    float r[MAX_VLS];
    uint8_t glossy[MAX_VLS];
} vl_list;

/* VLs at the camera's primary hits (normal facing the camera), radius 2 r_max of Eq. 1 times a
 * factor in [1, spread) (spread 1: uniform radii, one grid level). */
static void place_vls(const vbnl_scene *s, vl_list *v, uint32_t want, float area, float spread)
{
    vbi_rng rng = vbi_rng_make(77, 1);
    v->n = 0;
    float rad = 2.0f * sqrtf(area / (2.0f * sqrtf(3.0f) * (float)want));
    while (v->n < want) {
        vec3 o, d;
        vbi_camera_ray(&s->camera, 64, 64, vbi_rng_next(&rng) * 64, vbi_rng_next(&rng) * 64, &o, &d);
        float u = vbi_rng_next(&rng);
        vbi_hit h;
        if (!vbi_scene_intersect(s, o, d, INFINITY, &h) || vbi_bsdf_is_delta(&s->materials[h.material].bsdf))
            continue;
        v->c[v->n] = h.p;
        v->nrm[v->n] = v3_dot(h.ng, d) > 0.0f ? v3_neg(h.ng) : h.ng;
        v->r[v->n] = rad * (1.0f + (spread - 1.0f) * u);
        v->glossy[v->n] = s->materials[h.material].bsdf.type != VBNL_MATERIAL_LAMBERT;
        v->n++;
    }
}

static vbi_profile_set *run(const vbnl_context *ctx, const vbnl_scene *s, const vl_list *v, vbi_vl_index_kind kind,
                             vbi_vl_index_levels levels, uint32_t expect_levels, const vbi_hemioct *map,
                             vbi_pool *pool, uint64_t paths, vbi_split_stats *st)
{
    vbi_vl_index_desc xd = {v->c, v->r, v->nrm, v->n, kind, 0.0f, ctx->device, levels};
    vbi_vl_index *idx = NULL;
    assert_int_equal(vbi_vl_index_create(&xd, &idx), VBNL_OK);
    if (kind == VBI_VL_INDEX_GRID) { /* the path this test means to take */
        uint32_t nl = vbi_vl_index_level_count(idx);
        print_message("# grid levels: %u\n", nl);
        assert_true(expect_levels == 1 ? nl == 1 : nl > 1);
    }
    vbi_profile_set *ps = NULL;
    assert_int_equal(vbi_profile_set_create_fixed(map, v->n, v->glossy, vbi_split_photon_unit(s, paths), &ps),
                     VBNL_OK);
    vbi_split_desc d;
    vbi_split_desc_init(&d);
    d.scene = s;
    d.index = idx;
    d.vl_normals = v->nrm;
    d.profiles = ps;
    d.photon_paths = paths;
    d.seed = 99;
    d.chunk = 2000;
    assert_int_equal(vbi_split_photons(&d, pool, NULL, st), VBNL_OK);
    vbi_vl_index_destroy(idx);
    /* exact bookkeeping of this run */
    uint64_t sum[3] = {0, 0, 0};
    for (uint32_t j = 0; j < v->n; ++j)
        for (int c = 0; c < 3; ++c)
            sum[c] += vbi_profile_incident_power_fixed(ps, j)[c];
    for (int c = 0; c < 3; ++c)
        assert_true(sum[c] == st->covered_power[c]);
    return ps;
}

static uint64_t map_sum(const vbi_profile_set *ps, uint32_t j, uint32_t texels, int c)
{
    const uint64_t *m = vbi_profile_incident_map_fixed(ps, j);
    uint64_t s = 0;
    for (uint32_t t = 0; m && t < texels; ++t)
        s += m[3 * (size_t)t + (size_t)c];
    return s;
}

static void compare_paths(float spread, vbi_vl_index_levels levels, uint32_t expect_levels)
{
    vbnl_context *ctx = ts_context(2);
    assert_non_null(ctx);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    static vl_list v;
    place_vls(s, &v, 3000, 24.0f, spread);
    vbi_hemioct *map = NULL;
    assert_int_equal(vbi_hemioct_create(8, &map), VBNL_OK);
    const uint32_t texels = vbi_hemioct_texel_count(map);
    vbi_pool *pool = vbi_pool_create(2);
    const uint64_t P = 150000;
    vbi_split_stats sg, se;
    vbi_profile_set *g = run(ctx, s, &v, VBI_VL_INDEX_GRID, levels, expect_levels, map, pool, P, &sg);
    vbi_profile_set *e = run(ctx, s, &v, VBI_VL_INDEX_EMBREE, levels, 0, map, pool, P, &se);
    print_message("# spread %.1f: %llu hits, %llu covered, %llu deposits (grid) / %llu (embree)\n", (double)spread,
                  (unsigned long long)sg.hits, (unsigned long long)sg.covered_hits,
                  (unsigned long long)sg.deposits, (unsigned long long)se.deposits);
    assert_true(sg.covered_hits > sg.hits / 4 && sg.deposits > sg.covered_hits);
    assert_true(sg.hits == se.hits && sg.rays == se.rays);
    assert_true(sg.covered_hits == se.covered_hits);
    assert_true(sg.deposits == se.deposits);
    assert_memory_equal(sg.covered_power, se.covered_power, sizeof(sg.covered_power));
    /* per VL: the same power up to the rounding of the normalised weights */
    double worst = 0.0;
    uint32_t glossy_seen = 0;
    for (uint32_t j = 0; j < v.n; ++j) {
        const uint64_t *a = vbi_profile_incident_power_fixed(g, j), *b = vbi_profile_incident_power_fixed(e, j);
        for (int c = 0; c < 3; ++c) {
            double da = (double)a[c], db = (double)b[c], diff = fabs(da - db);
            double tol = 1e-5 * (da > db ? da : db) + 256.0;
            if (diff > tol)
                print_message("# VL %u channel %d: %.0f vs %.0f\n", j, c, da, db);
            assert_true(diff <= tol);
            if (da > 0.0)
                worst = fmax(worst, diff / da);
            if (v.glossy[j]) {
                /* each glossy map holds its VL's power */
                assert_true(map_sum(g, j, texels, c) == a[c]);
                assert_true(map_sum(e, j, texels, c) == b[c]);
                glossy_seen += c == 0 && a[c] > 0;
            }
        }
    }
    print_message("# largest relative difference of a VL's power: %.2e; %u glossy VLs lit\n", worst, glossy_seen);
    assert_true(glossy_seen > 10);
    vbi_profile_set_destroy(g);
    vbi_profile_set_destroy(e);
    vbi_pool_destroy(pool);
    vbi_hemioct_destroy(map);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* Uniform radii: the grid has one dense level (hits carry their cell) vs plain queries. */
static void test_cell_path_vs_plain(void **state)
{
    (void)state;
    compare_paths(1.0f, VBI_VL_INDEX_LEVELS_AUTO, 1);
}

/* Radii over a factor 6 in one level (the default for such a spread, vl_index.h "Levels"):
 * hits carry their cell, spheres of several sizes share the cells, vs plain queries. */
static void test_cell_path_mixed_radii_vs_plain(void **state)
{
    (void)state;
    compare_paths(6.0f, VBI_VL_INDEX_LEVELS_AUTO, 1);
}

/* Radii over a factor 6 in one level per radius class: the index pipeline vs plain queries. */
static void test_level_path_vs_plain(void **state)
{
    (void)state;
    compare_paths(6.0f, VBI_VL_INDEX_LEVELS_CLASSES, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cell_path_vs_plain),
        cmocka_unit_test(test_cell_path_mixed_radii_vs_plain),
        cmocka_unit_test(test_level_path_vs_plain),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
