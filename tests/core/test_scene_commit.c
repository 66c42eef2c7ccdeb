/* Scene commit (core/src/scene_commit.c): what commit makes of the scene (emitters turned into
 * lights, the power table, bounds and counts, instances), what it refuses (no camera, no light,
 * twice, changes afterwards) and that a refused commit leaves the scene as it was, the
 * fingerprint of a committed scene, and the descriptors' size check. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "scene_internal.h"
#include "scenes.h"
#include "vbnl/vbnl.h"

static vbnl_context *g_ctx;

static int setup(void **state)
{
    (void)state;
    g_ctx = ts_context(1);
    return g_ctx ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    vbnl_context_destroy(g_ctx);
    return 0;
}

static void set_camera(vbnl_scene *s, float z)
{
    const float pos[3] = {0, 0, z}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 60.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
}

/* A quad z = 0 of [-1, 1]^2 split in two triangles, plus one degenerate triangle, all of
 * material m. */
static void emissive_mesh(vbnl_scene *s, uint32_t m)
{
    static const float pos[15] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0, 0, 0, 0};
    static const uint32_t idx[9] = {0, 1, 2, 0, 2, 3, 4, 4, 4};
    vbnl_mesh_desc d;
    vbnl_mesh_desc_init(&d);
    d.positions = pos;
    d.vertex_count = 5;
    d.indices = idx;
    d.triangle_count = 3;
    d.material = m;
    assert_int_equal(vbnl_scene_add_mesh(s, &d, NULL, NULL), VBNL_OK);
}

/* Emitters become lights at commit: one per non-degenerate emissive triangle, one per emissive
 * sphere, one for the environment, after the lights added by the user; the light table picks
 * each with probability proportional to its (mean) power, next-event estimation by the
 * irradiance it gives at the scene's centre. */
static void test_emitters_and_power(void **state)
{
    (void)state;
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(g_ctx, &s, NULL), VBNL_OK);
    set_camera(s, 5.0f);
    const float p[3] = {0, 0, 2}, i1[3] = {1, 1, 1};
    assert_int_equal(vbnl_scene_add_point_light(s, p, i1, NULL, NULL), VBNL_OK);
    const uint32_t em = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 2.0f);
    emissive_mesh(s, em);
    const float c[3] = {3, 0, 0};
    assert_int_equal(vbnl_scene_add_sphere(s, c, 0.5f, em, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    const float env[3] = {0.1f, 0.1f, 0.1f};
    assert_int_equal(vbnl_scene_set_environment(s, env, NULL), VBNL_OK);
    vbnl_scene_info info;
    assert_int_equal(vbnl_scene_get_info(s, &info, NULL), VBNL_OK);
    assert_int_equal(info.light_count, 1); /* before commit: the user's */
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_get_info(s, &info, NULL), VBNL_OK);
    assert_int_equal(info.light_count, 1 + 2 + 1 + 1);
    assert_int_equal(info.triangle_count, 3);
    assert_int_equal(info.sphere_count, 1);
    /* power: the point light 4 pi I; each triangle (area 2) pi Le A one-sided; the sphere pi Le 4 pi r^2 */
    double power[5], total = 0.0;
    for (uint32_t k = 0; k < 5; ++k) {
        power[k] = v3_avg(vbi_light_power(&s->lights[k]));
        total += power[k];
    }
    assert_float_equal(power[0], 4.0 * M_PI, 1e-4);
    assert_float_equal(power[1], M_PI * 2.0 * 2.0, 1e-4);
    assert_float_equal(power[2], M_PI * 2.0 * 2.0, 1e-4);
    assert_float_equal(power[3], M_PI * 2.0 * 4.0 * M_PI * 0.25, 1e-3);
    for (uint32_t k = 0; k < 5; ++k)
        assert_float_equal(s->light_table.pmf[k], power[k] / total, 1e-5);
    assert_int_equal(s->env_light, 4);
    /* next-event estimation picks each by the irradiance it gives at the scene's centre: power
     * over 4 pi d^2 for the finite ones, pi times the environment's radiance */
    const vec3 centre = v3_scale(v3_add(s->bounds_min, s->bounds_max), 0.5f);
    vec3 at[4] = {s->lights[0].p, v3_add(s->lights[1].p, v3_scale(v3_add(s->lights[1].e0, s->lights[1].e1), 1.0f / 3.0f)),
                  v3_add(s->lights[2].p, v3_scale(v3_add(s->lights[2].e0, s->lights[2].e1), 1.0f / 3.0f)),
                  s->lights[3].p};
    double w[5], wt = 0.0;
    for (uint32_t k = 0; k < 4; ++k)
        w[k] = power[k] / (4.0 * M_PI * v3_len2(v3_sub(at[k], centre)));
    w[4] = M_PI * 0.1;
    for (uint32_t k = 0; k < 5; ++k)
        wt += w[k];
    for (uint32_t k = 0; k < 5; ++k)
        assert_float_equal(vbi_scene_light_pmf(s, k), w[k] / wt, 1e-4);
    /* the environment's share by power is far larger than by irradiance here */
    assert_true(s->light_table.pmf[4] > 2.0f * vbi_scene_light_pmf(s, 4));
    /* a ray down onto the quad hits a light's triangle; the degenerate one is nobody's light */
    vbi_hit h;
    assert_true(vbi_scene_intersect(s, v3(0.5f, -0.2f, 1.0f), v3(0, 0, -1), INFINITY, &h));
    assert_true(h.light == 1 || h.light == 2);
    assert_float_equal(h.t, 1.0, 1e-6);
    assert_int_equal(s->geoms[0].kind, SCENE_GEOM_MESH);
    assert_int_equal(s->geoms[0].u.mesh.face_lights[2], VBI_NO_LIGHT);
    /* committed: no more changes, no second commit */
    vbnl_error err = {0};
    assert_int_equal(vbnl_scene_commit(s, &err), VBNL_ERR_STATE);
    assert_int_equal(vbnl_scene_add_point_light(s, p, i1, NULL, &err), VBNL_ERR_STATE);
    assert_int_equal(vbnl_scene_set_environment(s, env, &err), VBNL_ERR_STATE);
    vbnl_scene_destroy(s);
}

