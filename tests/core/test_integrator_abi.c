/* The integrator ABI (vbnl/integrator.h) implemented from the public headers alone: this file is
 * compiled with core/include (which holds nothing but the public headers) as its only include
 * path into the core, and renders through vbnl_renderer_create_with_class.
 *
 * The integrator is ambient occlusion: at a camera ray's first hit, `rays` cosine-distributed
 * rays within `distance`; the beauty image is the unoccluded fraction, its own layer "occluded"
 * the occluded one, the core's AOVs are filled from the hit and its material. A preparation
 * stage counts, on the workers, which of a few probe rays hit something.
 *
 * Checked: a floor under a ceiling at height h seen from between them has the analytic
 * unoccluded fraction (h / distance)^2 of cosine-distributed rays (P(cos theta > c) = 1 - c^2);
 * the AOVs (normal, depth, albedo from vbnl_scene_get_material); the layer the integrator added;
 * 1 and 2 threads give the same film; the preparation stage's time, work and storage in the
 * statistics; parameters validated against the class's table; malformed classes refused. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vbnl/vbnl.h"

/* ---- the integrator ---------------------------------------------------------------------------- */

static const vbnl_param_spec ao_params[] = {
    {"rays", VBNL_PARAM_INT, 4, NULL, 1, 64, NULL, "occlusion rays per sample"},
    {"distance", VBNL_PARAM_FLOAT, 1.0, NULL, 1e-6, 1e6, NULL, "occlusion distance"},
};
#define AO_PARAM_COUNT ((uint32_t)(sizeof(ao_params) / sizeof(ao_params[0])))

typedef struct ao_state {
    const vbnl_scene *scene;
    uint32_t rays, occluded_offset, record_size;
    float distance;
    float forward[3]; /* the camera's view axis, for the depth AOV */
    uint8_t probe_hit[64];
} ao_state;

static vbnl_result ao_create(const vbnl_integrator_env *env, void **out, vbnl_error *err)
{
    ao_state *s = calloc(1, sizeof(*s));
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    s->scene = env->scene;
    s->rays = (uint32_t)vbnl_params_number(env->params, ao_params, AO_PARAM_COUNT, "rays");
    s->distance = (float)vbnl_params_number(env->params, ao_params, AO_PARAM_COUNT, "distance");
    static const char *const names[] = {"Y"};
    vbnl_result r = vbnl_film_add_layer(env->film, "occluded", 1, names, &s->occluded_offset, err);
    if (r != VBNL_OK) {
        free(s);
        return r;
    }
    s->record_size = vbnl_film_record_size(env->film);
    *out = s;
    return VBNL_OK;
}

static void probe_item(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    ao_state *s = user;
    const float o[3] = {0.0f, 0.25f, 0.0f};
    const float a = (float)item * 0.1f;
    const float d[3] = {sinf(a), cosf(a), 0.0f}; /* item 0 straight up: the ceiling */
    vbnl_surface_hit h;
    s->probe_hit[item] = (uint8_t)vbnl_scene_trace_ray(s->scene, o, d, INFINITY, &h);
}

static vbnl_result ao_prepare(void *state, vbnl_stage_ctx *stage, vbnl_error *err)
{
    ao_state *s = state;
    vbnl_stage_begin(stage, "probe", 64, "rays");
    if (vbnl_stage_run(stage, 64, probe_item, s) != 0)
        return vbnl_error_set(err, VBNL_ERR_CANCELLED, "cancelled");
    vbnl_stage_set_work(stage, 64, "rays");
    vbnl_stage_end(stage);
    vbnl_stage_set_storage(stage, sizeof(*s));
    return VBNL_OK;
}

/* A unit vector at cosine-distributed angle about unit n (Malley: a disk point lifted). */
static void cosine_dir(const float n[3], float u1, float u2, float out[3])
{
    const float r = sqrtf(u1), phi = 6.2831853f * u2;
    const float x = r * cosf(phi), y = r * sinf(phi), z = sqrtf(fmaxf(0.0f, 1.0f - u1));
    /* an orthonormal basis about n */
    const float sign = n[2] >= 0.0f ? 1.0f : -1.0f, a = -1.0f / (sign + n[2]), b = n[0] * n[1] * a;
    const float t1[3] = {1.0f + sign * n[0] * n[0] * a, sign * b, -sign * n[0]};
    const float t2[3] = {b, sign + n[1] * n[1] * a, -n[1]};
    for (int i = 0; i < 3; ++i)
        out[i] = x * t1[i] + y * t2[i] + z * n[i];
}

