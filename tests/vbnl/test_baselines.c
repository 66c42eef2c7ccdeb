/* The many-light baselines `vpl` and `vsl` against the oracles of the baseline notes (§6): the
 * unclamped VPL estimator converges to the path-traced indirect light, clamping never brightens,
 * Georgiev-Slusallek with epsilon >= 1 is plain instant radiosity, VSLs keep the VPLs' energy. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vbnl/mesh_import.h"
#include "vbnl/vbnl.h"
#include "vpl_set.h"
#include "ts_render.h"

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

static double sum_of(const float *img, uint32_t n)
{
    double m = 0.0;
    for (uint32_t i = 0; i < n; ++i)
        m += img[4 * i] + img[4 * i + 1] + img[4 * i + 2];
    return m;
}

typedef struct fixture {
    vbnl_context *ctx;
    vbnl_scene *scene;
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof(*f));
    vbnl_context_create(NULL, &f->ctx, NULL);
    f->scene = cornell(f->ctx);
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    vbnl_scene_destroy(f->scene);
    vbnl_context_destroy(f->ctx);
    free(f);
    return 0;
}

#define W 16u
#define H 16u

/* Oracle 1: unclamped IR is unbiased. The mean of many independent renders (different seeds,
 * so different VPL sets) approaches the indirect light of `path`, in total and per 4x4 block. */
static void test_vpl_converges_to_path(void **state)
{
    fixture *f = *state;
    const char *const pt[] = {"indirect_only=on", NULL};
    float *ref = ts_render(f->ctx, f->scene, "path", W, H, 4096, 99, pt);
    const char *const vs[] = {"indirect_only=on", "light_paths=300", NULL};
    const int M = 32;
    double *acc = calloc((size_t)4 * W * H, sizeof(double));
    for (int m = 0; m < M; ++m) {
        float *img = ts_render(f->ctx, f->scene, "vpl", W, H, 4, 1000 + (uint64_t)m, vs);
        for (uint32_t i = 0; i < 4 * W * H; ++i)
            acc[i] += img[i] / M;
        free(img);
    }
    double sv = 0.0, sr = sum_of(ref, W * H);
    for (uint32_t i = 0; i < W * H; ++i)
        sv += acc[4 * i] + acc[4 * i + 1] + acc[4 * i + 2];
    double worst = 0.0;
    for (uint32_t by = 0; by < H / 4; ++by)
        for (uint32_t bx = 0; bx < W / 4; ++bx) {
            double a = 0.0, b = 0.0;
            for (uint32_t y = 4 * by; y < 4 * by + 4; ++y)
                for (uint32_t x = 4 * bx; x < 4 * bx + 4; ++x)
                    for (int c = 0; c < 3; ++c) {
                        a += acc[4 * (y * W + x) + c];
                        b += ref[4 * (y * W + x) + c];
                    }
            if (b > 0.0)
                worst = fmax(worst, fabs(a / b - 1.0));
        }
    print_message("# vpl (mean of %d renders) / path indirect: total %.4f, worst 4x4 block off by %.1f%%\n", M,
                  sv / sr, 100.0 * worst);
    assert_true(sr > 0.0);
    assert_true(fabs(sv / sr - 1.0) < 0.03);
    assert_true(worst < 0.25);
    free(acc);
    free(ref);
}

/* Oracle 2: clamping only removes energy. With the same VPL set (same seed) every pixel of the
 * clamped image is at most the unclamped one, and a tight bound removes some energy. */
static void test_clamp_never_brightens(void **state)
{
    fixture *f = *state;
    const char *const un[] = {"indirect_only=on", "virtual_lights=400", NULL};
    const char *const cl[] = {"indirect_only=on", "virtual_lights=400", "clamp=1", NULL};
    float *a = ts_render(f->ctx, f->scene, "vpl", W, H, 2, 5, un);
    float *b = ts_render(f->ctx, f->scene, "vpl", W, H, 2, 5, cl);
    for (uint32_t i = 0; i < W * H; ++i)
        for (int c = 0; c < 3; ++c)
            assert_true(b[4 * i + c] <= a[4 * i + c] * (1.0f + 1e-6f) + 1e-12f);
    double sa = sum_of(a, W * H), sb = sum_of(b, W * H);
    print_message("# clamp=1 keeps %.2f%% of the unclamped indirect energy\n", 100.0 * sb / sa);
    assert_true(sb < sa);
    free(a);
    free(b);
}

