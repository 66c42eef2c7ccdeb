/* Object layer tests: geometry of every shape, transform order, camera framing, light mapping,
 * the integrator block, error messages, and a small render of examples/cornell-box.pov.
 * Appearance checks only use pigment colour, finish diffuse and finish emission. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_internal.h"
#include "vbnl/integrator.h"
#include "vbnl/integrator.h"
#include "vbnl/pov_scene.h"
#include "vbnl/render.h"

static vbnl_context *g_ctx;
static char g_diags[16384];

static void collect(const vbnl_sdl_diag *d, void *user)
{
    (void)user;
    size_t n = strlen(g_diags);
    snprintf(g_diags + n, sizeof g_diags - n, "%s", d->text);
}

/* A camera and a light so that every snippet commits. */
/* The same with a distant light, which does not enter the scene bounds. */
#define BASE_B "camera { location <0, 0, -10> look_at <0, 0, 0> }\nlight_source { <0, 50, -50> rgb 1 parallel point_at 0 }\n"
#define BASE "camera { location <0, 0, -10> look_at <0, 0, 0> }\nlight_source { <0, 50, -50> rgb 1 }\n"

static vbnl_result load(const char *text, vbnl_pov_scene **s, vbnl_error *err)
{
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    o.diag = collect;
    g_diags[0] = 0;
    memset(err, 0, sizeof *err);
    return vbnl_pov_load_text(g_ctx, "test.pov", text, strlen(text), &o, s, err);
}

static vbnl_pov_scene *ok(const char *text)
{
    vbnl_pov_scene *s = NULL;
    vbnl_error err;
    vbnl_result r = load(text, &s, &err);
    if (r != VBNL_OK)
        fprintf(stderr, "# %s\n%s", err.message, g_diags);
    assert_int_equal(r, VBNL_OK);
    return s;
}

static const vbnl_scene *sc(vbnl_pov_scene *s) { return vbnl_pov_scene_get(s); }

static vbnl_scene_info info(vbnl_pov_scene *s)
{
    vbnl_scene_info i;
    assert_int_equal(vbnl_scene_get_info(sc(s), &i, NULL), VBNL_OK);
    return i;
}

static void expect_error(const char *text, const char *message)
{
    vbnl_pov_scene *s = NULL;
    vbnl_error err;
    assert_int_equal(load(text, &s, &err), VBNL_ERR_PARSE);
    assert_null(s);
    assert_string_equal(err.message, message);
}

static int hit(vbnl_pov_scene *s, float ox, float oy, float oz, float dx, float dy, float dz, vbnl_hit *h)
{
    return vbnl_scene_intersect(sc(s), v3(ox, oy, oz), v3(dx, dy, dz), INFINITY, h);
}

#define NEAR(a, b) assert_float_equal((a), (b), 1e-3)

/* ---- shapes ----------------------------------------------------------------------------------- */

static void test_sphere_analytic(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "sphere { <1, 2, 3>, 0.5 scale 2 translate x }");
    vbnl_scene_info i = info(s);
    assert_int_equal(i.sphere_count, 1);
    assert_int_equal(i.triangle_count, 0);
    vbnl_hit h; /* centre (3, 4, 6), radius 1 */
    assert_true(hit(s, 3, 4, -10, 0, 0, 1, &h));
    NEAR(h.t, 15.0f);
    vbnl_pov_scene_destroy(s);
}

static void test_sphere_tessellated(void **state)
{
    (void)state;
    /* an ellipsoid: an instance of an analytic unit sphere */
    vbnl_pov_scene *s = ok(BASE_B "sphere { 0, 1 scale <2, 1, 1> }\nsphere { <0, 5, 0>, 1 scale <2, 1, 1> }");
    vbnl_scene_info i = info(s);
    assert_int_equal(i.instance_count, 2);
    assert_int_equal(i.triangle_count, 0);
    NEAR(i.bounds_max[0], 2.0f);
    NEAR(i.bounds_max[1], 6.0f);
    vbnl_hit h;
    assert_true(hit(s, -10, 0, 0, 1, 0, 0, &h));
    NEAR(h.t, 8.0f);
    assert_true(hit(s, -10, 5, 0, 1, 0, 0, &h));
    NEAR(h.t, 8.0f);
    vbnl_pov_scene_destroy(s);
    /* emissive ones are tessellated (emitters must be world geometry) */
    s = ok(BASE_B "sphere { 0, 1 scale <2, 1, 1> pigment { rgb 1 } finish { emission 1 } }");
    i = info(s);
    assert_int_equal(i.instance_count, 0);
    assert_int_equal(i.triangle_count, 2 * 64 * 31);
    NEAR(i.bounds_max[0], 2.0f);
    assert_true(hit(s, -10, 0, 0, 1, 0, 0, &h));
    NEAR(h.t, 8.0f);
    vbnl_pov_scene_destroy(s);
}

