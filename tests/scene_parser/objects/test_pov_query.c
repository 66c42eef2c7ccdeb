/* The object functions min_extent, max_extent, inside and trace (objects/query.c) as a scene sees
 * them: each snippet prints its results with #debug, and the values are checked against the
 * analytic answers. */
#include "pov_test.h"

/* Loads BASE + `text`, which prints "Q:" followed by comma-separated numbers; reads n of them. */
static void values(const char *text, double *out, int n)
{
    char buf[8192];
    snprintf(buf, sizeof buf, BASE_B "%s", text);
    vbnl_pov_scene *s = ok(buf);
    const char *q = strstr(g_diags, "Q:");
    if (!q)
        fprintf(stderr, "# no Q: in\n%s", g_diags);
    assert_non_null(q);
    q += 2;
    for (int i = 0; i < n; ++i) {
        char *end;
        out[i] = strtod(q, &end);
        assert_true(end != q);
        q = end;
        while (*q == ',' || *q == ' ')
            ++q;
    }
    vbnl_pov_scene_destroy(s);
}

#define CLOSE(a, b, tol) assert_float_equal((a), (b), (tol))

/* "#debug concat("Q:", vstr(min_extent(O)), ",", vstr(max_extent(O)))" for the declared O */
static void extent(const char *decl, double lo[3], double hi[3])
{
    char buf[4096];
    snprintf(buf, sizeof buf,
             "%s\n#debug concat(\"Q:\", vstr(3, min_extent(O), \",\", 0, 9), \",\", "
             "vstr(3, max_extent(O), \",\", 0, 9), \"\\n\")\n",
             decl);
    double v[6];
    values(buf, v, 6);
    memcpy(lo, v, 3 * sizeof *lo);
    memcpy(hi, v + 3, 3 * sizeof *hi);
}

static void test_extent(void **state)
{
    (void)state;
    double lo[3], hi[3];
    /* a sphere: centre -+ radius */
    extent("#declare O = sphere { <1, 2, 3>, 0.5 }", lo, hi);
    CLOSE(lo[0], 0.5, 1e-9);
    CLOSE(lo[1], 1.5, 1e-9);
    CLOSE(lo[2], 2.5, 1e-9);
    CLOSE(hi[0], 1.5, 1e-9);
    CLOSE(hi[1], 2.5, 1e-9);
    CLOSE(hi[2], 3.5, 1e-9);
    /* a rotated sphere keeps its exact box (POV-Ray 3.7 prints 2.328427 .. 3.328427 in x) */
    extent("#declare O = sphere { <1, 2, 3>, 0.5 rotate 45 * y }", lo, hi);
    CLOSE(lo[0], 2.828427125 - 0.5, 1e-9);
    CLOSE(hi[0], 2.828427125 + 0.5, 1e-9);
    CLOSE(lo[2], 1.414213562 - 0.5, 1e-9);
    /* a torus rotated: the box of its rotated box (POV-Ray 3.7 prints the same values) */
    extent("#declare O = torus { 1, 0.3 rotate 30 * x translate <0.2, 0.1, 0> }", lo, hi);
    CLOSE(lo[0], -1.1, 1e-6);
    CLOSE(hi[0], 1.5, 1e-6);
    CLOSE(lo[1], -0.809808, 1e-6);
    CLOSE(hi[2], 1.275833, 1e-6);
    /* a box scaled, rotated 90 degrees about z (x -> y, y -> -x) and moved */
    extent("#declare O = box { <0, 0, 0>, <1, 2, 3> scale 2 rotate 90 * z translate <10, 0, 0> }", lo, hi);
    CLOSE(lo[0], 6, 1e-6);
    CLOSE(hi[0], 10, 1e-6);
    CLOSE(lo[1], 0, 1e-6);
    CLOSE(hi[1], 2, 1e-6);
    CLOSE(lo[2], 0, 1e-6);
    CLOSE(hi[2], 6, 1e-6);
    /* a CSG: a box minus a box over its top half keeps the bottom half */
    extent("#declare O = difference { box { -1, 1 } box { <-2, 0, -2>, <2, 2, 2> } }", lo, hi);
    CLOSE(lo[1], -1, 1e-6);
    CLOSE(hi[1], 0, 1e-6);
    CLOSE(lo[0], -1, 1e-6);
    CLOSE(hi[2], 1, 1e-6);
    /* a union of two spheres */
    extent("#declare O = union { sphere { 0, 1 } sphere { <5, 0, 0>, 2 } }", lo, hi);
    CLOSE(lo[0], -1, 1e-9);
    CLOSE(hi[0], 7, 1e-9);
    CLOSE(lo[1], -2, 1e-9);
    /* a plane: POV-Ray's infinite box */
    extent("#declare O = plane { y, 0 }", lo, hi);
    CLOSE(lo[0], -1e10, 1);
    CLOSE(hi[2], 1e10, 1);
}

