/* Per-point textures (private header): the committed form of the nodes of scene.h's texture
 * section and their evaluation.
 *
 *   noise.c     POV-Ray's noise, turbulence and tables            (noise.h)
 *   warp.c      warps and the point mapping of a pattern
 *   pattern.c   the value of each pattern kind; fractal.c the fractal patterns; tiling.c and
 *               tiling_table.h the tiling pattern
 *   image.c     image lookups (POV-Ray's map types, interpolations, once)
 *   pigment.c   pigments and maps
 *   normal.c    normal perturbation
 *   material.c  materials chosen per point (the blend, layers, transmission) and the BSDF at a hit
 *   nodes.c     the scene API: validation and storage of the nodes
 *
 * Nodes live in the scene's vbi_texture_set, refer to each other by index and are immutable once
 * added. Evaluation reads them only: no allocation, no shared state, so any number of threads may
 * evaluate at once. */
#ifndef VBI_TEXTURE_TEXTURE_H
#define VBI_TEXTURE_TEXTURE_H

#include <stdint.h>

#include "noise.h"
#include "vbnl/scene.h"
#include "vmath.h"

/* POV-Ray offsets the cell of checker and cells by 1e-10; hit points here are single precision,
 * so the offset is 1e-4: a face lying on an integer plane stays in one cell. */
#define VBI_PATTERN_CELL_EPS 1e-4

typedef struct vbi_warp {
    vbnl_warp_kind kind;
    dmat m, inv;             /* TRANSFORM: the point map and its inverse */
    vbi_turb turb;          /* TURBULENCE */
    int axis;                /* REPEAT */
    double width;
    dvec3 offset, flip;      /* flip: -1 on mirrored axes, +1 elsewhere */
    dvec3 center;            /* BLACK_HOLE */
    double radius, strength, falloff;
    int inverse, repeat, uncertain;
    dvec3 repeat_vec, jitter;
    dvec3 orient;            /* mappings */
    double dist_exp, major_radius, plane_offset;
} vbi_warp;

typedef enum vbi_image_wrap {
    VBI_IMAGE_REPEAT = 0,
    VBI_IMAGE_ONCE,         /* outside the image: no colour (clear) */
    VBI_IMAGE_CLAMP,        /* outside: the edge texels (vbnl_texture_desc CLAMP) */
} vbi_image_wrap;

typedef struct vbi_image {
    uint32_t width, height, channels;
    float *texels;
    uint8_t *indices;        /* NULL unless a palette image */
    int opaque;              /* no alpha below 1 */
} vbi_image;

typedef struct vbi_pattern {
    vbnl_pattern_kind kind;
    int has_xf;
    dmat xf, xf_inv;         /* the transform and its inverse */
    uint32_t warp_begin, warp_count;
    int has_turb;            /* classic turbulence */
    vbi_turb turb;
    int generator;
    vbnl_texture_wave wave;
    double frequency, phase, exponent;
    union {
        dvec3 gradient;      /* unit */
        struct { dvec3 size; double mortar; } brick;
        double agate_turb;
        struct { double c0, c1; } quilted;
        int arms;
        struct { dvec3 form; double metric, offset; int solid; } crackle;
        struct {
            int iterations, exponent, magnet, julia, interior, exterior;
            double cu, cv, ifactor, efactor;
        } fractal;
        struct { double size, coords, metric; } facets;
        int tiling;
        struct {
            dvec3 dir, alt;  /* unit (dir: the point with point_at) */
            double low, span, alt_low, alt_span; /* span 0: no range */
            double w_slope, w_alt;
            int point_at;
        } slope;
        struct { uint32_t nx, ny, nz; int interpolate; float *values; } density;
        struct {
            uint32_t image;  /* index */
            int map_type, interpolate, use;
            int uv;          /* the hit's UV as the image coordinate (legacy UV textures) */
            vbi_image_wrap wrap;
            double filter_all, transmit_all, major_radius;
        } image;
        struct { vbnl_pattern_fn fn; void *user; void (*destroy)(void *user); } function;
        uint32_t pigment;    /* index */
        int waves;
    } u;
} vbi_pattern;

typedef struct vbi_pigment {
    vbnl_pigment_kind kind;
    float color[5];
    uint32_t pattern;        /* index + 1 */
    uint32_t entry_begin, entry_count;
    int uv;
    uint32_t depth;
} vbi_pigment;

typedef struct vbi_normal {
    vbnl_normal_kind kind;
    uint32_t pattern;        /* index + 1 */
    double amount, accuracy;
    uint32_t slope_begin, slope_count;
    uint32_t entry_begin, entry_count;
    int no_bump_scale, uv;
    uint32_t depth;
} vbi_normal;

/* A material node's committed form (scene_material.node). */
typedef struct vbi_mnode {
    vbnl_material_node_kind kind;
    uint32_t material;       /* TEXTURED */
    uint32_t pigment, normal, transmission; /* id + 1 */
    uint32_t pattern;        /* id + 1 */
    uint32_t entry_begin, entry_count; /* map entries or layers */
    int uv;
    uint32_t depth;
} vbi_mnode;

