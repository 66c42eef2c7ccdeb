/* Participating media and fog (core/src/medium.c, medium_path.c), rendered by `path` and `vbnl`:
 * - every phase function integrates to 1 over the sphere, and its sampler's mean cosine matches
 *   the function's;
 * - a sphere of absorbing medium behind ior-1 boundaries lets through exp(-sigma_a chord)
 *   (Beer-Lambert), grey (exact tracking) and chromatic (delta tracking with the majorant), and a
 *   shadow ray through it carries the same transmittance;
 * - furnace: a sphere of purely scattering medium (albedo 1) in a uniform environment of
 *   radiance 1 looks 1 everywhere, with isotropic, Henyey-Greenstein and mixed Rayleigh + Mie
 *   phase functions (and path's clamp: a bound no contribution reaches changes no pixel, a low one
 *   darkens);
 * - POV-Ray's scattering extinction: the passing and scattering weights of a medium whose
 *   scattering extincts partly or not at all;
 * - a medium that only emits gathers its emission along a ray with a bounded spread per ray;
 * - constant and ground fog reproduce POV-Ray's blend (reference "Fog") on camera rays;
 * - single scattering of a point light in a medium (equiangular sampling) against the integral
 *   along the ray, with a small spread between pixels; none with media_interaction off;
 * - no_shadow geometry and shadowless lights: a ground point under an occluder gets the point
 *   light's full direct light I albedo / (pi r^2);
 * - POV-Ray's brilliance as a BSDF: sampled weights equal eval / pdf, and the albedo seen from wo
 *   is the base colour times cos_o^(b - 1). */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf.h"
#include "medium.h"
#include "rng.h"
#include "scene_internal.h"
#include "shading.h"
#include "ts_render.h"
#include "vbnl/vbnl.h"

static float v3_get(vec3 v, int c) { return c == 0 ? v.x : c == 1 ? v.y : v.z; }

typedef struct fixture {
    vbnl_context *ctx;
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof(*f));
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    if (!f || vbnl_context_create(&d, &f->ctx, NULL) != VBNL_OK)
        return -1;
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    vbnl_context_destroy(f->ctx);
    free(f);
    return 0;
}

/* ---- phase functions -------------------------------------------------------------------------- */

static void test_phase_normalised(void **state)
{
    (void)state;
    const vbnl_phase_kind kinds[] = {VBNL_PHASE_ISOTROPIC, VBNL_PHASE_MIE_HAZY, VBNL_PHASE_MIE_MURKY,
                                     VBNL_PHASE_RAYLEIGH, VBNL_PHASE_HENYEY_GREENSTEIN};
    for (int k = 0; k < 5; ++k) {
        const float g = 0.6f;
        /* integral over the sphere = 2 pi int_{-1}^{1} p(mu) dmu (midpoint rule) */
        const int n = 200000;
        double integral = 0.0, mean_mu = 0.0;
        for (int i = 0; i < n; ++i) {
            double mu = -1.0 + (i + 0.5) * 2.0 / n;
            double p = vbi_phase_eval(kinds[k], g, (float)mu);
            integral += 2.0 * M_PI * p * 2.0 / n;
            mean_mu += 2.0 * M_PI * p * mu * 2.0 / n;
        }
        assert_true(fabs(integral - 1.0) < 1e-3);
        /* the sampler: its mean cosine, and pdf = eval */
        const vec3 in = v3_norm(v3(0.3f, -0.5f, 0.8f));
        vbi_rng rng = vbi_rng_for(7, (uint64_t)k, 0);
        const int m = 400000;
        double smu = 0.0;
        for (int i = 0; i < m; ++i) {
            float pdf;
            vec3 out = vbi_phase_sample(kinds[k], g, in, vbi_rng_next2(&rng), &pdf);
            float mu = v3_dot(in, out);
            assert_true(fabsf(pdf - vbi_phase_eval(kinds[k], g, mu)) <= 1e-3f * pdf + 1e-6f);
            smu += mu;
        }
        smu /= m;
        if (fabs(smu - mean_mu) > 0.01)
            fail_msg("phase %d: sampled mean cosine %.4f, integral %.4f", (int)kinds[k], smu, mean_mu);
    }
}

