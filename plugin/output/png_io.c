/* PNG writer and reader on libpng 1.6. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <png.h>

#include "atomic_file.h"
#include "image_io.h"
#include "read_file.h"

/* libpng reports errors by calling this and expecting it not to return: keep the message, longjmp
 * back to the setjmp in the calling function. */
typedef struct vbi_png_ctx {
    char msg[256];
} vbi_png_ctx;

static void vbi_png_on_error(png_structp png, png_const_charp msg)
{
    vbi_png_ctx *ctx = png_get_error_ptr(png);
    if (ctx && !ctx->msg[0])
        snprintf(ctx->msg, sizeof ctx->msg, "%s", msg ? msg : "libpng error");
    png_longjmp(png, 1);
}

static void vbi_png_on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* warnings (e.g. unknown chunks) do not make a call fail; stay silent */
}

static int vbi_png_color_type(uint32_t channels)
{
    return channels == 1 ? PNG_COLOR_TYPE_GRAY
           : channels == 3 ? PNG_COLOR_TYPE_RGB
                           : PNG_COLOR_TYPE_RGB_ALPHA;
}

/* The libpng part of a write, apart so that only `png`, `info` and `fp` live across setjmp. */
static int vbi_png_encode(FILE *fp, vbi_png_ctx *ctx, uint32_t width, uint32_t height,
                           uint32_t channels, uint32_t bit_depth, const void *pixels)
{
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, ctx, vbi_png_on_error,
                                              vbi_png_on_warning);
    if (!png) {
        snprintf(ctx->msg, sizeof ctx->msg, "out of memory");
        return -1;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(ctx->msg, sizeof ctx->msg, "out of memory");
        return -1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return -1;
    }
    png_init_io(png, fp);
    png_set_IHDR(png, info, width, height, (int)bit_depth, vbi_png_color_type(channels),
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    /* sRGB chunk; libpng also writes the matching gAMA and cHRM for older readers */
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    if (bit_depth == 16) {
        const uint16_t probe = 1;
        if (*(const uint8_t *)&probe == 1)
            png_set_swap(png); /* PNG is big-endian, our buffer native */
    }
    const size_t row = (size_t)width * channels * (bit_depth / 8u);
    for (uint32_t y = 0; y < height; y++)
        png_write_row(png, (png_const_bytep)pixels + (size_t)y * row);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return 0;
}

vbnl_result vbi_png_write(const char *path, uint32_t width, uint32_t height, uint32_t channels,
                           uint32_t bit_depth, const void *pixels, vbnl_error *err)
{
    if (!path || !path[0] || !pixels)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "cannot write PNG '%s': %s",
                              path ? path : "(null)", !path || !path[0] ? "no path" : "no pixels");
    if (width == 0 || height == 0 || width > PNG_UINT_31_MAX || height > PNG_UINT_31_MAX)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "cannot write '%s': invalid image size %ux%u", path, width, height);
    if (channels != 1 && channels != 3 && channels != 4)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "cannot write '%s': %u channels (1, 3 or 4 expected)", path, channels);
    if (bit_depth != 8 && bit_depth != 16)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "cannot write '%s': bit depth %u (8 or 16 expected)", path, bit_depth);

    vbi_atomic_file tmp;
    vbnl_result r = vbi_atomic_file_open(&tmp, path, err);
    if (r != VBNL_OK)
        return r;
    int fd = dup(tmp.fd); /* fclose closes this one; the atomic file keeps its own for fsync */
    FILE *fp = fd >= 0 ? fdopen(fd, "wb") : NULL;
    if (!fp) {
        int e = errno;
        if (fd >= 0)
            close(fd);
        vbi_atomic_file_discard(&tmp);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", path, strerror(e));
    }
    vbi_png_ctx ctx = {{0}};
    int rc = vbi_png_encode(fp, &ctx, width, height, channels, bit_depth, pixels);
    int io_errno = ferror(fp) ? errno : 0;
    if (fclose(fp) != 0 && !io_errno)
        io_errno = errno;
    if (rc != 0 || io_errno) {
        vbi_atomic_file_discard(&tmp);
        if (io_errno)
            return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", path,
                                  strerror(io_errno));
        return vbnl_error_set(err, VBNL_ERR_BACKEND, "cannot write '%s': libpng: %s", path,
                              ctx.msg);
    }
    return vbi_atomic_file_commit(&tmp, err);
}

