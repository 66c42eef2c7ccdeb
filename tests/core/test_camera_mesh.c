/* vbnl core: POV-Ray's mesh camera (scene.h VBNL_CAMERA_MESH): each distribution's face for a
 * pixel, the ray's origin, direction, offset, reversal and transform, the uv index against a
 * plain search, and the scene's own copy of the meshes. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera_mesh.h"
#include "scene_internal.h"
#include "vbnl/vbnl.h"

#define W 4
#define H 3

/* A grid of W x H small triangles in the plane z = 0, face y * W + x with its centroid at (x, y), each
 * wound so that cross(c - a, b - a) points along +z. */
static float *grid_faces(uint32_t n)
{
    float *p = malloc(9 * n * sizeof *p);
    for (uint32_t f = 0; f < n; ++f) {
        float cx = (float)(f % W), cy = (float)(f / W);
        const float t[9] = {cx - 0.1f, cy - 0.1f, 0, cx - 0.1f, cy + 0.2f, 0, cx + 0.2f, cy - 0.1f, 0};
        memcpy(p + 9 * f, t, sizeof t);
    }
    return p;
}

static void identity(float m[16])
{
    memset(m, 0, 16 * sizeof *m);
    m[0] = m[5] = m[10] = m[15] = 1;
}

static vbnl_camera_desc mesh_desc(const vbnl_camera_mesh *meshes, uint32_t count, uint32_t dist, uint32_t rays)
{
    vbnl_camera_desc c;
    vbnl_camera_desc_init(&c);
    c.forward[2] = c.right[0] = c.up[1] = 1;
    c.projection = VBNL_CAMERA_MESH;
    c.meshes = meshes;
    c.mesh_count = count;
    c.mesh_distribution = dist;
    c.mesh_rays_per_pixel = rays;
    return c;
}

