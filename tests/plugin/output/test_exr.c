/* Tests for the EXR side of plugin/output/image_io.h. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <openexr.h>

#include "atomic_file.h" /* the core's atomic files, tested here with the writers that use them */
#include "image_io.h"

/* ---- fixtures: one fresh directory under /tmp per test ---- */

typedef struct fixture {
    char dir[64];
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    if (!f)
        return -1;
    snprintf(f->dir, sizeof f->dir, "/tmp/vbnl-test-exr-XXXXXX");
    if (!mkdtemp(f->dir)) {
        free(f);
        return -1;
    }
    *state = f;
    return 0;
}

static void remove_tree(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    char p[512];
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        struct stat st;
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode)) {
            chmod(p, 0700);
            remove_tree(p);
        } else {
            unlink(p);
        }
    }
    closedir(d);
    rmdir(dir);
}

static int teardown(void **state)
{
    fixture *f = *state;
    remove_tree(f->dir);
    free(f);
    return 0;
}

static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, ".."))
            n++;
    closedir(d);
    return n;
}

/* A path inside the fixture directory, in a buffer of the caller's scope. */
#define TMP_PATH(var, name)                                                                        \
    char var[512];                                                                                 \
    snprintf(var, sizeof var, "%s/%s", f->dir, name)

static float *make_data(uint32_t w, uint32_t h, uint32_t ch, float seed)
{
    float *d = malloc(sizeof(float) * w * h * ch);
    assert_non_null(d);
    for (uint32_t i = 0; i < w * h * ch; i++)
        d[i] = seed + 0.001f * (float)i + (float)(i % 7) * 0.37f - 1.0f;
    return d;
}

static int same_bits(float a, float b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

/* ---- FLOAT: bit-exact, three layers, attributes ---- */

static void test_float_roundtrip_layers_and_attrs(void **state)
{
    fixture *f = *state;
    const uint32_t W = 13, H = 37; /* ZIP packs 16 lines: 3 chunks, the last partial */
    float *beauty = make_data(W, H, 4, 0.5f);
    float *albedo = make_data(W, H, 3, 2.0f);
    float *depth = make_data(W, H, 1, 100.0f);
    /* values whose bits must survive: -0, denormal, huge, infinities */
    beauty[0] = -0.0f;
    beauty[1] = 1e-40f;
    beauty[2] = 3.0e38f;
    beauty[3] = INFINITY;
    depth[W * H - 1] = -INFINITY;

    static const char *const rgb[] = {"R", "G", "B"};
    static const char *const z[] = {"Z"};
    const vbi_image_layer layers[] = {
        {"", 4, NULL, beauty}, {"albedo", 3, rgb, albedo}, {"depth", 1, z, depth}};
    vbi_image_attr attrs[5] = {
        {.name = "vbnl/integrator", .type = VBI_IMAGE_ATTR_STRING, .value.s = "path"},
        {.name = "vbnl/spp", .type = VBI_IMAGE_ATTR_INT, .value.i = 64},
        {.name = "vbnl/seed", .type = VBI_IMAGE_ATTR_INT, .value.i = -7},
        {.name = "vbnl/rr_threshold", .type = VBI_IMAGE_ATTR_FLOAT, .value.f = 0.125f},
        {.name = "vbnl/time_render_s", .type = VBI_IMAGE_ATTR_DOUBLE, .value.d = 12.3456789012345},
    };
    TMP_PATH(p, "out.exr");
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_write(p, W, H, layers, 3, attrs, 5, 0, &err), VBNL_OK);
    assert_int_equal(count_entries(f->dir), 1); /* no temporary left behind */

    vbi_exr_image img;
    assert_int_equal(vbi_exr_read(p, &img, &err), VBNL_OK);
    assert_int_equal(img.width, W);
    assert_int_equal(img.height, H);
    assert_int_equal(img.data_x, 0);
    assert_int_equal(img.data_y, 0);
    assert_int_equal(img.channel_count, 8);

    static const char *const names[] = {"R", "G", "B", "A"};
    for (uint32_t c = 0; c < 4; c++) {
        const vbi_exr_channel *ch = vbi_exr_image_channel(&img, names[c]);
        assert_non_null(ch);
        assert_int_equal(ch->stored_type, VBI_EXR_PIXEL_FLOAT);
        for (uint32_t i = 0; i < W * H; i++)
            assert_true(same_bits(ch->data[i], beauty[i * 4 + c]));
    }
    static const char *const anames[] = {"albedo.R", "albedo.G", "albedo.B"};
    for (uint32_t c = 0; c < 3; c++) {
        const vbi_exr_channel *ch = vbi_exr_image_channel(&img, anames[c]);
        assert_non_null(ch);
        for (uint32_t i = 0; i < W * H; i++)
            assert_true(same_bits(ch->data[i], albedo[i * 3 + c]));
    }
    const vbi_exr_channel *zc = vbi_exr_image_channel(&img, "depth.Z");
    assert_non_null(zc);
    for (uint32_t i = 0; i < W * H; i++)
        assert_true(same_bits(zc->data[i], depth[i]));
    assert_null(vbi_exr_image_channel(&img, "Z"));

    const vbi_image_attr *a = vbi_exr_image_attr(&img, "vbnl/integrator");
    assert_non_null(a);
    assert_int_equal(a->type, VBI_IMAGE_ATTR_STRING);
    assert_string_equal(a->value.s, "path");
    a = vbi_exr_image_attr(&img, "vbnl/spp");
    assert_non_null(a);
    assert_int_equal(a->type, VBI_IMAGE_ATTR_INT);
    assert_int_equal(a->value.i, 64);
    a = vbi_exr_image_attr(&img, "vbnl/seed");
    assert_non_null(a);
    assert_int_equal(a->value.i, -7);
    a = vbi_exr_image_attr(&img, "vbnl/rr_threshold");
    assert_non_null(a);
    assert_int_equal(a->type, VBI_IMAGE_ATTR_FLOAT);
    assert_true(a->value.f == 0.125f);
    a = vbi_exr_image_attr(&img, "vbnl/time_render_s");
    assert_non_null(a);
    assert_int_equal(a->type, VBI_IMAGE_ATTR_DOUBLE);
    assert_true(a->value.d == 12.3456789012345);

    assert_true(img.has_chromaticities);
    const float rec709[8] = {0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f};
    for (int i = 0; i < 8; i++)
        assert_true(img.chromaticities[i] == rec709[i]);

    vbi_exr_image_free(&img);
    assert_null(img.channels);
    vbi_exr_image_free(&img); /* twice is fine */
    free(beauty);
    free(albedo);
    free(depth);
}

