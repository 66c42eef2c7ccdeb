/* The cost of the curved shapes (built, not run as a test): for each shape, the time to make it,
 * its triangles and memory, the distance of its mesh from the exact surface (sampled at every
 * triangle's centroid and edge midpoints, as a fraction of the shape's bounding radius), and the
 * time per ray of Embree on it next to a single triangle's and an analytic sphere's; then, for
 * comparison with tracing the exact surface per ray (POV-Ray's way, Embree user geometry), the
 * time per ray of exact intersectors written the usual way: a torus's quartic solved by
 * isolating its roots between the roots of its derivatives, and an isosurface marched with its
 * gradient bound as POV-Ray does.
 *
 *     bench_shapes [rays]     (default 200000 rays per measurement; medians of 5 runs) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "scene_internal.h"
#include "vbnl/pov_scene.h"
#include "vbnl/render.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_d);
    return v[n / 2];
}

/* ---- exact functions of some shapes (< 0 inside) ------------------------------------------------ */

static double f_torus(const double p[3])
{
    double r = sqrt(p[0] * p[0] + p[2] * p[2]) - 1;
    return sqrt(r * r + p[1] * p[1]) - 0.4;
}

static double f_blob(const double p[3])
{
    double s = 0;
    for (int k = 0; k < 2; ++k) {
        double x = p[0] - (k ? 0.6 : -0.6), d2 = x * x + p[1] * p[1] + p[2] * p[2];
        if (d2 < 1)
            s += (1 - d2) * (1 - d2);
    }
    return 0.5 - s;
}

static double f_super(const double p[3])
{
    double e = 0.5, n = 0.3;
    return pow(pow(pow(fabs(p[0]), 2 / e) + pow(fabs(p[1]), 2 / e), e / n) + pow(fabs(p[2]), 2 / n), n / 2) - 1;
}

static double f_wavy(const double p[3])
{
    double v = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 0.8 + 0.08 * sin(6 * p[0]) * sin(6 * p[1]);
    return fmax(v, fmax(fabs(p[0]), fmax(fabs(p[1]), fabs(p[2]))) - 1);
}

static double f_cylinder(const double p[3]) /* the linear lathe below: r = 1, y in [0, 2], flat ends */
{
    return fmax(sqrt(p[0] * p[0] + p[2] * p[2]) - 1, fmax(-p[1], p[1] - 2));
}

static double f_sweep(const double p[3])
{
    double lo = 0, hi = 1;
    for (int it = 0; it < 80; ++it) {
        double a = hi - 0.618 * (hi - lo), b = lo + 0.618 * (hi - lo);
        double ca = -1 + 2 * a, cb = -1 + 2 * b;
        double ga = sqrt((p[0] - ca) * (p[0] - ca) + p[1] * p[1] + p[2] * p[2]) - (0.5 - 0.25 * a);
        double gb = sqrt((p[0] - cb) * (p[0] - cb) + p[1] * p[1] + p[2] * p[2]) - (0.5 - 0.25 * b);
        if (ga < gb)
            hi = b;
        else
            lo = a;
    }
    double t = 0.5 * (lo + hi), c = -1 + 2 * t;
    return sqrt((p[0] - c) * (p[0] - c) + p[1] * p[1] + p[2] * p[2]) - (0.5 - 0.25 * t);
}

typedef double (*field_fn)(const double p[3]);

typedef struct shape_case {
    const char *name, *text;
    field_fn f; /* NULL: no exact function here */
} shape_case;

static const shape_case cases[] = {
    {"triangle (reference)", "triangle { <-1, -1, 0>, <1, -1, 0>, <0, 1, 0> }", NULL},
    {"sphere (analytic, reference)", "sphere { 0, 1 }", NULL},
    {"quartic (torus)",
     "intersection { quartic { <1, 0, 0, 0, 2, 0, 0, 2, 0, -2.32, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 2, 0, 1.68, 0,"
     " 0, 0, 0, 1, 0, -2.32, 0, 0.7056> } box { -2, 2 } }",
     f_torus},
    {"lathe (linear)", "lathe { linear_spline 4, <0, 0>, <1, 0>, <1, 2>, <0, 2> }", f_cylinder},
    {"lathe (cubic vase)", "lathe { cubic_spline 7, <0.3, -0.3>, <0, 0>, <0.7, 0.2>, <0.9, 0.8>, <0.5, 1.4>, <0, 1.8>, <-0.3, 2.1> }", NULL},
    {"superellipsoid", "superellipsoid { <0.5, 0.3> }", f_super},
    {"blob (2 spheres)", "blob { threshold 0.5 sphere { <-0.6, 0, 0>, 1, 1 } sphere { <0.6, 0, 0>, 1, 1 } }", f_blob},
    {"isosurface", "isosurface { function { sqrt(x*x + y*y + z*z) - 0.8 + 0.08 * sin(6*x) * sin(6*y) } max_gradient 1.6 }",
     f_wavy},
    {"sphere_sweep", "sphere_sweep { linear_spline 2, <-1, 0, 0>, 0.5, <1, 0, 0>, 0.25 }", f_sweep},
    {"prism (cubic)", "prism { cubic_spline 0, 1, 7, <0, -1>, <1, 0>, <0, 1>, <-1, 0>, <0, -1>, <1, 0>, <0, 1> }", NULL},
    {"text (\"POV-Ray\", timrom)", "text { ttf \"timrom.ttf\" \"POV-Ray\" 0.3, 0 translate <-1.8, -0.3, 0> }", NULL},
    {"julia_fractal", "julia_fractal { <-0.2, 0.6, 0.2, 0> }", NULL},
    {"height_field (256^2)", "height_field { function 256, 256 { 0.5 + 0.25 * sin(20 * x) * cos(15 * y) } translate -0.5 }", NULL},
};

