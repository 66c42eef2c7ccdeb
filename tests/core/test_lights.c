/* Tests for core/src/lights.c.
 *
 *  - sample_li / pdf_li: for rect, triangle, sphere (reference outside and inside) and the
 *    environment, the directions of sample_li pass a chi-square test against pdf_li integrated
 *    over bins of the sphere of directions (pdf_li evaluated at the point a ray along each
 *    direction hits), pdf_li integrates to 1, and every sample's pdf equals pdf_li.
 *  - Irradiance: E[Li cos / pdf] matches closed forms (Lambert's polygon formula for rect and
 *    triangle, pi L sin^2 cos for a sphere, pi L for the environment and inside a sphere).
 *  - Delta lights: point Li = I / d^2 exactly; spot zero outside the cone, I / d^2 inside the
 *    inner cone, the smoothstep value in between, and the cos^exponent factor.
 *  - Power: the flux estimate from sample_le matches vbi_light_power within 1% for every type.
 * Seeds are fixed, so results are deterministic. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lights.h"
#include "rng.h"
#include "sampling.h"

#include "../common/chi2.h"

#define SIGNIFICANCE 0.01
#define MIN_EXPECTED 5.0

/* ---- light construction (what the scene builder does) ------------------------------------- */

static vbi_light make_rect(vec3 p, vec3 e0, vec3 e1, vec3 L, int two_sided)
{
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBI_LIGHT_RECT;
    l.p = p;
    l.e0 = e0;
    l.e1 = e1;
    vec3 c = v3_cross(e0, e1);
    l.area = v3_len(c);
    l.n = v3_norm(c);
    l.L = L;
    l.two_sided = two_sided;
    return l;
}

static vbi_light make_triangle(vec3 p0, vec3 p1, vec3 p2, vec3 L, int two_sided)
{
    vbi_light l = make_rect(p0, v3_sub(p1, p0), v3_sub(p2, p0), L, two_sided);
    l.type = VBI_LIGHT_TRIANGLE;
    l.area *= 0.5f;
    return l;
}

static vbi_light make_sphere(vec3 c, float r, vec3 L, int two_sided)
{
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBI_LIGHT_SPHERE;
    l.p = c;
    l.radius = r;
    l.area = 4.0f * VBI_PI * r * r;
    l.L = L;
    l.two_sided = two_sided;
    return l;
}

static vbi_light make_distant(vbi_light_type type, vec3 n, vec3 L)
{
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = type;
    l.n = v3_norm(n);
    l.L = L;
    l.world_center = v3(1.0f, -2.0f, 0.5f);
    l.world_radius = 7.0f;
    return l;
}

static vbi_light make_spot(vec3 p, vec3 dir, vec3 I, float cos_inner, float cos_outer, float exponent)
{
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBI_LIGHT_SPOT;
    l.p = p;
    l.n = v3_norm(dir);
    l.L = I;
    l.cos_inner = cos_inner;
    l.cos_outer = cos_outer;
    l.exponent = exponent;
    return l;
}

/* ---- ray casting against the light's geometry (double precision) -------------------------- */