/* ---- a part of an image: data window inside the display window ---- */

static void test_data_window(void **state)
{
    fixture *f = *state;
    /* the window starts at row 17 (not a multiple of ZIP's 16 lines) and ends inside a chunk */
    const uint32_t DW = 20, DH = 60, win[4] = {3, 17, 11, 50};
    const uint32_t w = win[2] - win[0], h = win[3] - win[1];
    float *beauty = make_data(w, h, 4, 0.25f);
    float *depth = make_data(w, h, 1, 7.0f);
    static const char *const z[] = {"Z"};
    const vbi_image_layer layers[] = {{"", 4, NULL, beauty}, {"depth", 1, z, depth}};
    const vbi_image_attr attr = {.name = "vbnl/crop", .type = VBI_IMAGE_ATTR_STRING, .value.s = "3,17,11,50"};
    TMP_PATH(p, "part.exr");
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_write_window(p, DW, DH, win, layers, 2, &attr, 1, 0, &err), VBNL_OK);
    vbi_exr_image img;
    assert_int_equal(vbi_exr_read(p, &img, &err), VBNL_OK);
    assert_int_equal(img.width, w);
    assert_int_equal(img.height, h);
    assert_int_equal(img.data_x, 3);
    assert_int_equal(img.data_y, 17);
    assert_int_equal(img.display_x, 0);
    assert_int_equal(img.display_y, 0);
    assert_int_equal(img.display_width, DW);
    assert_int_equal(img.display_height, DH);
    static const char *const names[] = {"R", "G", "B", "A"};
    for (uint32_t c = 0; c < 4; c++) {
        const vbi_exr_channel *ch = vbi_exr_image_channel(&img, names[c]);
        assert_non_null(ch);
        for (uint32_t i = 0; i < w * h; i++)
            assert_true(same_bits(ch->data[i], beauty[i * 4 + c]));
    }
    const vbi_exr_channel *zc = vbi_exr_image_channel(&img, "depth.Z");
    assert_non_null(zc);
    for (uint32_t i = 0; i < w * h; i++)
        assert_true(same_bits(zc->data[i], depth[i]));
    assert_string_equal(vbi_exr_image_attr(&img, "vbnl/crop")->value.s, "3,17,11,50");
    vbi_exr_image_free(&img);
    /* a whole image reads back with its display window equal to the data window */
    assert_int_equal(vbi_exr_write(p, w, h, layers, 2, NULL, 0, 0, &err), VBNL_OK);
    assert_int_equal(vbi_exr_read(p, &img, &err), VBNL_OK);
    assert_int_equal(img.display_width, w);
    assert_int_equal(img.display_height, h);
    vbi_exr_image_free(&img);
    /* windows that are empty or reach outside */
    const uint32_t outside[4] = {3, 17, 21, 50}, empty[4] = {3, 17, 3, 50};
    TMP_PATH(q, "bad.exr");
    assert_int_equal(vbi_exr_write_window(q, DW, DH, outside, layers, 2, NULL, 0, 0, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "data window"));
    assert_int_equal(vbi_exr_write_window(q, DW, DH, empty, layers, 2, NULL, 0, 0, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(count_entries(f->dir), 1);
    free(beauty);
    free(depth);
}

/* ---- HALF: within half precision ---- */

static void test_half_roundtrip(void **state)
{
    fixture *f = *state;
    const uint32_t W = 9, H = 20;
    float *beauty = make_data(W, H, 3, 0.1f);
    beauty[0] = 65504.0f;  /* largest half */
    beauty[1] = 1e6f;      /* overflows to +inf */
    beauty[2] = 3.0e-6f;   /* half denormal */
    beauty[3] = -2.5f;
    beauty[4] = 0.0f;
    beauty[5] = NAN;
    const vbi_image_layer layer = {"", 3, NULL, beauty};
    TMP_PATH(p, "half.exr");
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_write(p, W, H, &layer, 1, NULL, 0, 1, &err), VBNL_OK);

    vbi_exr_image img;
    assert_int_equal(vbi_exr_read(p, &img, &err), VBNL_OK);
    assert_int_equal(img.channel_count, 3);
    static const char *const names[] = {"R", "G", "B"};
    for (uint32_t c = 0; c < 3; c++) {
        const vbi_exr_channel *ch = vbi_exr_image_channel(&img, names[c]);
        assert_non_null(ch);
        assert_int_equal(ch->stored_type, VBI_EXR_PIXEL_HALF);
        for (uint32_t i = 0; i < W * H; i++) {
            float want = beauty[i * 3 + c], got = ch->data[i];
            if (isnan(want)) {
                assert_true(isnan(got));
            } else if (fabsf(want) > 65520.0f) {
                assert_true(isinf(got) && (got > 0) == (want > 0));
            } else {
                /* half: 11 significant bits, denormal step 2^-24; round to nearest */
                float tol = fmaxf(fabsf(want) * 0x1p-11f, 0x1p-25f);
                if (fabsf(got - want) > tol)
                    fail_msg("%s[%u]: wrote %.9g, read %.9g", names[c], i, (double)want,
                             (double)got);
            }
        }
    }
    assert_true(vbi_exr_image_channel(&img, "R")->data[0] == 65504.0f);
    const float g0 = vbi_exr_image_channel(&img, "G")->data[0];
    assert_true(isinf(g0) && g0 > 0.0f);
    vbi_exr_image_free(&img);
    free(beauty);
}

