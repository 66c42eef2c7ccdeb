/* The object layer around the shapes: camera framing, light mapping, the integrator block,
 * background, error messages of malformed inputs, and a small render of
 * examples/cornell-box.pov. */
#include <sys/stat.h>
#include <unistd.h>

#include "pov_test.h"
#include "vbnl/integrator.h"

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
    vbi_camera_ray(c, 300, 200, 300.0f, 100.0f, &o, &d);
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
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { omnimax location -5 look_at 0 }");
    assert_non_null(strstr(g_diags, "test.pov:2:10: warning: camera type 'omnimax' is not supported; rendering with a perspective camera"));
    vbnl_pov_scene_destroy(s);
}

/* mesh_camera: a pinhole made of one small triangle per pixel of an 8 x 6 image, on the unit
 * sphere along each pixel centre's perspective ray and wound to face along it, gives the
 * perspective camera's rays at the pixel centres; POV-Ray's checks are errors at the block. */
#define PINHOLE_MESH                                                                                   \
    "#declare S = 0.001;\n"                                                                            \
    "#declare M = mesh { #for (R, 0, 5) #for (C, 0, 7)\n"                                              \
    "  #local D = vnormalize(<(C + 0.5) / 8 - 0.5, (0.5 - (R + 0.5) / 6) * 0.75, 1>);\n"               \
    "  #local E2 = vnormalize(vcross(y, D)); #local E1 = vcross(D, E2);\n"                             \
    "  triangle { D, D + E1 * S, D + E2 * S }\n"                                                       \
    "#end #end }\n"

static void test_mesh_camera(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok("light_source { <0, 5, 0> rgb 1 }\n" PINHOLE_MESH
                           "camera { mesh_camera { 1 0 mesh { M rotate y * 90 } } location <0, 0, 0.25> }");
    const vbnl_camera_desc *c = &sc(s)->camera;
    assert_int_equal(c->projection, VBNL_CAMERA_MESH);
    assert_int_equal(c->mesh_count, 1);
    assert_int_equal(c->meshes[0].triangle_count, 48);
    for (int r = 0; r < 6; ++r)
        for (int k = 0; k < 8; ++k) {
            vec3 o, d;
            assert_int_equal(vbi_camera_ray(c, 8, 6, (float)k + 0.5f, (float)r + 0.5f, &o, &d), 1);
            /* the perspective ray of the pixel centre, turned 90 degrees about y (x' = z, z' = -x) */
            vec3 e = v3_norm(v3(((float)k + 0.5f) / 8 - 0.5f, (0.5f - ((float)r + 0.5f) / 6) * 0.75f, 1));
            e = v3(e.z, e.y, -e.x);
            /* (the face normal of a 0.001 triangle, in single precision) */
            assert_float_equal(d.x, e.x, 1e-4f);
            assert_float_equal(d.y, e.y, 1e-4f);
            assert_float_equal(d.z, e.z, 1e-4f);
            /* from the sphere plus the offset of 0.25 (location z) along the ray */
            assert_float_equal(v3_len(o), 1.25f, 2e-3f);
        }
    vbnl_pov_scene_destroy(s);
    /* direction z < 0 reverses the rays */
    s = ok("light_source { <0, 5, 0> rgb 1 }\n" PINHOLE_MESH "camera { mesh_camera { 1 0 mesh { M } } direction -z }");
    vec3 o, d;
    vbi_camera_ray(&sc(s)->camera, 8, 6, 4.0f, 3.0f, &o, &d);
    assert_true(d.z < -0.9f);
    vbnl_pov_scene_destroy(s);
    /* POV-Ray's checks */
    expect_error("light_source { <0, 5, 0> rgb 1 }\n" PINHOLE_MESH "camera { mesh_camera { 2 0 mesh { M } } }",
                 "test.pov:8:10: mesh_camera: rays per pixel (2) must not exceed the number of meshes (1) for distribution 0");
    expect_error("light_source { <0, 5, 0> rgb 1 }\n" PINHOLE_MESH "camera { mesh_camera { 1 3 mesh { M } } }",
                 "test.pov:8:10: mesh_camera: distribution 3 needs a mesh with uv_vectors");
    expect_error("light_source { <0, 5, 0> rgb 1 }\n" PINHOLE_MESH "camera { mesh_camera { 1 0 mesh { M } smooth } }",
                 "test.pov:8:10: mesh_camera: smooth needs distribution 3");
    expect_error("light_source { <0, 5, 0> rgb 1 }\ncamera { mesh_camera { 1 0 } }",
                 "test.pov:2:10: mesh_camera needs a mesh or mesh2");
    expect_error("light_source { <0, 5, 0> rgb 1 }\ncamera { mesh_camera { 1 5 } }",
                 "test.pov:2:10: mesh_camera: distribution 5 is not one of 0, 1, 2, 3");
    /* distribution 3 with uv_vectors: a quad whose uvs cover the image; a declared camera keeps its meshes */
    s = ok("light_source { <0, 5, 0> rgb 1 }\n"
           "#declare Q = mesh { triangle { <0, 0, 0>, <2, 1, 0>, <2, 0, 0> uv_vectors <0, 0>, <1, 1>, <1, 0> }\n"
           "                    triangle { <0, 0, 0>, <0, 1, 0>, <2, 1, 0> uv_vectors <0, 0>, <0, 1>, <1, 1> } }\n"
           "#declare C = camera { mesh_camera { 1 3 mesh { Q } } }\n"
           "camera { C }");
    assert_int_equal(vbi_camera_ray(&sc(s)->camera, 10, 10, 7.5f, 2.5f, &o, &d), 1);
    NEAR(o.x, 1.5f);
    NEAR(o.y, 0.75f);
    vbnl_pov_scene_destroy(s);
}

