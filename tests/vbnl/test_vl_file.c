/* Saved virtual-light sets (vl_file.h): round trips, damage, versions, scenes, photon ranges,
 * unwritable paths, saves abandoned from a signal handler. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <dirent.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "atomic_file.h"
#include "rng.h"
#include "scenes.h"
#include "vbnl/vbnl.h"
#include "vl_file.h"

#define W 16u
#define H 16u
#define LIGHTS "virtual_lights=2000"
#define PHOTONS "photon_paths=100000"

typedef struct fixture {
    vbnl_context *ctx;
    vbnl_scene *scene;
    char dir[256];
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof(*f));
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    d.threads = 2;
    vbnl_context_create(&d, &f->ctx, NULL);
    f->scene = ts_box_scene(f->ctx, 1.0f);
    assert_int_equal(vbnl_scene_commit(f->scene, NULL), VBNL_OK);
    snprintf(f->dir, sizeof(f->dir), "/tmp/vbnl-vlfile-XXXXXX");
    assert_non_null(mkdtemp(f->dir));
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    DIR *d = opendir(f->dir);
    struct dirent *e;
    char p[600];
    while (d && (e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        snprintf(p, sizeof(p), "%s/%s", f->dir, e->d_name);
        if (unlink(p) != 0)
            rmdir(p);
    }
    if (d)
        closedir(d);
    rmdir(f->dir);
    vbnl_scene_destroy(f->scene);
    vbnl_context_destroy(f->ctx);
    free(f);
    return 0;
}

static void path_in(const fixture *f, const char *name, char *out, size_t n)
{
    snprintf(out, n, "%s/%s", f->dir, name);
}

/* Renders with the vbnl integrator and the given settings at `width` x H with `seed`; returns the
 * beauty RGBA (or NULL with *res and err filled when create/prepare/render fails). spp 0: prepare
 * only. */
static float *run_as(const fixture *f, const vbnl_scene *scene, uint32_t spp, const char *const *settings,
                     uint32_t width, uint64_t seed, vbnl_result *res, vbnl_error *err)
{
    vbnl_params *p;
    vbnl_params_create(&p, NULL);
    for (const char *const *kv = settings; kv && *kv; ++kv)
        assert_int_equal(vbnl_params_set_text(p, *kv, NULL, NULL), VBNL_OK);
    vbnl_render_settings rs;
    vbnl_render_settings_init(&rs);
    rs.width = width;
    rs.height = H;
    rs.spp = spp ? spp : 1;
    rs.seed = seed;
    rs.integrator = "vbnl";
    rs.params = p;
    vbnl_renderer *r = NULL;
    float *rgba = NULL;
    *res = vbnl_renderer_create(f->ctx, scene, &rs, &r, err);
    if (*res == VBNL_OK)
        *res = vbnl_renderer_prepare(r, NULL, NULL, err);
    if (*res == VBNL_OK && spp)
        *res = vbnl_renderer_render(r, NULL, NULL, err);
    if (*res == VBNL_OK) {
        rgba = malloc(sizeof(float) * 4 * width * H);
        assert_int_equal(vbnl_film_read(vbnl_renderer_film(r), "", rgba, (size_t)4 * width * H, NULL), VBNL_OK);
    }
    vbnl_renderer_destroy(r);
    vbnl_params_destroy(p);
    return rgba;
}

static float *run(const fixture *f, const vbnl_scene *scene, uint32_t spp, const char *const *settings,
                  vbnl_result *res, vbnl_error *err)
{
    return run_as(f, scene, spp, settings, W, 5, res, err);
}

/* A run expected to fail at create, prepare or render with `code` and `pattern` in the message. */
static void expect_run_error(const fixture *f, const vbnl_scene *scene, const char *const *settings, uint32_t width,
                             uint64_t seed, vbnl_result code, const char *pattern)
{
    vbnl_result res;
    vbnl_error err = {0};
    float *img = run_as(f, scene ? scene : f->scene, 1, settings, width, seed, &res, &err);
    print_message("# -> %s: %s\n", vbnl_result_name(res), err.message);
    assert_null(img);
    assert_int_equal(res, code);
    if (!strstr(err.message, pattern))
        fail_msg("message '%s' lacks '%s'", err.message, pattern);
}

static float *run_ok(const fixture *f, uint32_t spp, const char *const *settings)
{
    vbnl_result res;
    vbnl_error err = {0};
    float *img = run(f, f->scene, spp, settings, &res, &err);
    if (res != VBNL_OK)
        fail_msg("%s: %s", vbnl_result_name(res), err.message);
    return img;
}

/* Loads a file (list) expecting failure with `code` and `pattern` in the message. */
static void expect_load_error(const fixture *f, const vbnl_scene *scene, const char *paths, vbnl_result code,
                              const char *pattern)
{
    vbi_vl_file_data d;
    vbnl_error err = {0};
    vbnl_result r = vbi_vl_file_load(paths, scene ? scene : f->scene, &d, &err);
    print_message("# %s -> %s: %s\n", paths, vbnl_result_name(r), err.message);
    assert_int_equal(r, code);
    if (!strstr(err.message, pattern))
        fail_msg("message '%s' lacks '%s'", err.message, pattern);
    assert_null(d.profiles);
    assert_int_equal(d.vls.count, 0);
}

static unsigned char *read_all(const char *path, size_t *n)
{
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    fseek(fp, 0, SEEK_END);
    *n = (size_t)ftell(fp);
    fseek(fp, 0, SEEK_SET);
    unsigned char *b = malloc(*n);
    assert_int_equal(fread(b, 1, *n, fp), *n);
    fclose(fp);
    return b;
}

