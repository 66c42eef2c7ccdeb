/* vbnl output module: EXR and PNG image files (private to the project, never installed).
 *
 * What it does
 *   - vbi_exr_write: one-part scanline OpenEXR file, ZIP compression, FLOAT or HALF pixels, a beauty
 *     layer plus any number of AOV layers, Rec.709/D65 chromaticities and caller-given header
 *     attributes (render settings: integrator, seed, spp, timings ...).
 *   - vbi_exr_read: every channel of a scanline or tiled (level 0) EXR file, any writer, as planar
 *     float arrays keyed by full channel name, plus its string/int/float/double attributes.
 *   - vbi_png_write / vbi_png_read: 8- or 16-bit gray, RGB or RGBA PNG with an sRGB chunk.
 *   - vbi_display_quantise: clamp, deterministic dither and 8/16-bit quantisation of values a
 *     colour view (OpenColorIO, plugin/colour) has made display-referred: the PNG path.
 *   - vbi_linear_to_srgb8: plain sRGB without OpenColorIO (exposure, sRGB OETF, clamp, dither),
 *     for benchmark images.
 *
 * Pixel layout (everywhere in this header): row 0 is the top row; rows are tightly packed;
 * interleaved buffers hold `channels` values per pixel in channel order.
 *
 * Files are written atomically through the core's atomic files (core/src/atomic_file.h, which the
 * core's virtual-light files use too): the data goes to "<path>.tmp-XXXXXX" in the same directory,
 * is fsync'ed and then renamed over `path`. On any failure the temporary file is removed and an
 * existing file at `path` is left untouched; a reader never sees a half-written image. A signal
 * handler can remove the temporaries of writes under way with vbi_atomic_file_abandon_all before
 * it ends the process (the plugin's abandon_writes), so an interrupted write leaves nothing.
 *
 * Errors: every fallible function returns a vbnl_result and, if `err` is non-NULL, fills it with one
 * sentence naming the path and the library's or the system's reason, e.g.
 * "cannot write 'out/x.exr': No such file or directory". Codes used:
 *   VBNL_ERR_INVALID_ARGUMENT  NULL pointer, zero size, bad channel count or name, duplicate name;
 *   VBNL_ERR_IO                a file could not be opened, created, written, synced or renamed;
 *   VBNL_ERR_CORRUPT           a file is not an EXR/PNG or is truncated or damaged;
 *   VBNL_ERR_UNSUPPORTED       valid file this module does not read (deep data, subsampled channels);
 *   VBNL_ERR_OUT_OF_MEMORY, VBNL_ERR_BACKEND (any other OpenEXR/libpng failure);
 *   VBNL_ERR_CANCELLED         writes were abandoned (vbi_atomic_file_abandon_all).
 *
 * Thread-safety: the only shared mutable state is the core's lock-free table of temporaries in
 * progress (atomic_file.c), which a signal handler must be able to reach (no OpenEXR process-wide
 * defaults; OpenEXR error messages reach the call through a thread-local pointer valid during that
 * call; libpng errors go through a per-call setjmp). Different calls may run concurrently on
 * different threads; two calls writing the same `path` at once both succeed and the last rename
 * wins. */
#ifndef VBI_PLUGIN_OUTPUT_IMAGE_IO_H
#define VBI_PLUGIN_OUTPUT_IMAGE_IO_H

#include <stddef.h>
#include <stdint.h>

#include "vbnl/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------------------------------------- */
/* Header attributes                                                                              */

typedef enum vbi_image_attr_type {
    VBI_IMAGE_ATTR_STRING = 0,
    VBI_IMAGE_ATTR_INT = 1,    /* int32 */
    VBI_IMAGE_ATTR_FLOAT = 2,
    VBI_IMAGE_ATTR_DOUBLE = 3,
} vbi_image_attr_type;

/* One named header attribute. For writing, the strings are borrowed for the duration of the call.
 * For vbi_exr_read results, `name` and `value.s` are owned by the vbi_exr_image. Names must not
 * collide with the attributes the writer sets itself (channels, compression, dataWindow,
 * displayWindow, lineOrder, pixelAspectRatio, screenWindowCenter, screenWindowWidth,
 * chromaticities); a collision or a repeated name fails with VBNL_ERR_INVALID_ARGUMENT. Names
 * are 1..255 bytes; any attribute or channel name over 31 bytes sets the EXR "long names" flag. */
