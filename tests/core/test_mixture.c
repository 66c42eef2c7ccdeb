/* Materials chosen per point (core/src/texture/material.c) and perturbed normals in rendering:
 * - the directions a mixed material samples at one point, over many hits there, follow the
 *   mixture sum_i p_i pdf_i (chi-square), for a texture map and for layers;
 * - the colour a hit carries averages to the mixture's colour;
 * - furnace: inside a closed emitting sphere whose material is an average, layers or a map of
 *   materials, path and vbnl reach L = Le / (1 - albedo);
 * - path and vbnl agree on the image mean of a room with a textured, bumped and mixed floor;
 * - a bumped material's BSDF carries the perturbed normal on the hit's side of the surface. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf.h"
#include "chi2.h"
#include "rng.h"
#include "scene_internal.h"
#include "scenes.h"
#include "ts_render.h"
#include "vbnl/vbnl.h"

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

static uint32_t plain(vbnl_scene *s, vbnl_material_type type, float r, float g, float b, float alpha)
{
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.type = type;
    md.base_color[0] = r;
    md.base_color[1] = g;
    md.base_color[2] = b;
    md.alpha = alpha;
    uint32_t id;
    vbnl_error err = {0};
    if (vbnl_scene_add_material(s, &md, &id, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    return id;
}

static uint32_t pattern(vbnl_scene *s, vbnl_pattern_kind kind, double scale)
{
    vbnl_pattern_desc pd;
    vbnl_pattern_desc_init(&pd);
    pd.kind = kind;
    pd.gradient.direction[0] = 1.0;
    pd.gradient.direction[1] = pd.gradient.direction[2] = 0.0;
    for (int i = 0; i < 3; ++i)
        pd.transform[5 * i] = 1.0 / scale;
    uint32_t id;
    vbnl_error err = {0};
    if (vbnl_scene_add_pattern(s, &pd, &id, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    return id;
}

static uint32_t node(vbnl_scene *s, const vbnl_material_node_desc *nd)
{
    uint32_t id;
    vbnl_error err = {0};
    if (vbnl_scene_add_material_node(s, nd, &id, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    return id;
}

static uint32_t solid_pigment(vbnl_scene *s, float r, float g, float b, float f, float t)
{
    vbnl_pigment_desc pd;
    vbnl_pigment_desc_init(&pd);
    const float c[5] = {r, g, b, f, t};
    memcpy(pd.color, c, sizeof(c));
    uint32_t id;
    vbnl_error err = {0};
    if (vbnl_scene_add_pigment(s, &pd, &id, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    return id;
}

/* A TEXTURED node: `leaf` coloured by a solid pigment (r, g, b, f, t). */
static uint32_t textured(vbnl_scene *s, uint32_t leaf, float r, float g, float b, float f, float t)
{
    vbnl_material_node_desc nd;
    vbnl_material_node_desc_init(&nd);
    nd.kind = VBNL_NODE_TEXTURED;
    nd.material = leaf;
    nd.pigment = solid_pigment(s, r, g, b, f, t) + 1;
    return node(s, &nd);
}

static vbi_hit hit_at(uint32_t material, vec3 p, vec3 n, uint32_t seed)
{
    vbi_hit h;
    memset(&h, 0, sizeof(h));
    h.p = p;
    h.ng = h.ns = n;
    h.material = material;
    h.prim = seed;
    h.geom = 3;
    return h;
}

/* ---- chi-square of the directions a mixture samples ----------------------------------------- */

#define MIX_MAX 4
typedef struct mixture {
    const vbi_bsdf *bsdf[MIX_MAX];
    double p[MIX_MAX];
    int n;
    vec3 wo;
} mixture;

static double mixture_pdf(void *ctx, double z, double phi)
{
    const mixture *m = ctx;
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    vec3 wi = v3((float)(r * cos(phi)), (float)(r * sin(phi)), (float)z);
    double pdf = 0.0;
    for (int i = 0; i < m->n; ++i)
        pdf += m->p[i] * (double)vbi_bsdf_pdf(m->bsdf[i], m->wo, wi);
    return pdf;
}

/* Samples `count` directions from the BSDF resolved at p over as many hit seeds and tests them
 * against the mixture m; returns the mean colour the hits carried. */