static void write_all(const char *path, const void *b, size_t n)
{
    FILE *fp = fopen(path, "wb");
    assert_non_null(fp);
    assert_int_equal(fwrite(b, 1, n, fp), n);
    fclose(fp);
}

/* A synthetic set (half the lights glossy) with random deposits, saved and loaded: every array
 * and every fixed-point value comes back bit for bit. */
static void test_round_trip_arrays(void **state)
{
    fixture *f = *state;
    const uint32_t n = 701;
    vbi_vl_set vls;
    assert_int_equal(vbi_vl_set_alloc(&vls, n, NULL), VBNL_OK);
    uint8_t *glossy = malloc(n);
    vbi_rng rng = vbi_rng_for(11, 0, 0);
    for (uint32_t j = 0; j < n; ++j) {
        vls.position[j] = v3(vbi_rng_next(&rng), 2.0f * vbi_rng_next(&rng), -vbi_rng_next(&rng));
        vls.normal[j] = v3_norm(v3(vbi_rng_next(&rng) - 0.5f, 1.0f, vbi_rng_next(&rng) - 0.5f));
        vls.material[j] = j % f->scene->material_count;
        vls.tint[j] = v3(vbi_rng_next(&rng), 1.0f, 0.25f);
        vls.radius[j] = 0.01f + 0.1f * vbi_rng_next(&rng);
        vls.density[j] = 1.0f / vls.radius[j];
        glossy[j] = (uint8_t)(j % 2);
    }
    vbi_hemioct *map;
    assert_int_equal(vbi_hemioct_create(16, &map), VBNL_OK);
    vbi_profile_set *ps;
    assert_int_equal(vbi_profile_set_create_fixed(map, n, glossy, 0x1p-30, &ps), VBNL_OK);
    for (int k = 0; k < 20000; ++k) {
        uint32_t j = (uint32_t)(vbi_rng_next(&rng) * n) % n;
        vec3 wi = v3_norm(v3(vbi_rng_next(&rng) - 0.5f, vbi_rng_next(&rng) - 0.5f, vbi_rng_next(&rng) + 0.05f));
        vbi_profile_deposit(ps, j, wi, v3(vbi_rng_next(&rng), vbi_rng_next(&rng), 0.5f));
    }
    vbi_vl_file_header h;
    memset(&h, 0, sizeof(h));
    h.fingerprint = vbi_scene_fingerprint(f->scene);
    h.virtual_lights = 800;
    h.profile_resolution = 16;
    h.photon_paths = 1000;
    h.photon_count = 1000;
    h.unit = 0x1p-30;
    h.seed = 77;
    h.elimination = 2;
    h.radius_scale = 2.0f;
    h.material_count = f->scene->material_count;
    h.width = 640;
    h.height = 360;
    h.camera = 0x0123456789abcdefull;
    h.preparation = 0xfedcba9876543210ull;
    h.placement_seconds = 1.5;
    h.elimination_seconds = 0.25;
    h.photon_seconds = 3.0;
    h.photon_rays = 12345.0;
    char path[400];
    path_in(f, "set.vls", path, sizeof(path));
    vbnl_error err = {0};
    assert_int_equal(vbi_vl_file_save(path, &h, &vls, ps, &err), VBNL_OK);

    vbi_vl_file_data d;
    if (vbi_vl_file_load(path, f->scene, &d, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    assert_int_equal(d.vls.count, n);
    assert_int_equal(d.header.version, VBI_VL_FILE_VERSION);
    assert_int_equal(d.header.virtual_lights, 800);
    assert_int_equal(d.header.seed, 77);
    assert_int_equal(d.header.photon_paths, 1000);
    assert_true(d.header.unit == 0x1p-30);
    assert_true(d.header.radius_scale == 2.0f);
    assert_int_equal(d.header.width, 640);
    assert_int_equal(d.header.height, 360);
    assert_true(d.header.camera == 0x0123456789abcdefull);
    assert_true(d.header.preparation == 0xfedcba9876543210ull);
    assert_true(d.header.placement_seconds == 1.5 && d.header.elimination_seconds == 0.25);
    assert_true(d.header.photon_seconds == 3.0 && d.header.photon_rays == 12345.0);
    assert_int_equal(d.header.count, n);
    assert_int_equal(d.header.glossy_count, n / 2); /* the odd lights */
    /* the header alone reads back the same, with the set fingerprint the save computed */
    vbi_vl_file_header only;
    assert_int_equal(vbi_vl_file_read_header(path, 1, &only, &err), VBNL_OK);
    assert_int_equal(only.count, n);
    assert_true(only.set == d.header.set && only.set != 0);
    assert_true(only.camera == h.camera && only.photon_count == 1000);
    assert_memory_equal(d.vls.position, vls.position, sizeof(vec3) * n);
    assert_memory_equal(d.vls.normal, vls.normal, sizeof(vec3) * n);
    assert_memory_equal(d.vls.material, vls.material, sizeof(uint32_t) * n);
    assert_memory_equal(d.vls.tint, vls.tint, sizeof(vec3) * n);
    assert_memory_equal(d.vls.radius, vls.radius, sizeof(float) * n);
    assert_memory_equal(d.vls.density, vls.density, sizeof(float) * n);
    uint64_t nonzero = 0;
    for (uint32_t j = 0; j < n; ++j) {
        assert_int_equal(vbi_profile_is_glossy(d.profiles, j), glossy[j]);
        assert_memory_equal(vbi_profile_incident_power_fixed(d.profiles, j),
                            vbi_profile_incident_power_fixed(ps, j), 3 * sizeof(uint64_t));
        nonzero += vbi_profile_incident_power_fixed(ps, j)[0] != 0;
        if (glossy[j])
            assert_memory_equal(vbi_profile_incident_map_fixed(d.profiles, j),
                                vbi_profile_incident_map_fixed(ps, j), 3 * 256 * sizeof(uint64_t));
    }
    assert_true(nonzero > n / 2); /* the comparison saw real data */
    vbi_vl_file_data_free(&d);
    vbi_profile_set_destroy(ps);
    vbi_hemioct_destroy(map);
    vbi_vl_set_free(&vls);
    free(glossy);
}

/* Render and save; load in a new renderer: the same film, bit for bit (same seed). */
static void test_round_trip_render(void **state)
{
    fixture *f = *state;
    char path[400], set[420], load[420];
    path_in(f, "render.vls", path, sizeof(path));
    snprintf(set, sizeof(set), "save_lights=%s", path);
    snprintf(load, sizeof(load), "load_lights=%s", path);
    const char *const save_settings[] = {LIGHTS, PHOTONS, set, NULL};
    float *a = run_ok(f, 2, save_settings);
    /* the file's set is used whatever the unset preparation parameters (their defaults differ) */
    const char *const load_settings[] = {load, NULL};
    float *b = run_ok(f, 2, load_settings);
    /* counts set to other values than the file's are refused; reuse_lights accepts them */
    const char *const other_counts[] = {load, "virtual_lights=50", NULL};
    expect_run_error(f, NULL, other_counts, W, 5, VBNL_ERR_INVALID_ARGUMENT,
                     "was prepared with virtual_lights=2000, this render sets 50");
    const char *const other_paths[] = {load, "photon_paths=7", NULL};
    expect_run_error(f, NULL, other_paths, W, 5, VBNL_ERR_INVALID_ARGUMENT,
                     "was prepared with photon_paths=100000, this render sets 7");
    const char *const reuse[] = {load, "virtual_lights=50", "photon_paths=7", "reuse_lights=on", NULL};
    float *b2 = run_ok(f, 2, reuse);
    assert_memory_equal(a, b2, sizeof(float) * 4 * W * H);
    free(b2);
    double sum = 0.0;
    for (uint32_t i = 0; i < 4 * W * H; ++i)
        sum += a[i];
    assert_true(sum > 0.0);
    assert_memory_equal(a, b, sizeof(float) * 4 * W * H);
    /* and the view of the lights renders from the file too */
    const char *const view_settings[] = {load, "view=lights", NULL};
    float *c = run_ok(f, 1, view_settings);
    free(c);
    free(a);
    free(b);
}

/* Damage is found by the checksum before anything else is believed. */
static void test_damaged(void **state)
{
    fixture *f = *state;
    char path[400], set[420], bad[400];
    path_in(f, "good.vls", path, sizeof(path));
    snprintf(set, sizeof(set), "save_lights=%s", path);
    const char *const settings[] = {LIGHTS, "photon_paths=20000", set, NULL};
    free(run_ok(f, 0, settings));
    size_t n;
    unsigned char *b = read_all(path, &n);
    assert_true(n > 1000);
    path_in(f, "bad.vls", bad, sizeof(bad));
    /* one flipped byte in the arrays, in the header, in the version field, in the checksum */
    const size_t where[] = {n / 2, 20, 8, n - 3};
    for (size_t k = 0; k < sizeof(where) / sizeof(where[0]); ++k) {
        b[where[k]] ^= 0x10;
        write_all(bad, b, n);
        b[where[k]] ^= 0x10;
        expect_load_error(f, NULL, bad, VBNL_ERR_CORRUPT, "is damaged (checksum mismatch)");
    }
    /* truncated */
    write_all(bad, b, n - 100);
    expect_load_error(f, NULL, bad, VBNL_ERR_CORRUPT, "is damaged (truncated");
    write_all(bad, b, 40);
    expect_load_error(f, NULL, bad, VBNL_ERR_CORRUPT, "is damaged");
    /* not ours at all */
    write_all(bad, "hello, world\n", 13);
    expect_load_error(f, NULL, bad, VBNL_ERR_CORRUPT, "is not a virtual-light file");
    write_all(bad, "", 0);
    expect_load_error(f, NULL, bad, VBNL_ERR_CORRUPT, "is not a virtual-light file");
    path_in(f, "missing.vls", bad, sizeof(bad));
    expect_load_error(f, NULL, bad, VBNL_ERR_IO, "cannot read");
    /* through the integrator: prepare fails with the same error */
    char load[420];
    snprintf(load, sizeof(load), "load_lights=%s", path);
    b[n / 3] ^= 1;
    write_all(path, b, n);
    const char *const load_settings[] = {load, NULL};
    vbnl_result res;
    vbnl_error err = {0};
    assert_null(run(f, f->scene, 1, load_settings, &res, &err));
    assert_int_equal(res, VBNL_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "checksum mismatch"));
    free(b);
}

/* A file of another format version (with a valid checksum) is named as such. */
static void test_wrong_version(void **state)
{
    fixture *f = *state;
    char path[400], set[420];
    path_in(f, "v.vls", path, sizeof(path));
    snprintf(set, sizeof(set), "save_lights=%s", path);
    const char *const settings[] = {LIGHTS, "photon_paths=20000", set, NULL};
    free(run_ok(f, 0, settings));
    size_t n;
    unsigned char *b = read_all(path, &n);
    uint32_t v;
    memcpy(&v, b + 8, 4);
    assert_int_equal(v, VBI_VL_FILE_VERSION);
    v = VBI_VL_FILE_VERSION - 1;
    memcpy(b + 8, &v, 4);
    uint64_t h = vbi_vl_file_hash(VBI_VL_FILE_HASH_INIT, b, n - 8);
    memcpy(b + n - 8, &h, 8);
    write_all(path, b, n);
    expect_load_error(f, NULL, path, VBNL_ERR_CORRUPT, "was written by format version 3; this build reads version 4");
    free(b);
}

/* Another scene is refused; another camera is not another scene. */
static void test_other_scene(void **state)
{
    fixture *f = *state;
    char path[400], set[420];
    path_in(f, "scene.vls", path, sizeof(path));
    snprintf(set, sizeof(set), "save_lights=%s", path);
    const char *const settings[] = {LIGHTS, "photon_paths=20000", set, NULL};
    free(run_ok(f, 0, settings));

    /* the same box with one more sphere */
    vbnl_scene *other = ts_box_scene(f->ctx, 1.0f);
    float c[3] = {-0.5f, 0.3f, 0.2f};
    vbnl_scene_add_sphere(other, c, 0.2f, 0, VBNL_GROUP_WORLD, NULL, NULL);
    assert_int_equal(vbnl_scene_commit(other, NULL), VBNL_OK);
    assert_true(vbi_scene_fingerprint(other) != vbi_scene_fingerprint(f->scene));
    expect_load_error(f, other, path, VBNL_ERR_INVALID_ARGUMENT, "was prepared for another scene (fingerprint");
    vbnl_scene_destroy(other);

    /* the same box with a slightly different light */
    other = ts_box_scene(f->ctx, 1.0f);
    vbnl_area_light_desc al;
    vbnl_area_light_desc_init(&al);
    al.corner[0] = 0.5f;
    al.corner[1] = 1.9f;
    al.edge_u[0] = 0.1f;
    al.edge_v[2] = 0.1f;
    al.radiance[0] = 1.0f;
    vbnl_scene_add_area_light(other, &al, NULL, NULL);
    assert_int_equal(vbnl_scene_commit(other, NULL), VBNL_OK);
    expect_load_error(f, other, path, VBNL_ERR_INVALID_ARGUMENT, "was prepared for another scene");
    vbnl_scene_destroy(other);

    /* same scene, another viewpoint: the file loads (the set describes the scene's light), but a
     * render refuses it, as it does another image size or seed, unless reuse_lights */
    other = ts_box_scene(f->ctx, 1.0f);
    float pos[3] = {0.5f, 1.5f, 0.5f}, target[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 50.0f, 1.0f, NULL);
    vbnl_scene_set_camera(other, &cam, NULL);
    assert_int_equal(vbnl_scene_commit(other, NULL), VBNL_OK);
    assert_true(vbi_scene_fingerprint(other) == vbi_scene_fingerprint(f->scene));
    vbi_vl_file_data d;
    vbnl_error err = {0};
    assert_int_equal(vbi_vl_file_load(path, other, &d, &err), VBNL_OK);
    vbi_vl_file_data_free(&d);
    char load[420];
    snprintf(load, sizeof(load), "load_lights=%s", path);
    const char *const plain[] = {load, NULL};
    const char *const reuse[] = {load, "reuse_lights=on", NULL};
    expect_run_error(f, other, plain, W, 5, VBNL_ERR_INVALID_ARGUMENT, "was prepared for another camera");
    vbnl_result res;
    float *img = run_as(f, other, 1, reuse, W, 5, &res, &err);
    assert_int_equal(res, VBNL_OK);
    free(img);
    expect_run_error(f, NULL, plain, W / 2, 5, VBNL_ERR_INVALID_ARGUMENT,
                     "was prepared for a 16x16 image, this render is 8x16");
    expect_run_error(f, NULL, plain, W, 6, VBNL_ERR_INVALID_ARGUMENT,
                     "was prepared with seed 5, this render has seed 6");
    img = run_as(f, f->scene, 1, reuse, W / 2, 6, &res, &err);
    assert_int_equal(res, VBNL_OK);
    free(img);
    vbnl_scene_destroy(other);
}

/* Photon ranges [0, k) and [k, N) in two runs, summed on load, equal one run over [0, N): the
 * incident data and the rendered film bit for bit. Overlaps and gaps are refused. */
static void test_photon_ranges_merge(void **state)
{
    fixture *f = *state;
    char full[400], p1[400], p2[400], p3[400], s[4][420];
    path_in(f, "full.vls", full, sizeof(full));
    path_in(f, "r1.vls", p1, sizeof(p1));
    path_in(f, "r2.vls", p2, sizeof(p2));
    path_in(f, "r3.vls", p3, sizeof(p3));
    snprintf(s[0], sizeof(s[0]), "save_lights=%s", full);
    snprintf(s[1], sizeof(s[1]), "save_lights=%s", p1);
    snprintf(s[2], sizeof(s[2]), "save_lights=%s", p2);
    snprintf(s[3], sizeof(s[3]), "save_lights=%s", p3);
    const char *const a[] = {LIGHTS, PHOTONS, s[0], NULL};
    /* a range that is not a multiple of the splitting chunk (4096) */
    const char *const b[] = {LIGHTS, PHOTONS, s[1], "photon_count=37001", NULL};
    const char *const c[] = {LIGHTS, PHOTONS, s[2], "photon_first=37001", NULL};
    const char *const d3[] = {LIGHTS, PHOTONS, s[3], "photon_first=30000", "photon_count=10000", NULL};
    float *img_full = run_ok(f, 2, a);
    free(run_ok(f, 0, b));
    free(run_ok(f, 0, c));
    free(run_ok(f, 0, d3));

    vbi_vl_file_data one, sum;
    vbnl_error err = {0};
    char list[1300];
    snprintf(list, sizeof(list), "%s:%s", p2, p1); /* any order */
    assert_int_equal(vbi_vl_file_load(full, f->scene, &one, &err), VBNL_OK);
    if (vbi_vl_file_load(list, f->scene, &sum, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    assert_int_equal(sum.header.photon_first, 0);
    assert_int_equal(sum.header.photon_count, 100000);
    assert_int_equal(one.vls.count, sum.vls.count);
    uint32_t n = one.vls.count, glossy = 0;
    const uint32_t texels = vbi_hemioct_texel_count(one.map);
    uint64_t total = 0;
    for (uint32_t j = 0; j < n; ++j) {
        assert_memory_equal(vbi_profile_incident_power_fixed(one.profiles, j),
                            vbi_profile_incident_power_fixed(sum.profiles, j), 3 * sizeof(uint64_t));
        total += vbi_profile_incident_power_fixed(one.profiles, j)[1];
        if (vbi_profile_is_glossy(one.profiles, j)) {
            ++glossy;
            assert_memory_equal(vbi_profile_incident_map_fixed(one.profiles, j),
                                vbi_profile_incident_map_fixed(sum.profiles, j), 3 * texels * sizeof(uint64_t));
        }
    }
    print_message("# %u lights, %u glossy\n", n, glossy);
    assert_true(total > 0 && glossy > 0);
    vbi_vl_file_data_free(&one);
    vbi_vl_file_data_free(&sum);

    char load[1320];
    snprintf(load, sizeof(load), "load_lights=%s", list);
    const char *const l[] = {load, NULL};
    float *img_sum = run_ok(f, 2, l);
    assert_memory_equal(img_full, img_sum, sizeof(float) * 4 * W * H);

    /* overlap: r3 = [30000, 40000) meets r1 = [0, 37001) */
    snprintf(list, sizeof(list), "%s:%s:%s", p1, p3, p2);
    expect_load_error(f, NULL, list, VBNL_ERR_INVALID_ARGUMENT, "would count those photons twice");
    snprintf(list, sizeof(list), "%s:%s", p1, p1);
    expect_load_error(f, NULL, list, VBNL_ERR_INVALID_ARGUMENT, "twice");
    /* gaps: one range alone, or two that leave [37001, 30000 + ...) out */
    expect_load_error(f, NULL, p1, VBNL_ERR_INVALID_ARGUMENT, "leave [37001, 100000) of the 100000 paths");
    snprintf(list, sizeof(list), "%s:%s", p3, p2);
    expect_load_error(f, NULL, list, VBNL_ERR_INVALID_ARGUMENT, "leave [0, 30000)");
    /* another preparation (another seed of the lights) does not sum */
    char other[400], so[420];
    path_in(f, "other.vls", other, sizeof(other));
    snprintf(so, sizeof(so), "save_lights=%s", other);
    const char *const o[] = {"virtual_lights=1900", PHOTONS, so, "photon_first=37001", NULL};
    free(run_ok(f, 0, o));
    snprintf(list, sizeof(list), "%s:%s", p1, other);
    expect_load_error(f, NULL, list, VBNL_ERR_INVALID_ARGUMENT, "holds another virtual-light set");
    /* the integrator refuses ranges outside photon_paths, and ranges on a set that has its photons */
    const char *const bad1[] = {LIGHTS, PHOTONS, "photon_first=100000", NULL};
    const char *const bad2[] = {load, "photon_count=5", NULL};
    expect_run_error(f, NULL, bad1, W, 5, VBNL_ERR_INVALID_ARGUMENT, "must lie inside the 100000 photon_paths");
    expect_run_error(f, NULL, bad2, W, 5, VBNL_ERR_INVALID_ARGUMENT, "holds photon paths [0, 100000) already");
    free(img_full);
    free(img_sum);
}

/* Prepare once, trace photons apart: a placement (placement_only) holds the set and no photon;
 * processes that load it trace disjoint photon ranges; vbi_vl_file_merge sums their files
 * without the scene. The sum, and a render from it, equal one run bit for bit. Files of another
 * scene or preparation, missing and overlapping ranges are refused by the merge. */
static void test_placement_then_photons(void **state)
{
    fixture *f = *state;
    char place[400], full[400], part[3][400], merged[400], set[420], load[420];
    path_in(f, "placement.vls", place, sizeof(place));
    path_in(f, "full.vls", full, sizeof(full));
    path_in(f, "merged.vls", merged, sizeof(merged));
    /* the whole preparation in one run */
    snprintf(set, sizeof(set), "save_lights=%s", full);
    const char *const one[] = {LIGHTS, PHOTONS, set, NULL};
    float *img_one = run_ok(f, 2, one);

    /* a placement: no photon, and it does not render */
    snprintf(set, sizeof(set), "save_lights=%s", place);
    const char *const pl[] = {LIGHTS, PHOTONS, set, "placement_only=on", NULL};
    free(run_ok(f, 0, pl));
    vbi_vl_file_header hp, hf;
    vbnl_error err = {0};
    assert_int_equal(vbi_vl_file_read_header(place, 1, &hp, &err), VBNL_OK);
    assert_int_equal(vbi_vl_file_read_header(full, 0, &hf, &err), VBNL_OK);
    assert_int_equal(hp.photon_first, 0);
    assert_int_equal(hp.photon_count, 0);
    assert_int_equal(hp.photon_paths, 100000);
    assert_true(hp.set == hf.set && hp.preparation == hf.preparation); /* the same lights as the full run */
    assert_int_equal(hp.width, W);
    assert_true(hp.camera == vbi_vl_file_camera_fingerprint(f->scene) && hp.camera != 0);
    assert_true(hp.placement_seconds > 0.0 && hp.photon_seconds == 0.0);
    assert_true(hf.photon_rays > 0.0 && hf.photon_seconds > 0.0);

    /* three photon jobs on the placement, of unequal ranges (not multiples of the 4096-path chunk) */
    const char *const ranges[3][2] = {{"photon_first=0", "photon_count=20001"},
                                      {"photon_first=20001", "photon_count=50000"},
                                      {"photon_first=70001", "photon_count=0"}};
    snprintf(load, sizeof(load), "load_lights=%s", place);
    for (int k = 0; k < 3; ++k) {
        char name[32], sk[1300];
        snprintf(name, sizeof(name), "part%d.vls", k);
        path_in(f, name, part[k], sizeof(part[k]));
        snprintf(sk, sizeof(sk), "save_lights=%s", part[k]);
        const char *const job[] = {load, ranges[k][0], ranges[k][1], sk, NULL};
        free(run_ok(f, 0, job));
    }
    const char *const list[] = {part[2], part[0], place, part[1]}; /* any order; the placement adds nothing */
    vbi_vl_file_header hm;
    if (vbi_vl_file_merge(list, 4, merged, 0, &hm, &err) != VBNL_OK)
        fail_msg("%s", err.message);
    assert_int_equal(hm.photon_first, 0);
    assert_int_equal(hm.photon_count, 100000);
    assert_true(hm.set == hf.set);
    assert_true(hm.photon_rays > 0.0);

    /* the merged file holds the full run's photon data bit for bit */
    vbi_vl_file_data a, b;
    assert_int_equal(vbi_vl_file_load(full, f->scene, &a, &err), VBNL_OK);
    assert_int_equal(vbi_vl_file_load(merged, f->scene, &b, &err), VBNL_OK);
    assert_int_equal(a.vls.count, b.vls.count);
    uint64_t total = 0;
    for (uint32_t j = 0; j < a.vls.count; ++j) {
        assert_memory_equal(vbi_profile_incident_power_fixed(a.profiles, j),
                            vbi_profile_incident_power_fixed(b.profiles, j), 3 * sizeof(uint64_t));
        total += vbi_profile_incident_power_fixed(a.profiles, j)[0];
        if (vbi_profile_is_glossy(a.profiles, j))
            assert_memory_equal(vbi_profile_incident_map_fixed(a.profiles, j),
                                vbi_profile_incident_map_fixed(b.profiles, j),
                                3 * vbi_hemioct_texel_count(a.map) * sizeof(uint64_t));
    }
    assert_true(total > 0);
    vbi_vl_file_data_free(&a);
    vbi_vl_file_data_free(&b);
    /* and renders the same image */
    snprintf(load, sizeof(load), "load_lights=%s", merged);
    const char *const from_merged[] = {load, NULL};
    float *img_merged = run_ok(f, 2, from_merged);
    assert_memory_equal(img_one, img_merged, sizeof(float) * 4 * W * H);
    /* so does a placement loaded alone: its whole photon range is traced on it */
    snprintf(load, sizeof(load), "load_lights=%s", place);
    const char *const from_place[] = {load, NULL};
    float *img_place = run_ok(f, 2, from_place);
    assert_memory_equal(img_one, img_place, sizeof(float) * 4 * W * H);

    /* a missing range, overlaps, files of another scene or preparation, only placements */
    const char *const missing[] = {part[0], part[2]};
    assert_int_equal(vbi_vl_file_merge(missing, 2, merged, 0, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "leave [20001, 70001)"));
    assert_int_equal(vbi_vl_file_merge(missing, 2, merged, 1, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "a file of that range is missing"));
    const char *const first_two[] = {part[1], part[0]};
    assert_int_equal(vbi_vl_file_merge(first_two, 2, merged, 1, &hm, &err), VBNL_OK); /* partial: [0, 70001) */
    assert_int_equal(hm.photon_count, 70001);
    const char *const twice[] = {part[0], full};
    assert_int_equal(vbi_vl_file_merge(twice, 2, merged, 0, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "count those photons twice"));
    const char *const places[] = {place, place};
    assert_int_equal(vbi_vl_file_merge(places, 2, merged, 0, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "placement without photons"));

    vbnl_scene *other = ts_box_scene(f->ctx, 1.0f);
    float c[3] = {-0.5f, 0.3f, 0.2f};
    vbnl_scene_add_sphere(other, c, 0.2f, 0, VBNL_GROUP_WORLD, NULL, NULL);
    assert_int_equal(vbnl_scene_commit(other, NULL), VBNL_OK);
    char foreign[400], sk[420];
    path_in(f, "foreign.vls", foreign, sizeof(foreign));
    snprintf(sk, sizeof(sk), "save_lights=%s", foreign);
    const char *const fo[] = {LIGHTS, PHOTONS, "photon_first=20001", "photon_count=50000", sk, NULL};
    vbnl_result res;
    free(run(f, other, 0, fo, &res, &err));
    assert_int_equal(res, VBNL_OK);
    vbnl_scene_destroy(other);
    const char *const mixed[] = {part[0], foreign, part[2]};
    assert_int_equal(vbi_vl_file_merge(mixed, 3, merged, 0, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "was prepared for another scene than"));
    /* another seed of the same scene: another preparation */
    char seeded[400];
    path_in(f, "seeded.vls", seeded, sizeof(seeded));
    snprintf(sk, sizeof(sk), "save_lights=%s", seeded);
    const char *const se[] = {LIGHTS, PHOTONS, "photon_first=20001", "photon_count=50000", sk, NULL};
    free(run_as(f, f->scene, 0, se, W, 9, &res, &err));
    assert_int_equal(res, VBNL_OK);
    const char *const reseeded[] = {part[0], seeded, part[2]};
    assert_int_equal(vbi_vl_file_merge(reseeded, 3, merged, 0, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "another seed"));

    /* rendering loads a placement alone, not in a list; placement_only needs save_lights */
    char listed[1300];
    snprintf(listed, sizeof(listed), "%s:%s", place, part[0]);
    expect_load_error(f, NULL, listed, VBNL_ERR_INVALID_ARGUMENT, "it loads alone");
    const char *const no_save[] = {LIGHTS, PHOTONS, "placement_only=on", NULL};
    expect_run_error(f, NULL, no_save, W, 5, VBNL_ERR_INVALID_ARGUMENT, "save_lights is not set");
    free(img_one);
    free(img_merged);
    free(img_place);
}

static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        n += e->d_name[0] != '.';
    if (d)
        closedir(d);
    return n;
}

/* A tiny set to save: three lights, empty profiles. */
typedef struct tiny_set {
    vbi_vl_set vls;
    vbi_hemioct *map;
    vbi_profile_set *ps;
    vbi_vl_file_header h;
} tiny_set;

static void tiny_set_make(tiny_set *t)
{
    assert_int_equal(vbi_vl_set_alloc(&t->vls, 3, NULL), VBNL_OK);
    for (uint32_t j = 0; j < 3; ++j) {
        t->vls.position[j] = v3((float)j, 0, 0);
        t->vls.normal[j] = v3(0, 1, 0);
        t->vls.material[j] = 0;
        t->vls.tint[j] = v3s(1.0f);
        t->vls.radius[j] = t->vls.density[j] = 1.0f;
    }
    assert_int_equal(vbi_hemioct_create(8, &t->map), VBNL_OK);
    assert_int_equal(vbi_profile_set_create(t->map, 3, NULL, &t->ps), VBNL_OK);
    memset(&t->h, 0, sizeof(t->h));
    t->h.profile_resolution = 8;
    t->h.photon_paths = t->h.photon_count = 1;
    t->h.unit = VBI_PROFILE_DEFAULT_UNIT;
}

static void tiny_set_free(tiny_set *t)
{
    vbi_profile_set_destroy(t->ps);
    vbi_hemioct_destroy(t->map);
    vbi_vl_set_free(&t->vls);
}

/* An unwritable path fails with VBNL_ERR_IO and leaves no file (not even the temporary). */
static void test_unwritable(void **state)
{
    fixture *f = *state;
    tiny_set t;
    tiny_set_make(&t);
    vbnl_error err = {0};
    char sub[400], path[500];
    /* a folder that does not exist */
    path_in(f, "no/such/folder/x.vls", path, sizeof(path));
    assert_int_equal(vbi_vl_file_save(path, &t.h, &t.vls, t.ps, &err), VBNL_ERR_IO);
    assert_non_null(strstr(err.message, "cannot write"));
    /* the final rename fails (the path is a folder): the temporary is removed */
    path_in(f, "sub", sub, sizeof(sub));
    assert_int_equal(mkdir(sub, 0755), 0);
    snprintf(path, sizeof(path), "%s/x.vls", sub);
    assert_int_equal(mkdir(path, 0755), 0);
    int before = count_entries(sub);
    assert_int_equal(vbi_vl_file_save(path, &t.h, &t.vls, t.ps, &err), VBNL_ERR_IO);
    print_message("# %s\n", err.message);
    assert_int_equal(count_entries(sub), before);
    rmdir(path);
    assert_int_equal(count_entries(sub), 0);
    /* and it works when the path is writable, leaving exactly one file */
    assert_int_equal(vbi_vl_file_save(path, &t.h, &t.vls, t.ps, &err), VBNL_OK);
    assert_int_equal(count_entries(sub), 1);
    unlink(path);
    rmdir(sub);
    /* through the integrator */
    char set[520];
    path_in(f, "no/such/folder/y.vls", path, sizeof(path));
    snprintf(set, sizeof(set), "save_lights=%s", path);
    const char *const settings[] = {LIGHTS, "photon_paths=20000", set, NULL};
    vbnl_result res;
    assert_null(run(f, f->scene, 0, settings, &res, &err));
    assert_int_equal(res, VBNL_ERR_IO);
    tiny_set_free(&t);
}

/* ---- abandoned saves: a second Ctrl-C during --save-lights -------------------------------------
 *
 * The save goes through the core's atomic files (atomic_file.h), so the table that the plugin's
 * abandon_writes empties from the host's signal handler lists its temporary too. Abandoning cannot
 * be undone in a process, so each case runs in a forked child (the fixture of these cases starts
 * no thread: the context and scene stay NULL) that reports by its exit status. */

static int setup_dir(void **state)
{
    fixture *f = calloc(1, sizeof(*f));
    snprintf(f->dir, sizeof(f->dir), "/tmp/vbnl-vlfile-XXXXXX");
    assert_non_null(mkdtemp(f->dir));
    *state = f;
    return 0;
}

static void on_signal_abandon(int sig)
{
    (void)sig;
    vbi_atomic_file_abandon_all();
    _exit(42);
}

/* A save held by the test hook VBNL_TEST_HOOK_PAUSE_WRITES (asked for through a context) with its
 * temporary complete and not yet renamed (the pause is announced on `err_fd`); the parent then
 * sends SIGUSR1, whose handler abandons and leaves. */
static int child_save_paused(const tiny_set *t, const char *path, int err_fd)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof(sa));
    sa.sa_handler = on_signal_abandon;
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = 1;
    cd.test_hooks = VBNL_TEST_HOOK_PAUSE_WRITES;
    vbnl_context *ctx = NULL;
    if (sigaction(SIGUSR1, &sa, NULL) != 0 || dup2(err_fd, STDERR_FILENO) < 0 ||
        vbnl_context_create(&cd, &ctx, NULL) != VBNL_OK)
        return 1;
    vbi_vl_file_save(path, &t->h, &t->vls, t->ps, NULL);
    return 2; /* the pause lasts 30 s: the signal comes long before */
}

