/* The curved shapes against their analytic definitions (POV-Ray 3.7's): for each shape, fixed
 * rays from around it, through it, grazing its silhouette and from inside it are traced in the
 * built scene and compared with the exact surface, found by marching the shape's own function
 * along the ray and bisecting: the hit distance and point (within the tessellation's error
 * bound), the normal (against the exact gradient), and which rays miss. Inside tests are checked
 * through CSG (a small sphere intersected with the shape is there exactly when its centre is
 * inside), and each shape is cut by a CSG. text is checked against FreeType's own metrics. */
#include <unistd.h>

#include "pov_test.h"

#include <ft2build.h>
#include FT_FREETYPE_H
#include FT_OUTLINE_H

typedef double (*field_fn)(const double p[3]); /* < 0 inside */

static double len3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

static void grad(field_fn f, const double p[3], double g[3])
{
    for (int k = 0; k < 3; ++k) {
        double a[3] = {p[0], p[1], p[2]}, b[3] = {p[0], p[1], p[2]};
        a[k] += 1e-6;
        b[k] -= 1e-6;
        g[k] = (f(a) - f(b)) / 2e-6;
    }
}

/* Where the shape's function is marched: the ray's part within this sphere around the shape. */
static double g_centre[3], g_radius;

/* The ray's interval within the sphere (t0 > t1: none). */
static void span(const double o[3], const double d[3], double *t0, double *t1)
{
    double oc[3] = {o[0] - g_centre[0], o[1] - g_centre[1], o[2] - g_centre[2]};
    double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2], c = len3(oc) * len3(oc) - g_radius * g_radius;
    double disc = b * b - c;
    *t0 = 1;
    *t1 = 0;
    if (disc < 0)
        return;
    *t0 = fmax(0, -b - sqrt(disc));
    *t1 = -b + sqrt(disc);
}

/* The first t where f changes sign along o + t d (d unit) within the sphere, by marching in
 * steps of `step` and bisecting; -1 when none. */
static double exact_t(field_fn f, const double o[3], const double d[3], double tmax, double step)
{
    double p[3], t0, t1;
    span(o, d, &t0, &t1);
    tmax = fmin(tmax, t1);
    for (int k = 0; k < 3; ++k)
        p[k] = o[k] + t0 * d[k];
    double f0 = f(p);
    for (double t = t0 + step; t <= tmax; t += step) {
        for (int k = 0; k < 3; ++k)
            p[k] = o[k] + t * d[k];
        double v = f(p);
        if ((v < 0) != (f0 < 0)) {
            double lo = t0, hi = t;
            for (int it = 0; it < 60; ++it) {
                double m = 0.5 * (lo + hi);
                for (int k = 0; k < 3; ++k)
                    p[k] = o[k] + m * d[k];
                if ((f(p) < 0) == (f0 < 0))
                    lo = m;
                else
                    hi = m;
            }
            return 0.5 * (lo + hi);
        }
        t0 = t;
        f0 = v;
    }
    return -1;
}

/* The smallest |f| / |grad f| along the ray (how close it passes to the surface). */
static double closest(field_fn f, const double o[3], const double d[3], double tmax, double step)
{
    double best = INFINITY, p[3], g[3], t0, t1;
    span(o, d, &t0, &t1);
    for (double t = t0; t <= fmin(tmax, t1); t += step) {
        for (int k = 0; k < 3; ++k)
            p[k] = o[k] + t * d[k];
        grad(f, p, g);
        double gl = len3(g);
        if (gl > 0)
            best = fmin(best, fabs(f(p)) / gl);
    }
    return best;
}

typedef struct ray_stats {
    int hits, misses, checked;
    double max_dt, max_dist, min_dot;
} ray_stats;

/* Traces the ray in the scene and in the exact shape; asserts they agree within `tol` (a
 * distance) unless the ray passes within 2 tol of the surface without crossing it (grazing:
 * either answer is right). */
