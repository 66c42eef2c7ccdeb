/* Tests for VBNL emission profiles (core/integrators/vbnl/profiles.h).
 *
 * The stored quantity is J(wo) = sum_i f(wo, w_i) Phi_i (cosine-free intensity, W/sr); the
 * intensity is I = J cos theta_o and the emitted power P = integral of I. References are brute
 * force: J_ref(wo) = sum over the photons p of f(wo, wi_p) Phi_p with the photons' exact
 * directions (no binning), and P_ref its stratified quadrature over the outgoing hemisphere.
 * Seeds are fixed. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf.h"
#include "bsdfs.h"
#include "octahedral.h"
#include "profiles.h"
#include "rng.h"
#include "sampling.h"

static vbi_hemioct *make_map(uint32_t res)
{
    vbi_hemioct *m = NULL;
    assert_int_equal(vbi_hemioct_create(res, &m), VBNL_OK);
    return m;
}

static vbi_bsdf make_bsdf(vbnl_material_type type, vec3 c, float alpha, float ior)
{
    return tb_bsdf(type, c.x, c.y, c.z, alpha, ior);
}

static vec3 uniform_dir(vbi_rng *r) { return sample_uniform_hemisphere(vbi_rng_next2(r)); }

/* f(wo, wi) without cosines (bsdf.h: eval = f |cos theta_i|). */
static vec3 brdf(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    return wi.z > 0.0f ? v3_scale(vbi_bsdf_eval(b, wo, wi), 1.0f / wi.z) : v3s(0.0f);
}

/* Photons arriving around a tilted axis (a cosine-power lobe) plus a diffuse background. */
typedef struct photons {
    int n;
    vec3 *wi;
    vec3 *power;
    vec3 total;
} photons;

static photons make_photons(int n, uint64_t seed)
{
    photons p = {n, malloc(n * sizeof(vec3)), malloc(n * sizeof(vec3)), v3s(0.0f)};
    vbi_rng rng = vbi_rng_make(seed, 77);
    float th = 35.0f * VBI_PI / 180.0f, ph = 20.0f * VBI_PI / 180.0f;
    frame f = frame_from_normal(v3(sinf(th) * cosf(ph), sinf(th) * sinf(ph), cosf(th)));
    for (int k = 0; k < n; ++k) {
        vec3 w;
        do {
            if (vbi_rng_next(&rng) < 0.7f) {
                vec2 u = vbi_rng_next2(&rng);
                float z = powf(u.x, 1.0f / 21.0f), s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
                w = frame_to_world(&f, v3(s * cosf(6.2831853f * u.y), s * sinf(6.2831853f * u.y), z));
            } else {
                w = sample_cosine_hemisphere(vbi_rng_next2(&rng));
            }
        } while (!(w.z > 0.01f));
        p.wi[k] = v3_norm(w);
        p.power[k] = v3_scale(v3(1.0f, 0.8f, 0.6f), (0.5f + vbi_rng_next(&rng)) * 5.0f / n);
        p.total = v3_add(p.total, p.power[k]);
    }
    return p;
}

static void free_photons(photons *p)
{
    free(p->wi);
    free(p->power);
}

static vec3 j_ref(const vbi_bsdf *b, const photons *p, vec3 wo)
{
    double acc[3] = {0, 0, 0};
    for (int k = 0; k < p->n; ++k) {
        vec3 f = brdf(b, wo, p->wi[k]);
        acc[0] += (double)f.x * p->power[k].x;
        acc[1] += (double)f.y * p->power[k].y;
        acc[2] += (double)f.z * p->power[k].z;
    }
    return v3((float)acc[0], (float)acc[1], (float)acc[2]);
}

/* ---- Lambertian ---------------------------------------------------------------------------- */

