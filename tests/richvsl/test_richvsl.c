/* The `richvsl` integrator: emission tables, placement, relaxation, energy and determinism. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "richvsl.h"
#include "rng.h"
#include "sampling.h"
#include "vbnl/mesh_import.h"
#include "vbnl/vbnl.h"
#include "ts_render.h"

/* ---- emission tables ------------------------------------------------------------------------ */

/* A Lambertian table integrates, with the true texel solid angles, to rho times the gathered
 * flux: sum_t I(w_t) cos(theta_t) Omega_t = rho Phi_g. The only error is the midpoint rule of
 * cos(theta) over each texel, which the sum over the bilinear projected solid angles C_t (exact
 * for a bilinear table) does not have. */
static void test_lambert_table_energy(void **state)
{
    (void)state;
    vbi_hemioct *map = NULL, *inc = NULL;
    assert_int_equal(vbi_hemioct_create(32, &map), VBNL_OK);
    assert_int_equal(vbi_hemioct_create(RV_INCIDENT_RES, &inc), VBNL_OK);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.type = VBNL_MATERIAL_LAMBERT;
    md.base_color[0] = 0.7f;
    md.base_color[1] = 0.5f;
    md.base_color[2] = 0.3f;
    vbi_bsdf bsdf;
    vbi_bsdf_from_material(&bsdf, &md);
    const vec3 n = v3_norm(v3(0.3f, -0.5f, 0.8f));
    frame f = frame_from_normal(n);
    vbi_rng rng = vbi_rng_make(7, 3);
    enum { NG = 300 };
    rv_gathered g[NG];
    vec3 total = v3s(0.0f);
    for (int j = 0; j < NG; ++j) {
        vec3 wl = sample_cosine_hemisphere(vbi_rng_next2(&rng));
        wl.z = fmaxf(wl.z, 0.01f);
        g[j].wi = frame_to_world(&f, v3_norm(wl));
        g[j].flux = v3(vbi_rng_next(&rng), vbi_rng_next(&rng), vbi_rng_next(&rng));
        total = v3_add(total, g[j].flux);
    }
    float *rgb = malloc(sizeof(float) * 3 * 32 * 32);
    rv_emission_table(map, inc, &bsdf, n, g, NG, rgb);
    double omega_sum[3] = {0, 0, 0}, proj_sum[3] = {0, 0, 0};
    const vec3 *dirs = vbi_hemioct_texel_dirs(map);
    for (uint32_t t = 0; t < 32 * 32; ++t)
        for (int c = 0; c < 3; ++c) {
            omega_sum[c] += rgb[3 * t + c] * dirs[t].z * vbi_hemioct_texel_solid_angle(map, t);
            proj_sum[c] += rgb[3 * t + c] * vbi_hemioct_texel_bilinear_projected(map, t);
        }
    const float rho[3] = {0.7f, 0.5f, 0.3f}, phi[3] = {total.x, total.y, total.z};
    vec3 li = rv_lambert_intensity(&bsdf, n, g, NG);
    const float lic[3] = {li.x, li.y, li.z};
    for (int c = 0; c < 3; ++c) {
        double want = rho[c] * phi[c];
        print_message("# channel %d: sum I cos Omega = %.6f, sum I C = %.6f, rho Phi_g = %.6f\n", c, omega_sum[c],
                      proj_sum[c], want);
        assert_true(fabs(omega_sum[c] / want - 1.0) < 2e-3);
        assert_true(fabs(proj_sum[c] / want - 1.0) < 1e-4);
        /* the flux-only Lambertian light equals the table */
        assert_true(fabs(lic[c] * VBI_PI / want - 1.0) < 1e-4);
    }
    free(rgb);
    vbi_hemioct_destroy(map);
    vbi_hemioct_destroy(inc);
}

/* A glossy table never emits more than the flux it gathered (energy conservation of the BSDF),
 * and puts its peak near the mirror direction of a single incident direction. */