/* The other camera types, with POV-Ray's defaults and angle rules, and focal blur. */
static void test_camera_types(void **state)
{
    (void)state;
    /* orthographic without up or right: right and up grow to what the perspective camera sees at
     * the look_at distance (5 / |direction| 1); the rays are parallel */
    vbnl_pov_scene *s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { orthographic location <0, 0, -5> look_at 0 }");
    const vbnl_camera_desc *c = &sc(s)->camera;
    assert_int_equal(c->projection, VBNL_CAMERA_ORTHOGRAPHIC);
    NEAR(c->right[0], 1.33f * 5.0f);
    NEAR(c->up[1], 5.0f);
    vec3 o, d;
    vbi_camera_ray(c, 100, 100, 100.0f, 50.0f, &o, &d); /* right edge */
    NEAR(o.x, 1.33f * 5.0f * 0.5f);
    NEAR(d.z, 1.0f);
    vbnl_pov_scene_destroy(s);
    /* the exporter's form: `angle` without a number, explicit right and up kept (look_at 1 away) */
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { orthographic angle right <-4, 0, 0> location 0 look_at <0, 0, -1> up <0, 3, 0> }");
    c = &sc(s)->camera;
    NEAR(fabsf(c->right[0]), 4.0f);
    NEAR(c->up[1], 3.0f);
    NEAR(c->forward[2], -1.0f);
    vbnl_pov_scene_destroy(s);
    /* fisheye: 90 degrees unless given; the spherical camera: 360 by half of the horizontal angle */
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { fisheye location 0 look_at z }");
    assert_int_equal(sc(s)->camera.projection, VBNL_CAMERA_FISHEYE);
    NEAR(sc(s)->camera.angle[0], 90.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { spherical location 0 look_at z angle 200 }");
    NEAR(sc(s)->camera.angle[0], 200.0f);
    NEAR(sc(s)->camera.angle[1], 100.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 1 }\n#declare V = 30;\ncamera { spherical angle 120, V }");
    NEAR(sc(s)->camera.angle[1], 30.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { cylinder 3 angle 200 }");
    assert_int_equal(sc(s)->camera.projection, VBNL_CAMERA_CYLINDER_3);
    NEAR(sc(s)->camera.angle[0], 200.0f);
    vbnl_pov_scene_destroy(s);
    /* focal blur: the lens radius is a quarter of the aperture (POV-Ray's eye points spread over a
     * disc of half the aperture's half), the focus at |focal_point - location|; `blur_samples a b`
     * without a comma, as Blender's exporter writes it */
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { location <0, 0, -5> look_at 0 focal_point <0, 3, 0> aperture 0.4 blur_samples 3 9 }");
    c = &sc(s)->camera;
    NEAR(c->lens_radius, 0.1f);
    NEAR(c->focal_distance, (float)sqrt(34.0));
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { location <0, 0, -5> look_at 0 aperture 0.4 }");
    NEAR(sc(s)->camera.lens_radius, 0.0f); /* no blur_samples: no focal blur, as in POV-Ray */
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 1 }\ncamera { location <0, 0, -5> look_at 0 aperture 1 blur_samples 4, 20 }");
    NEAR(sc(s)->camera.focal_distance, 1.0f); /* the default focus: |direction| */
    vbnl_pov_scene_destroy(s);
}

/* ---- lights ----------------------------------------------------------------------------------- */

static const vbi_light *light0(vbnl_pov_scene *s) { return &sc(s)->lights[0]; }

static void test_lights(void **state)
{
    (void)state;
    /* POV-Ray's colour c lights a diffuse surface as the irradiance pi c does a Lambertian */
    const float PI_F = (float)M_PI;
    vbnl_pov_scene *s = ok("light_source { <1, 2, 3> rgb <1, 2, 3> translate x }");
    assert_int_equal(light0(s)->type, VBI_LIGHT_POINT);
    NEAR(light0(s)->p.x, 2.0f);
    NEAR(light0(s)->L.y, 2.0f * PI_F);
    vbnl_pov_scene_destroy(s);
    /* unfaded: POV-Ray's brightness at the geometry's centre (distance 100 here), so a distant
     * sun lights the scene; at least the colour itself (distance 1) */
    s = ok("sphere { 0, 1 } light_source { <0, 100, 0> rgb <1, 2, 3> }");
    NEAR(light0(s)->L.y / 2e4f, PI_F);
    vbnl_pov_scene_destroy(s);
    s = ok("sphere { 0, 1 } light_source { <0, 0.5, 0> rgb <1, 2, 3> }");
    NEAR(light0(s)->L.y, 2.0f * PI_F);
    vbnl_pov_scene_destroy(s);
    /* faded: POV-Ray's 2 / (1 + (d / fade_distance)^fade_power) at the geometry's centre, times
     * d^2: here d = 4 from the centre of the unit sphere */
    s = ok("sphere { 0, 1 } light_source { <0, 4, 0> rgb 1 fade_distance 2 fade_power 2 }");
    NEAR(light0(s)->L.x, PI_F * 16.0f * 2.0f / (1.0f + 4.0f));
    vbnl_pov_scene_destroy(s);
    s = ok("sphere { 0, 1 } light_source { <0, 4, 0> rgb 1 fade_distance 2 fade_power 1 }");
    NEAR(light0(s)->L.x, PI_F * 16.0f * 2.0f / (1.0f + 2.0f));
    assert_null(strstr(g_diags, "warning"));
    vbnl_pov_scene_destroy(s);
    /* Blender's exported lamp: fade_distance 50 for a box a few units across is almost unfaded
     * (about twice the colour), not 2 * 50^2 */
    s = ok("box { -1, 1 } light_source { <0, 3, 0> rgb 1 fade_distance 50 fade_power 2 }");
    NEAR(light0(s)->L.x, PI_F * 9.0f * 2.0f / (1.0f + 9.0f / 2500.0f));
    vbnl_pov_scene_destroy(s);
    /* no finite geometry: the irradiance at the fade distance */
    s = ok("light_source { <0, 0, 0> rgb 1 fade_distance 3 fade_power 2 }");
    NEAR(light0(s)->L.x, PI_F * 9.0f);
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 5, 0> rgb 2 spotlight point_at <0, 0, 0> radius 10 falloff 20 tightness 5 }");
    assert_int_equal(light0(s)->type, VBI_LIGHT_SPOT);
    NEAR(light0(s)->cos_inner, (float)cos(10 * M_PI / 180));
    NEAR(light0(s)->cos_outer, (float)cos(20 * M_PI / 180));
    NEAR(light0(s)->exponent, 5.0f);
    NEAR(light0(s)->n.y, -1.0f);
    NEAR(light0(s)->L.x, 2.0f * PI_F);
    vbnl_pov_scene_destroy(s);
    s = ok("light_source { <0, 10, 0> rgb 3 parallel point_at <0, 0, 0> }");
    assert_int_equal(light0(s)->type, VBI_LIGHT_DIRECTIONAL);
    NEAR(light0(s)->n.y, -1.0f);
    NEAR(light0(s)->L.x, 3.0f * PI_F);
    vbnl_pov_scene_destroy(s);
    /* area light: two-sided rectangle, radiance 2 I / A (the point light's power) */
    s = ok("light_source { <0, 5, 0> rgb 1 area_light <2, 0, 0>, <0, 0, 1>, 4, 4 adaptive 1 jitter circular orient }");
    assert_int_equal(light0(s)->type, VBI_LIGHT_RECT);
    NEAR(light0(s)->L.x, PI_F);
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
                 "test.pov:4:23: unknown parameter 'max_dept' for integrator 'path'; did you mean 'max_depth'? (valid: max_depth, rr_depth, split_direct, indirect_only, clamp)");
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
    assert_true(sc(s)->env_light != VBI_NO_LIGHT);
    NEAR(sc(s)->env_radiance.y, 0.25f);
    vbnl_pov_scene_destroy(s);
    /* sky_sphere: the pigment on the unit sphere, scaled by emission; rotate x*90 turns the
     * gradient's +y (value 1 just below it) toward +z... seen along -z the sky shows value 0.5 at
     * 45 degrees */
    s = ok("camera { location -5 look_at 0 }\nsphere { 0, 1 }\n"
           "sky_sphere { pigment { gradient y color_map { [0 rgb <0, 0.2, 1>] [1 rgb <1, 0.6, 1>] } } emission 2 }");
    const vbi_light *l = &sc(s)->lights[sc(s)->env_light];
    assert_non_null(l->env);
    vec3 L = vbi_light_Le(l, v3s(0.0f), v3(0.0f, -0.5f, -0.8660254f)); /* sky direction y = 0.5 */
    NEAR(L.x, 1.0f);
    NEAR(L.y, 0.8f);
    NEAR(L.z, 2.0f);
    assert_null(strstr(g_diags, "average colour"));
    vbnl_pov_scene_destroy(s);
    /* declared sky_sphere, a second layer on top with transmit, a transform, the background below */
    s = ok("camera { location -5 look_at 0 }\nsphere { 0, 1 }\nbackground { rgb <0, 0, 1> }\n"
           "#declare Sky = sky_sphere { pigment { rgbt <1, 0, 0, 0.5> } }\n"
           "sky_sphere { Sky pigment { gradient x color_map { [0 rgbt <0, 1, 0, 1>] [1 rgbt <0, 1, 0, 1>] } } "
           "pigment { bozo pigment_map { [0 rgbt 1] [1 rgbt 1] } } rotate y * 30 }");
    l = &sc(s)->lights[sc(s)->env_light];
    L = vbi_light_Le(l, v3s(0.0f), v3(0.0f, -1.0f, 0.0f));
    /* two clear layers over red with transmit 0.5 over the blue background */
    NEAR(L.x, 0.5f);
    NEAR(L.y, 0.0f);
    NEAR(L.z, 0.5f);
    vbnl_pov_scene_destroy(s);
    /* a scene of #version 3.6 composes its layers by POV-Ray's older rule (docs/environment.md):
     * (0.8, 0.85, 0.9) where 3.7 gives (0.8, 0.65, 0.3) */
    const char *layers = "camera { location -5 look_at 0 }\nsphere { 0, 1 }\n"
                         "sky_sphere { pigment { rgb <0.2, 0.4, 0.6> } pigment { rgbft <1, 0.5, 0, 0.5, 0.25> } emission 2 }";
    char text[512];
    snprintf(text, sizeof text, "#version 3.6;\n%s", layers);
    s = ok(text);
    L = vbi_light_Le(&sc(s)->lights[sc(s)->env_light], v3s(0.0f), v3(0.0f, 1.0f, 0.0f));
    NEAR(L.y, 0.85f);
    NEAR(L.z, 0.9f);
    vbnl_pov_scene_destroy(s);
    s = ok(layers);
    L = vbi_light_Le(&sc(s)->lights[sc(s)->env_light], v3s(0.0f), v3(0.0f, 1.0f, 0.0f));
    NEAR(L.y, 0.65f);
    NEAR(L.z, 0.3f);
    vbnl_pov_scene_destroy(s);
    expect_error(BASE "sky_sphere { emission 2 }", "test.pov:3:1: sky_sphere needs at least one pigment");
    expect_error(BASE "sky_sphere { pigment { rgb 1 } frobnicate }", "test.pov:3:32: unexpected 'frobnicate' in 'sky_sphere'");
}