static void check_ray(vbnl_pov_scene *s, field_fn f, const double o[3], const double d_in[3], double tol, ray_stats *st)
{
    double d[3] = {d_in[0], d_in[1], d_in[2]}, l = len3(d);
    for (int k = 0; k < 3; ++k)
        d[k] /= l;
    double tmax = 40, step = tol;
    double te = exact_t(f, o, d, tmax, step);
    vbi_hit h;
    int got = hit(s, (float)o[0], (float)o[1], (float)o[2], (float)d[0], (float)d[1], (float)d[2], &h);
    if (te < 0) {
        if (got) {
            double pass = closest(f, o, d, h.t + 4 * tol, step);
            if (pass > 2 * tol)
                fprintf(stderr, "# spurious hit at t %g (ray passes %g from the surface)\n", h.t, pass);
            assert_true(pass <= 2 * tol);
        }
        st->misses++;
        return;
    }
    if (!got) {
        double pass = closest(f, o, d, tmax, step);
        /* a grazing ray: it dips into the shape by less than the tolerance */
        double p[3], g[3];
        for (int k = 0; k < 3; ++k)
            p[k] = o[k] + te * d[k];
        grad(f, p, g);
        double cosang = fabs(g[0] * d[0] + g[1] * d[1] + g[2] * d[2]) / len3(g);
        if (cosang > 0.2)
            fprintf(stderr, "# missed a hit at t %g (cos %g, pass %g) from %g %g %g along %g %g %g\n", te, cosang, pass, o[0],
                    o[1], o[2], d[0], d[1], d[2]);
        assert_true(cosang <= 0.2);
        return;
    }
    st->hits++;
    double p[3] = {h.p.x, h.p.y, h.p.z}, g[3];
    grad(f, p, g);
    double gl = len3(g), dist = fabs(f(p)) / gl;
    double n[3] = {g[0] / gl, g[1] / gl, g[2] / gl};
    double cosang = fabs(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
    /* the hit lies on the surface; away from grazing, at the exact distance too */
    if (dist > tol)
        fprintf(stderr, "# hit %g from the surface (tol %g) at %g %g %g\n", dist, tol, p[0], p[1], p[2]);
    assert_true(dist <= tol);
    /* a crease of the exact surface within the tolerance (a cap's rim): no normal to compare */
    int crease = 0;
    for (int k = 0; k < 3 && !crease; ++k) {
        double q[3] = {p[0], p[1], p[2]}, gq[3];
        q[k] += 2 * tol;
        grad(f, q, gq);
        crease = (gq[0] * g[0] + gq[1] * g[1] + gq[2] * g[2]) / (len3(gq) * gl) < 0.995;
        q[k] -= 4 * tol;
        grad(f, q, gq);
        crease |= (gq[0] * g[0] + gq[1] * g[1] + gq[2] * g[2]) / (len3(gq) * gl) < 0.995;
    }
    if (cosang > 0.3 && !crease) {
        double dt = fabs(h.t - te);
        if (dt > tol / cosang + 1e-4)
            fprintf(stderr, "# t %g, exact %g from %g %g %g along %g %g %g\n", h.t, te, o[0], o[1], o[2], d[0], d[1], d[2]);
        assert_true(dt <= tol / cosang + 1e-4);
        st->max_dt = fmax(st->max_dt, dt);
        /* the shading normal: the exact one (outward), up to the angle a chord can turn */
        double dot = n[0] * h.ns.x + n[1] * h.ns.y + n[2] * h.ns.z;
        if (dot < 0.97)
            fprintf(stderr, "# normal %g %g %g, exact %g %g %g at %g %g %g\n", h.ns.x, h.ns.y, h.ns.z, n[0], n[1], n[2], p[0], p[1],
                    p[2]);
        st->min_dot = fmin(st->min_dot, dot);
        st->checked++;
    }
    st->max_dist = fmax(st->max_dist, dist);
}

/* Rays from 26 directions around `c` at distance 12, aimed at points offset by `spread` from c,
 * and the same rays started at `inside` (a point inside the shape). */
static ray_stats check_shape(vbnl_pov_scene *s, field_fn f, const double c[3], double spread, const double *inside,
                             double tol)
{
    ray_stats st = {0, 0, 0, 0, 0, 1};
    vbnl_scene_info in = info(s);
    for (int k = 0; k < 3; ++k)
        g_centre[k] = c[k];
    g_radius = 0;
    for (int k = 0; k < 8; ++k) { /* a sphere around the scene's geometry */
        double q[3] = {k & 1 ? in.bounds_max[0] : in.bounds_min[0], k & 2 ? in.bounds_max[1] : in.bounds_min[1],
                       k & 4 ? in.bounds_max[2] : in.bounds_min[2]};
        double e[3] = {q[0] - c[0], q[1] - c[1], q[2] - c[2]};
        g_radius = fmax(g_radius, len3(e));
    }
    g_radius = fmin(g_radius + 0.1, 6);
    int n = 0;
    for (int i = -1; i <= 1; ++i)
        for (int j = -1; j <= 1; ++j)
            for (int k = -1; k <= 1; ++k) {
                if (!i && !j && !k)
                    continue;
                double dir[3] = {i + 0.13 * j, j + 0.07 * k, k + 0.11 * i}, l = len3(dir);
                for (int a = 0; a < 3; ++a) {
                    double o[3], t[3], d[3];
                    /* (off the shape's planes of symmetry: rays exactly along a grid's edges are where
                     * Embree's triangle test is not watertight) */
                    static const double jitter[3] = {0.0123, 0.0071, 0.0037};
                    for (int q = 0; q < 3; ++q) {
                        o[q] = c[q] + 12 * dir[q] / l + jitter[q];
                        t[q] = c[q] + spread * ((a == 0 ? 0 : a == 1 ? 0.37 : -0.52) * (q == n % 3 ? 1 : 0.4));
                        d[q] = t[q] - o[q];
                    }
                    check_ray(s, f, o, d, tol, &st);
                    if (inside) {
                        double io[3];
                        for (int q = 0; q < 3; ++q) {
                            d[q] = -dir[q];
                            io[q] = inside[q] + jitter[q];
                        }
                        check_ray(s, f, io, d, tol, &st);
                    }
                }
                n++;
            }
    assert_true(st.hits > 10);
    assert_true(st.min_dot > 0.97);
    return st;
}

/* 1 when the point is inside the shape by the object layer's inside test (CSG). */
static int inside_by_csg(const char *shape, double x, double y, double z)
{
    char text[4096];
    snprintf(text, sizeof text, BASE_B "intersection { %s sphere { <%g, %g, %g>, 0.001 } }", shape, x, y, z);
    vbnl_pov_scene *s = ok(text);
    int in = info(s).sphere_count + info(s).triangle_count > 0;
    vbnl_pov_scene_destroy(s);
    return in;
}

/* ---- the shapes' exact functions ------------------------------------------------------------- */

static double f_torus(const double p[3]) /* quartic torus R = 1, r = 0.4, around y */
{
    double r = sqrt(p[0] * p[0] + p[2] * p[2]) - 1;
    return sqrt(r * r + p[1] * p[1]) - 0.4;
}

static double f_cylinder_y(const double p[3]) /* within the box's slab |y| < 1 */
{
    return fmax(sqrt(p[0] * p[0] + p[2] * p[2]) - 0.8, fabs(p[1]) - 1);
}

static double f_super(const double p[3]) /* superellipsoid <0.5, 0.3> */
{
    double e = 0.5, n = 0.3;
    double a = pow(pow(fabs(p[0]), 2 / e) + pow(fabs(p[1]), 2 / e), e / n) + pow(fabs(p[2]), 2 / n);
    return pow(a, n / 2) - 1;
}

static double f_blob(const double p[3]) /* two spheres, radius 1, strength 1, threshold 0.5 */
{
    double s = 0;
    for (int k = 0; k < 2; ++k) {
        double x = p[0] - (k ? 0.6 : -0.6), d2 = x * x + p[1] * p[1] + p[2] * p[2];
        if (d2 < 1)
            s += (1 - d2) * (1 - d2);
    }
    return 0.5 - s;
}

static double f_sphere1(const double p[3]) { return len3(p) - 1; }

static double f_wavy(const double p[3]) /* the isosurface below, in its box */
{
    double v = len3(p) - 0.8 + 0.08 * sin(6 * p[0]) * sin(6 * p[1]);
    return fmax(v, fmax(fabs(p[0]), fmax(fabs(p[1]), fabs(p[2]))) - 1);
}

static double f_vase(const double p[3]) /* lathe: cubic profile, compared with its own profile */
{
    /* the surface r(y) of the closed lathe below is a Catmull-Rom spline through (r, y) points
     * from the axis at y = 0 to the axis at y = 1.8; here the same spline is evaluated: find t
     * with y(t) = y by bisection, return r - r(t) */
    static const double P[7][2] = {{0.3, -0.3}, {0, 0}, {0.7, 0.2}, {0.9, 0.8}, {0.5, 1.4}, {0, 1.8}, {-0.3, 2.1}};
    double y = p[1], r = sqrt(p[0] * p[0] + p[2] * p[2]);
    if (y < 0 || y > 1.8)
        return fmax(-y, y - 1.8) + r; /* beyond the poles */
    for (int s = 0; s < 4; ++s) {
        const double *a = P[s], *b = P[s + 1], *c = P[s + 2], *d = P[s + 3];
        double cy[4] = {-0.5 * a[1] + 1.5 * b[1] - 1.5 * c[1] + 0.5 * d[1], a[1] - 2.5 * b[1] + 2 * c[1] - 0.5 * d[1],
                        -0.5 * a[1] + 0.5 * c[1], b[1]};
        double cr[4] = {-0.5 * a[0] + 1.5 * b[0] - 1.5 * c[0] + 0.5 * d[0], a[0] - 2.5 * b[0] + 2 * c[0] - 0.5 * d[0],
                        -0.5 * a[0] + 0.5 * c[0], b[0]};
        if (y < b[1] || y > c[1])
            continue;
        double lo = 0, hi = 1;
        for (int it = 0; it < 60; ++it) {
            double m = 0.5 * (lo + hi), ym = ((cy[0] * m + cy[1]) * m + cy[2]) * m + cy[3];
            if (ym < y)
                lo = m;
            else
                hi = m;
        }
        double t = 0.5 * (lo + hi), rt = ((cr[0] * t + cr[1]) * t + cr[2]) * t + cr[3];
        return r - rt;
    }
    return 1;
}

static double f_prism(const double p[3]) /* linear prism: the square |x|, |z| < 1, y in [0, 0.5] */
{
    return fmax(fmax(fabs(p[0]), fabs(p[2])) - 1, fmax(-p[1], p[1] - 0.5));
}

static double sweep_g(const double p[3], double t)
{
    double c = -1 + 2 * t, r = 0.5 - 0.25 * t;
    return sqrt((p[0] - c) * (p[0] - c) + p[1] * p[1] + p[2] * p[2]) - r;
}

static double f_sweep(const double p[3]) /* linear sphere_sweep <-1,0,0> r 0.5 to <1,0,0> r 0.25 */
{
    double lo = 0, hi = 1; /* convex in t: golden sections */
    for (int it = 0; it < 80; ++it) {
        double a = hi - 0.618033988749895 * (hi - lo), b = lo + 0.618033988749895 * (hi - lo);
        if (sweep_g(p, a) < sweep_g(p, b))
            hi = b;
        else
            lo = a;
    }
    return fmin(sweep_g(p, 0.5 * (lo + hi)), fmin(sweep_g(p, 0), sweep_g(p, 1)));
}

static double f_ovus(const double p[3]) /* ovus { 1, 0.6 } as POV-Ray defines it */
{
    double rb = 1, rt = 0.6, cr = 2 * rb, cv = 2 * rt - rb - rt * rt / (2 * rb), hp = sqrt(rb * rb - cv * cv);
    double bv = -cv, tv = (rb - cv) * rt / (cr - rt) + rb;
    double d = len3(p) - rb, q[3] = {p[0], p[1] - rb, p[2]};
    d = fmin(d, len3(q) - rt);
    if (p[1] > bv && p[1] < tv) {
        double h = sqrt(p[0] * p[0] + p[2] * p[2]);
        d = fmin(d, sqrt((h + hp) * (h + hp) + (p[1] - cv) * (p[1] - cv)) - cr);
    }
    return d;
}

/* ---- the tests ------------------------------------------------------------------------------- */

static const double origin[3] = {0, 0, 0};

static void test_quartic_torus(void **state)
{
    (void)state;
    /* (x2 + y2 + z2 + R2 - r2)^2 - 4 R2 (x2 + z2) with R = 1, r = 0.4 (shapesq.inc's form) */
    const char *q = "quartic { <1, 0, 0, 0, 2, 0, 0, 2, 0, -2.32, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 2, 0, 1.68,"
                    " 0, 0, 0, 0, 1, 0, -2.32, 0, 0.7056> }";
    char text[2048];
    snprintf(text, sizeof text, BASE_B "%s", q);
    vbnl_pov_scene *s = ok(text);
    /* unbounded (POV-Ray's poly): made within the scene's bounds, where it vanishes */
    assert_non_null(strstr(g_diags, "the shape is unbounded"));
    double in[3] = {1, 0.1, 0};
    ray_stats st = check_shape(s, f_torus, origin, 0.9, in, 2.5e-3);
    assert_true(st.checked > 20);
    /* a grazing ray over the top: 0.4 + 3 tol misses, 0.4 - 3 tol hits */
    vbi_hit h;
    assert_false(hit(s, -5, 0.41, 1, 1, 0, 0, &h));
    assert_true(hit(s, -5, 0.39, 1, 1, 0, 0, &h));
    vbnl_pov_scene_destroy(s);
    /* inside: P < 0 (POV-Ray's) */
    assert_true(inside_by_csg(q, 1, 0, 0));
    assert_false(inside_by_csg(q, 0, 0, 0));
    assert_false(inside_by_csg(q, 1, 0.5, 0));
}

static void test_quadric_clipped(void **state)
{
    (void)state;
    /* an infinite cylinder x2 + z2 = 0.64 bounded by a box: its inside's bounds are exact along x
     * and z, so the CSG's region (the box) is where it is made */
    vbnl_pov_scene *s = ok(BASE_B "intersection { quadric { <1, 0, 1>, <0, 0, 0>, <0, 0, 0>, -0.64 } "
                                  "box { <-2, -1, -2>, <2, 1, 2> } }");
    assert_null(strstr(g_diags, "unbounded"));
    NEAR(info(s).bounds_max[1], 1.0f);
    assert_float_equal(info(s).bounds_max[0], 0.8f, 2e-3);
    double in[3] = {0.1, 0.2, 0};
    check_shape(s, f_cylinder_y, origin, 0.5, in, 2e-3);
    vbi_hit h; /* the box's caps close it: a ray down the axis hits y = 1 */
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h));
    NEAR(h.t, 4.0f);
    vbnl_pov_scene_destroy(s);
    /* bounded_by clips an unbounded shape, as POV-Ray's rays do */
    s = ok(BASE_B "quadric { <1, 0, 1>, <0, 0, 0>, <0, 0, 0>, -0.64 bounded_by { box { <-1, -1, -1>, <1, 1, 1> } } }");
    NEAR(info(s).bounds_max[1], 1.0f);
    vbnl_pov_scene_destroy(s);
}

