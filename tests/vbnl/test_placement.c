/* VBNL stage 1: candidate placement from camera sub-paths. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "placement.h"
#include "scenes.h"

static vbi_placement_params default_params(uint32_t count)
{
    vbi_placement_params p;
    memset(&p, 0, sizeof(p));
    p.count = count;
    p.tile_size = 4;
    p.specular_roughness = 0.15f;
    p.max_specular_chain = 4;
    p.width = 64;
    p.height = 64;
    p.seed = 11;
    return p;
}

static vbnl_scene *box(vbnl_context **ctx)
{
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    d.threads = 1;
    assert_int_equal(vbnl_context_create(&d, ctx, NULL), VBNL_OK);
    vbnl_scene *s = ts_box_scene(*ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    return s;
}

/* Candidates lie on the box's surfaces, normals are unit and face into the box. */
static void test_on_surfaces(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_scene *s = box(&ctx);
    vbi_placement_params p = default_params(20000);
    vbi_candidate *c;
    uint32_t n;
    vbi_placement_stats st;
    vbnl_error err = {0};
    assert_int_equal(vbi_place_candidates(s, &p, NULL, NULL, &c, &n, &st, &err), VBNL_OK);
    assert_int_equal(st.paths, 20000);
    assert_int_equal(st.candidates, n);
    assert_true(n > 19000); /* a closed box: only absorbed paths fail */
    const vec3 sphere_c = v3(0.3f, 0.4f, -0.3f);
    for (uint32_t i = 0; i < n; ++i) {
        vec3 q = c[i].p;
        assert_float_equal(v3_len(c[i].n), 1.0f, 1e-4f);
        float on_wall = fminf(fminf(fabsf(fabsf(q.x) - 1.0f), fabsf(fabsf(q.z) - 1.0f)),
                              fminf(fabsf(q.y), fabsf(q.y - 2.0f)));
        float on_sphere = fabsf(v3_len(v3_sub(q, sphere_c)) - 0.4f);
        assert_true(fminf(on_wall, on_sphere) < 1e-3f);
        /* the normal faces the inside of the box */
        vec3 inward = v3_sub(v3(0, 1, 0), q);
        if (on_sphere > 1e-3f)
            assert_true(v3_dot(c[i].n, inward) > 0.0f);
    }
    free(c);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* The same candidates for any thread count; tiles get equal shares of the paths. */
static void test_determinism_and_strata(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_scene *s = box(&ctx);
    vbi_placement_params p = default_params(30000);
    vbi_candidate *c[3];
    uint32_t n[3];
    vbi_pool *pool2 = vbi_pool_create(2), *pool3 = vbi_pool_create(3);
    assert_int_equal(vbi_place_candidates(s, &p, NULL, NULL, &c[0], &n[0], NULL, NULL), VBNL_OK);
    assert_int_equal(vbi_place_candidates(s, &p, NULL, pool2, &c[1], &n[1], NULL, NULL), VBNL_OK);
    assert_int_equal(vbi_place_candidates(s, &p, NULL, pool3, &c[2], &n[2], NULL, NULL), VBNL_OK);
    assert_int_equal(n[0], n[1]);
    assert_int_equal(n[0], n[2]);
    assert_memory_equal(c[0], c[1], sizeof(vbi_candidate) * n[0]);
    assert_memory_equal(c[0], c[2], sizeof(vbi_candidate) * n[0]);
    /* 256 tiles of 4x4 pixels: every tile started ceil or floor of 30000/256 paths */
    uint32_t hist[256] = {0};
    for (uint32_t i = 0; i < n[0]; ++i) {
        assert_true(c[0][i].tile < 256);
        hist[c[0][i].tile]++;
    }
    for (int t = 0; t < 256; ++t)
        assert_true(hist[t] <= 118 && hist[t] >= 100);
    /* another seed moves them */
    p.seed = 12;
    vbi_candidate *other;
    uint32_t no;
    assert_int_equal(vbi_place_candidates(s, &p, NULL, pool2, &other, &no, NULL, NULL), VBNL_OK);
    assert_true(no != n[0] || memcmp(other, c[0], sizeof(vbi_candidate) * no) != 0);
    free(other);
    for (int i = 0; i < 3; ++i)
        free(c[i]);
    vbi_pool_destroy(pool2);
    vbi_pool_destroy(pool3);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* A mirror never holds candidates; paths pass through it (Fig. 6) and place lights beyond. */
static void test_mirror_pass_through(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    d.threads = 1;
    vbnl_context_create(&d, &ctx, NULL);
    vbnl_scene *s;
    vbnl_scene_create(ctx, &s, NULL);
    uint32_t white = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.7f, 0.7f, 0.7f, 0.0f);
    uint32_t mirror = ts_material(s, VBNL_MATERIAL_MIRROR, 1.0f, 1.0f, 1.0f, 0.0f);
    /* a room with a mirror back wall */
    const float floor_[12] = {-1, 0, -1, -1, 0, 1, 1, 0, 1, 1, 0, -1};
    const float ceil_[12] = {-1, 2, -1, 1, 2, -1, 1, 2, 1, -1, 2, 1};
    const float back[12] = {-1, 0, -1, 1, 0, -1, 1, 2, -1, -1, 2, -1};
    const float front[12] = {-1, 0, 1, -1, 2, 1, 1, 2, 1, 1, 0, 1};
    const float left[12] = {-1, 0, -1, -1, 2, -1, -1, 2, 1, -1, 0, 1};
    const float right[12] = {1, 0, -1, 1, 0, 1, 1, 2, 1, 1, 2, -1};
    ts_quad(s, floor_, white);
    ts_quad(s, ceil_, white);
    ts_quad(s, back, mirror);
    ts_quad(s, front, white);
    ts_quad(s, left, white);
    ts_quad(s, right, white);
    float pl[3] = {0, 1.5f, 0}, I[3] = {5, 5, 5};
    vbnl_scene_add_point_light(s, pl, I, NULL, NULL);
    float pos[3] = {0, 1, 0.9f}, target[3] = {0, 1, -1}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 90.0f, 1.0f, NULL); /* sees walls and mirror */
    vbnl_scene_set_camera(s, &cam, NULL);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbi_placement_params p = default_params(20000);
    vbi_candidate *c;
    uint32_t n;
    vbi_placement_stats st;
    assert_int_equal(vbi_place_candidates(s, &p, NULL, NULL, &c, &n, &st, NULL), VBNL_OK);
    for (uint32_t i = 0; i < n; ++i)
        assert_int_not_equal(c[i].material, mirror);
    assert_true(st.through_specular > n / 10); /* much of the view is the mirror */
    /* with no pass-through allowed, paths that meet the mirror give nothing */
    p.max_specular_chain = 0;
    vbi_candidate *c0;
    uint32_t n0;
    vbnl_error e2 = {0};
    vbnl_result r2 = vbi_place_candidates(s, &p, NULL, NULL, &c0, &n0, &st, &e2);
    if (r2 != VBNL_OK)
        fail_msg("%s", e2.message);
    assert_int_equal(st.through_specular, 0);
    assert_true(n0 < n);
    free(c0);
    free(c);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_scene *s = box(&ctx);
    vbi_placement_params p = default_params(0);
    vbi_candidate *c;
    uint32_t n;
    vbnl_error err = {0};
    assert_int_equal(vbi_place_candidates(s, &p, NULL, NULL, &c, &n, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    p = default_params(10);
    p.tile_size = 0;
    assert_int_equal(vbi_place_candidates(s, &p, NULL, NULL, &c, &n, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_place_candidates(NULL, &p, NULL, NULL, &c, &n, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_on_surfaces),
        cmocka_unit_test(test_determinism_and_strata),
        cmocka_unit_test(test_mirror_pass_through),
        cmocka_unit_test(test_bad_arguments),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