/* fog { }: its items onto the core's fog (the blend itself: tests/core/test_medium.c) */
static void test_fog(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok("camera { location -5 look_at 0 }\nlight_source { <0, 5, 0> rgb 1 }\nsphere { 0, 1 }\n"
                           "fog { fog_type 2 distance 150 color rgbft <0.3, 0.5, 0.2, 0.4, 0.1> fog_offset 2 fog_alt 3 "
                           "turbulence 0.5 up z }\nfog { rgb 1 distance 20 }");
    const vbnl_scene *c = sc(s);
    assert_int_equal(c->fog_count, 2);
    assert_int_equal(c->has_media, 1);
    assert_int_equal(c->fogs[0].kind, VBNL_FOG_GROUND);
    NEAR((float)c->fogs[0].distance, 150.0f);
    NEAR(c->fogs[0].color.y, 0.5f);
    NEAR(c->fogs[0].filter, 0.4f);
    NEAR(c->fogs[0].transmit, 0.1f);
    NEAR((float)c->fogs[0].offset, 2.0f);
    NEAR((float)c->fogs[0].alt, 3.0f);
    NEAR((float)c->fogs[0].up.z, 1.0f);
    assert_int_equal(c->fogs[0].turbulent, 1);
    assert_int_equal(c->fogs[1].kind, VBNL_FOG_CONSTANT);
    NEAR(c->fogs[1].color.x, 1.0f);
    assert_null(strstr(g_diags, "warning: 'fog'"));
    vbnl_pov_scene_destroy(s);
    /* a colour identifier times a number after distance (lights/circular.pov) */
    s = ok("#declare Wheat = rgb <0.96, 0.87, 0.7>;\n" BASE "fog { distance 200 Wheat * .5 }");
    NEAR(sc(s)->fogs[0].color.x, 0.48f);
    NEAR((float)sc(s)->fogs[0].distance, 200.0f);
    vbnl_pov_scene_destroy(s);
    expect_error(BASE "fog { color rgb 1 }", "test.pov:3:1: fog distance must be positive, got 0");
    expect_error(BASE "fog { fog_type 3 distance 1 }", "test.pov:3:1: fog_type must be 1 (constant) or 2 (ground), got 3");
}

