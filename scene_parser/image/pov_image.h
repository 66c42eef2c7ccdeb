/* Image files for textures (image_map, bump_map, image_pattern, material_map): PNG through libpng
 * (image_read.c), every other format OpenImageIO reads (JPEG, TGA, GIF, PPM/PGM, TIFF, BMP, IFF,
 * EXR, HDR: POV-Ray's) through a module loaded on first use (image_oiio.cpp). PNG palettes keep
 * their indices; OpenImageIO expands the palettes of other formats.
 *
 * Errors: a non-zero result and one sentence in `why` (a file that is missing, unreadable, not an
 * image, empty, larger than 65536 on a side or 2^28 values in all, or of a format other than PNG
 * when OpenImageIO's module cannot be loaded). Every C++ exception is caught inside the module.
 * Thread-safety: calls share nothing but the module, loaded once. */
#ifndef VBI_POV_IMAGE_H
#define VBI_POV_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pov_image_encoding {
    POV_IMAGE_LINEAR = 0, /* float formats (EXR, HDR): values as stored are linear */
    POV_IMAGE_SRGB,       /* the sRGB transfer function (8/16-bit formats without other information) */
    POV_IMAGE_GAMMA,      /* a power law: linear = stored^gamma (a PNG gAMA chunk and the like) */
} pov_image_encoding;

typedef struct pov_image_data {
    uint32_t width, height, channels; /* channels 1 (grey), 2 (grey, alpha), 3 (RGB), 4 (RGBA) */
    float *texels;                    /* width * height * channels, row 0 at the top; integer formats
                                       * scaled to [0, 1]; owned (free with pov_image_data_free) */
    uint8_t *indices;                 /* palette indices (PNG palettes), or NULL */
    pov_image_encoding encoding;
    double gamma;                     /* POV_IMAGE_GAMMA: the decoding exponent */
    int grey8_png;                    /* a greyscale PNG of at most 8 bits: POV-Ray keeps its decoded
                                       * values in 8 bits (image_map.c) */
    uint32_t bits;                    /* bits per stored value of an integer format (8 for palettes and
                                       * PNG greys of fewer bits, which are scaled to 8), 0 for float
                                       * formats (height_field reads colour images by it) */
} pov_image_data;

/* Reads the image at `path` (already resolved and allowed by the caller). Returns 0, or -1 with
 * the reason in why. */
int pov_image_read(const char *path, pov_image_data *out, char *why, size_t why_size);
void pov_image_data_free(pov_image_data *d);

#ifdef __cplusplus
}
#endif
#endif