/* ---- regression: HALF RGBA from another writer, channel order ---- */

/* Writes a HALF RGBA file with the raw core API as another program would: planar buffers,
 * channels declared R,G,B,A (the library stores them A,B,G,R). */
static void write_foreign_half_rgba(const char *path, int w, int h, exr_compression_t comp,
                                    const float *const *planes /* R,G,B,A */)
{
    static const char *const names[] = {"R", "G", "B", "A"};
    exr_context_t ctxt = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part = 0;
    assert_int_equal(exr_start_write(&ctxt, path, EXR_WRITE_FILE_DIRECTLY, &init), 0);
    assert_int_equal(exr_add_part(ctxt, "", EXR_STORAGE_SCANLINE, &part), 0);
    assert_int_equal(exr_initialize_required_attr_simple(ctxt, part, w, h, comp), 0);
    for (int c = 0; c < 4; c++)
        assert_int_equal(exr_add_channel(ctxt, part, names[c], EXR_PIXEL_HALF,
                                         EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1), 0);
    assert_int_equal(exr_write_header(ctxt), 0);

    uint16_t *half[4];
    for (int c = 0; c < 4; c++) {
        half[c] = malloc(sizeof(uint16_t) * (size_t)w * (size_t)h);
        assert_non_null(half[c]);
        for (int i = 0; i < w * h; i++) {
            /* the test values are exact halves: build the bits from frexp, no library */
            float v = planes[c][i];
            int e;
            float m = frexpf(v, &e); /* v = m * 2^e, m in [0.5,1) */
            assert_true(v > 0.0f && e >= -13 && e <= 16);
            uint32_t mant = (uint32_t)((m * 2.0f - 1.0f) * 1024.0f);
            half[c][i] = (uint16_t)(((uint32_t)(e - 1 + 15) << 10) | mant);
        }
    }
    int32_t lines = 1;
    assert_int_equal(exr_get_scanlines_per_chunk(ctxt, part, &lines), 0);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    for (int y = 0; y < h; y += lines) {
        exr_chunk_info_t cinfo;
        assert_int_equal(exr_write_scanline_chunk_info(ctxt, part, y, &cinfo), 0);
        if (y == 0)
            assert_int_equal(exr_encoding_initialize(ctxt, part, &cinfo, &enc), 0);
        else
            assert_int_equal(exr_encoding_update(ctxt, part, &cinfo, &enc), 0);
        for (int c = 0; c < enc.channel_count; c++) {
            int k = -1;
            for (int j = 0; j < 4; j++)
                if (!strcmp(enc.channels[c].channel_name, names[j]))
                    k = j;
            assert_true(k >= 0);
            enc.channels[c].user_bytes_per_element = 2;
            enc.channels[c].user_data_type = EXR_PIXEL_HALF;
            enc.channels[c].user_pixel_stride = 2;
            enc.channels[c].user_line_stride = 2 * w;
            enc.channels[c].encode_from_ptr = (const uint8_t *)(half[k] + (size_t)y * w);
        }
        assert_int_equal(exr_encoding_choose_default_routines(ctxt, part, &enc), 0);
        assert_int_equal(exr_encoding_run(ctxt, part, &enc), 0);
    }
    exr_encoding_destroy(ctxt, &enc);
    assert_int_equal(exr_finish(&ctxt), 0);
    for (int c = 0; c < 4; c++)
        free(half[c]);
}