static void test_poly_forms(void **state)
{
    (void)state;
    /* the same sphere x2 + y2 + z2 - 1 as poly (order 2, 10 terms), polynomial and cubic */
    const char *forms[] = {"poly { 2, <1, 0, 0, 0, 1, 0, 0, 1, 0, -1> }",
                           "polynomial { 2, xyz(2, 0, 0): 1, xyz(0, 2, 0): 1, xyz(0, 0, 2): 1, xyz(0, 0, 0): -1 }",
                           "cubic { <0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -1> }"};
    for (int i = 0; i < 3; ++i) {
        char text[1024];
        snprintf(text, sizeof text, BASE_B "intersection { %s box { -2, 2 } }", forms[i]);
        vbnl_pov_scene *s = ok(text);
        check_shape(s, f_sphere1, origin, 0.5, origin, 2e-3);
        vbnl_pov_scene_destroy(s);
    }
    expect_error(BASE "polynomial { 2, xyz(3, 0, 0): 1 }", "test.pov:3:17: polynomial: xyz(3, 0, 0) is not a term of order 2");
    expect_error(BASE "poly { 1, <1, 2, 3, 4> }", "test.pov:3:1: poly: the order must be 2 to 35, got 1");
}

static void test_superellipsoid(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE_B "superellipsoid { <0.5, 0.3> }");
    double in[3] = {0.3, -0.2, 0.5};
    ray_stats st = check_shape(s, f_super, origin, 0.6, in, 2e-3 * 1.8);
    assert_true(st.checked > 20);
    vbnl_pov_scene_destroy(s);
    /* near the flat face's middle, the surface is x = 1 within the tolerance */
    s = ok(BASE_B "superellipsoid { <0.5, 0.3> }");
    vbi_hit h;
    assert_true(hit(s, 5, 0.1, 0.1, -1, 0, 0, &h));
    assert_float_equal(h.t, 4.0f, 4e-3);
    vbnl_pov_scene_destroy(s);
    assert_true(inside_by_csg("superellipsoid { <0.5, 0.3> }", 0.9, 0.1, 0.1));
    assert_false(inside_by_csg("superellipsoid { <0.5, 0.3> }", 0.97, 0.97, 0.5));
}

