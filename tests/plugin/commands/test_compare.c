/* `vbnl compare`: metrics of synthetic images with known values, the written error maps and
 * montage, and refusal of images of different sizes. */
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

#include "commands.h"
#include "image_io.h"

/* Reference: every channel 1, except pixel 0 (all 3). Candidate: reference + 0.1 everywhere,
 * and pixel 1 set to 5 (an outlier). Values by hand from the definitions in compare.c. */
static void test_known_values(void **state)
{
    (void)state;
    enum { N = 4 };
    float ref[4 * N], img[4 * N];
    for (int i = 0; i < N; ++i)
        for (int c = 0; c < 4; ++c) {
            ref[4 * i + c] = i == 0 ? 3.0f : 1.0f;
            img[4 * i + c] = ref[4 * i + c] + 0.1f;
        }
    for (int c = 0; c < 3; ++c)
        img[4 + c] = 5.0f;
    /* mean(ref) = (3 + 1 + 1 + 1) / 4 = 1.5, eps = 0.015 */
    const double eps = 0.015;
    assert_true(fabs(cmd_rmae_eps(ref, N) - eps) < 1e-12);
    double d0 = 0.1f, d1 = 4.0;
    double rmae = (d0 / (3.0 + eps) + d1 / (1.0 + eps) + 2.0 * d0 / (1.0 + eps)) / 4.0;
    double mse = (d0 * d0 * 3.0 + d1 * d1) / 4.0;
    double rel = (d0 * d0 / ((3.0 + eps) * (3.0 + eps)) + d1 * d1 / ((1.0 + eps) * (1.0 + eps)) +
                  2.0 * d0 * d0 / ((1.0 + eps) * (1.0 + eps))) /
                 4.0;
    cmd_metrics m;
    cmd_image_metrics(img, ref, N, &m);
    print_message("# rMAE %.6f (expected %.6f), MSE %.6f (%.6f), relMSE %.6f (%.6f), outliers %.3f (0.25)\n",
                  m.rmae, rmae, m.mse, mse, m.rel_mse, rel, m.outliers);
    assert_true(fabs(m.rmae - rmae) < 1e-6);
    assert_true(fabs(m.mse - mse) < 1e-5);
    assert_true(fabs(m.rel_mse - rel) < 1e-5);
    assert_true(m.outliers == 0.25);
    /* energy: (3.1 + 5 + 1.1 + 1.1) / (3 + 1 + 1 + 1), per channel alike */
    assert_true(fabs(m.energy - (3.1 + 5.0 + 2.2) / 6.0) < 1e-6);
    assert_true(fabs(cmd_rmae(img, ref, N) - rmae) < 1e-6);
    /* identical images: every metric 0 */
    cmd_image_metrics(ref, ref, N, &m);
    assert_true(m.rmae == 0.0 && m.mse == 0.0 && m.rel_mse == 0.0 && m.outliers == 0.0);
}

static void write_exr(const char *path, uint32_t w, uint32_t h, float value)
{
    float *px = malloc(sizeof(float) * 4 * w * h);
    for (uint32_t i = 0; i < 4 * w * h; ++i)
        px[i] = (i % 4 == 3) ? 1.0f : value * (float)(1 + i % 7) / 7.0f;
    vbi_image_layer layer = {"", 4, NULL, px};
    assert_int_equal(vbi_exr_write(path, w, h, &layer, 1, NULL, 0, 0, NULL), VBNL_OK);
    free(px);
}

/* Runs `vbnl compare` with stdout to `out_path` (stderr to /dev/null). */
static int run_compare_to(int argc, char **argv, const char *out_path)
{
    fflush(stdout);
    fflush(stderr);
    int so = dup(1), se = dup(2);
    FILE *out = fopen(out_path, "w"), *null = fopen("/dev/null", "w");
    dup2(fileno(out), 1);
    dup2(fileno(null), 2);
    int rc = cmd_compare(argc, argv);
    fflush(stdout);
    fflush(stderr);
    dup2(so, 1);
    dup2(se, 2);
    close(so);
    close(se);
    fclose(out);
    fclose(null);
    return rc;
}

/* The same with the table discarded (the test's own stdout is TAP). */
static int run_compare(int argc, char **argv) { return run_compare_to(argc, argv, "/dev/null"); }