static void test_box_and_transform_order(void **state)
{
    (void)state;
    /* scale, then rotate 90 about z (+x to +y), then translate */
    vbnl_pov_scene *s = ok(BASE_B "box { <-1, -1, -1>, <1, 1, 1> scale <2, 1, 1> rotate z * 90 translate <10, 0, 0> }");
    vbnl_scene_info i = info(s);
    assert_int_equal(i.triangle_count, 12);
    NEAR(i.bounds_min[0], 9.0f);
    NEAR(i.bounds_max[0], 11.0f);
    NEAR(i.bounds_min[1], -2.0f);
    NEAR(i.bounds_max[1], 2.0f);
    vbnl_pov_scene_destroy(s);
    /* rotate <90, 90, 0>: x first (y -> z), then y (z -> x): <0,1,0> ends at <1,0,0> */
    s = ok(BASE_B "sphere { <0, 1, 0>, 0.25 rotate <90, 90, 0> }");
    i = info(s);
    NEAR(i.bounds_min[0], 0.75f);
    NEAR(i.bounds_max[0], 1.25f);
    NEAR(i.bounds_max[1], 0.25f);
    vbnl_pov_scene_destroy(s);
    /* matrix (row-vector convention: the last row translates), transform blocks and inverse */
    s = ok(BASE "#declare T = transform { scale 2 translate <1, 0, 0> }\n"
                "sphere { 0, 1 matrix <1,0,0, 0,1,0, 0,0,1, 5,6,7> }\n"
                "sphere { 0, 1 transform T translate <0, 20, 0> }\n"
                "sphere { 0, 1 transform { T inverse } translate <0, -20, 0> }");
    vbnl_hit h;
    assert_true(hit(s, 5, 6, -10, 0, 0, 1, &h));
    NEAR(h.t, 16.0f);
    assert_true(hit(s, 1, 20, -10, 0, 0, 1, &h)); /* radius 2 at <1, 20, 0> */
    NEAR(h.t, 8.0f);
    assert_true(hit(s, -0.5f, -20, -10, 0, 0, 1, &h)); /* radius 0.5 at <-0.5, -20, 0> */
    NEAR(h.t, 9.5f);
    vbnl_pov_scene_destroy(s);
}

static void test_cylinder_cone_disc_torus(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "cylinder { <0, 0, 0>, <0, 2, 0>, 1 }");
    assert_int_equal(info(s).triangle_count, 4 * 64);
    vbnl_hit h;
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h)); /* top cap */
    NEAR(h.t, 3.0f);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE_B "cylinder { <0, 0, 0>, <0, 2, 0>, 1 open translate x * 3 }");
    assert_int_equal(info(s).triangle_count, 2 * 64);
    NEAR(info(s).bounds_max[0], 4.0f);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE "cone { <0, 0, 0>, 1, <0, 1, 0>, 0 }");
    assert_int_equal(info(s).triangle_count, 2 * 64); /* side (apex: one triangle per segment) + base */
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h));
    NEAR(h.t, 4.0f);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE "disc { <0, 1, 0>, y, 2, 1 }");
    assert_int_equal(info(s).triangle_count, 2 * 64);
    assert_false(hit(s, 0, 5, 0, 0, -1, 0, &h)); /* the hole */
    assert_true(hit(s, 1.5f, 5, 0, 0, -1, 0, &h));
    NEAR(h.t, 4.0f);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE_B "torus { 2, 0.5 }");
    assert_int_equal(info(s).triangle_count, 2 * 64 * 32);
    NEAR(info(s).bounds_max[1], 0.5f);
    assert_true(hit(s, 2, 5, 0, 0, -1, 0, &h));
    assert_float_equal(h.t, 4.5f, 2e-3);
    vbnl_pov_scene_destroy(s);
}

static void test_plane(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "plane { y, -1 }\nsphere { 0, 1 }");
    vbnl_hit h;
    assert_true(hit(s, 30, 5, 40, 0, -1, 0, &h));
    NEAR(h.t, 6.0f);
    /* a generous patch: 100 times the bounding radius around the scene centre */
    assert_true(info(s).bounds_max[0] > 500.0f);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE "plane { <0, 2, 0>, 2 rotate z * 90 }"); /* n.p = d with |n| = 2: x = -1 */
    assert_true(hit(s, 5, 0, 0, -1, 0, 0, &h));
    NEAR(h.t, 6.0f);
    vbnl_pov_scene_destroy(s);
}

static void test_triangles_polygon(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "triangle { <0,0,0>, <1,0,0>, <0,1,0> }\n"
                                "smooth_triangle { <0,0,5>, y, <1,0,5>, y, <0,1,5>, z }");
    assert_int_equal(info(s).triangle_count, 2);
    vbnl_hit h;
    assert_true(hit(s, 0.2f, 0.2f, -3, 0, 0, 1, &h));
    NEAR(h.t, 3.0f);
    vbnl_pov_scene_destroy(s);
    /* an L shape (concave) and a second sub-polygon: 4 + 2 triangles */
    s = ok(BASE "polygon { 12, <0,0>, <2,0>, <2,1>, <1,1>, <1,2>, <0,2>, <0,0>,\n"
                "  <5,0>, <6,0>, <6,1>, <5,1>, <5,0> }");
    assert_int_equal(info(s).triangle_count, 6);
    assert_true(hit(s, 0.5f, 1.5f, -3, 0, 0, 1, &h));
    assert_false(hit(s, 1.5f, 1.5f, -3, 0, 0, 1, &h)); /* the notch of the L */
    assert_true(hit(s, 5.5f, 0.5f, -3, 0, 0, 1, &h));
    vbnl_pov_scene_destroy(s);
    /* a 5000-gon (a disc): fanned, with a warning, instead of O(n^3) ear clipping */
    s = ok(BASE "polygon { 5001, #for (I, 0, 4999) <cos(2 * pi * I / 5000), sin(2 * pi * I / 5000)>, #end <1, 0> }");
    assert_int_equal(info(s).triangle_count, 4998);
    assert_true(hit(s, 0.1f, 0.2f, -3, 0, 0, 1, &h));
    assert_non_null(strstr(g_diags, "test.pov:3:1: warning: polygon: a sub-polygon has more than 4096 points"));
    vbnl_pov_scene_destroy(s);
}

static const vbnl_material_desc *mat_at(vbnl_pov_scene *s, float x, float y)
{
    vbnl_hit h;
    assert_true(hit(s, x, y, -20, 0, 0, 1, &h));
    return &sc(s)->materials[h.material].desc;
}

