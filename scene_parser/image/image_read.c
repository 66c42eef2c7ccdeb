/* Image files for textures (pov_image.h). PNG, the common case, is read here with libpng; every
 * other format through OpenImageIO in a module of its own (image_oiio.cpp, vbnl_image_oiio.so),
 * loaded the first time a scene names such a file: OpenImageIO and the libraries it pulls in
 * (over two hundred on Debian) cost a third of a second and 120 MB at load, which a run that reads
 * no such image does not pay. The module is looked for in $VBNL_IMAGE_MODULE (a path), beside the
 * program or module holding this code, in the build tree's scene_parser folder next to it, and in
 * the install folder. */

#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <png.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pov_image.h"
#include "read_file.h"

#ifndef VBI_IMAGE_MODULE_DIR
#define VBI_IMAGE_MODULE_DIR "/usr/local/lib/x86_64-linux-gnu/vbnl"
#endif
#define MODULE_NAME "vbnl_image_oiio.so"

static void say(char *why, size_t n, const char *fmt, const char *arg)
{
    if (why && n)
        snprintf(why, n, fmt, arg);
}

/* ---- PNG ---------------------------------------------------------------------------------------- */

typedef struct png_err {
    jmp_buf jump;
    char msg[200];
} png_err;

static void on_png_error(png_structp png, png_const_charp msg)
{
    png_err *e = png_get_error_ptr(png);
    snprintf(e->msg, sizeof(e->msg), "%s", msg);
    longjmp(e->jump, 1);
}

static void on_png_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

static int read_png(FILE *f, pov_image_data *out, char *why, size_t why_size)
{
    png_err e = {.msg = "not a PNG file"};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &e, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!info) {
        png_destroy_read_struct(&png, NULL, NULL);
        say(why, why_size, "%s", "out of memory");
        return -1;
    }
    png_bytep volatile rows = NULL;
    uint8_t *volatile indices = NULL;
    float *volatile texels = NULL;
    if (setjmp(e.jump)) {
        png_destroy_read_struct(&png, &info, NULL);
        free(rows);
        free(indices);
        free(texels);
        say(why, why_size, "%s", e.msg);
        return -1;
    }
    png_init_io(png, f);
    png_set_user_limits(png, 65536, 65536);
    png_read_info(png, info);
    const png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    const int depth = png_get_bit_depth(png, info), type = png_get_color_type(png, info);
    if ((uint64_t)w * h * 4 > ((uint64_t)1 << 28))
        png_error(png, "the image has more than 2^28 values");
    /* the decoding of the stored values (PNG: an sRGB chunk, else gAMA, else sRGB) */
    double file_gamma = 0.0;
    int srgb = 0;
    out->encoding = POV_IMAGE_SRGB;
    if (png_get_sRGB(png, info, &srgb))
        out->encoding = POV_IMAGE_SRGB;
    else if (png_get_gAMA(png, info, &file_gamma) && file_gamma > 0.0) {
        out->encoding = POV_IMAGE_GAMMA;
        out->gamma = 1.0 / file_gamma;
    }
    const int palette = type == PNG_COLOR_TYPE_PALETTE;
    out->grey8_png = (type == PNG_COLOR_TYPE_GRAY || type == PNG_COLOR_TYPE_GRAY_ALPHA) && depth <= 8;
    out->bits = depth == 16 ? 16 : 8;
    if (palette) { /* keep the indices, then expand to colours */
        png_set_packing(png);
    } else {
        if (depth < 8)
            png_set_expand_gray_1_2_4_to_8(png);
        if (png_get_valid(png, info, PNG_INFO_tRNS))
            png_set_tRNS_to_alpha(png);
    }
    png_read_update_info(png, info);
    const size_t stride = png_get_rowbytes(png, info);
    rows = malloc(stride * h);
    if (!rows)
        png_error(png, "out of memory");
    png_bytep *ptrs = malloc(sizeof(png_bytep) * h);
    if (!ptrs)
        png_error(png, "out of memory");
    for (png_uint_32 y = 0; y < h; ++y)
        ptrs[y] = rows + y * stride;
    png_read_image(png, ptrs);
    free(ptrs);
    if (palette) {
        png_colorp pal = NULL;
        int npal = 0, ntrans = 0;
        png_bytep trans = NULL;
        png_get_PLTE(png, info, &pal, &npal);
        png_get_tRNS(png, info, &trans, &ntrans, NULL);
        const int ch = ntrans > 0 ? 4 : 3;
        texels = malloc(sizeof(float) * (size_t)w * h * ch);
        indices = malloc((size_t)w * h);
        if (!texels || !indices)
            png_error(png, "out of memory");
        for (size_t i = 0; i < (size_t)w * h; ++i) {
            const int k = rows[i];
            indices[i] = (uint8_t)k;
            const int ok = k < npal;
            texels[i * ch + 0] = ok ? pal[k].red / 255.0f : 0.0f;
            texels[i * ch + 1] = ok ? pal[k].green / 255.0f : 0.0f;
            texels[i * ch + 2] = ok ? pal[k].blue / 255.0f : 0.0f;
            if (ch == 4)
                texels[i * ch + 3] = k < ntrans ? trans[k] / 255.0f : 1.0f;
        }
        out->channels = (uint32_t)ch;
    } else {
        const int ch = png_get_channels(png, info);
        const int bytes = png_get_bit_depth(png, info) == 16 ? 2 : 1;
        texels = malloc(sizeof(float) * (size_t)w * h * ch);
        if (!texels)
            png_error(png, "out of memory");
        for (size_t i = 0; i < (size_t)w * h * ch; ++i) {
            if (bytes == 2) { /* big-endian in the file */
                texels[i] = (float)((rows[2 * i] << 8) | rows[2 * i + 1]) / 65535.0f;
            } else {
                texels[i] = rows[i] / 255.0f;
            }
        }
        out->channels = (uint32_t)ch;
    }
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    free(rows);
    out->width = w;
    out->height = h;
    out->texels = texels;
    out->indices = indices;
    return 0;
}