#define HEAD "camera { location <0, 0, -10> look_at <0, 0, 0> }\nlight_source { <0, 50, -50> rgb 1 parallel point_at 0 }\n"

static double grad_dist(field_fn f, const double p[3])
{
    double g = 0;
    for (int k = 0; k < 3; ++k) {
        double a[3] = {p[0], p[1], p[2]}, b[3] = {p[0], p[1], p[2]};
        a[k] += 1e-6;
        b[k] -= 1e-6;
        double d = (f(a) - f(b)) / 2e-6;
        g += d * d;
    }
    return g > 0 ? fabs(f(p)) / sqrt(g) : 0;
}

/* Rays at the shape's bounding sphere from random directions (seeded, the same for every shape). */
static void make_rays(vec3 *o, vec3 *d, uint32_t n, vec3 c, float r)
{
    uint64_t s = 0x9e3779b97f4a7c15ull;
    for (uint32_t i = 0; i < n; ++i) {
        float u[4];
        for (int k = 0; k < 4; ++k) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            u[k] = (float)((s >> 40) * (1.0 / 16777216.0));
        }
        float z = 1 - 2 * u[0], rr = sqrtf(fmaxf(0, 1 - z * z)), ph = 6.2831853f * u[1];
        vec3 dir = {rr * cosf(ph), rr * sinf(ph), z};
        vec3 tgt = {c.x + r * (u[2] - 0.5f), c.y + r * (u[3] - 0.5f), c.z + r * (u[2] * u[3] - 0.25f)};
        o[i] = (vec3){tgt.x - 4 * r * dir.x, tgt.y - 4 * r * dir.y, tgt.z - 4 * r * dir.z};
        d[i] = dir;
    }
}

static double ns_per_ray(const vbnl_scene *sc, const vec3 *o, const vec3 *d, uint32_t n, double *hit_share)
{
    double t[5];
    uint32_t hits = 0;
    for (int run = 0; run < 5; ++run) {
        hits = 0;
        double t0 = now();
        for (uint32_t i = 0; i < n; ++i) {
            vbi_hit h;
            hits += (uint32_t)vbi_scene_intersect(sc, o[i], d[i], INFINITY, &h);
        }
        t[run] = (now() - t0) * 1e9 / n;
    }
    *hit_share = (double)hits / n;
    return median(t, 5);
}

/* ---- exact intersectors for comparison ------------------------------------------------------------ */

/* Roots in [lo, hi] of the polynomial c[0] + c[1] t + ... + c[n] t^n, isolated between the roots
 * of its derivative (recursively) and refined by bisection. */
static int poly_roots(const double *c, int n, double lo, double hi, double *out)
{
    if (n == 1) {
        if (c[1] == 0)
            return 0;
        double t = -c[0] / c[1];
        if (t >= lo && t <= hi) {
            out[0] = t;
            return 1;
        }
        return 0;
    }
    double dc[8], ext[10];
    for (int k = 1; k <= n; ++k)
        dc[k - 1] = k * c[k];
    int ne = poly_roots(dc, n - 1, lo, hi, ext + 1), nr = 0;
    ext[0] = lo;
    ext[ne + 1] = hi;
    for (int i = 0; i <= ne; ++i) {
        double a = ext[i], b = ext[i + 1], fa = 0, fb = 0;
        for (int k = n; k >= 0; --k) {
            fa = fa * a + c[k];
            fb = fb * b + c[k];
        }
        if ((fa < 0) == (fb < 0))
            continue;
        for (int it = 0; it < 60; ++it) {
            double m = 0.5 * (a + b), fm = 0;
            for (int k = n; k >= 0; --k)
                fm = fm * m + c[k];
            if ((fm < 0) == (fa < 0))
                a = m, fa = fm;
            else
                b = m;
        }
        out[nr++] = 0.5 * (a + b);
    }
    return nr;
}

