/* Tests for photon splitting (core/integrators/vbnl/splitting.h, Li et al. 2022, Section 3.3)
 * and the VL sphere index (vl_index.h).
 *
 *  - index: grid and Embree variants against the brute-force reference (reference.h: identical id
 *    lists and distances), several level policies, degenerate radii, a hashed grid;
 *    the batched query against single queries (same sets, capped or not, filtered or not);
 *  - closed Lambertian sphere with uniform two-sided emission: analytic incident power of every
 *    VL and exact energy bookkeeping;
 *  - determinism: 1, 2 and 3 threads and any chunk size bit-identical; split path ranges merged
 *    == one run; merge adds integer-wise;
 *  - a glossy VL under a small area light: direction-binned power toward the light.
 * Seeds are fixed. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "context.h"
#include "octahedral.h"
#include "pool.h"
#include "profiles.h"
#include "reference.h"
#include "rng.h"
#include "sampling.h"
#include "scene_internal.h"
#include "scenes.h"
#include "splitting.h"
#include "vbnl/vbnl.h"
#include "vl_index.h"

static vbnl_context *make_ctx(unsigned threads)
{
    vbnl_context *ctx = ts_context(threads);
    assert_non_null(ctx);
    return ctx;
}

static void set_camera(vbnl_scene *s, float z)
{
    float pos[3] = {0, 0.5f, z}, target[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 60.0f, 1.0f, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
}

/* ---- index against brute force ------------------------------------------------------------ */

/* vbi_vl_index_query_batch against one vbi_vl_index_query_found per point: same totals, same
 * sets of records (the batch keeps rank order), ids and ranks consistent. */
typedef struct batch_pt {
    vec3 p, n, wi;
} batch_pt;
typedef struct batch_check {
    const vbi_vl_index *x;
    const batch_pt *pts;
    const uint32_t *order;
    int filter;
    uint32_t max_out, calls;
} batch_check;

static int cmp_found(const void *a, const void *b)
{
    const vbi_vl_found *x = a, *y = b;
    return (x->id > y->id) - (x->id < y->id);
}

static void batch_cb(void *user, uint32_t k, uint32_t total, const vbi_vl_found *found, uint32_t n)
{
    batch_check *c = user;
    assert_int_equal(k, c->calls);
    c->calls++;
    const batch_pt *q = &c->pts[c->order[k]];
    vbi_vl_filter f = {q->n, q->wi, 0.2f, 1};
    vbi_vl_found ref[64], got[64];
    uint32_t rt = vbi_vl_index_query_found(c->x, q->p, c->filter ? &f : NULL, c->max_out, ref);
    assert_int_equal(total, rt);
    uint32_t rn = rt < c->max_out ? rt : c->max_out;
    assert_int_equal(n, rn);
    memcpy(got, found, n * sizeof(*found));
    qsort(got, n, sizeof(*got), cmp_found);
    assert_memory_equal(got, ref, n * sizeof(*got)); /* ref is in id order */
    for (uint32_t i = 0; i < n; ++i) {
        assert_int_equal(vbi_vl_index_rank(c->x, got[i].id), got[i].rank);
        assert_int_equal(vbi_vl_index_id(c->x, got[i].rank), got[i].id);
    }
}

static void check_batch(const vbi_vl_index *x, const vec3 *pts, uint32_t npts)
{
    batch_pt *bp = malloc(npts * sizeof(*bp));
    uint32_t *order = malloc(npts * sizeof(uint32_t));
    vbi_rng rng = vbi_rng_make(5, 9);
    for (uint32_t k = 0; k < npts; ++k) {
        bp[k].p = pts[k];
        bp[k].n = sample_uniform_sphere(vbi_rng_next2(&rng));
        bp[k].wi = sample_uniform_sphere(vbi_rng_next2(&rng));
        order[k] = k;
    }
    for (uint32_t k = npts; k > 1; --k) { /* a random order */
        uint32_t j = vbi_rng_uniform_u32(&rng, k), t = order[k - 1];
        order[k - 1] = order[j];
        order[j] = t;
    }
    for (int variant = 0; variant < 4; ++variant) {
        batch_check c = {x, bp, order, variant & 1, (variant & 2) ? 2u : 64u, 0};
        vbi_vl_batch b;
        memset(&b, 0, sizeof(b));
        b.count = npts;
        b.order = order;
        b.base = bp;
        b.stride = sizeof(batch_pt);
        b.p_off = offsetof(batch_pt, p);
        b.n_off = offsetof(batch_pt, n);
        b.wi_off = offsetof(batch_pt, wi);
        b.filter = c.filter;
        b.normal_cos = 0.2f;
        b.facing = 1;
        b.max_out = c.max_out;
        vbi_vl_index_query_batch(x, &b, batch_cb, &c);
        assert_int_equal(c.calls, npts);
    }
    for (uint32_t r = 0; r < vbi_vl_index_count(x); ++r)
        assert_int_equal(vbi_vl_index_rank(x, vbi_vl_index_id(x, r)), r);
    free(bp);
    free(order);
}