static void test_mesh_mesh2_textures(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "#declare R = texture { pigment { rgb <1, 0, 0> } finish { diffuse 1 } }\n"
                                "mesh { triangle { <0,0,0>, <1,0,0>, <0,1,0> texture { R } }\n"
                                "       triangle { <2,0,0>, <3,0,0>, <2,1,0> }\n"
                                "       inside_vector z pigment { rgb <0, 0, 1> } finish { diffuse 1 } }");
    assert_int_equal(info(s).triangle_count, 2);
    NEAR(mat_at(s, 0.2f, 0.2f)->base_color[0], 1.0f);
    NEAR(mat_at(s, 2.2f, 0.2f)->base_color[2], 1.0f);
    NEAR(mat_at(s, 2.2f, 0.2f)->base_color[0], 0.0f);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE "mesh2 { vertex_vectors { 4, <0,0,0>, <1,0,0>, <1,1,0>, <0,1,0> }\n"
                "  normal_vectors { 1, -z }\n"
                "  texture_list { 2, texture { pigment { rgb <0, 1, 0> } }, texture { pigment { rgb <1, 1, 0> } } }\n"
                "  face_indices { 2, <0, 1, 2>, 0, <0, 2, 3>, 1 }\n"
                "  normal_indices { 2, <0, 0, 0>, <0, 0, 0> }\n"
                "  translate <10, 0, 0> }");
    assert_int_equal(info(s).triangle_count, 2);
    vbnl_pov_scene_destroy(s);
    /* counts followed directly by the first vector (no comma), as POV-Ray accepts */
    s = ok(BASE "mesh2 { vertex_vectors { 4 <0,0,0>, <1,0,0>, <1,1,0>, <0,1,0> }\n"
                "  face_indices { 2 #local I = 0; #while (I < 2) <0, 1 + I, 2 + I> #local I = I + 1; #end } }\n"
                "polygon { 4 <5, 0>, <6, 0>, <6, 1>, <5, 0> }");
    assert_int_equal(info(s).triangle_count, 3);
    vbnl_pov_scene_destroy(s);
    /* without a texture_list, face entries are vector expressions, not texture indices
     * (shapes.inc writes `F1+A, F2+A,`) */
    s = ok(BASE "#declare F = <0, 1, 2>;\n"
                "mesh2 { vertex_vectors { 4, <0,0,0>, <1,0,0>, <1,1,0>, <0,1,0> }\n"
                "  face_indices { 2, F, F + <0, 1, 1>, } }");
    assert_int_equal(info(s).triangle_count, 2);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE "mesh2 { vertex_vectors { 4, <0,0,0>, <1,0,0>, <1,1,0>, <0,1,0> }\n"
                "  normal_vectors { 1, -z }\n"
                "  texture_list { 2, texture { pigment { rgb <0, 1, 0> } }, texture { pigment { rgb <1, 1, 0> } } }\n"
                "  face_indices { 2, <0, 1, 2>, 0, <0, 2, 3>, 1 }\n"
                "  normal_indices { 2, <0, 0, 0>, <0, 0, 0> }\n"
                "  translate <10, 0, 0> }");
    NEAR(mat_at(s, 10.8f, 0.2f)->base_color[1], 0.6f); /* diffuse 0.6 (POV-Ray's default) x 1 */
    NEAR(mat_at(s, 10.8f, 0.2f)->base_color[0], 0.0f);
    NEAR(mat_at(s, 10.2f, 0.8f)->base_color[0], 0.6f);
    vbnl_hit h;
    assert_true(hit(s, 10.2f, 0.8f, -20, 0, 0, 1, &h));
    NEAR(h.ns.z, -1.0f);
    vbnl_pov_scene_destroy(s);
}

static void test_union_inheritance(void **state)
{
    (void)state;
    /* children without a texture take the union's; the object's texture fills the rest */
    vbnl_pov_scene *s = ok(BASE "#declare U = union {\n"
                                "  sphere { <0, 0, 0>, 0.5 }\n"
                                "  sphere { <2, 0, 0>, 0.5 pigment { rgb <1, 0, 0> } }\n"
                                "  pigment { rgb <0, 1, 0> } }\n"
                                "object { U translate y * 3 }\n"
                                "merge { sphere { <0, 0, 0>, 0.5 } sphere { <2, 0, 0>, 0.5 } translate -y * 3 pigment { rgb <0, 0, 1> } }\n"
                                "object { sphere { <5, 0, 0>, 0.5 } pigment { rgb 1 } }\n"
                                "#declare A = array[2] { sphere { <7, 0, 0>, 0.5 }, sphere { <9, 0, 0>, 0.5 pigment { rgb x } } }\n"
                                "object { A[1] }");
    NEAR(mat_at(s, 0, 3)->base_color[1], 0.6f);
    NEAR(mat_at(s, 2, 3)->base_color[0], 0.6f);
    NEAR(mat_at(s, 2, 3)->base_color[1], 0.0f);
    NEAR(mat_at(s, 2, -3)->base_color[2], 0.6f);
    NEAR(mat_at(s, 5, 0)->base_color[1], 0.6f);
    NEAR(mat_at(s, 9, 0)->base_color[0], 0.6f);
    assert_int_equal(info(s).sphere_count, 6);
    vbnl_pov_scene_destroy(s);
}