/* media { } in an interior and at the top level (the atmosphere) */
static void test_media(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok("camera { location -5 look_at 0 }\nlight_source { <0, 5, 0> rgb 1 }\n"
                           "sphere { 0, 1 pigment { rgbt 1 } hollow interior { media { absorption rgb <0.1, 0.2, 0.3> "
                           "emission 0.5 scattering { 5, rgb 0.4 eccentricity 0.3 } method 3 samples 10, 20 intervals 1 } } }\n"
                           "media { scattering { 4, 0.01 } }");
    const vbnl_scene *c = sc(s);
    assert_int_equal(c->medium_count, 2);
    assert_int_equal(c->atmosphere, 2);
    const scene_medium *m = &c->media[0];
    NEAR(m->sigma_a.y, 0.2f);
    NEAR(m->sigma_s.z, 0.4f);
    NEAR(m->emission.x, 0.5f);
    assert_int_equal(m->part[0].phase, VBNL_PHASE_HENYEY_GREENSTEIN);
    NEAR(m->part[0].g, 0.3f);
    assert_int_equal(c->media[1].part[0].phase, VBNL_PHASE_RAYLEIGH);
    /* the sphere's surface lets rays into medium 0 */
    int entered = 0;
    for (uint32_t i = 0; i < c->material_count; ++i)
        entered |= c->materials[i].is_node && c->materials[i].desc.interior == 1;
    assert_true(entered);
    assert_null(strstr(g_diags, "warning"));
    vbnl_pov_scene_destroy(s);
    /* a declared media is left out, warned */
    s = ok(BASE "#declare M = media { absorption 1 }\nsphere { 0, 1 pigment { rgbf 1 } interior { media { M } } }");
    assert_int_equal(sc(s)->medium_count, 0);
    assert_non_null(strstr(g_diags, "test.pov:4:53: warning: declared media 'M' is not supported: the media is left out"));
    vbnl_pov_scene_destroy(s);
    expect_error(BASE "sphere { 0, 1 interior { media { scattering { 6, 1 } } } }",
                 "test.pov:3:34: scattering type must be 1 to 5 (got 6)");
    /* scattering extinction e: the core part's deficit 1 - e where the albedo stays at most 1 (here
     * e >= 1 - 0.4 / 0.5 = 0.2), no warning */
    s = ok(BASE "sphere { 0, 1 pigment { rgbt 1 } hollow interior { media { scattering { 1, 0.5 extinction 0.25 } "
                "absorption <0.4, 0.45, 0.5> } media { scattering { 1, 0.5 } } } }");
    NEAR(sc(s)->media[0].part[0].ext, 0.25f);
    NEAR(sc(s)->media[0].part[1].ext, 1.0f);
    NEAR(sc(s)->media[0].sigma_x.x, 0.5f * 0.25f + 0.5f);
    assert_null(strstr(g_diags, "warning"));
    vbnl_pov_scene_destroy(s);
    /* below that it is raised to it, warned (a pure scatterer: to 1) */
    s = ok(BASE "sphere { 0, 1 pigment { rgbt 1 } hollow interior { media { absorption 0.5 "
                "scattering { 1, <1, 2, 0> extinction 0.1 } } media { scattering { 1, 1 extinction 0 } } } }");
    NEAR(sc(s)->media[0].part[0].ext, 0.75f);
    NEAR(sc(s)->media[0].part[1].ext, 1.0f);
    assert_non_null(strstr(g_diags, "test.pov:3:101: warning: scattering extinction 0.1 would make the media gain energy "
                                    "when light scatters more than once (POV-Ray scatters once): raised to 0.75, where "
                                    "its albedo is 1"));
    assert_non_null(strstr(g_diags, "raised to 1, where its albedo is 1"));
    vbnl_pov_scene_destroy(s);
    expect_error(BASE "sphere { 0, 1 interior { media { scattering { 1, 1 extinction -1 } } } }",
                 "test.pov:3:52: scattering extinction must be finite and not negative (got -1)");
}

static float v3_get(vec3 v, int c) { return c == 0 ? v.x : c == 1 ? v.y : v.z; }

/* The mean transmittance of the scene's last medium along o + t d, t in [0, len] (ratio tracking:
 * exact in the mean; closed form for constant media). */
static vec3 mean_transmittance(vbnl_pov_scene *s, vec3 o, vec3 d, float len, int n)
{
    const vbnl_scene *c = sc(s);
    vbi_rng rng = vbi_rng_for(5, 0, 0);
    vbi_rand r = {NULL, &rng};
    double acc[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i) {
        vec3 t = vbi_medium_transmittance(c, c->medium_count, o, d, len, &r);
        for (int k = 0; k < 3; ++k)
            acc[k] += v3_get(t, k) / n;
    }
    return v3((float)acc[0], (float)acc[1], (float)acc[2]);
}

