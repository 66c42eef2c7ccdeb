/* Renderer tests through the public API: furnace, determinism, camera, intersection, AOVs,
 * cancellation, time budget, crop windows and bad arguments. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "scene_internal.h"
#include "scenes.h"
#include "vbnl/vbnl.h"

#define VBI_TEST_PI 3.14159265358979323846

static vbnl_context *make_ctx(unsigned threads)
{
    vbnl_context *ctx = ts_context(threads);
    assert_non_null(ctx);
    return ctx;
}

static float *render_layer(vbnl_context *ctx, vbnl_scene *s, uint32_t w, uint32_t h, uint32_t spp,
                           uint64_t seed, const char *layer, uint32_t channels, vbnl_params *params)
{
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = w;
    rs.height = h;
    rs.spp = spp;
    rs.seed = seed;
    rs.params = params;
    vbnl_renderer *r = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_OK);
    assert_int_equal(vbnl_renderer_render(r, NULL, NULL, &err), VBNL_OK);
    float *px = malloc(sizeof(float) * w * h * channels);
    assert_non_null(px);
    assert_int_equal(vbnl_film_read(vbnl_renderer_film(r), layer, px, (size_t)w * h * channels, &err), VBNL_OK);
    vbnl_renderer_destroy(r);
    return px;
}

/* Furnace: a camera inside a closed Lambertian sphere of albedo rho that emits Le everywhere
 * (both sides) sees L = Le / (1 - rho) in every pixel (the Neumann series of a constant). */