/* Abandoned before the save: it fails with VBNL_ERR_CANCELLED, over an existing file or not. */
static int child_save_after_abandon(const tiny_set *t, const char *fresh, const char *existing)
{
    vbnl_error err = {0};
    vbi_atomic_file_abandon_all();
    if (vbi_vl_file_save(existing, &t->h, &t->vls, t->ps, &err) != VBNL_ERR_CANCELLED)
        return 1;
    if (!strstr(err.message, "cannot write") || !strstr(err.message, existing) || !strstr(err.message, "abandoned"))
        return 2;
    if (vbi_vl_file_save(fresh, &t->h, &t->vls, t->ps, &err) != VBNL_ERR_CANCELLED)
        return 3;
    return 0;
}

/* Reads the child's stderr until the pause line; 0 when it came within 60 s. */
static int await_pause(int fd, char *buf, size_t cap)
{
    size_t len = 0;
    buf[0] = '\0';
    while (len + 1 < cap) {
        struct pollfd p = {fd, POLLIN, 0};
        if (poll(&p, 1, 60000) <= 0)
            return -1;
        ssize_t got = read(fd, buf + len, cap - 1 - len);
        if (got <= 0)
            return -1;
        len += (size_t)got;
        buf[len] = '\0';
        const char *at = strstr(buf, "vbnl: test pause (write)");
        if (at && strchr(at, '\n'))
            return 0;
    }
    return -1;
}