/* interior fade: POV-Ray's distance attenuation (trace.cpp) as an absorbing part of the interior's medium */
static void test_interior_fade(void **state)
{
    (void)state;
    /* exponential (fade_power >= 1000): T(d) = exp(-(1 - fade_color) d / fade_distance), exactly */
    vbnl_pov_scene *s = ok(BASE "sphere { 0, 1 pigment { rgbf 1 } interior { ior 1.5 fade_distance 2 fade_power 1001 "
                                "fade_color <0.2, 0.5, 1> } }");
    const vbnl_scene *c = sc(s);
    assert_int_equal(c->medium_count, 1);
    const double fc[3] = {0.2, 0.5, 1.0};
    for (float d = 0.5f; d <= 2.0f; d += 1.5f) {
        vec3 T = mean_transmittance(s, v3(-1, 0, 0), v3(1, 0, 0), d, 1);
        for (int k = 0; k < 3; ++k)
            assert_true(fabs(v3_get(T, k) - exp(-(1.0 - fc[k]) * d / 2.0)) < 1e-5);
    }
    /* the glass lets rays into the medium */
    int entered = 0;
    for (uint32_t i = 0; i < c->material_count; ++i)
        entered |= c->materials[i].desc.interior == 1 && c->materials[i].desc.type == VBNL_MATERIAL_DIELECTRIC;
    assert_true(entered);
    assert_null(strstr(g_diags, "warning"));
    vbnl_pov_scene_destroy(s);
    /* the power law fc + (1 - fc) / (1 + (d / D)^p) is met at d = D: (1 + fc) / 2 passes */
    s = ok(BASE "#declare I = interior { ior 1.5 fade_distance 0.8 fade_power 2 }\n"
                "sphere { 0, 1 pigment { rgbf 1 } interior { I fade_color <0, 0.5, 1> } }");
    vec3 T = mean_transmittance(s, v3(-1, 0, 0), v3(1, 0, 0), 0.8f, 1);
    NEAR(T.x, 0.5f);
    NEAR(T.y, 0.75f);
    NEAR(T.z, 1.0f);
    vbnl_pov_scene_destroy(s);
    /* no fade_distance: no fade, no medium, no warning (POV-Ray's defaults: distance 0, power 0) */
    s = ok(BASE "sphere { 0, 1 pigment { rgbf 1 } interior { ior 1.5 fade_color <0, 0.5, 1> } }");
    assert_int_equal(sc(s)->medium_count, 0);
    assert_null(strstr(g_diags, "warning"));
    vbnl_pov_scene_destroy(s);
    s = ok(BASE "sphere { 0, 1 pigment { rgbf 1 } interior { ior 1.5 fade_distance 3 } }");
    assert_int_equal(sc(s)->medium_count, 0);
    assert_non_null(strstr(g_diags, "test.pov:3:43: warning: fade_power 0: POV-Ray fades with distance only for a "
                                    "fade_power above 0: no fade"));
    vbnl_pov_scene_destroy(s);
}

/* media density { }: pigments multiplying the media, in the object's space */
static void test_media_density(void **state)
{
    (void)state;
    /* spherical: 1 - r inside r < 1 (the default map, black to white); along a diameter the optical
     * depth is the integral of 1 - |x| over [-1, 1] = 1 */
    const int n = 40000;
    vbnl_pov_scene *s = ok(BASE "sphere { 0, 1 pigment { rgbt 1 } hollow interior { media { absorption 1 "
                                "density { spherical } method 3 intervals 1 } } }");
    const vbnl_scene *c = sc(s);
    assert_int_equal(c->medium_count, 1);
    assert_int_equal(c->media[0].part[0].density_count, 1);
    assert_false(c->media[0].constant);
    vec3 T = mean_transmittance(s, v3(-1, 0, 0), v3(1, 0, 0), 2.0f, n);
    assert_true(fabs(T.x - exp(-1.0)) < 4e-3);
    assert_null(strstr(g_diags, "warning"));
    vbnl_pov_scene_destroy(s);
    /* the object's transforms after the interior move the density with it; the media's own scale
     * (2: density 1 - r / 2, depth 2 - 1/2 along [-1, 1]) and several densities multiplying
     * (a colour map: 0.5 everywhere in the second) */
    s = ok(BASE "#declare D = density { spherical }\n"
                "sphere { 0, 1 pigment { rgbt 1 } hollow interior { media { absorption 1 density { D } "
                "density { spherical color_map { [0 rgb 0.5] [1 rgb 0.5] } } scale 2 } } scale 2 translate <4, 0, 0> }");
    T = mean_transmittance(s, v3(3, 0, 0), v3(1, 0, 0), 2.0f, n); /* centre 4, r / 4 after both scales */
    assert_true(fabs(T.x - exp(-0.5 * (2.0 - 0.25))) < 4e-3);
    T = mean_transmittance(s, v3(-2, 0, 0), v3(1, 0, 0), 1.5f, 10); /* r / 4 > 1 from the centre 4: nothing */
    NEAR(T.x, 1.0f);
    vbnl_pov_scene_destroy(s);
    /* a second interior block keeps the first one's media where the transforms between moved
     * them, and its own media start unmoved (POV-Ray transforms the media an interior has) */
    s = ok(BASE "sphere { 0, 1 pigment { rgbt 1 } hollow interior { media { absorption 1 density { spherical } } } "
                "translate <4, 0, 0> interior { media { absorption 1 density { spherical translate <8, 0, 0> } } } "
                "scale <1, 1, 1> }");
    T = mean_transmittance(s, v3(3, 0, 0), v3(1, 0, 0), 2.0f, n); /* the first media's, moved to 4 */
    assert_true(fabs(T.x - exp(-1.0)) < 4e-3);
    T = mean_transmittance(s, v3(7, 0, 0), v3(1, 0, 0), 2.0f, n); /* the second's, at 8, not 12 */
    assert_true(fabs(T.x - exp(-1.0)) < 4e-3);
    vbnl_pov_scene_destroy(s);
    /* transforms before the interior do not move it (POV-Ray transforms the media it has) */
    s = ok(BASE "sphere { 0, 1 pigment { rgbt 1 } translate <4, 0, 0> hollow interior { media { absorption 1 "
                "density { spherical translate <4, 0, 0> } } } }");
    T = mean_transmittance(s, v3(3, 0, 0), v3(1, 0, 0), 2.0f, n);
    assert_true(fabs(T.x - exp(-1.0)) < 4e-3);
    vbnl_pov_scene_destroy(s);
    /* density_map: densities by a pattern */
    s = ok(BASE "#declare A = density { rgb 0.25 }\n#declare B = density { rgb 0.75 }\n"
                "sphere { 0, 1 pigment { rgbt 1 } hollow interior { media { absorption 1 "
                "density { gradient x density_map { [0.5 A] [0.5 B] } } } } }");
    T = mean_transmittance(s, v3(0.1f, 0, 0), v3(1, 0, 0), 0.3f, n); /* x in [0.1, 0.4]: A */
    assert_true(fabs(T.x - exp(-0.25 * 0.3)) < 4e-3);
    T = mean_transmittance(s, v3(0.6f, 0, 0), v3(1, 0, 0), 0.3f, n); /* x in [0.6, 0.9]: B */
    assert_true(fabs(T.x - exp(-0.75 * 0.3)) < 4e-3);
    vbnl_pov_scene_destroy(s);
    /* in the atmosphere: not kept, warned */
    s = ok(BASE "media { absorption 0.01 density { spherical } }");
    assert_non_null(strstr(g_diags, "warning: a density in the atmosphere's media is not supported: taken as constant"));
    vbnl_pov_scene_destroy(s);
    expect_error(BASE "sphere { 0, 1 hollow interior { media { density { spherical foo } } } }",
                 "test.pov:3:61: undeclared identifier 'foo'");
}