/* The nearest hit of a ray with the torus (R = 1, r = 0.4, around y): its quartic in t. */
static double torus_exact(const double o[3], const double d[3])
{
    double R2 = 1, r2 = 0.16, od = o[0] * d[0] + o[1] * d[1] + o[2] * d[2], oo = o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
    double k = oo - r2 - R2;
    /* (|p|^2 - r2 - R2)^2 - 4 R2 (r2 - y^2) = 0 with p = o + t d, |d| = 1 */
    double c[5];
    c[4] = 1;
    c[3] = 4 * od;
    c[2] = 2 * k + 4 * od * od + 4 * R2 * d[1] * d[1];
    c[1] = 4 * k * od + 8 * R2 * o[1] * d[1];
    c[0] = k * k - 4 * R2 * (r2 - o[1] * o[1]);
    double roots[4];
    int n = poly_roots(c, 4, 0, 100, roots);
    double best = INFINITY;
    for (int i = 0; i < n; ++i)
        best = fmin(best, roots[i]);
    return best;
}

/* POV-Ray's isosurface marching: steps of (f - t) / max_gradient until the sign changes, then
 * bisection to the accuracy; counts evaluations. */
static long g_evals;
static double iso_f(const double p[3])
{
    g_evals++;
    return sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 0.8 + 0.08 * sin(6 * p[0]) * sin(6 * p[1]);
}

static double iso_exact(const double o[3], const double d[3])
{
    /* the container box -1..1 */
    double t0 = 0, t1 = INFINITY;
    for (int k = 0; k < 3; ++k) {
        if (d[k] == 0)
            continue;
        double a = (-1 - o[k]) / d[k], b = (1 - o[k]) / d[k];
        t0 = fmax(t0, fmin(a, b));
        t1 = fmin(t1, fmax(a, b));
    }
    if (t0 > t1)
        return INFINITY;
    double t = t0, p[3];
    for (int k = 0; k < 3; ++k)
        p[k] = o[k] + t * d[k];
    double v = iso_f(p);
    while (t < t1) {
        double step = fmax(fabs(v) / 1.6, 0.001);
        double tn = fmin(t + step, t1), vn;
        for (int k = 0; k < 3; ++k)
            p[k] = o[k] + tn * d[k];
        vn = iso_f(p);
        if ((vn < 0) != (v < 0)) {
            double a = t, b = tn;
            while (b - a > 0.001) {
                double m = 0.5 * (a + b);
                for (int k = 0; k < 3; ++k)
                    p[k] = o[k] + m * d[k];
                if ((iso_f(p) < 0) == (v < 0))
                    a = m;
                else
                    b = m;
            }
            return 0.5 * (a + b);
        }
        t = tn;
        v = vn;
    }
    return INFINITY;
}

static double ns_exact(double (*fn)(const double *, const double *), const vec3 *o, const vec3 *d, uint32_t n)
{
    double t[5];
    volatile double sink = 0;
    for (int run = 0; run < 5; ++run) {
        double t0 = now();
        for (uint32_t i = 0; i < n; ++i) {
            double oo[3] = {o[i].x, o[i].y, o[i].z}, dd[3] = {d[i].x, d[i].y, d[i].z};
            sink += fn(oo, dd) < INFINITY;
        }
        t[run] = (now() - t0) * 1e9 / n;
    }
    (void)sink;
    return median(t, 5);
}