/* Text_Width (shapes.inc) is max_extent(T).x - min_extent(T).x of the text: for one glyph its
 * drawn width; each Spacing adds to every advance but the last. The width agrees with the
 * bounds of the same text placed in the scene. */
static void test_text_width(void **state)
{
    (void)state;
    double w[3];
    values("#include \"shapes.inc\"\n"
           "#debug concat(\"Q:\", str(Text_Width(\"timrom.ttf\", \"VAT\", 1, 0), 0, 9), \",\", "
           "str(Text_Width(\"timrom.ttf\", \"VAT\", 1, 0.5), 0, 9), \",\", "
           "str(Text_Width(\"timrom.ttf\", \"VAT\", 2, 0), 0, 9), \"\\n\")\n",
           w, 3);
    assert_true(w[0] > 1.0 && w[0] < 3.0); /* three glyphs of about 0.6 em */
    CLOSE(w[1], w[0] + 2 * 0.5, 1e-6);    /* two gaps widened by the spacing */
    CLOSE(w[2], 2 * w[0], 1e-6);          /* scale <Size, Size, 1> */
    vbnl_pov_scene *s = ok(BASE_B "text { ttf \"timrom.ttf\" \"VAT\" 1, 0 }");
    vbnl_scene_info i = info(s);
    CLOSE(w[0], i.bounds_max[0] - i.bounds_min[0], 1e-4);
    vbnl_pov_scene_destroy(s);
}