static void check_rgba_order(const char *path, int w, int h, const float *const *planes)
{
    vbi_exr_image img;
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_read(path, &img, &err), VBNL_OK);
    static const char *const names[] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; c++) {
        const vbi_exr_channel *ch = vbi_exr_image_channel(&img, names[c]);
        assert_non_null(ch);
        for (int i = 0; i < w * h; i++)
            if (ch->data[i] != planes[c][i])
                fail_msg("%s: channel %s pixel %d: expected %g, got %g", path, names[c], i,
                         (double)planes[c][i], (double)ch->data[i]);
    }
    vbi_exr_image_free(&img);
}

static void test_half_rgba_channel_order(void **state)
{
    fixture *f = *state;
    enum { W = 8, H = 19 };
    /* distinct per channel (and per pixel), all exactly representable as half */
    static float pr[W * H], pg[W * H], pb[W * H], pa[W * H];
    for (int i = 0; i < W * H; i++) {
        pr[i] = 0.25f + (float)(i % 8) * 0.03125f;
        pg[i] = 0.5f + (float)(i % 5) * 0.0625f;
        pb[i] = 1.0f + (float)(i % 3) * 0.125f;
        pa[i] = 2.0f + (float)(i % 4) * 0.25f;
    }
    const float *const planes[4] = {pr, pg, pb, pa};

    TMP_PATH(p1, "foreign_none.exr");
    write_foreign_half_rgba(p1, W, H, EXR_COMPRESSION_NONE, planes);
    check_rgba_order(p1, W, H, planes);
    TMP_PATH(p2, "foreign_zip.exr");
    write_foreign_half_rgba(p2, W, H, EXR_COMPRESSION_ZIP, planes);
    check_rgba_order(p2, W, H, planes);

    /* and through our own HALF writer */
    float inter[W * H * 4];
    for (int i = 0; i < W * H; i++) {
        inter[i * 4 + 0] = pr[i];
        inter[i * 4 + 1] = pg[i];
        inter[i * 4 + 2] = pb[i];
        inter[i * 4 + 3] = pa[i];
    }
    const vbi_image_layer layer = {"", 4, NULL, inter};
    TMP_PATH(p3, "ours_half.exr");
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_write(p3, W, H, &layer, 1, NULL, 0, 1, &err), VBNL_OK);
    check_rgba_order(p3, W, H, planes);
}