static void test_lambert(void **state)
{
    (void)state;
    vbi_hemioct *m = make_map(16);
    vec3 rho = v3(0.8f, 0.5f, 0.2f);
    vbi_bsdf b = make_bsdf(VBNL_MATERIAL_LAMBERT, rho, 0.1f, 1.5f);
    vbi_profile_kernel *k = NULL;
    assert_int_equal(vbi_profile_kernel_create(m, &b, 1, &k), VBNL_OK);
    /* VL 0: Lambertian slot (no map); VL 1: a map converted with the same Lambertian BSDF. */
    uint8_t glossy[2] = {0, 1};
    vbi_profile_set *s = NULL;
    assert_int_equal(vbi_profile_set_create(m, 2, glossy, &s), VBNL_OK);
    photons p = make_photons(5000, 1);
    for (int i = 0; i < p.n; ++i) {
        vbi_profile_deposit(s, 0, p.wi[i], p.power[i]);
        vbi_profile_deposit(s, 1, p.wi[i], p.power[i]);
    }
    vec3 phi = vbi_profile_incident_power(s, 0);
    assert_true(fabsf(phi.x / p.total.x - 1.0f) < 1e-5f);
    vbi_rng rng = vbi_rng_make(5, 5);
    for (int n = 0; n < 1000; ++n) {
        vec3 wo = uniform_dir(&rng);
        vec3 j = vbi_profile_eval(s, 0, k, wo), in = vbi_profile_intensity(s, 0, k, wo);
        /* J = rho / pi Phi_in, I = J cos theta_o (profiles.h). */
        for (int c = 0; c < 3; ++c) {
            double jr = v3_comp(rho, c) / M_PI * v3_comp(phi, c);
            assert_true(fabs(v3_comp(j, c) / jr - 1.0) < 1e-6);
            assert_true(fabs(v3_comp(in, c) - jr * wo.z) <= 1e-6 * jr);
        }
        /* The map version agrees to the RGBE precision (1/256 of the largest channel). */
        vec3 j1 = vbi_profile_eval(s, 1, k, wo);
        assert_true(fabsf(j1.x - j.x) <= j.x / 256.0f + 1e-7f && fabsf(j1.z - j.z) <= j.x / 256.0f + 1e-7f);
    }
    assert_true(v3_is_black(vbi_profile_eval(s, 0, k, v3(0.0f, 0.6f, -0.8f))));
    /* Energy conservation: P = rho Phi_in, and the quadrature of I over the hemisphere agrees. */
    for (uint32_t vl = 0; vl < 2; ++vl) {
        vec3 pw = vbi_profile_power(s, vl, k);
        double q[3] = {0, 0, 0};
        const int g = 200;
        for (int i = 0; i < g; ++i)
            for (int jj = 0; jj < g; ++jj) {
                vec3 wo = sample_uniform_hemisphere((vec2){(i + 0.5f) / g, (jj + 0.5f) / g});
                vec3 in = vbi_profile_intensity(s, vl, k, wo);
                q[0] += in.x;
                q[1] += in.y;
                q[2] += in.z;
            }
        double ref_max = rho.x * phi.x; /* the largest channel */
        for (int c = 0; c < 3; ++c) {
            double ref = v3_comp(rho, c) * v3_comp(phi, c);
            double quad = q[c] * 2.0 * M_PI / (g * g);
            print_message("# VL %u channel %d: P = %.6f, quadrature %.6f, rho Phi_in = %.6f\n", vl, c,
                          v3_comp(pw, c), quad, ref);
            assert_true(fabs(v3_comp(pw, c) / ref - 1.0) < 1e-5);
            /* Quadrature error 1e-3; the map (VL 1) adds RGBE rounding of up to 1/256 of the
             * largest channel. */
            assert_true(fabs(quad - ref) < 1e-3 * ref + (vl == 0 ? 0.0 : ref_max / 256.0));
        }
    }
    free_photons(&p);
    vbi_profile_set_destroy(s);
    vbi_profile_kernel_destroy(k);
    vbi_hemioct_destroy(m);
}

/* ---- glossy against brute force ----------------------------------------------------------- */

typedef struct glossy_case {
    const char *name;
    vbnl_material_type type;
    vec3 color;
    float alpha, ior;
    uint32_t res;
    double tol_centres, tol_eval, tol_power; /* relative L1 errors and power error */
} glossy_case;