static void vpl_params_default(vbi_vpl_params *p)
{
    memset(p, 0, sizeof(*p));
    p->target = 500;
    p->seed = 11;
    p->camera_points = 100;
    p->frames = 2;
    p->epsilon = 0.05f;
    p->width = 64;
    p->height = 64;
}

/* Oracle 4: with epsilon >= 1 every candidate is accepted and the set is the plain IR set, bit
 * for bit (the acceptance draws come from their own stream). With epsilon = 0.05 some are
 * rejected, the accepted count still reaches the target, and more light paths are needed. */
static void test_acceptance_epsilon_one_is_plain_ir(void **state)
{
    fixture *f = *state;
    vbi_vpl_params p;
    vpl_params_default(&p);
    vbi_vpl_set plain, gs1, gs;
    vbnl_error err = {0};
    assert_int_equal(vbi_vpl_set_build(f->scene, &p, NULL, &plain, &err), VBNL_OK);
    p.acceptance = 1;
    p.epsilon = 1.0f;
    assert_int_equal(vbi_vpl_set_build(f->scene, &p, NULL, &gs1, &err), VBNL_OK);
    assert_int_equal(plain.count, gs1.count);
    assert_int_equal(plain.paths, gs1.paths);
    assert_memory_equal(plain.vpls, gs1.vpls, sizeof(vbi_vpl) * plain.count);
    assert_true(gs1.mean_acceptance == 1.0);
    p.epsilon = 0.05f;
    assert_int_equal(vbi_vpl_set_build(f->scene, &p, NULL, &gs, &err), VBNL_OK);
    print_message("# acceptance eps=0.05: %u VPLs from %llu candidates (%llu paths vs %llu), mean p %.3f\n",
                  gs.count, (unsigned long long)gs.candidates, (unsigned long long)gs.paths,
                  (unsigned long long)plain.paths, gs.mean_acceptance);
    assert_int_equal(gs.count, p.target);
    assert_true(gs.mean_acceptance < 1.0);
    assert_true(gs.paths > plain.paths);
    assert_true(gs.candidates > gs.count);
    assert_true(plain.count == p.target);
    vbi_vpl_set_free(&plain);
    vbi_vpl_set_free(&gs1);
    vbi_vpl_set_free(&gs);
}

/* Oracle 4, in expectation: the acceptance keeps the expected image of plain IR (the 1/p weight).
 * Same number of light paths for both; means over independent seeds agree in total. */
static void test_acceptance_unbiased(void **state)
{
    fixture *f = *state;
    const char *const plain[] = {"indirect_only=on", "light_paths=200", NULL};
    const char *const gs[] = {"indirect_only=on", "light_paths=200", "acceptance=on", "virtual_lights=150", NULL};
    const int M = 24;
    double sp = 0.0, sg = 0.0;
    for (int m = 0; m < M; ++m) {
        float *a = ts_render(f->ctx, f->scene, "vpl", W, H, 1, 500 + (uint64_t)m, plain);
        float *b = ts_render(f->ctx, f->scene, "vpl", W, H, 1, 500 + (uint64_t)m, gs);
        sp += sum_of(a, W * H);
        sg += sum_of(b, W * H);
        free(a);
        free(b);
    }
    print_message("# acceptance / plain IR indirect energy over %d seeds: %.4f\n", M, sg / sp);
    assert_true(sp > 0.0);
    assert_true(fabs(sg / sp - 1.0) < 0.05);
}

/* Interior of an emitting Lambertian sphere (notes §6): G = 1/(4R^2) everywhere, so unclamped
 * VPLs have no singularity, and the indirect radiance is rho^2 Le / (1 - rho) = 0.5 for
 * rho = 0.5, Le = 1 in every pixel. Checks the flux normalisation by the path count and the
 * Russian roulette of the light walks. */
static void test_vpl_furnace(void **state)
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
    const char *const st[] = {"indirect_only=on", "virtual_lights=20000", NULL};
    float *img = ts_render(ctx, s, "vpl", 16, 16, 4, 3, st);
    double mean = sum_of(img, 256) / (3.0 * 256);
    print_message("# vpl furnace indirect: mean %.5f, expected 0.5 (%.2f%%)\n", mean, 100.0 * (mean / 0.5 - 1.0));
    assert_true(fabs(mean / 0.5 - 1.0) < 0.02);
    free(img);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* Oracle 3: VSLs redistribute the VPLs' energy. Same seed, hence the same light set. As the
 * radius shrinks the VSL estimate becomes the VPL term: within 2% of unclamped `vpl` for
 * M = 0.1. Larger spheres lose the near-field transfer that the VPL's singular geometry term
 * carries (receivers inside a sphere get a bounded integral, surfaces cut the cone): the energy
 * kept decreases monotonically with M (measured on this box with 1500 lights: 0.997 at M = 0.1,
 * 0.93 at M = 2, 0.84 at the default M = 4). */
