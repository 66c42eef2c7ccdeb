/* The film (core/src/film.h, vbnl/render.h): its standard layers and their offsets, adding layers
 * (and what is refused), accumulation of samples into per-pixel means across tile boundaries,
 * sample counts, crop windows, reading layers back, and the tile layout that keeps threads off
 * each other's cache lines. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdio.h>
#include <string.h>

#include "film.h"

static const char *const one_name[] = {"Y"};
static const char *const five_names[] = {"a", "b", "c", "d", "e"};

static void test_layers(void **state)
{
    (void)state;
    vbnl_film *f = NULL;
    vbnl_error err = {0};
    assert_int_equal(vbi_film_create(40, 20, NULL, &f, &err), VBNL_OK);
    /* the standard layers at the public offsets */
    assert_int_equal(vbnl_film_layer_count(f), 4);
    const char *names[4] = {"", "albedo", "normal", "depth"};
    const uint32_t channels[4] = {4, 3, 3, 1}, offsets[4] = {VBNL_FILM_BEAUTY, VBNL_FILM_ALBEDO,
                                                            VBNL_FILM_NORMAL, VBNL_FILM_DEPTH};
    for (uint32_t i = 0; i < 4; ++i) {
        vbnl_layer_info li;
        assert_int_equal(vbnl_film_layer(f, i, &li, &err), VBNL_OK);
        assert_string_equal(li.name, names[i]);
        assert_int_equal(li.channels, channels[i]);
        assert_int_equal(f->layers[i].offset, offsets[i]);
    }
    assert_int_equal(vbnl_film_record_size(f), 11);
    vbnl_layer_info li;
    assert_int_equal(vbnl_film_layer(f, 4, &li, &err), VBNL_ERR_INVALID_ARGUMENT);
    /* an integrator's layer comes after them */
    uint32_t off = 0;
    assert_int_equal(vbnl_film_add_layer(f, "ao", 1, one_name, &off, &err), VBNL_OK);
    assert_int_equal(off, 11);
    assert_int_equal(vbnl_film_record_size(f), 12);
    /* refused: a taken name, a name of 32 bytes, 0 or 5 channels, NULL names */
    assert_int_equal(vbnl_film_add_layer(f, "ao", 1, one_name, &off, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "exists already"));
    char longname[40];
    memset(longname, 'x', 32);
    longname[32] = '\0';
    assert_int_equal(vbnl_film_add_layer(f, longname, 1, one_name, &off, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_film_add_layer(f, "z", 0, one_name, &off, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_film_add_layer(f, "z", 5, five_names, &off, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_film_add_layer(f, "z", 1, NULL, &off, &err), VBNL_ERR_INVALID_ARGUMENT);
    /* more channels than VBNL_FILM_MAX_CHANNELS in all: refused at the layer that would pass it */
    uint32_t added = 0;
    vbnl_result r = VBNL_OK;
    while (r == VBNL_OK && added < 32) {
        char nm[8];
        snprintf(nm, sizeof(nm), "l%u", added);
        r = vbnl_film_add_layer(f, nm, 4, five_names, NULL, &err);
        added += r == VBNL_OK;
    }
    assert_int_equal(r, VBNL_ERR_INVALID_ARGUMENT);
    assert_true(vbnl_film_record_size(f) <= VBNL_FILM_MAX_CHANNELS);
    assert_true(vbnl_film_layer_count(f) <= VBI_FILM_MAX_LAYERS);
    /* after allocation no layer may be added */
    assert_int_equal(vbi_film_allocate(f, &err), VBNL_OK);
    assert_int_equal(vbnl_film_add_layer(f, "late", 1, one_name, &off, &err), VBNL_ERR_STATE);
    vbi_film_destroy(f);
    vbi_film_destroy(NULL);
}

/* Samples in pixels on both sides of tile boundaries (tiles of 16: x 15 / 16, y 15 / 16): each
 * pixel reads the mean of its own samples only, a pixel without samples reads 0. */
static void test_accumulate(void **state)
{
    (void)state;
    vbnl_film *f = NULL;
    assert_int_equal(vbi_film_create(40, 20, NULL, &f, NULL), VBNL_OK);
    uint32_t ao = 0;
    assert_int_equal(vbnl_film_add_layer(f, "ao", 1, one_name, &ao, NULL), VBNL_OK);
    assert_int_equal(vbi_film_allocate(f, NULL), VBNL_OK);
    const uint32_t px[4][2] = {{15, 15}, {16, 15}, {15, 16}, {39, 19}};
    float rec[VBNL_FILM_MAX_CHANNELS];
    for (uint32_t k = 0; k < 4; ++k)
        for (uint32_t s = 0; s < k + 1; ++s) { /* pixel k takes k + 1 samples */
            memset(rec, 0, sizeof(rec));
            for (uint32_t c = 0; c < vbnl_film_record_size(f); ++c)
                rec[c] = (float)(100 * k + 10 * s + c);
            vbi_film_add(f, px[k][0], px[k][1], rec);
        }
    float beauty[40 * 20 * 4], aov[40 * 20];
    assert_int_equal(vbnl_film_read(f, "", beauty, sizeof(beauty) / sizeof(beauty[0]), NULL), VBNL_OK);
    assert_int_equal(vbnl_film_read(f, "ao", aov, sizeof(aov) / sizeof(aov[0]), NULL), VBNL_OK);
    for (uint32_t y = 0; y < 20; ++y)
        for (uint32_t x = 0; x < 40; ++x) {
            int k = -1;
            for (int i = 0; i < 4; ++i)
                if (px[i][0] == x && px[i][1] == y)
                    k = i;
            const float *b = beauty + 4 * (y * 40 + x);
            if (k < 0) {
                assert_int_equal(vbnl_film_pixel_samples(f, x, y), 0);
                assert_true(b[0] == 0.0f && b[3] == 0.0f && aov[y * 40 + x] == 0.0f);
                continue;
            }
            assert_int_equal(vbnl_film_pixel_samples(f, x, y), (uint32_t)k + 1);
            /* mean over s of 100 k + 10 s + c = 100 k + 5 k + c */
            for (uint32_t c = 0; c < 4; ++c)
                assert_float_equal(b[c], 100.0f * k + 5.0f * k + c, 1e-4);
            assert_float_equal(aov[y * 40 + x], 100.0f * k + 5.0f * k + ao, 1e-4);
        }
    /* reading: an unknown layer, a buffer too small, outside the image */
    vbnl_error err = {0};
    assert_int_equal(vbnl_film_read(f, "nope", aov, 800, &err), VBNL_ERR_UNKNOWN_NAME);
    assert_non_null(strstr(err.message, "'ao'"));
    assert_int_equal(vbnl_film_read(f, "ao", aov, 799, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_film_pixel_samples(f, 40, 0), 0);
    /* the tile layout: blocks aligned to cache lines, none shared by two tiles */
    assert_int_equal((uintptr_t)f->data % 64, 0);
    assert_int_equal(f->tile_doubles % 8, 0);
    assert_true(f->tile_doubles >= (size_t)VBI_FILM_TILE * VBI_FILM_TILE * f->stride);
    assert_int_equal(f->tiles_x, 3);
    assert_int_equal(f->tiles_y, 2);
    vbi_film_destroy(f);
}

/* Sizes and crop windows. */
static void test_create(void **state)
{
    (void)state;
    vbnl_film *f = (vbnl_film *)1;
    vbnl_error err = {0};
    assert_int_equal(vbi_film_create(0, 10, NULL, &f, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_film_create(10, 65537, NULL, &f, &err), VBNL_ERR_INVALID_ARGUMENT);
    const uint32_t outside[4] = {0, 0, 11, 5}, empty[4] = {3, 3, 3, 5}, ok[4] = {2, 3, 7, 9};
    assert_int_equal(vbi_film_create(10, 10, outside, &f, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "does not lie inside"));
    assert_int_equal(vbi_film_create(10, 10, empty, &f, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_film_create(10, 10, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbi_film_create(10, 10, ok, &f, &err), VBNL_OK);
    assert_memory_equal(f->crop, ok, sizeof(ok));
    assert_int_equal(vbnl_film_width(f), 10);
    assert_int_equal(vbnl_film_height(f), 10);
    /* an unallocated film reads as zeros */
    float v[100];
    v[0] = 1.0f;
    assert_int_equal(vbnl_film_read(f, "depth", v, 100, &err), VBNL_OK);
    assert_true(v[0] == 0.0f);
    vbi_film_destroy(f);
    const uint32_t none[4] = {0, 0, 0, 0}; /* all zero: the whole image */
    assert_int_equal(vbi_film_create(10, 6, none, &f, &err), VBNL_OK);
    assert_int_equal(f->crop[2], 10);
    assert_int_equal(f->crop[3], 6);
    vbi_film_destroy(f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layers),
        cmocka_unit_test(test_accumulate),
        cmocka_unit_test(test_create),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