/* A tiled HALF file (other writers produce these) reads back at level 0. */
static void test_read_foreign_tiled(void **state)
{
    fixture *f = *state;
    const int W = 21, H = 10, T = 8; /* partial tiles on both edges */
    TMP_PATH(p, "tiled.exr");
    exr_context_t ctxt = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part = 0;
    assert_int_equal(exr_start_write(&ctxt, p, EXR_WRITE_FILE_DIRECTLY, &init), 0);
    assert_int_equal(exr_add_part(ctxt, "", EXR_STORAGE_TILED, &part), 0);
    assert_int_equal(exr_initialize_required_attr_simple(ctxt, part, W, H, EXR_COMPRESSION_ZIPS), 0);
    assert_int_equal(exr_set_tile_descriptor(ctxt, part, T, T, EXR_TILE_ONE_LEVEL,
                                             EXR_TILE_ROUND_DOWN), 0);
    assert_int_equal(exr_add_channel(ctxt, part, "Y", EXR_PIXEL_FLOAT,
                                     EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1), 0);
    assert_int_equal(exr_write_header(ctxt), 0);
    float *plane = malloc(sizeof(float) * W * H);
    assert_non_null(plane);
    for (int i = 0; i < W * H; i++)
        plane[i] = (float)i;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int first = 1;
    for (int ty = 0; ty * T < H; ty++) {
        for (int tx = 0; tx * T < W; tx++) {
            exr_chunk_info_t cinfo;
            assert_int_equal(exr_write_tile_chunk_info(ctxt, part, tx, ty, 0, 0, &cinfo), 0);
            if (first)
                assert_int_equal(exr_encoding_initialize(ctxt, part, &cinfo, &enc), 0);
            else
                assert_int_equal(exr_encoding_update(ctxt, part, &cinfo, &enc), 0);
            first = 0;
            enc.channels[0].user_bytes_per_element = 4;
            enc.channels[0].user_data_type = EXR_PIXEL_FLOAT;
            enc.channels[0].user_pixel_stride = 4;
            enc.channels[0].user_line_stride = 4 * W;
            enc.channels[0].encode_from_ptr =
                (const uint8_t *)(plane + (size_t)(ty * T) * W + (size_t)(tx * T));
            assert_int_equal(exr_encoding_choose_default_routines(ctxt, part, &enc), 0);
            assert_int_equal(exr_encoding_run(ctxt, part, &enc), 0);
        }
    }
    exr_encoding_destroy(ctxt, &enc);
    assert_int_equal(exr_finish(&ctxt), 0);

    vbi_exr_image img;
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_read(p, &img, &err), VBNL_OK);
    assert_int_equal(img.width, W);
    assert_int_equal(img.height, H);
    const vbi_exr_channel *y = vbi_exr_image_channel(&img, "Y");
    assert_non_null(y);
    for (int i = 0; i < W * H; i++)
        if (y->data[i] != plane[i])
            fail_msg("tiled pixel %d: expected %g, got %g", i, (double)plane[i],
                     (double)y->data[i]);
    vbi_exr_image_free(&img);
    free(plane);
}

/* Names over 31 bytes need the EXR "long names" flag. */
static void test_long_channel_names(void **state)
{
    fixture *f = *state;
    float d[4] = {1, 2, 3, 4};
    static const char *const n[] = {"a_rather_long_channel_name_component"};
    const vbi_image_layer layer = {"lightgroup_key_light_with_a_long_name", 1, n, d};
    const vbi_image_attr attr = {.name = "vbnl/stage_time_seconds/bvh_build_and_upload",
                                  .type = VBI_IMAGE_ATTR_DOUBLE, .value.d = 0.25};
    TMP_PATH(p, "long.exr");
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_write(p, 2, 2, &layer, 1, &attr, 1, 0, &err), VBNL_OK);
    vbi_exr_image img;
    assert_int_equal(vbi_exr_read(p, &img, &err), VBNL_OK);
    const vbi_image_attr *a = vbi_exr_image_attr(&img, attr.name);
    assert_non_null(a);
    assert_true(a->value.d == 0.25);
    const vbi_exr_channel *c = vbi_exr_image_channel(
        &img, "lightgroup_key_light_with_a_long_name.a_rather_long_channel_name_component");
    assert_non_null(c);
    assert_true(c->data[3] == 4.0f);
    vbi_exr_image_free(&img);
}

/* ---- failure handling ---- */

static void test_write_into_missing_directory(void **state)
{
    fixture *f = *state;
    float d[3 * 4] = {0};
    const vbi_image_layer layer = {"", 3, NULL, d};
    TMP_PATH(p, "no/such/dir/out.exr");
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_write(p, 2, 2, &layer, 1, NULL, 0, 0, &err), VBNL_ERR_IO);
    assert_int_equal(err.code, VBNL_ERR_IO);
    assert_non_null(strstr(err.message, p));
    assert_non_null(strstr(err.message, strerror(ENOENT)));
    assert_int_equal(access(p, F_OK), -1);
    assert_int_equal(count_entries(f->dir), 0);
}

static void write_text(const char *path, const char *text)
{
    FILE *fp = fopen(path, "wb");
    assert_non_null(fp);
    fputs(text, fp);
    assert_int_equal(fclose(fp), 0);
}