static void run_glossy(const glossy_case *gc)
{
    vbi_hemioct *m = make_map(gc->res);
    uint32_t cnt = vbi_hemioct_texel_count(m);
    vbi_bsdf b = make_bsdf(gc->type, gc->color, gc->alpha, gc->ior);
    vbi_profile_kernel *k = NULL;
    assert_int_equal(vbi_profile_kernel_create(m, &b, 1, &k), VBNL_OK);
    uint8_t glossy = 1;
    vbi_profile_set *s = NULL;
    assert_int_equal(vbi_profile_set_create(m, 1, &glossy, &s), VBNL_OK);
    photons p = make_photons(600, 2);
    for (int i = 0; i < p.n; ++i)
        vbi_profile_deposit(s, 0, p.wi[i], p.power[i]);
    vbi_profile_convert(s, 0, k);

    /* Texel centres, weighted by solid angle (luminance). */
    double num = 0.0, den = 0.0;
    for (uint32_t t = 0; t < cnt; ++t) {
        vec3 wo = vbi_hemioct_texel_dir(m, t);
        double om = vbi_hemioct_texel_solid_angle(m, t);
        num += fabs(v3_luminance(vbi_profile_texel(s, 0, k, t)) - v3_luminance(j_ref(&b, &p, wo))) * om;
        den += v3_luminance(j_ref(&b, &p, wo)) * om;
    }
    double err_centres = num / den;
    /* Bilinear evaluation at random directions. */
    vbi_rng rng = vbi_rng_make(9, 9);
    num = den = 0.0;
    for (int n = 0; n < 3000; ++n) {
        vec3 wo = uniform_dir(&rng);
        num += fabs(v3_luminance(vbi_profile_eval(s, 0, k, wo)) - v3_luminance(j_ref(&b, &p, wo)));
        den += v3_luminance(j_ref(&b, &p, wo));
    }
    double err_eval = num / den;
    /* Power: stratified quadrature of I_ref = J_ref cos over the outgoing hemisphere. */
    const int g = 96;
    double pref[3] = {0, 0, 0};
    for (int i = 0; i < g; ++i)
        for (int jj = 0; jj < g; ++jj) {
            vec2 u = {(i + vbi_rng_next(&rng)) / g, (jj + vbi_rng_next(&rng)) / g};
            vec3 wo = sample_uniform_hemisphere(u);
            vec3 jr = j_ref(&b, &p, wo);
            pref[0] += jr.x * wo.z;
            pref[1] += jr.y * wo.z;
            pref[2] += jr.z * wo.z;
        }
    vec3 pw = vbi_profile_power(s, 0, k);
    /* The stored (RGBE) profile integrates to the same power: sum_t J_t C_t. */
    double pstored[3] = {0, 0, 0};
    for (uint32_t t = 0; t < cnt; ++t) {
        vec3 j = vbi_profile_texel(s, 0, k, t);
        double c = vbi_hemioct_texel_bilinear_projected(m, t);
        pstored[0] += j.x * c;
        pstored[1] += j.y * c;
        pstored[2] += j.z * c;
    }
    /* Largest directional albedo over incident directions: passive reflection emits at most
     * Phi_in times it. Estimated at every incident texel centre by importance sampling the BSDF
     * (reciprocal: the weight of sampling x from wi integrates f(x, wi) cos_x over x). */
    double amax[3] = {0, 0, 0};
    const int ga = 32;
    for (uint32_t i = 0; i < cnt; i += (cnt > 256 ? 4 : 1)) {
        vec3 wi = vbi_hemioct_texel_dir(m, i);
        double a[3] = {0, 0, 0};
        for (int x = 0; x < ga; ++x)
            for (int y = 0; y < ga; ++y) {
                vbi_bsdf_sample_rec rec;
                vec2 u = {(x + vbi_rng_next(&rng)) / ga, (y + vbi_rng_next(&rng)) / ga};
                if (vbi_bsdf_sample(&b, wi, u, &rec)) {
                    a[0] += rec.weight.x;
                    a[1] += rec.weight.y;
                    a[2] += rec.weight.z;
                }
            }
        for (int c = 0; c < 3; ++c)
            amax[c] = fmax(amax[c], a[c] / (ga * ga));
    }
    print_message("# %s: J at centres %.4f, bilinear J %.4f (relative L1)\n", gc->name, err_centres, err_eval);
    assert_true(err_centres < gc->tol_centres);
    assert_true(err_eval < gc->tol_eval);
    for (int c = 0; c < 3; ++c) {
        double ref = pref[c] * 2.0 * M_PI / (g * g);
        double phi = v3_comp(p.total, c);
        print_message("#   channel %d: P = %.5f, brute force %.5f, stored profile %.5f, Phi_in %.5f, "
                      "max albedo %.4f\n", c, v3_comp(pw, c), ref, pstored[c], phi, amax[c]);
        assert_true(fabs(v3_comp(pw, c) / ref - 1.0) < gc->tol_power);
        assert_true(fabs(pstored[c] / v3_comp(pw, c) - 1.0) < 1.0 / 256.0);
        assert_true(v3_comp(pw, c) <= phi * amax[c] * 1.01);
        assert_true(v3_comp(pw, c) <= phi);
    }
    free_photons(&p);
    vbi_profile_set_destroy(s);
    vbi_profile_kernel_destroy(k);
    vbi_hemioct_destroy(m);
}