static void test_distributions(void **state)
{
    (void)state;
    float *p = grid_faces(W * H);
    vbnl_camera_mesh m = {W * H, p, NULL, NULL, {0}};
    identity(m.transform);
    vec3 o, d;
    /* 0: pixel (x, y) is face y * W + x, from its centroid along +z */
    vbnl_camera_desc c = mesh_desc(&m, 1, 0, 1);
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 2.7f, 1.2f, 0.5f, &o, &d), 1);
    assert_float_equal(o.x, 2.0f, 1e-6f);
    assert_float_equal(o.y, 1.0f, 1e-6f);
    assert_float_equal(d.z, 1.0f, 1e-6f);
    /* a pixel past the faces has no ray */
    vbnl_camera_mesh few = {W * H - 1, p, NULL, NULL, {0}};
    identity(few.transform);
    c.meshes = &few;
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 3.5f, 2.5f, 0.5f, &o, &d), 0);
    /* offset along the normal, then reversed; a transform moves the origin and turns the
     * direction by the inverse transpose (x scaled by 2 and z by 4, tilted face: normal (1,0,1)
     * becomes (1/2, 0, 1/4)) */
    c.meshes = &m;
    c.mesh_offset = 0.5f;
    c.mesh_reverse = 1;
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 0.5f, 0.5f, 0.5f, &o, &d), 1);
    assert_float_equal(o.z, 0.5f, 1e-6f);
    assert_float_equal(d.z, -1.0f, 1e-6f);
    const float tilted[9] = {0, 0, 0, 0, 1, 0, -1, 0, 1};
    float nrm_expect[3];
    {
        /* the face normal of `tilted`, computed as the documentation states */
        const float e1[3] = {tilted[6] - tilted[0], tilted[7] - tilted[1], tilted[8] - tilted[2]};
        const float e2[3] = {tilted[3] - tilted[0], tilted[4] - tilted[1], tilted[5] - tilted[2]};
        const float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        /* inverse transpose of diag(2, 1, 4) is diag(1/2, 1, 1/4) */
        nrm_expect[0] = n[0] / 2, nrm_expect[1] = n[1], nrm_expect[2] = n[2] / 4;
        float l = sqrtf(nrm_expect[0] * nrm_expect[0] + nrm_expect[1] * nrm_expect[1] + nrm_expect[2] * nrm_expect[2]);
        for (int k = 0; k < 3; ++k)
            nrm_expect[k] /= l;
    }
    vbnl_camera_mesh tm = {1, tilted, NULL, NULL, {2, 0, 0, 10, 0, 1, 0, 0, 0, 0, 4, 0, 0, 0, 0, 1}};
    vbnl_camera_desc ct = mesh_desc(&tm, 1, 0, 1);
    assert_int_equal(vbi_camera_mesh_ray(&ct, W, H, 0.5f, 0.5f, 0.5f, &o, &d), 1);
    assert_float_equal(o.x, 10.0f + 2.0f * (-1.0f / 3.0f), 1e-5f);
    assert_float_equal(o.z, 4.0f * (1.0f / 3.0f), 1e-5f);
    float dl = v3_len(d);
    assert_float_equal(d.x / dl, nrm_expect[0], 1e-5f);
    assert_float_equal(d.y / dl, nrm_expect[1], 1e-5f);
    assert_float_equal(d.z / dl, nrm_expect[2], 1e-5f);
    /* 0 with two rays per pixel: ray k from mesh k (pick in [0, 1) chooses k) */
    float *q = grid_faces(W * H);
    for (uint32_t i = 0; i < W * H; ++i)
        for (int j = 0; j < 3; ++j)
            q[9 * i + 3 * j + 2] = 7.0f; /* mesh 1 lies at z = 7 */
    vbnl_camera_mesh two[2] = {m, {W * H, q, NULL, NULL, {0}}};
    identity(two[1].transform);
    c = mesh_desc(two, 2, 0, 2);
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 1.5f, 1.5f, 0.2f, &o, &d), 1);
    assert_float_equal(o.z, 0.0f, 1e-6f);
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 1.5f, 1.5f, 0.7f, &o, &d), 1);
    assert_float_equal(o.z, 7.0f, 1e-6f);
    /* 1: the meshes as one list; ray 1 of pixel 0 is face W * H, the first of mesh 1 */
    two[0].triangle_count = 5;
    c = mesh_desc(two, 2, 1, 2);
    /* pixel 6 with mesh 0 cut to 5 faces: face 1 of mesh 1, centred on (1, 0) at z = 7 */
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 2.5f, 1.5f, 0.1f, &o, &d), 1);
    assert_float_equal(o.x, 1.0f, 1e-6f);
    assert_float_equal(o.z, 7.0f, 1e-6f);
    /* ray 1 of the last pixel is face 11 + 12 = 23 > 5 + 12 faces: none */
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 3.5f, 2.5f, 0.9f, &o, &d), 0);
    two[0].triangle_count = W * H;
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 0.5f, 0.5f, 0.9f, &o, &d), 1);
    assert_float_equal(o.z, 7.0f, 1e-6f);
    assert_float_equal(o.x, 0.0f, 1e-6f);
    /* 2: side by side, W / 2 columns each; pixel (3, 1) is mesh 1's face 1 * 2 + 1 */
    c = mesh_desc(two, 2, 2, 1);
    assert_int_equal(vbi_camera_mesh_ray(&c, W, H, 3.5f, 1.5f, 0.5f, &o, &d), 1);
    assert_float_equal(o.z, 7.0f, 1e-6f);
    assert_float_equal(o.x, 3.0f, 1e-6f); /* face 3: (3, 0) */
    assert_float_equal(o.y, 0.0f, 1e-6f);
    free(p);
    free(q);
}

/* Distribution 3: two triangles whose uvs cover [0, 1]^2 map the image onto a 2 x 1 rectangle at
 * z = 0; with smooth, the corner normals are interpolated. The scene's copy (uv index) agrees with
 * the plain search at every pixel. */