static uint32_t check_index_levels(vbi_vl_index_kind kind, vbi_vl_index_levels levels, RTCDevice dev, const vec3 *c,
                               const float *r, const vec3 *nrm, uint32_t n, const vec3 *pts, uint32_t npts)
{
    vbi_vl_index_desc d = {c, r, nrm, n, kind, 0.0f, dev, levels};
    vbi_vl_index *x = NULL;
    assert_int_equal(vbi_vl_index_create(&d, &x), VBNL_OK);
    uint32_t ids[256], ref[256];
    float d2[256], rd2[256];
    vbi_vl_found rf[256];
    uint64_t total = 0;
    uint32_t most = 0;
    for (uint32_t k = 0; k < npts; ++k) {
        /* the reference: brute force over every sphere (reference.h) */
        uint32_t m = vbi_vl_query_reference(c, r, nrm, n, pts[k], NULL, 256, rf);
        assert_true(m <= 256);
        for (uint32_t q = 0; q < m; ++q) {
            ref[q] = rf[q].id;
            rd2[q] = rf[q].d2;
        }
        uint32_t got = vbi_vl_index_query(x, pts[k], 256, ids, d2);
        assert_int_equal(got, m);
        assert_memory_equal(ids, ref, m * sizeof(uint32_t));
        assert_memory_equal(d2, rd2, m * sizeof(float));
        /* Capped output: the smallest ids, the full count. */
        if (m > 2) {
            uint32_t few[2];
            assert_int_equal(vbi_vl_index_query(x, pts[k], 2, few, NULL), m);
            assert_int_equal(few[0], ref[0]);
            assert_int_equal(few[1], ref[1]);
        }
        total += m;
        most = m > most ? m : most;
        /* Filtered query (splitting): the reference with the same filter. */
        vbi_vl_filter f = {v3_norm(v3(0.3f, 1.0f, -0.2f)), v3_norm(v3(-0.5f, 0.6f, 0.4f)), 0.2f, 1};
        uint32_t mf = vbi_vl_query_reference(c, r, nrm, n, pts[k], &f, 256, rf);
        for (uint32_t q = 0; q < mf; ++q)
            ref[q] = rf[q].id;
        assert_int_equal(vbi_vl_index_query_filtered(x, pts[k], &f, 256, ids, NULL), mf);
        assert_memory_equal(ids, ref, mf * sizeof(uint32_t));
    }
    print_message("# %s (%u levels): %u spheres, %u points, %.2f spheres per point (max %u), %zu bytes\n",
                  kind == VBI_VL_INDEX_GRID ? "grid" : "embree", vbi_vl_index_level_count(x), n, npts,
                  (double)total / npts, most, vbi_vl_index_bytes(x));
    assert_true(total > npts / 4); /* the test points do hit spheres */
    check_batch(x, pts, npts);
    uint32_t levels_built = vbi_vl_index_level_count(x);
    vbi_vl_index_destroy(x);
    return levels_built;
}

/* The grid with each level policy (vl_index.h, "Levels"), or the Embree variant; returns the
 * levels AUTO built. */
static uint32_t check_index(vbi_vl_index_kind kind, RTCDevice dev, const vec3 *c, const float *r, const vec3 *nrm,
                            uint32_t n, const vec3 *pts, uint32_t npts)
{
    if (kind != VBI_VL_INDEX_GRID)
        return check_index_levels(kind, VBI_VL_INDEX_LEVELS_AUTO, dev, c, r, nrm, n, pts, npts);
    uint32_t aut = check_index_levels(kind, VBI_VL_INDEX_LEVELS_AUTO, dev, c, r, nrm, n, pts, npts);
    uint32_t classes = check_index_levels(kind, VBI_VL_INDEX_LEVELS_CLASSES, dev, c, r, nrm, n, pts, npts);
    assert_int_equal(check_index_levels(kind, VBI_VL_INDEX_LEVELS_ONE, dev, c, r, nrm, n, pts, npts), 1);
    assert_true(aut == 1 || aut == classes);
    return aut;
}