typedef struct vbi_texture_set {
    const vbi_noise_tables *noise;
    vbi_image *images;
    uint32_t image_count, image_cap;
    vbi_warp *warps;
    uint32_t warp_count, warp_cap;
    vbi_pattern *patterns;
    uint32_t pattern_count, pattern_cap;
    vbi_pigment *pigments;
    uint32_t pigment_count, pigment_cap;
    vbnl_pigment_map_entry *pigment_entries;
    uint32_t pigment_entry_count, pigment_entry_cap;
    vbi_normal *normals;
    uint32_t normal_count, normal_cap;
    vbnl_normal_map_entry *normal_entries;
    uint32_t normal_entry_count, normal_entry_cap;
    vbnl_slope_map_entry *slope_entries;
    uint32_t slope_entry_count, slope_entry_cap;
    vbnl_material_map_entry *material_entries; /* node maps and layers (value unused) */
    uint32_t material_entry_count, material_entry_cap;
} vbi_texture_set;

void vbi_texture_set_init(vbi_texture_set *ts);
void vbi_texture_set_free(vbi_texture_set *ts);

/* What patterns may look at besides the point: the hit's world position, unit shading normal
 * (before any bump, on the geometric normal's side), UV, and the camera position (aoi). */
typedef struct vbi_shade_point {
    dvec3 p, n;
    double u, v;
    dvec3 eye;
} vbi_shade_point;

/* ---- patterns (warp.c, pattern.c) ---- */

/* The point a pattern evaluates at: q mapped by the pattern's transform and warps (and its
 * classic turbulence, except for the kinds that use it in their formula). */
dvec3 vbi_pattern_point(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 q);
/* The pattern's raw value at its own (warped) point w, before frequency and wave. */
double vbi_pattern_raw(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 w, const vbi_shade_point *sp);
/* Frequency, phase and wave applied to a raw value (POV-Ray's Evaluate_TPat tail). */
double vbi_pattern_shape(const vbi_pattern *pt, double v);
/* The whole pattern value at the point q it receives; *warped (optional) gets its warped point,
 * where the children of a map are evaluated. */
double vbi_pattern_value(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 q, const vbi_shade_point *sp,
                          dvec3 *warped);
/* The transform warps alone, for normals: n into the pattern's space (not normalised). */
dvec3 vbi_pattern_normal_in(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 n);
/* ... and back out. */
dvec3 vbi_pattern_normal_out(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 n);

/* Pattern kinds computed in their own files. */
double vbi_pattern_fractal(const vbi_pattern *pt, dvec3 p);
double vbi_pattern_tiling(int type, dvec3 p);
/* The quilted offset (its value and its normal perturbation use it). */
dvec3 vbi_pattern_quilted_offset(const vbi_pattern *pt, dvec3 p);

/* ---- images (image.c) ---- */

/* The colour (r, g, b, filter, transmit) of an IMAGE pattern at its warped point w. Returns 0
 * (and a clear colour) where a `once` image does not reach; *index receives the palette index
 * (or -1). */
int vbi_image_color(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 w, const vbi_shade_point *sp,
                     float out[5], int *index);
/* The pixel coordinates (x across, y down from the top, wrapped into the image) of an IMAGE
 * pattern at w, 0 where it has none; and the (interpolated) texel there. */
int vbi_image_pixel(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 w, const vbi_shade_point *sp,
                     double *x, double *y);
void vbi_image_lookup(const vbi_texture_set *ts, const vbi_pattern *pt, double x, double y, float out[5], int *index);
/* The value of an IMAGE pattern (image_pattern, material_map index). */
double vbi_image_value(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 w, const vbi_shade_point *sp);

/* ---- pigments (pigment.c) ---- */

/* Pigment `id` at the point q it receives (world, or its parent's warped point). Returns 0 when
 * no colour was found (outside a `once` image): out is then clear. */
int vbi_pigment_eval(const vbi_texture_set *ts, uint32_t id, dvec3 q, const vbi_shade_point *sp, float out[5]);
/* The same for a pigment a material uses directly (world point or uv). */
int vbi_pigment_at(const vbi_texture_set *ts, uint32_t id, const vbi_shade_point *sp, float out[5]);
/* Where value v falls in a sorted map of `count` values read with `stride` bytes between them:
 * the entries before and after (equal when v is outside or exactly on one) and the weight of
 * `next` (POV-Ray's Search_Blend_Map). */
void vbi_map_search(const float *values, size_t stride, uint32_t count, double v, uint32_t *prev,
                     uint32_t *next, double *w);
/* POV-Ray's greyscale (0.297, 0.589, 0.114). */
static inline double vbi_greyscale(const float c[3]) { return 0.297 * c[0] + 0.589 * c[1] + 0.114 * c[2]; }

/* ---- normals (normal.c) ---- */

/* The unit shading normal sp->n perturbed by normal `id` (world space, unit), the normal
 * receiving the world point (or (u, v, 0) with its `uv`). */
dvec3 vbi_normal_perturb(const vbi_texture_set *ts, uint32_t id, const vbi_shade_point *sp);
/* The same with the point q it receives (inside a material map: the map's warped point) and sp->n
 * already in that point's space. */
dvec3 vbi_normal_perturb_at(const vbi_texture_set *ts, uint32_t id, dvec3 q, const vbi_shade_point *sp);

#endif