static vec3 check_mixture(const vbnl_scene *s, uint32_t material, vec3 p, mixture *m, const char *what)
{
    enum { COUNT = 400000 };
    const vbi_chi2_grid grid = {12, 24, 0.0};
    const int nb = vbi_chi2_grid_bins(&grid);
    double *obs = calloc((size_t)nb, sizeof(double)), *exp_ = calloc((size_t)nb, sizeof(double));
    assert_non_null(obs);
    assert_non_null(exp_);
    vbi_rng rng = vbi_rng_make(11, 3);
    double col[3] = {0, 0, 0};
    for (uint32_t k = 0; k < COUNT; ++k) {
        vbi_hit h = hit_at(material, p, v3(0, 0, 1), k);
        vbi_bsdf storage;
        const vbi_bsdf *b = vbi_surface_bsdf(s, &h, &storage);
        col[0] += b->color.x;
        col[1] += b->color.y;
        col[2] += b->color.z;
        vbi_bsdf_sample_rec rec;
        if (!vbi_bsdf_sample(b, m->wo, vbi_rng_next2(&rng), &rec))
            continue;
        obs[vbi_chi2_grid_bin(&grid, rec.wi.z, atan2(rec.wi.y, rec.wi.x))] += 1.0;
    }
    vbi_chi2_grid_integrate(&grid, mixture_pdf, m, 8, COUNT, exp_);
    vbi_chi2_result res;
    int ok = vbi_chi2_test(obs, exp_, nb, 5.0, 0.01 / 2.0, &res);
    print_message("# %s: %s\n", what, res.msg);
    free(obs);
    free(exp_);
    assert_true(ok);
    return v3((float)(col[0] / COUNT), (float)(col[1] / COUNT), (float)(col[2] / COUNT));
}

static void expect_near(vec3 got, double r, double g, double b, double tol, const char *what)
{
    if (fabs(got.x - r) > tol || fabs(got.y - g) > tol || fabs(got.z - b) > tol)
        fail_msg("%s: (%g %g %g), expected (%g %g %g)", what, got.x, got.y, got.z, r, g, b);
}

/* A texture map blends its two entries by the pattern's fraction: at x = 0.3 of a gradient,
 * 0.7 of a Lambertian and 0.3 of a rough conductor. */
static void test_chi2_map(void **state)
{
    fixture *f = *state;
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(f->ctx, &s, NULL), VBNL_OK);
    uint32_t lam = plain(s, VBNL_MATERIAL_LAMBERT, 0.8f, 0.4f, 0.2f, 0.1f);
    uint32_t con = plain(s, VBNL_MATERIAL_CONDUCTOR, 0.9f, 0.9f, 0.9f, 0.3f);
    const vbnl_material_map_entry map[2] = {{0.0f, lam}, {1.0f, con}};
    vbnl_material_node_desc nd;
    vbnl_material_node_desc_init(&nd);
    nd.kind = VBNL_NODE_MAP;
    nd.pattern = pattern(s, VBNL_PATTERN_GRADIENT, 1.0) + 1;
    nd.map = map;
    nd.map_count = 2;
    uint32_t m = node(s, &nd);
    assert_int_equal(vbi_texture_commit(s, NULL), VBNL_OK);
    const float theta = 0.7f;
    mixture mx = {{&s->materials[lam].bsdf, &s->materials[con].bsdf}, {0.7, 0.3}, 2, v3(sinf(theta), 0, cosf(theta))};
    vec3 c = check_mixture(s, m, v3(0.3f, 0.1f, 0.2f), &mx, "texture map (0.7 Lambert, 0.3 conductor)");
    expect_near(c, 0.7 * 0.8 + 0.3 * 0.9, 0.7 * 0.4 + 0.3 * 0.9, 0.7 * 0.2 + 0.3 * 0.9, 0.005, "map colour");
    vbnl_scene_destroy(s);
}

/* Layers: a white Lambertian top layer that transmits 0.6 over a plastic bottom layer: weights
 * 0.4 and 0.6 (POV-Ray's (1 - f - t) and the product of what the layers above pass). */
static void test_chi2_layers(void **state)
{
    fixture *f = *state;
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(f->ctx, &s, NULL), VBNL_OK);
    uint32_t lam = plain(s, VBNL_MATERIAL_LAMBERT, 1, 1, 1, 0.1f);
    uint32_t pla = plain(s, VBNL_MATERIAL_PLASTIC, 0.2f, 0.5f, 0.2f, 0.2f);
    uint32_t top = textured(s, lam, 1, 1, 1, 0, 0.6f);
    const uint32_t layers[2] = {top, pla};
    vbnl_material_node_desc nd;
    vbnl_material_node_desc_init(&nd);
    nd.kind = VBNL_NODE_LAYERS;
    nd.layers = layers;
    nd.layer_count = 2;
    uint32_t m = node(s, &nd);
    assert_int_equal(vbi_texture_commit(s, NULL), VBNL_OK);
    const float theta = 1.1f;
    mixture mx = {{&s->materials[lam].bsdf, &s->materials[pla].bsdf}, {0.4, 0.6}, 2, v3(0, sinf(theta), cosf(theta))};
    vec3 c = check_mixture(s, m, v3(0.3f, 0.1f, 0.2f), &mx, "layers (0.4 Lambert, 0.6 plastic)");
    expect_near(c, 0.4 + 0.6 * 0.2, 0.4 + 0.6 * 0.5, 0.4 + 0.6 * 0.2, 0.005, "layer colour");
    vbnl_scene_destroy(s);
}