static void furnace_case(float rho, float Le, uint32_t res, uint32_t spp, double pixel_tol, double mean_tol)
{
    vbnl_context *ctx = make_ctx(0);
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    vbnl_material_desc d;
    vbnl_material_desc_init(&d);
    d.base_color[0] = d.base_color[1] = d.base_color[2] = rho;
    d.emission[0] = d.emission[1] = d.emission[2] = Le;
    d.two_sided = 1;
    uint32_t m;
    assert_int_equal(vbnl_scene_add_material(s, &d, &m, NULL), VBNL_OK);
    float c[3] = {0, 0, 0};
    assert_int_equal(vbnl_scene_add_sphere(s, c, 2.0f, m, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    float pos[3] = {0.3f, -0.2f, 0.5f}, target[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 90.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const uint32_t w = res, h = res;
    float *px = render_layer(ctx, s, w, h, spp, 7, "", 4, NULL);
    const double expected = Le / (1.0 - rho);
    double sum = 0.0, worst = 0.0;
    for (uint32_t i = 0; i < w * h; ++i) {
        for (int ch = 0; ch < 3; ++ch) {
            double v = px[4 * i + ch];
            sum += v;
            double e = fabs(v / expected - 1.0);
            if (e > worst)
                worst = e;
        }
        assert_float_equal(px[4 * i + 3], 1.0f, 0.0f); /* alpha */
    }
    double mean = sum / (w * h * 3);
    print_message("# furnace rho=%.2f: mean %.5f expected %.5f (%.3f%%), worst pixel %.2f%%\n", rho, mean,
                  expected, 100.0 * (mean / expected - 1.0), 100.0 * worst);
    assert_true(fabs(mean / expected - 1.0) < mean_tol);
    assert_true(worst < pixel_tol);
    free(px);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static void test_furnace(void **state)
{
    (void)state;
    furnace_case(0.5f, 1.0f, 8, 16384, 0.01, 0.002);
    furnace_case(0.8f, 0.5f, 4, 131072, 0.01, 0.002);
}

/* Irradiance at height h straight below the centre of a parallel a x b Lambertian panel of
 * radiance 1: pi times the form factor, four corner rectangles of (a/2) x (b/2). */
static double panel_irradiance(double a, double b, double h)
{
    double X = 0.5 * a / h, Y = 0.5 * b / h, sx = sqrt(1.0 + X * X), sy = sqrt(1.0 + Y * Y);
    double F = (X / sx * atan(Y / sx) + Y / sy * atan(X / sy)) / (2.0 * VBI_TEST_PI);
    return VBI_TEST_PI * 4.0 * F;
}

/* Direct light from a panel close above a floor, near the origin and far from it: the radiance
 * of the floor below the panel's centre is rho E / pi (nothing else lights it). The shadow ray
 * must end short of the emitter at any distance and any coordinate (the origin's offset off the
 * floor grows with the coordinates; a close light must not shadow itself). */
static void test_close_light(void **state)
{
    (void)state;
    const float heights[3] = {0.0f, 5.0f, 60.0f};
    const float gaps[2] = {0.3f, 0.05f};
    for (int hk = 0; hk < 3; ++hk) {
        for (int gk = 0; gk < 2; ++gk) {
            const float y0 = heights[hk], g = gaps[gk], rho = 0.7f;
            vbnl_context *ctx = make_ctx(0);
            vbnl_scene *s = NULL;
            assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
            uint32_t floor_m = ts_material(s, VBNL_MATERIAL_LAMBERT, rho, rho, rho, 0.0f);
            vbnl_material_desc d;
            vbnl_material_desc_init(&d);
            d.base_color[0] = d.base_color[1] = d.base_color[2] = 0.0f;
            d.emission[0] = d.emission[1] = d.emission[2] = 1.0f;
            d.two_sided = 1;
            uint32_t light_m;
            assert_int_equal(vbnl_scene_add_material(s, &d, &light_m, NULL), VBNL_OK);
            const float fl[12] = {-10, y0, -10, -10, y0, 10, 10, y0, 10, 10, y0, -10};
            const float yl = y0 + g;
            const float pl[12] = {-0.4f, yl, -0.3f, 0.4f, yl, -0.3f, 0.4f, yl, 0.3f, -0.4f, yl, 0.3f};
            ts_quad(s, fl, floor_m);
            ts_quad(s, pl, light_m);
            float pos[3] = {0.0f, y0 + 0.5f * g, -0.5f * g}, target[3] = {0.0f, y0, 0.0f}, up[3] = {0, 1, 0};
            vbnl_camera_desc cam;
            assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 1.0f, 1.0f, NULL), VBNL_OK);
            assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
            assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
            float *px = render_layer(ctx, s, 4, 4, 256, 3, "", 4, NULL);
            double sum = 0.0;
            for (int i = 0; i < 16; ++i)
                sum += px[4 * i];
            const double got = sum / 16.0, want = rho * panel_irradiance(0.8, 0.6, g) / VBI_TEST_PI;
            print_message("# close light at y %.0f, gap %.2f: %.5f, expected %.5f\n", (double)y0, (double)g, got,
                          want);
            assert_true(fabs(got / want - 1.0) < 0.01);
            free(px);
            vbnl_scene_destroy(s);
            vbnl_context_destroy(ctx);
        }
    }
}

/* Same seed, same image for 1 and 2 worker threads, bit for bit (every layer). */
static void test_determinism(void **state)
{
    (void)state;
    const uint32_t w = 40, h = 30;
    float *img[2];
    for (int t = 0; t < 2; ++t) {
        vbnl_context *ctx = make_ctx((unsigned)t + 1);
        vbnl_scene *s = ts_box_scene(ctx, (float)w / h);
        assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
        img[t] = render_layer(ctx, s, w, h, 8, 42, "", 4, NULL);
        vbnl_scene_destroy(s);
        vbnl_context_destroy(ctx);
    }
    assert_memory_equal(img[0], img[1], sizeof(float) * w * h * 4);
    /* and another seed gives another image */
    vbnl_context *ctx = make_ctx(2);
    vbnl_scene *s = ts_box_scene(ctx, (float)w / h);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    float *other = render_layer(ctx, s, w, h, 8, 43, "", 4, NULL);
    assert_true(memcmp(img[0], other, sizeof(float) * w * h * 4) != 0);
    free(other);
    free(img[0]);
    free(img[1]);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* The direct and indirect layers add up to the beauty image. */
static void test_split_direct(void **state)
{
    (void)state;
    const uint32_t w = 24, h = 24;
    vbnl_context *ctx = make_ctx(0);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbnl_params *p;
    vbnl_params_create(&p, NULL);
    vbnl_params_set_number(p, "split_direct", 1, NULL, NULL);
    float *beauty = render_layer(ctx, s, w, h, 4, 3, "", 4, p);
    float *direct = render_layer(ctx, s, w, h, 4, 3, "direct", 3, p);
    float *indirect = render_layer(ctx, s, w, h, 4, 3, "indirect", 3, p);
    double sd = 0, si = 0;
    for (uint32_t i = 0; i < w * h; ++i) {
        for (int c = 0; c < 3; ++c) {
            assert_float_equal(beauty[4 * i + c], direct[3 * i + c] + indirect[3 * i + c],
                               1e-4f * (1.0f + beauty[4 * i + c]));
            sd += direct[3 * i + c];
            si += indirect[3 * i + c];
        }
    }
    assert_true(sd > 0.0 && si > 0.0); /* a closed box has both */
    free(beauty);
    free(direct);
    free(indirect);
    vbnl_params_destroy(p);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* max_depth 0 shows emitters only; more bounces only add light (all contributions >= 0). */
static void test_max_depth(void **state)
{
    (void)state;
    const uint32_t w = 16, h = 16;
    vbnl_context *ctx = make_ctx(0);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    double totals[3];
    const int depths[3] = {0, 1, -1};
    for (int k = 0; k < 3; ++k) {
        vbnl_params *p;
        vbnl_params_create(&p, NULL);
        vbnl_params_set_number(p, "max_depth", depths[k], NULL, NULL);
        float *img = render_layer(ctx, s, w, h, 16, 5, "", 4, p);
        totals[k] = 0;
        for (uint32_t i = 0; i < w * h; ++i)
            totals[k] += img[4 * i] + img[4 * i + 1] + img[4 * i + 2];
        free(img);
        vbnl_params_destroy(p);
    }
    assert_true(totals[0] >= 0.0);
    assert_true(totals[1] > totals[0]);
    assert_true(totals[2] > totals[1] * 1.05);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static void test_camera_rays(void **state)
{
    (void)state;
    vbnl_camera_desc c;
    float pos[3] = {1, 2, 3}, target[3] = {1, 2, -7}, up[3] = {0, 1, 0};
    assert_int_equal(vbnl_camera_look_at(&c, pos, target, up, 90.0f, 2.0f, NULL), VBNL_OK);
    vec3 o, d;
    vbi_camera_ray(&c, 200, 100, 100.0f, 50.0f, &o, &d); /* image centre */
    assert_float_equal(o.x, 1.0f, 0);
    assert_float_equal(d.x, 0.0f, 1e-6f);
    assert_float_equal(d.y, 0.0f, 1e-6f);
    assert_float_equal(d.z, -1.0f, 1e-6f);
    /* top edge centre: 45 degrees up (vertical fov 90) */
    vbi_camera_ray(&c, 200, 100, 100.0f, 0.0f, &o, &d);
    assert_float_equal(atan2f(d.y, -d.z), (float)M_PI / 4.0f, 1e-5f);
    /* right edge centre: horizontal half-angle atan(aspect * tan(45)) = atan(2), toward +x */
    vbi_camera_ray(&c, 200, 100, 200.0f, 50.0f, &o, &d);
    assert_float_equal(atan2f(d.x, -d.z), atanf(2.0f), 1e-5f);
    /* degenerate cameras are refused */
    vbnl_error err = {0};
    assert_int_equal(vbnl_camera_look_at(&c, pos, pos, up, 60.0f, 1.0f, &err), VBNL_ERR_INVALID_ARGUMENT);
    float up_bad[3] = {0, 0, 1};
    assert_int_equal(vbnl_camera_look_at(&c, pos, target, up_bad, 60.0f, 1.0f, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_camera_look_at(&c, pos, target, up, 180.0f, 1.0f, &err), VBNL_ERR_INVALID_ARGUMENT);
}

/* POV-Ray's other projections at points whose rays are known, and the thin lens: every lens
 * point's ray meets the pinhole ray at the focal distance. */
static void test_camera_projections(void **state)
{
    (void)state;
    vbnl_camera_desc c = {.size = sizeof(vbnl_camera_desc), .position = {0, 0, 0}, .forward = {0, 0, 2}, .right = {1, 0, 0}, .up = {0, 1, 0}};
    vec3 o, d;
    c.projection = VBNL_CAMERA_ORTHOGRAPHIC;
    assert_int_equal(vbi_camera_ray(&c, 100, 100, 75.0f, 25.0f, &o, &d), 1);
    assert_float_equal(o.x, 0.25f, 1e-6f);
    assert_float_equal(o.y, 0.25f, 1e-6f);
    assert_float_equal(d.z, 1.0f, 1e-6f);
    /* fisheye of 180 degrees: the centre looks forward, the edge's middle along right, the corner
     * lies outside the circle and has no ray */
    c.projection = VBNL_CAMERA_FISHEYE;
    c.angle[0] = 180.0f;
    assert_int_equal(vbi_camera_ray(&c, 100, 100, 50.0f, 50.0f, &o, &d), 1);
    assert_float_equal(d.z, 1.0f, 1e-6f);
    assert_int_equal(vbi_camera_ray(&c, 100, 100, 100.0f, 50.0f, &o, &d), 1);
    assert_float_equal(d.x, 1.0f, 1e-5f);
    assert_int_equal(vbi_camera_ray(&c, 100, 100, 99.0f, 1.0f, &o, &d), 0);
    /* panoramic: the left edge looks along -right, the centre forward */
    c.projection = VBNL_CAMERA_PANORAMIC;
    vbi_camera_ray(&c, 100, 100, 0.0f, 50.0f, &o, &d);
    assert_float_equal(d.x, -1.0f, 1e-5f);
    vbi_camera_ray(&c, 100, 100, 50.0f, 50.0f, &o, &d);
    assert_float_equal(d.z, 1.0f, 1e-5f);
    /* spherical 360 x 180: the right edge is 180 degrees around (behind), the top straight up */
    c.projection = VBNL_CAMERA_SPHERICAL;
    c.angle[0] = 360.0f;
    c.angle[1] = 180.0f;
    vbi_camera_ray(&c, 100, 100, 75.0f, 50.0f, &o, &d);
    assert_float_equal(d.x, 1.0f, 1e-5f);
    vbi_camera_ray(&c, 100, 100, 50.0f, 0.0f, &o, &d);
    assert_float_equal(d.y, 1.0f, 1e-5f);
    /* cylinder 3: orthographic along up, 90 degrees around it across the width */
    c.projection = VBNL_CAMERA_CYLINDER_3;
    c.angle[0] = 90.0f;
    vbi_camera_ray(&c, 100, 100, 100.0f, 0.0f, &o, &d);
    assert_float_equal(o.y, 0.5f, 1e-6f);
    assert_float_equal(atan2f(d.x, d.z), (float)M_PI / 4.0f, 1e-5f);
    /* thin lens: rays from across the lens meet at the pinhole ray's point at the focal distance */
    c.projection = VBNL_CAMERA_PERSPECTIVE;
    c.lens_radius = 0.5f;
    c.focal_distance = 4.0f;
    vec3 focus = v3(0.25f * 2.0f, 0.0f, 4.0f); /* (forward + 0.25 right) * 4 / |forward| */
    float spread = 0.0f;
    for (int i = 0; i < 16; ++i) {
        vec2 lens = {(float)(i % 4) / 4.0f + 0.1f, (float)(i / 4) / 4.0f + 0.1f};
        assert_int_equal(vbi_camera_ray_lens(&c, 100, 100, 75.0f, 50.0f, lens, &o, &d), 1);
        vec3 to = v3_sub(focus, o);
        float t = v3_len(to);
        assert_float_equal(v3_dot(v3_scale(to, 1.0f / t), d), 1.0f, 1e-5f);
        assert_float_equal(o.z, 0.0f, 1e-6f); /* on the lens plane, perpendicular to forward */
        assert_true(o.x * o.x + o.y * o.y <= 0.25f * 1.0001f);
        spread = fmaxf(spread, sqrtf(o.x * o.x + o.y * o.y));
    }
    assert_true(spread > 0.3f); /* the samples reach across the lens */
    vbnl_error err = {0};
    vbnl_scene *s = NULL;
    vbnl_context *ctx = NULL;
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = 1;
    assert_int_equal(vbnl_context_create(&cd, &ctx, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    c.focal_distance = 0.0f;
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_ERR_INVALID_ARGUMENT);
    c.focal_distance = 1.0f;
    c.projection = (vbnl_camera_projection)42;
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* Embree answers known geometry: a sphere (outside and inside), a quad, an instance. */
static void test_intersection(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(1);
    vbnl_scene *s = NULL;
    vbnl_scene_create(ctx, &s, NULL);
    uint32_t m = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 0.0f);
    uint32_t e = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 1.0f);
    float c[3] = {0, 0, 0};
    uint32_t sphere;
    assert_int_equal(vbnl_scene_add_sphere(s, c, 1.0f, m, VBNL_GROUP_WORLD, &sphere, NULL), VBNL_OK);
    const float quad[12] = {5, -1, -1, 5, 1, -1, 5, 1, 1, 5, -1, 1};
    ts_quad(s, quad, e);
    uint32_t g;
    assert_int_equal(vbnl_scene_add_group(s, &g, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_add_sphere(s, c, 1.0f, m, g, NULL, NULL), VBNL_OK);
    /* instance: scale 2 along x, translate to (0, 10, 0) */
    const float xf[16] = {2, 0, 0, 0, 0, 1, 0, 10, 0, 0, 1, 0, 0, 0, 0, 1};
    assert_int_equal(vbnl_scene_add_instance(s, g, xf, NULL, NULL), VBNL_OK);
    float pos[3] = {0, 0, 5}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 40.0f, 1.0f, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbi_hit h;
    /* from outside */
    assert_true(vbi_scene_intersect(s, v3(0, 0, -5), v3(0, 0, 1), INFINITY, &h));
    assert_float_equal(h.t, 4.0f, 1e-4f);
    assert_float_equal(h.ng.z, -1.0f, 1e-5f);
    assert_int_equal(h.geom, sphere);
    assert_int_equal(h.light, VBI_NO_LIGHT);
    /* from inside: the far wall, outward normal */
    assert_true(vbi_scene_intersect(s, v3(0, 0, 0), v3(0, 1, 0), INFINITY, &h));
    assert_float_equal(h.t, 1.0f, 1e-4f);
    assert_float_equal(h.ng.y, 1.0f, 1e-5f);
    /* the emissive quad is a light */
    assert_true(vbi_scene_intersect(s, v3(3, 0.2f, 0.3f), v3(1, 0, 0), INFINITY, &h));
    assert_float_equal(h.t, 2.0f, 1e-4f);
    assert_true(h.light != VBI_NO_LIGHT);
    assert_float_equal(fabsf(h.ng.x), 1.0f, 1e-5f);
    /* the instance: ellipsoid with x semi-axis 2 centred at (0,10,0) */
    assert_true(vbi_scene_intersect(s, v3(-5, 10, 0), v3(1, 0, 0), INFINITY, &h));
    assert_float_equal(h.t, 3.0f, 1e-3f);
    assert_float_equal(h.ng.x, -1.0f, 1e-4f);
    /* at 45 degrees on the ellipse x = 2 cos t, y = sin t the normal is (cos t / 2, sin t) normalised */
    float t = 0.7f;
    vec3 p = v3(2.0f * cosf(t), 10.0f + sinf(t), 0.0f);
    assert_true(vbi_scene_intersect(s, v3(p.x + 3.0f, p.y, 0), v3(-1, 0, 0), INFINITY, &h));
    vec3 n = v3_norm(v3(cosf(t) / 2.0f, sinf(t), 0.0f));
    assert_float_equal(h.ng.x, n.x, 1e-3f);
    assert_float_equal(h.ng.y, n.y, 1e-3f);
    /* misses and occlusion */
    assert_false(vbi_scene_intersect(s, v3(0, -5, 20), v3(0, 0, 1), INFINITY, &h));
    assert_true(vbi_scene_occluded(s, v3(0, 0, -5), v3(0, 0, 1), 10.0f));
    assert_false(vbi_scene_occluded(s, v3(0, 0, -5), v3(0, 0, 1), 3.9f));
    /* the 8-wide packet agrees with single rays */
    int active[8], mask[8];
    vec3 o[8], d[8];
    vbi_hit hits[8];
    for (int i = 0; i < 8; ++i) {
        active[i] = i != 5;
        o[i] = v3(-0.9f + 0.25f * (float)i, 0.1f, 5.0f);
        d[i] = v3(0, 0, -1);
    }
    vbi_scene_intersect8(s, active, o, d, hits, mask);
    for (int i = 0; i < 8; ++i) {
        vbi_hit one;
        int got = vbi_scene_intersect(s, o[i], d[i], INFINITY, &one);
        assert_int_equal(mask[i], active[i] && got);
        if (mask[i])
            assert_float_equal(hits[i].t, one.t, 1e-5f);
    }
    vbnl_scene_info info;
    assert_int_equal(vbnl_scene_get_info(s, &info, NULL), VBNL_OK);
    assert_int_equal(info.triangle_count, 2);
    assert_int_equal(info.sphere_count, 2);
    assert_int_equal(info.instance_count, 1);
    assert_int_equal(info.light_count, 2); /* two emissive triangles */
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static int cancel_at_once(void *user, const vbnl_progress *p)
{
    int *calls = user;
    (*calls)++;
    assert_non_null(p->stage);
    return 1;
}

/* Cancelling keeps what is finished and says so. */
static void test_cancel(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(2);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = rs.height = 64;
    rs.spp = 100000;
    rs.progress_interval = 0.001f;
    vbnl_renderer *r;
    vbnl_error err = {0};
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_OK);
    int calls = 0;
    assert_int_equal(vbnl_renderer_render(r, cancel_at_once, &calls, &err), VBNL_ERR_CANCELLED);
    assert_true(calls >= 1);
    vbnl_render_stats st;
    assert_int_equal(vbnl_renderer_get_stats(r, &st, NULL), VBNL_OK);
    assert_true(st.cancelled);
    assert_true(st.spp < 100000);
    vbnl_renderer_destroy(r);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static void test_time_budget(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(0);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = rs.height = 32;
    rs.spp = 0;
    rs.time_budget = 0.3;
    vbnl_renderer *r;
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, NULL), VBNL_OK);
    assert_int_equal(vbnl_renderer_render(r, NULL, NULL, NULL), VBNL_OK);
    vbnl_render_stats st;
    vbnl_renderer_get_stats(r, &st, NULL);
    assert_true(st.spp >= 1);
    assert_true(st.rays > 0);
    /* the budget is kept: the tiles in flight at its end finish, no tile starts after it (a
     * 16x16 tile of this scene takes well under 10 ms) */
    assert_true(st.prepare_seconds + st.render_seconds < 0.3 + 0.1);
    /* every pixel of the film has spp samples, or, when the last pass was cut at the budget,
     * spp and that pass's samples */
    uint32_t more = 0;
    for (uint32_t y = 0; y < 32; ++y)
        for (uint32_t x = 0; x < 32; ++x) {
            uint32_t n = vbnl_film_pixel_samples(vbnl_renderer_film(r), x, y);
            if (n != st.spp) {
                assert_true(st.budget_cut && n > st.spp);
                assert_true(more == 0 || n == more);
                more = n;
            }
        }
    vbnl_renderer_destroy(r);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* Crop windows render only inside. */
static void test_crop(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(0);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = rs.height = 40;
    rs.spp = 2;
    uint32_t crop[4] = {5, 17, 23, 33};
    memcpy(rs.crop, crop, sizeof(crop));
    vbnl_renderer *r;
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, NULL), VBNL_OK);
    assert_int_equal(vbnl_renderer_render(r, NULL, NULL, NULL), VBNL_OK);
    for (uint32_t y = 0; y < 40; ++y)
        for (uint32_t x = 0; x < 40; ++x) {
            int inside = x >= 5 && x < 23 && y >= 17 && y < 33;
            assert_int_equal(vbnl_film_pixel_samples(vbnl_renderer_film(r), x, y), inside ? 2u : 0u);
        }
    vbnl_renderer_destroy(r);
    uint32_t bad[4] = {10, 10, 5, 20};
    memcpy(rs.crop, bad, sizeof(bad));
    vbnl_error err = {0};
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "crop window"));
    /* a sampler value that names none is refused too */
    memset(rs.crop, 0, sizeof(rs.crop));
    rs.sampler = (vbnl_sampler_kind)9;
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "unknown sampler 9 (valid: sobol, random)"));
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* Every public function refuses NULL handles and impossible values with an error. */
/* Raw Embree rates per ray kind (raybench.c), the mixture rate, and the per-kind counts of
 * the render statistics they are weighted with. */
static void test_ray_rates(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(0);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbnl_ray_rates rr;
    vbnl_error err = {0};
    assert_int_equal(vbnl_scene_measure_ray_rates(NULL, s, 1000, 16, 16, &rr, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_measure_ray_rates(ctx, s, 0, 16, 16, &rr, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_measure_ray_rates(ctx, s, 1000, 16, 16, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_measure_ray_rates(ctx, s, 20000, 16, 16, &rr, &err), VBNL_OK);
    assert_true(rr.camera > 0.0 && rr.closest > 0.0 && rr.shadow > 0.0 && rr.closest_packet > 0.0);
    double one;
    assert_int_equal(vbnl_scene_measure_ray_rate(ctx, s, 20000, 16, 16, &one, &err), VBNL_OK);
    assert_true(one > 0.0);
    /* the mixture rate is the total over the summed times */
    vbnl_ray_rates fixed = {4.0, 1.0, 2.0, 0.0};
    assert_true(fabs(vbnl_ray_rates_mix(&fixed, 0, 10, 0) - 1.0) < 1e-12);
    assert_true(fabs(vbnl_ray_rates_mix(&fixed, 4, 1, 2) - 7.0 / 3.0) < 1e-12);
    fixed.shadow = 0.0;
    assert_true(vbnl_ray_rates_mix(&fixed, 4, 1, 2) == 0.0);
    assert_true(vbnl_ray_rates_mix(&fixed, 4, 1, 0) > 0.0);
    assert_true(vbnl_ray_rates_mix(NULL, 1, 1, 1) == 0.0);
    /* path: one camera ray per sample, a shadow ray per traced next-event estimate */
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = rs.height = 16;
    rs.spp = 2;
    vbnl_renderer *r;
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, NULL), VBNL_OK);
    assert_int_equal(vbnl_renderer_render(r, NULL, NULL, NULL), VBNL_OK);
    vbnl_render_stats st;
    vbnl_renderer_get_stats(r, &st, NULL);
    assert_true(st.camera_rays == st.samples);
    assert_true(st.shadow_rays > 0);
    assert_true(st.camera_rays + st.shadow_rays < st.rays);
    vbnl_renderer_destroy(r);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    vbnl_error err = {0};
    uint32_t id;
    float v3a[3] = {0, 0, 0}, one[3] = {1, 1, 1}, nan3[3] = {NAN, 0, 0}, neg[3] = {-1, 0, 0};
    assert_int_equal(vbnl_context_create(NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_context_desc bigd;
    vbnl_context_desc_init(&bigd);
    bigd.threads = 5000;
    vbnl_context *ctx = NULL;
    assert_int_equal(vbnl_context_create(&bigd, &ctx, &err), VBNL_ERR_INVALID_ARGUMENT);
    ctx = make_ctx(1);
    assert_int_equal(vbnl_scene_create(NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(ctx, &s, &err), VBNL_OK);
    assert_int_equal(vbnl_scene_add_material(NULL, NULL, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_material(s, NULL, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = 1.5f;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_material_desc_init(&md);
    md.type = (vbnl_material_type)42;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_material_desc_init(&md);
    md.type = VBNL_MATERIAL_DIELECTRIC;
    md.ior = 0.5f;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_material_desc_init(&md);
    md.emission[1] = NAN;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    /* a plastic's coat curve: its fields are checked, each named */
    vbnl_material_desc_init(&md);
    md.type = VBNL_MATERIAL_PLASTIC;
    md.coat_curve = VBNL_COAT_SCHLICK;
    md.coat_falloff = 0.0f;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "coat_falloff"));
    md.coat_falloff = 5.0f;
    md.coat_max[2] = 1.5f;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "coat_max"));
    md.coat_max[2] = 1.0f;
    md.base_scale = -0.1f;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "base_scale"));
    md.base_scale = 0.6f;
    md.coat_curve = 7;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    md.coat_curve = VBNL_COAT_FRESNEL;
    md.coat_metallic = 1.0f;
    assert_int_equal(vbnl_scene_add_material(s, &md, &id, &err), VBNL_OK);
    uint32_t m = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 0.0f);
    uint32_t em = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 1.0f);
    /* meshes */
    assert_int_equal(vbnl_scene_add_mesh(s, NULL, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t idx_bad[3] = {0, 1, 3};
    vbnl_mesh_desc mesh;
    vbnl_mesh_desc_init(&mesh);
    mesh.positions = pos;
    mesh.vertex_count = 3;
    mesh.indices = idx_bad;
    mesh.triangle_count = 1;
    mesh.material = m;
    assert_int_equal(vbnl_scene_add_mesh(s, &mesh, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "out of range"));
    const uint32_t idx[3] = {0, 1, 2};
    mesh.indices = idx;
    mesh.material = 99;
    assert_int_equal(vbnl_scene_add_mesh(s, &mesh, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    mesh.material = m;
    mesh.group = 7;
    assert_int_equal(vbnl_scene_add_mesh(s, &mesh, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    const float pos_nan[9] = {0, 0, 0, 1, NAN, 0, 0, 1, 0};
    mesh.group = 0;
    mesh.positions = pos_nan;
    assert_int_equal(vbnl_scene_add_mesh(s, &mesh, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    mesh.positions = pos;
    const float singular[16] = {1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    mesh.transform = singular;
    assert_int_equal(vbnl_scene_add_mesh(s, &mesh, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    mesh.transform = NULL;
    uint32_t g;
    assert_int_equal(vbnl_scene_add_group(s, &g, &err), VBNL_OK);
    mesh.group = g;
    mesh.material = em;
    assert_int_equal(vbnl_scene_add_mesh(s, &mesh, &id, &err), VBNL_ERR_UNSUPPORTED);
    /* spheres, instances, lights */
    assert_int_equal(vbnl_scene_add_sphere(s, v3a, -1.0f, m, 0, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_sphere(s, nan3, 1.0f, m, 0, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_sphere(s, v3a, 1.0f, 123, 0, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    const float ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    assert_int_equal(vbnl_scene_add_instance(s, 0, ident, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_instance(s, g, NULL, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_instance(s, g, singular, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_point_light(s, nan3, one, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_point_light(s, v3a, neg, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_point_light(NULL, v3a, one, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_spot_light_desc spot = {sizeof(vbnl_spot_light_desc), {0, 0, 0}, {0, 0, 0}, {1, 1, 1}, 0.9f, 0.8f, 0.0f};
    assert_int_equal(vbnl_scene_add_spot_light(s, &spot, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    spot.direction[2] = -1.0f;
    spot.cos_inner = 0.5f; /* inner wider than outer */
    assert_int_equal(vbnl_scene_add_spot_light(s, &spot, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_area_light_desc al;
    vbnl_area_light_desc_init(&al);
    al.edge_u[0] = 1.0f;
    al.edge_v[0] = 2.0f; /* parallel edges */
    assert_int_equal(vbnl_scene_add_area_light(s, &al, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_add_directional_light(s, v3a, one, &id, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_set_environment(s, neg, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_set_camera(s, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_camera_desc flat = {.size = sizeof(vbnl_camera_desc), .position = {0, 0, 0}, .forward = {0, 0, -1}, .right = {1, 0, 0}, .up = {1, 0, 0}};
    assert_int_equal(vbnl_scene_set_camera(s, &flat, &err), VBNL_ERR_INVALID_ARGUMENT);
    /* commit needs a camera and a light */
    assert_int_equal(vbnl_scene_commit(s, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "camera"));
    vbnl_scene_destroy(s);
    assert_int_equal(vbnl_scene_create(ctx, &s, &err), VBNL_OK);
    vbnl_camera_desc cam;
    float p0[3] = {0, 0, 5}, t0[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    vbnl_camera_look_at(&cam, p0, t0, up, 40, 1, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
    assert_int_equal(vbnl_scene_commit(s, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "no light"));
    vbnl_scene_destroy(s);
    /* renderer */
    s = ts_box_scene(ctx, 1.0f);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    vbnl_renderer *r = NULL;
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_ERR_STATE); /* not committed */
    assert_int_equal(vbnl_scene_commit(s, &err), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, &err), VBNL_ERR_STATE);
    assert_int_equal(vbnl_scene_add_sphere(s, v3a, 1.0f, 0, 0, &id, &err), VBNL_ERR_STATE);
    assert_int_equal(vbnl_renderer_create(NULL, s, &rs, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    rs.integrator = "nope";
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(err.message, "registered: path"));
    rs.integrator = NULL;
    rs.spp = 0;
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    rs.spp = 1;
    rs.width = 0;
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    rs.width = 8;
    vbnl_params *p;
    vbnl_params_create(&p, NULL);
    vbnl_params_set_text(p, "max_dept=3", "cli", NULL);
    rs.params = p;
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(err.message, "did you mean 'max_depth'"));
    vbnl_params_destroy(p);
    rs.params = NULL;
    assert_int_equal(vbnl_renderer_render(NULL, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_renderer_prepare(NULL, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_renderer_get_stats(NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_OK);
    float buf[4];
    assert_int_equal(vbnl_film_read(vbnl_renderer_film(r), "", buf, 4, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_film_read(vbnl_renderer_film(r), "nolayer", buf, 4, &err), VBNL_ERR_UNKNOWN_NAME);
    assert_int_equal(vbnl_film_read(NULL, "", buf, 4, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_layer_info li;
    assert_int_equal(vbnl_film_layer(vbnl_renderer_film(r), 99, &li, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_scene_get_info(NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_renderer_destroy(r);
    /* destroy accepts NULL */
    vbnl_renderer_destroy(NULL);
    vbnl_scene_destroy(NULL);
    vbnl_context_destroy(NULL);
    vbnl_params_destroy(NULL);
    /* NULL error records are allowed */
    assert_int_equal(vbnl_scene_add_sphere(NULL, v3a, 1.0f, 0, 0, &id, NULL), VBNL_ERR_INVALID_ARGUMENT);
    assert_string_equal(vbnl_result_name(VBNL_ERR_IO), "VBNL_ERR_IO");
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static void test_registry(void **state)
{
    (void)state;
    assert_true(vbnl_integrator_count() >= 1);
    const vbnl_integrator_class *c = vbnl_integrator_find("path");
    assert_non_null(c);
    assert_int_equal(c->abi_major, VBNL_INTEGRATOR_ABI_MAJOR);
    assert_int_equal(c->size, sizeof(vbnl_integrator_class));
    assert_null(vbnl_integrator_find("nope"));
    assert_null(vbnl_integrator_find(NULL));
    assert_null(vbnl_integrator_at(vbnl_integrator_count()));
    for (uint32_t i = 0; i < vbnl_integrator_count(); ++i) {
        const vbnl_integrator_class *k = vbnl_integrator_at(i);
        assert_non_null(k->create);
        assert_non_null(k->render_tile);
        for (uint32_t j = 0; j < k->param_count; ++j)
            assert_non_null(k->params[j].doc);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_furnace),       cmocka_unit_test(test_close_light),
        cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_split_direct),  cmocka_unit_test(test_max_depth),
        cmocka_unit_test(test_camera_rays),
        cmocka_unit_test(test_camera_projections),   cmocka_unit_test(test_intersection),
        cmocka_unit_test(test_cancel),        cmocka_unit_test(test_time_budget),
        cmocka_unit_test(test_crop),          cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_ray_rates),
        cmocka_unit_test(test_registry),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