static void test_blob(void **state)
{
    (void)state;
    const char *b = "blob { threshold 0.5 sphere { <-0.6, 0, 0>, 1, 1 } sphere { <0.6, 0, 0>, 1, strength 1 } }";
    char text[1024];
    snprintf(text, sizeof text, BASE_B "%s", b);
    vbnl_pov_scene *s = ok(text);
    ray_stats st = check_shape(s, f_blob, origin, 0.5, origin, 2.5e-3);
    assert_true(st.checked > 20);
    vbnl_pov_scene_destroy(s);
    assert_true(inside_by_csg(b, 0, 0.3, 0)); /* the neck: 2 (1 - 0.45)^2 = 0.605 > 0.5 */
    assert_false(inside_by_csg(b, 0, 0.5, 0)); /* 2 (1 - 0.61)^2 = 0.304 */
    /* a component's transform stretches its field; a cylinder component reaches along its axis */
    s = ok(BASE_B "blob { cylinder { <-1, 0, 0>, <1, 0, 0>, 0.5, 2 } }");
    vbi_hit h;
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h)); /* 2 (1 - d2/0.25)^2 = 1: d = 0.5 sqrt(1 - 1/sqrt 2) */
    assert_float_equal(h.t, 5 - 0.5 * sqrt(1 - 1 / sqrt(2.0)), 3e-3);
    vbnl_pov_scene_destroy(s);
}

static void test_isosurface(void **state)
{
    (void)state;
    const char *iso = "isosurface { function { sqrt(x*x + y*y + z*z) - 0.8 + 0.08 * sin(6*x) * sin(6*y) } "
                      "max_gradient 1.6 contained_by { box { -1, 1 } } }";
    char text[1024];
    snprintf(text, sizeof text, BASE_B "%s", iso);
    vbnl_pov_scene *s = ok(text);
    ray_stats st = check_shape(s, f_wavy, origin, 0.5, origin, 2e-3 * 1.8);
    assert_true(st.checked > 20);
    vbnl_pov_scene_destroy(s);
    assert_true(inside_by_csg(iso, 0.5, 0.1, 0.2));
    assert_false(inside_by_csg(iso, 0.9, 0.1, 0.2));
    /* the container closes it where the function is below the threshold there */
    s = ok(BASE_B "isosurface { function { y } contained_by { box { -1, 1 } } }");
    vbi_hit h;
    assert_true(hit(s, 5, -0.5, 0, -1, 0, 0, &h)); /* the box's side below y = 0 */
    assert_float_equal(h.t, 4.0f, 2e-3);
    assert_false(hit(s, 5, 0.5, 0, -1, 0, 0, &h)); /* above: outside */
    assert_true(hit(s, 0.3, 5, 0.2, 0, -1, 0, &h)); /* the plane y = 0 */
    assert_float_equal(h.t, 5.0f, 2e-3);
    vbnl_pov_scene_destroy(s);
    /* open: no container walls */
    s = ok(BASE_B "isosurface { function { y } contained_by { box { -1, 1 } } open }");
    assert_false(hit(s, 5, -0.5, 0, -1, 0, 0, &h));
    assert_true(hit(s, 0.3, 5, 0.2, 0, -1, 0, &h));
    vbnl_pov_scene_destroy(s);
    /* the geometric internal functions of functions.inc */
    s = ok(BASE_B "#include \"functions.inc\"\n"
                  "isosurface { function { f_rounded_box(x, y, z, 0.1, 0.5, 0.5, 0.5) } contained_by { box { -1, 1 } } }");
    assert_true(hit(s, 5, 0, 0, -1, 0, 0, &h));
    assert_float_equal(h.t, 4.5f, 2e-3);
    vbnl_pov_scene_destroy(s);
}