/* ---- furnace ---------------------------------------------------------------------------------- */

/* The mean radiance seen from inside a closed sphere of radius 2 whose material is m (emitting
 * 1 on both sides). */
static double furnace_mean(vbnl_context *ctx, vbnl_scene *s, uint32_t m, const char *integrator)
{
    float c[3] = {0, 0, 0};
    assert_int_equal(vbnl_scene_add_sphere(s, c, 2.0f, m, VBNL_GROUP_WORLD, NULL, NULL), VBNL_OK);
    float pos[3] = {0.3f, -0.2f, 0.5f}, target[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 90.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    const char *const vbnl_settings[] = {"virtual_lights=3000", "photon_paths=400000", NULL};
    const int is_vbnl = !strcmp(integrator, "vbnl");
    float *px = ts_render(ctx, s, integrator, 24, 24, is_vbnl ? 32 : 128, 5, is_vbnl ? vbnl_settings : NULL);
    double mean = 0.0;
    for (int i = 0; i < 24 * 24; ++i)
        mean += (px[4 * i] + px[4 * i + 1] + px[4 * i + 2]) / (3.0 * 24 * 24);
    free(px);
    return mean;
}

typedef enum { FURNACE_AVERAGE, FURNACE_LAYERS, FURNACE_MAP } furnace_kind;

/* The material of each furnace; *albedo receives its albedo (the same in every direction). With
 * `mirror` one member of the average and the map is a white mirror, else a Lambertian. */
static uint32_t furnace_material(vbnl_scene *s, furnace_kind kind, int mirror, double *albedo)
{
    vbnl_material_node_desc nd;
    vbnl_material_node_desc_init(&nd);
    nd.emission[0] = nd.emission[1] = nd.emission[2] = 1.0f;
    nd.two_sided = 1;
    const vbnl_material_type other = mirror ? VBNL_MATERIAL_MIRROR : VBNL_MATERIAL_LAMBERT;
    switch (kind) {
    case FURNACE_AVERAGE: { /* 0.4 of a white member, 0.6 of a Lambertian 0.5: albedo 0.7 */
        uint32_t a = plain(s, other, 1, 1, 1, 0.1f);
        uint32_t lam = plain(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 0.1f);
        static vbnl_material_map_entry e[2];
        e[0] = (vbnl_material_map_entry){0.4f, a};
        e[1] = (vbnl_material_map_entry){0.6f, lam};
        nd.kind = VBNL_NODE_AVERAGE;
        nd.map = e;
        nd.map_count = 2;
        *albedo = 0.7;
        break;
    }
    case FURNACE_LAYERS: { /* top: white Lambertian (colour 0.5), transmit 0.5; below: Lambertian 0.5 */
        uint32_t white = plain(s, VBNL_MATERIAL_LAMBERT, 1, 1, 1, 0.1f);
        uint32_t lam = plain(s, VBNL_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f, 0.1f);
        static uint32_t layers[2];
        layers[0] = textured(s, white, 0.5f, 0.5f, 0.5f, 0, 0.5f);
        layers[1] = lam;
        nd.kind = VBNL_NODE_LAYERS;
        nd.layers = layers;
        nd.layer_count = 2;
        *albedo = 0.5 * 0.5 + 0.5 * 0.5;
        break;
    }
    case FURNACE_MAP: { /* a checker of two members of albedo 0.6 */
        uint32_t a = plain(s, other, 0.6f, 0.6f, 0.6f, 0.1f);
        uint32_t lam = plain(s, VBNL_MATERIAL_LAMBERT, 0.6f, 0.6f, 0.6f, 0.1f);
        static vbnl_material_map_entry e[2];
        e[0] = (vbnl_material_map_entry){0.0f, a};
        e[1] = (vbnl_material_map_entry){1.0f, lam};
        nd.kind = VBNL_NODE_MAP;
        nd.pattern = pattern(s, VBNL_PATTERN_CHECKER, 0.5) + 1;
        nd.map = e;
        nd.map_count = 2;
        *albedo = 0.6;
        break;
    }
    }
    return node(s, &nd);
}

static void test_furnace(void **state)
{
    fixture *f = *state;
    const char *names[3] = {"average", "layers (transmitting top)", "checker map"};
    const char *integrators[2] = {"path", "vbnl"};
    for (int k = 0; k < 3; ++k)
        for (int i = 0; i < 4; ++i) {
            /* path and vbnl, with a mirror member (i = 0, 3) and with Lambertian members */
            if (k == FURNACE_LAYERS && (i == 0 || i == 3))
                continue; /* no mirror in the layers */
            const int mirror = i == 0 || i == 3;
            const char *integrator = integrators[i >= 2];
            vbnl_scene *s = NULL;
            assert_int_equal(vbnl_scene_create(f->ctx, &s, NULL), VBNL_OK);
            double albedo;
            uint32_t m = furnace_material(s, (furnace_kind)k, mirror, &albedo);
            double mean = furnace_mean(f->ctx, s, m, integrator);
            double expected = 1.0 / (1.0 - albedo);
            print_message("# furnace, %s%s, %s: mean %.4f, expected %.4f (%+.2f%%)\n", names[k],
                          mirror ? " with a mirror" : "", integrator, mean, expected, 100.0 * (mean / expected - 1.0));
            /* vbnl's lights near the border of a checker's mirror cell take the photons of the
             * cell's edge (nothing else there does): measured +3.4% */
            const double tol = mirror && k == FURNACE_MAP && i == 3 ? 0.05 : 0.02;
            assert_true(fabs(mean / expected - 1.0) < tol);
            vbnl_scene_destroy(s);
        }
}

/* ---- path and vbnl on a textured, bumped, mixed room ----------------------------------------- */

static vbnl_scene *mixed_room(vbnl_context *ctx)
{
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    /* floor: a checker of (a red/green gradient-coloured Lambertian with bumps) and a rough plastic */
    uint32_t leaf = plain(s, VBNL_MATERIAL_LAMBERT, 1, 1, 1, 0.1f);
    vbnl_pigment_desc pg;
    vbnl_pigment_desc_init(&pg);
    pg.kind = VBNL_PIGMENT_MAP;
    pg.pattern = pattern(s, VBNL_PATTERN_GRADIENT, 0.7) + 1;
    const vbnl_pigment_map_entry pm[2] = {{0.0f, {0.8f, 0.1f, 0.1f, 0, 0}, 0}, {1.0f, {0.1f, 0.7f, 0.1f, 0, 0}, 0}};
    pg.map = pm;
    pg.map_count = 2;
    uint32_t pig;
    assert_int_equal(vbnl_scene_add_pigment(s, &pg, &pig, NULL), VBNL_OK);
    vbnl_normal_desc nm;
    vbnl_normal_desc_init(&nm);
    nm.pattern = pattern(s, VBNL_PATTERN_BUMPS, 0.2) + 1;
    nm.amount = 0.8f;
    uint32_t nrm;
    assert_int_equal(vbnl_scene_add_normal(s, &nm, &nrm, NULL), VBNL_OK);
    vbnl_material_node_desc nd;
    vbnl_material_node_desc_init(&nd);
    nd.kind = VBNL_NODE_TEXTURED;
    nd.material = leaf;
    nd.pigment = pig + 1;
    nd.normal = nrm + 1;
    uint32_t bumpy = node(s, &nd);
    uint32_t plastic = plain(s, VBNL_MATERIAL_PLASTIC, 0.3f, 0.3f, 0.6f, 0.3f);
    const vbnl_material_map_entry checker[2] = {{0.0f, bumpy}, {1.0f, plastic}};
    vbnl_material_node_desc_init(&nd);
    nd.kind = VBNL_NODE_MAP;
    nd.pattern = pattern(s, VBNL_PATTERN_CHECKER, 0.5) + 1;
    nd.map = checker;
    nd.map_count = 2;
    uint32_t floor_m = node(s, &nd);
    /* back wall: layers, a white top transmitting 0.5 over a Lambertian blue */
    uint32_t white = plain(s, VBNL_MATERIAL_LAMBERT, 1, 1, 1, 0.1f);
    uint32_t blue = plain(s, VBNL_MATERIAL_LAMBERT, 0.2f, 0.3f, 0.8f, 0.1f);
    const uint32_t layers[2] = {textured(s, white, 0.8f, 0.8f, 0.8f, 0, 0.5f), blue};
    vbnl_material_node_desc_init(&nd);
    nd.kind = VBNL_NODE_LAYERS;
    nd.layers = layers;
    nd.layer_count = 2;
    uint32_t back_m = node(s, &nd);
    uint32_t wall = ts_material(s, VBNL_MATERIAL_LAMBERT, 0.7f, 0.7f, 0.7f, 0.0f);
    const uint32_t walls[6] = {floor_m, wall, back_m, wall, wall, wall};
    ts_room_walls(s, walls);
    const float le[3] = {10.0f, 10.0f, 10.0f};
    ts_room_light(s, le);
    const float pos[3] = {0, 1.2f, 0.95f}, target[3] = {0, 0.5f, -1}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 70.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    return s;
}

static void image_mean(const float *px, int n, double mean[3])
{
    mean[0] = mean[1] = mean[2] = 0.0;
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            mean[c] += px[4 * i + c] / (double)n;
}

static void test_path_vs_vbnl(void **state)
{
    fixture *f = *state;
    vbnl_scene *s = mixed_room(f->ctx);
    const int w = 32, h = 32;
    double ref[3], got[3];
    float *a = ts_render(f->ctx, s, "path", w, h, 1024, 3, NULL);
    image_mean(a, w * h, ref);
    const char *const settings[] = {"virtual_lights=8000", "photon_paths=800000", NULL};
    float *b = ts_render(f->ctx, s, "vbnl", w, h, 64, 3, settings);
    image_mean(b, w * h, got);
    print_message("# mixed room means: path (%.4f %.4f %.4f), vbnl (%.4f %.4f %.4f)\n", ref[0], ref[1], ref[2], got[0],
                  got[1], got[2]);
    for (int c = 0; c < 3; ++c)
        assert_true(fabs(got[c] / ref[c] - 1.0) < 0.03);
    free(a);
    free(b);
    vbnl_scene_destroy(s);
}

/* ---- bump normals at a hit ----------------------------------------------------------------- */

/* normal { gradient x 1 } (POV-Ray's convention: the normal tilts against the gradient by
 * -5 amount 0.02 (4/3) = -0.1333 before normalising), from either side of the surface. */
static void test_bump_side(void **state)
{
    fixture *f = *state;
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(f->ctx, &s, NULL), VBNL_OK);
    uint32_t leaf = plain(s, VBNL_MATERIAL_LAMBERT, 1, 1, 1, 0.1f);
    vbnl_normal_desc nm;
    vbnl_normal_desc_init(&nm);
    nm.pattern = pattern(s, VBNL_PATTERN_GRADIENT, 1.0) + 1;
    nm.amount = 1.0f;
    uint32_t nrm;
    assert_int_equal(vbnl_scene_add_normal(s, &nm, &nrm, NULL), VBNL_OK);
    vbnl_material_node_desc nd;
    vbnl_material_node_desc_init(&nd);
    nd.kind = VBNL_NODE_TEXTURED;
    nd.material = leaf;
    nd.normal = nrm + 1;
    uint32_t m = node(s, &nd);
    assert_int_equal(vbi_texture_commit(s, NULL), VBNL_OK);
    const double k = -5.0 * 0.02 * 4.0 / 3.0, len = sqrt(1.0 + k * k);
    for (int side = 0; side < 2; ++side) {
        const float sg = side ? -1.0f : 1.0f;
        vbi_hit h = hit_at(m, v3(0.5f, 0.3f, 0.2f), v3(0, 0, sg), 0);
        vbi_bsdf storage;
        const vbi_bsdf *b = vbi_surface_bsdf(s, &h, &storage);
        assert_true(b->bumped);
        vec3 n = vbi_bsdf_shading_normal(b, h.ns);
        /* the perturbation is added in space (POV-Ray adds it to the surface's normal): the same
         * tilt on either side, and the normal stays on the hit's side */
        assert_float_equal(n.x, k / len, 1e-5);
        assert_float_equal(n.y, 0.0, 1e-5);
        assert_float_equal(n.z, sg / len, 1e-5);
        assert_true(v3_dot(n, h.ng) > 0.0f);
    }
    vbnl_scene_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_chi2_map, setup, teardown),
        cmocka_unit_test_setup_teardown(test_chi2_layers, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bump_side, setup, teardown),
        cmocka_unit_test_setup_teardown(test_furnace, setup, teardown),
        cmocka_unit_test_setup_teardown(test_path_vs_vbnl, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
