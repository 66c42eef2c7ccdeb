/* Colour management: the OpenColorIO shim's embedded config and views, $OCIO and explicit configs,
 * errors, and the display quantiser (clamp, dither, 8/16 bits). */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
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

#include "image_io.h"
#include "ocio_shim.h"

static float srgb_oetf(double v)
{
    return (float)(v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055);
}

static void test_standard_is_srgb(void **state)
{
    (void)state;
    unsetenv("OCIO");
    float px[4 * 4] = {0.18f, 0.18f, 0.18f, 0.5f, 0.0f, 0.002f, 1.0f, 1.0f,
                       0.5f, 0.25f, 0.75f, 0.0f, 2.0f, 0.001f, 0.04f, 1.0f};
    float in[16];
    memcpy(in, px, sizeof(px));
    char msg[512] = "";
    assert_int_equal(vbi_ocio_apply(NULL, "sRGB", "Standard", px, 2, 2, 4, msg, sizeof(msg)), 0);
    /* the reference value: linear 0.18 -> 0.4614 */
    for (int c = 0; c < 3; ++c)
        assert_true(fabsf(px[c] - 0.4614f) < 5e-4f);
    for (int i = 0; i < 4; ++i) {
        for (int c = 0; c < 3; ++c) {
            float want = in[4 * i + c] <= 1.0f ? srgb_oetf(in[4 * i + c]) : px[4 * i + c];
            assert_true(fabsf(px[4 * i + c] - want) < 2e-3f);
        }
        assert_true(px[4 * i + 3] == in[4 * i + 3]); /* alpha untouched */
    }
    /* the Standard view does not clip: 2.0 encodes above 1 */
    assert_true(px[12] > 1.0f);
    /* defaults: display sRGB, view Standard */
    float d[3] = {0.18f, 0.18f, 0.18f};
    assert_int_equal(vbi_ocio_apply(NULL, NULL, NULL, d, 1, 1, 3, msg, sizeof(msg)), 0);
    assert_true(fabsf(d[0] - 0.4614f) < 5e-4f);
}

static void test_raw_is_identity(void **state)
{
    (void)state;
    unsetenv("OCIO");
    float px[3 * 5] = {0.18f, 0.5f, 0.7f, -1.0f, 3.0f, 1e-4f, 0.0f, 1.0f, 64.0f, 0.25f, 0.125f, 1e6f, 2.0f, 0.3f, 0.9f};
    float in[15];
    memcpy(in, px, sizeof(px));
    char msg[512];
    assert_int_equal(vbi_ocio_apply(NULL, "sRGB", "Raw", px, 5, 1, 3, msg, sizeof(msg)), 0);
    assert_memory_equal(px, in, sizeof(px));
}

static void test_aces_tone_maps(void **state)
{
    (void)state;
    unsetenv("OCIO");
    /* a grey ramp: monotonic, mid grey darker than the plain sRGB curve (the ACES RRT's contrast),
     * very bright values compress below 1 instead of passing above it */
    float px[3 * 6] = {0.01f, 0.01f, 0.01f, 0.05f, 0.05f, 0.05f, 0.18f, 0.18f, 0.18f,
                       1.0f, 1.0f, 1.0f, 4.0f, 4.0f, 4.0f, 100.0f, 100.0f, 100.0f};
    char msg[512];
    assert_int_equal(vbi_ocio_apply(NULL, "sRGB", "ACES 1.0 SDR-video", px, 6, 1, 3, msg, sizeof(msg)), 0);
    for (int i = 1; i < 6; ++i)
        assert_true(px[3 * i] > px[3 * (i - 1)]);
    assert_true(px[6] < 0.4614f - 0.05f);
    assert_true(px[12] < 1.0f && px[15] < 1.05f); /* the sRGB curve alone would give 7.0 for 100 */
    /* a saturated colour may go negative: the PNG path clamps (test_quantise) */
    float red[3] = {1.0f, 0.0f, 0.0f};
    assert_int_equal(vbi_ocio_apply(NULL, "sRGB", "ACES 1.0 SDR-video", red, 1, 1, 3, msg, sizeof(msg)), 0);
    assert_true(red[0] > 0.5f && red[1] < 0.05f);
}

static void test_errors_list_views(void **state)
{
    (void)state;
    unsetenv("OCIO");
    float px[3] = {0.5f, 0.5f, 0.5f};
    char msg[1024] = "";
    assert_int_equal(vbi_ocio_apply(NULL, "sRGB", "Filmic", px, 1, 1, 3, msg, sizeof(msg)), 4);
    assert_non_null(strstr(msg, "unknown view 'Filmic'"));
    assert_non_null(strstr(msg, "'Standard', 'ACES 1.0 SDR-video', 'Raw'"));
    assert_true(px[0] == 0.5f); /* untouched on error */
    assert_int_equal(vbi_ocio_apply(NULL, "Rec.2020", NULL, px, 1, 1, 3, msg, sizeof(msg)), 4);
    assert_non_null(strstr(msg, "unknown display 'Rec.2020'"));
    assert_non_null(strstr(msg, "display 'sRGB' with views"));
    assert_int_equal(vbi_ocio_apply("/nonexistent/config.ocio", NULL, NULL, px, 1, 1, 3, msg, sizeof(msg)), 6);
    assert_non_null(strstr(msg, "/nonexistent/config.ocio"));
    assert_int_equal(vbi_ocio_apply(NULL, NULL, NULL, px, 1, 1, 2, msg, sizeof(msg)), 1);
    assert_int_equal(vbi_ocio_apply(NULL, NULL, NULL, NULL, 1, 1, 3, msg, sizeof(msg)), 1);
}