static void test_lathe_sor(void **state)
{
    (void)state;
    const char *vase = "lathe { cubic_spline 7, <0.3, -0.3>, <0, 0>, <0.7, 0.2>, <0.9, 0.8>, <0.5, 1.4>, <0, 1.8>,"
                       " <-0.3, 2.1> }";
    char text[1024];
    snprintf(text, sizeof text, BASE_B "%s", vase);
    vbnl_pov_scene *s = ok(text);
    /* (off the plane x = 0, where rays would run along the grid's edges: Embree's triangle test is
     * not watertight for rays exactly along an edge) */
    double c[3] = {0.0123, 0.9, 0}, in[3] = {0.0123, 0.9, 0.3};
    ray_stats st = check_shape(s, f_vase, c, 0.4, in, 2.5e-3);
    assert_true(st.checked > 20);
    vbnl_pov_scene_destroy(s);
    /* inside: the profile's crossings (odd) */
    assert_true(inside_by_csg(vase, 0.3, 0.6, 0));
    assert_false(inside_by_csg(vase, 1.0, 0.6, 0));
    assert_false(inside_by_csg(vase, 0.1, 1.9, 0));
    /* every spline type makes a surface through its points: linear r = 1 from y 0 to 1 */
    s = ok(BASE_B "lathe { linear_spline 4, <0, 0>, <1, 0>, <1, 1>, <0, 1> }");
    vbi_hit h;
    assert_true(hit(s, 5, 0.5, 0, -1, 0, 0, &h));
    assert_float_equal(h.t, 4.0f, 1e-3);
    assert_true(hit(s, 0.5, 5, 0, 0, -1, 0, &h)); /* the flat top */
    NEAR(h.t, 4.0f);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE_B "lathe { bezier_spline 4, <1, 0>, <1.5, 0.3>, <1.5, 0.7>, <1, 1> }");
    assert_true(hit(s, 5, 0.5, 0, -1, 0, 0, &h)); /* r(0.5) = 1.375 */
    assert_float_equal(h.t, 5 - 1.375f, 2e-3);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE_B "lathe { quadratic_spline 4, <0, 0>, <1, 0>, <1, 1>, <1, 2> }");
    assert_true(hit(s, 5, 0.5, 0, -1, 0, 0, &h));
    vbnl_pov_scene_destroy(s);
    /* sor: r^2 a cubic in y; closed by caps unless open */
    s = ok(BASE_B "sor { 4, <0.5, -1>, <1, 0>, <1, 1>, <0.5, 2> }");
    assert_true(hit(s, 5, 0.5, 0, -1, 0, 0, &h)); /* r^2 = 1 at y 0 and 1, slopes 0.5 and -0.5: 1.125 */
    assert_float_equal(h.t, 5 - sqrt(1.125), 2e-3);
    assert_true(hit(s, 0.2, 5, 0, 0, -1, 0, &h)); /* the cap at y = 1 */
    assert_float_equal(h.t, 4.0f, 1e-3);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE_B "sor { 4, <0.5, -1>, <1, 0>, <1, 1>, <0.5, 2> open }");
    assert_false(hit(s, 0.2, 5, 0, 0, -1, 0, &h)); /* through the open ends, within the wall */
    vbnl_pov_scene_destroy(s);
    assert_true(inside_by_csg("sor { 4, <0.5, -1>, <1, 0>, <1, 1>, <0.5, 2> }", 0.5, 0.5, 0.5));
    assert_false(inside_by_csg("sor { 4, <0.5, -1>, <1, 0>, <1, 1>, <0.5, 2> }", 0.5, 1.2, 0.5));
    expect_error(BASE "sor { 4, <0.5, -1>, <1, 0>, <1, 0>, <0.5, 2> }",
                 "test.pov:3:29: sor: point 3 <1, 0>: radii must be >= 0 and heights must rise");
}

static void test_prism(void **state)
{
    (void)state;
    const char *sq = "prism { linear_sweep linear_spline 0, 0.5, 5, <-1, -1>, <1, -1>, <1, 1>, <-1, 1>, <-1, -1> }";
    char text[1024];
    snprintf(text, sizeof text, BASE_B "%s", sq);
    vbnl_pov_scene *s = ok(text);
    double c[3] = {0, 0.25, 0};
    check_shape(s, f_prism, c, 0.5, c, 1e-3);
    vbnl_pov_scene_destroy(s);
    /* a square with a square hole (two sub-outlines, even-odd) */
    const char *holed = "prism { 0, 1, 10, <-1, -1>, <1, -1>, <1, 1>, <-1, 1>, <-1, -1>,"
                        " <-0.5, -0.5>, <0.5, -0.5>, <0.5, 0.5>, <-0.5, 0.5>, <-0.5, -0.5> }";
    snprintf(text, sizeof text, BASE_B "%s", holed);
    s = ok(text);
    vbi_hit h;
    assert_false(hit(s, 0, 5, 0, 0, -1, 0, &h));
    assert_true(hit(s, 0.75, 5, 0, 0, -1, 0, &h));
    NEAR(h.t, 4.0f);
    vbnl_pov_scene_destroy(s);
    assert_true(inside_by_csg(holed, 0.75, 0.5, 0));
    assert_false(inside_by_csg(holed, 0, 0.5, 0));
    /* conic sweep: the outline scaled by the height (a pyramid from the apex at the origin) */
    s = ok(BASE_B "prism { conic_sweep linear_spline 0, 1, 5, <-1, -1>, <1, -1>, <1, 1>, <-1, 1>, <-1, -1> }");
    assert_true(hit(s, 5, 0.5, 0, -1, 0, 0, &h)); /* the side x = y */
    assert_float_equal(h.t, 4.5f, 1e-3);
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h)); /* the cap at y = 1 */
    NEAR(h.t, 4.0f);
    vbnl_pov_scene_destroy(s);
    /* curved outlines pass through their points (quadratic: P[1] to P[2] ...) */
    s = ok(BASE_B "prism { cubic_spline 0, 1, 7, <0, -1>, <1, 0>, <0, 1>, <-1, 0>, <0, -1>, <1, 0>, <0, 1> }");
    assert_true(hit(s, 5, 0.5, 0, -1, 0, 0, &h));
    assert_float_equal(h.t, 4.0f, 1e-3);
    vbnl_pov_scene_destroy(s);
    /* open: no caps */
    s = ok(BASE_B "prism { 0, 1, 5, <-1, -1>, <1, -1>, <1, 1>, <-1, 1>, <-1, -1> open }");
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h) == 0 || h.t > 5.5f);
    vbnl_pov_scene_destroy(s);
    /* POV-Ray closes an open linear outline, and leaves another open one empty */
    s = ok(BASE_B "prism { 0, 1, 4, <-1, -1>, <1, -1>, <1, 1>, <-1, 1> }");
    assert_non_null(strstr(g_diags, "test.pov:3:1: warning: prism: the linear outline is not closed; it is closed"));
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h));
    vbnl_pov_scene_destroy(s);
}