static void test_files_and_refusal(void **state)
{
    (void)state;
    char dir[] = "/tmp/vbnl-compare-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char ref[256], a[256], b[256], small[256], out[256], png[300];
    snprintf(ref, sizeof(ref), "%s/ref.exr", dir);
    snprintf(a, sizeof(a), "%s/a.exr", dir);
    snprintf(b, sizeof(b), "%s/b.exr", dir);
    snprintf(small, sizeof(small), "%s/small.exr", dir);
    snprintf(out, sizeof(out), "%s/out", dir);
    write_exr(ref, 40, 30, 1.0f);
    write_exr(a, 40, 30, 1.2f);
    write_exr(b, 40, 30, 0.5f);
    write_exr(small, 20, 30, 1.0f);
    char *argv1[] = {"compare", ref, a, b, "--labels", "first,second one", "--out", out, NULL};
    assert_int_equal(run_compare(8, argv1), VBI_EXIT_OK);
    vbi_png_image im;
    snprintf(png, sizeof(png), "%s/montage.png", out);
    assert_int_equal(vbi_png_read(png, &im, NULL), VBNL_OK);
    /* three columns of 40 pixels with 4-pixel gaps; two image rows plus labels and the bar */
    assert_int_equal(im.width, 3 * 40 + 2 * 4);
    assert_true(im.height > 2 * 30);
    /* the label row is not empty: the font drew something */
    int lit = 0;
    const uint8_t *p8 = im.pixels;
    for (uint32_t y = 0; y < 10; ++y)
        for (uint32_t x = 0; x < 40; ++x)
            lit += p8[3 * (y * im.width + x)] == 255;
    assert_true(lit > 10);
    vbi_png_image_free(&im);
    snprintf(png, sizeof(png), "%s/error-second_one.png", out);
    assert_int_equal(vbi_png_read(png, &im, NULL), VBNL_OK);
    assert_int_equal(im.width, 40);
    vbi_png_image_free(&im);
    /* different sizes: refused */
    char *argv2[] = {"compare", ref, small, NULL};
    assert_int_equal(run_compare(3, argv2), VBI_EXIT_FAILURE);
    /* label count mismatch, missing candidate: usage errors */
    char *argv3[] = {"compare", ref, a, "--labels", "x,y", NULL};
    assert_int_equal(run_compare(5, argv3), VBI_EXIT_USAGE);
    char *argv4[] = {"compare", ref, NULL};
    assert_int_equal(run_compare(2, argv4), VBI_EXIT_USAGE);
    char cmd[512];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", dir);
    assert_int_equal(system(cmd), 0);
}

/* rMAE of the table's first candidate row in `path` (the row after the column headers). */
static double table_rmae(const char *path)
{
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    char line[512], label[128];
    double v = -1.0;
    while (fgets(line, sizeof(line), f))
        if (!strncmp(line, "candidate", 9) && fgets(line, sizeof(line), f) && sscanf(line, "%127s %lf", label, &v) == 2)
            break;
    fclose(f);
    return v;
}

/* --layer / --ref-layer: a candidate whose beauty image is off but whose "indirect" layer equals
 * the reference measures 0 with --layer indirect, and not without; a reference layer is read as
 * well; a missing layer is an error naming it. */
static void test_layers(void **state)
{
    (void)state;
    char dir[] = "/tmp/vbnl-compare-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char ref[256], cand[256], table[256];
    snprintf(ref, sizeof(ref), "%s/ref.exr", dir);
    snprintf(cand, sizeof(cand), "%s/cand.exr", dir);
    snprintf(table, sizeof(table), "%s/table.txt", dir);
    enum { W = 16, H = 8 };
    float good[4 * W * H], off[4 * W * H], rgb[3 * W * H];
    for (int i = 0; i < W * H; ++i) {
        for (int c = 0; c < 3; ++c) {
            good[4 * i + c] = 0.25f + (float)((i * 7 + c) % 11) / 11.0f;
            off[4 * i + c] = 2.0f * good[4 * i + c];
            rgb[3 * i + c] = good[4 * i + c];
        }
        good[4 * i + 3] = off[4 * i + 3] = 1.0f;
    }
    const char *names[3] = {"R", "G", "B"};
    vbi_image_layer ref_layers[2] = {{"", 4, NULL, good}, {"direct", 3, names, rgb}};
    vbi_image_layer cand_layers[2] = {{"", 4, NULL, off}, {"indirect", 3, names, rgb}};
    assert_int_equal(vbi_exr_write(ref, W, H, ref_layers, 2, NULL, 0, 0, NULL), VBNL_OK);
    assert_int_equal(vbi_exr_write(cand, W, H, cand_layers, 2, NULL, 0, 0, NULL), VBNL_OK);
    char *beauty[] = {"compare", ref, cand, NULL};
    assert_int_equal(run_compare_to(3, beauty, table), VBI_EXIT_OK);
    assert_true(table_rmae(table) > 0.5);
    char *layered[] = {"compare", ref, cand, "--layer", "indirect", NULL};
    assert_int_equal(run_compare_to(5, layered, table), VBI_EXIT_OK);
    assert_true(table_rmae(table) == 0.0);
    char *both[] = {"compare", ref, cand, "--layer", "indirect", "--ref-layer", "direct", NULL};
    assert_int_equal(run_compare_to(7, both, table), VBI_EXIT_OK);
    assert_true(table_rmae(table) == 0.0);
    char *missing[] = {"compare", ref, cand, "--layer", "direct", NULL};
    assert_int_equal(run_compare_to(5, missing, table), VBI_EXIT_FAILURE);
    char *empty[] = {"compare", ref, cand, "--layer", "", NULL};
    assert_int_equal(run_compare_to(5, empty, table), VBI_EXIT_USAGE);
    char cmd[512];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", dir);
    assert_int_equal(system(cmd), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_known_values),
        cmocka_unit_test(test_files_and_refusal),
        cmocka_unit_test(test_layers),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