static void test_glossy_table(void **state)
{
    (void)state;
    vbi_hemioct *map = NULL, *inc = NULL;
    assert_int_equal(vbi_hemioct_create(32, &map), VBNL_OK);
    assert_int_equal(vbi_hemioct_create(RV_INCIDENT_RES, &inc), VBNL_OK);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.type = VBNL_MATERIAL_CONDUCTOR;
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 0.9f;
    md.alpha = 0.3f;
    vbi_bsdf bsdf;
    vbi_bsdf_from_material(&bsdf, &md);
    const vec3 n = v3(0.0f, 0.0f, 1.0f);
    /* one incident direction: a bin centre of the incident map, so binning does not smear it */
    const vec3 wi = vbi_hemioct_texel_dirs(inc)[3 * RV_INCIDENT_RES + 1];
    rv_gathered g = {wi, v3s(1.0f)};
    float *rgb = malloc(sizeof(float) * 3 * 32 * 32);
    rv_emission_table(map, inc, &bsdf, n, &g, 1, rgb);
    double power = 0.0;
    uint32_t best = 0;
    for (uint32_t t = 0; t < 32 * 32; ++t) {
        power += rgb[3 * t] * vbi_hemioct_texel_bilinear_projected(map, t);
        if (rgb[3 * t] > rgb[3 * best])
            best = t;
    }
    vec3 mirror = v3(-wi.x, -wi.y, wi.z);
    float cos_peak = v3_dot(vbi_hemioct_texel_dirs(map)[best], mirror);
    print_message("# glossy table: emitted %.4f of 1 (directional albedo), peak %.2f deg from the mirror "
                  "direction\n",
                  power, acosf(fminf(1.0f, cos_peak)) * 180.0f / VBI_PI);
    assert_true(power > 0.3 && power <= 1.0);
    assert_true(cos_peak > cosf(15.0f * VBI_PI / 180.0f));
    free(rgb);
    vbi_hemioct_destroy(map);
    vbi_hemioct_destroy(inc);
}

/* A near-mirror conductor tabulated by BSDF sampling per photon: the table's power (with the
 * bilinear projected solid angles) is the directional albedo (estimated apart with 200K
 * samples) within 2%, and the peak is within 6 degrees of the mirror direction although the
 * lobe is narrower than a texel. */
static void test_sampled_table(void **state)
{
    (void)state;
    vbi_hemioct *map = NULL;
    assert_int_equal(vbi_hemioct_create(32, &map), VBNL_OK);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.type = VBNL_MATERIAL_CONDUCTOR;
    md.base_color[0] = md.base_color[1] = md.base_color[2] = 0.9f;
    md.alpha = 0.02f;
    vbi_bsdf bsdf;
    vbi_bsdf_from_material(&bsdf, &md);
    const vec3 wi = v3_norm(v3(0.5f, 0.2f, 0.8f));
    rv_gathered g = {wi, v3s(1.0f)};
    float *rgb = malloc(sizeof(float) * 3 * 32 * 32);
    vbi_rng rng = vbi_rng_make(3, 4);
    rv_emission_table_sampled(map, &bsdf, v3(0.0f, 0.0f, 1.0f), &g, 1, 4096, &rng, rgb);
    double power = 0.0, albedo = 0.0;
    uint32_t best = 0;
    for (uint32_t t = 0; t < 32 * 32; ++t) {
        power += rgb[3 * t] * vbi_hemioct_texel_bilinear_projected(map, t);
        if (rgb[3 * t] > rgb[3 * best])
            best = t;
    }
    vbi_rng r2 = vbi_rng_make(8, 8);
    for (int k = 0; k < 200000; ++k) {
        vbi_bsdf_sample_rec bs;
        vec2 u = vbi_rng_next2(&r2);
        if (vbi_bsdf_sample(&bsdf, wi, u, &bs) && bs.wi.z > 0.0f)
            albedo += bs.weight.x;
    }
    albedo /= 200000.0;
    vec3 mirror = v3(-wi.x, -wi.y, wi.z);
    float cos_peak = v3_dot(vbi_hemioct_texel_dirs(map)[best], mirror);
    print_message("# sampled table (alpha 0.02): power %.4f, directional albedo %.4f, peak %.2f deg from mirror\n",
                  power, albedo, acosf(fminf(1.0f, cos_peak)) * 180.0f / VBI_PI);
    assert_true(fabs(power / albedo - 1.0) < 0.02);
    assert_true(cos_peak > cosf(6.0f * VBI_PI / 180.0f));
    free(rgb);
    vbi_hemioct_destroy(map);
}