void vbi_png_image_free(vbi_png_image *img)
{
    if (!img)
        return;
    free(img->pixels);
    memset(img, 0, sizeof *img);
}

/* Decoding; `out->pixels` is the only allocation that must survive a longjmp, so it lives in *out. */
static int vbi_png_decode(FILE *fp, vbi_png_ctx *ctx, vbi_png_image *out, png_bytep **rows)
{
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, ctx, vbi_png_on_error,
                                             vbi_png_on_warning);
    if (!png) {
        snprintf(ctx->msg, sizeof ctx->msg, "out of memory");
        return -1;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_read_struct(&png, NULL, NULL);
        snprintf(ctx->msg, sizeof ctx->msg, "out of memory");
        return -1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        return -1;
    }
    png_init_io(png, fp);
    png_read_info(png, info);
    png_uint_32 w = 0, h = 0;
    int depth = 0, color = 0, interlace = 0;
    png_get_IHDR(png, info, &w, &h, &depth, &color, &interlace, NULL, NULL);
    png_set_expand(png); /* palette -> RGB, gray < 8 bit -> 8 bit, tRNS -> alpha */
    if (color == PNG_COLOR_TYPE_GRAY_ALPHA)
        png_set_gray_to_rgb(png);
    if (depth == 16) {
        const uint16_t probe = 1;
        if (*(const uint8_t *)&probe == 1)
            png_set_swap(png);
    }
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    out->width = w;
    out->height = h;
    out->channels = png_get_channels(png, info);
    out->bit_depth = png_get_bit_depth(png, info);
    int intent;
    out->has_srgb = png_get_sRGB(png, info, &intent) != 0;
    if ((out->channels != 1 && out->channels != 3 && out->channels != 4) ||
        (out->bit_depth != 8 && out->bit_depth != 16))
        png_error(png, "unexpected pixel format after expansion");
    size_t row = png_get_rowbytes(png, info);
    if (row != (size_t)w * out->channels * (out->bit_depth / 8u) || h == 0 ||
        row > SIZE_MAX / h)
        png_error(png, "unexpected row size");
    out->pixels = malloc(row * h);
    *rows = malloc(sizeof **rows * h);
    if (!out->pixels || !*rows)
        png_error(png, "out of memory");
    for (png_uint_32 y = 0; y < h; y++)
        (*rows)[y] = (png_bytep)out->pixels + (size_t)y * row;
    png_read_image(png, *rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    return 0;
}

vbnl_result vbi_png_read(const char *path, vbi_png_image *out, vbnl_error *err)
{
    if (out)
        memset(out, 0, sizeof *out);
    if (!path || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "cannot read PNG: %s is NULL",
                              !path ? "path" : "out");
    const char *why;
    FILE *fp = vbi_read_fopen(path, NULL, &why);
    if (!fp)
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot read '%s': %s", path, why);
    uint8_t sig[8];
    if (fread(sig, 1, 8, fp) != 8 || png_sig_cmp(sig, 0, 8) != 0) {
        fclose(fp);
        return vbnl_error_set(err, VBNL_ERR_CORRUPT, "cannot read '%s': not a PNG file", path);
    }
    rewind(fp);
    vbi_png_ctx ctx = {{0}};
    png_bytep *rows = NULL;
    int rc = vbi_png_decode(fp, &ctx, out, &rows);
    free(rows);
    fclose(fp);
    if (rc != 0) {
        vbi_png_image_free(out);
        return vbnl_error_set(err, strcmp(ctx.msg, "out of memory") == 0 ? VBNL_ERR_OUT_OF_MEMORY
                                                                          : VBNL_ERR_CORRUPT,
                              "cannot read '%s': %s", path, ctx.msg);
    }
    return VBNL_OK;
}
