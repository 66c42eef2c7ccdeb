/* Tests for core/src/environment.c (the directional environment) through the scene API.
 *
 *  - Layers: solid layers compose by POV-Ray 3.7's rule (top last; filter, transmit, emission,
 *    background below) into a constant sky; a pattern layer is evaluated at pattern_from_world
 *    (d, 1), its transform included.
 *  - Sampling: directions of the env light's sample_li pass a chi-square test against pdf_li
 *    integrated over bins of the sphere, pdf_li integrates to 1, and every sample's pdf equals
 *    pdf_li at its direction.
 *  - Irradiance on an upward facing plane under a gradient sky (L = A + (B - A) cos theta above
 *    the horizon, E = pi A + 2 pi (B - A) / 3): light sampling alone, cosine (BSDF) sampling alone
 *    and their MIS combination with the table's pdf agree with it; light tracing (sample_le)
 *    carries the sky's power.
 *  - Shadows: at points of a plane beside a sphere, environment sampling alone and cosine sampling
 *    alone, both with shadow rays, agree within their noise.
 *  - Furnace: the path integrator renders a white-ish Lambertian plane under that sky as
 *    rho E / pi in every pixel.
 * Seeds are fixed, so results are deterministic. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "environment.h"
#include "lights.h"
#include "rng.h"
#include "scene_internal.h"
#include "vbnl/vbnl.h"

#include "../common/chi2.h"
#include "../common/scenes.h"
#include "../common/ts_render.h"

#define PI_D 3.14159265358979323846

/* A (bottom) and B (zenith) of the gradient sky; the lower hemisphere repeats the ramp. */
static const float SKY_A[3] = {1.0f, 0.9f, 0.8f}, SKY_B[3] = {0.1f, 0.3f, 2.0f};

static uint32_t gradient_pigment(vbnl_scene *s, const float a[3], const float b[3], float knee)
{
    vbnl_pattern_desc pd;
    vbnl_pattern_desc_init(&pd);
    pd.kind = VBNL_PATTERN_GRADIENT;
    pd.gradient.direction[0] = 0.0;
    pd.gradient.direction[1] = 1.0;
    uint32_t pat, pig;
    assert_int_equal(vbnl_scene_add_pattern(s, &pd, &pat, NULL), VBNL_OK);
    /* [0 a] [knee a] [1 b], or [0 a] [1 b] without a knee */
    vbnl_pigment_map_entry e[3];
    memset(e, 0, sizeof(e));
    uint32_t count = 0;
    e[count].value = 0.0f;
    memcpy(e[count++].color, a, sizeof(float) * 3);
    if (knee > 0.0f) {
        e[count].value = knee;
        memcpy(e[count++].color, a, sizeof(float) * 3);
    }
    e[count].value = 1.0f;
    memcpy(e[count++].color, b, sizeof(float) * 3);
    vbnl_pigment_desc d;
    vbnl_pigment_desc_init(&d);
    d.kind = VBNL_PIGMENT_MAP;
    d.pattern = pat + 1;
    d.map = e;
    d.map_count = count;
    assert_int_equal(vbnl_scene_add_pigment(s, &d, &pig, NULL), VBNL_OK);
    return pig;
}

static uint32_t solid_pigment(vbnl_scene *s, float r, float g, float b, float f, float t)
{
    vbnl_pigment_desc d;
    vbnl_pigment_desc_init(&d);
    d.kind = VBNL_PIGMENT_SOLID;
    float c[5] = {r, g, b, f, t};
    memcpy(d.color, c, sizeof(c));
    uint32_t id;
    assert_int_equal(vbnl_scene_add_pigment(s, &d, &id, NULL), VBNL_OK);
    return id;
}