static void test_skipped_shapes_warn(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "sphere { 0, 1 }\n"
                                "superellipsoid { <0.5, 0.5> }\n"
                                "lathe { linear_spline 3, <0,0>, <1,1>, <0,2> }\n"
                                "#declare I = ovus { 1, 0.5 }\n"
                                "object { I }\n"
                                "cylinder { <1, 1, 1>, <1, 1, 1>, 1 }\n"
                                "#declare Unused = quadric { <1, 1, 0>, <0, 0, 0>, <0, 0, 0>, -1 }\n"
                                "#declare U = union { object { I } sphere { 0, 1 } }\n"
                                "object { U translate x } object { U translate -x }");
    assert_non_null(strstr(g_diags, "test.pov:4:1: warning: 'superellipsoid' is not supported; the object is skipped"));
    assert_non_null(strstr(g_diags, "test.pov:5:1: warning: 'lathe' is not supported; the object is skipped"));
    assert_non_null(strstr(g_diags, "test.pov:6:14: warning: 'ovus' is not supported; the object is skipped"));
    assert_non_null(strstr(g_diags, "test.pov:8:1: warning: cylinder: the two end points coincide; the object is skipped"));
    assert_null(strstr(g_diags, "quadric")); /* declared, never placed: silent */
    const char *w = strstr(g_diags, "test.pov:6:14: warning");
    assert_non_null(w);
    assert_null(strstr(w + 30, "test.pov:6:14: warning")); /* once, though placed three times */
    assert_int_equal(info(s).sphere_count, 3);
    assert_int_equal(info(s).triangle_count, 0);
    vbnl_pov_scene_destroy(s);
}

/* Does a ray from o along d hit the scene, and where (t)? */
static float hit_t(vbnl_pov_scene *s, float ox, float oy, float oz, float dx, float dy, float dz)
{
    vbnl_hit h;
    return hit(s, ox, oy, oz, dx, dy, dz, &h) ? h.t : -1.0f;
}

/* CSG: the surfaces of intersection, difference and merge against the exact solids, nesting,
 * transforms after the operands, inverse, half-spaces, textures of the cut walls. */
static void test_csg(void **state)
{
    (void)state;
    /* a box minus a sphere poking out of its front face: the ray through the centre enters the
     * hole and meets the sphere's inner wall at z = -0.3 + ... (sphere radius 0.5 at z = -1) */
    vbnl_pov_scene *s = ok(BASE "difference { box { -1, 1 } sphere { <0, 0, -1>, 0.5 } }");
    float t = hit_t(s, 0, 0, -10, 0, 0, 1);
    assert_float_equal(t, 9.5f, 0.01f); /* the bottom of the spherical dent, z = -0.5 */
    assert_float_equal(hit_t(s, 0.8f, 0.8f, -10, 0, 0, 1), 9.0f, 1e-3f); /* the box face beside it */
    /* a ray just inside the hole's rim still reaches the dent (the seam is cut, not stair-stepped) */
    assert_float_equal(hit_t(s, 0.49f, 0, -10, 0, 0, 1), 9.0f + sqrtf(0.25f - 0.49f * 0.49f), 0.03f);
    assert_float_equal(hit_t(s, 0.52f, 0, -10, 0, 0, 1), 9.0f, 1e-3f);
    /* no sphere left outside the box: from the side, the box face at x = -1 comes first */
    assert_float_equal(hit_t(s, -10, 0, -1.2f, 1, 0, 0), -1.0f, 0);
    assert_float_equal(hit_t(s, -10, 0, -0.9f, 1, 0, 0), 9.0f, 1e-3f);
    vbnl_pov_scene_destroy(s);

    /* intersection of a sphere and a box: a rounded cube; the half-space below a plane */
    s = ok(BASE "intersection { sphere { 0, 1.3 } box { -1, 1 } }\n"
                "intersection { plane { y, 0 } sphere { <5, 0, 0>, 1 } }\n");
    assert_float_equal(hit_t(s, 0, 0, -10, 0, 0, 1), 9.0f, 1e-3f);     /* the box face */
    assert_float_equal(hit_t(s, 0.95f, 0.95f, -10, 0, 0, 1), -1.0f, 0); /* the corner is cut off */
    assert_float_equal(hit_t(s, 0.95f, 0.5f, -10, 0, 0, 1), 10.0f - sqrtf(1.69f - 0.95f * 0.95f - 0.25f), 0.01f);
    assert_float_equal(hit_t(s, 5, 3, 0, 0, -1, 0), 3.0f, 1e-3f);    /* the flat top of the half ball */
    assert_float_equal(hit_t(s, 5, -3, 0, 0, 1, 0), 2.0f, 0.01f);    /* its round bottom */
    assert_float_equal(hit_t(s, 5, 0.5f, -10, 0, 0, 1), -1.0f, 0);   /* nothing above the plane */
    assert_float_equal(hit_t(s, 20, -0.5f, 10, 0, 0, -1), -1.0f, 0); /* the plane is bounded by the ball */
    vbnl_pov_scene_destroy(s);

    /* nesting, transforms after the operands, inverse and a cut wall's own texture */
    s = ok(BASE "#declare Ring = difference { cylinder { -z, z, 1 } cylinder { -2 * z, 2 * z, 0.5 } }\n"
                "difference { object { Ring } box { <0, -2, -2>, <2, 2, 2> pigment { rgb <0, 1, 0> } }\n"
                "  pigment { rgb <1, 0, 0> } rotate z * 90 translate x * 5 }\n"
                "intersection { sphere { <10, 0, 0>, 1 } sphere { <10, 0, 0>, 0.5 inverse } }\n");
    /* the half ring, turned: its remaining half is at y < 0 ... rotate z*90 maps -x to -y */
    assert_float_equal(hit_t(s, 5, -0.75f, -10, 0, 0, 1), 9.0f, 1e-3f); /* the ring's front face */
    assert_float_equal(hit_t(s, 5, 0.75f, -10, 0, 0, 1), -1.0f, 0);     /* the removed half */
    assert_float_equal(hit_t(s, 5, 0, -10, 0, 0, 1), -1.0f, 0);         /* the hole */
    assert_float_equal(hit_t(s, 5, -3, 0, 0, 1, 0), 2.0f, 0.01f);       /* outer wall from below */
    /* the cut face (at y = 0 after the rotation) has the box's green; the rest the CSG's red */
    vbnl_hit h;
    assert_true(hit(s, 5.75f, 3, 0.5f, 0, -1, 0, &h));
    assert_float_equal(h.t, 3.0f, 1e-3f);
    NEAR(sc(s)->materials[h.material].desc.base_color[0], 0.0f);
    NEAR(sc(s)->materials[h.material].desc.base_color[1], 0.6f);
    NEAR(mat_at(s, 5, -0.75f)->base_color[0], 0.6f);
    /* a hollow ball: from outside the outer shell, from inside the inner one (facing inwards) */
    assert_float_equal(hit_t(s, 10, 0, -10, 0, 0, 1), 9.0f, 0.01f);
    assert_float_equal(hit_t(s, 10, 0, 0, 0, 0, 1), 0.5f, 0.01f);
    vbnl_pov_scene_destroy(s);

    /* merge keeps only the outer surface; two overlapping balls */
    s = ok(BASE "merge { sphere { <-0.5, 0, 0>, 1 } sphere { <0.5, 0, 0>, 1 } }");
    assert_float_equal(hit_t(s, 0, 0, 0, 1, 0, 0), 1.5f, 0.01f); /* no inner wall at x = 0.5 */
    assert_float_equal(hit_t(s, -0.2f, 0, -10, 0, 0, 1), 10.0f - sqrtf(1.0f - 0.09f), 0.01f);
    vbnl_pov_scene_destroy(s);
    assert_null(strstr(g_diags, "not supported"));

    /* clipped_by: the surface inside the clipping shapes, without their surfaces; a cylinder
     * (built after its modifiers) clipped, then moved with its clip */
    s = ok(BASE "sphere { 0, 1 clipped_by { plane { y, 0 } } }\n"
                "cylinder { -z, z, 1 clipped_by { box { <-2, -2, -0.5>, <2, 2, 0.5> } } translate x * 5 }\n");
    assert_float_equal(hit_t(s, 0, 3, 0, 0, -1, 0), 4.0f, 0.01f);  /* no cap: the inside bottom */
    assert_float_equal(hit_t(s, 0, -3, 0, 0, 1, 0), 2.0f, 0.01f);
    assert_float_equal(hit_t(s, 0, 0.5f, -10, 0, 0, 1), -1.0f, 0); /* the top half is gone */
    assert_float_equal(hit_t(s, 5, 0, -10, 0, 0, 1), -1.0f, 0);    /* the cylinder's caps are cut off */
    assert_float_equal(hit_t(s, 5, -3, 0, 0, 1, 0), 2.0f, 0.01f);  /* its wall within |z| < 0.5 */
    assert_float_equal(hit_t(s, 5, -3, 0.8f, 0, 1, 0), -1.0f, 0);  /* but not beyond */
    vbnl_pov_scene_destroy(s);
}