static void ao_render_tile(void *state, vbnl_tile_job *job)
{
    const ao_state *s = state;
    uint32_t x0, y0, x1, y1, b, e;
    vbnl_tile_job_rect(job, &x0, &y0, &x1, &y1);
    vbnl_tile_job_samples(job, &b, &e);
    float rec[VBNL_FILM_MAX_CHANNELS];
    uint64_t rays = 0;
    for (uint32_t smp = b; smp < e; ++smp)
        for (uint32_t y = y0; y < y1; ++y)
            for (uint32_t x = x0; x < x1; ++x) {
                memset(rec, 0, sizeof(float) * s->record_size);
                vbnl_sample_stream st;
                vbnl_tile_job_stream(job, x, y, smp, &st);
                const float px = (float)x + vbnl_sample_stream_next(&st), py = (float)y + vbnl_sample_stream_next(&st);
                float o[3], d[3];
                vbnl_tile_job_camera_ray(job, px, py, o, d);
                vbnl_surface_hit h;
                rays++;
                rec[VBNL_FILM_BEAUTY + 3] = 1.0f;
                if (vbnl_scene_trace_ray(s->scene, o, d, INFINITY, &h)) {
                    float n[3];
                    const float side = h.geometric_normal[0] * d[0] + h.geometric_normal[1] * d[1] +
                                               h.geometric_normal[2] * d[2] <
                                           0.0f
                                       ? 1.0f
                                       : -1.0f;
                    for (int i = 0; i < 3; ++i)
                        n[i] = side * h.geometric_normal[i];
                    uint32_t occluded = 0;
                    for (uint32_t k = 0; k < s->rays; ++k) {
                        const float u1 = vbnl_sample_stream_next(&st), u2 = vbnl_sample_stream_next(&st);
                        float w[3], org[3];
                        cosine_dir(n, u1, u2, w);
                        vbnl_scene_offset_origin(h.position, n, w, org);
                        occluded += (uint32_t)vbnl_scene_ray_occluded(s->scene, org, w, s->distance);
                    }
                    rays += s->rays;
                    const float open = 1.0f - (float)occluded / (float)s->rays;
                    rec[VBNL_FILM_BEAUTY] = rec[VBNL_FILM_BEAUTY + 1] = rec[VBNL_FILM_BEAUTY + 2] = open;
                    rec[s->occluded_offset] = 1.0f - open;
                    vbnl_material_desc md;
                    if (vbnl_scene_get_material(s->scene, h.material, &md, NULL) == VBNL_OK)
                        memcpy(rec + VBNL_FILM_ALBEDO, md.base_color, sizeof(md.base_color));
                    memcpy(rec + VBNL_FILM_NORMAL, h.shading_normal, sizeof(h.shading_normal));
                    rec[VBNL_FILM_DEPTH] = h.t * -d[1]; /* the camera looks straight down (-y) */
                }
                vbnl_tile_job_add_sample(job, x, y, rec);
            }
    vbnl_tile_job_count_rays(job, rays);
}

static void ao_destroy(void *state) { free(state); }

static const vbnl_integrator_class ao_class = {
    VBNL_INTEGRATOR_ABI_MAJOR, VBNL_INTEGRATOR_ABI_MINOR, sizeof(vbnl_integrator_class),
    "ao", "ambient occlusion (a test of the integrator ABI)", ao_params, AO_PARAM_COUNT,
    ao_create, ao_prepare, ao_render_tile, ao_destroy,
};

/* ---- the scene: a floor (y = 0) under a ceiling (y = h), a camera between them looking down ---- */

#define CEILING 0.5f
#define ALBEDO_R 0.5f