static void test_sphere_sweep_ovus_lemon(void **state)
{
    (void)state;
    vbnl_pov_scene *s = ok(BASE_B "sphere_sweep { linear_spline 2, <-1, 0, 0>, 0.5, <1, 0, 0>, 0.25 }");
    ray_stats st = check_shape(s, f_sweep, origin, 0.3, origin, 3e-3);
    assert_true(st.checked > 10);
    vbnl_pov_scene_destroy(s);
    assert_true(inside_by_csg("sphere_sweep { linear_spline 2, <-1, 0, 0>, 0.5, <1, 0, 0>, 0.25 }", -1.4, 0, 0));
    assert_false(inside_by_csg("sphere_sweep { linear_spline 2, <-1, 0, 0>, 0.5, <1, 0, 0>, 0.25 }", 1.3, 0, 0));
    /* a b-spline: the sweep passes near, not through, its points (uniform B-spline averages) */
    s = ok(BASE_B "sphere_sweep { b_spline 4, <-3, 0, 0>, 0.3, <-1, 0, 0>, 0.3, <1, 0, 0>, 0.3, <3, 0, 0>, 0.3 }");
    vbi_hit h; /* the segment runs from (-3 + 4 -1)/6... = -1/3 ... 1/3 * 3: x from -1 to 1 */
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h));
    assert_float_equal(h.t, 4.7f, 2e-3);
    assert_true(hit(s, -5, 0, 0, 1, 0, 0, &h));
    assert_float_equal(h.t, 3.7f, 3e-3);
    vbnl_pov_scene_destroy(s);
    s = ok(BASE_B "ovus { 1, 0.6 }");
    double c[3] = {0, 0.5, 0};
    st = check_shape(s, f_ovus, c, 0.4, c, 3e-3);
    assert_true(st.checked > 20);
    vbnl_pov_scene_destroy(s);
    /* lemon (POV-Ray 3.8): the arc joining the rims, capped */
    s = ok(BASE_B "lemon { <0, 1, 0>, 0.5, <0, -1, 0>, 0.5, 1.5 }");
    assert_true(hit(s, 0, 5, 0, 0, -1, 0, &h)); /* the apex cap */
    NEAR(h.t, 4.0f);
    assert_true(hit(s, 5, 0, 0, -1, 0, 0, &h)); /* the bulge: the arc's centre is at -(f - 1)/2 */
    assert_true(h.t < 4.5f && h.t > 3.5f);
    vbnl_pov_scene_destroy(s);
}

static void test_height_field(void **state)
{
    (void)state;
    /* a function height field is exactly its triangles: height F(x, 1 - z) on 16 bits */
    vbnl_pov_scene *s = ok(BASE_B "height_field { function 33, 33 { 0.25 + 0.5 * x * y } }");
    vbi_hit h;
    for (int i = 0; i < 5; ++i) {
        float x = (4 + 6 * i) / 32.0f, z = (3 + 5 * i) / 32.0f; /* grid points: exact */
        assert_true(hit(s, x, 5, z, 0, -1, 0, &h));
        double y = floor((0.25 + 0.5 * x * (1 - z)) * 65535) / 65536;
        assert_float_equal(5 - h.t, y, 2e-5);
    }
    vbnl_pov_scene_destroy(s);
    /* water_level cuts below it */
    s = ok(BASE_B "height_field { function 9, 9 { x } water_level 0.5 }");
    assert_false(hit(s, 0.25f, 5, 0.5f, 0, -1, 0, &h));
    assert_true(hit(s, 0.75f, 5, 0.5f, 0, -1, 0, &h));
    vbnl_pov_scene_destroy(s);
    assert_true(inside_by_csg("height_field { function 9, 9 { x } }", 0.75, 0.5, 0.5));
    assert_false(inside_by_csg("height_field { function 9, 9 { x } }", 0.25, 0.5, 0.5));
    expect_error(BASE "height_field { png \"missing.png\" }",
                 "test.pov:3:20: height_field: image: cannot find 'missing.png' (searched: ., /usr/share/povray-3.7/include)");
}

/* Height fields from image files other than PNG (through OpenImageIO), with POV-Ray's values: a
 * 16-bit grey PGM's value * 65535 / 65535, an 8-bit colour PPM's red * 256 + green. */
static void test_height_field_images(void **state)
{
    (void)state;
    char dir[] = "/tmp/vbnl_hf_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char cwd[4096], path[512];
    assert_non_null(getcwd(cwd, sizeof cwd));
    assert_int_equal(chdir(dir), 0);
    /* 2 x 2, top row first: the top row lies at z = 1 */
    FILE *f = fopen("grey.pgm", "w");
    assert_non_null(f);
    fputs("P2\n2 2\n65535\n1000 2000\n30000 65535\n", f);
    fclose(f);
    f = fopen("colour.ppm", "w");
    assert_non_null(f);
    fputs("P3\n2 2\n255\n10 20 0  0 0 0\n0 0 0  200 7 99\n", f);
    fclose(f);
    f = fopen("bad.tga", "w");
    assert_non_null(f);
    fputs("not an image", f);
    fclose(f);
    const struct {
        const char *file;
        double corner[4]; /* heights * 65536 at (x, z) = (0, 1), (1, 1), (0, 0), (1, 0) */
    } cases[] = {
        {"pgm \"grey.pgm\"", {1000, 2000, 30000, 65535}},
        {"\"colour.ppm\"", {10 * 256 + 20, 0, 0, 200 * 256 + 7}},
    };
    for (size_t i = 0; i < 2; ++i) {
        char text[512];
        snprintf(text, sizeof text, BASE_B "height_field { %s }", cases[i].file);
        vbnl_pov_scene *s = ok(text);
        const float xz[4][2] = {{0.001f, 0.999f}, {0.999f, 0.999f}, {0.001f, 0.001f}, {0.999f, 0.001f}};
        for (int k = 0; k < 4; ++k) {
            vbi_hit h;
            assert_true(hit(s, xz[k][0], 5, xz[k][1], 0, -1, 0, &h));
            assert_float_equal(5 - h.t, cases[i].corner[k] / 65536.0, 2e-3);
        }
        vbnl_pov_scene_destroy(s);
    }
    /* a file no library reads: an error at the file name, with the library's reason */
    vbnl_pov_scene *s = NULL;
    vbnl_error err;
    assert_int_equal(load(BASE "height_field { tga \"bad.tga\" }", &s, &err), VBNL_ERR_PARSE);
    assert_null(s);
    assert_non_null(strstr(err.message, "test.pov:3:20: height_field: cannot read '"));
    assert_non_null(strstr(err.message, "bad.tga': "));
    snprintf(path, sizeof path, "%s/bad.tga", dir);
    assert_int_equal(chdir(cwd), 0);
    remove(path);
    snprintf(path, sizeof path, "%s/grey.pgm", dir);
    remove(path);
    snprintf(path, sizeof path, "%s/colour.ppm", dir);
    remove(path);
    assert_int_equal(rmdir(dir), 0);
}

