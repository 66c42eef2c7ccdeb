#include "film.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const rgba_names[] = {"R", "G", "B", "A"};
static const char *const xyz_names[] = {"X", "Y", "Z"};
static const char *const z_names[] = {"Z"};

vbnl_result vbi_film_create(uint32_t width, uint32_t height, const uint32_t crop[4], vbnl_film **out,
                             vbnl_error *err)
{
    if (!out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_film_create: out is NULL");
    if (width == 0 || height == 0 || width > 65536 || height > 65536)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "image size %ux%u is out of range (1 .. 65536 per side)", width, height);
    vbnl_film *f = calloc(1, sizeof(*f));
    if (!f)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    f->width = width;
    f->height = height;
    f->tiles_x = (width + VBI_FILM_TILE - 1) / VBI_FILM_TILE;
    f->tiles_y = (height + VBI_FILM_TILE - 1) / VBI_FILM_TILE;
    if (crop && (crop[0] | crop[1] | crop[2] | crop[3])) {
        if (crop[0] >= crop[2] || crop[1] >= crop[3] || crop[2] > width || crop[3] > height) {
            free(f);
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "crop window %u,%u-%u,%u does not lie inside the %ux%u image",
                                  crop[0], crop[1], crop[2], crop[3], width, height);
        }
        memcpy(f->crop, crop, sizeof(f->crop));
    } else {
        f->crop[2] = width;
        f->crop[3] = height;
    }
    uint32_t off;
    vbnl_film_add_layer(f, "", 4, rgba_names, &off, NULL);
    vbnl_film_add_layer(f, "albedo", 3, rgba_names, &off, NULL);
    vbnl_film_add_layer(f, "normal", 3, xyz_names, &off, NULL);
    vbnl_film_add_layer(f, "depth", 1, z_names, &off, NULL);
    *out = f;
    return VBNL_OK;
}

void vbi_film_destroy(vbnl_film *f)
{
    if (!f)
        return;
    free(f->data);
    free(f->samples);
    free(f);
}

vbnl_result vbnl_film_add_layer(vbnl_film *f, const char *name, uint32_t channels,
                                const char *const *channel_names, uint32_t *offset, vbnl_error *err)
{
    if (!f || !name || !channel_names || channels == 0 || channels > 4)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_film_add_layer: bad argument");
    if (f->data)
        return vbnl_error_set(err, VBNL_ERR_STATE, "film layers must be added before allocation");
    if (strlen(name) >= sizeof(f->layers[0].name))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "layer name '%s' is too long", name);
    for (uint32_t i = 0; i < f->layer_count; ++i)
        if (strcmp(f->layers[i].name, name) == 0)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "layer '%s' exists already", name);
    if (f->layer_count == VBI_FILM_MAX_LAYERS || f->stride + channels > VBNL_FILM_MAX_CHANNELS)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "too many film layers");
    film_layer *l = &f->layers[f->layer_count++];
    strcpy(l->name, name);
    l->channels = channels;
    for (uint32_t c = 0; c < channels; ++c)
        l->channel_names[c] = channel_names[c];
    l->offset = f->stride;
    f->stride += channels;
    if (offset)
        *offset = l->offset;
    return VBNL_OK;
}

vbnl_result vbi_film_allocate(vbnl_film *f, vbnl_error *err)
{
    size_t tiles = (size_t)f->tiles_x * f->tiles_y;
    size_t px = VBI_FILM_TILE * VBI_FILM_TILE;
    f->tile_doubles = (px * f->stride + 7) & ~(size_t)7; /* 64-byte multiple */
    size_t bytes = tiles * f->tile_doubles * sizeof(double);
    f->data = aligned_alloc(64, bytes);
    f->samples = aligned_alloc(64, ((tiles * px * sizeof(uint32_t)) + 63) & ~(size_t)63);
    if (!f->data || !f->samples) {
        free(f->data);
        free(f->samples);
        f->data = NULL;
        f->samples = NULL;
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY,
                              "out of memory for a %ux%u film (%.1f MB)", f->width, f->height,
                              (double)bytes / 1e6);
    }
    memset(f->data, 0, bytes);
    memset(f->samples, 0, tiles * px * sizeof(uint32_t));
    return VBNL_OK;
}

uint32_t vbnl_film_width(const vbnl_film *f) { return f ? f->width : 0; }
uint32_t vbnl_film_record_size(const vbnl_film *f) { return f ? f->stride : 0; }
uint32_t vbnl_film_height(const vbnl_film *f) { return f ? f->height : 0; }
uint32_t vbnl_film_layer_count(const vbnl_film *f) { return f ? f->layer_count : 0; }

vbnl_result vbnl_film_layer(const vbnl_film *f, uint32_t index, vbnl_layer_info *out, vbnl_error *err)
{
    if (!f || !out || index >= f->layer_count)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_film_layer: bad argument");
    out->name = f->layers[index].name;
    out->channels = f->layers[index].channels;
    out->channel_names = f->layers[index].channel_names;
    return VBNL_OK;
}

uint32_t vbnl_film_pixel_samples(const vbnl_film *f, uint32_t x, uint32_t y)
{
    if (!f || !f->samples || x >= f->width || y >= f->height)
        return 0;
    size_t tile;
    size_t px = vbi_film_pixel_index(f, x, y, &tile);
    return f->samples[tile * VBI_FILM_TILE * VBI_FILM_TILE + px];
}

vbnl_result vbnl_film_read(const vbnl_film *f, const char *layer, float *dst, size_t dst_count,
                           vbnl_error *err)
{
    if (!f || !layer || !dst)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_film_read: NULL argument");
    const film_layer *l = NULL;
    for (uint32_t i = 0; i < f->layer_count; ++i)
        if (strcmp(f->layers[i].name, layer) == 0)
            l = &f->layers[i];
    if (!l) {
        char list[512] = "";
        for (uint32_t i = 0; i < f->layer_count; ++i) {
            size_t n = strlen(list);
            snprintf(list + n, sizeof(list) - n, "%s'%s'", i ? ", " : "", f->layers[i].name);
        }
        return vbnl_error_set(err, VBNL_ERR_UNKNOWN_NAME, "no film layer '%s' (layers: %s)", layer, list);
    }
    size_t need = (size_t)f->width * f->height * l->channels;
    if (dst_count < need)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbnl_film_read: buffer holds %zu floats, layer '%s' needs %zu", dst_count,
                              layer, need);
    if (!f->data) {
        memset(dst, 0, need * sizeof(float));
        return VBNL_OK;
    }
    for (uint32_t y = 0; y < f->height; ++y) {
        for (uint32_t x = 0; x < f->width; ++x) {
            size_t tile;
            size_t px = vbi_film_pixel_index(f, x, y, &tile);
            uint32_t n = f->samples[tile * VBI_FILM_TILE * VBI_FILM_TILE + px];
            const double *d = f->data + tile * f->tile_doubles + px * f->stride + l->offset;
            float *o = dst + ((size_t)y * f->width + x) * l->channels;
            for (uint32_t c = 0; c < l->channels; ++c)
                o[c] = n ? (float)(d[c] / n) : 0.0f;
        }
    }
    return VBNL_OK;
}