static void test_trace(void **state)
{
    (void)state;
    double v[6];
    /* a sphere of radius 2 at <1, 0, 0>, hit from the left: the point <-1, 0, 0>, normal -x */
    values("#declare O = sphere { <1, 0, 0>, 2 }\n#declare N = <9, 9, 9>;\n"
           "#declare P = trace(O, <-10, 0, 0>, <3, 0, 0>, N);\n"
           "#debug concat(\"Q:\", vstr(3, P, \",\", 0, 9), \",\", vstr(3, N, \",\", 0, 9), \"\\n\")\n",
           v, 6);
    CLOSE(v[0], -1, 1e-9);
    CLOSE(v[1], 0, 1e-9);
    CLOSE(v[3], -1, 1e-9);
    CLOSE(v[4], 0, 1e-9);
    /* an oblique ray: the point at distance 2 from the centre, the normal along it */
    values("#declare O = sphere { 0, 2 }\n"
           "#declare P = trace(O, <1, 0, -10>, z, N);\n"
           "#debug concat(\"Q:\", vstr(3, P, \",\", 0, 9), \",\", vstr(3, N, \",\", 0, 9), \"\\n\")\n",
           v, 6);
    CLOSE(v[0], 1, 1e-9);
    CLOSE(v[2], -sqrt(3.0), 1e-9);
    CLOSE(v[3], 0.5, 1e-9);
    CLOSE(v[5], -sqrt(3.0) / 2, 1e-9);
    /* a miss: <0,0,0> for the point and the normal */
    values("#declare O = sphere { 0, 1 }\n#declare N = <9, 9, 9>;\n"
           "#declare P = trace(O, <0, 5, -10>, z, N);\n"
           "#debug concat(\"Q:\", vstr(3, P, \",\", 0, 9), \",\", vstr(3, N, \",\", 0, 9), \"\\n\")\n",
           v, 6);
    for (int k = 0; k < 6; ++k)
        CLOSE(v[k], 0, 0);
    /* a ray pointing away from the object misses too */
    values("#declare O = sphere { 0, 1 }\n"
           "#declare P = trace(O, <0, 0, -10>, -z);\n"
           "#debug concat(\"Q:\", vstr(3, P, \",\", 0, 9), \"\\n\")\n",
           v, 3);
    CLOSE(v[2], 0, 0);
    /* a transformed box (a tessellated shape): a unit cube scaled by 2 and rotated 45 degrees about
     * y, hit along -y from above: the top face at y = 1, normal +y */
    values("#declare O = box { -0.5, 0.5 scale 2 rotate 45 * y translate <0, 3, 0> }\n"
           "#declare P = trace(O, <0.2, 10, 0.1>, -y, N);\n"
           "#debug concat(\"Q:\", vstr(3, P, \",\", 0, 9), \",\", vstr(3, N, \",\", 0, 9), \"\\n\")\n",
           v, 6);
    CLOSE(v[0], 0.2, 1e-9);
    CLOSE(v[1], 4, 1e-6);
    CLOSE(v[2], 0.1, 1e-9);
    CLOSE(v[4], 1, 1e-6);
    /* an ellipsoid (a non-uniformly scaled sphere): the normal is the inverse transpose's */
    values("#declare O = sphere { 0, 1 scale <2, 1, 1> }\n"
           "#declare P = trace(O, <sqrt(2), 10, 0>, -y, N);\n"
           "#debug concat(\"Q:\", vstr(3, P, \",\", 0, 9), \",\", vstr(3, N, \",\", 0, 9), \"\\n\")\n",
           v, 6);
    /* x^2/4 + y^2 = 1 at x = sqrt(2): y = sqrt(1/2); normal ~ (x/4, y) = (sqrt(2)/4, sqrt(1/2)) */
    CLOSE(v[1], sqrt(0.5), 1e-9);
    double nx = sqrt(2.0) / 4, ny = sqrt(0.5), nl = sqrt(nx * nx + ny * ny);
    CLOSE(v[3], nx / nl, 1e-9);
    CLOSE(v[4], ny / nl, 1e-9);
    /* a grazing ray down the side of a cylinder (tessellated): the point is moved onto the exact
     * surface, y = sqrt(r^2 - x^2), which the triangles miss by about 0.01 here (POV-Ray's
     * language/trace.pov at clock 0) */
    values("#declare O = cylinder { -z, z, 0.5 }\n"
           "#declare P = trace(O, <-0.499, 2, 0>, -y);\n"
           "#debug concat(\"Q:\", vstr(3, P, \",\", 0, 12), \"\\n\")\n",
           v, 3);
    CLOSE(v[0], -0.499, 1e-12);
    CLOSE(v[1], sqrt(0.25 - 0.499 * 0.499), 1e-9);
    /* the same on a CSG whose box top (y = 0) lies just below the cylinder's exact surface: the
     * point and the normal are the cylinder's (POV-Ray 3.7 prints -1.49900,0.03161,0.00000 and
     * the normal -0.99800,0.06321,0; the normal here is the triangles', within 0.03) */
    values("#declare O = difference { union { box { <-1.5, -0.6, -0.001>, <1.5, 0, 0.1> }\n"
           "cylinder { <-1, 0, -0.003>, <-1, 0, 0.11>, 0.5 } } cylinder { <0, 0, -0.003>, <0, 0, 0.11>, 0.5 } }\n"
           "#declare P = trace(O, <-1.499, 2, 0>, -y, N);\n"
           "#debug concat(\"Q:\", vstr(3, P, \",\", 0, 12), \",\", vstr(3, N, \",\", 0, 12), \"\\n\")\n",
           v, 6);
    CLOSE(v[1], sqrt(0.25 - 0.499 * 0.499), 1e-9);
    CLOSE(v[3], -0.998, 0.03);
    CLOSE(v[4], 0.06321, 0.03);
    /* a plane, and the nearest of a union's members */
    values("#declare O = union { plane { y, -1 } sphere { <0, 2, 0>, 1 } }\n"
           "#declare A = trace(O, <0, 10, 0>, -y);\n#declare B = trace(O, <5, 10, 0>, -y, N);\n"
           "#debug concat(\"Q:\", vstr(3, A, \",\", 0, 9), \",\", vstr(3, B, \",\", 0, 9), \",\", "
           "vstr(3, N, \",\", 0, 9), \"\\n\")\n",
           v, 6);
    CLOSE(v[1], 3, 1e-9);
    CLOSE(v[4], -1, 1e-9);
    /* a CSG: a box with a hole bored along z; a ray down the hole's axis meets nothing, one
     * beside the hole meets the box's front face */
    values("#declare O = difference { box { -1, 1 } cylinder { -2 * z, 2 * z, 0.5 } }\n"
           "#declare A = trace(O, <0, 0, -10>, z);\n#declare B = trace(O, <0.75, 0, -10>, z);\n"
           "#debug concat(\"Q:\", vstr(3, A, \",\", 0, 9), \",\", vstr(3, B, \",\", 0, 9), \"\\n\")\n",
           v, 6);
    CLOSE(v[2], 0, 0);
    CLOSE(v[3], 0.75, 1e-9);
    CLOSE(v[5], -1, 1e-6);
}

