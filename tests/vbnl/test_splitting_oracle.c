/* Photon splitting (splitting.h) against its plain reference (reference.h,
 * vbi_split_photons_reference): the same 64-bit fixed-point incident power of every VL, the same
 * incident direction maps texel for texel, and the same counters, for every way a hit can go
 * through the optimised code:
 *   - VL indexes: one dense grid level (hits carry their cell), several levels (the index's
 *     pipeline, candidates level by level), more levels than the pipeline takes and the Embree
 *     variant (plain queries, answers in id order);
 *   - hits inside more than VBI_SPLIT_QUERY_MAX spheres (the smallest ids), max_vls selections
 *     that drop the smallest or pick the largest, filters off, the support test;
 *   - 1 and 3 threads, work items of 7 paths, atomic deposits instead of per-thread sums, every
 *     hit through the general walk, shares large enough for the general splat form;
 *   - surfaces the SIMD step takes (Lambertian and glossy mesh faces) and those it leaves to the
 *     general walk (an analytic sphere, a textured face, a mirror and glass, which take no
 *     deposit).
 * Both are deterministic; any difference is a bug in one of them. Seeds are fixed. */
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
#include "reference.h"
#include "rng.h"
#include "sampling.h"
#include "scene_internal.h"
#include "scenes.h"
#include "splitting.h"
#include "vbnl/vbnl.h"
#include "vl_index.h"

#define MAX_VLS 2000u

typedef struct vl_list {
    uint32_t n;
    vec3 c[MAX_VLS], nrm[MAX_VLS];
    float r[MAX_VLS];
    uint32_t material[MAX_VLS];
    uint8_t glossy[MAX_VLS];
} vl_list;

/* The box of scenes.h with a mirror and a textured panel on the back wall and a glass sphere:
 * faces the SIMD step leaves to the general walk. */
static vbnl_scene *oracle_scene(vbnl_context *ctx)
{
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    const float mirror[12] = {-0.9f, 0.2f, -0.99f, -0.3f, 0.2f, -0.99f, -0.3f, 0.9f, -0.99f, -0.9f, 0.9f, -0.99f};
    ts_quad(s, mirror, ts_material(s, VBNL_MATERIAL_MIRROR, 0.9f, 0.9f, 0.9f, 0.0f));
    uint32_t tex = 0;
    {
        vbnl_color_map_entry cm[2] = {{0.0f, {0.9f, 0.2f, 0.2f}}, {1.0f, {0.2f, 0.2f, 0.9f}}};
        vbnl_texture_desc td;
        vbnl_texture_desc_init(&td);
        td.kind = VBNL_TEXTURE_CHECKER;
        td.color_map = cm;
        td.color_map_count = 2;
        for (int i = 0; i < 3; ++i)
            td.pattern_from_world[5 * i] = 8.0f;
        assert_int_equal(vbnl_scene_add_texture(s, &td, &tex, NULL), VBNL_OK);
    }
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 1.0f;
    md.base_texture = tex + 1;
    uint32_t textured = 0;
    assert_int_equal(vbnl_scene_add_material(s, &md, &textured, NULL), VBNL_OK);
    const float panel[12] = {0.2f, 0.6f, -0.99f, 0.9f, 0.6f, -0.99f, 0.9f, 1.5f, -0.99f, 0.2f, 1.5f, -0.99f};
    ts_quad(s, panel, textured);
    const float gc[3] = {-0.5f, 0.3f, 0.2f};
    vbnl_scene_add_sphere(s, gc, 0.25f, ts_material(s, VBNL_MATERIAL_DIELECTRIC, 1, 1, 1, 0), VBNL_GROUP_WORLD,
                          NULL, NULL);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    return s;
}

/* n VLs at the camera's primary hits on non-delta surfaces (normal facing the camera), radius
 * r0 x 2^(spread x u) for uniform u (spread 0: one radius). */