/* ---- placement ------------------------------------------------------------------------------ */

/* The kernel estimate of importance is normalised: importons of total importance 1 spread
 * evenly over the unit square give W = 1 inside it (2 / (pi d_K^2), not 1 / (pi d_K^2)). */
static void test_importance_normalisation(void **state)
{
    (void)state;
    enum { G = 300 };
    rv_maps m;
    memset(&m, 0, sizeof(m));
    m.imp_count = G * G;
    m.imp_pts = malloc(sizeof(vbi_kd_pt) * m.imp_count);
    m.imp_w = malloc(sizeof(float) * m.imp_count);
    vbi_rng rng = vbi_rng_make(11, 1);
    for (uint32_t i = 0; i < m.imp_count; ++i) {
        m.imp_pts[i].p[0] = ((float)(i % G) + vbi_rng_next(&rng)) / G;
        m.imp_pts[i].p[1] = ((float)(i / G) + vbi_rng_next(&rng)) / G;
        m.imp_pts[i].p[2] = 0.0f;
        m.imp_pts[i].id = i;
        m.imp_w[i] = 1.0f / (float)m.imp_count;
    }
    assert_int_equal(vbi_kd_build(&m.imp_tree, m.imp_pts, m.imp_count), 0);
    m.ph_count = 2000;
    m.ph = calloc(m.ph_count, sizeof(rv_photon));
    for (uint32_t i = 0; i < m.ph_count; ++i)
        m.ph[i].hit.p = v3(0.1f + 0.8f * vbi_rng_next(&rng), 0.1f + 0.8f * vbi_rng_next(&rng), 0.0f);
    float *W = malloc(sizeof(float) * m.ph_count);
    double W_mean = 0.0;
    vbnl_error err = {0};
    assert_int_equal(rv_importance_at_photons(&m, 16, NULL, NULL, W, &W_mean, &err), VBNL_OK);
    print_message("# mean importance %.4f (expected 1)\n", W_mean);
    assert_true(fabs(W_mean - 1.0) < 0.03);
    free(W);
    rv_maps_free(&m);
}

/* One trial per photon: the acceptance frequency of photons of equal importance matches
 * P_RS = min(1, W / (q W_mean)) within 5 binomial standard deviations, including the clipped
 * case P_RS = 1, and every accepted light carries that probability. */
static void test_acceptance_frequency(void **state)
{
    (void)state;
    enum { GROUPS = 4 };
    const float w_group[GROUPS] = {1.0f, 10.0f, 50.0f, 1e5f};
    const uint32_t n = 600000;
    float *W = malloc(sizeof(float) * n);
    uint32_t *group = malloc(sizeof(uint32_t) * n);
    uint32_t size[GROUPS] = {0};
    double mean = 0.0;
    for (uint32_t i = 0; i < n; ++i) {
        group[i] = i % 1000 == 0 ? 3 : i % 3; /* one photon in 1000 so important that P_RS clips to 1 */
        W[i] = w_group[group[i]];
        size[group[i]]++;
        mean += W[i];
    }
    mean /= n;
    const double q = 100.0;
    uint32_t *ids;
    float *p_rs;
    uint32_t count;
    vbnl_error err = {0};
    assert_int_equal(rv_place(W, n, q, mean, 99, &ids, &p_rs, &count, &err), VBNL_OK);
    uint32_t acc[GROUPS] = {0};
    for (uint32_t k = 0; k < count; ++k) {
        uint32_t gi = group[ids[k]];
        acc[gi]++;
        double want = fmin(1.0, w_group[gi] / (q * mean));
        assert_true(fabs(p_rs[k] - want) < 1e-6 * want);
        if (k > 0)
            assert_true(ids[k] > ids[k - 1]);
    }
    for (int gi = 0; gi < GROUPS; ++gi) {
        double p = fmin(1.0, w_group[gi] / (q * mean));
        double f = (double)acc[gi] / size[gi], sd = sqrt(p * (1.0 - p) / size[gi]);
        print_message("# group W=%g: P_RS %.5f, accepted %.5f\n", w_group[gi], p, f);
        if (p >= 1.0)
            assert_int_equal(acc[gi], size[gi]);
        else
            assert_true(fabs(f - p) <= 5.0 * sd + 1e-12);
    }
    free(W);
    free(group);
    free(ids);
    free(p_rs);
}