static void test_conductor_brute_force(void **state)
{
    (void)state;
    glossy_case c16 = {"conductor alpha 0.3, 16x16", VBNL_MATERIAL_CONDUCTOR, {0.95f, 0.64f, 0.54f}, 0.3f, 1.5f,
                       16, 0.03, 0.05, 0.02};
    run_glossy(&c16);
    glossy_case c32 = {"conductor alpha 0.15, 32x32", VBNL_MATERIAL_CONDUCTOR, {0.95f, 0.93f, 0.88f}, 0.15f,
                       1.5f, 32, 0.03, 0.05, 0.02};
    run_glossy(&c32);
}

static void test_plastic_brute_force(void **state)
{
    (void)state;
    glossy_case p16 = {"plastic alpha 0.2, 16x16", VBNL_MATERIAL_PLASTIC, {0.5f, 0.3f, 0.2f}, 0.2f, 1.5f, 16,
                       0.03, 0.05, 0.02};
    run_glossy(&p16);
}

/* ---- lazy vs eager ------------------------------------------------------------------------- */

typedef struct lazy_job {
    vbi_profile_set *s;
    const vbi_profile_kernel *k;
    uint32_t vl, texels;
    uint64_t seed;
} lazy_job;

static void *lazy_worker(void *arg)
{
    lazy_job *j = arg;
    vbi_rng rng = vbi_rng_make(j->seed, 3);
    for (int n = 0; n < 40; ++n) {
        if (n & 1)
            vbi_profile_eval(j->s, j->vl, j->k, uniform_dir(&rng));
        else
            vbi_profile_texel(j->s, j->vl, j->k, vbi_rng_uniform_u32(&rng, j->texels));
    }
    return NULL;
}