static void place(const vbnl_scene *s, vl_list *v, uint32_t n, float r0, float spread)
{
    vbi_rng rng = vbi_rng_make(123, 4);
    v->n = 0;
    while (v->n < n) {
        vec3 o, d;
        vbi_camera_ray(&s->camera, 64, 64, vbi_rng_next(&rng) * 64, vbi_rng_next(&rng) * 64, &o, &d);
        vbi_hit h;
        if (!vbi_scene_intersect(s, o, d, INFINITY, &h) || vbi_bsdf_is_delta(&s->materials[h.material].bsdf))
            continue;
        v->c[v->n] = h.p;
        v->nrm[v->n] = v3_dot(h.ng, d) > 0.0f ? v3_neg(h.ng) : h.ng;
        v->r[v->n] = r0 * exp2f(spread * vbi_rng_next(&rng));
        v->material[v->n] = h.material;
        v->glossy[v->n] = s->materials[h.material].bsdf.type != VBNL_MATERIAL_LAMBERT;
        v->n++;
    }
}

/* How one comparison runs. */
typedef struct oracle_case {
    const char *name;
    vbi_vl_index_kind kind;
    vbi_vl_index_levels levels;
    uint32_t max_vls;
    float normal_cos;
    int facing, support;
    /* how the optimised code does the work (the reference ignores these) */
    unsigned threads;
    uint32_t chunk;
    int atomic, general;
    int fine; /* unit 2^-fine of the default: large shares */
} oracle_case;

static int sets_equal(const vbi_profile_set *a, const vbi_profile_set *b, uint32_t texels)
{
    for (uint32_t j = 0; j < vbi_profile_set_count(a); ++j) {
        if (memcmp(vbi_profile_incident_power_fixed(a, j), vbi_profile_incident_power_fixed(b, j), 24))
            return 0;
        const uint64_t *ma = vbi_profile_incident_map_fixed(a, j), *mb = vbi_profile_incident_map_fixed(b, j);
        if ((ma == NULL) != (mb == NULL) || (ma && memcmp(ma, mb, texels * 24u)))
            return 0;
    }
    return 1;
}

/* Runs case c on VLs v, optimised and reference, and compares. Returns the optimised run's
 * statistics for the callers' checks that the case reached what it is meant to. */
static vbi_split_stats run_case(const vbnl_scene *s, const vl_list *v, const vbi_hemioct *map, uint64_t paths,
                                 const oracle_case *c)
{
    vbi_vl_index_desc xd = {v->c, v->r, v->nrm, v->n, c->kind, 0.0f, s->ctx->device, c->levels};
    vbi_vl_index *x = NULL;
    assert_int_equal(vbi_vl_index_create(&xd, &x), VBNL_OK);
    vbi_vl_support *sup = NULL;
    if (c->support) { /* every other VL takes the test at its radius; all keep their material */
        sup = calloc(v->n, sizeof(*sup));
        assert_non_null(sup);
        for (uint32_t r = 0; r < v->n; ++r) {
            const uint32_t id = vbi_vl_index_id(x, r);
            sup[r].material = v->material[id];
            sup[r].tau = id % 2 ? v->r[id] : 0.0f;
        }
    }
    const double unit = ldexp(vbi_split_photon_unit(s, paths), -c->fine);
    vbi_profile_set *opt = NULL, *ref = NULL;
    assert_int_equal(vbi_profile_set_create_fixed(map, v->n, v->glossy, unit, &opt), VBNL_OK);
    assert_int_equal(vbi_profile_set_create_fixed(map, v->n, v->glossy, unit, &ref), VBNL_OK);
    vbi_split_desc d;
    vbi_split_desc_init(&d);
    d.scene = s;
    d.index = x;
    d.vl_normals = v->nrm;
    d.photon_paths = paths;
    d.seed = 31;
    d.max_vls = c->max_vls;
    d.normal_cos = c->normal_cos;
    d.require_facing = c->facing;
    d.support = sup;
    d.chunk = c->chunk;
    d.atomic_deposits = c->atomic;
    d.general_walk = c->general;
    vbi_pool *pool = vbi_pool_create(c->threads);
    vbi_split_stats so, sr;
    d.profiles = opt;
    assert_int_equal(vbi_split_photons(&d, pool, NULL, &so), VBNL_OK);
    d.profiles = ref;
    assert_int_equal(vbi_split_photons_reference(&d, &sr), VBNL_OK);
    print_message("# %-28s %6llu hits, %6llu covered, %7llu deposits, %4llu overflow, %5llu support tests\n", c->name,
                  (unsigned long long)so.hits, (unsigned long long)so.covered_hits, (unsigned long long)so.deposits,
                  (unsigned long long)so.overflow, (unsigned long long)so.support_tests);
    assert_true(sets_equal(opt, ref, vbi_hemioct_texel_count(map)));
    assert_int_equal(so.paths, sr.paths);
    assert_int_equal(so.rays, sr.rays);
    assert_int_equal(so.hits, sr.hits);
    assert_int_equal(so.delta_hits, sr.delta_hits);
    assert_int_equal(so.covered_hits, sr.covered_hits);
    assert_int_equal(so.deposits, sr.deposits);
    assert_int_equal(so.overflow, sr.overflow);
    assert_int_equal(so.support_tests, sr.support_tests);
    assert_int_equal(so.support_rejects, sr.support_rejects);
    assert_memory_equal(so.covered_power, sr.covered_power, sizeof(so.covered_power));
    assert_true(so.covered_hits > 0 && so.delta_hits > 0);
    vbi_pool_destroy(pool);
    vbi_profile_set_destroy(opt);
    vbi_profile_set_destroy(ref);
    free(sup);
    vbi_vl_index_destroy(x);
    return so;
}