static int file_equals(const char *path, const char *text)
{
    char buf[256] = {0};
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return 0;
    size_t n = fread(buf, 1, sizeof buf - 1, fp);
    fclose(fp);
    return n == strlen(text) && memcmp(buf, text, n) == 0;
}

/* A write that fails half-way (the disk "fills up": RLIMIT_FSIZE) must leave the old file as it
 * was and no temporary file. */
static void test_failed_write_keeps_existing_file(void **state)
{
    fixture *f = *state;
    TMP_PATH(p, "keep.exr");
    write_text(p, "previous render");

    const uint32_t W = 64, H = 64;
    float *d = malloc(sizeof(float) * W * H * 4);
    assert_non_null(d);
    uint32_t s = 12345;
    for (uint32_t i = 0; i < W * H * 4; i++) { /* incompressible */
        s = s * 1664525u + 1013904223u;
        d[i] = (float)(s >> 8) / 16777216.0f;
    }
    const vbi_image_layer layer = {"", 4, NULL, d};

    struct rlimit old;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &old), 0);
    void (*old_handler)(int) = signal(SIGXFSZ, SIG_IGN);
    struct rlimit small = {4096, old.rlim_max};
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &small), 0);
    vbnl_error err = {0};
    vbnl_result r = vbi_exr_write(p, W, H, &layer, 1, NULL, 0, 0, &err);
    setrlimit(RLIMIT_FSIZE, &old);
    signal(SIGXFSZ, old_handler);

    assert_int_equal(r, VBNL_ERR_IO);
    assert_non_null(strstr(err.message, p));
    assert_non_null(strstr(err.message, strerror(EFBIG)));
    assert_true(file_equals(p, "previous render"));
    assert_int_equal(count_entries(f->dir), 1);

    /* a failure at the very end (rename onto a non-empty directory) removes the temporary */
    TMP_PATH(dirp, "adir");
    assert_int_equal(mkdir(dirp, 0700), 0);
    TMP_PATH(inside, "adir/inside");
    write_text(inside, "x");
    r = vbi_exr_write(dirp, W, H, &layer, 1, NULL, 0, 0, &err);
    assert_int_equal(r, VBNL_ERR_IO);
    assert_non_null(strstr(err.message, dirp));
    assert_int_equal(count_entries(f->dir), 2);
    assert_int_equal(count_entries(dirp), 1);

    /* and a successful write does replace it */
    assert_int_equal(vbi_exr_write(p, W, H, &layer, 1, NULL, 0, 0, &err), VBNL_OK);
    assert_false(file_equals(p, "previous render"));
    assert_int_equal(count_entries(f->dir), 2);
    free(d);
}

static void test_write_into_readonly_directory(void **state)
{
    fixture *f = *state;
    if (geteuid() == 0) /* root ignores directory permissions; covered by the missing dir test */
        return;
    TMP_PATH(sub, "ro");
    assert_int_equal(mkdir(sub, 0500), 0);
    char p[600];
    snprintf(p, sizeof p, "%s/out.exr", sub);
    float d[3] = {0};
    const vbi_image_layer layer = {"", 3, NULL, d};
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_write(p, 1, 1, &layer, 1, NULL, 0, 0, &err), VBNL_ERR_IO);
    assert_non_null(strstr(err.message, strerror(EACCES)));
    assert_int_equal(count_entries(sub), 0);
}

static void copy_prefix(const char *from, const char *to, long bytes)
{
    FILE *in = fopen(from, "rb"), *out = fopen(to, "wb");
    assert_non_null(in);
    assert_non_null(out);
    for (long i = 0; i < bytes; i++) {
        int c = fgetc(in);
        if (c == EOF)
            break;
        fputc(c, out);
    }
    fclose(in);
    assert_int_equal(fclose(out), 0);
}

static long file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : -1;
}