/* Relaxation on a curved surface (photons on the unit sphere): after every step the lights sit
 * exactly on photons (so on the sphere), stay mostly distinct, and spread out: the smallest and
 * the mean nearest-neighbour distances grow. */
static double nn_stats(const vec3 *pos, const uint32_t *ids, uint32_t n, double *min_out)
{
    double sum = 0.0, mn = INFINITY;
    for (uint32_t i = 0; i < n; ++i) {
        double best = INFINITY;
        for (uint32_t j = 0; j < n; ++j)
            if (j != i)
                best = fmin(best, v3_len(v3_sub(pos[ids[i]], pos[ids[j]])));
        sum += best;
        mn = fmin(mn, best);
    }
    *min_out = mn;
    return sum / n;
}

static void test_relaxation(void **state)
{
    (void)state;
    enum { NP = 40000, NL = 400 };
    vec3 *pos = malloc(sizeof(vec3) * NP);
    vbi_kd_pt *pts = malloc(sizeof(vbi_kd_pt) * NP);
    vbi_rng rng = vbi_rng_make(5, 5);
    for (uint32_t i = 0; i < NP; ++i) {
        pos[i] = sample_uniform_sphere(vbi_rng_next2(&rng));
        pts[i].p[0] = pos[i].x;
        pts[i].p[1] = pos[i].y;
        pts[i].p[2] = pos[i].z;
        pts[i].id = i;
    }
    vbi_kd_tree tree;
    assert_int_equal(vbi_kd_build(&tree, pts, NP), 0);
    uint32_t ids[NL];
    for (uint32_t i = 0; i < NL; ++i) /* distinct photons, as one trial per photon gives */
        ids[i] = (uint32_t)((uint64_t)i * NP / NL + vbi_rng_uniform_u32(&rng, NP / NL));
    double min0, mean0 = nn_stats(pos, ids, NL, &min0);
    vbnl_error err = {0};
    assert_int_equal(rv_relax(&tree, pos, ids, NL, 6, 20, NULL, NULL, &err), VBNL_OK);
    double min1, mean1 = nn_stats(pos, ids, NL, &min1);
    uint32_t distinct = 0;
    for (uint32_t i = 0; i < NL; ++i) {
        assert_true(ids[i] < NP);
        assert_true(fabs(v3_len(pos[ids[i]]) - 1.0) < 1e-5); /* on a photon, so on the surface */
        int dup = 0;
        for (uint32_t j = 0; j < i; ++j)
            dup |= ids[j] == ids[i];
        distinct += !dup;
    }
    print_message("# relaxation: nearest-neighbour distance mean %.4f -> %.4f, min %.4f -> %.4f, %u/%u "
                  "distinct\n",
                  mean0, mean1, min0, min1, distinct, NL);
    assert_true(mean1 > 1.2 * mean0);
    assert_true(min1 > 3.0 * min0);
    assert_true(distinct == NL);
    vbi_kd_free(&tree);
    free(pts);
    free(pos);
}

/* ---- renders -------------------------------------------------------------------------------- */

