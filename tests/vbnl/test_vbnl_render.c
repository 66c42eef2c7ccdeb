/* The `vbnl` integrator against analytic radiance and the path-traced reference. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "rng.h"
#include "sampling.h"
#include "scenes.h"
#include "sizing.h"
#include "vbnl/mesh_import.h"
#include "vbnl/vbnl.h"

typedef struct render_result {
    float *rgba;
    double prepare_s, render_s;
} render_result;

static render_result render_sampled(vbnl_context *ctx, const vbnl_scene *s, const char *integrator, uint32_t w,
                                    uint32_t h, uint32_t spp, uint64_t seed, const char *const *settings,
                                    vbnl_sampler_kind sampler)
{
    vbnl_params *p;
    vbnl_params_create(&p, NULL);
    for (const char *const *kv = settings; kv && *kv; ++kv)
        assert_int_equal(vbnl_params_set_text(p, *kv, NULL, NULL), VBNL_OK);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = w;
    rs.height = h;
    rs.spp = spp;
    rs.seed = seed;
    rs.sampler = sampler;
    rs.integrator = integrator;
    rs.params = p;
    vbnl_renderer *r;
    vbnl_error err = {0};
    if (vbnl_renderer_create(ctx, s, &rs, &r, &err) != VBNL_OK || vbnl_renderer_render(r, NULL, NULL, &err) != VBNL_OK)
        fail_msg("%s: %s", integrator, err.message);
    render_result out;
    out.rgba = malloc(sizeof(float) * 4 * w * h);
    assert_int_equal(vbnl_film_read(vbnl_renderer_film(r), "", out.rgba, (size_t)4 * w * h, NULL), VBNL_OK);
    vbnl_render_stats st;
    vbnl_renderer_get_stats(r, &st, NULL);
    out.prepare_s = st.prepare_seconds;
    out.render_s = st.render_seconds;
    vbnl_renderer_destroy(r);
    vbnl_params_destroy(p);
    return out;
}

static render_result render(vbnl_context *ctx, const vbnl_scene *s, const char *integrator, uint32_t w,
                            uint32_t h, uint32_t spp, uint64_t seed, const char *const *settings)
{
    return render_sampled(ctx, s, integrator, w, h, spp, seed, settings, VBNL_SAMPLER_SOBOL);
}

/* rMAE as the paper defines it: mean |I - I_ref| / (I_ref + eps), eps = 0.01 mean(I_ref), over
 * pixels and channels. */