/* shadowless, media_interaction, no_shadow and brilliance onto the core */
static void test_lighting_controls(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok("camera { location -5 look_at 0 }\nlight_source { <0, 5, 0> rgb 1 shadowless }\n"
                           "light_source { <0, 6, 0> rgb 1 media_interaction off }\n"
                           "light_source { <0, 7, 0> rgb 1 spotlight point_at 0 media_interaction on }\n"
                           "sphere { 0, 1 no_shadow pigment { rgb 1 } finish { brilliance 3 } }\nbox { -2, -1.5 }");
    const vbnl_scene *c = sc(s);
    int shadowless = 0, no_shadow = 0, brilliance = 0;
    for (uint32_t i = 0; i < c->light_count; ++i)
        shadowless += c->lights[i].shadowless;
    assert_int_equal(shadowless, 1);
    assert_int_equal(c->light_count, 3);
    assert_true(!c->lights[0].no_media && c->lights[1].no_media && !c->lights[2].no_media);
    for (uint32_t g = 0; g < c->geom_count; ++g)
        no_shadow += c->geoms[g].visibility == VBNL_VISIBLE_NO_SHADOW;
    assert_int_equal(no_shadow, 1);
    assert_int_equal(c->has_masks, 1);
    for (uint32_t i = 0; i < c->material_count; ++i)
        brilliance |= c->materials[i].desc.type == VBNL_MATERIAL_BRILLIANCE && c->materials[i].desc.brilliance == 3.0f;
    assert_true(brilliance);
    assert_null(strstr(g_diags, "warning: shadowless"));
    assert_null(strstr(g_diags, "warning: no_shadow"));
    assert_null(strstr(g_diags, "warning: 'brilliance'"));
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
    expect_error(BASE "camera { angle 190 }", "test.pov:3:10: camera angle must be smaller than 180 degrees, got 190");
    expect_error(BASE "camera { cylinder 5 }", "test.pov:3:10: cylinder camera type 5: valid types are 1 to 4");
    expect_error(BASE "camera { blur_samples 9, 3 }", "test.pov:3:10: blur_samples: the minimum 9 exceeds the maximum 3");
    expect_error(BASE "camera { fisheye angle -5 }", "test.pov:3:18: negative camera angle -5");
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
    expect_error(BASE "vbnl_mesh { \"no-such-file.obj\" }",
                 "test.pov:3:13: vbnl_mesh: 'no-such-file.obj' is a file that does not exist");
}

/* Numbers that are no numbers, and a world too large to trace, are errors at the statement that
 * holds them (file:line:col, the object's keyword), never blamed on another object or the scene. */