static double channel_mean(const float *img, uint32_t n, int channels)
{
    double m = 0.0;
    for (uint32_t i = 0; i < n; ++i)
        m += img[channels * i] + img[channels * i + 1] + img[channels * i + 2];
    return m / (3.0 * n);
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

/* The Cornell box: the mean of the indirect-only image against the path tracer's 'indirect'
 * layer, averaged over four light sets (seeds 2..5): one light set samples the heavy tail near
 * the 1/d^2 singularity in the corners once, and its mean varies by several per cent from seed to
 * seed (spheres -2.8% to -8.9%, points -0.2% to -6.2% over seeds 2..7), so a single seed
 * says little: seed 2 alone gives -2.8% and -0.2%. The P_RS-weighted emission is energy-consistent in expectation, so the point form (radius_scale = 0, unclamped)
 * keeps the total up to that variance and the gathering bias at corners: within 4% (measured
 * over the four sets -3.1%). The sphere term removes light from receivers closer than r to a
 * light and adds a little farther out; the net loss grows with r: with r = the 10th-neighbour
 * distance (radius_scale = 1) within 8% (measured -6.3%); the default radius_scale = 4 loses
 * about 18% at 3000 lights (README). */
static void test_cornell_indirect_energy(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_context_create(NULL, &ctx, NULL);
    vbnl_scene *s = cornell(ctx);
    const uint32_t W = 24, H = 24;
    const char *const ps[] = {"split_direct=1", NULL};
    float *ref = ts_render_layer(ctx, s, "path", W, H, 2048, 1, ps, "indirect");
    const char *const rs[] = {"virtual_lights=3000", "indirect_only=1", "radius_scale=1", NULL};
    const char *const rp[] = {"virtual_lights=3000", "indirect_only=1", "radius_scale=0", NULL};
    double mr = channel_mean(ref, W * H, 3), mi = 0.0, mp = 0.0;
    float *pt = NULL;
    for (uint64_t seed = 2; seed < 6; ++seed) {
        float *img = ts_render_layer(ctx, s, "richvsl", W, H, 4, seed, rs, "");
        mi += channel_mean(img, W * H, 4) / 4.0;
        free(img);
        free(pt); /* the last set's point image stays for the clamp test below */
        pt = ts_render_layer(ctx, s, "richvsl", W, H, 4, seed, rp, "");
        mp += channel_mean(pt, W * H, 4) / 4.0;
    }
    print_message("# cornell indirect mean over 4 light sets: path %.5f, richvsl (spheres) %.5f (%+.2f%%), richvsl "
                  "(points, unclamped) %.5f (%+.2f%%)\n",
                  mr, mi, 100.0 * (mi / mr - 1.0), mp, 100.0 * (mp / mr - 1.0));
    assert_true(fabs(mi / mr - 1.0) < 0.08);
    assert_true(fabs(mp / mr - 1.0) < 0.04);
    /* clamping only removes light */
    const char *const rc[] = {"virtual_lights=3000", "indirect_only=1", "radius_scale=0", "clamp=2", NULL};
    float *cl = ts_render_layer(ctx, s, "richvsl", W, H, 4, 5, rc, ""); /* the light set of pt */
    double mc = channel_mean(cl, W * H, 4), mp5 = channel_mean(pt, W * H, 4);
    print_message("# clamp=2: %.5f\n", mc);
    for (uint32_t i = 0; i < W * H; ++i)
        for (int c = 0; c < 3; ++c)
            assert_true(cl[4 * i + c] <= pt[4 * i + c] * 1.0001f + 1e-7f);
    assert_true(mc < mp5);
    free(ref);
    free(pt);
    free(cl);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* The door-ajar scene (examples/door-ajar.obj): the light is in the far room, the camera's room
 * is lit only through the gap of a door, so most photons land where the camera does not look and
 * the lights there are few (P_RS small: large flux each) with spheres of about 2 m. Lights on the
 * far side of the 10 cm partition lit the camera's side of it through the wall (a receiver
 * inside a sphere takes every direction of the cone, and the visibility ray to the centre ran
 * inside the wall): 8.2x the path tracer's indirect energy. With the plane conditions of `vsl` the
 * point form keeps the energy within 20% (measured -3.2%, loss at the corners and on the glossy
 * floor) and the default spheres (radius_scale = 4, radii up to 2 m here) lose at most 35%
 * (measured -22%; -22% to -29% over seeds at 24x24 and 32x32: the sphere term's near-field
 * loss, README). */
static void test_door_ajar_indirect_energy(void **state)
{
    (void)state;
    vbnl_context *ctx;
    vbnl_context_create(NULL, &ctx, NULL);
    const char *src = getenv("VBNL_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof(path), "%s/examples/door-ajar.obj", src ? src : ".");
    vbnl_scene *s;
    vbnl_scene_create(ctx, &s, NULL);
    vbnl_error err = {0};
    if (vbnl_mesh_import(s, path, NULL, NULL, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    float pos[3] = {3.6f, 1.3f, 1.6f}, target[3] = {0, 1, -0.2f}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 60.0f, 1.0f, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const uint32_t W = 24, H = 24;
    const char *const ps[] = {"split_direct=1", NULL};
    float *ref = ts_render_layer(ctx, s, "path", W, H, 2048, 1, ps, "indirect");
    const char *const rs[] = {"virtual_lights=3000", "indirect_only=1", NULL};
    uint64_t sd = getenv("RSEED") ? strtoull(getenv("RSEED"), 0, 10) : 2;
    float *img = ts_render_layer(ctx, s, "richvsl", W, H, 4, sd, rs, "");
    const char *const rp[] = {"virtual_lights=3000", "indirect_only=1", "radius_scale=0", NULL};
    float *pt = ts_render_layer(ctx, s, "richvsl", W, H, 4, sd, rp, "");
    double mr = channel_mean(ref, W * H, 3), mi = channel_mean(img, W * H, 4), mp = channel_mean(pt, W * H, 4);
    print_message("# door-ajar indirect mean: path %.6f, richvsl (spheres) %.6f (%+.2f%%), richvsl (points) "
                  "%.6f (%+.2f%%)\n",
                  mr, mi, 100.0 * (mi / mr - 1.0), mp, 100.0 * (mp / mr - 1.0));
    assert_true(mr > 0.0);
    assert_true(fabs(mi / mr - 1.0) < 0.35);
    assert_true(fabs(mp / mr - 1.0) < 0.2);
    free(ref);
    free(img);
    free(pt);
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
        const char *const settings[] = {"virtual_lights=600", NULL};
        img[t] = ts_render_layer(ctx, s, "richvsl", 20, 20, 2, 17, settings, "");
        vbnl_scene_destroy(s);
        vbnl_context_destroy(ctx);
    }
    assert_memory_equal(img[0], img[1], sizeof(float) * 4 * 20 * 20);
    assert_true(channel_mean(img[0], 400, 4) > 0.0);
    free(img[0]);
    free(img[1]);
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
    const char *bad[][2] = {{"profile_resolution=12", "8, 16 or 32"},
                            {"virtual_lights=40000000", "photon map holds"},
                            {"clamp=-1", "clamp"},
                            {"relax_neighbors=6", "relax_neighbours"}};
    for (int i = 0; i < 4; ++i) {
        vbnl_params *p;
        vbnl_params_create(&p, NULL);
        vbnl_params_set_text(p, bad[i][0], NULL, NULL);
        vbnl_render_settings rs;
        vbnl_render_settings_init(&rs);
        rs.integrator = "richvsl";
        rs.params = p;
        vbnl_renderer *r = NULL;
        vbnl_error err = {0};
        assert_int_not_equal(vbnl_renderer_create(ctx, s, &rs, &r, &err), VBNL_OK);
        if (!strstr(err.message, bad[i][1]))
            fail_msg("'%s': %s", bad[i][0], err.message);
        vbnl_params_destroy(p);
    }
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lambert_table_energy),
        cmocka_unit_test(test_glossy_table),
        cmocka_unit_test(test_sampled_table),
        cmocka_unit_test(test_importance_normalisation),
        cmocka_unit_test(test_acceptance_frequency),
        cmocka_unit_test(test_relaxation),
        cmocka_unit_test(test_refused),
        cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_cornell_indirect_energy),
        cmocka_unit_test(test_door_ajar_indirect_energy),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
