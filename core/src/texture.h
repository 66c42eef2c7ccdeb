/* Textures (private header): the committed form of a vbnl_texture_desc and its lookup. */
#ifndef VBNL_TEXTURE_H
#define VBNL_TEXTURE_H

#include <stdint.h>

#include "vbnl/scene.h"
#include "vmath.h"

typedef struct vbnl_texture {
    vbnl_texture_kind kind;
    mat4 xf;                    /* pattern_from_world */
    float *texels;              /* IMAGE: width * height * 3 */
    uint32_t width, height;
    vbnl_texture_projection projection;
    vbnl_texture_wrap wrap;
    int interpolate;
    vec3 gradient;              /* unit */
    vec3 brick_size;
    float mortar;
    vbnl_color_map_entry *map;
    uint32_t map_count;
    float frequency, phase;
    vbnl_texture_wave wave;
} vbnl_texture;

/* Colour at the world-space point p with mesh coordinates uv. */
vec3 vbnl_texture_eval(const vbnl_texture *t, vec3 p, vec2 uv);
/* The raw pattern value (before the colour map) at texture-space point q: for tests. */
float vbnl_texture_pattern(const vbnl_texture *t, vec3 q);
/* Colour-map lookup of a value. */
vec3 vbnl_color_map_eval(const vbnl_color_map_entry *map, uint32_t count, float v);
/* Image lookup at (u, v) with the texture's wrap and filter. */
vec3 vbnl_texture_image(const vbnl_texture *t, float u, float v);

#endif