static void test_read_damaged_files(void **state)
{
    fixture *f = *state;
    const uint32_t W = 32, H = 48;
    float *d = make_data(W, H, 4, 0.0f);
    const vbi_image_layer layer = {"", 4, NULL, d};
    TMP_PATH(good, "good.exr");
    vbnl_error err = {0};
    assert_int_equal(vbi_exr_write(good, W, H, &layer, 1, NULL, 0, 0, &err), VBNL_OK);
    long size = file_size(good);
    assert_true(size > 400);

    vbi_exr_image img;
    /* truncated: header only, half the data, all but the last byte */
    const long cuts[] = {0, 4, 100, size / 2, size - 1};
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        TMP_PATH(p, "cut.exr");
        copy_prefix(good, p, cuts[i]);
        memset(&err, 0, sizeof err);
        vbnl_result r = vbi_exr_read(p, &img, &err);
        if (r == VBNL_OK)
            fail_msg("truncated to %ld of %ld bytes but read succeeded", cuts[i], size);
        assert_int_equal(r, VBNL_ERR_CORRUPT);
        assert_non_null(strstr(err.message, p));
        assert_null(img.channels); /* zeroed on failure */
    }

    /* not an EXR at all */
    TMP_PATH(txt, "text.exr");
    write_text(txt, "this is not an OpenEXR file, just some text long enough to parse");
    assert_int_equal(vbi_exr_read(txt, &img, &err), VBNL_ERR_CORRUPT);

    /* damaged compressed data: must fail cleanly or decode something, never crash */
    TMP_PATH(bad, "flipped.exr");
    copy_prefix(good, bad, size);
    FILE *fp = fopen(bad, "r+b");
    assert_non_null(fp);
    for (long off = size / 2; off < size / 2 + 64; off++) {
        fseek(fp, off, SEEK_SET);
        fputc(0xA5, fp);
    }
    fclose(fp);
    if (vbi_exr_read(bad, &img, &err) == VBNL_OK)
        vbi_exr_image_free(&img);

    /* missing file */
    TMP_PATH(missing, "missing.exr");
    assert_int_equal(vbi_exr_read(missing, &img, &err), VBNL_ERR_IO);
    assert_non_null(strstr(err.message, "missing.exr"));
    free(d);
}

