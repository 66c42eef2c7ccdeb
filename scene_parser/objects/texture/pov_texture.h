/* vbnl object layer, texture part: the types and functions its files share, and the accessors
 * its tests use. The object part sees only pov_internal.h. */
#ifndef VBNL_POV_TEXTURE_H
#define VBNL_POV_TEXTURE_H

#include <stdint.h>

#include "pov_block.h"
#include "pov_internal.h"
#include "pov_matrix.h"
#include "pov_transform.h"

#define POV_MAP_MAX 256    /* entries of a colour map */
#define POV_PATH_MAX 1024  /* an image file's path */
#define POV_NEST_MAX 64    /* pigments in pigment lists, textures in texture patterns */

/* ---- the values ------------------------------------------------------------------------------ */

enum { POV_PIG_SOLID = 0, POV_PIG_CHECKER, POV_PIG_GRADIENT, POV_PIG_BRICK, POV_PIG_IMAGE };

typedef struct pov_map_entry {
    double value;
    double color[5];
} pov_map_entry;

typedef struct pov_color_map {
    uint32_t count;
    pov_map_entry e[POV_MAP_MAX];
} pov_color_map;

typedef struct pov_pigment {
    int kind;
    double color[5];       /* POV_PIG_SOLID (also the average that stands for unsupported patterns) */
    pov_color_map map;     /* patterns: colour map, or the two colours of checker / brick */
    double gradient[3], brick_size[3], mortar, frequency, phase;
    int wave;
    int image;             /* POV_PIG_IMAGE: index in the state's image list */
    int map_type, once, interpolate, uv_mapping;
    double xf[16];         /* pattern space -> POV world: the transforms applied so far */
} pov_pigment;

typedef struct pov_finish {
    double diffuse, emission[3], reflection[3], specular, roughness, phong, phong_size;
    int metallic;
} pov_finish;

typedef struct pov_ext_bsdf { /* vbnl_bsdf { }: a core material given directly */
    int set, has_color;
    vbnl_material_desc desc;
} pov_ext_bsdf;

typedef struct pov_texture {
    pov_pigment pig;
    pov_finish fin;
    pov_ext_bsdf ext;
} pov_texture;

typedef struct pov_interior {
    double ior;
} pov_interior;

struct pov_appearance {
    pov_texture tex;
    pov_interior interior;
    vbnl_sdl_loc loc;     /* where the object's appearance was first given (warnings) */
    int own_texture;      /* a texture { } was given on this object: another one is a layer */
    int refs;             /* holders of this heap copy (pov_appearance_free drops one) */
};

/* A declared normal carries nothing: normals are not rendered. */
typedef struct pov_normal {
    int unused;
} pov_normal;

typedef struct pov_image {
    char path[POV_PATH_MAX];
    uint32_t width, height;
    float *texels; /* linear RGB */
} pov_image;

typedef struct pov_material_entry pov_material_entry; /* core_material.c */

struct pov_texture_state {
    pov_appearance deflt; /* what #default makes new objects start from */
    pov_appearance *deflt_shared; /* one heap copy of deflt shared by the placed objects that have no
                                     appearance of their own (dropped when #default changes) */
    pov_image *images;
    uint32_t image_count;
    pov_material_entry **cache;
    uint32_t cache_count, cache_cap;
    int normal_warned;
    int depth; /* nested pigments and texture patterns */
};

/* ---- declared values (appearance.c) ---------------------------------------------------------- */

extern const vbnl_sdl_opaque_type pov_type_texture, pov_type_pigment, pov_type_finish, pov_type_normal,
    pov_type_interior, pov_type_material, pov_type_color_map;
/* Takes the value of an identifier, or of an array element `Arr[i]...`, holding a value of this
 * type into dst. Returns 1 when taken (tokens consumed), 0 when the next token is not such a
 * value, -1 on a parse error. */
int pov_take_ident(pov_ctx *c, const vbnl_sdl_opaque_type *type, void *dst, size_t size);
void pov_appearance_init(pov_appearance *a);

/* ---- the blocks; each is called after its keyword and reads from its '{' ------------------------ */