/* A config file of the user's: given explicitly, or through $OCIO. Its only view halves values. */
static void test_config_file_and_env(void **state)
{
    (void)state;
    char path[] = "/tmp/vbnl-ocio-XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    const char *yaml = "ocio_profile_version: 2.1\n"
                       "roles: {default: lin, scene_linear: lin}\n"
                       "displays:\n  Half:\n    - !<View> {name: Halved, colorspace: halved}\n"
                       "colorspaces:\n"
                       "  - !<ColorSpace> {name: lin}\n"
                       "  - !<ColorSpace>\n    name: halved\n"
                       "    from_scene_reference: !<MatrixTransform> {matrix: [0.5,0,0,0, 0,0.5,0,0, 0,0,0.5,0, 0,0,0,1]}\n";
    assert_int_equal(write(fd, yaml, strlen(yaml)), (ssize_t)strlen(yaml));
    close(fd);
    char msg[1024] = "";
    float px[3] = {0.5f, 0.25f, 1.0f};
    assert_int_equal(vbi_ocio_apply(path, NULL, NULL, px, 1, 1, 3, msg, sizeof(msg)), 0);
    assert_true(fabsf(px[0] - 0.25f) < 1e-6f && fabsf(px[2] - 0.5f) < 1e-6f);
    setenv("OCIO", path, 1);
    float q[3] = {0.5f, 0.25f, 1.0f};
    assert_int_equal(vbi_ocio_apply(NULL, "Half", "Halved", q, 1, 1, 3, msg, sizeof(msg)), 0);
    assert_true(fabsf(q[1] - 0.125f) < 1e-6f);
    /* the embedded config's view is not in this one: the message says where it looked */
    assert_int_equal(vbi_ocio_apply(NULL, "sRGB", "Standard", q, 1, 1, 3, msg, sizeof(msg)), 4);
    assert_non_null(strstr(msg, "(from $OCIO)"));
    assert_non_null(strstr(msg, "'Halved'"));
    unsetenv("OCIO");
    unlink(path);
}

static void test_quantise(void **state)
{
    (void)state;
    const float src[4 * 3] = {-0.2f, 0.5f, 1.7f, NAN, 1.0f, 0.0f, 0.25f, 0.5f, NAN, 1.0f, 1.0f, 1.0f};
    uint8_t q8[3 * 3];
    uint16_t q16[3 * 3];
    assert_int_equal(vbi_display_quantise(src, 3, 1, 4, 8, 0, q8, 3, NULL), VBNL_OK);
    assert_int_equal(q8[0], 0);   /* negative clamps to 0 */
    assert_int_equal(q8[1], 128); /* 0.5 * 255 = 127.5 rounds up */
    assert_int_equal(q8[2], 255); /* above 1 clamps */
    assert_int_equal(q8[3], 255); /* pixel 1: source alpha skipped, R = 1 */
    assert_int_equal(vbi_display_quantise(src, 3, 1, 4, 16, 0, q16, 3, NULL), VBNL_OK);
    assert_int_equal(q16[1], 32768);
    assert_int_equal(q16[2], 65535);
    assert_int_equal(q16[4], 0);
    /* NaN -> 0 */
    assert_int_equal(vbi_display_quantise(src + 8, 1, 1, 4, 16, 1, q16, 3, NULL), VBNL_OK);
    assert_int_equal(q16[0], 0);
    /* dither: a flat 0.5 grey averages to 127.5 and is noisy, exact 0 and 1 stay exact */
    enum { W = 64, H = 64 };
    float *grey = malloc(sizeof(float) * 3 * W * H);
    uint8_t *out = malloc(3 * W * H);
    for (int i = 0; i < 3 * W * H; ++i)
        grey[i] = i % 3 == 0 ? 0.5f : i % 3 == 1 ? 0.0f : 1.0f;
    assert_int_equal(vbi_display_quantise(grey, W, H, 3, 8, 1, out, 3, NULL), VBNL_OK);
    double mean = 0.0;
    int distinct[256] = {0};
    for (int i = 0; i < W * H; ++i) {
        mean += out[3 * i];
        distinct[out[3 * i]] = 1;
        assert_int_equal(out[3 * i + 1], 0);
        assert_int_equal(out[3 * i + 2], 255);
    }
    mean /= W * H;
    assert_true(fabs(mean - 127.5) < 0.1);
    assert_true(distinct[127] && distinct[128]);
    free(grey);
    free(out);
    assert_int_equal(vbi_display_quantise(src, 1, 1, 4, 12, 0, q16, 3, NULL), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_display_quantise(NULL, 1, 1, 4, 8, 0, q8, 3, NULL), VBNL_ERR_INVALID_ARGUMENT);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_standard_is_srgb),  cmocka_unit_test(test_raw_is_identity),
        cmocka_unit_test(test_aces_tone_maps),    cmocka_unit_test(test_errors_list_views),
        cmocka_unit_test(test_config_file_and_env), cmocka_unit_test(test_quantise),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