/* Instances: each counts its group's triangles, the bounds hold the transformed geometry, rays
 * hit it where the transform put it. */
static void test_instances(void **state)
{
    (void)state;
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(g_ctx, &s, NULL), VBNL_OK);
    set_camera(s, 10.0f);
    uint32_t g = 0;
    assert_int_equal(vbnl_scene_add_group(s, &g, NULL), VBNL_OK);
    const uint32_t white = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 0.0f);
    static const float pos[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
    static const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    vbnl_mesh_desc d;
    vbnl_mesh_desc_init(&d);
    d.positions = pos;
    d.vertex_count = 4;
    d.indices = idx;
    d.triangle_count = 2;
    d.material = white;
    d.group = g;
    assert_int_equal(vbnl_scene_add_mesh(s, &d, NULL, NULL), VBNL_OK);
    const float shift_right[16] = {1, 0, 0, 5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const float scale_left[16] = {2, 0, 0, -5, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1};
    assert_int_equal(vbnl_scene_add_instance(s, g, shift_right, NULL, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_add_instance(s, g, scale_left, NULL, NULL), VBNL_OK);
    d.group = VBNL_GROUP_WORLD; /* and the quad itself at the origin */
    assert_int_equal(vbnl_scene_add_mesh(s, &d, NULL, NULL), VBNL_OK);
    const float lp[3] = {0, 0, 3}, li[3] = {1, 1, 1};
    assert_int_equal(vbnl_scene_add_point_light(s, lp, li, NULL, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbnl_scene_info info;
    assert_int_equal(vbnl_scene_get_info(s, &info, NULL), VBNL_OK);
    assert_int_equal(info.triangle_count, 6);
    assert_int_equal(info.instance_count, 2);
    assert_float_equal(info.bounds_min[0], -7.0, 1e-5); /* the scaled copy: x in [-7, -3] */
    assert_float_equal(info.bounds_max[0], 6.0, 1e-5);  /* the shifted one: x in [4, 6] */
    assert_float_equal(info.bounds_min[1], -2.0, 1e-5);
    assert_float_equal(info.bounds_max[2], 3.0, 1e-5);  /* the point light */
    vbi_hit h;
    assert_true(vbi_scene_intersect(s, v3(5.5f, 0.5f, 1.0f), v3(0, 0, -1), INFINITY, &h));
    assert_float_equal(h.p.x, 5.5, 1e-5);
    assert_false(vbi_scene_intersect(s, v3(2.5f, 0.5f, 1.0f), v3(0, 0, -1), INFINITY, &h));
    assert_true(vbi_scene_intersect(s, v3(-6.5f, 1.5f, 1.0f), v3(0, 0, -1), INFINITY, &h));
    vbnl_scene_destroy(s);
}

/* A refused commit changes nothing: the scene can be completed and committed, and then has the
 * lights it should (no emitter twice). */
static void test_refused_then_committed(void **state)
{
    (void)state;
    vbnl_scene *s = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbnl_scene_create(g_ctx, &s, NULL), VBNL_OK);
    const uint32_t black = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.0f, 0.0f, 0.0f, 0.0f);
    emissive_mesh(s, black); /* not emissive: no light */
    assert_int_equal(vbnl_scene_commit(s, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "no camera"));
    set_camera(s, 4.0f);
    assert_int_equal(vbnl_scene_commit(s, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "no light"));
    /* an emissive sphere and the environment: emitters, then zero power everywhere is refused */
    const uint32_t em = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 1.0f);
    const float c[3] = {0, 0, 1};
    assert_int_equal(vbnl_scene_add_sphere(s, c, 0.25f, em, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, &err), VBNL_OK);
    vbnl_scene_info info;
    assert_int_equal(vbnl_scene_get_info(s, &info, NULL), VBNL_OK);
    assert_int_equal(info.light_count, 1);
    vbnl_scene_destroy(s);
}

static vbnl_scene *fingerprint_scene(float z, float x0)
{
    vbnl_scene *s = ts_box_scene(g_ctx, 1.0f);
    set_camera(s, z);
    const float p[12] = {x0, 0.1f, 0.0f, 0.2f, 0.1f, 0.0f, 0.2f, 0.5f, 0.0f, x0, 0.5f, 0.0f};
    ts_quad(s, p, 0);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    return s;
}

/* The fingerprint: equal scenes agree, a moved vertex changes it, the camera does not. */
static void test_fingerprint(void **state)
{
    (void)state;
    vbnl_scene *a = fingerprint_scene(3.0f, -0.2f), *b = fingerprint_scene(3.0f, -0.2f);
    vbnl_scene *other_cam = fingerprint_scene(2.0f, -0.2f), *moved = fingerprint_scene(3.0f, -0.2000001f);
    assert_true(vbi_scene_fingerprint(a) != 0);
    assert_true(vbi_scene_fingerprint(a) == vbi_scene_fingerprint(b));
    assert_true(vbi_scene_fingerprint(a) == vbi_scene_fingerprint(other_cam));
    assert_true(vbi_scene_fingerprint(a) != vbi_scene_fingerprint(moved));
    vbnl_scene *open = ts_box_scene(g_ctx, 1.0f);
    assert_true(vbi_scene_fingerprint(open) == 0);
    assert_true(vbi_scene_fingerprint(NULL) == 0);
    vbnl_scene_destroy(a);
    vbnl_scene_destroy(b);
    vbnl_scene_destroy(other_cam);
    vbnl_scene_destroy(moved);
    vbnl_scene_destroy(open);
}

/* Descriptors carry their size: one not filled by its init function is refused naming the
 * function, one from a newer vbnl (larger) as unsupported; the scene is unchanged. */
static void test_descriptor_sizes(void **state)
{
    (void)state;
    vbnl_scene *s = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbnl_scene_create(g_ctx, &s, NULL), VBNL_OK);
    vbnl_material_desc md;
    memset(&md, 0, sizeof(md));
    assert_int_equal(vbnl_scene_add_material(s, &md, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "vbnl_material_desc_init"));
    vbnl_material_desc_init(&md);
    md.size += 8;
    assert_int_equal(vbnl_scene_add_material(s, &md, NULL, &err), VBNL_ERR_UNSUPPORTED);
    assert_non_null(strstr(err.message, "newer"));
    vbnl_mesh_desc d;
    memset(&d, 0, sizeof(d));
    assert_int_equal(vbnl_scene_add_mesh(s, &d, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "vbnl_mesh_desc_init"));
    vbnl_area_light_desc al;
    memset(&al, 0, sizeof(al));
    assert_int_equal(vbnl_scene_add_area_light(s, &al, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_spot_light_desc sp;
    memset(&sp, 0, sizeof(sp));
    assert_int_equal(vbnl_scene_add_spot_light(s, &sp, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_texture_desc td;
    memset(&td, 0, sizeof(td));
    assert_int_equal(vbnl_scene_add_texture(s, &td, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_camera_desc cd;
    memset(&cd, 0, sizeof(cd));
    assert_int_equal(vbnl_scene_set_camera(s, &cd, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_scene_info info;
    assert_int_equal(vbnl_scene_get_info(s, &info, NULL), VBNL_OK);
    assert_int_equal(info.material_count, 0);
    assert_int_equal(info.light_count, 0);
    vbnl_context_desc xd;
    memset(&xd, 0, sizeof(xd));
    vbnl_context *ctx = (vbnl_context *)1;
    assert_int_equal(vbnl_context_create(&xd, &ctx, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(ctx);
    vbnl_scene_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_emitters_and_power), cmocka_unit_test(test_instances),
        cmocka_unit_test(test_refused_then_committed), cmocka_unit_test(test_fingerprint),
        cmocka_unit_test(test_descriptor_sizes),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