static void test_bad_arguments(void **state)
{
    fixture *f = *state;
    TMP_PATH(p, "args.exr");
    float d[8] = {0};
    static const char *const xy[] = {"X", "Y"};
    static const char *const dup[] = {"R", "R"};
    const vbi_image_layer ok = {"", 4, NULL, d};
    vbi_image_layer l;
    vbnl_error err = {0};

    assert_int_equal(vbi_exr_write(NULL, 1, 1, &ok, 1, NULL, 0, 0, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(err.code, VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_exr_write(p, 1, 1, NULL, 1, NULL, 0, 0, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_exr_write(p, 1, 1, &ok, 0, NULL, 0, 0, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_exr_write(p, 0, 1, &ok, 1, NULL, 0, 0, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_exr_write(p, 1, 0, &ok, 1, NULL, 0, 0, NULL), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_exr_write(p, 1, 1, &ok, 1, NULL, 2, 0, &err), VBNL_ERR_INVALID_ARGUMENT);
    l = ok;
    l.data = NULL;
    assert_int_equal(vbi_exr_write(p, 1, 1, &l, 1, NULL, 0, 0, &err), VBNL_ERR_INVALID_ARGUMENT);
    l = ok;
    l.name = NULL;
    assert_int_equal(vbi_exr_write(p, 1, 1, &l, 1, NULL, 0, 0, &err), VBNL_ERR_INVALID_ARGUMENT);
    l = ok;
    l.channels = 2; /* no default names for 2 channels */
    assert_int_equal(vbi_exr_write(p, 1, 1, &l, 1, NULL, 0, 0, &err), VBNL_ERR_INVALID_ARGUMENT);
    l.channel_names = xy;
    assert_int_equal(vbi_exr_write(p, 1, 1, &l, 1, NULL, 0, 0, &err), VBNL_OK);
    l.channel_names = dup;
    assert_int_equal(vbi_exr_write(p, 1, 1, &l, 1, NULL, 0, 0, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "'R'"));
    /* the same full name from two layers */
    const vbi_image_layer twice[2] = {ok, ok};
    assert_int_equal(vbi_exr_write(p, 1, 1, twice, 2, NULL, 0, 0, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    const vbi_image_attr reserved = {.name = "compression", .type = VBI_IMAGE_ATTR_INT};
    assert_int_equal(vbi_exr_write(p, 1, 1, &ok, 1, &reserved, 1, 0, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    const vbi_image_attr nulls = {.name = "s", .type = VBI_IMAGE_ATTR_STRING, .value.s = NULL};
    assert_int_equal(vbi_exr_write(p, 1, 1, &ok, 1, &nulls, 1, 0, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    const vbi_image_attr two[2] = {{.name = "k", .type = VBI_IMAGE_ATTR_INT},
                                    {.name = "k", .type = VBI_IMAGE_ATTR_FLOAT}};
    assert_int_equal(vbi_exr_write(p, 1, 1, &ok, 1, two, 2, 0, &err), VBNL_ERR_INVALID_ARGUMENT);

    vbi_exr_image img;
    assert_int_equal(vbi_exr_read(NULL, &img, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_exr_read(p, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbi_exr_image_free(NULL);
    assert_null(vbi_exr_image_channel(NULL, "R"));
    assert_null(vbi_exr_image_attr(NULL, "x"));
    /* only args.exr from the one valid call above */
    assert_int_equal(count_entries(f->dir), 1);
}

/* ---- abandoned writes: what a second Ctrl-C does before _exit ---- */

/* vbi_atomic_file_abandon_all cannot be undone in a process, so each case runs in a child (this
 * test program has no other threads, fork is safe). The children report by exit status. */

static void on_signal_abandon(int sig)
{
    (void)sig;
    vbi_atomic_file_abandon_all();
    _exit(42);
}

/* Two writes under way (a new file, and one over an existing file) with data written, then a
 * signal whose handler abandons them and leaves. */
static int child_interrupted(const char *fresh, const char *existing)
{
    vbi_atomic_file a, b;
    if (vbi_atomic_file_open(&a, fresh, NULL) != VBNL_OK || vbi_atomic_file_open(&b, existing, NULL) != VBNL_OK)
        return 1;
    if (write(a.fd, "partial", 7) != 7 || write(b.fd, "partial", 7) != 7)
        return 2;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal_abandon;
    sigaction(SIGINT, &sa, NULL);
    raise(SIGINT);
    return 3; /* not reached */
}

/* Abandoned with one write open: its temporary is gone, its commit fails, and so does every write
 * that would start afterwards. */
static int child_after_abandon(const char *fresh, const char *existing)
{
    vbi_atomic_file a, b;
    vbnl_error err = {0};
    if (vbi_atomic_file_open(&a, existing, NULL) != VBNL_OK)
        return 1;
    vbi_atomic_file_abandon_all();
    if (access(a.tmp_path, F_OK) == 0)
        return 2;
    if (vbi_atomic_file_commit(&a, &err) != VBNL_ERR_CANCELLED || !strstr(err.message, "abandoned"))
        return 3;
    if (vbi_atomic_file_open(&b, fresh, &err) != VBNL_ERR_CANCELLED)
        return 4;
    float d[4] = {0};
    const vbi_image_layer l = {"", 4, NULL, d};
    if (vbi_exr_write(fresh, 1, 1, &l, 1, NULL, 0, 0, &err) != VBNL_ERR_CANCELLED)
        return 5;
    uint8_t px[3] = {0};
    if (vbi_png_write(fresh, 1, 1, 3, 8, px, &err) != VBNL_ERR_CANCELLED)
        return 6;
    return 0;
}

static int run_child(int (*fn)(const char *, const char *), const char *a, const char *b)
{
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid == 0)
        _exit(fn(a, b));
    int status;
    if (pid < 0 || waitpid(pid, &status, 0) != pid || !WIFEXITED(status))
        return -1;
    return WEXITSTATUS(status);
}

static void test_abandoned_writes_leave_nothing(void **state)
{
    fixture *f = *state;
    TMP_PATH(fresh, "fresh.exr");
    TMP_PATH(old, "old.exr");
    write_text(old, "previous render");
    assert_int_equal(run_child(child_interrupted, fresh, old), 42);
    assert_true(file_equals(old, "previous render"));
    assert_int_equal(count_entries(f->dir), 1);
    assert_int_equal(run_child(child_after_abandon, fresh, old), 0);
    assert_true(file_equals(old, "previous render"));
    assert_int_equal(count_entries(f->dir), 1);
    /* this process abandoned nothing: its writes still work */
    float d[4] = {1, 2, 3, 1};
    const vbi_image_layer l = {"", 4, NULL, d};
    assert_int_equal(vbi_exr_write(fresh, 1, 1, &l, 1, NULL, 0, 0, NULL), VBNL_OK);
    assert_int_equal(count_entries(f->dir), 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_float_roundtrip_layers_and_attrs, setup, teardown),
        cmocka_unit_test_setup_teardown(test_data_window, setup, teardown),
        cmocka_unit_test_setup_teardown(test_half_roundtrip, setup, teardown),
        cmocka_unit_test_setup_teardown(test_half_rgba_channel_order, setup, teardown),
        cmocka_unit_test_setup_teardown(test_read_foreign_tiled, setup, teardown),
        cmocka_unit_test_setup_teardown(test_long_channel_names, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_into_missing_directory, setup, teardown),
        cmocka_unit_test_setup_teardown(test_failed_write_keeps_existing_file, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_into_readonly_directory, setup, teardown),
        cmocka_unit_test_setup_teardown(test_read_damaged_files, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bad_arguments, setup, teardown),
        cmocka_unit_test_setup_teardown(test_abandoned_writes_leave_nothing, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