static void test_inside(void **state)
{
    (void)state;
    double v[8];
    values("#declare S = sphere { <1, 0, 0>, 1 }\n"
           "#declare B = box { 0, 1 rotate 45 * z }\n"
           "#declare D = difference { box { -1, 1 } sphere { 0, 0.5 } }\n"
           "#declare T = triangle { 0, x, y }\n"
           "#debug concat(\"Q:\", str(inside(S, <1.5, 0, 0>), 0, 0), \",\", str(inside(S, <-0.1, 0, 0>), 0, 0), \",\", "
           "str(inside(B, <0, 1, 0.5>), 0, 0), \",\", str(inside(B, <0.5, 0.2, 0.5>), 0, 0), \",\", "
           "str(inside(D, <0.8, 0.8, 0>), 0, 0), \",\", str(inside(D, <0.1, 0, 0>), 0, 0), \",\", "
           "str(inside(D, <2, 0, 0>), 0, 0), \",\", str(inside(T, <0.1, 0.1, 0>), 0, 0), \"\\n\")\n",
           v, 8);
    CLOSE(v[0], 1, 0);
    CLOSE(v[1], 0, 0);
    CLOSE(v[2], 1, 0); /* the rotated box's top corner region */
    CLOSE(v[3], 0, 0); /* below its rotated bottom edge */
    CLOSE(v[4], 1, 0);
    CLOSE(v[5], 0, 0); /* in the hole */
    CLOSE(v[6], 0, 0);
    CLOSE(v[7], 0, 0); /* a triangle has no inside */
}

static void test_errors(void **state)
{
    (void)state;
    expect_error(BASE "#declare P = trace(sphere { 0, 1 }, 0, <0, 0, 0>);",
                 "test.pov:3:40: trace(): the direction must be a finite vector of non-zero length");
    expect_error(BASE "#declare P = min_extent(3);",
                 "test.pov:3:25: argument 1 of min_extent() must be an object, found a float");
    /* a declared transform is an object-layer value but not an object */
    expect_error(BASE "#declare M = transform { scale 2 }\n#declare P = inside(M, 0);",
                 "test.pov:4:21: argument 1 of inside() must be an object, found a transform");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_extent),
        cmocka_unit_test(test_text_width),
        cmocka_unit_test(test_trace),
        cmocka_unit_test(test_inside),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, pov_t_setup, pov_t_teardown);
}
