/* Film: per-pixel accumulation of every layer (private header).
 *
 * Storage is tile-major (16x16 tiles, each a contiguous block aligned to 64 bytes) so that two
 * threads rendering different tiles never write to the same cache line. Each pixel holds the
 * running sums of all layers' channels (double, so that long reference renders do not lose
 * precision) and a sample count; reading a layer divides by the count. Layer 0 is the beauty
 * image (R, G, B, A); the core also adds albedo, normal and depth. */
#ifndef VBI_FILM_H
#define VBI_FILM_H

#include <stdint.h>

#include "vbnl/render.h"

#define VBI_FILM_TILE 16u
#define VBI_FILM_MAX_LAYERS 16u

typedef struct film_layer {
    char name[32];
    uint32_t channels;
    const char *channel_names[4];
    uint32_t offset;            /* first channel within a pixel's record */
} film_layer;

struct vbnl_film {
    uint32_t width, height;
    uint32_t tiles_x, tiles_y;
    uint32_t crop[4];
    film_layer layers[VBI_FILM_MAX_LAYERS];
    uint32_t layer_count;
    uint32_t stride;            /* channels per pixel, all layers */
    size_t tile_doubles;        /* doubles per tile block, padded to a cache line */
    double *data;
    uint32_t *samples;          /* tile-major like data */
};

/* The standard layers' offsets (VBNL_FILM_BEAUTY ...) and the channel limit are public
 * (vbnl/render.h). */

vbnl_result vbi_film_create(uint32_t width, uint32_t height, const uint32_t crop[4], vbnl_film **out,
                             vbnl_error *err);
void vbi_film_destroy(vbnl_film *f);
vbnl_result vbi_film_allocate(vbnl_film *f, vbnl_error *err);

static inline size_t vbi_film_pixel_index(const vbnl_film *f, uint32_t x, uint32_t y, size_t *tile)
{
    uint32_t tx = x / VBI_FILM_TILE, ty = y / VBI_FILM_TILE;
    *tile = (size_t)ty * f->tiles_x + tx;
    return (size_t)(y % VBI_FILM_TILE) * VBI_FILM_TILE + (x % VBI_FILM_TILE);
}

/* Adds one sample: `values` holds f->stride floats (every layer). The record and the sample are
 * never the same memory (restrict), so the sums vectorise. */
static inline void vbi_film_add(vbnl_film *f, uint32_t x, uint32_t y, const float *restrict values)
{
    size_t tile;
    size_t px = vbi_film_pixel_index(f, x, y, &tile);
    double *restrict d = f->data + tile * f->tile_doubles + px * f->stride;
    const uint32_t n = f->stride;
    for (uint32_t c = 0; c < n; ++c)
        d[c] += (double)values[c];
    f->samples[tile * VBI_FILM_TILE * VBI_FILM_TILE + px] += 1;
}

#endif