/* ---- scenes ------------------------------------------------------------------------------------- */

/* A camera at (0, 0, 5) looking at the origin with a narrow field, on scene s. */
static void narrow_camera(vbnl_scene *s)
{
    float pos[3] = {0, 0, 5}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 1.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
}

/* A medium of one part. */
static uint32_t one_part_medium(vbnl_scene *s, const float sa[3], const float ss[3], vbnl_phase_kind phase, float g)
{
    vbnl_medium_part_desc part;
    memset(&part, 0, sizeof(part));
    memcpy(part.absorption, sa, sizeof(part.absorption));
    memcpy(part.scattering, ss, sizeof(part.scattering));
    part.phase = phase;
    part.g = g;
    vbnl_medium_desc md;
    vbnl_medium_desc_init(&md);
    md.parts = &part;
    md.part_count = 1;
    uint32_t id;
    vbnl_error err = {0};
    if (vbnl_scene_add_medium(s, &md, &id, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    return id;
}

/* A medium of the one part given. */
static uint32_t part_medium(vbnl_scene *s, const vbnl_medium_part_desc *part)
{
    vbnl_medium_desc md;
    vbnl_medium_desc_init(&md);
    md.parts = part;
    md.part_count = 1;
    uint32_t id;
    assert_int_equal(vbnl_scene_add_medium(s, &md, &id, NULL), VBNL_OK);
    return id;
}

/* A sphere of radius r at the origin whose surface lets light through unchanged (ior 1, white)
 * and whose inside is medium `medium`. */
static void medium_sphere(vbnl_scene *s, uint32_t medium, float r)
{
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.type = VBNL_MATERIAL_DIELECTRIC;
    md.ior = 1.0f;
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 1.0f;
    md.interior = medium + 1;
    uint32_t mat;
    assert_int_equal(vbnl_scene_add_material(s, &md, &mat, NULL), VBNL_OK);
    float c[3] = {0, 0, 0};
    assert_int_equal(vbnl_scene_add_sphere(s, c, r, mat, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
}

/* The image's mean of each channel. */
static void image_mean(const float *px, int n, double mean[3])
{
    mean[0] = mean[1] = mean[2] = 0.0;
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            mean[c] += px[4 * i + c] / n;
}

/* ---- Beer-Lambert ------------------------------------------------------------------------------- */

static void slab_check(vbnl_context *ctx, const float sa[3], const char *integrator, const char *const *settings)
{
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    const float env[3] = {1, 1, 1}, zero[3] = {0, 0, 0};
    assert_int_equal(vbnl_scene_set_environment(s, env, NULL), VBNL_OK);
    medium_sphere(s, one_part_medium(s, sa, zero, VBNL_PHASE_ISOTROPIC, 0.0f), 1.0f);
    narrow_camera(s);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    /* chords within 1 degree of the axis: 2 sqrt(1 - (5 sin 0.5deg)^2) differs from 2 by 0.1% */
    float *px = ts_render(ctx, s, integrator, 8, 8, 256, 3, settings);
    double mean[3];
    image_mean(px, 64, mean);
    for (int c = 0; c < 3; ++c) {
        double want = exp(-2.0 * sa[c]);
        /* binary estimators: 16384 samples, sigma <= 0.004 */
        if (fabs(mean[c] - want) > 0.02)
            fail_msg("%s channel %d: %.4f, Beer-Lambert %.4f", integrator, c, mean[c], want);
    }
    free(px);
    vbnl_scene_destroy(s);
}

static void test_beer_lambert_grey(void **state)
{
    fixture *f = *state;
    const float sa[3] = {0.35f, 0.35f, 0.35f};
    slab_check(f->ctx, sa, "path", NULL);
    const char *const vs[] = {"virtual_lights=200", "photon_paths=20000", NULL};
    slab_check(f->ctx, sa, "vbnl", vs);
}

static void test_beer_lambert_chromatic(void **state)
{
    fixture *f = *state;
    const float sa[3] = {0.1f, 0.35f, 0.8f};
    slab_check(f->ctx, sa, "path", NULL);
}

/* A shadow ray through the medium: the light's transmittance in closed form and by ratio
 * tracking. */
static void test_shadow_transmittance(void **state)
{
    fixture *f = *state;
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(f->ctx, &s, NULL), VBNL_OK);
    const float env[3] = {1, 1, 1}, zero[3] = {0, 0, 0}, sa[3] = {0.2f, 0.5f, 0.9f}, gr[3] = {0.4f, 0.4f, 0.4f};
    uint32_t chrom = one_part_medium(s, sa, zero, VBNL_PHASE_ISOTROPIC, 0.0f);
    uint32_t grey = one_part_medium(s, gr, zero, VBNL_PHASE_ISOTROPIC, 0.0f);
    (void)grey;
    assert_int_equal(vbnl_scene_set_environment(s, env, NULL), VBNL_OK);
    medium_sphere(s, chrom, 1.0f);
    narrow_camera(s);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbi_thread_stats stats;
    memset(&stats, 0, sizeof(stats));
    vbi_rng rng = vbi_rng_for(11, 0, 0);
    vbi_rand r = {NULL, &rng};
    /* along the x axis through the centre: chord 2 */
    const vec3 o = v3(-3.0f, 0.0f, 0.0f), d = v3(1.0f, 0.0f, 0.0f);
    vec3 T = vbi_shadow_transmittance(s, NULL, o, d, 6.0f, &r, &stats, NULL);
    for (int c = 0; c < 3; ++c)
        assert_true(fabsf(v3_get(T, c) - expf(-2.0f * sa[c])) < 1e-3f);
    /* ratio tracking directly on the medium with a density-free majorant: the mean is exact */
    double acc[3] = {0, 0, 0};
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
        vec3 t = vbi_medium_transmittance(s, chrom + 1, v3s(0.0f), d, 1.5f, &r);
        for (int c = 0; c < 3; ++c)
            acc[c] += v3_get(t, c) / n;
    }
    for (int c = 0; c < 3; ++c)
        assert_true(fabs(acc[c] - exp(-1.5 * sa[c])) < 2e-3);
    vbnl_scene_destroy(s);
}

/* A medium that only emits, in a scene much larger than it (a sphere of radius 1 beside one 50
 * units away): each ray through its diameter gathers 2 x emission, and the collisions are frequent
 * enough (majorant >= 10 x emission) that single rays stay near it rather than a few rays carrying
 * it all. */
static void test_emission_only(void **state)
{
    fixture *f = *state;
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(f->ctx, &s, NULL), VBNL_OK);
    vbnl_medium_part_desc part;
    memset(&part, 0, sizeof(part));
    part.emission[0] = part.emission[1] = part.emission[2] = 0.05f;
    part.phase = VBNL_PHASE_ISOTROPIC;
    const uint32_t id = part_medium(s, &part);
    medium_sphere(s, id, 1.0f);
    vbnl_material_desc grey;
    vbnl_material_desc_init(&grey);
    uint32_t mat;
    assert_int_equal(vbnl_scene_add_material(s, &grey, &mat, NULL), VBNL_OK);
    const float far[3] = {0, 0, -100};
    assert_int_equal(vbnl_scene_add_sphere(s, far, 1.0f, mat, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    const float env[3] = {1, 1, 1};
    assert_int_equal(vbnl_scene_set_environment(s, env, NULL), VBNL_OK);
    narrow_camera(s);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    assert_true(s->media[id].majorant >= 0.5f);
    vbi_rng rng = vbi_rng_for(3, 0, 0);
    vbi_rand r = {NULL, &rng};
    const int n = 4000;
    double mean = 0.0, sq = 0.0;
    for (int i = 0; i < n; ++i) {
        vec3 beta = v3s(1.0f), L = v3s(0.0f);
        vbi_medium_event ev;
        assert_int_equal(vbi_medium_track(s, id + 1, v3(-1, 0, 0), v3(1, 0, 0), 2.0f, &r, &beta, &L, &ev),
                         VBI_TRACK_PASSED);
        mean += L.x / n;
        sq += (double)L.x * L.x / n;
    }
    assert_true(fabs(mean - 0.1) < 3e-3);
    /* the collisions along 2 units are Poisson with mean 2 majorant, each adding emission /
     * majorant: relative deviation 1 / sqrt(2 majorant), 1 at majorant 0.5 (one collision per
     * scene radius, ~50 here, would give 5) */
    assert_true(sqrt(sq - mean * mean) / mean < 1.1);
    vbnl_scene_destroy(s);
}

/* POV-Ray's scattering extinction e (sigma_t = sigma_a + e sigma_s, in-scattering at sigma_s):
 * along a segment of length 2 in a medium of sigma_s only, a path passes with weight exp(-2 e
 * sigma_s) on average and scatters with the weight integral of sigma_s exp(-e sigma_s t) dt =
 * 2 (1 - exp(-2 e sigma_s)) / (2 e) (2 sigma_s when e = 0), channel by channel; grey (exact
 * step), chromatic (delta tracking) and e = 0 (sampled: no extinction at all). */
static void test_scattering_extinction(void **state)
{
    fixture *f = *state;
    const struct {
        float ss[3], e;
    } cases[] = {{{1, 1, 1}, 0.5f}, {{1, 0.5f, 0.2f}, 0.5f}, {{0.7f, 0.7f, 0.7f}, 0.0f}};
    for (int ci = 0; ci < 3; ++ci) {
        vbnl_scene *s;
        assert_int_equal(vbnl_scene_create(f->ctx, &s, NULL), VBNL_OK);
        vbnl_medium_part_desc part;
        memset(&part, 0, sizeof(part));
        memcpy(part.scattering, cases[ci].ss, sizeof(part.scattering));
        part.phase = VBNL_PHASE_ISOTROPIC;
        part.extinction_deficit = 1.0f - cases[ci].e;
        const uint32_t id = part_medium(s, &part);
        medium_sphere(s, id, 1.0f);
        const float env[3] = {1, 1, 1};
        assert_int_equal(vbnl_scene_set_environment(s, env, NULL), VBNL_OK);
        narrow_camera(s);
        assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
        vbi_rng rng = vbi_rng_for(9, (uint64_t)ci, 0);
        vbi_rand r = {NULL, &rng};
        const int n = 100000;
        double passed[3] = {0, 0, 0}, scattered[3] = {0, 0, 0};
        for (int i = 0; i < n; ++i) {
            vec3 beta = v3s(1.0f), L = v3s(0.0f);
            vbi_medium_event ev;
            int t = vbi_medium_track(s, id + 1, v3(-1, 0, 0), v3(1, 0, 0), 2.0f, &r, &beta, &L, &ev);
            for (int c = 0; c < 3; ++c) {
                passed[c] += t == VBI_TRACK_PASSED ? v3_get(beta, c) / n : 0.0;
                scattered[c] += t == VBI_TRACK_SCATTERED ? v3_get(beta, c) / n : 0.0;
            }
        }
        const vec3 T = vbi_medium_transmittance(s, id + 1, v3(-1, 0, 0), v3(1, 0, 0), 2.0f, &r);
        for (int c = 0; c < 3; ++c) {
            const double ss = cases[ci].ss[c], e = cases[ci].e;
            const double pass = exp(-2.0 * e * ss), scat = e > 0.0 ? (1.0 - pass) / e : 2.0 * ss;
            assert_true(fabs(passed[c] - pass) < 0.01);
            assert_true(fabs(scattered[c] - scat) < 0.02 * scat + 0.005);
            assert_true(fabs(v3_get(T, c) - pass) < 1e-5); /* constant: closed form */
        }
        vbnl_scene_destroy(s);
    }
    /* an extinction above 1 is fine (deficit < 0), a negative one is not */
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(f->ctx, &s, NULL), VBNL_OK);
    vbnl_medium_part_desc part;
    memset(&part, 0, sizeof(part));
    part.phase = VBNL_PHASE_ISOTROPIC;
    part.extinction_deficit = 1.5f;
    vbnl_medium_desc md;
    vbnl_medium_desc_init(&md);
    md.parts = &part;
    md.part_count = 1;
    vbnl_error err = {0};
    assert_int_equal(vbnl_scene_add_medium(s, &md, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_string_equal(err.message, "medium part 0: the extinction deficit must be finite and at most 1 (got 1.5)");
    vbnl_scene_destroy(s);
}

/* ---- furnace ------------------------------------------------------------------------------------ */

static void furnace_check(vbnl_context *ctx, const vbnl_medium_part_desc *parts, uint32_t n)
{
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    const float env[3] = {1, 1, 1};
    assert_int_equal(vbnl_scene_set_environment(s, env, NULL), VBNL_OK);
    vbnl_medium_desc md;
    vbnl_medium_desc_init(&md);
    md.parts = parts;
    md.part_count = n;
    uint32_t id;
    assert_int_equal(vbnl_scene_add_medium(s, &md, &id, NULL), VBNL_OK);
    medium_sphere(s, id, 1.0f);
    float pos[3] = {0, 0, 3}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 30.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    float *px = ts_render(ctx, s, "path", 12, 12, 512, 9, NULL);
    double mean[3];
    image_mean(px, 144, mean);
    if (n == 1 && parts[0].phase == VBNL_PHASE_ISOTROPIC) {
        /* path's clamp: a bound no contribution reaches changes nothing; a low one darkens */
        const char *const high[] = {"clamp=1000", NULL}, *const low[] = {"clamp=0.05", NULL};
        float *ph = ts_render(ctx, s, "path", 12, 12, 512, 9, high);
        assert_memory_equal(ph, px, sizeof(float) * 4 * 144);
        free(ph);
        float *pl = ts_render(ctx, s, "path", 12, 12, 64, 9, low);
        double ml[3];
        image_mean(pl, 144, ml);
        assert_true(ml[0] < 0.8);
        free(pl);
    }
    for (int c = 0; c < 3; ++c)
        if (fabs(mean[c] - 1.0) > 0.02)
            fail_msg("furnace (%u parts, phase %d) channel %d: %.4f, want 1", n, (int)parts[0].phase, c, mean[c]);
    free(px);
    vbnl_scene_destroy(s);
}

static void test_furnace(void **state)
{
    fixture *f = *state;
    vbnl_medium_part_desc p[2];
    memset(p, 0, sizeof(p));
    for (int c = 0; c < 3; ++c)
        p[0].scattering[c] = 1.5f;
    p[0].phase = VBNL_PHASE_ISOTROPIC;
    furnace_check(f->ctx, p, 1);
    p[0].phase = VBNL_PHASE_HENYEY_GREENSTEIN;
    p[0].g = 0.7f;
    furnace_check(f->ctx, p, 1);
    /* two parts, chromatic: Rayleigh and murky Mie (delta tracking with null collisions) */
    p[0].phase = VBNL_PHASE_RAYLEIGH;
    p[0].scattering[0] = 0.3f;
    p[0].scattering[2] = 1.2f;
    p[1].phase = VBNL_PHASE_MIE_MURKY;
    for (int c = 0; c < 3; ++c)
        p[1].scattering[c] = 0.8f;
    furnace_check(f->ctx, p, 2);
}

/* ---- fog ---------------------------------------------------------------------------------------- */

/* The centre pixel of a camera at distance 4 from an emitting sphere (radiance 1) in fog. */
static void fog_check(vbnl_context *ctx, const vbnl_fog_desc *fd, const double want[3])
{
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 0.0f;
    md.emission[0] = md.emission[1] = md.emission[2] = 1.0f;
    uint32_t mat;
    assert_int_equal(vbnl_scene_add_material(s, &md, &mat, NULL), VBNL_OK);
    float c[3] = {0, 0, 0};
    assert_int_equal(vbnl_scene_add_sphere(s, c, 1.0f, mat, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    vbnl_error err = {0};
    if (vbnl_scene_add_fog(s, fd, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    narrow_camera(s);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    float *px = ts_render(ctx, s, "path", 5, 5, 4, 1, NULL);
    for (int k = 0; k < 3; ++k)
        if (fabs(px[4 * 12 + k] - want[k]) > 2e-3)
            fail_msg("fog channel %d: %.4f, POV-Ray's formula %.4f", k, px[4 * 12 + k], want[k]);
    free(px);
    vbnl_scene_destroy(s);
}

static void test_fog(void **state)
{
    fixture *f = *state;
    const double col[3] = {0.2, 0.5, 0.8};
    vbnl_fog_desc fd;
    vbnl_fog_desc_init(&fd);
    fd.distance = 4.0f;
    for (int k = 0; k < 3; ++k)
        fd.color[k] = (float)col[k];
    /* constant fog over d = 4: a = exp(-d / distance); colour = a L + (1 - a) fog */
    double want[3], a = exp(-1.0);
    for (int k = 0; k < 3; ++k)
        want[k] = a * 1.0 + (1.0 - a) * col[k];
    fog_check(f->ctx, &fd, want);
    /* filter 0.5, transmit 0.3 with distance 2: a = max(exp(-2), 0.3); what passes is tinted by
     * (1 - filter + filter colour) */
    fd.distance = 2.0f;
    fd.color[3] = 0.5f;
    fd.color[4] = 0.3f;
    a = fmax(exp(-2.0), 0.3);
    for (int k = 0; k < 3; ++k)
        want[k] = a * (0.5 + 0.5 * col[k]) + (1.0 - a) * col[k];
    fog_check(f->ctx, &fd, want);
    /* ground fog along a horizontal ray at height h above the offset: density 1 / (1 + (h /
     * alt)^2); the ray at y = 0 with offset -1, alt 2 sees density 1 / (1 + 0.25) = 0.8 */
    vbnl_fog_desc_init(&fd);
    fd.kind = VBNL_FOG_GROUND;
    fd.distance = 4.0f;
    fd.offset = -1.0f;
    fd.alt = 2.0f;
    for (int k = 0; k < 3; ++k)
        fd.color[k] = (float)col[k];
    a = exp(-4.0 * 0.8 / 4.0);
    for (int k = 0; k < 3; ++k)
        want[k] = a + (1.0 - a) * col[k];
    fog_check(f->ctx, &fd, want);
}

/* ---- brilliance ------------------------------------------------------------------------------- */

static void test_brilliance(void **state)
{
    (void)state;
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.type = VBNL_MATERIAL_BRILLIANCE;
    md.brilliance = 4.0f;
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 0.9f;
    vbi_bsdf b;
    vbi_bsdf_from_material(&b, &md);
    const vec3 wo = v3_norm(v3(0.5f, 0.1f, 0.6f));
    vbi_rng rng = vbi_rng_for(3, 0, 0);
    const int n = 200000;
    double albedo = 0.0, est = 0.0;
    for (int i = 0; i < n; ++i) {
        vbi_bsdf_sample_rec rec;
        memset(&rec, 0, sizeof(rec));
        assert_true(vbi_bsdf_sample(&b, wo, vbi_rng_next2(&rng), &rec));
        vec3 f = vbi_bsdf_eval(&b, wo, rec.wi);
        assert_true(fabsf(f.x / rec.pdf - rec.weight.x) <= 1e-3f * rec.weight.x + 1e-6f);
        albedo += rec.weight.x / n;
        /* the same albedo by uniform hemisphere sampling of eval (eval includes cos_i) */
        vec2 u = vbi_rng_next2(&rng);
        float z = u.x, r = sqrtf(fmaxf(0.0f, 1.0f - z * z)), phi = 2.0f * (float)M_PI * u.y;
        est += vbi_bsdf_eval(&b, wo, v3(r * cosf(phi), r * sinf(phi), z)).x * 2.0 * M_PI / n;
    }
    const double want = 0.9 * pow(wo.z, 3.0);
    assert_true(fabs(albedo - want) < 1e-4);
    if (fabs(est - want) > 0.01 * want + 2e-3)
        fail_msg("brilliance albedo by uniform sampling %.4f, want %.4f", est, want);
}

/* ---- a point light in a medium ------------------------------------------------------------------ */

/* Single scattering (max_depth 1) of a point light of intensity 1 at (0, h, 0) in an atmosphere
 * (sigma_s 0.5, sigma_a 0.1, isotropic) inside a black sphere of radius 5, seen along the z axis
 * from (0, 0, -4) through a 0.05-degree camera: the radiance is
 *   int_0^9 exp(-sigma_t t) sigma_s / (4 pi) exp(-sigma_t r) / r^2 dt,  r^2 = h^2 + (t - 4)^2,
 * and the path's one segment passes within h of the light, where 1 / r^2 peaks. Equiangular
 * sampling draws t with a pdf proportional to 1 / r^2, so every sample is near the mean: the
 * spread of 8x8 pixels (the same ray, each 16 samples) is 1% of it; distances drawn by the
 * medium's density with next-event estimation at the vertex spread 38% of it. */
static vbnl_scene *point_light_scene(vbnl_context *ctx, float h, float ss, float sa, int media_interaction)
{
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    const float a[3] = {sa, sa, sa}, sc3[3] = {ss, ss, ss};
    const uint32_t m = one_part_medium(s, a, sc3, VBNL_PHASE_ISOTROPIC, 0.0f);
    assert_int_equal(vbnl_scene_set_atmosphere(s, m + 1, NULL), VBNL_OK);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 0.0f;
    uint32_t black, light;
    assert_int_equal(vbnl_scene_add_material(s, &md, &black, NULL), VBNL_OK);
    const float c[3] = {0, 0, 0}, lp[3] = {0, h, 0}, I[3] = {1, 1, 1};
    assert_int_equal(vbnl_scene_add_sphere(s, c, 5.0f, black, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_add_point_light(s, lp, I, &light, NULL), VBNL_OK);
    if (!media_interaction)
        assert_int_equal(vbnl_scene_set_light_media_interaction(s, light, 0, NULL), VBNL_OK);
    float pos[3] = {0, 0, -4}, target[3] = {0, 0, 1}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 0.05f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    return s;
}

static void test_point_light_in_medium(void **state)
{
    fixture *f = *state;
    const float h = 0.3f, ss = 0.5f, sa = 0.1f, st = ss + sa;
    vbnl_scene *s = point_light_scene(f->ctx, h, ss, sa, 1);
    double want = 0.0;
    const int n = 400000;
    for (int i = 0; i < n; ++i) { /* midpoint rule */
        const double t = (i + 0.5) * 9.0 / n, r2 = (double)h * h + (t - 4.0) * (t - 4.0);
        want += exp(-st * t) * ss / (4.0 * M_PI) * exp(-st * sqrt(r2)) / r2 * (9.0 / n);
    }
    const char *const single[] = {"max_depth=1", NULL};
    float *px = ts_render(f->ctx, s, "path", 8, 8, 16, 5, single);
    double mean[3], var = 0.0;
    image_mean(px, 64, mean);
    for (int i = 0; i < 64; ++i)
        var += (px[4 * i] - mean[0]) * (px[4 * i] - mean[0]) / 63.0;
    const double spread = sqrt(var) / mean[0];
    if (fabs(mean[0] / want - 1.0) > 0.02 || spread > 0.1)
        fail_msg("point light in a medium: %.5f (spread %.3f of it), the integral %.5f", mean[0], spread, want);
    free(px);
    vbnl_scene_destroy(s);
    /* media_interaction off: the medium scatters none of its light, at any depth */
    s = point_light_scene(f->ctx, h, ss, sa, 0);
    px = ts_render(f->ctx, s, "path", 4, 4, 16, 5, NULL);
    image_mean(px, 16, mean);
    assert_true(mean[0] == 0.0);
    free(px);
    vbnl_scene_destroy(s);
}

/* ---- no_shadow, shadowless ---------------------------------------------------------------------- */

/* The centre pixel's mean: ground (a huge sphere, albedo 0.5) at the origin, an occluder between it
 * and a point light of intensity 9 at height 3; flags on the occluder, shadowless on the light, and
 * with `reflecting` a clear occluder that reflects 0.3 (a dielectric of ior 1 with a curve). */
static double shadow_pixel(vbnl_context *ctx, uint32_t occluder_flags, int shadowless, int reflecting)
{
    vbnl_scene *s;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 0.5f;
    uint32_t mat, occ;
    assert_int_equal(vbnl_scene_add_material(s, &md, &mat, NULL), VBNL_OK);
    float gc[3] = {0, -1000, 0}, oc[3] = {0, 1, 0}, lp[3] = {0, 3, 0}, I[3] = {9, 9, 9};
    assert_int_equal(vbnl_scene_add_sphere(s, gc, 1000.0f, mat, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    uint32_t occ_mat = mat;
    if (reflecting) { /* a clear dielectric of ior 1 reflecting 0.3 at every angle */
        vbnl_material_desc gd;
        vbnl_material_desc_init(&gd);
        gd.type = VBNL_MATERIAL_DIELECTRIC;
        gd.ior = 1.0f;
        gd.base_color[0] = gd.base_color[1] = gd.base_color[2] = 1.0f;
        gd.coat_curve = VBNL_COAT_SCHLICK;
        for (int k = 0; k < 3; ++k)
            gd.coat_min[k] = gd.coat_max[k] = 0.3f;
        assert_int_equal(vbnl_scene_add_material(s, &gd, &occ_mat, NULL), VBNL_OK);
    }
    assert_int_equal(vbnl_scene_add_sphere(s, oc, 0.5f, occ_mat, VBNL_GROUP_WORLD, &occ, NULL), VBNL_OK);
    if (occluder_flags)
        assert_int_equal(vbnl_scene_set_visibility(s, occ, occluder_flags, NULL), VBNL_OK);
    uint32_t light;
    assert_int_equal(vbnl_scene_add_point_light(s, lp, I, &light, NULL), VBNL_OK);
    if (shadowless)
        assert_int_equal(vbnl_scene_set_light_shadowless(s, light, 1, NULL), VBNL_OK);
    float pos[3] = {0, 0.3f, 4}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 1.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    float *px = ts_render(ctx, s, "path", 5, 5, 64, 2, NULL);
    double v = px[4 * 12];
    free(px);
    vbnl_scene_destroy(s);
    return v;
}

static void test_shadow_controls(void **state)
{
    fixture *f = *state;
    const double direct = 0.5 / M_PI * 9.0 / 9.0; /* albedo / pi * I / r^2, normal incidence */
    double shadowed = shadow_pixel(f->ctx, 0, 0, 0);
    double no_shadow = shadow_pixel(f->ctx, VBNL_VISIBLE_NO_SHADOW, 0, 0);
    double shadowless = shadow_pixel(f->ctx, 0, 1, 0);
    /* a point light seen through a clear sphere reflecting 0.3: (1 - 0.3)^2 of it, by next-event
     * estimation alone (no path reaches a point light), plus the little indirect light */
    double through = shadow_pixel(f->ctx, 0, 0, 1);
    if (!(through > 0.97 * 0.49 * direct && through < 1.1 * 0.49 * direct))
        fail_msg("through a reflecting clear sphere: %.4f, want 0.49 x %.4f", through, direct);
    if (!(shadowed < 0.2 * direct))
        fail_msg("the occluder's shadow: %.4f, direct light %.4f", shadowed, direct);
    /* the full direct light, plus the little indirect light (the lit ground bounced back by the
     * occluder's underside: a few percent) */
    if (!(no_shadow > 0.97 * direct && no_shadow < 1.1 * direct))
        fail_msg("no_shadow occluder: %.4f, direct light %.4f (shadowed %.4f)", no_shadow, direct, shadowed);
    if (!(shadowless > 0.97 * direct && shadowless < 1.1 * direct))
        fail_msg("shadowless light: %.4f, direct light %.4f (shadowed %.4f)", shadowless, direct, shadowed);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_phase_normalised),
        cmocka_unit_test_setup_teardown(test_beer_lambert_grey, setup, teardown),
        cmocka_unit_test_setup_teardown(test_beer_lambert_chromatic, setup, teardown),
        cmocka_unit_test_setup_teardown(test_shadow_transmittance, setup, teardown),
        cmocka_unit_test_setup_teardown(test_emission_only, setup, teardown),
        cmocka_unit_test_setup_teardown(test_scattering_extinction, setup, teardown),
        cmocka_unit_test_setup_teardown(test_furnace, setup, teardown),
        cmocka_unit_test_setup_teardown(test_fog, setup, teardown),
        cmocka_unit_test(test_brilliance),
        cmocka_unit_test_setup_teardown(test_shadow_controls, setup, teardown),
        cmocka_unit_test_setup_teardown(test_point_light_in_medium, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