static void test_julia_bicubic_parametric(void **state)
{
    (void)state;
    /* c = 0: the unit ball (q -> q^2 stays bounded exactly for |q| <= 1) */
    vbnl_pov_scene *s = ok(BASE_B "julia_fractal { <0, 0, 0, 0> quaternion sqr max_iteration 8 }");
    vbi_hit h;
    assert_true(hit(s, 0, 0, -5, 0, 0, 1, &h));
    assert_float_equal(h.t, 4.0f, 1e-2);
    vbnl_pov_scene_destroy(s);
    /* c = 0.3: |q| stays at most R = 1.3 through 3 iterations inside (|q| <= 0.95 here) */
    assert_true(inside_by_csg("julia_fractal { <0.3, 0, 0, 0> max_iteration 3 }", 0.1, 0.2, 0));
    assert_false(inside_by_csg("julia_fractal { <0.3, 0, 0, 0> max_iteration 3 }", 1.2, 0, 0));
    expect_error(BASE "julia_fractal { <0, 0, 0, 0> quaternion exp }",
                 "test.pov:3:1: julia_fractal: quaternions support sqr and cube only, not exp");
    /* a bicubic patch: a flat net is the plane z = 0 over its corners */
    s = ok(BASE_B "bicubic_patch { type 1 u_steps 3 v_steps 3"
                  " <0,0,0>, <1,0,0>, <2,0,0>, <3,0,0>, <0,1,0>, <1,1,0>, <2,1,0>, <3,1,0>,"
                  " <0,2,0>, <1,2,0>, <2,2,0>, <3,2,0>, <0,3,0>, <1,3,0>, <2,3,0>, <3,3,0> }");
    assert_true(hit(s, 1.5f, 1.5f, -5, 0, 0, 1, &h));
    NEAR(h.t, 5.0f);
    assert_false(hit(s, 3.5f, 1.5f, -5, 0, 0, 1, &h));
    vbnl_pov_scene_destroy(s);
    /* a parametric sphere of radius 1 */
    s = ok(BASE_B "parametric { function { sin(u) * cos(v) }, function { cos(u) }, function { sin(u) * sin(v) }"
                  " <0, 0>, <pi, 2 * pi> contained_by { box { -2, 2 } } }");
    assert_true(hit(s, 0.3f, 0.2f, -5, 0, 0, 1, &h));
    assert_float_equal(h.t, 5 - sqrt(1 - 0.13), 3e-3);
    vbnl_pov_scene_destroy(s);
}

/* ---- text -------------------------------------------------------------------------------------- */

static const char *font_dir(void)
{
    static const char *const dirs[] = {"/usr/share/povray-3.7/include", "/usr/share/povray/include"};
    for (size_t i = 0; i < 2; ++i) {
        char p[512];
        snprintf(p, sizeof p, "%s/timrom.ttf", dirs[i]);
        FILE *f = fopen(p, "rb");
        if (f) {
            fclose(f);
            return dirs[i];
        }
    }
    return NULL;
}

static void test_text_metrics(void **state)
{
    (void)state;
    const char *dir = font_dir();
    if (!dir) {
        fprintf(stderr, "# POV-Ray's fonts (povray-includes) are not installed: nothing to compare\n");
        skip();
    }
    /* FreeType's own metrics of "VAT" in timrom.ttf, in em */
    char path[600];
    snprintf(path, sizeof path, "%s/timrom.ttf", dir);
    FT_Library lib;
    FT_Face face;
    assert_int_equal(FT_Init_FreeType(&lib), 0);
    assert_int_equal(FT_New_Face(lib, path, 0, &face), 0);
    const char *str = "VAT";
    double upem = face->units_per_EM, pen = 0, xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
    FT_UInt prev = 0;
    int glyphs = 0;
    for (int i = 0; str[i]; ++i) {
        FT_UInt gi = FT_Get_Char_Index(face, (unsigned char)str[i]);
        assert_int_equal(FT_Load_Glyph(face, gi, FT_LOAD_NO_SCALE | FT_LOAD_NO_HINTING), 0);
        FT_BBox b;
        FT_Outline_Get_CBox(&face->glyph->outline, &b);
        double at;
        if (i == 0) {
            at = -b.xMin / upem; /* the first glyph's left edge at 0 */
            pen = (face->glyph->metrics.horiAdvance - b.xMin) / upem;
        } else {
            FT_Vector k = {0, 0};
            FT_Get_Kerning(face, prev, gi, FT_KERNING_UNSCALED, &k);
            at = pen + k.x / upem;
            pen += (face->glyph->metrics.horiAdvance + k.x) / upem;
        }
        xmin = fmin(xmin, at + b.xMin / upem);
        xmax = fmax(xmax, at + b.xMax / upem);
        ymin = fmin(ymin, b.yMin / upem);
        ymax = fmax(ymax, b.yMax / upem);
        prev = gi;
        glyphs++;
    }
    FT_Done_Face(face);
    FT_Done_FreeType(lib);
    vbnl_pov_scene *s = ok(BASE_B "text { ttf \"timrom.ttf\" \"VAT\" 0.25, 0 }");
    const vbnl_scene *sc0 = sc(s);
    int meshes = 0;
    for (uint32_t g = 0; g < sc0->geom_count; ++g)
        meshes += sc0->geoms[g].kind == SCENE_GEOM_MESH;
    assert_int_equal(meshes, glyphs); /* one primitive per glyph */
    vbnl_scene_info i = info(s);
    /* the bounds: FreeType's control boxes are the outline's (the curves lie within them, and
     * touch them at the extreme points of TrueType's glyphs) */
    assert_float_equal(i.bounds_min[0], xmin, 2e-3);
    assert_float_equal(i.bounds_max[0], xmax, 2e-3);
    assert_float_equal(i.bounds_min[1], ymin, 2e-3);
    assert_float_equal(i.bounds_max[1], ymax, 2e-3);
    NEAR(i.bounds_min[2], 0.0f);
    NEAR(i.bounds_max[2], 0.25f);
    vbnl_pov_scene_destroy(s);
    /* the advance: the same text with the offset <1, 0, 0> is wider by two units (after each
     * glyph but the last) */
    s = ok(BASE_B "text { ttf \"timrom.ttf\" \"VAT\" 0.25, <1, 0, 0> }");
    assert_float_equal(info(s).bounds_max[0], xmax + 2, 2e-3);
    vbnl_pov_scene_destroy(s);
    /* a ray through the middle of an 'I' hits its front face at z = 0 */
    s = ok(BASE_B "text { ttf \"timrom.ttf\" \"I\" 0.5, 0 }");
    i = info(s);
    vbi_hit h;
    assert_true(hit(s, 0.5f * (i.bounds_min[0] + i.bounds_max[0]), 0.3f, -5, 0, 0, 1, &h));
    NEAR(h.t, 5.0f);
    NEAR(h.ns.z, -1.0f);
    vbnl_pov_scene_destroy(s);
    /* inside: between the faces, within the glyph */
    assert_true(inside_by_csg("text { ttf \"timrom.ttf\" \"I\" 0.5, 0 }", 0.5 * (i.bounds_min[0] + i.bounds_max[0]), 0.3, 0.25));
    assert_false(inside_by_csg("text { ttf \"timrom.ttf\" \"I\" 0.5, 0 }", 0.5 * (i.bounds_min[0] + i.bounds_max[0]), 0.3, 0.6));
    /* POV-Ray's names without the extension, and its built-in fonts */
    s = ok(BASE_B "text { ttf \"crystal\" \"ab\" 1, 0 } text { internal 1 \"ab\" 1, 0 translate y * 2 }");
    assert_true(info(s).triangle_count > 100);
    vbnl_pov_scene_destroy(s);
}