static void test_oracle(void **state)
{
    (void)state;
    vbnl_context *ctx = ts_context(2);
    assert_non_null(ctx);
    vbnl_scene *s = oracle_scene(ctx);
    vbi_hemioct *map = NULL;
    assert_int_equal(vbi_hemioct_create(8, &map), VBNL_OK);
    static vl_list v;
    const uint64_t P = 6000;
    const vbi_vl_index_kind G = VBI_VL_INDEX_GRID;
    const vbi_vl_index_levels AUTO = VBI_VL_INDEX_LEVELS_AUTO, CLASSES = VBI_VL_INDEX_LEVELS_CLASSES;

    /* one radius: one dense level, the hits carry their cell */
    place(s, &v, 1500, 0.12f, 0.0f);
    const oracle_case one[] = {
        {"one level", G, AUTO, 8, 0.7f, 1, 0, 2, 0, 0, 0, 0},
        {"one level, 3 threads, 7 paths", G, AUTO, 8, 0.7f, 1, 0, 3, 7, 0, 0, 0},
        {"one level, atomic deposits", G, AUTO, 8, 0.7f, 1, 0, 2, 0, 1, 0, 0},
        {"one level, general walk", G, AUTO, 8, 0.7f, 1, 0, 1, 0, 0, 1, 0},
        {"one level, large shares", G, AUTO, 8, 0.7f, 1, 0, 2, 0, 0, 0, 12},
        {"one level, support test", G, AUTO, 8, 0.7f, 1, 1, 2, 0, 0, 0, 0},
        {"one level, no filters", G, AUTO, 3, -2.0f, 0, 0, 2, 0, 0, 0, 0},
        {"embree", VBI_VL_INDEX_EMBREE, AUTO, 8, 0.7f, 1, 1, 2, 0, 0, 0, 0},
    };
    for (size_t i = 0; i < sizeof(one) / sizeof(one[0]); ++i) {
        vbi_split_stats st = run_case(s, &v, map, P, &one[i]);
        if (i == 5)
            assert_true(st.support_tests > 0 && st.support_rejects > 0);
    }
    /* radii over a factor 4 and 256: a few levels (the pipeline, level by level) and more than
     * the pipeline takes (plain queries) */
    place(s, &v, 1500, 0.06f, 2.0f);
    run_case(s, &v, map, P, &(oracle_case){"2-3 levels", G, CLASSES, 8, 0.7f, 1, 1, 2, 0, 0, 0, 0});
    place(s, &v, 1500, 0.02f, 8.0f);
    run_case(s, &v, map, P, &(oracle_case){"many levels", G, CLASSES, 8, 0.7f, 1, 0, 2, 0, 0, 0, 0});
    /* large spheres: more than VBI_SPLIT_QUERY_MAX around a hit, and max_vls selections of both
     * kinds (drop the smallest: 10 of >= 11; pick the largest: 2 of > 4) */
    place(s, &v, 1500, 0.5f, 0.5f);
    const oracle_case big[] = {
        {"big spheres, keep 10", G, AUTO, 10, -2.0f, 0, 0, 2, 0, 0, 0, 0},
        {"big spheres, keep 2", G, AUTO, 2, 0.7f, 1, 0, 2, 0, 0, 0, 0},
        {"big spheres, keep 2, classes", G, CLASSES, 2, 0.7f, 1, 0, 2, 0, 0, 0, 0},
    };
    for (size_t i = 0; i < sizeof(big) / sizeof(big[0]); ++i) {
        vbi_split_stats st = run_case(s, &v, map, P, &big[i]);
        assert_true(st.deposits > (uint64_t)big[i].max_vls * st.covered_hits * 9 / 10); /* mostly capped */
        if (i == 0)
            assert_true(st.overflow > 0);
    }
    vbi_hemioct_destroy(map);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* The VL index's query against its reference (brute force) on the VLs of the box: same ids in
 * the same (id) order, the same squared distances and radii, the same totals, capped or not,
 * filtered or not, for every index variant. */
static void test_index_oracle(void **state)
{
    (void)state;
    vbnl_context *ctx = ts_context(1);
    assert_non_null(ctx);
    vbnl_scene *s = oracle_scene(ctx);
    static vl_list v;
    place(s, &v, 1500, 0.05f, 3.0f);
    const vbi_vl_index_levels pol[3] = {VBI_VL_INDEX_LEVELS_AUTO, VBI_VL_INDEX_LEVELS_CLASSES,
                                         VBI_VL_INDEX_LEVELS_ONE};
    vbi_rng rng = vbi_rng_make(8, 8);
    for (int variant = 0; variant < 4; ++variant) {
        vbi_vl_index_desc xd = {v.c, v.r, v.nrm, v.n, variant < 3 ? VBI_VL_INDEX_GRID : VBI_VL_INDEX_EMBREE, 0.0f,
                                 s->ctx->device, pol[variant % 3]};
        vbi_vl_index *x = NULL;
        assert_int_equal(vbi_vl_index_create(&xd, &x), VBNL_OK);
        uint64_t found_total = 0;
        for (uint32_t k = 0; k < 4000; ++k) {
            /* near a VL's centre, at its boundary, or anywhere in the box */
            const uint32_t j = vbi_rng_uniform_u32(&rng, v.n);
            vec3 p = k % 3 == 0 ? v3_fma(v.c[j], sample_uniform_sphere(vbi_rng_next2(&rng)), v.r[j])
                     : k % 3 == 1 ? v3_fma(v.c[j], sample_uniform_sphere(vbi_rng_next2(&rng)), 0.5f * v.r[j])
                                  : v3(2.0f * vbi_rng_next(&rng) - 1.0f, 2.0f * vbi_rng_next(&rng),
                                       2.0f * vbi_rng_next(&rng) - 1.0f);
            const vbi_vl_filter f = {sample_uniform_sphere(vbi_rng_next2(&rng)), sample_uniform_sphere(vbi_rng_next2(&rng)),
                                      0.2f, 1};
            for (int filt = 0; filt < 2; ++filt)
                for (uint32_t cap = 2; cap <= 64; cap += 62) {
                    vbi_vl_found a[64], b[64];
                    const vbi_vl_filter *fp = filt ? &f : NULL;
                    uint32_t na = vbi_vl_index_query_found(x, p, fp, cap, a);
                    uint32_t nb = vbi_vl_query_reference(v.c, v.r, v.nrm, v.n, p, fp, cap, b);
                    assert_int_equal(na, nb);
                    for (uint32_t i = 0; i < (na < cap ? na : cap); ++i) {
                        assert_int_equal(a[i].id, b[i].id);
                        assert_true(a[i].d2 == b[i].d2 && a[i].r == b[i].r);
                        assert_int_equal(vbi_vl_index_rank(x, a[i].id), a[i].rank);
                    }
                    found_total += na;
                }
        }
        assert_true(found_total > 4000); /* the points do fall into spheres */
        vbi_vl_index_destroy(x);
    }
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_index_oracle),
        cmocka_unit_test(test_oracle),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