static void test_vsl_preserves_energy(void **state)
{
    fixture *f = *state;
    const char *const s[] = {"indirect_only=on", "virtual_lights=1500", NULL};
    float *a = ts_render(f->ctx, f->scene, "vpl", 32, 32, 8, 21, s);
    double sa = sum_of(a, 32 * 32), prev = 2.0;
    const char *ms[] = {"radius_scale=0.1", "radius_scale=1", "radius_scale=4"};
    for (int k = 0; k < 3; ++k) {
        const char *const s2[] = {"indirect_only=on", "virtual_lights=1500", ms[k], NULL};
        float *b = ts_render(f->ctx, f->scene, "vsl", 32, 32, 8, 21, s2);
        double ratio = sum_of(b, 32 * 32) / sa;
        print_message("# %s: vsl / vpl indirect energy %.4f\n", ms[k], ratio);
        if (k == 0)
            assert_true(fabs(ratio - 1.0) < 0.02);
        assert_true(ratio < prev && ratio > 0.7);
        prev = ratio;
        free(b);
    }
    free(a);
}

/* indirect_only on every integrator: the light it removes is the direct part, so the image
 * gets darker but not black. */
static void test_indirect_only_everywhere(void **state)
{
    fixture *f = *state;
    static const char *const off[4][3] = {
        {NULL}, {"virtual_lights=200", "photon_paths=20000", NULL}, {"virtual_lights=200", NULL},
        {"virtual_lights=200", NULL}};
    static const char *const on[4][4] = {{"indirect_only=on", NULL},
                                         {"indirect_only=on", "virtual_lights=200", "photon_paths=20000", NULL},
                                         {"indirect_only=on", "virtual_lights=200", NULL},
                                         {"indirect_only=on", "virtual_lights=200", NULL}};
    const char *const names[] = {"path", "vbnl", "vpl", "vsl"};
    for (int k = 0; k < 4; ++k) {
        float *a = ts_render(f->ctx, f->scene, names[k], 16, 16, 8, 3, off[k]);
        float *b = ts_render(f->ctx, f->scene, names[k], 16, 16, 8, 3, on[k]);
        double sa = sum_of(a, 256), sb = sum_of(b, 256);
        print_message("# %s: indirect / full = %.3f\n", names[k], sb / sa);
        assert_true(sb > 0.05 * sa && sb < 0.8 * sa);
        free(a);
        free(b);
    }
}

/* Bit-identical images for 1 and 2 threads. */
static void test_determinism(void **state)
{
    (void)state;
    vbnl_context *c1, *c2;
    vbnl_context_desc d1, d2;
    vbnl_context_desc_init(&d1);
    vbnl_context_desc_init(&d2);
    d1.threads = 1;
    d2.threads = 2;
    vbnl_context_create(&d1, &c1, NULL);
    vbnl_context_create(&d2, &c2, NULL);
    vbnl_scene *s1 = cornell(c1), *s2 = cornell(c2);
    const char *const names[] = {"vpl", "vsl"};
    for (int k = 0; k < 2; ++k) {
        const char *const st[] = {"virtual_lights=300", "acceptance=on", NULL};
        const char *const sv[] = {"virtual_lights=300", NULL};
        const char *const *ps = k == 0 ? st : sv;
        float *a = ts_render(c1, s1, names[k], 16, 16, 2, 4, ps);
        float *b = ts_render(c2, s2, names[k], 16, 16, 2, 4, ps);
        assert_memory_equal(a, b, sizeof(float) * 4 * 256);
        free(a);
        free(b);
    }
    vbnl_scene_destroy(s1);
    vbnl_scene_destroy(s2);
    vbnl_context_destroy(c1);
    vbnl_context_destroy(c2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vpl_converges_to_path),
        cmocka_unit_test(test_clamp_never_brightens),
        cmocka_unit_test(test_acceptance_epsilon_one_is_plain_ir),
        cmocka_unit_test(test_acceptance_unbiased),
        cmocka_unit_test(test_vpl_furnace),
        cmocka_unit_test(test_vsl_preserves_energy),
        cmocka_unit_test(test_indirect_only_everywhere),
        cmocka_unit_test(test_determinism),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