static void quad(vbnl_scene *s, float y, int up, uint32_t material)
{
    const float big = 1000.0f;
    const float p[12] = {-big, y, -big, big, y, -big, big, y, big, -big, y, big};
    /* seen from above: (0,1,2) winds clockwise, so the normal is -y; reversed for +y */
    const uint32_t down_idx[6] = {0, 1, 2, 0, 2, 3}, up_idx[6] = {0, 2, 1, 0, 3, 2};
    vbnl_mesh_desc m;
    vbnl_mesh_desc_init(&m);
    m.positions = p;
    m.vertex_count = 4;
    m.indices = up ? up_idx : down_idx;
    m.triangle_count = 2;
    m.material = material;
    assert_int_equal(vbnl_scene_add_mesh(s, &m, NULL, NULL), VBNL_OK);
}

static vbnl_scene *ao_scene(vbnl_context *ctx)
{
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    md.base_color[0] = ALBEDO_R;
    md.base_color[1] = 0.6f;
    md.base_color[2] = 0.7f;
    uint32_t mat = 0;
    assert_int_equal(vbnl_scene_add_material(s, &md, &mat, NULL), VBNL_OK);
    quad(s, 0.0f, 1, mat);
    quad(s, CEILING, 0, mat);
    const float pos[3] = {0.0f, 0.25f, 0.0f}, target[3] = {0.0f, 0.0f, 0.0f}, up[3] = {0.0f, 0.0f, -1.0f};
    vbnl_camera_desc cam;
    assert_int_equal(vbnl_camera_look_at(&cam, pos, target, up, 40.0f, 1.0f, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_set_camera(s, &cam, NULL), VBNL_OK);
    const float lp[3] = {0.0f, 0.4f, 0.0f}, li[3] = {1.0f, 1.0f, 1.0f};
    assert_int_equal(vbnl_scene_add_point_light(s, lp, li, NULL, NULL), VBNL_OK); /* a scene needs a light */
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    return s;
}

/* Renders with `threads` workers; returns the film's layers read into malloc'ed arrays. */
static vbnl_renderer *ao_render(vbnl_context *ctx, const vbnl_scene *s, const char *set, vbnl_render_stats *stats)
{
    vbnl_params *p = NULL;
    assert_int_equal(vbnl_params_create(&p, NULL), VBNL_OK);
    if (set)
        assert_int_equal(vbnl_params_set_text(p, set, NULL, NULL), VBNL_OK);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = rs.height = 32;
    rs.spp = 16;
    rs.params = p;
    vbnl_renderer *r = NULL;
    vbnl_error err = {0};
    if (vbnl_renderer_create_with_class(ctx, s, &rs, &ao_class, &r, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    vbnl_params_destroy(p); /* the renderer keeps a copy */
    assert_int_equal(vbnl_renderer_prepare(r, NULL, NULL, &err), VBNL_OK);
    assert_int_equal(vbnl_renderer_render(r, NULL, NULL, &err), VBNL_OK);
    assert_int_equal(vbnl_renderer_get_stats(r, stats, NULL), VBNL_OK);
    return r;
}

static float *read_layer(const vbnl_renderer *r, const char *name, uint32_t channels)
{
    const vbnl_film *f = vbnl_renderer_film(r);
    size_t n = (size_t)vbnl_film_width(f) * vbnl_film_height(f) * channels;
    float *v = malloc(n * sizeof(float));
    assert_non_null(v);
    assert_int_equal(vbnl_film_read(f, name, v, n, NULL), VBNL_OK);
    return v;
}

static void test_ao_render(void **state)
{
    (void)state;
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = 2;
    vbnl_context *ctx = NULL;
    assert_int_equal(vbnl_context_create(&cd, &ctx, NULL), VBNL_OK);
    vbnl_scene *s = ao_scene(ctx);
    vbnl_render_stats st;
    vbnl_renderer *r = ao_render(ctx, s, "rays=8", &st);
    const uint32_t n = 32 * 32;
    float *beauty = read_layer(r, "", 4), *occ = read_layer(r, "occluded", 1), *nrm = read_layer(r, "normal", 3);
    float *depth = read_layer(r, "depth", 1), *alb = read_layer(r, "albedo", 3);
    /* distance 1 above a floor under a ceiling at 0.5: a ray is unoccluded when cos theta < h / d */
    const double expect = (double)CEILING * CEILING;
    double mean = 0.0;
    for (uint32_t i = 0; i < n; ++i) {
        mean += beauty[4 * i];
        assert_float_equal(beauty[4 * i] + occ[i], 1.0, 1e-6);
        assert_float_equal(beauty[4 * i + 3], 1.0, 0.0);
        assert_float_equal(nrm[3 * i + 1], 1.0, 1e-6);
        assert_float_equal(alb[3 * i], ALBEDO_R, 0.0);
    }
    mean /= n;
    print_message("# unoccluded fraction %.4f (analytic %.4f), %llu rays\n", mean, expect,
                  (unsigned long long)st.rays);
    assert_float_equal(mean, expect, 0.01); /* 131072 rays: sigma 0.0012 */
    assert_float_equal(depth[16 * 32 + 16], 0.25, 1e-4); /* straight down at the centre */
    /* the statistics: 16 spp, every sample's camera ray and its 8 occlusion rays; the stage */
    assert_int_equal(st.spp, 16);
    assert_int_equal(st.rays, (uint64_t)n * 16 * 9);
    assert_int_equal(st.storage_bytes, sizeof(ao_state));
    int found = 0;
    for (uint32_t i = 0; i < st.stage_count; ++i)
        if (!strcmp(st.stages[i].name, "probe")) {
            found = 1;
            assert_float_equal(st.stages[i].work, 64.0, 0.0);
            assert_string_equal(st.stages[i].work_unit, "rays");
        }
    assert_true(found);
    /* 1 thread: the same film bit for bit */
    vbnl_context *one = NULL;
    cd.threads = 1;
    assert_int_equal(vbnl_context_create(&cd, &one, NULL), VBNL_OK);
    vbnl_scene *s1 = ao_scene(one);
    vbnl_render_stats st1;
    vbnl_renderer *r1 = ao_render(one, s1, "rays=8", &st1);
    float *beauty1 = read_layer(r1, "", 4);
    assert_memory_equal(beauty, beauty1, (size_t)n * 4 * sizeof(float));
    /* a short distance: nothing is occluded */
    vbnl_renderer *r2 = ao_render(ctx, s, "distance=0.1", &st1);
    float *beauty2 = read_layer(r2, "", 4);
    for (uint32_t i = 0; i < n; ++i)
        assert_float_equal(beauty2[4 * i], 1.0, 0.0);
    free(beauty);
    free(beauty1);
    free(beauty2);
    free(occ);
    free(nrm);
    free(depth);
    free(alb);
    vbnl_renderer_destroy(r);
    vbnl_renderer_destroy(r1);
    vbnl_renderer_destroy(r2);
    vbnl_scene_destroy(s1);
    vbnl_context_destroy(one);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static void test_ao_refused(void **state)
{
    (void)state;
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = 1;
    vbnl_context *ctx = NULL;
    assert_int_equal(vbnl_context_create(&cd, &ctx, NULL), VBNL_OK);
    vbnl_scene *s = ao_scene(ctx);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    vbnl_renderer *r = (vbnl_renderer *)1;
    vbnl_error err = {0};
    /* a parameter out of the class's range */
    vbnl_params *p = NULL;
    assert_int_equal(vbnl_params_create(&p, NULL), VBNL_OK);
    assert_int_equal(vbnl_params_set_text(p, "rays=0", NULL, NULL), VBNL_OK);
    rs.params = p;
    assert_int_equal(vbnl_renderer_create_with_class(ctx, s, &rs, &ao_class, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_null(r);
    assert_non_null(strstr(err.message, "rays"));
    rs.params = NULL;
    vbnl_params_destroy(p);
    /* malformed classes */
    vbnl_integrator_class bad = ao_class;
    bad.abi_major = VBNL_INTEGRATOR_ABI_MAJOR + 1;
    assert_int_equal(vbnl_renderer_create_with_class(ctx, s, &rs, &bad, &r, &err), VBNL_ERR_UNSUPPORTED);
    bad = ao_class;
    bad.size = 8;
    assert_int_equal(vbnl_renderer_create_with_class(ctx, s, &rs, &bad, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "sizeof(vbnl_integrator_class)"));
    bad = ao_class;
    bad.render_tile = NULL;
    assert_int_equal(vbnl_renderer_create_with_class(ctx, s, &rs, &bad, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_renderer_create_with_class(ctx, s, &rs, NULL, &r, &err), VBNL_ERR_INVALID_ARGUMENT);
    /* the registry does not know it */
    assert_null(vbnl_integrator_find("ao"));
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ao_render),
        cmocka_unit_test(test_ao_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
