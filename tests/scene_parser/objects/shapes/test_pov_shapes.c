/* The shapes: the geometry of every shape by triangle counts, bounds and ray hits, transform
 * order, unions and CSG, modifiers, unsupported shapes, mesh files. Appearance checks only use
 * pigment colour, finish diffuse and finish emission. */
#include "pov_test.h"

static void test_sphere_analytic(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE "sphere { <1, 2, 3>, 0.5 scale 2 translate x }");
    vbnl_scene_info i = info(s);
    assert_int_equal(i.sphere_count, 1);
    assert_int_equal(i.triangle_count, 0);
    vbi_hit h; /* centre (3, 4, 6), radius 1 */
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
    vbi_hit h;
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
    vbi_hit h;
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
    vbi_hit h;
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
    vbi_hit h;
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
    vbi_hit h;
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
    vbi_hit h;
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
    vbi_hit h;
    assert_true(hit(s, 10.2f, 0.8f, -20, 0, 0, 1, &h));
    NEAR(h.ns.z, -1.0f);
    vbnl_pov_scene_destroy(s);
    /* mesh { ID modifiers }: a copy of the declared mesh, moved and textured */
    s = ok(BASE "#declare M = mesh { triangle { <0,0,0>, <1,0,0>, <0,1,0> } }\n"
                "mesh { M pigment { rgb <0, 0, 1> } finish { diffuse 1 } translate <5, 0, 0> }");
    assert_int_equal(info(s).triangle_count, 1);
    NEAR(mat_at(s, 5.2f, 0.2f)->base_color[2], 1.0f);
    assert_false(hit(s, 0.2f, 0.2f, -20, 0, 0, 1, &h));
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

static void test_curved_shapes_placed(void **state)
{
    (void)state;
    /* every POV-Ray shape is made (test_pov_curved checks their geometry); a degenerate cylinder
     * is still dropped with a warning, and a declared shape never placed costs nothing */
    vbnl_pov_scene *s = ok(BASE "sphere { 0, 1 }\n"
                                "superellipsoid { <0.5, 0.5> }\n"
                                "lathe { linear_spline 3, <0,0>, <1,1>, <0,2> }\n"
                                "#declare I = ovus { 1, 0.5 }\n"
                                "object { I }\n"
                                "cylinder { <1, 1, 1>, <1, 1, 1>, 1 }\n"
                                "#declare Unused = quadric { <1, 1, 0>, <0, 0, 0>, <0, 0, 0>, -1 }\n"
                                "#declare U = union { object { I } sphere { 0, 1 } }\n"
                                "object { U translate x } object { U translate -x }");
    assert_null(strstr(g_diags, "is not supported"));
    assert_non_null(strstr(g_diags, "test.pov:8:1: warning: cylinder: the two end points coincide; the object is skipped"));
    assert_null(strstr(g_diags, "quadric")); /* declared, never placed: silent */
    assert_int_equal(info(s).sphere_count, 3);
    assert_true(info(s).triangle_count > 1000);
    vbnl_pov_scene_destroy(s);
}

/* Does a ray from o along d hit the scene, and where (t)? */
static float hit_t(vbnl_pov_scene *s, float ox, float oy, float oz, float dx, float dy, float dz)
{
    vbi_hit h;
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
    vbi_hit h;
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
    assert_null(strstr(g_diags, "warning: no_shadow")); /* made into the core's visibility flag */
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
    /* material override and transform (the mesh beside the scene that names it) */
    snprintf(text, sizeof text, BASE_B "vbnl_mesh { \"cornell-box.obj\" pigment { rgb <0, 0, 1> } scale 2 translate x * 100 }");
    char name[1100];
    snprintf(name, sizeof name, "%s/examples/override.pov", src);
    vbnl_pov_options_init(&o);
    assert_int_equal(vbnl_pov_load_text(g_ctx, name, text, strlen(text), &o, &s, &err), VBNL_OK);
    NEAR(info(s).bounds_max[0], 102.0f);
    NEAR(mat_at(s, 100, 2)->base_color[2], 0.6f);
    vbnl_pov_scene_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_analytic),
        cmocka_unit_test(test_sphere_tessellated),
        cmocka_unit_test(test_box_and_transform_order),
        cmocka_unit_test(test_cylinder_cone_disc_torus),
        cmocka_unit_test(test_plane),
        cmocka_unit_test(test_triangles_polygon),
        cmocka_unit_test(test_mesh_mesh2_textures),
        cmocka_unit_test(test_union_inheritance),
        cmocka_unit_test(test_curved_shapes_placed),
        cmocka_unit_test(test_ignored_modifiers),
        cmocka_unit_test(test_csg),
        cmocka_unit_test(test_vbnl_mesh),
    };
    return cmocka_run_group_tests(tests, pov_t_setup, pov_t_teardown);
}