static void test_lazy_equals_eager(void **state)
{
    (void)state;
    vbi_hemioct *m = make_map(16);
    uint32_t cnt = vbi_hemioct_texel_count(m);
    /* alpha 0.4: point-sampled at 16 x 16 (narrower lobes always keep the matrix, profiles.c) */
    vbi_bsdf b = make_bsdf(VBNL_MATERIAL_CONDUCTOR, v3(0.9f, 0.7f, 0.4f), 0.4f, 1.5f);
    vbi_profile_kernel *kc = NULL, *ku = NULL;
    assert_int_equal(vbi_profile_kernel_create(m, &b, 1, &kc), VBNL_OK);
    assert_int_equal(vbi_profile_kernel_create(m, &b, 0, &ku), VBNL_OK);
    assert_true(vbi_profile_kernel_bytes(kc) > vbi_profile_kernel_bytes(ku));
    print_message("# kernel bytes at 16x16: cached %zu, uncached %zu\n", vbi_profile_kernel_bytes(kc),
                  vbi_profile_kernel_bytes(ku));
    /* Same incident data in VLs 0 (eager), 1 (lazy from 4 threads), 2 (lazy, uncached kernel). */
    uint8_t glossy[3] = {1, 1, 1};
    vbi_profile_set *s = NULL;
    assert_int_equal(vbi_profile_set_create(m, 3, glossy, &s), VBNL_OK);
    photons p = make_photons(3000, 4);
    for (int i = 0; i < p.n; ++i)
        for (uint32_t vl = 0; vl < 3; ++vl)
            vbi_profile_deposit(s, vl, p.wi[i], p.power[i]);
    assert_int_equal(memcmp(vbi_profile_incident_map_fixed(s, 0), vbi_profile_incident_map_fixed(s, 1), cnt * 24), 0);

    vbi_profile_convert(s, 0, kc);
    for (uint32_t t = 0; t < cnt; ++t) {
        assert_true(vbi_profile_texel_converted(s, 0, t));
        assert_false(vbi_profile_texel_converted(s, 1, t));
    }
    assert_int_equal(vbi_profile_set_release_incident(s), VBNL_ERR_STATE);

    /* Lazy reads from 4 threads: with the cached kernel (VL 1) the first read converts the whole
     * light; with the uncached one (VL 2) only the texels read. */
    enum { THREADS = 4 };
    pthread_t th[THREADS];
    lazy_job jobs[THREADS];
    for (uint32_t vl = 1; vl <= 2; ++vl) {
        for (int i = 0; i < THREADS; ++i) {
            jobs[i] = (lazy_job){s, vl == 1 ? kc : ku, vl, cnt, 50 + (uint64_t)i};
            assert_int_equal(pthread_create(&th[i], NULL, lazy_worker, &jobs[i]), 0);
        }
        for (int i = 0; i < THREADS; ++i)
            pthread_join(th[i], NULL);
        uint32_t touched = 0;
        for (uint32_t t = 0; t < cnt; ++t)
            touched += (uint32_t)vbi_profile_texel_converted(s, vl, t);
        print_message("# lazy, %s kernel: %u of %u texels converted by the threads\n", vl == 1 ? "cached" : "uncached",
                      touched, cnt);
        if (vl == 1)
            assert_int_equal(touched, cnt);
        else
            assert_true(touched > 0 && touched < cnt); /* the loop below converts the rest */
    }

    vbi_rng rng = vbi_rng_make(8, 8);
    vec3 before[64];
    vec3 dirs[64];
    for (int n = 0; n < 64; ++n) {
        dirs[n] = uniform_dir(&rng);
        before[n] = vbi_profile_eval(s, 0, kc, dirs[n]);
    }
    vec3 power_before = vbi_profile_power(s, 0, kc);
    for (uint32_t t = 0; t < cnt; ++t) {
        vec3 e = vbi_profile_texel(s, 0, kc, t);
        vec3 l = vbi_profile_texel(s, 1, kc, t);
        vec3 u = vbi_profile_texel(s, 2, ku, t);
        assert_int_equal(memcmp(&e, &l, sizeof(vec3)), 0);
        assert_int_equal(memcmp(&e, &u, sizeof(vec3)), 0);
    }
    /* Every texel is converted now: the incident maps can go; values stay. */
    size_t bytes_before = vbi_profile_set_bytes(s);
    assert_int_equal(vbi_profile_set_release_incident(s), VBNL_OK);
    assert_null(vbi_profile_incident_map_fixed(s, 0));
    size_t bytes_after = vbi_profile_set_bytes(s);
    print_message("# set bytes (3 glossy VLs): %zu before release, %zu after\n", bytes_before, bytes_after);
    assert_int_equal(bytes_before - bytes_after, 3 * cnt * 24); /* 64-bit fixed-point RGB */
    for (int n = 0; n < 64; ++n) {
        vec3 v = vbi_profile_eval(s, 0, kc, dirs[n]);
        assert_int_equal(memcmp(&v, &before[n], sizeof(vec3)), 0);
    }
    vec3 power_after = vbi_profile_power(s, 0, kc);
    assert_true(fabsf(power_after.x / power_before.x - 1.0f) < 1.0f / 256.0f);

    free_photons(&p);
    vbi_profile_set_destroy(s);
    vbi_profile_kernel_destroy(kc);
    vbi_profile_kernel_destroy(ku);
    vbi_hemioct_destroy(m);
}

/* ---- memory and arguments ------------------------------------------------------------------ */