static void test_index_brute_force(void **state)
{
    (void)state;
    enum { N = 3000, P = 20000 };
    vec3 *c = malloc(N * sizeof(vec3)), *pts = malloc(P * sizeof(vec3)), *nrm = malloc(N * sizeof(vec3));
    float *r = malloc(N * sizeof(float));
    vbi_rng rng = vbi_rng_make(11, 3);
    for (uint32_t j = 0; j < N; ++j) {
        c[j] = v3(vbi_rng_next(&rng) * 2 - 1, vbi_rng_next(&rng) * 2 - 1, vbi_rng_next(&rng) * 2 - 1);
        /* radii over a factor 16 (several grid levels), a few degenerate ones */
        r[j] = 0.03f * exp2f(4.0f * vbi_rng_next(&rng));
        nrm[j] = sample_uniform_sphere(vbi_rng_next2(&rng));
        if (j % 97 == 0)
            r[j] = (j % 2) ? 0.0f : -1.0f;
    }
    for (uint32_t k = 0; k < P; ++k) {
        if (k % 2) { /* right at a sphere's boundary: stresses the cell assignment */
            uint32_t j = vbi_rng_uniform_u32(&rng, N);
            vec3 w = sample_uniform_sphere(vbi_rng_next2(&rng));
            pts[k] = v3_fma(c[j], w, r[j] * (1.0f + (vbi_rng_next(&rng) - 0.5f) * 2e-6f));
        } else {
            pts[k] = v3(vbi_rng_next(&rng) * 2.4f - 1.2f, vbi_rng_next(&rng) * 2.4f - 1.2f,
                        vbi_rng_next(&rng) * 2.4f - 1.2f);
        }
    }
    RTCDevice dev = rtcNewDevice(NULL);
    /* radii over a factor 16: one level costs less than twice the classes' listings */
    assert_int_equal(check_index(VBI_VL_INDEX_GRID, NULL, c, r, nrm, N, pts, P), 1);
    check_index(VBI_VL_INDEX_EMBREE, dev, c, r, nrm, N, pts, P);
    /* one radius class (the pipelined single-level query) and three classes (pipelined, <= 4
     * levels; the set above has 5 and takes the plain path) */
    {
        float *r1 = malloc(N * sizeof(float)), *r3 = malloc(N * sizeof(float));
        for (uint32_t j = 0; j < N; ++j) {
            r1[j] = r[j] > 0.0f ? 0.12f : r[j];
            r3[j] = r[j] > 0.0f ? 0.05f * exp2f(2.0f * (float)(j % 11) / 11.0f) : r[j];
        }
        check_index(VBI_VL_INDEX_GRID, NULL, c, r1, nrm, N, pts, P);
        check_index(VBI_VL_INDEX_GRID, NULL, c, r3, nrm, N, pts, P);
        free(r1);
        free(r3);
    }
    /* a spread-out set forces the hashed grid (few spheres, huge box) */
    for (uint32_t j = 0; j < 200; ++j) {
        c[j] = v3_scale(c[j], 1000.0f);
        r[j] = 0.5f + (float)(j % 3);
        pts[2 * j + 1] = v3_fma(c[j], v3(0.3f, -0.2f, 0.1f), r[j]);
    }
    /* radii 0.5 to 2.5: one level with the cells of the most populated class would hold more
     * than twice the classes' listings, so AUTO keeps the classes */
    assert_true(check_index(VBI_VL_INDEX_GRID, NULL, c, r, nrm, 200, pts, 400) > 1);
    /* bad arguments */
    vbi_vl_index *x = (vbi_vl_index *)1;
    vbi_vl_index_desc bad = {c, r, NULL, N, VBI_VL_INDEX_EMBREE, 0.0f, NULL, VBI_VL_INDEX_LEVELS_AUTO};
    assert_int_equal(vbi_vl_index_create(&bad, &x), VBNL_ERR_INVALID_ARGUMENT);
    vbi_vl_index_desc bad_levels = {c, r, NULL, N, VBI_VL_INDEX_GRID, 0.0f, NULL, (vbi_vl_index_levels)3};
    assert_int_equal(vbi_vl_index_create(&bad_levels, &x), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(x);
    vbi_vl_index_destroy(NULL);
    rtcReleaseDevice(dev);
    free(c);
    free(r);
    free(nrm);
    free(pts);
}

/* ---- closed Lambertian sphere ------------------------------------------------------------- */

/* Fibonacci lattice of n points on the unit sphere. */
static vec3 fibonacci(uint32_t i, uint32_t n)
{
    float z = 1.0f - (2.0f * (float)i + 1.0f) / (float)n;
    float phi = (float)i * 2.39996322972865332f;
    float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    return v3(s * cosf(phi), s * sinf(phi), z);
}

static void sum_phi(const vbi_profile_set *s, uint64_t out[3])
{
    out[0] = out[1] = out[2] = 0;
    for (uint32_t v = 0; v < vbi_profile_set_count(s); ++v) {
        const uint64_t *q = vbi_profile_incident_power_fixed(s, v);
        for (int c = 0; c < 3; ++c)
            out[c] += q[c];
    }
}

/* Inside a sphere of radius R with albedo rho and two-sided emission Le, the radiance is
 * uniform, L = Le / (1 - rho), so the irradiance everywhere on the inner surface is
 * E = pi Le / (1 - rho) (emitted light included). VL j (Fibonacci lattice, normals inward,
 * r = 2 r_max of Eq. 1) receives Phi_in_j = E A_j in expectation, with A_j the integral of its
 * partition-of-unity weight over the surface, which is 4 pi R^2 / N up to the lattice's
 * irregularity (up to 3.6 % at N = 48, measured, hence A_j is computed by quadrature).
 * Asserted: (1) all but 1e-4 of the hits deposit (complete coverage); (2) sum of all VLs'
 * fixed-point Phi_in == the fixed-point sum of the covered hits' photon power, exactly;
 * (3) for every VL and channel |Phi_in_j / (E A_j) - 1| < 2 % with A_j by quadrature;
 * (4) the mean over VLs of Phi_in_j / (E 4 pi R^2 / N) is 1 within 0.5 % (global energy);
 * (5) every VL's outgoing radiance J_j / A_j (Lambertian kernel, profiles.h) is
 * rho Le / (1 - rho) within 2 %. */
static void test_closed_sphere(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(2);
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    const float R = 1.0f, Le = 2.0f;
    const vec3 rho = v3(0.5f, 0.3f, 0.7f);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = rho.x;
    md.base_color[1] = rho.y;
    md.base_color[2] = rho.z;
    md.emission[0] = md.emission[1] = md.emission[2] = Le;
    md.two_sided = 1;
    uint32_t mat;
    assert_int_equal(vbnl_scene_add_material(s, &md, &mat, NULL), VBNL_OK);
    const float zero[3] = {0, 0, 0};
    assert_int_equal(vbnl_scene_add_sphere(s, zero, R, mat, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    set_camera(s, 0.5f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);

    enum { N = 48 };
    const uint64_t paths = 1500000;
    vec3 c[N], n[N];
    float r[N];
    const double area = 4.0 * M_PI * R * R;
    const float r_vl = 2.0f * sqrtf((float)(area / (2.0 * sqrt(3.0) * N))); /* alpha_r r_max, Eq. 1 */
    for (uint32_t j = 0; j < N; ++j) {
        vec3 u = fibonacci(j, N);
        c[j] = v3_scale(u, R);
        n[j] = v3_neg(u);
        r[j] = r_vl;
    }
    vbi_vl_index_desc xd = {c, r, n, N, VBI_VL_INDEX_GRID, 0.0f, NULL, VBI_VL_INDEX_LEVELS_AUTO};
    vbi_vl_index *idx = NULL;
    assert_int_equal(vbi_vl_index_create(&xd, &idx), VBNL_OK);
    vbi_hemioct *map = NULL;
    assert_int_equal(vbi_hemioct_create(16, &map), VBNL_OK);
    vbi_profile_set *ps = NULL;
    assert_int_equal(vbi_profile_set_create_fixed(map, N, NULL, vbi_split_photon_unit(s, paths), &ps), VBNL_OK);

    vbi_split_desc d;
    vbi_split_desc_init(&d);
    d.scene = s;
    d.index = idx;
    d.vl_normals = n;
    d.profiles = ps;
    d.photon_paths = paths;
    d.seed = 1234;
    vbi_split_stats st;
    assert_int_equal(vbi_split_photons(&d, ctx->pool, NULL, &st), VBNL_OK);
    print_message("# closed sphere: %llu paths, %llu hits (%llu covered), %llu deposits, %.2f s, %.2f Mpaths/s\n",
                  (unsigned long long)st.paths, (unsigned long long)st.hits, (unsigned long long)st.covered_hits,
                  (unsigned long long)st.deposits, st.seconds, st.paths / st.seconds * 1e-6);
    assert_int_equal(st.paths, paths);
    /* Complete coverage; the only misses are grazing photons below a (tilted) VL's horizon,
     * dropped by the facing rule (about 2 per million hits). */
    assert_true(st.covered_hits >= st.hits - st.hits / 10000);
    assert_int_equal(st.overflow, 0);
    uint64_t sum[3];
    sum_phi(ps, sum);
    for (int ch = 0; ch < 3; ++ch)
        assert_true(sum[ch] == st.covered_power[ch]);

    vbi_bsdf lam = s->materials[mat].bsdf;
    vbi_profile_kernel *k = NULL;
    assert_int_equal(vbi_profile_kernel_create(map, &lam, 0, &k), VBNL_OK);
    double worst = 0.0, worst_L = 0.0, worst_eff = 0.0, worst_area = 0.0, mean[3] = {0, 0, 0};
    const double Aj = area / N;
    /* A_j by quadrature: the partition-of-unity weight of VL j integrated over the sphere
     * (the same selection as the splitting, facing aside), on a dense Fibonacci lattice. */
    static double aeff[N];
    memset(aeff, 0, sizeof(aeff));
    const uint32_t M = 400000;
    for (uint32_t i = 0; i < M; ++i) {
        vec3 p = v3_scale(fibonacci(i, M), R);
        uint32_t ids[64];
        float d2[64], w[64], sw = 0.0f;
        uint32_t m = vbi_vl_index_query(idx, p, 64, ids, d2);
        for (uint32_t q = 0; q < m; ++q) {
            w[q] = v3_dot(n[ids[q]], v3_neg(p)) > 0.7f ? 1.0f - d2[q] / (r_vl * r_vl) : 0.0f;
            sw += w[q];
        }
        for (uint32_t q = 0; q < m && sw > 0.0f; ++q)
            aeff[ids[q]] += w[q] / sw * area / M;
    }
    for (uint32_t j = 0; j < N; ++j) {
        vec3 phi = vbi_profile_incident_power(ps, j);
        vec3 J = vbi_profile_eval(ps, j, k, v3(0.3f, 0.2f, 0.9f));
        for (int ch = 0; ch < 3; ++ch) {
            double rc = v3_comp(rho, ch);
            double E = M_PI * Le / (1.0 - rc);
            double e1 = v3_comp(phi, ch) / (E * Aj) - 1.0;
            double e2 = v3_comp(J, ch) / aeff[j] / (rc * Le / (1.0 - rc)) - 1.0;
            worst = fmax(worst, fabs(e1));
            mean[ch] += v3_comp(phi, ch) / (E * Aj) / N;
            worst_eff = fmax(worst_eff, fabs(v3_comp(phi, ch) / (E * aeff[j]) - 1.0));
            worst_area = fmax(worst_area, fabs(aeff[j] / Aj - 1.0));
            worst_L = fmax(worst_L, fabs(e2));
        }
    }
    print_message("# closed sphere: worst |Phi_in / (E A_j) - 1| = %.4f, worst |J/A_j(quadrature) / (rho Le/(1-rho)) - 1| = %.4f "
                  "over %d VLs x 3 channels; against the quadrature A_j: %.4f; |A_j quadrature / (4 pi R^2 / N) - 1| <= %.4f\n",
                  worst, worst_L, N, worst_eff, worst_area);
    print_message("# closed sphere: mean Phi_in / (E 4 pi R^2 / N) = %.4f %.4f %.4f\n", mean[0], mean[1], mean[2]);
    assert_true(worst_eff < 0.02);
    assert_true(worst_L < 0.02);
    for (int ch = 0; ch < 3; ++ch)
        assert_true(fabs(mean[ch] - 1.0) < 0.005);
    vbi_profile_kernel_destroy(k);
    vbi_profile_set_destroy(ps);
    vbi_hemioct_destroy(map);
    vbi_vl_index_destroy(idx);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* ---- determinism and merging (Cornell-like box) ------------------------------------------- */

typedef struct vl_list {
    uint32_t n;
    vec3 c[4096], nrm[4096];
    float r[4096];
    uint8_t glossy[4096];
} vl_list;

/* VLs at the camera's primary hits (normal facing the camera), radius 2 r_max of Eq. 1. */
static void place_vls(const vbnl_scene *s, vl_list *v, uint32_t want, float area)
{
    vbi_rng rng = vbi_rng_make(77, 1);
    v->n = 0;
    float rad = 2.0f * sqrtf(area / (2.0f * sqrtf(3.0f) * (float)want));
    while (v->n < want) {
        vec3 o, d;
        vbi_camera_ray(&s->camera, 64, 64, vbi_rng_next(&rng) * 64, vbi_rng_next(&rng) * 64, &o, &d);
        vbi_hit h;
        if (!vbi_scene_intersect(s, o, d, INFINITY, &h) || vbi_bsdf_is_delta(&s->materials[h.material].bsdf))
            continue;
        vec3 nn = v3_dot(h.ng, d) > 0.0f ? v3_neg(h.ng) : h.ng;
        v->c[v->n] = h.p;
        v->nrm[v->n] = nn;
        v->r[v->n] = rad;
        v->glossy[v->n] = s->materials[h.material].bsdf.type != VBNL_MATERIAL_LAMBERT;
        v->n++;
    }
}

static int g_atomic_deposits; /* run_split_chunk: vbi_split_desc.atomic_deposits */
static int g_general_walk;    /* run_split_chunk: vbi_split_desc.general_walk */

static vbi_profile_set *run_split_chunk(const vbnl_scene *s, const vbi_vl_index *idx, const vl_list *v,
                                         const vbi_hemioct *map, double unit, vbi_pool *pool, uint64_t seed,
                                         uint64_t paths, uint64_t first, uint64_t count, uint32_t chunk,
                                         vbi_split_stats *st)
{
    vbi_profile_set *ps = NULL;
    assert_int_equal(vbi_profile_set_create_fixed(map, v->n, v->glossy, unit, &ps), VBNL_OK);
    vbi_split_desc d;
    vbi_split_desc_init(&d);
    d.scene = s;
    d.index = idx;
    d.vl_normals = v->nrm;
    d.profiles = ps;
    d.photon_paths = paths;
    d.first_path = first;
    d.path_count = count;
    d.seed = seed;
    d.chunk = chunk;
    d.atomic_deposits = g_atomic_deposits;
    d.general_walk = g_general_walk;
    assert_int_equal(vbi_split_photons(&d, pool, NULL, st), VBNL_OK);
    return ps;
}

static vbi_profile_set *run_split(const vbnl_scene *s, const vbi_vl_index *idx, const vl_list *v,
                                   const vbi_hemioct *map, double unit, vbi_pool *pool, uint64_t seed,
                                   uint64_t paths, uint64_t first, uint64_t count, vbi_split_stats *st)
{
    return run_split_chunk(s, idx, v, map, unit, pool, seed, paths, first, count, 1000, st);
}

static int sets_equal(const vbi_profile_set *a, const vbi_profile_set *b, uint32_t texels)
{
    for (uint32_t v = 0; v < vbi_profile_set_count(a); ++v) {
        if (memcmp(vbi_profile_incident_power_fixed(a, v), vbi_profile_incident_power_fixed(b, v), 24))
            return 0;
        const uint64_t *ma = vbi_profile_incident_map_fixed(a, v), *mb = vbi_profile_incident_map_fixed(b, v);
        if ((ma == NULL) != (mb == NULL) || (ma && memcmp(ma, mb, texels * 24u)))
            return 0;
    }
    return 1;
}

/* 3000 VLs placed from the camera of committed scene s (place_vls), their grid index, and a
 * 16 x 16 octahedral map in *map. */
static vbi_vl_index *place_and_index(const vbnl_scene *s, vl_list *v, vbi_hemioct **map)
{
    place_vls(s, v, 3000, 24.0f);
    vbi_vl_index_desc xd = {v->c, v->r, v->nrm, v->n, VBI_VL_INDEX_GRID, 0.0f, NULL, VBI_VL_INDEX_LEVELS_AUTO};
    vbi_vl_index *x = NULL;
    assert_int_equal(vbi_vl_index_create(&xd, &x), VBNL_OK);
    assert_int_equal(vbi_hemioct_create(16, map), VBNL_OK);
    return x;
}

static void test_determinism_and_merge(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(2);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    static vl_list v;
    vbi_hemioct *map = NULL;
    vbi_vl_index *idx = place_and_index(s, &v, &map);
    const uint32_t texels = vbi_hemioct_texel_count(map);
    const uint64_t P = 200000;
    double unit = vbi_split_photon_unit(s, P);
    vbi_pool *p1 = vbi_pool_create(1), *p2 = vbi_pool_create(2);
    vbi_split_stats s1, s2, sa, sb, sc;
    vbi_profile_set *one = run_split(s, idx, &v, map, unit, p1, 5, P, 0, 0, &s1);
    vbi_profile_set *two = run_split(s, idx, &v, map, unit, p2, 5, P, 0, 0, &s2);
    print_message("# box: %llu paths, %llu rays, %llu hits (%llu covered, %llu on delta), %llu deposits\n",
                  (unsigned long long)s1.paths, (unsigned long long)s1.rays, (unsigned long long)s1.hits,
                  (unsigned long long)s1.covered_hits, (unsigned long long)s1.delta_hits,
                  (unsigned long long)s1.deposits);
    assert_true(s1.covered_hits > s1.hits / 4 && s1.deposits > s1.covered_hits);
    /* 1 vs 2 threads: bit-identical incident data and statistics. */
    assert_true(sets_equal(one, two, texels));
    assert_memory_equal(s1.covered_power, s2.covered_power, sizeof(s1.covered_power));
    assert_int_equal(s1.deposits, s2.deposits);
    /* Work items of 7 paths (tiny batches) on 3 threads, and the default chunk (batches that fill
     * up within an item) with atomic deposits instead of per-thread sums: the same bits. */
    {
        vbi_pool *p3 = vbi_pool_create(3);
        vbi_split_stats s3, s4;
        vbi_profile_set *three = run_split_chunk(s, idx, &v, map, unit, p3, 5, P, 0, 0, 7, &s3);
        g_atomic_deposits = 1; /* the fallback without per-thread sums */
        vbi_profile_set *dflt = run_split_chunk(s, idx, &v, map, unit, p2, 5, P, 0, 0, 0, &s4);
        g_atomic_deposits = 0;
        assert_true(sets_equal(one, three, texels));
        assert_true(sets_equal(one, dflt, texels));
        assert_memory_equal(s1.covered_power, s3.covered_power, sizeof(s1.covered_power));
        assert_memory_equal(s1.covered_power, s4.covered_power, sizeof(s1.covered_power));
        assert_int_equal(s1.deposits, s3.deposits);
        assert_int_equal(s1.overflow, s4.overflow);
        vbi_profile_set_destroy(three);
        vbi_profile_set_destroy(dflt);
        vbi_pool_destroy(p3);
    }
    /* Every hit through the general walk instead of the SIMD step where it applies (Lambertian
     * mesh faces: here nearly all): the same paths, hits and bits. */
    {
        vbi_split_stats s5;
        g_general_walk = 1;
        vbi_profile_set *gen = run_split_chunk(s, idx, &v, map, unit, p2, 5, P, 0, 0, 0, &s5);
        g_general_walk = 0;
        print_message("# box: %llu of %llu hits in the SIMD step\n", (unsigned long long)s1.simd_hits,
                      (unsigned long long)s1.hits);
#if defined(__AVX2__)
        assert_true(s1.simd_hits > s1.hits / 2);
#endif
        assert_int_equal(s5.simd_hits, 0);
        assert_true(sets_equal(one, gen, texels));
        assert_memory_equal(s1.covered_power, s5.covered_power, sizeof(s1.covered_power));
        assert_int_equal(s1.rays, s5.rays);
        assert_int_equal(s1.hits, s5.hits);
        assert_int_equal(s1.deposits, s5.deposits);
        vbi_profile_set_destroy(gen);
    }
    /* Large shares: units 2^6 and 2^12 times finer than the default, so that the thread maps'
     * 32-bit texels wrap every few photons (the carry into the set's maps) and, at 2^12, shares
     * reach 2^31 (splitting.c: then the general splat form instead of the vector rows). The
     * private maps give the same bits as atomic splats into the set. */
    for (int fine = 6; fine <= 12; fine += 6) {
        vbi_split_stats s6, s7;
        const double u2 = ldexp(unit, -fine);
        vbi_profile_set *priv = run_split(s, idx, &v, map, u2, p2, 7, 40000, 0, 0, &s6);
        g_atomic_deposits = 1;
        vbi_profile_set *atom = run_split(s, idx, &v, map, u2, p2, 7, 40000, 0, 0, &s7);
        g_atomic_deposits = 0;
        assert_true(sets_equal(priv, atom, texels));
        assert_memory_equal(s6.covered_power, s7.covered_power, sizeof(s6.covered_power));
        vbi_profile_set_destroy(priv);
        vbi_profile_set_destroy(atom);
    }
    /* Exact bookkeeping: VL sums == covered photon power; each glossy map sums to its Phi_in. */
    uint64_t sum[3];
    sum_phi(one, sum);
    assert_memory_equal(sum, s1.covered_power, sizeof(sum));
    uint32_t n_glossy = 0;
    for (uint32_t j = 0; j < v.n; ++j) {
        const uint64_t *m = vbi_profile_incident_map_fixed(one, j);
        if (!m)
            continue;
        ++n_glossy;
        uint64_t t3[3] = {0, 0, 0};
        for (uint32_t t = 0; t < texels; ++t)
            for (int ch = 0; ch < 3; ++ch)
                t3[ch] += m[3 * t + ch];
        assert_memory_equal(t3, vbi_profile_incident_power_fixed(one, j), sizeof(t3));
    }
    assert_true(n_glossy > 100);
    /* Paths [0, 70000) and [70000, P) in two runs, merged: the same as one run. */
    vbi_profile_set *a = run_split(s, idx, &v, map, unit, p2, 5, P, 0, 70000, &sa);
    vbi_profile_set *b = run_split(s, idx, &v, map, unit, p1, 5, P, 70000, 0, &sb);
    assert_int_equal(sa.paths + sb.paths, P);
    assert_int_equal(vbi_profile_set_merge(a, b), VBNL_OK);
    assert_true(sets_equal(a, one, texels));
    /* A run with another seed merged into it: every integer is the sum of the two. */
    vbi_profile_set *c = run_split(s, idx, &v, map, unit, p2, 6, P, 0, 50000, &sc);
    assert_int_equal(vbi_profile_set_merge(c, a), VBNL_OK);
    {
        /* exact: merge(C, A) - A == C as run, cell by cell */
        vbi_split_stats sc2;
        vbi_profile_set *c_again = run_split(s, idx, &v, map, unit, p1, 6, P, 0, 50000, &sc2);
        for (uint32_t j = 0; j < v.n; ++j) {
            const uint64_t *qc = vbi_profile_incident_power_fixed(c, j), *qa = vbi_profile_incident_power_fixed(a, j),
                           *q0 = vbi_profile_incident_power_fixed(c_again, j);
            for (int ch = 0; ch < 3; ++ch)
                assert_true(qc[ch] == qa[ch] + q0[ch]);
            const uint64_t *mc = vbi_profile_incident_map_fixed(c, j), *ma = vbi_profile_incident_map_fixed(a, j),
                           *m0 = vbi_profile_incident_map_fixed(c_again, j);
            if (mc)
                for (uint32_t t = 0; t < 3 * texels; ++t)
                    assert_true(mc[t] == ma[t] + m0[t]);
        }
        vbi_profile_set_destroy(c_again);
    }
    /* mismatched sets are refused */
    vbi_profile_set *other = NULL;
    assert_int_equal(vbi_profile_set_create_fixed(map, v.n, v.glossy, unit * 2.0, &other), VBNL_OK);
    assert_int_equal(vbi_profile_set_merge(other, a), VBNL_ERR_INVALID_ARGUMENT);
    vbi_profile_set *bad = NULL;
    assert_int_equal(vbi_profile_set_create_fixed(map, 3, NULL, 3.0, &bad), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(bad);
    vbi_profile_set_destroy(other);
    vbi_profile_set_destroy(one);
    vbi_profile_set_destroy(two);
    vbi_profile_set_destroy(a);
    vbi_profile_set_destroy(b);
    vbi_profile_set_destroy(c);
    vbi_pool_destroy(p1);
    vbi_pool_destroy(p2);
    vbi_hemioct_destroy(map);
    vbi_vl_index_destroy(idx);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* ---- the SIMD step on shading normals ---------------------------------------------------- */

/* The box with a sphere mesh of material `type` (24 x 12 facets) whose vertex normals are the smooth
 * ones, every 7th reversed and every 5th tilted: interpolated normals that differ from the
 * facet's (adjoint correction) and that lie behind it (the facet normal turned to their side;
 * photons arriving behind the shading normal). Photon splitting through the SIMD step and through the
 * general walk alone: the same rays, hits and bits. */
static double simd_step_sphere(vbnl_material_type type, const char *name)
{
    vbnl_context *ctx = make_ctx(2);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    enum { NU = 24, NV = 12 };
    static float pos[(NU + 1) * (NV + 1) * 3], nrm[(NU + 1) * (NV + 1) * 3];
    static uint32_t idx[NU * NV * 6];
    const float c[3] = {-0.45f, 0.45f, 0.25f}, R = 0.35f;
    for (int j = 0, k = 0; j <= NV; ++j)
        for (int i = 0; i <= NU; ++i, ++k) {
            float th = VBI_PI * (float)j / NV, ph = 2.0f * VBI_PI * (float)i / NU;
            float n3[3] = {sinf(th) * cosf(ph), cosf(th), sinf(th) * sinf(ph)};
            float sg = k % 7 == 3 ? -1.0f : 1.0f, tilt = k % 5 == 1 ? 0.6f : 0.0f;
            for (int a = 0; a < 3; ++a) {
                pos[3 * k + a] = c[a] + R * n3[a];
                nrm[3 * k + a] = sg * n3[a] + (a == 0 ? tilt : 0.0f);
            }
        }
    uint32_t nt = 0;
    for (int j = 0; j < NV; ++j)
        for (int i = 0; i < NU; ++i) {
            uint32_t a = (uint32_t)(j * (NU + 1) + i), b = a + 1, d = a + NU + 1, e = d + 1;
            uint32_t t6[6] = {a, d, b, b, d, e};
            memcpy(idx + 3 * nt, t6, sizeof(t6));
            nt += 2;
        }
    vbnl_mesh_desc m;
    vbnl_mesh_desc_init(&m);
    m.positions = pos;
    m.normals = nrm;
    m.vertex_count = (NU + 1) * (NV + 1);
    m.indices = idx;
    m.triangle_count = nt;
    m.material = ts_material(s, type, 0.8f, 0.75f, 0.7f, 0.0f);
    assert_int_equal(vbnl_scene_add_mesh(s, &m, NULL, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    static vl_list v;
    vbi_hemioct *map = NULL;
    vbi_vl_index *x = place_and_index(s, &v, &map);
    const uint64_t P = 100000;
    const double unit = vbi_split_photon_unit(s, P);
    vbi_pool *pool = vbi_pool_create(2);
    vbi_split_stats sa, sb;
    vbi_profile_set *a = run_split_chunk(s, x, &v, map, unit, pool, 9, P, 0, 0, 0, &sa);
    g_general_walk = 1;
    vbi_profile_set *b = run_split_chunk(s, x, &v, map, unit, pool, 9, P, 0, 0, 0, &sb);
    g_general_walk = 0;
    print_message("# shaded %s sphere: %llu of %llu hits in the SIMD step, %llu covered\n", name,
                  (unsigned long long)sa.simd_hits, (unsigned long long)sa.hits, (unsigned long long)sa.covered_hits);
#if defined(__AVX2__)
    assert_true(sa.simd_hits > sa.hits / 2);
#endif
    assert_int_equal(sb.simd_hits, 0);
    assert_int_equal(sa.rays, sb.rays);
    assert_int_equal(sa.hits, sb.hits);
    assert_int_equal(sa.deposits, sb.deposits);
    assert_memory_equal(sa.covered_power, sb.covered_power, sizeof(sa.covered_power));
    assert_true(sets_equal(a, b, vbi_hemioct_texel_count(map)));
    vbi_profile_set_destroy(a);
    vbi_profile_set_destroy(b);
    vbi_pool_destroy(pool);
    vbi_hemioct_destroy(map);
    vbi_vl_index_destroy(x);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
    return (double)(sa.hits - sa.simd_hits) / (double)sa.hits; /* the general walk's share */
}

/* The SIMD step (step_fast) against the general walk on a sphere mesh whose vertex normals are
 * partly reversed and tilted (shading normals, their flips and the adjoint correction), for a
 * Lambertian sphere and for the BSDFs the step samples one lane at a time (plastic, conductor):
 * the same rays, hits, deposits and light sums, bit for bit. */
static void test_simd_step_shading_normals(void **state)
{
    (void)state;
    /* The general walk takes only the light's hits (its surface is black) in every case: the
     * sphere's hits take the step whatever its BSDF. */
    double lambert = simd_step_sphere(VBNL_MATERIAL_LAMBERT, "Lambertian");
    double plastic = simd_step_sphere(VBNL_MATERIAL_PLASTIC, "plastic");
    double conductor = simd_step_sphere(VBNL_MATERIAL_CONDUCTOR, "conductor");
    print_message("# general walk's share of the hits: %.4f, %.4f, %.4f\n", lambert, plastic, conductor);
#if defined(__AVX2__)
    assert_true(plastic < lambert + 0.01);
    assert_true(conductor < lambert + 0.01);
#endif
}

/* ---- glossy VL under a small area light --------------------------------------------------- */

/* A black floor (no bounces) and a 0.1 x 0.1 light at height 1, offset by 0.5 in x; one glossy
 * VL at the origin (normal up, r = 0.2, alone: its partition-of-unity weight is 1 on its
 * disk). Asserted: the power-weighted mean incident direction is within 3 degrees of the light
 * centre; >= 95 % of the power lies in texels within 15 degrees of it; the total incident power
 * matches the direct irradiance integrated over the disk (quadrature) within 2 %. */
static void test_glossy_directions(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(2);
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    uint32_t black = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.0f, 0.0f, 0.0f, 0.0f);
    const float floor_[12] = {-3, 0, -3, -3, 0, 3, 3, 0, 3, 3, 0, -3};
    ts_quad(s, floor_, black);
    vbnl_area_light_desc al;
    vbnl_area_light_desc_init(&al);
    const float corner[3] = {0.45f, 1.0f, -0.05f}, eu[3] = {0.1f, 0, 0}, ev[3] = {0, 0, 0.1f};
    const float Le = 50.0f;
    memcpy(al.corner, corner, sizeof(corner));
    memcpy(al.edge_u, eu, sizeof(eu));
    memcpy(al.edge_v, ev, sizeof(ev)); /* cross(eu, ev) = -y: facing the floor */
    al.radiance[0] = al.radiance[1] = al.radiance[2] = Le;
    assert_int_equal(vbnl_scene_add_area_light(s, &al, NULL, NULL), VBNL_OK);
    set_camera(s, 2.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);

    vec3 c = v3(0, 0, 0), nrm = v3(0, 1, 0);
    float r = 0.2f;
    uint8_t glossy = 1;
    vbi_vl_index_desc xd = {&c, &r, &nrm, 1, VBI_VL_INDEX_EMBREE, 0.0f, ctx->device, VBI_VL_INDEX_LEVELS_AUTO};
    vbi_vl_index *idx = NULL;
    assert_int_equal(vbi_vl_index_create(&xd, &idx), VBNL_OK);
    vbi_hemioct *map = NULL;
    assert_int_equal(vbi_hemioct_create(16, &map), VBNL_OK);
    const uint64_t P = 1000000;
    vbi_profile_set *ps = NULL;
    assert_int_equal(vbi_profile_set_create_fixed(map, 1, &glossy, vbi_split_photon_unit(s, P), &ps), VBNL_OK);
    vbi_split_desc d;
    vbi_split_desc_init(&d);
    d.scene = s;
    d.index = idx;
    d.vl_normals = &nrm;
    d.profiles = ps;
    d.photon_paths = P;
    d.seed = 9;
    vbi_split_stats st;
    assert_int_equal(vbi_split_photons(&d, ctx->pool, NULL, &st), VBNL_OK);

    frame f = frame_from_normal(nrm);
    vec3 to_light = frame_to_local(&f, v3_norm(v3(0.5f, 1.0f, 0.0f)));
    uint32_t texels = vbi_hemioct_texel_count(map);
    vec3 mean = v3s(0.0f);
    double total = 0.0, near = 0.0;
    for (uint32_t t = 0; t < texels; ++t) {
        double p = vbi_profile_incident_texel(ps, 0, t).x;
        vec3 w = vbi_hemioct_texel_dir(map, t);
        mean = v3_fma(mean, w, (float)p);
        total += p;
        if (v3_dot(w, to_light) > cosf(15.0f * (float)M_PI / 180.0f))
            near += p;
    }
    float ang = acosf(fminf(1.0f, v3_dot(v3_norm(mean), to_light))) * 180.0f / (float)M_PI;
    /* Reference: integral over the disk of the direct irradiance from the light (midpoint rule). */
    double ref = 0.0;
    const int gd = 60, gl = 8;
    for (int i = 0; i < gd; ++i)
        for (int j = 0; j < gd; ++j) {
            double x = -r + (i + 0.5) * 2.0 * r / gd, z = -r + (j + 0.5) * 2.0 * r / gd;
            if (x * x + z * z >= (double)r * r)
                continue;
            double E = 0.0;
            for (int a = 0; a < gl; ++a)
                for (int b = 0; b < gl; ++b) {
                    double lx = 0.45 + (a + 0.5) * 0.1 / gl, lz = -0.05 + (b + 0.5) * 0.1 / gl;
                    double dx = lx - x, dy = 1.0, dz = lz - z, d2 = dx * dx + dy * dy + dz * dz;
                    E += Le * (dy / sqrt(d2)) * (dy / sqrt(d2)) / d2 * (0.01 / (gl * gl));
                }
            ref += E * (2.0 * r / gd) * (2.0 * r / gd);
        }
    double phi = vbi_profile_incident_power(ps, 0).x;
    print_message("# glossy VL: mean direction %.2f deg from the light, %.4f of the power within 15 deg, "
                  "Phi_in %.5f vs %.5f (quadrature)\n", ang, near / total, phi, ref);
    assert_true(ang < 3.0f);
    assert_true(near / total > 0.95);
    assert_true(fabs(phi / ref - 1.0) < 0.02);
    assert_true(fabs(total / phi - 1.0) < 1e-5);
    vbi_profile_set_destroy(ps);
    vbi_hemioct_destroy(map);
    vbi_vl_index_destroy(idx);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* vbi_vl_key_bin (photon splitting's inline bins) equals the top bits of the spatial key,
 * also for points outside the key cube (clamped) and NaN. */
static void test_key_bin(void **state)
{
    (void)state;
    enum { N = 500 };
    vec3 c[N];
    float r[N];
    vbi_rng rng = vbi_rng_make(5, 9);
    for (uint32_t j = 0; j < N; ++j) {
        c[j] = v3(vbi_rng_next(&rng) * 3 - 1, vbi_rng_next(&rng) * 2, vbi_rng_next(&rng) - 4);
        r[j] = 0.05f;
    }
    vbi_vl_index_desc xd = {c, r, NULL, N, VBI_VL_INDEX_GRID, 0.0f, NULL, VBI_VL_INDEX_LEVELS_AUTO};
    vbi_vl_index *idx = NULL;
    assert_int_equal(vbi_vl_index_create(&xd, &idx), VBNL_OK);
    vbi_vl_key_grid g = vbi_vl_index_key_grid(idx);
    for (uint32_t k = 0; k < 20000; ++k) {
        vec3 p = v3(vbi_rng_next(&rng) * 5 - 2, vbi_rng_next(&rng) * 4 - 1, vbi_rng_next(&rng) * 3 - 5);
        if (k == 0)
            p.x = NAN;
        uint64_t key = vbi_vl_index_spatial_key(idx, p);
        for (unsigned b = 1; b <= 8; ++b)
            assert_int_equal(vbi_vl_key_bin(&g, p, b), key >> (63 - 3 * b));
    }
    vbi_vl_index_destroy(idx);
}

/* The rule for the private 32-bit glossy maps: none without maps, threads x half the maps
 * within the budget, none (the atomic path) beyond it; and the rule for hit batches. */
static void test_map_copy_rule(void **state)
{
    (void)state;
    /* a 32-bit map (half the set's 64-bit maps) per thread */
    assert_int_equal(vbi_split_map_copy_bytes(1000, 0), 0);
    assert_int_equal(vbi_split_map_copy_bytes(0, 8), 0);
    assert_int_equal(vbi_split_map_copy_bytes(1000, 1), 500);
    assert_int_equal(vbi_split_map_copy_bytes(1000, 2), 1000);
    assert_int_equal(vbi_split_map_copy_bytes(1000, 4), 2000);
    const uint64_t budget = VBI_SPLIT_MAX_MAP_COPY_BYTES;
    const double phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
    if (phys >= 8.0 * (double)budget) /* else the eighth of memory is the smaller cap */
        assert_int_equal(vbi_split_map_copy_bytes(budget, 2), budget); /* exactly the budget */
    assert_int_equal(vbi_split_map_copy_bytes(budget + 2, 2), 0);       /* two bytes over */
    assert_int_equal(vbi_split_map_copy_bytes(budget, 33), 0);
    /* hit batches: the largest while all threads' fit the budget, then fewer, never below the
     * minimum */
    assert_int_equal(vbi_split_batch_hits(0), VBI_SPLIT_BATCH_HITS);
    assert_int_equal(vbi_split_batch_hits(1), VBI_SPLIT_BATCH_HITS);
    assert_int_equal(vbi_split_batch_hits(4096), VBI_SPLIT_BATCH_HITS_MIN);
    for (unsigned th = 1; th <= 64; ++th) {
        uint32_t h = vbi_split_batch_hits(th);
        assert_true(h >= VBI_SPLIT_BATCH_HITS_MIN && h <= VBI_SPLIT_BATCH_HITS);
        if (h > VBI_SPLIT_BATCH_HITS_MIN)
            assert_true((uint64_t)th * vbi_split_batch_bytes(h) <= VBI_SPLIT_MAX_BATCH_BYTES);
        if (h < VBI_SPLIT_BATCH_HITS) /* 1024 more would not have fitted */
            assert_true((uint64_t)th * vbi_split_batch_bytes(h + 1024u) > VBI_SPLIT_MAX_BATCH_BYTES);
    }
}

/* photon_fast.h's inline intersection fills the same hit as vbi_scene_intersect (meshes inline,
 * the sphere and the area light through the general call). */
static void test_photon_fast(void **state)
{
    (void)state;
    vbnl_context *ctx = make_ctx(1);
    vbnl_scene *s = ts_box_scene(ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    vbi_rng rng = vbi_rng_make(17, 1);
    uint32_t hits = 0, spheres = 0;
    for (uint32_t k = 0; k < 200000; ++k) {
        vec3 o = v3(vbi_rng_next(&rng) * 1.8f - 0.9f, vbi_rng_next(&rng) * 1.8f + 0.1f, vbi_rng_next(&rng) * 1.8f - 0.9f);
        vec3 d = sample_uniform_sphere(vbi_rng_next2(&rng));
        vbi_hit a, b;
        memset(&a, 0, sizeof a);
        memset(&b, 0, sizeof b);
        int ha = vbi_scene_intersect(s, o, d, INFINITY, &a), hb = vbi_photon_intersect(s, o, d, &b);
        assert_int_equal(ha, hb);
        if (ha) {
            assert_memory_equal(&a, &b, sizeof a);
            hits++;
            spheres += (uint32_t)(a.material == b.material && v3_len2(v3_sub(a.p, v3(0.3f, 0.4f, -0.3f))) < 0.17f);
        }
    }
    assert_true(hits > 150000 && spheres > 1000);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_index_brute_force),
        cmocka_unit_test(test_key_bin),
        cmocka_unit_test(test_photon_fast),
        cmocka_unit_test(test_map_copy_rule),
        cmocka_unit_test(test_closed_sphere),
        cmocka_unit_test(test_determinism_and_merge),
        cmocka_unit_test(test_simd_step_shading_normals),
        cmocka_unit_test(test_glossy_directions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