typedef struct vbi_image_attr {
    const char *name;
    vbi_image_attr_type type;
    union {
        const char *s; /* NUL-terminated */
        int32_t i;
        float f;
        double d;
    } value;
} vbi_image_attr;

/* ---------------------------------------------------------------------------------------------- */
/* OpenEXR                                                                                        */

/* One layer of an image to write: `channels` interleaved floats per pixel, width*height pixels.
 * name "" is the beauty layer: its channels are stored under their own names ("R","G","B","A").
 * Any other name is an AOV: channel c is stored as "<name>.<channel_names[c]>" ("albedo.R",
 * "normal.X", "depth.Z"). channel_names may be NULL for 1 channel ("Y"), 3 ("R","G","B") or 4
 * ("R","G","B","A"). Full channel names must be unique across all layers and at most 255 bytes. */
typedef struct vbi_image_layer {
    const char *name;
    uint32_t channels;                 /* 1 .. 64 */
    const char *const *channel_names;  /* `channels` names, or NULL (see above) */
    const float *data;                 /* width * height * channels floats, borrowed */
} vbi_image_layer;

/* Writes `path` as a single-part scanline EXR (ZIP, increasing Y, data window = display window =
 * (0,0)-(width-1,height-1)) with the given layers and attributes and Rec.709 primaries / D65 white
 * chromaticities. half_float != 0 stores every channel as HALF (round to nearest even, overflow to
 * infinity), otherwise as FLOAT (bit-exact). All inputs are borrowed; nothing is kept. */
vbnl_result vbi_exr_write(const char *path, uint32_t width, uint32_t height,
                           const vbi_image_layer *layers, uint32_t layer_count,
                           const vbi_image_attr *attrs, uint32_t attr_count, int half_float,
                           vbnl_error *err);

/* The same for a part of an image: the display window is (0,0)-(display_width-1,
 * display_height-1), the data window the pixels [window[0], window[2]) x [window[1], window[3])
 * (x0, y0, x1, y1; ends exclusive), which the layers hold: (x1-x0) * (y1-y0) pixels each, row 0
 * the window's top row. A window outside the image or empty fails with
 * VBNL_ERR_INVALID_ARGUMENT. (A crop render writes its window so; `vbnl merge-tiles` joins such
 * parts.) */
vbnl_result vbi_exr_write_window(const char *path, uint32_t display_width, uint32_t display_height,
                                  const uint32_t window[4], const vbi_image_layer *layers,
                                  uint32_t layer_count, const vbi_image_attr *attrs,
                                  uint32_t attr_count, int half_float, vbnl_error *err);

/* Where a channel's pixels came from in the file. */
typedef enum vbi_exr_pixel_type {
    VBI_EXR_PIXEL_UINT = 0,  /* converted to float exactly up to 2^24 */
    VBI_EXR_PIXEL_HALF = 1,
    VBI_EXR_PIXEL_FLOAT = 2,
} vbi_exr_pixel_type;

typedef struct vbi_exr_channel {
    char *name;                     /* full name as stored, e.g. "R", "albedo.G" */
    vbi_exr_pixel_type stored_type;
    float *data;                    /* width * height floats, planar, row 0 = top of data window */
} vbi_exr_channel;

/* An image read from disk. Everything it points to is owned by it: release with
 * vbi_exr_image_free. Channels are in file order (sorted by name: "A","B","G","R",...): look
 * them up by name with vbi_exr_image_channel, never by index. */
typedef struct vbi_exr_image {
    uint32_t width, height;         /* of the data window */
    int32_t data_x, data_y;         /* data window origin (0,0 for whole images this module writes) */
    uint32_t channel_count;
    vbi_exr_channel *channels;
    uint32_t attr_count;
    vbi_image_attr *attrs;         /* string, int, float and double attributes, file order */
    int has_chromaticities;
    float chromaticities[8];        /* red xy, green xy, blue xy, white xy */
    int32_t display_x, display_y;   /* display window: origin and size (the whole image, of */
    uint32_t display_width, display_height; /* which the data window may be a part) */
} vbi_exr_image;

/* Reads the first part of `path` (scanline or tiled; for tiled files the full-resolution level).
 * Pixel data is decoded planar in the stored type and converted here, so HALF files from any
 * writer come back with R, G, B, A in their places (see the OpenEXR 3.1 bug in dependencies.md).
 * On success *out is filled; on failure *out is zeroed and needs no free. */