static void test_uv_distribution(void **state)
{
    (void)state;
    const float pos[18] = {0, 0, 0, 2, 1, 0, 2, 0, 0, /* uv (0,0) (1,1) (1,0) */
                           0, 0, 0, 0, 1, 0, 2, 1, 0}; /* uv (0,0) (0,1) (1,1) */
    const float uv[12] = {0, 0, 1, 1, 1, 0, 0, 0, 0, 1, 1, 1};
    float nrm[18];
    for (int i = 0; i < 6; ++i) {
        nrm[3 * i] = i % 3 == 1 ? 1.0f : 0.0f; /* corners 1 and 4 lean along +x */
        nrm[3 * i + 1] = 0;
        nrm[3 * i + 2] = 1;
    }
    vbnl_camera_mesh m = {2, pos, nrm, uv, {0}};
    identity(m.transform);
    vbnl_camera_desc c = mesh_desc(&m, 1, 3, 1);
    vec3 o, d;
    /* pixel point (px, py) in a 10 x 10 image is uv (px / 10, 1 - py / 10), the point (2u, v) */
    assert_int_equal(vbi_camera_mesh_ray(&c, 10, 10, 7.5f, 2.5f, 0.5f, &o, &d), 1);
    assert_float_equal(o.x, 1.5f, 1e-5f);
    assert_float_equal(o.y, 0.75f, 1e-5f);
    assert_float_equal(fabsf(d.z), 1.0f, 1e-6f);
    c.mesh_smooth = 1;
    assert_int_equal(vbi_camera_mesh_ray(&c, 10, 10, 7.5f, 2.5f, 0.5f, &o, &d), 1);
    assert_true(d.x > 0.1f);
    /* the scene's copy: its uv index finds the same faces as the plain search */
    vbnl_context *ctx = NULL;
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_context_create(NULL, &ctx, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &c, NULL), VBNL_OK);
    assert_non_null(s->camera.mesh_index);
    assert_ptr_not_equal(s->camera.meshes, &m);
    for (int y = 0; y < 10; ++y)
        for (int x = 0; x < 10; ++x) {
            vec3 o1, d1, o2, d2;
            int a = vbi_camera_mesh_ray(&c, 10, 10, (float)x + 0.3f, (float)y + 0.6f, 0.5f, &o1, &d1);
            int b = vbi_camera_mesh_ray(&s->camera, 10, 10, (float)x + 0.3f, (float)y + 0.6f, 0.5f, &o2, &d2);
            assert_int_equal(a, b);
            assert_float_equal(o1.x, o2.x, 1e-6f);
            assert_float_equal(d1.x, d2.x, 1e-6f);
        }
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static void test_refused(void **state)
{
    (void)state;
    const float pos[9] = {0, 0, 0, 0, 1, 0, 1, 0, 0};
    vbnl_camera_mesh m = {1, pos, NULL, NULL, {0}};
    identity(m.transform);
    vbnl_context *ctx = NULL;
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_context_create(NULL, &ctx, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    vbnl_error err = {0};
    vbnl_camera_desc c = mesh_desc(&m, 1, 0, 2); /* two rays, one mesh */
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "rays per pixel"));
    c = mesh_desc(&m, 1, 3, 1); /* no uvs */
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_ERR_INVALID_ARGUMENT);
    c = mesh_desc(&m, 1, 4, 1);
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_ERR_INVALID_ARGUMENT);
    c = mesh_desc(&m, 0, 0, 1);
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_camera_mesh flat = m;
    flat.transform[10] = 0; /* singular */
    c = mesh_desc(&flat, 1, 0, 1);
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_ERR_INVALID_ARGUMENT);
    /* a valid one replaces the previous camera; the caller's arrays may go */
    float *copy = malloc(sizeof pos);
    memcpy(copy, pos, sizeof pos);
    vbnl_camera_mesh mine = {1, copy, NULL, NULL, {0}};
    identity(mine.transform);
    c = mesh_desc(&mine, 1, 0, 1);
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &c, &err), VBNL_OK);
    memset(copy, 0, sizeof pos);
    free(copy);
    vec3 o, d;
    assert_int_equal(vbi_camera_ray(&s->camera, 1, 1, 0.5f, 0.5f, &o, &d), 1);
    assert_float_equal(o.x, 1.0f / 3.0f, 1e-6f);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_distributions),
        cmocka_unit_test(test_uv_distribution),
        cmocka_unit_test(test_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