int main(int argc, char **argv)
{
    uint32_t nrays = argc > 1 ? (uint32_t)atoi(argv[1]) : 200000;
    vbnl_context *ctx;
    vbnl_context_desc cdesc;
    vbnl_context_desc_init(&cdesc);
    cdesc.threads = 1;
    vbnl_error err = {0};
    if (vbnl_context_create(&cdesc, &ctx, &err) != VBNL_OK)
        return 1;
    vec3 *o = malloc(sizeof *o * nrays), *d = malloc(sizeof *d * nrays);
    printf("%-30s %9s %9s %8s %10s %11s %11s %8s %6s\n", "shape", "build ms", "triangles", "KiB", "max err", "99% err",
           "ns/ray", "x tri", "hits");
    double tri_ns = 0;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        char text[2048];
        snprintf(text, sizeof text, HEAD "%s", cases[c].text);
        vbnl_pov_options opt;
        vbnl_pov_options_init(&opt);
        double tb[3];
        vbnl_pov_scene *s = NULL;
        for (int run = 0; run < 3; ++run) {
            vbnl_pov_scene_destroy(s);
            s = NULL;
            double t0 = now();
            if (vbnl_pov_load_text(ctx, "bench.pov", text, strlen(text), &opt, &s, &err) != VBNL_OK) {
                fprintf(stderr, "%s: %s\n", cases[c].name, err.message);
                return 1;
            }
            tb[run] = (now() - t0) * 1e3;
        }
        const vbnl_scene *sc = vbnl_pov_scene_get(s);
        uint64_t tris = 0, bytes = 0;
        double maxe = 0, radius = 0;
        double *errs = NULL;
        size_t nerr = 0;
        vbnl_scene_info info;
        vbnl_scene_get_info(sc, &info, NULL);
        for (int k = 0; k < 3; ++k)
            radius += 0.25 * (info.bounds_max[k] - info.bounds_min[k]) * (info.bounds_max[k] - info.bounds_min[k]);
        radius = sqrt(radius);
        for (uint32_t g = 0; g < sc->geom_count; ++g) {
            if (sc->geoms[g].kind != SCENE_GEOM_MESH)
                continue;
            const scene_mesh *m = &sc->geoms[g].u.mesh;
            tris += m->triangle_count;
            bytes += (uint64_t)m->vertex_count * (12 + (m->normals ? 12 : 0) + (m->uvs ? 8 : 0)) +
                     (uint64_t)m->triangle_count * 12;
            if (!cases[c].f)
                continue;
            errs = realloc(errs, sizeof *errs * (nerr + 4 * (size_t)m->triangle_count));
            for (uint32_t t = 0; t < m->triangle_count; ++t) {
                const float *v[3];
                for (int k = 0; k < 3; ++k)
                    v[k] = m->positions + 3 * m->indices[3 * t + k];
                double pts[4][3];
                for (int k = 0; k < 3; ++k) {
                    pts[0][k] = (v[0][k] + v[1][k] + v[2][k]) / 3;
                    pts[1][k] = 0.5 * (v[0][k] + v[1][k]);
                    pts[2][k] = 0.5 * (v[1][k] + v[2][k]);
                    pts[3][k] = 0.5 * (v[2][k] + v[0][k]);
                }
                for (int q = 0; q < 4; ++q) {
                    double e = grad_dist(cases[c].f, pts[q]) / radius;
                    errs[nerr++] = e;
                    maxe = fmax(maxe, e);
                }
            }
        }
        double p99 = 0;
        if (nerr) {
            qsort(errs, nerr, sizeof *errs, cmp_d);
            p99 = errs[(size_t)(0.99 * (double)(nerr - 1))];
        }
        free(errs);
        vec3 ctr = {0.5f * (info.bounds_min[0] + info.bounds_max[0]), 0.5f * (info.bounds_min[1] + info.bounds_max[1]),
                    0.5f * (info.bounds_min[2] + info.bounds_max[2])};
        make_rays(o, d, nrays, ctr, (float)radius);
        double share, ns = ns_per_ray(sc, o, d, nrays, &share);
        if (c == 0)
            tri_ns = ns;
        char e1[16] = "-", e2[16] = "-";
        if (cases[c].f) {
            snprintf(e1, sizeof e1, "%.2e", maxe);
            snprintf(e2, sizeof e2, "%.2e", p99);
        }
        printf("%-30s %9.2f %9llu %8.0f %10s %11s %11.1f %8.2f %5.0f%%\n", cases[c].name, median(tb, 3),
               (unsigned long long)tris, bytes / 1024.0, e1, e2, ns, ns / tri_ns, 100 * share);
        vbnl_pov_scene_destroy(s);
    }
    /* the exact intersectors, on the torus's and the isosurface's rays */
    vec3 ctr = {0, 0, 0};
    make_rays(o, d, nrays, ctr, 1.4f);
    printf("\nexact intersection per ray, for comparison:\n");
    printf("  torus quartic, roots isolated by derivatives: %8.1f ns/ray (%.1f x a triangle)\n",
           ns_exact(torus_exact, o, d, nrays), ns_exact(torus_exact, o, d, nrays) / tri_ns);
    make_rays(o, d, nrays, ctr, 1.0f);
    g_evals = 0;
    double iso = ns_exact(iso_exact, o, d, nrays);
    printf("  isosurface marched (max_gradient 1.6, accuracy 0.001), C function: %8.1f ns/ray (%.1f x), %.1f evaluations/ray\n",
           iso, iso / tri_ns, (double)g_evals / (5.0 * nrays));
    free(o);
    free(d);
    vbnl_context_destroy(ctx);
    return 0;
}