static void test_ignored_modifiers(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "sphere { 0, 1 hollow on no_shadow no_image inverse sturm bounded_by { box { -1, 1 } }\n"
                                "  photons { target } double_illuminate }\n"
                                "sphere { x * 3, 1 no_shadow bounded_by { box { -1, 1 } } scale 0 }");
    assert_int_equal(info(s).sphere_count, 2);
    assert_non_null(strstr(g_diags, "test.pov:3:25: warning: no_shadow is ignored: every object casts shadows under global illumination"));
    assert_null(strstr(g_diags, "test.pov:5:19: warning: no_shadow")); /* once */
    const char *sc0 = strstr(g_diags, "test.pov:5:58: warning: scale by 0 changed to 1 (as POV-Ray does)");
    assert_non_null(sc0);
    assert_null(strstr(sc0 + 40, "scale by 0")); /* once per scale */
    vbnl_pov_scene_destroy(s);
}

static void test_vbnl_mesh(void **state)
{
    (void)state;
    const char *src = getenv("VBNL_SOURCE_DIR");
    if (!src)
        skip();
    char path[1024], text[2048];
    snprintf(path, sizeof path, "%s/examples/cornell-box-mesh.pov", src);
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    vbnl_pov_scene *s = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbnl_pov_load_file(g_ctx, path, &o, &s, &err), VBNL_OK);
    assert_int_equal(info(s).triangle_count, 32);
    vbnl_pov_scene_destroy(s);
    /* untrusted input: no file access */
    o.includes_disabled = 1;
    const char *t = BASE "vbnl_mesh { \"cornell-box.obj\" }";
    assert_int_equal(vbnl_pov_load_text(g_ctx, "x.pov", t, strlen(t), &o, &s, &err), VBNL_ERR_PARSE);
    assert_string_equal(err.message, "x.pov:3:13: vbnl_mesh: file access is disabled");
    /* material override and transform */
    snprintf(text, sizeof text,
             BASE_B "vbnl_mesh { \"%s/examples/cornell-box.obj\" pigment { rgb <0, 0, 1> } scale 2 translate x * 100 }", src);
    s = ok(text);
    NEAR(info(s).bounds_max[0], 102.0f);
    NEAR(mat_at(s, 100, 2)->base_color[2], 0.6f);
    vbnl_pov_scene_destroy(s);
}

/* ---- camera ----------------------------------------------------------------------------------- */