/* A scene: a large upward facing Lambertian quad of albedo rho at y = 0 seen from above. */
static vbnl_scene *plane_scene(vbnl_context *ctx, float rho)
{
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    uint32_t m = ts_material(s, VBNL_MATERIAL_LAMBERT, rho, rho, rho, 0.0f);
    const float q[12] = {-100, 0, -100, -100, 0, 100, 100, 0, 100, 100, 0, -100};
    ts_quad(s, q, m);
    float pos[3] = {0, 1, 0}, target[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 30.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
    return s;
}

static void set_sky(vbnl_scene *s, const uint32_t *ids, uint32_t n)
{
    vbnl_environment_desc d;
    vbnl_environment_desc_init(&d);
    d.pigments = ids;
    d.pigment_count = n;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &d, NULL), VBNL_OK);
}

static const vbi_light *env_light(const vbnl_scene *s)
{
    assert_true(s->env_light != VBI_NO_LIGHT);
    return &s->lights[s->env_light];
}

static vec3 sky_Le(const vbi_light *l, vec3 d) { return vbi_light_Le(l, v3s(0.0f), v3_neg(d)); }

/* ---- layers -------------------------------------------------------------------------------------- */

static void test_layers(void **state)
{
    (void)state;
    vbnl_context *ctx = ts_context(1);
    vbnl_scene *s = plane_scene(ctx, 0.5f);
    uint32_t ids[2] = {solid_pigment(s, 0.2f, 0.4f, 0.6f, 0, 0), solid_pigment(s, 1.0f, 0.5f, 0.0f, 0.5f, 0.25f)};
    vbnl_environment_desc d;
    vbnl_environment_desc_init(&d);
    d.pigments = ids;
    d.pigment_count = 2;
    d.emission[0] = d.emission[1] = d.emission[2] = 2.0f;
    d.background[0] = d.background[1] = d.background[2] = 1.0f;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &d, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const vbi_light *l = env_light(s);
    /* top: (1, .5, 0) * (1 - .75) * 2 = (.5, .25, 0), lets (1, .5, 0) * .5 + .25 = (.75, .5, .25)
     * through; bottom: (.2, .4, .6) * 2 * that = (.3, .4, .3), opaque: no background */
    assert_null(l->env); /* solid layers: the constant fast path */
    vec3 L = sky_Le(l, v3(0.3f, 0.8f, -0.52f));
    assert_float_equal(L.x, 0.8f, 1e-5f);
    assert_float_equal(L.y, 0.65f, 1e-5f);
    assert_float_equal(L.z, 0.3f, 1e-5f);
    vbnl_scene_destroy(s);

    /* the same layers by POV-Ray's rule before 3.7: the top weighs 0.25, leaves a scalar 0.75 for
     * the bottom, (0.25, 0.125, 0) + 0.75 (0.2, 0.4, 0.6) = (0.4, 0.425, 0.45), times emission 2 */
    s = plane_scene(ctx, 0.5f);
    ids[0] = solid_pigment(s, 0.2f, 0.4f, 0.6f, 0, 0);
    ids[1] = solid_pigment(s, 1.0f, 0.5f, 0.0f, 0.5f, 0.25f);
    d.legacy_layers = 1;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &d, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    L = sky_Le(env_light(s), v3(0, -1, 0));
    assert_float_equal(L.x, 0.8f, 1e-5f);
    assert_float_equal(L.y, 0.85f, 1e-5f);
    assert_float_equal(L.z, 0.9f, 1e-5f);
    vbnl_scene_destroy(s);
    d.legacy_layers = 0;

    /* a transparent top over nothing: the background shows, unscaled by the emission */
    s = plane_scene(ctx, 0.5f);
    ids[0] = solid_pigment(s, 0.5f, 0.5f, 0.5f, 0.0f, 1.0f);
    d.pigments = ids;
    d.pigment_count = 1;
    d.background[1] = 0.25f;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &d, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    L = sky_Le(env_light(s), v3(0, 1, 0));
    assert_float_equal(L.x, 1.0f, 1e-6f);
    assert_float_equal(L.y, 0.25f, 1e-6f);
    vbnl_scene_destroy(s);

    /* a pattern layer at pattern_from_world (d, 1): translated by 0.5 along y, the horizon shows
     * the middle of the ramp */
    s = plane_scene(ctx, 0.5f);
    ids[0] = gradient_pigment(s, SKY_A, SKY_B, 0.0f);
    vbnl_environment_desc_init(&d);
    d.pigments = ids;
    d.pigment_count = 1;
    d.pattern_from_world[7] = 0.5;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &d, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    assert_non_null(env_light(s)->env);
    L = sky_Le(env_light(s), v3(1, 0, 0));
    assert_float_equal(L.z, 0.5f * (SKY_A[2] + SKY_B[2]), 1e-5f);
    L = sky_Le(env_light(s), v3(0, 0.25f, 0.968246f));
    assert_float_equal(L.z, SKY_A[2] + 0.75f * (SKY_B[2] - SKY_A[2]), 1e-4f);
    /* a committed scene takes no environment */
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &d, NULL), VBNL_ERR_STATE);
    vbnl_scene_destroy(s);
    /* bad descriptions */
    s = plane_scene(ctx, 0.5f);
    vbnl_environment_desc bad = d;
    uint32_t unknown = 999;
    bad.pigments = &unknown;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &bad, NULL), VBNL_ERR_INVALID_ARGUMENT);
    bad.pigments = ids;
    bad.pigment_count = 0;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &bad, NULL), VBNL_ERR_INVALID_ARGUMENT);
    bad.pigment_count = 1;
    bad.pattern_from_world[12] = 1.0;
    ids[0] = solid_pigment(s, 1, 1, 1, 0, 0);
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &bad, NULL), VBNL_ERR_INVALID_ARGUMENT);
    bad = d;
    bad.pigments = ids;
    bad.emission[0] = NAN;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &bad, NULL), VBNL_ERR_INVALID_ARGUMENT);
    bad = d;
    bad.pigments = ids;
    bad.size = 4;
    assert_int_equal(vbnl_scene_set_environment_pigments(s, &bad, NULL), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* ---- sampling against the pdf ---------------------------------------------------------------- */

static double pdf_at(void *ctx, double z, double phi)
{
    const vbi_light *l = ctx;
    double r = sqrt(fmax(1.0 - z * z, 0.0));
    vec3 w = v3((float)(r * cos(phi)), (float)z, (float)(r * sin(phi)));
    return vbi_light_pdf_li(l, v3s(0.0f), v3s(0.0f), v3s(0.0f), w);
}

/* Expected counts of grid g when the pdf is constant on the table's cells (rows of equal theta
 * about +y, columns of equal phi): each bin is cut at the cell edges and every piece gets the pdf
 * at its middle times its solid angle dz dphi, which is exact. Returns the integral. */
static double table_expected(const vbi_chi2_grid *g, const vbi_light *l, double count, double *expected)
{
    const double two_pi = 2.0 * PI_D;
    double dz = (1.0 - g->zmin) / g->nz, dphi = two_pi / g->nphi, total = 0.0;
    for (int iz = 0; iz < g->nz; ++iz) {
        double za = g->zmin + iz * dz, zb = za + dz;
        for (int ip = 0; ip < g->nphi; ++ip) {
            double pa = ip * dphi, pb = pa + dphi, sum = 0.0;
            for (double z0 = za; z0 < zb;) {
                /* the next row edge above z0: cos of the row edge below theta(z0) */
                double th = acos(fmin(fmax(z0, -1.0), 1.0));
                int row = (int)floor(th / (PI_D / VBI_ENV_TABLE_ROWS) - 1e-9);
                double z1 = fmin(zb, cos(row * (PI_D / VBI_ENV_TABLE_ROWS)));
                if (!(z1 > z0))
                    z1 = fmin(zb, z0 + 1e-9);
                for (double p0 = pa; p0 < pb;) {
                    double p1 = fmin(pb, (floor(p0 / (two_pi / VBI_ENV_TABLE_COLS) + 1e-9) + 1.0) *
                                             (two_pi / VBI_ENV_TABLE_COLS));
                    sum += pdf_at((void *)l, 0.5 * (z0 + z1), 0.5 * (p0 + p1)) * (z1 - z0) * (p1 - p0);
                    p0 = p1;
                }
                z0 = z1;
            }
            expected[iz * g->nphi + ip] = sum * count;
            total += sum;
        }
    }
    expected[g->nz * g->nphi] = 0.0;
    return total;
}

static void test_sampling_chi2(void **state)
{
    (void)state;
    vbnl_context *ctx = ts_context(1);
    vbnl_scene *s = plane_scene(ctx, 0.5f);
    /* a bright cap near the zenith over a dim sky: far from uniform */
    const float dim[3] = {0.02f, 0.02f, 0.02f}, bright[3] = {20.0f, 10.0f, 5.0f};
    uint32_t id = gradient_pigment(s, dim, bright, 0.85f);
    set_sky(s, &id, 1);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const vbi_light *l = env_light(s);
    assert_non_null(l->env);

    /* the chi2 grid's z is y here (the table's pole); phi = atan2(z, x) as the table */
    vbi_chi2_grid g = {24, 48, -1.0};
    int nb = vbi_chi2_grid_bins(&g);
    double *obs = calloc((size_t)nb, sizeof(double)), *exp_ = calloc((size_t)nb, sizeof(double));
    assert_non_null(obs);
    assert_non_null(exp_);
    const int n = 400000;
    vbi_rng rng = vbi_rng_make(11, 3);
    double worst = 0.0;
    for (int i = 0; i < n; ++i) {
        vec2 u = {vbi_rng_next(&rng), vbi_rng_next(&rng)};
        vbi_light_li_sample ls;
        assert_true(vbi_light_sample_li(l, v3s(0.0f), u, &ls));
        double pdf = vbi_light_pdf_li(l, v3s(0.0f), v3s(0.0f), v3s(0.0f), ls.wi);
        double rel = fabs(ls.pdf / pdf - 1.0);
        if (rel > worst)
            worst = rel;
        obs[vbi_chi2_grid_bin(&g, ls.wi.y, atan2(ls.wi.z, ls.wi.x))] += 1.0;
    }
    double total = table_expected(&g, l, n, exp_);
    vbi_chi2_result res;
    int pass = vbi_chi2_test(obs, exp_, nb, 5.0, 0.01, &res);
    print_message("# env sampling: %s; pdf integral %.5f; worst sample pdf / pdf_li - 1 = %.2e\n", res.msg, total,
                  worst);
    assert_true(pass);
    assert_true(fabs(total - 1.0) < 1e-4);
    assert_true(worst < 1e-3);
    free(obs);
    free(exp_);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* ---- irradiance: light sampling, BSDF sampling, MIS ------------------------------------------------ */

static double sky_irradiance(int k) { return PI_D * SKY_A[k] + 2.0 * PI_D * (SKY_B[k] - SKY_A[k]) / 3.0; }

static void test_irradiance_estimators(void **state)
{
    (void)state;
    vbnl_context *ctx = ts_context(1);
    vbnl_scene *s = plane_scene(ctx, 0.5f);
    uint32_t id = gradient_pigment(s, SKY_A, SKY_B, 0.0f);
    set_sky(s, &id, 1);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const vbi_light *l = env_light(s);
    const vec3 n = v3(0, 1, 0);
    const frame f = frame_from_normal(n);
    const int N = 200000;
    double sum[3][3] = {{0}}, sq[3][3] = {{0}};
    vbi_rng rng = vbi_rng_make(5, 1);
    for (int i = 0; i < N; ++i) {
        vec3 e[3] = {v3s(0.0f), v3s(0.0f), v3s(0.0f)}; /* light only, cosine only, MIS */
        vbi_light_li_sample ls;
        vec2 u = {vbi_rng_next(&rng), vbi_rng_next(&rng)};
        if (vbi_light_sample_li(l, v3s(0.0f), u, &ls)) {
            float c = v3_dot(ls.wi, n);
            if (c > 0.0f) {
                e[0] = v3_scale(ls.Li, c / ls.pdf);
                float pb = c * VBI_INV_PI;
                e[2] = v3_add(e[2], v3_scale(ls.Li, c / ls.pdf * power_heuristic(ls.pdf, pb)));
            }
        }
        vec2 ub = {vbi_rng_next(&rng), vbi_rng_next(&rng)};
        vec3 wl = sample_cosine_hemisphere(ub);
        vec3 w = frame_to_world(&f, wl);
        float pb = pdf_cosine_hemisphere(wl);
        if (pb > 0.0f) {
            vec3 Le = sky_Le(l, w);
            e[1] = v3_scale(Le, wl.z / pb);
            float pl = vbi_light_pdf_li(l, v3s(0.0f), v3s(0.0f), v3s(0.0f), w);
            e[2] = v3_add(e[2], v3_scale(Le, wl.z / pb * power_heuristic(pb, pl)));
        }
        for (int m = 0; m < 3; ++m)
            for (int k = 0; k < 3; ++k) {
                double v = v3_comp(e[m], k);
                sum[m][k] += v;
                sq[m][k] += v * v;
            }
    }
    static const char *const names[3] = {"light sampling", "cosine sampling", "MIS"};
    for (int m = 0; m < 3; ++m)
        for (int k = 0; k < 3; ++k) {
            double mean = sum[m][k] / N, var = sq[m][k] / N - mean * mean;
            double se = sqrt(fmax(var, 0.0) / N), want = sky_irradiance(k);
            print_message("# %s channel %d: E %.5f expected %.5f (%.3f%%, %.1f standard errors)\n", names[m], k, mean,
                          want, 100.0 * (mean / want - 1.0), fabs(mean - want) / se);
            assert_true(fabs(mean - want) < 4.0 * se + 1e-4 * want);
            assert_true(fabs(mean / want - 1.0) < 0.01);
        }

    /* light tracing: E[Le cos / (pdf_pos pdf_dir)] over the rays of sample_le is the sky's power
     * through the scene's cross-section, pi R^2 * 4 pi * mean radiance */
    double flux[3] = {0, 0, 0};
    const int M = 200000;
    for (int i = 0; i < M; ++i) {
        vbi_light_le_sample le;
        vec2 up = {vbi_rng_next(&rng), vbi_rng_next(&rng)}, ud = {vbi_rng_next(&rng), vbi_rng_next(&rng)};
        if (!vbi_light_sample_le(l, up, ud, &le))
            continue;
        for (int k = 0; k < 3; ++k)
            flux[k] += v3_comp(le.Le, k) * le.cos_at_light / (le.pdf_pos * le.pdf_dir) / M;
    }
    vec3 power = vbi_light_power(l);
    for (int k = 0; k < 3; ++k) {
        print_message("# sample_le flux channel %d: %.4f, power %.4f\n", k, flux[k], v3_comp(power, k));
        assert_true(fabs(flux[k] / v3_comp(power, k) - 1.0) < 0.01);
    }
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* ---- shadowed light: environment sampling alone against BSDF sampling alone ----------------------- */

/* Irradiance at points of the plane around a sphere resting on it, each estimated twice with
 * shadow rays: by the environment's samples alone and by cosine samples alone. Both are unbiased
 * only if sample_li draws by the pdf it reports over the visible part of the sky; they must agree
 * point by point within their noise. */
static void test_shadowed_consistency(void **state)
{
    (void)state;
    vbnl_context *ctx = ts_context(1);
    vbnl_scene *s = plane_scene(ctx, 0.5f);
    uint32_t m = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 0.0f);
    const float c[3] = {0.0f, 1.0f, 0.0f};
    assert_int_equal(vbnl_scene_add_sphere(s, c, 1.0f, m, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    const float dim[3] = {0.05f, 0.05f, 0.1f}, bright[3] = {8.0f, 6.0f, 3.0f};
    uint32_t id = gradient_pigment(s, dim, bright, 0.7f);
    set_sky(s, &id, 1);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const vbi_light *l = env_light(s);
    const vec3 n = v3(0, 1, 0);
    const frame f = frame_from_normal(n);
    const int N = 6000;
    vbi_rng rng = vbi_rng_make(9, 4);
    double worst = 0.0, sum_a = 0.0, sum_b = 0.0;
    for (int px = 0; px < 6; ++px)
        for (int pz = 0; pz < 6; ++pz) {
            vec3 p = v3(-1.5f + 0.6f * px, 1e-3f, -1.5f + 0.6f * pz);
            double a = 0, a2 = 0, b = 0, b2 = 0;
            vbi_hit hit;
            for (int i = 0; i < N; ++i) {
                vbi_light_li_sample ls;
                double ea = 0.0, eb = 0.0;
                vec2 u = {vbi_rng_next(&rng), vbi_rng_next(&rng)};
                if (vbi_light_sample_li(l, p, u, &ls) && ls.wi.y > 0.0f && !vbi_scene_intersect(s, p, ls.wi, INFINITY, &hit))
                    ea = v3_avg(ls.Li) * ls.wi.y / ls.pdf;
                vec3 wl = sample_cosine_hemisphere((vec2){vbi_rng_next(&rng), vbi_rng_next(&rng)});
                vec3 w = frame_to_world(&f, wl);
                if (wl.z > 0.0f && !vbi_scene_intersect(s, p, w, INFINITY, &hit))
                    eb = v3_avg(sky_Le(l, w)) * PI_D;
                a += ea;
                a2 += ea * ea;
                b += eb;
                b2 += eb * eb;
            }
            a /= N;
            b /= N;
            double va = (a2 / N - a * a) / N, vb = (b2 / N - b * b) / N;
            double z = fabs(a - b) / sqrt(va + vb + 1e-12);
            if (z > worst)
                worst = z;
            sum_a += a;
            sum_b += b;
        }
    print_message("# shadowed irradiance, 36 points: env sampling mean %.4f, cosine sampling mean %.4f, worst point "
                  "%.2f standard errors apart\n", sum_a / 36, sum_b / 36, worst);
    assert_true(worst < 4.5);
    assert_true(fabs(sum_a / sum_b - 1.0) < 0.01);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* ---- furnace through the renderer -------------------------------------------------------------- */

static void test_furnace_plane(void **state)
{
    (void)state;
    vbnl_context *ctx = ts_context(0);
    const float rho = 0.75f;
    vbnl_scene *s = plane_scene(ctx, rho);
    uint32_t id = gradient_pigment(s, SKY_A, SKY_B, 0.0f);
    set_sky(s, &id, 1);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const uint32_t w = 8, h = 8;
    float *px = ts_render(ctx, s, "path", w, h, 1024, 3, NULL);
    for (int k = 0; k < 3; ++k) {
        double want = rho * sky_irradiance(k) / PI_D, sum = 0.0;
        for (uint32_t i = 0; i < w * h; ++i)
            sum += px[4 * i + k];
        double mean = sum / (w * h);
        print_message("# furnace path channel %d: %.5f expected %.5f (%.3f%%)\n", k, mean, want,
                      100.0 * (mean / want - 1.0));
        assert_true(fabs(mean / want - 1.0) < 0.005);
    }
    free(px);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layers),
        cmocka_unit_test(test_sampling_chi2),
        cmocka_unit_test(test_irradiance_estimators),
        cmocka_unit_test(test_shadowed_consistency),
        cmocka_unit_test(test_furnace_plane),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
