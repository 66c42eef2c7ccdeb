/* Tests for the PNG and sRGB side of plugin/output/image_io.h. */
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
#include <unistd.h>

#include "image_io.h"

typedef struct fixture {
    char dir[64];
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    if (!f)
        return -1;
    snprintf(f->dir, sizeof f->dir, "/tmp/vbnl-test-png-XXXXXX");
    if (!mkdtemp(f->dir)) {
        free(f);
        return -1;
    }
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    DIR *d = opendir(f->dir);
    if (d) {
        struct dirent *e;
        char p[512];
        while ((e = readdir(d))) {
            if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
                continue;
            snprintf(p, sizeof p, "%s/%s", f->dir, e->d_name);
            unlink(p);
        }
        closedir(d);
    }
    rmdir(f->dir);
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

/* ---- round trips ---- */

static void roundtrip8(const fixture *f, uint32_t channels)
{
    const uint32_t W = 17, H = 11;
    uint8_t *px = malloc((size_t)W * H * channels);
    assert_non_null(px);
    for (uint32_t i = 0; i < W * H * channels; i++)
        px[i] = (uint8_t)(i * 37u + i / 5u); /* covers 0..255, distinct per channel */
    TMP_PATH(p, "rt8.png");
    vbnl_error err = {0};
    assert_int_equal(vbi_png_write(p, W, H, channels, 8, px, &err), VBNL_OK);
    assert_int_equal(count_entries(f->dir), 1);

    vbi_png_image img;
    assert_int_equal(vbi_png_read(p, &img, &err), VBNL_OK);
    assert_int_equal(img.width, W);
    assert_int_equal(img.height, H);
    assert_int_equal(img.channels, channels);
    assert_int_equal(img.bit_depth, 8);
    assert_true(img.has_srgb);
    assert_memory_equal(img.pixels, px, (size_t)W * H * channels);
    vbi_png_image_free(&img);
    assert_null(img.pixels);
    free(px);
}

static void test_png8_roundtrip(void **state)
{
    roundtrip8(*state, 3);
    roundtrip8(*state, 4);
    roundtrip8(*state, 1);
}

static void test_png16_roundtrip(void **state)
{
    fixture *f = *state;
    const uint32_t W = 9, H = 7;
    for (uint32_t channels = 3; channels <= 4; channels++) {
        uint16_t *px = malloc(sizeof(uint16_t) * W * H * channels);
        assert_non_null(px);
        /* high and low bytes differ, so a byte-order mistake shows */
        for (uint32_t i = 0; i < W * H * channels; i++)
            px[i] = (uint16_t)(i * 1031u + 0x0102u);
        px[0] = 0;
        px[1] = 0xffff;
        TMP_PATH(p, "rt16.png");
        vbnl_error err = {0};
        assert_int_equal(vbi_png_write(p, W, H, channels, 16, px, &err), VBNL_OK);

        vbi_png_image img;
        assert_int_equal(vbi_png_read(p, &img, &err), VBNL_OK);
        assert_int_equal(img.channels, channels);
        assert_int_equal(img.bit_depth, 16);
        assert_true(img.has_srgb);
        assert_memory_equal(img.pixels, px, sizeof(uint16_t) * W * H * channels);
        vbi_png_image_free(&img);
        free(px);
    }
}

/* ---- sRGB conversion ---- */

static uint8_t srgb1(float v, int dither)
{
    float px[3] = {v, v, v};
    uint8_t out[3];
    vbnl_error err = {0};
    assert_int_equal(vbi_linear_to_srgb8(px, 1, 1, 3, 0.0f, dither, out, 3, &err), VBNL_OK);
    if (!dither) { /* same value in every channel encodes the same */
        assert_int_equal(out[1], out[0]);
        assert_int_equal(out[2], out[0]);
    }
    return out[0];
}

static void test_srgb_known_values(void **state)
{
    (void)state;
    assert_int_equal(srgb1(0.0f, 0), 0);
    assert_int_equal(srgb1(1.0f, 0), 255);
    assert_int_equal(srgb1(0.5f, 0), 188);
    assert_int_equal(srgb1(0.18f, 0), 118);
    assert_int_equal(srgb1(0.001f, 0), 3);  /* linear segment: 12.92 * 0.001 * 255 = 3.29 */
    assert_int_equal(srgb1(-1.0f, 0), 0);   /* clamp */
    assert_int_equal(srgb1(7.0f, 0), 255);  /* clamp */
    assert_int_equal(srgb1(NAN, 0), 0);
    assert_int_equal(srgb1(INFINITY, 0), 255);

    /* exposure: +1 stop doubles the linear value */
    float px[3] = {0.25f, 0.09f, 0.0f};
    uint8_t out[4];
    vbnl_error err = {0};
    assert_int_equal(vbi_linear_to_srgb8(px, 1, 1, 3, 1.0f, 0, out, 4, &err), VBNL_OK);
    assert_int_equal(out[0], 188);
    assert_int_equal(out[1], 118);
    assert_int_equal(out[2], 0);
    assert_int_equal(out[3], 255); /* no source alpha -> opaque */

    /* alpha is linear, untouched by exposure */
    float rgba[4] = {1.0f, 1.0f, 1.0f, 0.5f};
    assert_int_equal(vbi_linear_to_srgb8(rgba, 1, 1, 4, 3.0f, 0, out, 4, &err), VBNL_OK);
    assert_int_equal(out[3], 128);
}

static void test_srgb_dither(void **state)
{
    (void)state;
    enum { W = 64, H = 64 };
    static float img[W * H * 3];
    static uint8_t a[W * H * 3], b[W * H * 3];
    const float vals[] = {0.5f, 0.18f, 0.0f, 1.0f};
    const int want[] = {188, 118, 0, 255};
    for (int v = 0; v < 4; v++) {
        for (int i = 0; i < W * H * 3; i++)
            img[i] = vals[v];
        vbnl_error err = {0};
        assert_int_equal(vbi_linear_to_srgb8(img, W, H, 3, 0.0f, 1, a, 3, &err), VBNL_OK);
        assert_int_equal(vbi_linear_to_srgb8(img, W, H, 3, 0.0f, 1, b, 3, &err), VBNL_OK);
        assert_memory_equal(a, b, sizeof a); /* deterministic */
        double sum = 0;
        int distinct = 0;
        for (int i = 0; i < W * H * 3; i++) {
            assert_true(abs((int)a[i] - want[v]) <= 1);
            sum += a[i];
            distinct |= a[i] != a[0];
        }
        if (want[v] == 0 || want[v] == 255) {
            assert_false(distinct); /* black and white stay exact */
        } else {
            assert_true(distinct); /* dither actually does something */
            /* and is unbiased: the mean tracks the unquantised value */
            double exact = vals[v] == 0.5f ? 187.5212 : 117.5538;
            assert_true(fabs(sum / (W * H * 3) - exact) < 0.1);
        }
    }
    /* a smooth ramp stays monotone on average and within 1 LSB of the undithered result */
    for (int x = 0; x < W; x++)
        for (int y = 0; y < H; y++)
            for (int c = 0; c < 3; c++)
                img[(y * W + x) * 3 + c] = (float)x / (W - 1);
    vbnl_error err = {0};
    assert_int_equal(vbi_linear_to_srgb8(img, W, H, 3, 0.0f, 1, a, 3, &err), VBNL_OK);
    assert_int_equal(vbi_linear_to_srgb8(img, W, H, 3, 0.0f, 0, b, 3, &err), VBNL_OK);
    for (int i = 0; i < W * H * 3; i++)
        assert_true(abs((int)a[i] - (int)b[i]) <= 1);
}

/* ---- errors ---- */

static void test_png_errors(void **state)
{
    fixture *f = *state;
    uint8_t px[4 * 4] = {0};
    vbnl_error err = {0};
    TMP_PATH(p, "e.png");

    assert_int_equal(vbi_png_write(NULL, 2, 2, 4, 8, px, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_png_write(p, 2, 2, 4, 8, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_png_write(p, 0, 2, 4, 8, px, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_png_write(p, 2, 2, 2, 8, px, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_png_write(p, 2, 2, 4, 12, px, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_png_write(p, 2, 2, 4, 8, px, NULL), VBNL_OK); /* err is optional */

    vbi_png_image img;
    assert_int_equal(vbi_png_read(NULL, &img, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_png_read(p, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);

    /* missing directory: VBNL_ERR_IO naming the path and the reason, nothing left behind */
    TMP_PATH(nodir, "missing/dir/x.png");
    assert_int_equal(vbi_png_write(nodir, 2, 2, 4, 8, px, &err), VBNL_ERR_IO);
    assert_non_null(strstr(err.message, nodir));
    assert_non_null(strstr(err.message, strerror(ENOENT)));
    assert_int_equal(count_entries(f->dir), 1);

    /* missing, empty, non-PNG and truncated files */
    TMP_PATH(none, "none.png");
    assert_int_equal(vbi_png_read(none, &img, &err), VBNL_ERR_IO);
    TMP_PATH(junk, "junk.png");
    FILE *fp = fopen(junk, "wb");
    assert_non_null(fp);
    fclose(fp);
    assert_int_equal(vbi_png_read(junk, &img, &err), VBNL_ERR_CORRUPT);
    fp = fopen(junk, "wb");
    fputs("GIF89a and then some more bytes", fp);
    fclose(fp);
    assert_int_equal(vbi_png_read(junk, &img, &err), VBNL_ERR_CORRUPT);

    uint8_t big[32 * 32 * 3];
    for (size_t i = 0; i < sizeof big; i++)
        big[i] = (uint8_t)(i * 7919u >> 3);
    assert_int_equal(vbi_png_write(p, 32, 32, 3, 8, big, &err), VBNL_OK);
    struct stat st;
    assert_int_equal(stat(p, &st), 0);
    TMP_PATH(cut, "cut.png");
    const long cuts[] = {8, 40, st.st_size / 2, st.st_size - 13};
    for (size_t c = 0; c < sizeof cuts / sizeof cuts[0]; c++) {
        FILE *in = fopen(p, "rb"), *out = fopen(cut, "wb");
        assert_non_null(in);
        assert_non_null(out);
        for (long i = 0; i < cuts[c]; i++)
            fputc(fgetc(in), out);
        fclose(in);
        fclose(out);
        memset(&err, 0, sizeof err);
        assert_int_equal(vbi_png_read(cut, &img, &err), VBNL_ERR_CORRUPT);
        assert_non_null(strstr(err.message, cut));
        assert_null(img.pixels);
    }
    vbi_png_image_free(NULL);

    /* sRGB conversion arguments */
    float lin[3] = {0};
    uint8_t o[4];
    assert_int_equal(vbi_linear_to_srgb8(NULL, 1, 1, 3, 0, 0, o, 3, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_linear_to_srgb8(lin, 1, 1, 3, 0, 0, NULL, 3, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_linear_to_srgb8(lin, 1, 1, 2, 0, 0, o, 3, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_linear_to_srgb8(lin, 1, 1, 3, NAN, 0, o, 3, &err),
                     VBNL_ERR_INVALID_ARGUMENT);
}

/* A PNG write that fails half-way leaves the previous file and no temporary. */
static void test_png_failed_write_keeps_existing(void **state)
{
    fixture *f = *state;
    TMP_PATH(p, "keep.png");
    FILE *fp = fopen(p, "wb");
    assert_non_null(fp);
    fputs("previous", fp);
    assert_int_equal(fclose(fp), 0);

    const uint32_t W = 256, H = 256;
    uint8_t *px = malloc((size_t)W * H * 4);
    assert_non_null(px);
    uint32_t s = 99;
    for (size_t i = 0; i < (size_t)W * H * 4; i++) {
        s = s * 1664525u + 1013904223u;
        px[i] = (uint8_t)(s >> 24);
    }
    struct rlimit old;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &old), 0);
    void (*old_handler)(int) = signal(SIGXFSZ, SIG_IGN);
    struct rlimit small = {8192, old.rlim_max};
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &small), 0);
    vbnl_error err = {0};
    vbnl_result r = vbi_png_write(p, W, H, 4, 8, px, &err);
    setrlimit(RLIMIT_FSIZE, &old);
    signal(SIGXFSZ, old_handler);
    assert_int_equal(r, VBNL_ERR_IO);
    assert_non_null(strstr(err.message, p));
    assert_int_equal(count_entries(f->dir), 1);
    char buf[16] = {0};
    fp = fopen(p, "rb");
    assert_non_null(fp);
    assert_int_equal(fread(buf, 1, sizeof buf - 1, fp), 8);
    fclose(fp);
    assert_string_equal(buf, "previous");
    free(px);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_png8_roundtrip, setup, teardown),
        cmocka_unit_test_setup_teardown(test_png16_roundtrip, setup, teardown),
        cmocka_unit_test(test_srgb_known_values),
        cmocka_unit_test(test_srgb_dither),
        cmocka_unit_test_setup_teardown(test_png_errors, setup, teardown),
        cmocka_unit_test_setup_teardown(test_png_failed_write_keeps_existing, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