static void test_camera(void **state)
{
    (void)state;
    /* defaults: direction z, up y, right 1.33 x */
    vbnl_pov_scene *s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { location <1, 2, 3> }");
    const vbnl_camera_desc *c = &sc(s)->camera;
    NEAR(c->position[0], 1.0f);
    NEAR(c->forward[2], 1.0f);
    NEAR(c->right[0], 1.33f);
    NEAR(c->up[1], 1.0f);
    vbnl_pov_scene_destroy(s);
    /* angle is the horizontal field of view: |direction| = |right| / 2 / tan(angle / 2) */
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { right x * 1.5 angle 90 location <0, 0, -5> look_at <0, 0, 0> }");
    c = &sc(s)->camera;
    NEAR(c->forward[2], 0.75f);
    NEAR(c->right[0], 1.5f);
    NEAR(c->up[1], 1.0f);
    /* the ray through the right edge's middle leaves at 45 degrees */
    vec3 o, d;
    vbnl_camera_ray(c, 300, 200, 300.0f, 100.0f, &o, &d);
    NEAR(d.x, (float)sqrt(0.5));
    NEAR(d.z, (float)sqrt(0.5));
    vbnl_pov_scene_destroy(s);
    /* looking along +x in left-handed coordinates: right is -z */
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { location <0, 0, 0> look_at <10, 0, 0> }");
    c = &sc(s)->camera;
    NEAR(c->forward[0], 1.0f);
    NEAR(c->right[2], -1.33f);
    NEAR(c->up[1], 1.0f);
    vbnl_pov_scene_destroy(s);
    /* a right-handed scene: negative right mirrors the image */
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { right -x * 4 / 3 location <0, 0, -5> look_at 0 }");
    NEAR(sc(s)->camera.right[0], -4.0f / 3.0f);
    vbnl_pov_scene_destroy(s);
    /* sky tilts up; transforms apply last */
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { sky x location 0 look_at z up y right x translate <0, 7, 0> }");
    c = &sc(s)->camera;
    NEAR(c->up[0], 1.0f);
    NEAR(c->right[1], -1.0f);
    NEAR(c->position[1], 7.0f);
    vbnl_pov_scene_destroy(s);
    /* a declared camera reused */
    s = ok("light_source { <0, 5, 0> rgb 1 }\n#declare C = camera { location <0, 0, -3> look_at 0 }\ncamera { C rotate y * 90 }");
    c = &sc(s)->camera;
    NEAR(c->position[0], -3.0f);
    NEAR(c->forward[0], 1.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { orthographic location -5 look_at 0 }");
    assert_non_null(strstr(g_diags, "test.pov:2:10: warning: camera type 'orthographic' is not supported; rendering with a perspective camera"));
    vbnl_pov_scene_destroy(s);
}

/* ---- lights ----------------------------------------------------------------------------------- */

static const vbnl_light *light0(vbnl_pov_scene *s) { return &sc(s)->lights[0]; }

static void test_lights(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok("light_source { <1, 2, 3> rgb <1, 2, 3> translate x }");
    assert_int_equal(light0(s)->type, VBNL_LIGHT_POINT);
    NEAR(light0(s)->p.x, 2.0f);
    NEAR(light0(s)->L.y, 2.0f);
    vbnl_pov_scene_destroy(s);
    /* unfaded: POV-Ray's irradiance at the geometry's centre (distance 100 here), so a distant
     * sun lights the scene; at least the colour itself (distance 1) */
    s = ok("sphere { 0, 1 } light_source { <0, 100, 0> rgb <1, 2, 3> }");
    NEAR(light0(s)->L.y / 2e4f, 1.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("sphere { 0, 1 } light_source { <0, 0.5, 0> rgb <1, 2, 3> }");
    NEAR(light0(s)->L.y, 2.0f);
    vbnl_pov_scene_destroy(s);
    /* fade_power 2: 2 D^2 colour */
    s = ok("light_source { <0, 0, 0> rgb 1 fade_distance 3 fade_power 2 }");
    NEAR(light0(s)->L.x, 18.0f);
    vbnl_pov_scene_destroy(s);
    /* other fade powers: equal to POV-Ray's at fade_distance, with a warning */
    s = ok("light_source { <0, 0, 0> rgb 1 fade_distance 3 fade_power 1 }");
    NEAR(light0(s)->L.x, 9.0f);
    assert_non_null(strstr(g_diags, "test.pov:1:1: warning: fade_power 1: light falls off as 1/d^2; its intensity matches POV-Ray's at fade_distance"));
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 2 spotlight point_at <0, 0, 0> radius 10 falloff 20 tightness 5 }");
    assert_int_equal(light0(s)->type, VBNL_LIGHT_SPOT);
    NEAR(light0(s)->cos_inner, (float)cos(10 * M_PI / 180));
    NEAR(light0(s)->cos_outer, (float)cos(20 * M_PI / 180));
    NEAR(light0(s)->exponent, 5.0f);
    NEAR(light0(s)->n.y, -1.0f);
    NEAR(light0(s)->L.x, 2.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 10, 0> rgb 3 parallel point_at <0, 0, 0> }");
    assert_int_equal(light0(s)->type, VBNL_LIGHT_DIRECTIONAL);
    NEAR(light0(s)->n.y, -1.0f);
    NEAR(light0(s)->L.x, 3.0f);
    vbnl_pov_scene_destroy(s);
    /* area light: two-sided rectangle, radiance 2 I / A (the point light's power) */
    s = ok("light_source { <0, 5, 0> rgb 1 area_light <2, 0, 0>, <0, 0, 1>, 4, 4 adaptive 1 jitter circular orient }");
    assert_int_equal(light0(s)->type, VBNL_LIGHT_RECT);
    NEAR(light0(s)->L.x, 1.0f);
    NEAR(light0(s)->area, 2.0f);
    NEAR(light0(s)->p.x, -1.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 1 shadowless media_interaction off looks_like { sphere { 0, 1 } } }");
    assert_int_equal(info(s).sphere_count, 0);
    assert_non_null(strstr(g_diags, "warning: looks_like"));
    vbnl_pov_scene_destroy(s);
    /* lights inside unions move with them */
    s = ok("#declare L = union { light_source { <1, 0, 0> rgb 1 } sphere { <0, -5, 0>, 1 } }\nobject { L translate y * 4 }");
    NEAR(light0(s)->p.y, 4.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("light_group { light_source { <1, 0, 0> rgb 1 } sphere { <0, -5, 0>, 1 } global_lights on translate x }");
    NEAR(light0(s)->p.x, 2.0f);
    assert_int_equal(info(s).sphere_count, 1);
    assert_non_null(strstr(g_diags, "test.pov:1:1: warning: light_group is rendered as a union: its lights illuminate the whole scene"));
    vbnl_pov_scene_destroy(s);
}

/* ---- global settings, integrator block ---------------------------------------------------------- */

static void test_integrator_block(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "sphere { 0, 1 }");
    assert_string_equal(vbnl_pov_scene_integrator(s), "vbnl");
    assert_int_equal(vbnl_params_count(vbnl_pov_scene_params(s)), 0);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE "#ifdef (vbnl_version)\nglobal_settings { assumed_gamma 1 integrator { \"path\" max_depth 5 split_direct on } max_trace_level 5 }\n#end");
    assert_string_equal(vbnl_pov_scene_integrator(s), "path");
    const vbnl_params *p = vbnl_pov_scene_params(s);
    assert_int_equal(vbnl_params_count(p), 2);
    const char *name, *str, *where;
    int is_string;
    double num;
    assert_int_equal(vbnl_params_get(p, 0, &name, &is_string, &num, &str, &where), VBNL_OK);
    assert_string_equal(name, "max_depth");
    assert_float_equal(num, 5, 0);
    assert_string_equal(where, "test.pov:4:55");
    vbnl_pov_scene_destroy(s);
    s = ok(BASE "global_settings { radiosity { count 100 } ambient_light rgb 0 }");
    assert_non_null(strstr(g_diags, "test.pov:3:19: note: radiosity: global illumination is always on in vbnl; the block's settings are ignored"));
    vbnl_pov_scene_destroy(s);
    {
        /* the message lists every registered integrator, in registry order */
        char want[512] = "test.pov:3:32: unknown integrator 'pathh' (registered: ";
        for (uint32_t i = 0; i < vbnl_integrator_count(); ++i) {
            strcat(want, i ? ", " : "");
            strcat(want, vbnl_integrator_at(i)->name);
        }
        strcat(want, ")");
        assert_non_null(strstr(want, "path, vbnl, "));
        expect_error(BASE "global_settings { integrator { \"pathh\" } }", want);
    }
    expect_error(BASE "global_settings {\n  integrator { \"path\" max_dept 4 } }",
                 "test.pov:4:23: unknown parameter 'max_dept' for integrator 'path'; did you mean 'max_depth'? (valid: max_depth, rr_depth, split_direct, indirect_only)");
    expect_error(BASE "global_settings { integrator { \"path\" max_depth 2.5 } }",
                 "test.pov:3:39: parameter 'max_depth' of integrator 'path' takes an integer, got 2.5");
    expect_error(BASE "global_settings { integrator { \"path\" max_depth \"deep\" } }",
                 "test.pov:3:39: parameter 'max_depth' of integrator 'path' takes an integer");
    expect_error(BASE "global_settings { integrator { path } }",
                 "test.pov:3:32: integrator block must start with the integrator's name as a string, e.g. \"vbnl\"");
}