vbnl_result vbi_exr_read(const char *path, vbi_exr_image *out, vbnl_error *err);

/* Releases everything owned by `img` and zeroes it. NULL and zeroed images are allowed. */
void vbi_exr_image_free(vbi_exr_image *img);

/* Channel named `name` (exact, case-sensitive) or NULL. */
const vbi_exr_channel *vbi_exr_image_channel(const vbi_exr_image *img, const char *name);

/* Attribute named `name` or NULL. */
const vbi_image_attr *vbi_exr_image_attr(const vbi_exr_image *img, const char *name);

/* ---------------------------------------------------------------------------------------------- */
/* PNG                                                                                            */

/* Writes `path` as a PNG with an sRGB chunk (rendering intent: perceptual). `pixels` holds
 * width*height*channels samples, uint8_t when bit_depth is 8 and uint16_t in native byte order
 * when it is 16. channels: 1 (gray), 3 (RGB) or 4 (RGBA, straight alpha). The values are stored
 * as given: encode them first (vbi_linear_to_srgb8). Atomic like vbi_exr_write. */
vbnl_result vbi_png_write(const char *path, uint32_t width, uint32_t height, uint32_t channels,
                           uint32_t bit_depth, const void *pixels, vbnl_error *err);

/* A PNG read back from disk; `pixels` (malloc'ed, owned) is laid out as vbi_png_write expects. */
typedef struct vbi_png_image {
    uint32_t width, height;
    uint32_t channels;   /* 1, 3 or 4 (gray+alpha is expanded to RGBA, palettes to RGB/RGBA) */
    uint32_t bit_depth;  /* 8 or 16 (1/2/4-bit gray is expanded to 8) */
    int has_srgb;        /* the file has an sRGB chunk */
    void *pixels;
} vbi_png_image;

/* Reads any PNG (any colour type, 1..16 bits, interlaced or not) into the layout above. On
 * failure *out is zeroed and needs no free. */
vbnl_result vbi_png_read(const char *path, vbi_png_image *out, vbnl_error *err);

/* Releases `img->pixels` and zeroes it. NULL allowed. */
void vbi_png_image_free(vbi_png_image *img);

/* ---------------------------------------------------------------------------------------------- */
/* Display transform                                                                              */

/* Converts scene-linear Rec.709 pixels to 8-bit sRGB for display/PNG:
 *   v = clamp(linear * 2^exposure_stops, 0, 1); out = round(255 * sRGB_OETF(v) + dither)
 * with the piecewise IEC 61966-2-1 OETF. NaN becomes 0, +inf 255. Alpha (4th source channel) is
 * clamped and quantised linearly, without exposure or OETF; if src has 3 channels and dst 4, alpha
 * is 255. dither != 0 adds triangular (TPDF, +-1 LSB) noise from a hash of (x, y, channel): the
 * result depends only on the inputs, never on threads or call order; exact 0 and 255 stay exact.
 * src_channels and dst_channels: 3 or 4. Errors: VBNL_ERR_INVALID_ARGUMENT only. */
vbnl_result vbi_linear_to_srgb8(const float *src, uint32_t width, uint32_t height,
                                 uint32_t src_channels, float exposure_stops, int dither,
                                 uint8_t *dst, uint32_t dst_channels, vbnl_error *err);

/* Quantises display-referred values (already through a view, e.g. OpenColorIO) for a PNG:
 *   out = round(maxv * clamp(v, 0, 1) + dither),  maxv = 255 (bits 8) or 65535 (bits 16)
 * NaN becomes 0. dither != 0 adds the same position-hashed triangular noise as
 * vbi_linear_to_srgb8 (exact 0 and maxv stay exact). dst holds uint8_t (8 bits) or uint16_t
 * (16 bits), dst_channels per pixel (3 or 4; from 3 source channels alpha is opaque).
 * Errors: VBNL_ERR_INVALID_ARGUMENT only. */
vbnl_result vbi_display_quantise(const float *src, uint32_t width, uint32_t height, uint32_t src_channels,
                                  uint32_t bits, int dither, void *dst, uint32_t dst_channels,
                                  vbnl_error *err);

#ifdef __cplusplus
}
#endif
#endif
