/* exr_same: the farm tests' comparison of two EXRs, bit for bit (not a cmocka test; a tool that
 * tests/plugin/commands/test_farm*.sh call).
 *
 *   exr_same A.exr B.exr [--attrs NAME,NAME,...] [--has-all]
 *
 * Exit status 0 when both have the same display and data windows, the same channels and every
 * channel's values have the same bits; with --attrs, when the named header attributes are equal
 * too (present in both, same type, same bits); with --has-all, when every vbnl/ attribute of A is
 * in B. Otherwise 1, naming the first difference (a pixel and its two values, or the attribute). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "image_io.h"

static int same_attr(const vbi_image_attr *x, const vbi_image_attr *y)
{
    if (!x || !y || x->type != y->type)
        return 0;
    switch (x->type) {
    case VBI_IMAGE_ATTR_STRING: return !strcmp(x->value.s, y->value.s);
    case VBI_IMAGE_ATTR_INT: return x->value.i == y->value.i;
    case VBI_IMAGE_ATTR_FLOAT: return !memcmp(&x->value.f, &y->value.f, sizeof(float));
    case VBI_IMAGE_ATTR_DOUBLE: return !memcmp(&x->value.d, &y->value.d, sizeof(double));
    }
    return 0;
}

static void show(const vbi_image_attr *a, char *buf, size_t n)
{
    if (!a)
        snprintf(buf, n, "(absent)");
    else if (a->type == VBI_IMAGE_ATTR_STRING)
        snprintf(buf, n, "'%s'", a->value.s);
    else if (a->type == VBI_IMAGE_ATTR_INT)
        snprintf(buf, n, "%d", (int)a->value.i);
    else
        snprintf(buf, n, "%.17g", a->type == VBI_IMAGE_ATTR_FLOAT ? (double)a->value.f : a->value.d);
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: exr_same A.exr B.exr [--attrs NAME,...] [--has-all]\n");
        return 2;
    }
    const char *attrs = NULL;
    int has_all = 0;
    for (int i = 3; i < argc; ++i) {
        if (!strcmp(argv[i], "--attrs") && i + 1 < argc)
            attrs = argv[++i];
        else if (!strcmp(argv[i], "--has-all"))
            has_all = 1;
        else {
            fprintf(stderr, "exr_same: unknown argument '%s'\n", argv[i]);
            return 2;
        }
    }
    vbi_exr_image a, b;
    vbnl_error err = {0};
    if (vbi_exr_read(argv[1], &a, &err) != VBNL_OK || vbi_exr_read(argv[2], &b, &err) != VBNL_OK) {
        fprintf(stderr, "exr_same: %s\n", err.message);
        return 1;
    }
    int rc = 0;
    if (a.width != b.width || a.height != b.height || a.data_x != b.data_x || a.data_y != b.data_y ||
        a.display_width != b.display_width || a.display_height != b.display_height) {
        fprintf(stderr, "exr_same: windows differ: %ux%u at (%d,%d) of %ux%u, %ux%u at (%d,%d) of %ux%u\n", a.width,
                a.height, a.data_x, a.data_y, a.display_width, a.display_height, b.width, b.height, b.data_x, b.data_y,
                b.display_width, b.display_height);
        rc = 1;
    }
    if (!rc && a.channel_count != b.channel_count) {
        fprintf(stderr, "exr_same: %u channels, %u channels\n", a.channel_count, b.channel_count);
        rc = 1;
    }
    size_t compared = 0;
    for (uint32_t c = 0; !rc && c < a.channel_count; ++c) {
        const vbi_exr_channel *x = &a.channels[c], *y = vbi_exr_image_channel(&b, x->name);
        if (!y) {
            fprintf(stderr, "exr_same: '%s' has no channel '%s'\n", argv[2], x->name);
            rc = 1;
            break;
        }
        for (size_t p = 0; p < (size_t)a.width * a.height; ++p, ++compared)
            if (memcmp(&x->data[p], &y->data[p], sizeof(float))) {
                fprintf(stderr, "exr_same: channel %s differs at pixel (%zu, %zu): %.9g, %.9g\n", x->name,
                        p % a.width + (size_t)a.data_x, p / a.width + (size_t)a.data_y, (double)x->data[p],
                        (double)y->data[p]);
                rc = 1;
                break;
            }
    }
    if (!rc && attrs) {
        char *list = strdup(attrs);
        for (char *save = NULL, *n = strtok_r(list, ",", &save); n && !rc; n = strtok_r(NULL, ",", &save)) {
            const vbi_image_attr *x = vbi_exr_image_attr(&a, n), *y = vbi_exr_image_attr(&b, n);
            if (!same_attr(x, y)) {
                char tx[512], ty[512];
                show(x, tx, sizeof(tx));
                show(y, ty, sizeof(ty));
                fprintf(stderr, "exr_same: attribute %s: %s, %s\n", n, tx, ty);
                rc = 1;
            }
        }
        free(list);
    }
    for (uint32_t i = 0; !rc && has_all && i < a.attr_count; ++i)
        if (!strncmp(a.attrs[i].name, "vbnl/", 5) && !vbi_exr_image_attr(&b, a.attrs[i].name)) {
            fprintf(stderr, "exr_same: '%s' lacks the attribute %s\n", argv[2], a.attrs[i].name);
            rc = 1;
        }
    if (!rc)
        printf("exr_same: %zu values of %u channels identical\n", compared, a.channel_count);
    vbi_exr_image_free(&a);
    vbi_exr_image_free(&b);
    return rc;
}