static void test_non_finite_and_huge(void **state)
{
    (void)state;
    /* a shape's value: at the expression (a NaN box corner would otherwise vanish in fmin) */
    expect_error(BASE "sphere { <pow(-8, 1/3), 0, 0>, 1 }", "test.pov:3:10: this vector's x is NaN, not a finite number");
    expect_error(BASE "union { sphere { 0, 1 }\n  box { <0, pow(-8, 1/3), 0>, 1 } }",
                 "test.pov:4:9: this vector's y is NaN, not a finite number");
    expect_error(BASE "cylinder { 0, y, 1e400 }", "test.pov:3:18: this value is infinite, not a finite number");
    expect_error("camera { location <0, 0, -10> look_at 0 }\nlight_source { <0, pow(-1, 0.5), -50> rgb 1 }\n",
                 "test.pov:2:16: this vector's y is NaN, not a finite number");
    /* a transformation, checked when the world is built: the statement that placed the object */
    expect_error(BASE "sphere { 0, 1 }\nsphere { 0, 1 scale 1e400 }",
                 "test.pov:4:1: sphere: its transformation (scale, rotate, translate, matrix) is not a finite number "
                 "(NaN or infinite)");
    expect_error(BASE "#declare O = cone { 0, 1, y, 0.5 }\nobject { O scale <1, 1, 1e300> scale 1e300 }",
                 "test.pov:3:14: cone: its transformation (scale, rotate, translate, matrix) is not a finite number "
                 "(NaN or infinite)");
    /* a light too far is an error at its statement */
    expect_error(BASE "sphere { 0, 1 }\nlight_source { <0, 0, 1e11> rgb 1 }",
                 "test.pov:4:1: light_source: its position lies beyond 1e+10 units from the origin, farther than vbnl "
                 "holds");
    /* an object too large is skipped with a warning at its own statement (POV-Ray traces no farther
     * than 1e7 either), not blamed on the light whose power it would overflow */
    vbnl_pov_scene *s = ok(BASE "sphere { 0, 1 }\nsphere { 0, 1e38 }\n  box { 0, 1e38 }\n"
                                "sphere { <0, 1e11, 0>, 1 }\nplane { y, -2e10 }");
    assert_non_null(strstr(g_diags, "test.pov:4:1: warning: sphere: its surface reaches 1e+38 units from the origin, "
                                    "beyond the 1e+10 vbnl holds (POV-Ray traces no farther than 1e7): the object is "
                                    "skipped\nsphere { 0, 1e38 }\n^\n"));
    assert_non_null(strstr(g_diags, "test.pov:5:3: warning: box: its surface reaches 1e+38 units"));
    assert_non_null(strstr(g_diags, "test.pov:6:1: warning: sphere: its surface reaches 1e+11 units"));
    assert_non_null(strstr(g_diags, "test.pov:7:1: warning: plane: a point of it reaches 2e+10 units"));
    vbi_hit h;
    assert_true(hit(s, 0, 0, -10, 0, 0, 1, &h)); /* the unit sphere alone: hit at z = -1 */
    assert_float_equal(h.t, 9.0f, 1e-3f);
    assert_false(hit(s, 0, 0, 0, 0, 0, 1, &h) && h.t > 2.0f); /* from inside it, nothing beyond */
    vbnl_pov_scene_destroy(s);
    /* a large world within the bound loads, the error's diagnostic showing the statement's line */
    s = ok(BASE "sphere { 0, 1 }\nsphere { 0, 1e9 inverse }");
    vbnl_pov_scene_destroy(s);
    vbnl_error err;
    assert_int_equal(load(BASE "sphere { 0, 1 scale <1, 1e300, 1> scale 1e300 }", &s, &err), VBNL_ERR_PARSE);
    assert_non_null(strstr(g_diags, "test.pov:3:1: error: sphere: its transformation"));
    assert_non_null(strstr(g_diags, "\nsphere { 0, 1 scale <1, 1e300, 1> scale 1e300 }\n^\n"));
}

/* A scene is untrusted: the files it names (read or written) lie in its own folder. */
static void test_scene_files(void **state)
{
    (void)state;
    expect_error(BASE "global_settings { integrator { \"vbnl\" save_lights \"/tmp/x.vls\" } }",
                 "test.pov:3:39: save_lights '/tmp/x.vls' is an absolute path: a scene writes inside its own folder and "
                 "the folders opened to it with --write-dir (give other paths on the command line)");
    expect_error(BASE "global_settings { integrator { \"vbnl\" save_lights \"a/../../x.vls\" } }",
                 "test.pov:3:39: save_lights 'a/../../x.vls' is a path that leaves the scene's folder ('..'): a scene "
                 "writes inside its own folder and the folders opened to it with --write-dir");
    expect_error(BASE "global_settings { integrator { \"vbnl\" load_lights \"/etc/passwd:a.vls\" } }",
                 "test.pov:3:39: load_lights '/etc/passwd' is an absolute path: a scene names files inside its own "
                 "folder and the folders opened to it with --read-dir (give other paths on the command line)");
    expect_error(BASE "vbnl_mesh { \"/etc/passwd\" }",
                 "test.pov:3:13: vbnl_mesh: '/etc/passwd' is an absolute path: a scene names files inside its own "
                 "folder and the folders opened to it with --read-dir (give other paths on the command line)");
    expect_error(BASE "sphere { 0, 1 pigment { image_map { png \"../x.png\" } } }",
                 "test.pov:3:41: image_map: '../x.png' is a path that leaves the scene's folder ('..'): a scene names "
                 "files inside its own folder and the folders opened to it with --read-dir");
    /* a link inside the folder that leads out of it */
    char cwd[4096];
    assert_non_null(getcwd(cwd, sizeof(cwd)));
    char dir[] = "/tmp/vbnl_scene_files_XXXXXX";
    assert_non_null(mkdtemp(dir));
    assert_int_equal(chdir(dir), 0);
    assert_int_equal(symlink("/etc/passwd", "mesh.obj"), 0);
    expect_error(BASE "vbnl_mesh { \"mesh.obj\" }",
                 "test.pov:3:13: vbnl_mesh: 'mesh.obj' is a path that a symbolic link carries out of the scene's folder");
    assert_int_equal(symlink("/tmp/elsewhere.vls", "out.vls"), 0);
    expect_error(BASE "global_settings { integrator { \"vbnl\" save_lights \"out.vls\" } }",
                 "test.pov:3:39: save_lights 'out.vls' is a symbolic link: a scene writes only plain files in its "
                 "own folder and the folders opened to it");
    unlink("mesh.obj");
    unlink("out.vls");
    assert_int_equal(chdir(cwd), 0);
    rmdir(dir);
}

/* Loads `text` as <root>/scene/test.pov with the folders given opened to it; the error message
 * or "" in `msg`. */