static void test_memory_and_arguments(void **state)
{
    (void)state;
    const uint32_t n = 1000;
    uint32_t res[3] = {8, 16, 32};
    for (int r = 0; r < 3; ++r) {
        vbi_hemioct *m = make_map(res[r]);
        uint8_t *glossy = malloc(n);
        memset(glossy, 1, n);
        vbi_profile_set *sg = NULL, *sl = NULL;
        assert_int_equal(vbi_profile_set_create(m, n, glossy, &sg), VBNL_OK);
        assert_int_equal(vbi_profile_set_create(m, n, NULL, &sl), VBNL_OK);
        size_t per_lambert = (vbi_profile_set_bytes(sl) - sizeof(void *) * 0) / n;
        size_t per_glossy = (vbi_profile_set_bytes(sg) - vbi_profile_set_bytes(sl)) / n;
        print_message("# R=%u: Lambertian VL ~%zu B; glossy VL +%zu B while incident maps exist, +%u B after "
                      "release\n", res[r], per_lambert, per_glossy, res[r] * res[r] * 4);
        assert_int_equal(per_glossy, (size_t)res[r] * res[r] * 28); /* 4 B RGBE + 24 B fixed-point RGB */
        assert_true(vbi_profile_is_glossy(sg, 5) && !vbi_profile_is_glossy(sl, 5));
        assert_int_equal(vbi_profile_set_count(sg), n);
        vbi_profile_set_destroy(sg);
        vbi_profile_set_destroy(sl);
        free(glossy);
        vbi_hemioct_destroy(m);
    }
    vbi_profile_set *s = (vbi_profile_set *)1;
    assert_int_equal(vbi_profile_set_create(NULL, 4, NULL, &s), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(s);
    assert_int_equal(vbi_profile_set_create(NULL, 4, NULL, NULL), VBNL_ERR_INVALID_ARGUMENT);
    vbi_profile_kernel *k = (vbi_profile_kernel *)1;
    assert_int_equal(vbi_profile_kernel_create(NULL, NULL, 0, &k), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(k);
    vbi_profile_set_destroy(NULL);
    vbi_profile_kernel_destroy(NULL);
    assert_int_equal(vbi_profile_set_release_incident(NULL), VBNL_ERR_INVALID_ARGUMENT);
}

/* Splats into private 32-bit maps with plain adds, their carries past 2^32 into the set, the
 * low halves added into the set afterwards (vbi_profile_add_incident_lo32; photon splitting's
 * per-thread maps), equal atomic splats into the set bit for bit; prepare by slot into a 32-bit
 * map gives the shares and offsets of prepare by VL into the set. The deposits are large enough
 * (up to 2^34 steps) that carries happen often. */
static void test_private_map_copies(void **state)
{
    (void)state;
    const uint32_t n = 40;
    vbi_hemioct *m = make_map(16);
    uint8_t glossy[40];
    for (uint32_t j = 0; j < n; ++j)
        glossy[j] = j % 3 != 0;
    vbi_profile_set *direct = NULL, *merged = NULL;
    assert_int_equal(vbi_profile_set_create(m, n, glossy, &direct), VBNL_OK);
    assert_int_equal(vbi_profile_set_create(m, n, glossy, &merged), VBNL_OK);
    const size_t bytes = vbi_profile_incident_bytes(merged);
    assert_int_equal(bytes, (size_t)26 * vbi_hemioct_texel_count(m) * 3 * sizeof(uint64_t)); /* 26 glossy */
    uint32_t *lo[2] = {calloc(bytes / 2, 1), calloc(bytes / 2, 1)};
    assert_non_null(lo[0]);
    assert_non_null(lo[1]);
    const uint64_t *set_maps = vbi_profile_incident_maps(merged);
    vbi_rng rng = vbi_rng_make(9, 1);
    int splats = 0;
    for (int k = 0; k < 20000; ++k) {
        uint32_t j = (uint32_t)(vbi_rng_next(&rng) * n) % n;
        vec3 wi = uniform_dir(&rng);
        uint64_t q[3] = {1000003u + (uint64_t)k * 7919u, 17u * (uint64_t)k, (uint64_t)k << 20};
        vbi_profile_deposit_map_fixed(direct, j, wi, q);
        /* by VL into the set's maps (not applied) and by slot into a 32-bit map: the same shares
         * at the same offsets, the carries into the set's texels */
        vbi_profile_splat a;
        vbi_profile_splat32 b;
        int ha = vbi_profile_splat_prepare(merged, j, wi, q, &a);
        int hb = vbi_profile_splat_prepare_lo32(merged, lo[k & 1], vbi_profile_slot(merged, j), wi, q, &b);
        assert_int_equal(ha, glossy[j]);
        assert_int_equal(hb, glossy[j]);
        if (hb) {
            assert_memory_equal(a.part, b.part, sizeof(a.part));
            for (int t = 0; t < 4; ++t) {
                assert_true(a.texel[t] - set_maps == b.texel[t] - lo[k & 1]);
                assert_ptr_equal(b.carry[t], a.texel[t]);
            }
            vbi_profile_splat_apply_lo32(&b);
            ++splats;
        }
    }
    assert_true(splats > 10000);
    /* before the low halves: only carries have reached the set, and there were some */
    uint64_t carried = 0;
    for (size_t i = 0; i < bytes / sizeof(uint64_t); ++i) {
        assert_int_equal(set_maps[i] & UINT32_MAX, 0);
        carried += set_maps[i] != 0;
    }
    print_message("# %d splats, %llu texel channels carried past 2^32\n", splats, (unsigned long long)carried);
    assert_true(carried > 100);
    for (int c = 0; c < 2; ++c)
        assert_int_equal(vbi_profile_add_incident_lo32(merged, lo[c]), VBNL_OK);
    for (uint32_t j = 0; j < n; ++j) {
        const uint64_t *x = vbi_profile_incident_map_fixed(direct, j), *y = vbi_profile_incident_map_fixed(merged, j);
        assert_true((x == NULL) == (y == NULL));
        if (x)
            assert_memory_equal(x, y, 3 * sizeof(uint64_t) * vbi_hemioct_texel_count(m));
    }
    assert_int_equal(vbi_profile_add_incident_lo32(merged, NULL), VBNL_ERR_INVALID_ARGUMENT);
    vbi_profile_set *lambert = NULL;
    assert_int_equal(vbi_profile_set_create(m, n, NULL, &lambert), VBNL_OK);
    assert_int_equal(vbi_profile_incident_bytes(lambert), 0); /* nothing to copy */
    vbi_profile_set_destroy(lambert);
    free(lo[0]);
    free(lo[1]);
    vbi_profile_set_destroy(direct);
    vbi_profile_set_destroy(merged);
    vbi_hemioct_destroy(m);
}

/* A Lambertian slot given a glossy kernel falls back to the diffuse approximation: power
 * rho_avg Phi_in with rho_avg the kernel's cosine-weighted albedo. */
static void test_diffuse_fallback(void **state)
{
    (void)state;
    vbi_hemioct *m = make_map(16);
    vbi_bsdf b = make_bsdf(VBNL_MATERIAL_PLASTIC, v3(0.5f, 0.3f, 0.2f), 0.3f, 1.5f);
    vbi_profile_kernel *k = NULL;
    assert_int_equal(vbi_profile_kernel_create(m, &b, 0, &k), VBNL_OK);
    vbi_profile_set *s = NULL;
    assert_int_equal(vbi_profile_set_create(m, 1, NULL, &s), VBNL_OK);
    vbi_profile_deposit(s, 0, v3(0, 0, 1), v3s(2.0f));
    vec3 rho = vbi_profile_kernel_diffuse_albedo(k);
    assert_true(rho.x > 0.3f && rho.x < 1.0f && rho.x > rho.z);
    vec3 pw = vbi_profile_power(s, 0, k);
    assert_true(fabsf(pw.x - 2.0f * rho.x) < 1e-6f);
    vec3 j = vbi_profile_eval(s, 0, k, v3(0.6f, 0.0f, 0.8f));
    assert_true(fabsf(j.y - 2.0f * rho.y / VBI_PI) < 1e-6f);
    vbi_profile_set_destroy(s);
    vbi_profile_kernel_destroy(k);
    vbi_hemioct_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lambert),
        cmocka_unit_test(test_conductor_brute_force),
        cmocka_unit_test(test_plastic_brute_force),
        cmocka_unit_test(test_lazy_equals_eager),
        cmocka_unit_test(test_memory_and_arguments),
        cmocka_unit_test(test_diffuse_fallback),
        cmocka_unit_test(test_private_map_copies),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