/* The name in `dir` that contains `part`, or "" */
static void find_entry(const char *dir, const char *part, char *out, size_t n)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    out[0] = '\0';
    while (d && (e = readdir(d)))
        if (strstr(e->d_name, part))
            snprintf(out, n, "%s", e->d_name);
    if (d)
        closedir(d);
}

static void test_abandoned_saves(void **state)
{
    fixture *f = *state;
    tiny_set t;
    tiny_set_make(&t);
    char old[400], fresh[400];
    path_in(f, "old.vls", old, sizeof(old));
    path_in(f, "fresh.vls", fresh, sizeof(fresh));
    static const char previous[] = "previous lights";
    write_all(old, previous, sizeof(previous));

    /* abandoned during the save, its temporary complete: the handler removes it */
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        close(fds[0]);
        _exit(child_save_paused(&t, old, fds[1]));
    }
    close(fds[1]);
    char said[2048], tmp[256];
    int paused = await_pause(fds[0], said, sizeof(said));
    close(fds[0]);
    find_entry(f->dir, "old.vls.tmp-", tmp, sizeof(tmp));
    int status = 0;
    if (paused == 0)
        kill(pid, SIGUSR1);
    else
        kill(pid, SIGKILL);
    assert_int_equal(waitpid(pid, &status, 0), pid);
    said[strcspn(said, "\n")] = '\0';
    print_message("# child said: %s\n", said);
    assert_int_equal(paused, 0);
    assert_true(tmp[0] != '\0');        /* the write was under way */
    assert_non_null(strstr(said, tmp)); /* and paused on this temporary */
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 42);
    assert_int_equal(count_entries(f->dir), 1); /* no temporary left */
    size_t n;
    unsigned char *b = read_all(old, &n);
    assert_int_equal(n, sizeof(previous));
    assert_memory_equal(b, previous, n);
    free(b);

    /* abandoned before: every save fails with CANCELLED and leaves nothing */
    fflush(stdout);
    fflush(stderr);
    pid = fork();
    assert_true(pid >= 0);
    if (pid == 0)
        _exit(child_save_after_abandon(&t, fresh, old));
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    assert_int_equal(count_entries(f->dir), 1);
    b = read_all(old, &n);
    assert_int_equal(n, sizeof(previous));
    assert_memory_equal(b, previous, n);
    free(b);

    /* this process abandoned nothing: its saves still work */
    vbnl_error err = {0};
    assert_int_equal(vbi_vl_file_save(fresh, &t.h, &t.vls, t.ps, &err), VBNL_OK);
    assert_int_equal(count_entries(f->dir), 2);
    tiny_set_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_round_trip_arrays, setup, teardown),
        cmocka_unit_test_setup_teardown(test_round_trip_render, setup, teardown),
        cmocka_unit_test_setup_teardown(test_damaged, setup, teardown),
        cmocka_unit_test_setup_teardown(test_wrong_version, setup, teardown),
        cmocka_unit_test_setup_teardown(test_other_scene, setup, teardown),
        cmocka_unit_test_setup_teardown(test_photon_ranges_merge, setup, teardown),
        cmocka_unit_test_setup_teardown(test_placement_then_photons, setup, teardown),
        cmocka_unit_test_setup_teardown(test_unwritable, setup, teardown),
        cmocka_unit_test_setup_teardown(test_abandoned_saves, setup_dir, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