static vbnl_result load_opened(const char *root, const char *text, const char *read_dir, const char *write_dir,
                               char *msg, size_t n)
{
    char name[512];
    snprintf(name, sizeof name, "%s/scene/test.pov", root);
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    o.diag = collect;
    o.no_commit = 1;
    o.read_dirs = &read_dir;
    o.read_dir_count = read_dir ? 1 : 0;
    o.write_dirs = &write_dir;
    o.write_dir_count = write_dir ? 1 : 0;
    g_diags[0] = 0;
    vbnl_error err = {0};
    vbnl_pov_scene *s = NULL;
    vbnl_result r = vbnl_pov_load_text(g_ctx, name, text, strlen(text), &o, &s, &err);
    snprintf(msg, n, "%s", r == VBNL_OK ? "" : err.message);
    vbnl_pov_scene_destroy(s);
    return r;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* The folders a user opens to the scene (--read-dir, --write-dir, as POV-Ray's I/O restriction
 * settings): reads and writes there are accepted, and only there; a read folder is not a write
 * folder. */
static void test_opened_folders(void **state)
{
    (void)state;
    char root[] = "/tmp/vbnl_opened_XXXXXX", path[256], data[64], out[64], msg[1024], text[2048];
    assert_non_null(mkdtemp(root));
    const char *sub[] = {"scene", "data", "out"};
    for (int i = 0; i < 3; ++i) {
        snprintf(path, sizeof path, "%s/%s", root, sub[i]);
        assert_int_equal(mkdir(path, 0700), 0);
    }
    snprintf(data, sizeof data, "%s/data", root);
    snprintf(out, sizeof out, "%s/out", root);
    snprintf(path, sizeof path, "%s/inc.inc", data);
    write_text(path, "#declare FromData = 7;\n");
    snprintf(path, sizeof path, "%s/m.obj", data);
    write_text(path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    snprintf(path, sizeof path, "%s/lights.vls", data);
    write_text(path, "x");
    /* an include, file_exists, vbnl_mesh through '..' and load_lights by an absolute name */
    snprintf(text, sizeof text,
             BASE "#include \"%s/inc.inc\"\n#if (!file_exists(\"%s/m.obj\")) #error \"unseen\" #end\n"
                  "vbnl_mesh { \"../data/m.obj\" }\n"
                  "global_settings { integrator { \"vbnl\" load_lights \"%s/lights.vls\" } }\n",
             data, data, data);
    assert_int_equal(load_opened(root, text, NULL, NULL, msg, sizeof msg), VBNL_ERR_PARSE);
    assert_non_null(strstr(msg, "is outside the folders a scene may read"));
    assert_int_equal(load_opened(root, text, data, NULL, msg, sizeof msg), VBNL_OK);
    /* a write folder may be read too */
    assert_int_equal(load_opened(root, text, NULL, data, msg, sizeof msg), VBNL_OK);
    /* writing: only into a write folder */
    snprintf(text, sizeof text, BASE "global_settings { integrator { \"vbnl\" save_lights \"%s/x.vls\" } }\n", out);
    assert_int_equal(load_opened(root, text, out, NULL, msg, sizeof msg), VBNL_ERR_PARSE);
    assert_non_null(strstr(msg, "is an absolute path: a scene writes inside its own folder"));
    assert_int_equal(load_opened(root, text, NULL, out, msg, sizeof msg), VBNL_OK);
    snprintf(text, sizeof text, BASE "global_settings { integrator { \"vbnl\" save_lights \"../out/x.vls\" } }\n");
    assert_int_equal(load_opened(root, text, NULL, out, msg, sizeof msg), VBNL_OK);
    assert_int_equal(load_opened(root, text, NULL, data, msg, sizeof msg), VBNL_ERR_PARSE);
    /* reading elsewhere stays refused with a folder opened */
    assert_int_equal(load_opened(root, BASE "vbnl_mesh { \"/etc/passwd\" }", data, out, msg, sizeof msg),
                     VBNL_ERR_PARSE);
    assert_non_null(strstr(msg, "is an absolute path"));
    /* a folder that does not exist cannot be opened */
    snprintf(path, sizeof path, "%s/nowhere", root);
    assert_int_equal(load_opened(root, BASE, path, NULL, msg, sizeof msg), VBNL_ERR_IO);
    assert_non_null(strstr(msg, "is not a folder that can be opened to the scene"));
    const char *files[] = {"data/inc.inc", "data/m.obj", "data/lights.vls", "scene", "data", "out"};
    for (int i = 0; i < 6; ++i) {
        snprintf(path, sizeof path, "%s/%s", root, files[i]);
        assert_int_equal(i < 3 ? unlink(path) : rmdir(path), 0);
    }
    rmdir(root);
}

/* Placed objects count against the parser's memory limit: a loop of spheres ends with the
 * limit's error, not with the machine's memory. */
static void test_object_memory_limit(void **state)
{
    (void)state;
    vbnl_sdl_limits lim;
    vbnl_sdl_limits_default(&lim);
    lim.max_memory = 4u << 20; /* 4 MiB */
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    o.limits = &lim;
    const char *t = BASE "#for (I, 0, 999999)\nsphere { <I, 0, 0>, 0.1 }\n#end\n";
    vbnl_pov_scene *s = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbnl_pov_load_text(g_ctx, "test.pov", t, strlen(t), &o, &s, &err), VBNL_ERR_PARSE);
    assert_non_null(strstr(err.message, "memory limit exceeded (4194304 bytes for the scene's strings, arrays and objects)"));
    /* a few thousand fit */
    const char *few = BASE "#for (I, 0, 999)\nsphere { <I, 0, 0>, 0.1 }\n#end\n";
    assert_int_equal(vbnl_pov_load_text(g_ctx, "test.pov", few, strlen(few), &o, &s, &err), VBNL_OK);
    vbnl_pov_scene_destroy(s);
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
    vbi_hit h;
    assert_true(hit(s, 0, 1, 0, 0, 1, 0, &h));
    NEAR(h.p.y, 1.97374f);
    assert_true(h.ng.y < -0.99f);
    assert_true(h.light != VBI_NO_LIGHT);
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
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_camera),
        cmocka_unit_test(test_camera_types), cmocka_unit_test(test_mesh_camera),
        cmocka_unit_test(test_lights),
        cmocka_unit_test(test_integrator_block),
        cmocka_unit_test(test_background),
        cmocka_unit_test(test_fog),
        cmocka_unit_test(test_media),
        cmocka_unit_test(test_interior_fade),
        cmocka_unit_test(test_media_density),
        cmocka_unit_test(test_lighting_controls),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_non_finite_and_huge),
        cmocka_unit_test(test_scene_files),
        cmocka_unit_test(test_opened_folders),
        cmocka_unit_test(test_object_memory_limit),
        cmocka_unit_test(test_render_cornell),
    };
    return cmocka_run_group_tests(tests, pov_t_setup, pov_t_teardown);
}