static double rmae(const float *img, const float *ref, uint32_t n)
{
    double mean = 0.0;
    for (uint32_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            mean += ref[4 * i + c];
    mean /= 3.0 * n;
    double eps = 0.01 * mean, sum = 0.0;
    for (uint32_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            sum += fabs(img[4 * i + c] - ref[4 * i + c]) / (ref[4 * i + c] + eps);
    return sum / (3.0 * n);
}

static double mean_of(const float *img, uint32_t n)
{
    double m = 0.0;
    for (uint32_t i = 0; i < n; ++i)
        m += img[4 * i] + img[4 * i + 1] + img[4 * i + 2];
    return m / (3.0 * n);
}

/* Box-filters 4x4 pixel blocks, so that the comparison measures bias rather than per-pixel noise. */
static float *downsample(const float *img, uint32_t w, uint32_t h, uint32_t k)
{
    uint32_t W = w / k, H = h / k;
    float *o = calloc((size_t)4 * W * H, sizeof(float));
    for (uint32_t y = 0; y < H * k; ++y)
        for (uint32_t x = 0; x < W * k; ++x)
            for (int c = 0; c < 4; ++c)
                o[4 * ((y / k) * W + x / k) + c] += img[4 * (y * w + x) + c] / (float)(k * k);
    return o;
}

/* Furnace: inside a closed emitting Lambertian sphere every pixel sees Le / (1 - rho). The
 * virtual lights carry everything reflected; emission stays with the real light. */
static void test_furnace(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_context_create(NULL, &ctx, NULL);
    vbnl_scene *s;
    vbnl_scene_create(ctx, &s, NULL);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 0.5f;
    md.emission[0] = md.emission[1] = md.emission[2] = 1.0f;
    md.two_sided = 1;
    uint32_t m;
    vbnl_scene_add_material(s, &md, &m, NULL);
    float c[3] = {0, 0, 0};
    vbnl_scene_add_sphere(s, c, 2.0f, m, VBNL_GROUP_WORLD, NULL, NULL);
    float pos[3] = {0.3f, -0.2f, 0.5f}, target[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 90.0f, 1.0f, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const char *const settings[] = {"virtual_lights=3000", "photon_paths=400000", NULL};
    render_result r = render(ctx, s, "vbnl", 32, 32, 64, 3, settings);
    double mean = mean_of(r.rgba, 32 * 32);
    print_message("# vbnl furnace: mean %.5f, expected 2 (%.2f%%)\n", mean, 100.0 * (mean / 2.0 - 1.0));
    assert_true(fabs(mean / 2.0 - 1.0) < 0.02);
    free(r.rgba);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static vbnl_scene *cornell(vbnl_context *ctx)
{
    const char *src = getenv("VBNL_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof(path), "%s/examples/cornell-box.obj", src ? src : ".");
    vbnl_scene *s;
    vbnl_scene_create(ctx, &s, NULL);
    vbnl_error err = {0};
    if (vbnl_mesh_import(s, path, NULL, NULL, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    float pos[3] = {0, 1, 3.6f}, target[3] = {0, 1, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 39.0f, 1.0f, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    return s;
}

/* The diffuse Cornell box against a converged path-traced reference: within 3% rMAE (on 4x4
 * blocks, so the figure measures bias, not the references' pixel noise), and the error falls
 * as lights and photons grow. With n_min very high the estimator is a path tracer. */
static void test_cornell_against_path(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_context_create(NULL, &ctx, NULL);
    vbnl_scene *s = cornell(ctx);
    const uint32_t W = 48, H = 48, K = 4, n = (W / K) * (H / K);
    render_result ref = render(ctx, s, "path", W, H, 4096, 1, NULL);
    float *ref_ds = downsample(ref.rgba, W, H, K);
    const char *const small[] = {"virtual_lights=2000", "photon_paths=200000", NULL};
    const char *const large[] = {"virtual_lights=20000", "photon_paths=2000000", NULL};
    const char *const as_path[] = {"virtual_lights=2000", "photon_paths=100000", "n_min=1e8", "n_max=2e8", NULL};
    render_result a = render(ctx, s, "vbnl", W, H, 1024, 2, small);
    render_result b = render(ctx, s, "vbnl", W, H, 1024, 2, large);
    render_result c = render(ctx, s, "vbnl", W, H, 1024, 2, as_path);
    float *a_ds = downsample(a.rgba, W, H, K), *b_ds = downsample(b.rgba, W, H, K), *c_ds = downsample(c.rgba, W, H, K);
    double ea = rmae(a_ds, ref_ds, n), eb = rmae(b_ds, ref_ds, n), ec = rmae(c_ds, ref_ds, n);
    print_message("# cornell rMAE vs path (4x4 blocks): 2K lights/200K photons %.4f, 20K/2M %.4f, "
                  "n_min=1e8 (path tracing) %.4f; means ref %.4f vbnl %.4f\n",
                  ea, eb, ec, mean_of(ref.rgba, W * H), mean_of(b.rgba, W * H));
    assert_true(eb < 0.03);
    assert_true(eb < ea);
    assert_true(ec < 0.03); /* statistically the path tracer */
    /* The sobol sampler against independent numbers at equal samples, per pixel (measured: path
     * 0.1135 against 0.1444, vbnl 0.0705 against 0.1059): the stratified first bounce lowers the
     * error of both methods, vbnl's most (its estimate after the first bounce is smooth). Image
     * means within 3% (vbnl with 2K lights is ~1.5% dark: its bias, checked above). */
    double e_smp[2][2], m_smp[2][2];
    for (int k = 0; k < 2; ++k)
        for (int sm = 0; sm < 2; ++sm) {
            render_result r = render_sampled(ctx, s, k ? "vbnl" : "path", W, H, 32, 5, k ? small : NULL,
                                             sm ? VBNL_SAMPLER_RANDOM : VBNL_SAMPLER_SOBOL);
            e_smp[k][sm] = rmae(r.rgba, ref.rgba, W * H);
            m_smp[k][sm] = mean_of(r.rgba, W * H) / mean_of(ref.rgba, W * H);
            free(r.rgba);
        }
    print_message("# 32 spp, rMAE per pixel, sobol / random: path %.4f / %.4f, vbnl %.4f / %.4f; means / ref: "
                  "%.4f %.4f, %.4f %.4f\n", e_smp[0][0], e_smp[0][1], e_smp[1][0], e_smp[1][1], m_smp[0][0],
                  m_smp[0][1], m_smp[1][0], m_smp[1][1]);
    for (int k = 0; k < 2; ++k)
        for (int sm = 0; sm < 2; ++sm)
            assert_true(fabs(m_smp[k][sm] - 1.0) < 0.03);
    assert_true(e_smp[0][0] < 0.9 * e_smp[0][1]);
    assert_true(e_smp[1][0] < 0.8 * e_smp[1][1]);
    free(ref.rgba);
    free(ref_ds);
    free(a.rgba);
    free(b.rgba);
    free(c.rgba);
    free(a_ds);
    free(b_ds);
    free(c_ds);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* Eq. 5: the two strategies' power-heuristic weights of a sample pair add up to one. */
static void test_mis_weights(void **state)
{
    (void)state;
    vbi_rng rng = vbi_rng_make(5, 9);
    for (int i = 0; i < 100000; ++i) {
        float a = expf(20.0f * (vbi_rng_next(&rng) - 0.5f)), b = expf(20.0f * (vbi_rng_next(&rng) - 0.5f));
        assert_float_equal(power_heuristic(a, b) + power_heuristic(b, a), 1.0f, 1e-6f);
    }
    assert_float_equal(power_heuristic(1.0f, 0.0f), 1.0f, 0.0f);
    assert_float_equal(power_heuristic(0.0f, 1.0f), 0.0f, 0.0f);
}

/* Impossible parameters are refused before any work, with the reason. */
static void test_refused(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    d.threads = 1;
    vbnl_context_create(&d, &ctx, NULL);
    vbnl_scene *s = cornell(ctx);
    const char *bad[][3] = {{"virtual_lights=1000", "candidates=500", "candidates (M = 500) must be at least"},
                            {"photon_paths=0", "", "must lie in"},
                            {"profile_resolution=12", "", "8, 16 or 32"},
                            {"n_min=90", "", "n_max (80) must be greater"},
                            {"virtual_lights=40000000", "candidates=400000000", "needs about"}};
    for (int i = 0; i < 5; ++i) {
        vbnl_params *p;
        vbnl_params_create(&p, NULL);
        vbnl_params_set_text(p, bad[i][0], NULL, NULL);
        if (bad[i][1][0])
            vbnl_params_set_text(p, bad[i][1], NULL, NULL);
        vbnl_render_settings rs;
        vbnl_render_settings_init(&rs);
        rs.integrator = "vbnl";
        rs.params = p;
        vbnl_renderer *r = NULL;
        vbnl_error err = {0};
        vbnl_result res = vbnl_renderer_create(ctx, s, &rs, &r, &err);
        assert_int_not_equal(res, VBNL_OK);
        if (!strstr(err.message, bad[i][2]))
            fail_msg("'%s': %s", bad[i][0], err.message);
        vbnl_params_destroy(p);
    }
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* Same seed, same image with 1 and 2 threads (preparation included). */
static void test_determinism(void **state)
{
    (void)state;
    float *img[2];
    for (int t = 0; t < 2; ++t) {
        vbnl_context *ctx;
        vbnl_context_desc d;
        vbnl_context_desc_init(&d);
        d.threads = (unsigned)t + 1;
        vbnl_context_create(&d, &ctx, NULL);
        vbnl_scene *s = cornell(ctx);
        const char *const settings[] = {"virtual_lights=3000", "photon_paths=100000", NULL};
        render_result r = render(ctx, s, "vbnl", 40, 40, 4, 17, settings);
        img[t] = r.rgba;
        vbnl_scene_destroy(s);
        vbnl_context_destroy(ctx);
    }
    assert_memory_equal(img[0], img[1], sizeof(float) * 4 * 40 * 40);
    free(img[0]);
    free(img[1]);
}

/* The sizing rule (sizing.h) on made-up rates: the sized plan's estimate (with its margin) stays
 * within the preparation's bound, the light count follows the image and the budget, counts set
 * by the user are kept, and a plan of set counts that cannot fit says so. */
static void test_sizing_rule(void **state)
{
    (void)state;
    vbi_sizing_in in;
    memset(&in, 0, sizeof(in));
    in.budget = 10.0;
    in.prepare_limit = VBNL_BUDGET_PREPARE_SHARE * in.budget;
    in.pixels = 512.0 * 512.0;
    in.elapsed = 0.05;
    in.seconds_per_light = 20e-6;
    in.seconds_per_path = 2e-6;
    vbi_sizing_out out;
    vbi_size_to_budget(&in, &out);
    assert_true(out.fits);
    assert_true(fabs(out.lights - 20000.0) < 0.5);
    assert_true(fabs(out.paths - floor(VBI_SIZING_PHOTON_SHARE * 10.0 / (2e-6 * VBI_SIZING_MARGIN))) < 1.0);
    assert_true(out.estimate <= in.prepare_limit);
    /* a quarter of the pixels: a quarter of the lights (above the minimum) */
    in.pixels = 256.0 * 256.0;
    vbi_size_to_budget(&in, &out);
    assert_true(fabs(out.lights - 5000.0) < 0.5);
    /* slow placement: lights lowered so that they take at most half of what the bound leaves */
    in.pixels = 512.0 * 512.0;
    in.seconds_per_light = 1e-3;
    vbi_size_to_budget(&in, &out);
    assert_true(out.lights < 20000.0);
    assert_true(out.lights * in.seconds_per_light * VBI_SIZING_MARGIN <= 0.5 * (in.prepare_limit - in.elapsed) + 1e-9);
    assert_true(out.estimate <= in.prepare_limit);
    assert_true(strstr(out.lights_why, "lowered") != NULL);
    /* a long budget: more lights, photons capped */
    in.seconds_per_light = 20e-6;
    in.budget = 1000.0;
    in.prepare_limit = VBNL_BUDGET_PREPARE_SHARE * in.budget;
    vbi_size_to_budget(&in, &out);
    assert_true(fabs(out.lights - 130000.0) < 0.5);
    assert_true(out.paths <= VBI_SIZING_PATHS_MAX);
    /* set counts are kept; when they cannot fit, the plan says so */
    in.budget = 10.0;
    in.prepare_limit = VBNL_BUDGET_PREPARE_SHARE * in.budget;
    in.paths_set = 1;
    in.paths = 2e7; /* 40 s at 2 us per path */
    vbi_size_to_budget(&in, &out);
    assert_true(out.paths == 2e7);
    assert_false(out.fits);
    assert_true(out.estimate > 40.0);
    in.paths = 1e5;
    in.lights_set = 1;
    in.lights = 3000;
    vbi_size_to_budget(&in, &out);
    assert_true(out.fits && out.lights == 3000 && out.paths == 1e5);
    assert_true(strstr(out.lights_why, "explicitly") != NULL);
}

static vbnl_result render_budget(vbnl_context *ctx, const vbnl_scene *s, const char *integrator, double budget,
                                 uint32_t size, const char *const *settings, vbnl_render_stats *st, double *wall,
                                 vbnl_error *err)
{
    vbnl_params *p;
    vbnl_params_create(&p, NULL);
    for (const char *const *kv = settings; kv && *kv; ++kv)
        assert_int_equal(vbnl_params_set_text(p, *kv, NULL, NULL), VBNL_OK);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = rs.height = size;
    rs.spp = 0;
    rs.time_budget = budget;
    rs.integrator = integrator;
    rs.params = p;
    vbnl_renderer *r = NULL;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    vbnl_result res = vbnl_renderer_create(ctx, s, &rs, &r, err);
    if (res == VBNL_OK)
        res = vbnl_renderer_render(r, NULL, NULL, err);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    *wall = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    if (res == VBNL_OK) {
        vbnl_renderer_get_stats(r, st, NULL);
        st->stages = NULL; /* owned by the renderer */
        st->choices = NULL;
    }
    vbnl_renderer_destroy(r);
    vbnl_params_destroy(p);
    return res;
}

/* Under a time budget: `vbnl` sizes itself (its choices recorded), preparation stays within its
 * bound, the render ends at the budget (plus the tiles in flight: 0.3 s here, far more than a
 * 16x16 tile of 64x64 pixels takes); explicit counts that cannot fit are refused before the work
 * they size, with the estimate and the bound in the message. */
static void test_time_budget(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_context_create(NULL, &ctx, NULL);
    vbnl_scene *s = cornell(ctx);
    vbnl_render_stats st;
    vbnl_error err = {0};
    double wall;
    const double budget = 2.0;
    if (render_budget(ctx, s, "vbnl", budget, 64, NULL, &st, &wall, &err) != VBNL_OK)
        fail_msg("vbnl: %s", err.message);
    printf("# vbnl --time %g at 64x64: prepare %.3f s (bound %.3f s), render %.3f s, wall %.3f s, %u spp, %u choices\n",
           budget, st.prepare_seconds, st.prepare_limit, st.render_seconds, wall, st.spp, st.choice_count);
    assert_true(st.choice_count >= 2);
    assert_true(fabs(st.prepare_limit - VBNL_BUDGET_PREPARE_SHARE * budget) < 1e-9);
    /* the sizing aims at 80% of the bound from rates measured before the work; other work on the
     * machine slowing it afterwards stretches it (0.69 s of 0.5 s measured at a load average of
     * 30 on 2 cores): the slack of the CLI test (docs/time-budget.md) */
    assert_true(st.prepare_seconds <= 1.5 * st.prepare_limit);
    assert_true(st.spp >= 1);
    assert_true(st.prepare_seconds + st.render_seconds <= budget + 0.3);
    assert_true(wall <= budget + 0.3);

    /* 1e9 photon paths cannot fit 2 s: refused after the calibration, long before they would end */
    const char *const too_many[] = {"photon_paths=1e9", NULL};
    vbnl_result r = render_budget(ctx, s, "vbnl", budget, 64, too_many, &st, &wall, &err);
    assert_int_equal(r, VBNL_ERR_INVALID_ARGUMENT);
    if (!strstr(err.message, "photon_paths set explicitly") || !strstr(err.message, "more than its bound"))
        fail_msg("%s", err.message);
    assert_true(wall < budget);
    /* a count that fits is kept: 500 lights take milliseconds; a 4 s budget (bound 1 s) leaves the
     * calibration room on a loaded machine, where it alone has taken 0.4 s of a 2 s budget's 0.5 s */
    const char *const fits[] = {"virtual_lights=500", NULL};
    if (render_budget(ctx, s, "vbnl", 2.0 * budget, 64, fits, &st, &wall, &err) != VBNL_OK)
        fail_msg("vbnl: %s", err.message);
    assert_true(st.prepare_seconds <= st.prepare_limit);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mis_weights),
        cmocka_unit_test(test_refused),
        cmocka_unit_test(test_furnace),
        cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_sizing_rule),
        cmocka_unit_test(test_time_budget),
        cmocka_unit_test(test_cornell_against_path),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