static void test_text_errors(void **state)
{
    (void)state;
    expect_error(BASE "text { ttf \"nofont.ttf\" \"abc\" 1, 0 }",
                 "test.pov:3:12: text: font: cannot find 'nofont.ttf' (searched: ., /usr/share/povray-3.7/include)");
    expect_error(BASE "text { \"timrom.ttf\" \"abc\" 1, 0 }", "test.pov:3:8: text: expected 'ttf' or 'internal'");
}

/* ---- CSG with every shape as an operand ------------------------------------------------------------ */

static void test_csg_operands(void **state)
{
    (void)state;
    /* each shape cut by the half-space x < 0 (a plane): rays along -x from +x hit the cut face at
     * x = 0 where the shape is inside there, and the shape's own surface elsewhere */
    static const struct {
        const char *shape;
        float y, z; /* a point of x = 0 inside the shape */
    } cases[] = {
        {"quartic { <1, 0, 0, 0, 2, 0, 0, 2, 0, -2.32, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 2, 0, 1.68, 0, 0, 0, 0, 1, 0,"
         " -2.32, 0, 0.7056> }", 0.1f, 1.0f},
        {"superellipsoid { <0.5, 0.3> }", 0.1f, 0.1f},
        {"blob { threshold 0.5 sphere { <-0.6, 0, 0>, 1, 1 } sphere { <0.6, 0, 0>, 1, 1 } }", 0.1f, 0.1f},
        {"isosurface { function { sqrt(x*x + y*y + z*z) - 0.8 } }", 0.1f, 0.1f},
        {"lathe { linear_spline 4, <0, -1>, <1, -1>, <1, 1>, <0, 1> }", 0.1f, 0.1f},
        {"sor { 4, <0.5, -2>, <1, -1>, <1, 1>, <0.5, 2> }", 0.1f, 0.1f},
        {"prism { -1, 1, 5, <-1, -1>, <1, -1>, <1, 1>, <-1, 1>, <-1, -1> }", 0.1f, 0.1f},
        {"text { ttf \"timrom.ttf\" \"O\" 1, 0 translate <-0.05, -0.3, -0.5> }", 0.05f, 0.0f}, /* its left stroke */
        {"sphere_sweep { linear_spline 2, <-1, 0, 0>, 0.5, <1, 0, 0>, 0.5 }", 0.1f, 0.1f},
        {"ovus { 1, 0.6 }", 0.1f, 0.1f},
        {"julia_fractal { <0.3, 0, 0, 0> max_iteration 3 }", 0.1f, 0.1f},
        {"height_field { function 9, 9 { 0.5 } translate <-0.5, -0.25, -0.5> }", 0.0f, 0.0f},
        {"quadric { <1, 1, 1>, <0, 0, 0>, <0, 0, 0>, -1 }", 0.1f, 0.1f},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        char text[2048];
        if (strstr(cases[i].shape, "timrom") && !font_dir())
            continue;
        snprintf(text, sizeof text, BASE_B "difference { %s plane { -x, 0 } }", cases[i].shape);
        vbnl_pov_scene *s = ok(text);
        vbi_hit h;
        int got = hit(s, 5, cases[i].y, cases[i].z, -1, 0, 0, &h);
        if (!got || fabsf(h.t - 5.0f) > 2e-3f)
            fprintf(stderr, "# %s: %s t %g\n", cases[i].shape, got ? "hit at" : "no hit", got ? h.t : 0.0f);
        assert_true(got);
        assert_float_equal(h.t, 5.0f, 2e-3); /* the cut face: the plane's own x = 0 */
        assert_float_equal(h.ns.x, 1.0f, 1e-3);
        /* nothing of the shape is left at x > 0 */
        assert_true(info(s).bounds_max[0] < 1e-3f || info(s).bounds_max[0] > 50.0f);
        vbnl_pov_scene_destroy(s);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_quartic_torus),
        cmocka_unit_test(test_quadric_clipped),
        cmocka_unit_test(test_poly_forms),
        cmocka_unit_test(test_superellipsoid),
        cmocka_unit_test(test_blob),
        cmocka_unit_test(test_isosurface),
        cmocka_unit_test(test_lathe_sor),
        cmocka_unit_test(test_prism),
        cmocka_unit_test(test_sphere_sweep_ovus_lemon),
        cmocka_unit_test(test_height_field),
        cmocka_unit_test(test_height_field_images),
        cmocka_unit_test(test_julia_bicubic_parametric),
        cmocka_unit_test(test_text_metrics),
        cmocka_unit_test(test_text_errors),
        cmocka_unit_test(test_csg_operands),
    };
    return cmocka_run_group_tests(tests, pov_t_setup, pov_t_teardown);
}