static void test_background(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok("camera { location -5 look_at 0 }\nbackground { rgb <0.5, 0.25, 1> }\nsphere { 0, 1 }");
    assert_true(sc(s)->env_light != VBNL_NO_LIGHT);
    NEAR(sc(s)->env_radiance.y, 0.25f);
    vbnl_pov_scene_destroy(s);
    /* sky_sphere: a constant sky of the pigment's average colour times its emission */
    s = ok("camera { location -5 look_at 0 }\nsphere { 0, 1 }\n"
           "sky_sphere { pigment { gradient y color_map { [0 rgb <0, 0.2, 1>] [1 rgb <1, 0.6, 1>] } } emission 2 rotate x * 10 }");
    assert_true(sc(s)->env_light != VBNL_NO_LIGHT);
    NEAR(sc(s)->env_radiance.x, 1.0f);
    NEAR(sc(s)->env_radiance.y, 0.8f);
    NEAR(sc(s)->env_radiance.z, 2.0f);
    assert_non_null(strstr(g_diags, "test.pov:3:1: warning: sky_sphere is rendered as a constant sky of its pigment's average colour (1 0.8 2)"));
    vbnl_pov_scene_destroy(s);
}

/* ---- errors ------------------------------------------------------------------------------------- */

static void test_errors(void **state)
{
    (void)state;
    expect_error(BASE "sphere { <0, 0, 0> }", "test.pov:3:20: expected an expression, found '}'");
    expect_error(BASE "sphere { 0, -1 }", "test.pov:3:1: sphere radius must be positive, got -1");
    expect_error(BASE "box { 0, 1 frobnicate }", "test.pov:3:12: unexpected 'frobnicate' in 'box'");
    expect_error(BASE "cylinder { 0, 0, 1 } cone { 0, 1, y, -1 }", "test.pov:3:22: cone radii must be >= 0 and not both 0");
    expect_error(BASE "plane { 0, 1 }", "test.pov:3:1: plane normal must not be zero");
    expect_error(BASE "polygon { 2, <0,0>, <1,0> }", "test.pov:3:1: polygon needs a whole number of at least 3 points, got 2");
    expect_error(BASE "object { Nothing }", "test.pov:3:10: undeclared object identifier 'Nothing'");
    expect_error(BASE "#declare F = 3;\nobject { F }", "test.pov:4:10: 'F' is a float, not an object");
    expect_error(BASE "sphere { 0, 1 translate }", "test.pov:3:25: expected an expression, found '}'");
    expect_error(BASE "mesh2 { vertex_vectors { 2, <0,0,0>, <1,0,0> } face_indices { 1, <0, 1, 2> } }",
                 "test.pov:3:1: mesh2: face 0 uses vertex index 2; vertex_vectors has 2");
    expect_error(BASE "mesh2 { vertex_vectors { 3, <0,0,0>, <1,0,0> } }",
                 "test.pov:3:46: vertex_vectors: 2 items given, 3 declared");
    expect_error(BASE "camera { angle 190 }", "test.pov:3:10: camera angle must lie in (0, 180) degrees, got 190");
    expect_error(BASE "camera { location 0 look_at 0 }", "test.pov:3:1: camera look_at equals location");
    expect_error(BASE "light_source { <0, 0, 0> rgb 1 spotlight point_at <0, 0, 0> }",
                 "test.pov:3:1: light_source: spotlight point_at equals the location");
    expect_error(BASE "union { sphere { 0, 1 } ", "test.pov:3:25: missing '}' at the end of 'union'");
    expect_error(BASE "global_settings { max_trace_levle 5 }", "test.pov:3:19: unknown global_settings item 'max_trace_levle'");
    expect_error(BASE "sphere { 0, 1 matrix <1,0,0, 0,0,0, 0,0,1, 0,0,0> }", "test.pov:3:15: matrix is singular");
    {
        /* nested CSG counts against the nesting limit (512) instead of exhausting the stack */
        size_t n = 600, len = strlen(BASE) + n * 10 + 64;
        char *deep = malloc(len);
        assert_non_null(deep);
        strcpy(deep, BASE);
        for (size_t i = 0; i < n; ++i)
            strcat(deep, "union { ");
        vbnl_pov_scene *s = NULL;
        vbnl_error err;
        assert_int_equal(load(deep, &s, &err), VBNL_ERR_PARSE);
        assert_string_equal(err.message, "test.pov:3:4097: nesting too deep (more than 512 levels of expressions, blocks or directives)");
        free(deep);
    }
    expect_error(BASE "vbnl_mesh { \"no-such-file.obj\" }", "test.pov:3:13: vbnl_mesh: cannot open 'no-such-file.obj'");
}