typedef struct dvec {
    double x, y, z;
} dvec;
static dvec dv(vec3 a) { return (dvec){a.x, a.y, a.z}; }
static dvec dsub(dvec a, dvec b) { return (dvec){a.x - b.x, a.y - b.y, a.z - b.z}; }
static dvec dadd(dvec a, dvec b) { return (dvec){a.x + b.x, a.y + b.y, a.z + b.z}; }
static dvec dscale(dvec a, double s) { return (dvec){a.x * s, a.y * s, a.z * s}; }
static double ddot(dvec a, dvec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static dvec dcross(dvec a, dvec b)
{
    return (dvec){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static dvec dnorm(dvec a) { return dscale(a, 1.0 / sqrt(ddot(a, a))); }
static vec3 fv(dvec a) { return v3((float)a.x, (float)a.y, (float)a.z); }

/* First hit of the ray o + t w (t > 0) with the light; *p and *n receive the point and the
 * geometric normal. Env: every direction "hits". */
static int light_hit(const vbi_light *l, dvec o, dvec w, dvec *p, dvec *n)
{
    switch (l->type) {
    case VBI_LIGHT_RECT:
    case VBI_LIGHT_TRIANGLE: {
        dvec e0 = dv(l->e0), e1 = dv(l->e1), N = dcross(e0, e1);
        double denom = ddot(w, N);
        if (denom == 0.0)
            return 0;
        double t = ddot(dsub(dv(l->p), o), N) / denom;
        if (!(t > 0.0))
            return 0;
        dvec q = dadd(o, dscale(w, t)), d = dsub(q, dv(l->p));
        double nn = ddot(N, N);
        double s = ddot(dcross(d, e1), N) / nn, u = ddot(dcross(e0, d), N) / nn;
        int in = l->type == VBI_LIGHT_RECT ? (s >= 0 && s <= 1 && u >= 0 && u <= 1)
                                            : (s >= 0 && u >= 0 && s + u <= 1);
        if (!in)
            return 0;
        *p = q;
        *n = dv(l->n);
        return 1;
    }
    case VBI_LIGHT_SPHERE: {
        dvec oc = dsub(o, dv(l->p));
        double b = ddot(oc, w), c = ddot(oc, oc) - (double)l->radius * l->radius;
        double disc = b * b - c;
        if (disc < 0.0)
            return 0;
        double sq = sqrt(disc), t = -b - sq;
        if (!(t > 0.0))
            t = -b + sq;
        if (!(t > 0.0))
            return 0;
        *p = dadd(o, dscale(w, t));
        *n = dnorm(dsub(*p, dv(l->p)));
        return 1;
    }
    case VBI_LIGHT_ENV:
        *p = dadd(o, dscale(w, 1e3));
        *n = dscale(w, -1.0);
        return 1;
    default:
        return 0;
    }
}

/* ---- chi-square of sample_li directions against pdf_li -------------------------------------- */

typedef struct li_ctx {
    const vbi_light *l;
    vec3 ref;
    frame f; /* z = the grid's axis */
} li_ctx;

static double li_grid_pdf(void *vctx, double z, double phi)
{
    const li_ctx *c = vctx;
    double s = sqrt(fmax(0.0, 1.0 - z * z));
    dvec w = dnorm(dadd(dadd(dscale(dv(c->f.s), s * cos(phi)), dscale(dv(c->f.t), s * sin(phi))),
                        dscale(dv(c->f.n), z)));
    dvec p, n;
    if (!light_hit(c->l, dv(c->ref), w, &p, &n))
        return 0.0;
    return vbi_light_pdf_li(c->l, c->ref, fv(p), fv(n), fv(w));
}

/* zmin: lowest cosine to `axis` the light can subtend (the grid concentrates on z >= zmin). */
static void check_li_distribution(const char *name, const vbi_light *l, vec3 ref, vec3 axis,
                                  double zmin, uint64_t seed)
{
    enum { N = 400000 };
    li_ctx ctx = {l, ref, frame_from_normal(v3_norm(axis))};
    vbi_chi2_grid g = {20, 40, zmin};
    int nb = vbi_chi2_grid_bins(&g);
    double *obs = calloc((size_t)nb, sizeof(double)), *expd = calloc((size_t)nb, sizeof(double));
    double total = vbi_chi2_grid_integrate(&g, li_grid_pdf, &ctx, 32, N, expd);

    vbi_rng rng = vbi_rng_make(seed, 99);
    int failed = 0, pdf_mismatch = 0, Li_mismatch = 0;
    for (int i = 0; i < N; ++i) {
        vbi_light_li_sample s;
        if (!vbi_light_sample_li(l, ref, vbi_rng_next2(&rng), &s)) {
            ++failed;
            continue;
        }
        float pdf = vbi_light_pdf_li(l, ref, s.p, s.n, s.wi);
        if (!(fabsf(pdf - s.pdf) <= 1e-3f * s.pdf) || s.is_delta)
            ++pdf_mismatch;
        /* Li must be the light's Le toward the reference point. */
        vec3 Le = vbi_light_Le(l, s.n, v3_neg(s.wi));
        if (fabsf(Le.x - s.Li.x) > 1e-6f || fabsf(v3_len(s.wi) - 1.0f) > 1e-4f)
            ++Li_mismatch;
        vec3 loc = frame_to_local(&ctx.f, s.wi);
        obs[vbi_chi2_grid_bin(&g, loc.z, atan2(loc.y, loc.x))] += 1.0;
    }
    vbi_chi2_result res;
    int ok = vbi_chi2_test(obs, expd, nb, MIN_EXPECTED, SIGNIFICANCE, &res);
    printf("#   %-24s pdf integral %.5f, %s\n", name, total, res.msg);
    free(obs);
    free(expd);
    assert_int_equal(failed, 0);
    assert_int_equal(pdf_mismatch, 0);
    assert_int_equal(Li_mismatch, 0);
    assert_true(fabs(total - 1.0) < 3e-3);
    assert_true(ok);
}

/* Smallest cosine to `axis` over the directions toward the polygon's vertices, with a margin. */
static double polygon_zmin(vec3 ref, vec3 axis, const vec3 *v, int nv)
{
    double m = 1.0;
    for (int i = 0; i < nv; ++i)
        m = fmin(m, v3_dot(v3_norm(v3_sub(v[i], ref)), v3_norm(axis)));
    return fmax(-1.0, m - 0.1 * (1.0 - m));
}

static void test_rect_li_distribution(void **state)
{
    (void)state;
    /* A tilted, non-rectangular parallelogram close to the reference point, so the pdf varies a
     * lot across it. Winding chosen so the emitting side faces the origin. */
    vec3 p = v3(-0.8f, -0.4f, 1.5f), e0 = v3(0.4f, 1.2f, 0.3f), e1 = v3(1.5f, 0.2f, 0.4f);
    vbi_light l = make_rect(p, e0, e1, v3(1.0f, 2.0f, 3.0f), 0);
    vec3 ref = v3(0.0f, 0.0f, 0.0f);
    assert_true(v3_dot(l.n, v3_sub(ref, p)) > 0.0f);
    vec3 v[4] = {p, v3_add(p, e0), v3_add(v3_add(p, e0), e1), v3_add(p, e1)};
    vec3 axis = v3_sub(v3_add(p, v3_scale(v3_add(e0, e1), 0.5f)), ref);
    check_li_distribution("rect", &l, ref, axis, polygon_zmin(ref, axis, v, 4), 101);

    /* Two-sided, seen from the back. */
    vbi_light l2 = make_rect(p, e1, e0, v3s(1.0f), 1);
    check_li_distribution("rect two-sided (back)", &l2, ref, axis, polygon_zmin(ref, axis, v, 4), 102);
}

static void test_triangle_li_distribution(void **state)
{
    (void)state;
    vec3 v[3] = {v3(-1.0f, -0.5f, 0.8f), v3(1.2f, -0.2f, 1.6f), v3(0.1f, 1.3f, 0.6f)};
    vbi_light l = make_triangle(v[0], v[2], v[1], v3s(2.0f), 0);
    vec3 ref = v3(0.1f, 0.2f, -0.3f);
    if (v3_dot(l.n, v3_sub(ref, v[0])) <= 0.0f)
        l = make_triangle(v[0], v[1], v[2], v3s(2.0f), 0);
    assert_true(v3_dot(l.n, v3_sub(ref, v[0])) > 0.0f);
    vec3 axis = v3_sub(v3_scale(v3_add(v3_add(v[0], v[1]), v[2]), 1.0f / 3.0f), ref);
    check_li_distribution("triangle", &l, ref, axis, polygon_zmin(ref, axis, v, 3), 201);
}

static void test_sphere_li_distribution(void **state)
{
    (void)state;
    vec3 c = v3(0.5f, 0.3f, 2.5f);
    vec3 ref = v3(0.0f, 0.0f, 0.0f);
    for (int k = 0; k < 2; ++k) {
        /* A large cone (about 25 degrees) and a small one (below the 1.5-degree switch to the
         * Taylor form). */
        float r = k == 0 ? 1.1f : 0.05f;
        vbi_light l = make_sphere(c, r, v3s(1.0f), 0);
        double d = v3_len(c);
        double cos_max = sqrt(1.0 - (double)r * r / (d * d));
        check_li_distribution(k == 0 ? "sphere outside" : "sphere outside (small)", &l, ref,
                              v3_sub(c, ref), cos_max - 0.1 * (1.0 - cos_max), 301 + (uint64_t)k);
    }
    /* Inside a two-sided sphere, off centre: area sampling gives a strongly non-uniform pdf. */
    vbi_light in = make_sphere(c, 2.0f, v3s(1.0f), 1);
    vec3 ref_in = v3_add(c, v3(0.9f, -0.6f, 0.8f));
    check_li_distribution("sphere inside", &in, ref_in, v3(0.0f, 0.0f, 1.0f), -1.0, 303);
}

static void test_env_li_distribution(void **state)
{
    (void)state;
    vbi_light l = make_distant(VBI_LIGHT_ENV, v3(0, 0, 1), v3s(1.0f));
    check_li_distribution("environment", &l, v3(0.3f, 0.1f, -0.2f), v3(0.2f, 1.0f, 0.1f), -1.0, 401);
}

/* ---- irradiance ------------------------------------------------------------------------------ */

/* Monte Carlo irradiance at ref on a surface with normal nref (channel-wise), with its standard
 * error. */
static void estimate_irradiance(const vbi_light *l, vec3 ref, vec3 nref, int n, uint64_t seed,
                                double mean[3], double *stderr_x)
{
    vbi_rng rng = vbi_rng_make(seed, 5);
    double sum[3] = {0, 0, 0}, sum2 = 0.0;
    for (int i = 0; i < n; ++i) {
        vbi_light_li_sample s;
        if (!vbi_light_sample_li(l, ref, vbi_rng_next2(&rng), &s))
            continue;
        double w = fmax(0.0, v3_dot(s.wi, nref)) / s.pdf;
        sum[0] += s.Li.x * w;
        sum[1] += s.Li.y * w;
        sum[2] += s.Li.z * w;
        sum2 += (s.Li.x * w) * (s.Li.x * w);
    }
    for (int c = 0; c < 3; ++c)
        mean[c] = sum[c] / n;
    *stderr_x = sqrt(fmax(0.0, sum2 / n - mean[0] * mean[0]) / n);
}

/* Asserts that the estimate matches E_exact * L per channel: within 5 standard errors, with the
 * standard error itself under 1% so the comparison is sharp. */
static void check_irradiance(const char *name, const vbi_light *l, vec3 ref, vec3 nref, double E_unit)
{
    double mean[3], se;
    estimate_irradiance(l, ref, nref, 200000, 777, mean, &se);
    printf("#   %-30s E = %.6f, expected %.6f (stderr %.2g)\n", name, mean[0], E_unit * l->L.x, se);
    assert_true(se <= 0.01 * E_unit * l->L.x + 1e-12);
    assert_true(fabs(mean[0] - E_unit * l->L.x) <= 5.0 * se + 1e-6 * E_unit);
    /* Other channels scale with L exactly (same samples). */
    assert_true(fabs(mean[1] * l->L.x - mean[0] * l->L.y) <= 1e-4 * mean[0] * l->L.y);
    assert_true(fabs(mean[2] * l->L.x - mean[0] * l->L.z) <= 1e-4 * mean[0] * l->L.z);
}

/* Lambert's formula: irradiance from a uniform unit-radiance polygon fully above the tangent
 * plane, E = 1/2 sum_i theta_i (nref . normalize(v_i x v_{i+1})), v_i unit vectors toward the
 * vertices (Arvo 1995, "Applications of irradiance tensors", Eq. 7). */
static double lambert_polygon(vec3 ref, vec3 nref, const vec3 *v, int nv)
{
    double sum = 0.0;
    for (int i = 0; i < nv; ++i) {
        dvec a = dnorm(dsub(dv(v[i]), dv(ref))), b = dnorm(dsub(dv(v[(i + 1) % nv]), dv(ref)));
        double theta = acos(fmax(-1.0, fmin(1.0, ddot(a, b))));
        sum += theta * ddot(dnorm(dcross(a, b)), dv(nref));
    }
    return 0.5 * fabs(sum);
}

static void test_irradiance(void **state)
{
    (void)state;
    vec3 ref = v3(0.0f, 0.0f, 0.0f);
    vec3 nref = v3_norm(v3(0.2f, -0.1f, 1.0f));
    {
        /* Large, close rect. */
        vec3 p = v3(-0.8f, -0.4f, 1.5f), e0 = v3(1.5f, 0.2f, 0.4f), e1 = v3(0.4f, 1.2f, 0.3f);
        vbi_light l = make_rect(p, e1, e0, v3(1.0f, 2.0f, 0.5f), 0);
        vec3 v[4] = {p, v3_add(p, e0), v3_add(v3_add(p, e0), e1), v3_add(p, e1)};
        check_irradiance("rect (near)", &l, ref, nref, lambert_polygon(ref, nref, v, 4));
        /* The same rect seen from its back emits nothing unless two-sided. */
        vbi_light back = make_rect(p, e0, e1, v3s(1.0f), 0);
        double mean[3], se;
        estimate_irradiance(&back, ref, nref, 1000, 1, mean, &se);
        assert_true(mean[0] == 0.0);
        back.two_sided = 1;
        check_irradiance("rect two-sided (back)", &back, ref, nref, lambert_polygon(ref, nref, v, 4));
    }
    {
        /* Small, far rect: close to L A cos cos / d^2. */
        vec3 p = v3(2.0f, 1.0f, 9.0f), e0 = v3(0.2f, 0.0f, 0.05f), e1 = v3(0.0f, 0.3f, 0.0f);
        vbi_light l = make_rect(p, e1, e0, v3s(5.0f), 0);
        vec3 v[4] = {p, v3_add(p, e0), v3_add(v3_add(p, e0), e1), v3_add(p, e1)};
        double E = lambert_polygon(ref, nref, v, 4);
        vec3 cen = v3_add(p, v3_scale(v3_add(e0, e1), 0.5f));
        vec3 w = v3_norm(cen);
        double approx = l.area * v3_dot(w, nref) * -v3_dot(w, l.n) / v3_len2(cen);
        assert_true(fabs(E - approx) < 0.01 * E);
        check_irradiance("rect (far)", &l, ref, nref, E);
    }
    {
        vec3 v[3] = {v3(-1.0f, -0.5f, 0.8f), v3(1.2f, -0.2f, 1.6f), v3(0.1f, 1.3f, 0.6f)};
        vbi_light l = make_triangle(v[0], v[2], v[1], v3(3.0f, 1.0f, 2.0f), 1);
        check_irradiance("triangle", &l, ref, nref, lambert_polygon(ref, nref, v, 3));
    }
    {
        /* Sphere fully above the horizon: E = pi L (r/d)^2 cos(angle to the centre). */
        vec3 c = v3(0.5f, 0.3f, 4.0f);
        float r = 1.2f;
        vbi_light l = make_sphere(c, r, v3(2.0f, 1.0f, 4.0f), 0);
        double d2 = v3_len2(c);
        check_irradiance("sphere (facing)", &l, ref, v3_norm(c), M_PI * r * r / d2);
        check_irradiance("sphere (tilted)", &l, ref, nref, M_PI * r * r / d2 * v3_dot(v3_norm(c), nref));
        vbi_light small = make_sphere(c, 0.02f, v3s(1000.0f), 0);
        check_irradiance("sphere (small)", &small, ref, nref,
                         M_PI * 0.02 * 0.02 / d2 * v3_dot(v3_norm(c), nref));
    }
    {
        /* Inside a closed two-sided sphere (the furnace): radiance L from everywhere, E = pi L. */
        vec3 c = v3(0.5f, 0.3f, 4.0f);
        vbi_light l = make_sphere(c, 2.0f, v3s(1.0f), 1);
        vec3 in_ref = v3_add(c, v3(0.7f, -0.9f, 0.4f));
        check_irradiance("inside two-sided sphere", &l, in_ref, nref, M_PI);
        l.two_sided = 0; /* a one-sided sphere emits outward only */
        vbi_light_li_sample s;
        assert_int_equal(vbi_light_sample_li(&l, in_ref, (vec2){0.3f, 0.6f}, &s), 0);
    }
    {
        vbi_light l = make_distant(VBI_LIGHT_ENV, v3(0, 0, 1), v3s(1.0f));
        check_irradiance("environment", &l, ref, nref, M_PI);
    }
}

/* ---- Le ---------------------------------------------------------------------------------- */

static void test_Le_sidedness(void **state)
{
    (void)state;
    vbi_light r = make_rect(v3(0, 0, 0), v3(1, 0, 0), v3(0, 1, 0), v3s(2.0f), 0);
    assert_true(vbi_light_Le(&r, r.n, v3(0.1f, 0.0f, 1.0f)).x == 2.0f);
    assert_true(vbi_light_Le(&r, r.n, v3(0.1f, 0.0f, -1.0f)).x == 0.0f);
    /* The caller's normal cannot flip the emitting side of a planar light. */
    assert_true(vbi_light_Le(&r, v3(0, 0, -1), v3(0.1f, 0.0f, 1.0f)).x == 2.0f);
    r.two_sided = 1;
    assert_true(vbi_light_Le(&r, r.n, v3(0.1f, 0.0f, -1.0f)).x == 2.0f);

    vbi_light s = make_sphere(v3(0, 0, 0), 1.0f, v3s(3.0f), 0);
    assert_true(vbi_light_Le(&s, v3(0, 0, 1), v3(0, 0.5f, 1)).x == 3.0f);
    assert_true(vbi_light_Le(&s, v3(0, 0, 1), v3(0, 0.5f, -1)).x == 0.0f);
    s.two_sided = 1;
    assert_true(vbi_light_Le(&s, v3(0, 0, 1), v3(0, 0.5f, -1)).x == 3.0f);

    vbi_light e = make_distant(VBI_LIGHT_ENV, v3(0, 0, 1), v3s(0.5f));
    assert_true(vbi_light_Le(&e, v3(0, 0, 1), v3(0, 1, 0)).x == 0.5f);
    vbi_light d = make_distant(VBI_LIGHT_DIRECTIONAL, v3(0, 0, 1), v3s(0.5f));
    assert_true(v3_is_black(vbi_light_Le(&d, v3(0, 0, 1), v3(0, 0, -1))));
}

/* ---- delta lights ------------------------------------------------------------------------- */

static void test_point_light(void **state)
{
    (void)state;
    vbi_light l;
    memset(&l, 0, sizeof(l));
    l.type = VBI_LIGHT_POINT;
    l.p = v3(1.0f, 2.0f, 3.0f);
    l.L = v3(4.0f, 8.0f, 2.0f);
    vec3 refs[3] = {v3(0, 0, 0), v3(1.0f, 2.0f, 0.5f), v3(-3.0f, 7.0f, 3.0f)};
    for (int i = 0; i < 3; ++i) {
        vbi_light_li_sample s;
        assert_int_equal(vbi_light_sample_li(&l, refs[i], (vec2){0.3f, 0.7f}, &s), 1);
        vec3 d = v3_sub(l.p, refs[i]);
        float d2 = v3_len2(d);
        assert_true(s.is_delta && s.pdf == 1.0f);
        assert_true(fabsf(s.dist - sqrtf(d2)) <= 1e-6f * s.dist);
        assert_true(fabsf(s.Li.x - l.L.x / d2) <= 1e-6f * s.Li.x);
        assert_true(fabsf(s.Li.y - l.L.y / d2) <= 1e-6f * s.Li.y);
        assert_true(fabsf(s.Li.z - l.L.z / d2) <= 1e-6f * s.Li.z);
        assert_true(v3_len(v3_sub(s.wi, v3_norm(d))) < 1e-6f);
        assert_true(vbi_light_pdf_li(&l, refs[i], s.p, s.n, s.wi) == 0.0f);
    }
}

static void test_spot_light(void **state)
{
    (void)state;
    const float ci = 0.9f, co = 0.7f;
    vec3 axis = v3_norm(v3(0.3f, -0.2f, -1.0f));
    vbi_light l = make_spot(v3(0.5f, 1.0f, 6.0f), axis, v3(10.0f, 5.0f, 1.0f), ci, co, 0.0f);
    frame f = frame_from_normal(axis);
    /* Directions from the light at a given cosine to the axis, three azimuths each. */
    const float cosines[] = {1.0f, 0.95f, 0.9001f, 0.8f, 0.75f, 0.6999f, 0.5f, 0.0f, -0.5f};
    for (unsigned i = 0; i < sizeof(cosines) / sizeof(cosines[0]); ++i)
        for (int k = 0; k < 3; ++k) {
            float c = cosines[i], s = sqrtf(1.0f - c * c), phi = 2.1f * (float)k;
            vec3 w = frame_to_world(&f, v3(s * cosf(phi), s * sinf(phi), c));
            float dist = 3.0f + (float)k;
            vec3 ref = v3_fma(l.p, w, dist);
            vbi_light_li_sample smp;
            int ok = vbi_light_sample_li(&l, ref, (vec2){0.5f, 0.5f}, &smp);
            float t = clampf((c - co) / (ci - co), 0.0f, 1.0f);
            float expect = c < co ? 0.0f : t * t * (3.0f - 2.0f * t);
            if (expect == 0.0f) {
                assert_true(!ok || v3_is_black(smp.Li)); /* zero outside the cone */
                continue;
            }
            assert_int_equal(ok, 1);
            float Ix = l.L.x * expect / (dist * dist);
            assert_true(fabsf(smp.Li.x - Ix) <= 2e-3f * Ix);
            if (c >= ci) /* full intensity inside the inner cone */
                assert_true(fabsf(smp.Li.x - l.L.x / (dist * dist)) <= 1e-4f * smp.Li.x);
        }
    /* Half-way through the transition the smoothstep is exactly 1/2. */
    {
        float c = 0.5f * (ci + co), s = sqrtf(1.0f - c * c);
        vec3 ref = v3_fma(l.p, frame_to_world(&f, v3(s, 0.0f, c)), 2.0f);
        vbi_light_li_sample smp;
        assert_int_equal(vbi_light_sample_li(&l, ref, (vec2){0.5f, 0.5f}, &smp), 1);
        assert_true(fabsf(smp.Li.x - 0.5f * l.L.x / 4.0f) <= 1e-3f * smp.Li.x);
    }
    /* The exponent multiplies by cos^exponent, also inside the inner cone. */
    {
        vbi_light le = make_spot(l.p, axis, l.L, ci, co, 5.0f);
        float c = 0.95f, s = sqrtf(1.0f - c * c);
        vec3 ref = v3_fma(l.p, frame_to_world(&f, v3(0.0f, s, c)), 2.0f);
        vbi_light_li_sample smp;
        assert_int_equal(vbi_light_sample_li(&le, ref, (vec2){0.5f, 0.5f}, &smp), 1);
        float Ix = l.L.x * powf(c, 5.0f) / 4.0f;
        assert_true(fabsf(smp.Li.x - Ix) <= 1e-3f * Ix);
        assert_true(vbi_light_pdf_li(&le, ref, smp.p, smp.n, smp.wi) == 0.0f);
    }
}

/* ---- power ------------------------------------------------------------------------------- */

/* Flux estimate Le |cos| / (pdf_pos pdf_dir) from sample_le, per channel; also checks the
 * geometric sanity of every ray through `check` (may be NULL). */
typedef int (*le_check_fn)(const vbi_light *l, const vbi_light_le_sample *s);

static void check_power(const char *name, const vbi_light *l, le_check_fn check, uint64_t seed)
{
    enum { N = 200000 };
    vbi_rng rng = vbi_rng_make(seed, 17);
    double sum[3] = {0, 0, 0};
    int bad = 0;
    for (int i = 0; i < N; ++i) {
        vec2 up = vbi_rng_next2(&rng), ud = vbi_rng_next2(&rng);
        vbi_light_le_sample s;
        if (!vbi_light_sample_le(l, up, ud, &s))
            continue;
        if (!(s.pdf_pos > 0.0f) || !(s.pdf_dir > 0.0f) || fabsf(v3_len(s.dir) - 1.0f) > 1e-4f ||
            (check && !check(l, &s))) {
            ++bad;
            continue;
        }
        double w = s.cos_at_light / ((double)s.pdf_pos * s.pdf_dir);
        sum[0] += s.Le.x * w;
        sum[1] += s.Le.y * w;
        sum[2] += s.Le.z * w;
    }
    vec3 P = vbi_light_power(l);
    printf("#   %-26s flux %.6g, power %.6g (%+.3f%%)\n", name, sum[0] / N, P.x,
           100.0 * (sum[0] / N / P.x - 1.0));
    assert_int_equal(bad, 0);
    assert_true(fabs(sum[0] / N - P.x) <= 0.01 * P.x);
    assert_true(fabs(sum[1] / N - P.y) <= 0.01 * P.y);
    assert_true(fabs(sum[2] / N - P.z) <= 0.01 * P.z);
}

static int check_le_planar(const vbi_light *l, const vbi_light_le_sample *s)
{
    /* On the light, leaving from the side the reported normal is on, cos consistent. */
    dvec d = dsub(dv(s->p), dv(l->p)), e0 = dv(l->e0), e1 = dv(l->e1), N = dcross(e0, e1);
    double nn = ddot(N, N), a = ddot(dcross(d, e1), N) / nn, b = ddot(dcross(e0, d), N) / nn;
    double off = fabs(ddot(d, N)) / sqrt(nn);
    int in = l->type == VBI_LIGHT_RECT ? (a >= -1e-5 && a <= 1 + 1e-5 && b >= -1e-5 && b <= 1 + 1e-5)
                                        : (a >= -1e-5 && b >= -1e-5 && a + b <= 1 + 1e-5);
    float c = v3_dot(s->dir, s->n);
    int side_ok = l->two_sided ? v3_absdot(s->n, l->n) > 0.9999f : v3_dot(s->n, l->n) > 0.9999f;
    return in && off < 1e-5 && side_ok && c >= 0.0f && fabsf(c - s->cos_at_light) < 1e-5f;
}

static int check_le_sphere(const vbi_light *l, const vbi_light_le_sample *s)
{
    vec3 d = v3_sub(s->p, l->p);
    float c = v3_dot(s->dir, s->n);
    vec3 outward = v3_scale(d, 1.0f / l->radius);
    int side_ok = l->two_sided ? v3_absdot(s->n, outward) > 0.9999f : v3_dot(s->n, outward) > 0.9999f;
    return fabsf(v3_len(d) - l->radius) < 1e-5f * l->radius && side_ok && c >= 0.0f &&
           fabsf(c - s->cos_at_light) < 1e-5f;
}

static int check_le_distant(const vbi_light *l, const vbi_light_le_sample *s)
{
    /* The ray starts one radius behind the bounding sphere and crosses it. */
    vec3 oc = v3_sub(l->world_center, s->p);
    float along = v3_dot(oc, s->dir);
    float perp2 = v3_len2(oc) - along * along;
    int dir_ok = l->type == VBI_LIGHT_ENV || v3_dot(s->dir, l->n) > 0.99999f;
    return dir_ok && fabsf(along - l->world_radius) < 1e-4f * l->world_radius &&
           perp2 <= sqr(l->world_radius) * 1.0001f;
}

static int check_le_spot(const vbi_light *l, const vbi_light_le_sample *s)
{
    return v3_dot(s->dir, l->n) >= l->cos_outer - 1e-5f && s->cos_at_light == 1.0f;
}

static void test_power(void **state)
{
    (void)state;
    vec3 L = v3(1.0f, 0.25f, 3.0f);
    vbi_light point;
    memset(&point, 0, sizeof(point));
    point.type = VBI_LIGHT_POINT;
    point.p = v3(1, 2, 3);
    point.L = L;
    check_power("point", &point, NULL, 1);

    vec3 axis = v3(0.2f, 1.0f, -0.3f);
    vbi_light spot = make_spot(v3(0, 0, 0), axis, L, 0.9f, 0.7f, 0.0f);
    check_power("spot", &spot, check_le_spot, 2);
    spot = make_spot(v3(0, 0, 0), axis, L, 0.95f, 0.5f, 8.5f);
    check_power("spot (exponent 8.5)", &spot, check_le_spot, 3);
    spot = make_spot(v3(0, 0, 0), axis, L, 0.2f, -0.4f, 0.0f);
    check_power("spot (wider than 90 deg)", &spot, check_le_spot, 4);
    spot = make_spot(v3(0, 0, 0), axis, L, 0.5f, -0.3f, 2.0f);
    check_power("spot (wide, exponent 2)", &spot, check_le_spot, 5);
    spot = make_spot(v3(0, 0, 0), axis, L, 0.8f, 0.8f, 0.0f);
    check_power("spot (hard edge)", &spot, check_le_spot, 6);
    /* Closed form for exponent 0 (pbrt-v4 SpotLight::Phi): 2 pi I ((1 - ci) + (ci - co) / 2). */
    spot = make_spot(v3(0, 0, 0), axis, L, 0.9f, 0.7f, 0.0f);
    assert_true(fabsf(vbi_light_power(&spot).x - 2.0f * VBI_PI * L.x * (0.1f + 0.1f)) < 1e-5f);

    vbi_light rect = make_rect(v3(1, 0, 2), v3(0.5f, 0.1f, 0.0f), v3(0.2f, 0.0f, 1.5f), L, 0);
    check_power("rect", &rect, check_le_planar, 7);
    rect.two_sided = 1;
    check_power("rect two-sided", &rect, check_le_planar, 8);
    vbi_light tri = make_triangle(v3(0, 0, 0), v3(1, 0.2f, 0), v3(0.3f, 2, 1), L, 0);
    check_power("triangle", &tri, check_le_planar, 9);
    vbi_light sph = make_sphere(v3(0, 1, 0), 0.7f, L, 0);
    check_power("sphere", &sph, check_le_sphere, 10);
    sph.two_sided = 1;
    check_power("sphere two-sided", &sph, check_le_sphere, 11);
    vbi_light dir = make_distant(VBI_LIGHT_DIRECTIONAL, v3(0.3f, -1.0f, 0.2f), L);
    check_power("directional", &dir, check_le_distant, 12);
    vbi_light env = make_distant(VBI_LIGHT_ENV, v3(0, 0, 1), L);
    check_power("environment", &env, check_le_distant, 13);

    /* The stated closed forms. */
    assert_true(fabsf(vbi_light_power(&point).x - 4.0f * VBI_PI * L.x) < 1e-5f);
    assert_true(fabsf(vbi_light_power(&rect).x - 2.0f * VBI_PI * rect.area * L.x) < 1e-4f);
    assert_true(fabsf(vbi_light_power(&env).x - 4.0f * VBI_PI * VBI_PI * 49.0f * L.x) < 1e-2f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rect_li_distribution),
        cmocka_unit_test(test_triangle_li_distribution),
        cmocka_unit_test(test_sphere_li_distribution),
        cmocka_unit_test(test_env_li_distribution),
        cmocka_unit_test(test_irradiance),
        cmocka_unit_test(test_Le_sidedness),
        cmocka_unit_test(test_point_light),
        cmocka_unit_test(test_spot_light),
        cmocka_unit_test(test_power),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