void pov_texture_init(pov_texture *t);                         /* texture.c */
vbnl_result pov_texture_parse(pov_ctx *c, pov_texture *tx);
/* Rows whose target is a pov_texture: `texture { }` read over it, and the items of a texture
 * (pigment finish normal vbnl_bsdf uv_mapping), which may also stand directly in an object. */
extern const pov_row pov_texture_rows[];
extern const pov_row pov_texture_item_rows[];
/* Layered textures are rendered as one: the next layer replaces the one below unless its pigment
 * is mostly transparent. */
void pov_texture_put_layer(pov_texture *below, const pov_texture *above);

void pov_pigment_init(pov_pigment *p);                         /* pigment.c */
vbnl_result pov_pigment_parse(pov_ctx *c, pov_pigment *pg);

vbnl_result pov_color_map_parse(pov_ctx *c, pov_color_map *m); /* color_map.c */
/* Interval-weighted average colour of a map over [0, 1] (entries held outside their range). */
void pov_color_map_average(const pov_color_map *m, double out[5]);
/* Mean filter + transmit of a pigment (its colour map's average for patterns; images count as
 * opaque). */
double pov_pigment_transparency(const pov_pigment *g);

vbnl_result pov_image_map_parse(pov_ctx *c, pov_pigment *pg);  /* image_map.c */

void pov_finish_init(pov_finish *f);                           /* finish.c */
vbnl_result pov_finish_parse(pov_ctx *c, pov_finish *f);
/* A colour (its first three components). */
vbnl_result pov_parse_color3(pov_ctx *c, double out[3]);

vbnl_result pov_normal_parse(pov_ctx *c, const vbnl_sdl_loc *loc); /* normal.c */

vbnl_result pov_interior_parse(pov_ctx *c, pov_interior *in);  /* interior.c */
vbnl_result pov_material_parse(pov_ctx *c, pov_appearance *a);

vbnl_result pov_bsdf_parse(pov_ctx *c, pov_ext_bsdf *e);       /* vbnl_bsdf.c */

/* ---- patterns (pattern.c) ---------------------------------------------------------------------- */

/* 1 when `t` names a pattern rendered as the average colour of its colour map (bozo, wood,
 * hexagon, ...). */
int pov_is_fallback_pattern(const vbnl_sdl_token *t);
/* 1 when `t` names a pattern of a texture pattern (checker brick gradient and the fallbacks). */
int pov_is_pattern(const vbnl_sdl_token *t);
/* Pattern modifiers shared by pigments and texture patterns (waves, turbulence and the
 * parameters of the patterns rendered as averages); the target is a pov_pigment. */
extern const pov_row pov_pattern_modifier_rows[];
/* The arguments after a pattern keyword rendered as an average (pg NULL: a texture pattern). */
vbnl_result pov_pattern_args(pov_ctx *c, pov_pigment *pg, const char *name);
/* Block patterns and their number of colours (0: a continuous pattern). */
int pov_discrete_pattern(const char *name);
/* POV-Ray 3.7's default colour maps of the patterns (pattern.cpp); black to white otherwise. */
void pov_default_color_map(const char *name, pov_color_map *m);
/* Up to max colours or pigments after checker / brick / hexagon ...: entries at 0, 1, ... */
vbnl_result pov_block_colors(pov_ctx *c, pov_pigment *pg, int max);

/* ---- transforms inside appearances (transform.c) ----------------------------------------------- */

/* translate rotate scale matrix transform { }: rows that hand the matrix to the block's
 * transform callback. */
extern const pov_row pov_pattern_transform_rows[];

/* ---- test accessors (core_material.c) ---------------------------------------------------------- */

/* The description of core material `material` as pov_appearance_material added it (NULL when
 * that id was not added by the texture part), and its texture (NULL: untextured). */
const vbnl_material_desc *pov_texture_material_desc(const pov_ctx *c, uint32_t material);
const vbnl_texture_desc *pov_texture_texture_desc(const pov_ctx *c, uint32_t material);
/* Distinct core materials added so far. */
uint32_t pov_texture_material_count(const pov_ctx *c);

#endif