/* ---- other formats: the OpenImageIO module ------------------------------------------------------ */

/* The module's reader (image_oiio.cpp): the image in the open stream, named `path`. */
typedef int (*oiio_read_fn)(const char *, FILE *, pov_image_data *, char *, size_t);
static pthread_once_t module_once = PTHREAD_ONCE_INIT;
static oiio_read_fn module_read;
static char module_error[512];

static int try_module(const char *path)
{
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char *e = dlerror();
        if (!module_error[0] || access(path, F_OK) == 0)
            snprintf(module_error, sizeof(module_error), "%s", e ? e : path);
        return 0;
    }
    module_read = (oiio_read_fn)(uintptr_t)dlsym(h, "vbnl_oiio_image_read_stream");
    if (!module_read) {
        snprintf(module_error, sizeof(module_error), "%s has no reader", path);
        dlclose(h);
        return 0;
    }
    return 1;
}

static void load_module(void)
{
    const char *env = getenv("VBNL_IMAGE_MODULE");
    if (env && env[0] && try_module(env))
        return;
    Dl_info info;
    char dir[PATH_MAX], path[PATH_MAX + 64];
    if (dladdr((void *)(uintptr_t)load_module, &info) && info.dli_fname) {
        snprintf(dir, sizeof(dir), "%s", info.dli_fname);
        if (dir[0] != '/') { /* a program started by a relative name: its absolute path */
            ssize_t n = readlink("/proc/self/exe", dir, sizeof(dir) - 1);
            dir[n > 0 ? n : 0] = '\0';
        }
        char *slash = strrchr(dir, '/');
        if (slash) {
            *slash = '\0';
            snprintf(path, sizeof(path), "%s/" MODULE_NAME, dir);
            if (try_module(path))
                return;
            snprintf(path, sizeof(path), "%s/../scene_parser/" MODULE_NAME, dir);
            if (try_module(path))
                return;
        }
    }
    snprintf(path, sizeof(path), "%s/" MODULE_NAME, VBI_IMAGE_MODULE_DIR);
    if (try_module(path))
        return;
    if (!module_error[0])
        snprintf(module_error, sizeof(module_error), "%s not found", MODULE_NAME);
}

int pov_image_read(const char *path, pov_image_data *out, char *why, size_t why_size)
{
    memset(out, 0, sizeof(*out));
    const char *no;
    FILE *f = vbi_read_fopen(path, NULL, &no);
    if (!f) {
        say(why, why_size, "%s", no);
        return -1;
    }
    unsigned char sig[8] = {0};
    size_t n = fread(sig, 1, sizeof(sig), f);
    rewind(f);
    int r;
    if (n == sizeof(sig) && !png_sig_cmp(sig, 0, sizeof(sig))) {
        r = read_png(f, out, why, why_size);
    } else {
        pthread_once(&module_once, load_module);
        if (module_read) {
            r = module_read(path, f, out, why, why_size);
        } else {
            say(why, why_size, "reading formats other than PNG needs OpenImageIO (%s)", module_error);
            r = -1;
        }
    }
    fclose(f);
    return r;
}

void pov_image_data_free(pov_image_data *d)
{
    if (!d)
        return;
    free(d->texels);
    free(d->indices);
    d->texels = NULL;
    d->indices = NULL;
}