/* ---- a render of the example ------------------------------------------------------------------- */

static void test_render_cornell(void **state)
{
    (void)state;
    const char *src = getenv("VBNL_SOURCE_DIR");
    if (!src)
        skip();
    char path[1024];
    snprintf(path, sizeof path, "%s/examples/cornell-box.pov", src);
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    o.width = o.height = 24;
    vbnl_pov_scene *s = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbnl_pov_load_file(g_ctx, path, &o, &s, &err), VBNL_OK);
    assert_string_equal(vbnl_pov_scene_integrator(s), "vbnl");
    /* the light panel's winding faces down (for one-sided emitters) */
    vbnl_hit h;
    assert_true(hit(s, 0, 1, 0, 0, 1, 0, &h));
    NEAR(h.p.y, 1.97374f);
    assert_true(h.ng.y < -0.99f);
    assert_true(h.light != VBNL_NO_LIGHT);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = rs.height = 24;
    rs.spp = 16;
    rs.integrator = "path";
    vbnl_renderer *r = NULL;
    assert_int_equal(vbnl_renderer_create(g_ctx, sc(s), &rs, &r, &err), VBNL_OK);
    assert_int_equal(vbnl_renderer_prepare(r, NULL, NULL, &err), VBNL_OK);
    assert_int_equal(vbnl_renderer_render(r, NULL, NULL, &err), VBNL_OK);
    float px[24 * 24 * 4];
    vbnl_layer_info li;
    assert_int_equal(vbnl_film_layer(vbnl_renderer_film(r), 0, &li, NULL), VBNL_OK);
    assert_int_equal(vbnl_film_read(vbnl_renderer_film(r), "", px, 24 * 24 * li.channels, NULL), VBNL_OK);
    double mean[3] = {0, 0, 0}, left_red = 0, right_green = 0;
    for (int y = 0; y < 24; ++y)
        for (int x = 0; x < 24; ++x) {
            const float *p = px + (y * 24 + x) * li.channels;
            for (int c = 0; c < 3; ++c)
                mean[c] += p[c] / (24.0 * 24.0);
            if (x < 3 && y > 6 && y < 18)
                left_red += p[0] - p[1];
            if (x > 20 && y > 6 && y < 18)
                right_green += p[1] - p[0];
        }
    print_message("# cornell-box.pov mean %.3f %.3f %.3f\n", mean[0], mean[1], mean[2]);
    for (int c = 0; c < 3; ++c)
        assert_true(mean[c] > 0.01);
    double lum = 0.2126 * mean[0] + 0.7152 * mean[1] + 0.0722 * mean[2];
    assert_true(lum > 0.05 && lum < 2.0);
    /* framing: the red wall is on the left, the green one on the right */
    assert_true(left_red > 0);
    assert_true(right_green > 0);
    vbnl_renderer_destroy(r);
    vbnl_pov_scene_destroy(s);
}

int main(void)
{
    vbnl_context_desc cd = {2};
    if (vbnl_context_create(&cd, &g_ctx, NULL) != VBNL_OK)
        return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_analytic),
        cmocka_unit_test(test_sphere_tessellated),
        cmocka_unit_test(test_box_and_transform_order),
        cmocka_unit_test(test_cylinder_cone_disc_torus),
        cmocka_unit_test(test_plane),
        cmocka_unit_test(test_triangles_polygon),
        cmocka_unit_test(test_mesh_mesh2_textures),
        cmocka_unit_test(test_union_inheritance),
        cmocka_unit_test(test_skipped_shapes_warn),
        cmocka_unit_test(test_ignored_modifiers),
        cmocka_unit_test(test_csg),
        cmocka_unit_test(test_vbnl_mesh),
        cmocka_unit_test(test_camera),
        cmocka_unit_test(test_lights),
        cmocka_unit_test(test_integrator_block),
        cmocka_unit_test(test_background),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_render_cornell),
    };
    int r = cmocka_run_group_tests(tests, NULL, NULL);
    vbnl_context_destroy(g_ctx);
    return r;
}
