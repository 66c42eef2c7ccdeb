/* vbnl object layer, texture part: the types and functions its files share, and the accessors
 * its tests use. The object part sees only pov_internal.h.
 *
 * POV-Ray's texture values are trees: a texture holds a pigment, a normal and a finish, or a
 * pattern with a map of textures, and layers below it; a pigment holds a pattern with a map of
 * colours or pigments; and so on. Each node here owns its children (deep copies: a declared value
 * is copied where it is used, as POV-Ray copies it), and core_material.c turns a finished tree
 * into core nodes (vbnl/scene.h's texture section) when an object is built. */
#ifndef VBI_POV_TEXTURE_H
#define VBI_POV_TEXTURE_H

#include <stdint.h>

#include "pov_block.h"
#include "pov_internal.h"
#include "pov_matrix.h"
#include "pov_transform.h"

#define POV_MAP_MAX 256    /* entries of a map (POV-Ray's MAX_BLEND_MAP_ENTRIES) */
#define POV_PATH_MAX 1024  /* an image file's path */
#define POV_NEST_MAX 64    /* pigments, normals and textures nested in maps and lists */
#define POV_WARP_MAX 64    /* warps and transforms of one pattern */

typedef struct pov_pigment pov_pigment;
typedef struct pov_normal pov_normal;
typedef struct pov_texture pov_texture;

/* ---- patterns ----------------------------------------------------------------------------------- */

/* A voxel grid read by density_file, shared between the copies of its pattern. */
typedef struct pov_density {
    int refs;
    uint32_t n[3];
    float *v; /* n[0] n[1] n[2] values in [0, 1], x fastest */
} pov_density;

/* A compiled SDL function (function { } patterns): shared between the copies of its pattern and
 * handed to the core, which frees it with the scene. */
typedef struct pov_fn pov_fn;

/* A pattern: what the core takes (vbnl_pattern_desc: kind, parameters, classic turbulence, wave)
 * and its warps in the order the core applies them (POV-Ray applies the last given first; its
 * classic turbulence last). */
typedef struct pov_pattern {
    vbnl_pattern_desc d;     /* warps / density / function / image / pigment pointers unset */
    const char *name;        /* the pattern's keyword (static), NULL before a pattern is given */
    vbnl_warp_desc *warps;   /* owned */
    uint32_t nwarps;
    int image;               /* IMAGE: index into the state's images, else -1 */
    pov_pigment *pigment;    /* PIGMENT: owned */
    pov_fn *fn;              /* FUNCTION */
    pov_density *density;    /* DENSITY */
} pov_pattern;

/* ---- maps --------------------------------------------------------------------------------------- */

typedef struct pov_map_entry {
    double value;
    double color[5];         /* colour entries */
    double slope[2];         /* slope_map entries: height, slope */
    void *sub;               /* pov_pigment, pov_normal or pov_texture of the entry (owned), or NULL */
} pov_map_entry;

typedef enum { POV_MAP_COLOR = 0, POV_MAP_PIGMENT, POV_MAP_NORMAL, POV_MAP_TEXTURE, POV_MAP_SLOPE } pov_map_kind;

typedef struct pov_map {
    pov_map_kind kind;
    uint32_t count;
    pov_map_entry *e;        /* owned */
} pov_map;

/* ---- pigments, normals, textures -------------------------------------------------------------------- */

enum { POV_PIG_SOLID = 0, POV_PIG_MAP, POV_PIG_IMAGE, POV_PIG_AVERAGE };

struct pov_pigment {
    int kind;
    double color[5];         /* SOLID: r g b filter transmit */
    pov_pattern pat;         /* MAP, IMAGE (an IMAGE pattern), AVERAGE (its transforms) */
    pov_map map;             /* colour or pigment entries; count 0: POV-Ray's default map of the pattern */
    int uv_mapping;
};

enum { POV_NRM_PATTERN = 0, POV_NRM_MAP, POV_NRM_AVERAGE, POV_NRM_IMAGE };

struct pov_normal {
    int kind;
    pov_pattern pat;
    double amount, accuracy; /* bump_size (0.5), accuracy (0.02) */
    pov_map slopes;          /* slope_map */
    pov_map map;             /* normal_map, average and block lists: normal entries */
    int no_bump_scale, uv_mapping;
};

typedef struct pov_finish {
    double diffuse, emission[3], specular, roughness, phong, phong_size;
    double reflection[3];     /* POV-Ray's variable reflection: the maximum (grazing) ... */
    double reflection_min[3]; /* ... and the minimum (head-on); equal without a second colour */
    double falloff;           /* reflection { falloff f }: the exponent of (1 - cos), 1 by default */
    double reflect_metallic;  /* reflection { metallic m }: the surface-colour tint, 0 by default */
    double brilliance; /* the diffuse falloff exponent (1: Lambert) */
    int metallic;      /* finish { metallic } */
    int fresnel; /* reflection { fresnel }: the reflection follows the interior's Fresnel term */
} pov_finish;

typedef struct pov_ext_bsdf { /* vbnl_bsdf { }: a core material given directly */
    int set, has_color;
    vbnl_material_desc desc;
} pov_ext_bsdf;

enum { POV_TEX_PLAIN = 0, POV_TEX_MAP, POV_TEX_AVERAGE, POV_TEX_MATERIAL_MAP };

struct pov_texture {
    int kind;
    pov_pigment *pig;        /* PLAIN: owned, never NULL */
    pov_normal *nrm;         /* PLAIN: owned, NULL for none */
    pov_finish fin;          /* PLAIN */
    pov_ext_bsdf ext;        /* PLAIN */
    pov_pattern pat;         /* MAP (texture_map, texture lists, tiles), MATERIAL_MAP, AVERAGE */
    pov_map map;             /* texture entries */
    int uv_mapping;
    pov_texture *below;      /* the next layer down (layered textures), owned, NULL at the bottom */
};

/* An interior as parsed: a plain value (copied byte for byte). Its core medium is made when an
 * object using it is built (core_material.c), where the object's transform is known. */
typedef struct pov_interior {
    double ior;
    double fade_distance, fade_power; /* POV-Ray's defaults 0 and 0: fade applies for distance > 0 */
    double fade_color[3];             /* black by default */
    vbnl_medium_part_desc media[VBNL_MEDIUM_PARTS_MAX]; /* its media { } blocks (density unset) */
    uint32_t nmedia;
    /* the density { } blocks of each media: indices + 1 into the state's densities */
    uint32_t density[VBNL_MEDIUM_PARTS_MAX][VBNL_MEDIUM_DENSITY_MAX];
    /* each media's transforms given after it (a material's, the object's: POV-Ray's
     * Interior::Transform moves the media an interior has; identity for unused slots) */
    double xf[VBNL_MEDIUM_PARTS_MAX][16];
    uint32_t medium;                  /* the core medium id + 1 (0: none); set only on the copy
                                       * core_material.c builds from */
} pov_interior;

struct pov_appearance {
    pov_texture *tex;        /* owned; the top layer */
    pov_interior interior;
    double xf[16];           /* object transforms given after the texture (they move its patterns) */
    vbnl_sdl_loc loc;        /* where the object's appearance was first given (warnings) */
    int own_texture;         /* a texture { } was given on this object: another one is a layer */
    int refs;                /* holders of this heap copy (pov_appearance_free drops one) */
};

typedef struct pov_image {
    char path[POV_PATH_MAX];
    int raw;                 /* read without gamma decoding (bump maps, image patterns) */
    uint32_t width, height, channels;
    float *texels;           /* linear values, `channels` per texel, row 0 at the top */
    uint8_t *indices;        /* palette images: the palette index of each texel, else NULL */
    uint32_t core_id;        /* core image id + 1 once added to the scene */
} pov_image;

typedef struct pov_material_entry pov_material_entry; /* core_material.c */

struct pov_texture_state {
    pov_appearance deflt;         /* what #default makes new objects start from */
    pov_appearance *deflt_shared; /* one heap copy of deflt shared by the placed objects that have no
                                     appearance of their own (dropped when #default changes) */
    pov_image *images;
    uint32_t image_count;
    pov_material_entry **cache;
    uint32_t cache_count, cache_cap;
    int depth;                    /* nested pigments, normals and textures */
    int noise_generator;          /* global_settings noise_generator (0: POV-Ray's default 2) */
    int waves;                    /* global_settings number_of_waves (0: POV-Ray's default 10) */
    pov_pigment **densities;      /* every media density { } read (owned), named by interiors */
    uint32_t density_count, density_cap;
};

/* ---- trees (tree.c) ----------------------------------------------------------------------------- */

void pov_pattern_init(pov_pattern *p);
void pov_pattern_free(pov_pattern *p);
/* Deep copies: 0 when out of memory (dst then needs no freeing). */
int pov_pattern_copy(pov_pattern *dst, const pov_pattern *src);
/* Adds a warp the pattern applies before all it has (POV-Ray's order: what is given later acts
 * on the point first); a transform next to a transform is merged. 0 when out of room. */
int pov_pattern_prepend_warp(pov_pattern *p, const vbnl_warp_desc *w);
/* A transform of the pattern (pattern space -> its parent's): prepends its inverse. */
int pov_pattern_transform(pov_pattern *p, const double m[16]);

void pov_map_free(pov_map *m);
int pov_map_copy(pov_map *dst, const pov_map *src);
/* Room for one more entry, zeroed, or NULL (the caller reports). */
pov_map_entry *pov_map_add(pov_map *m);

void pov_pigment_clear(pov_pigment *g); /* back to black, keeping the allocation */

pov_normal *pov_normal_new(void);
pov_normal *pov_normal_dup(const pov_normal *n);
void pov_normal_free(pov_normal *n);

pov_texture *pov_texture_new(void);   /* POV-Ray's default texture */
pov_texture *pov_texture_dup(const pov_texture *t); /* with its layers */
void pov_texture_free(pov_texture *t);
/* Puts `above` (a stack of layers, taken) on top of *stack. */
void pov_texture_put_layer(pov_texture **stack, pov_texture *above);
/* POV-Ray's Transform_Textures: a plain layer moves its pigment's and normal's patterns, a
 * patterned one its pattern; every layer. 0 when out of room for the transform. */
int pov_texture_transform(pov_texture *t, const double m[16]);

/* The interval-weighted average colour of a map over [0, 1] (entries held outside their range;
 * pigment entries by their average); POV-Ray's default map when the map is empty. */
void pov_pigment_average(const pov_pigment *g, const pov_texture_state *s, double out[5]);

/* A byte string that is equal for equal trees (the cache key of core materials). */
typedef struct pov_key {
    unsigned char *b;
    size_t n, cap;
    int failed;
} pov_key;
void pov_key_bytes(pov_key *k, const void *p, size_t n);
void pov_key_texture(pov_key *k, const pov_texture *t);

/* ---- declared values (appearance.c) -------------------------------------------------------------- */

extern const vbnl_sdl_opaque_type pov_type_texture, pov_type_pigment, pov_type_finish, pov_type_normal,
    pov_type_interior, pov_type_material, pov_type_color_map, pov_type_pigment_map, pov_type_normal_map,
    pov_type_texture_map, pov_type_slope_map;
/* Takes a copy of the value of an identifier, or of an array element `Arr[i]...`, holding a value
 * of this type: `copy(dst, value)` (0 out of memory). Returns 1 when taken (tokens consumed), 0
 * when the next token is not such a value, -1 on a parse error. */
int pov_take_ident(pov_ctx *c, const vbnl_sdl_opaque_type *type, void *dst, int (*copy)(void *dst, const void *src));
void pov_appearance_init(pov_appearance *a);
/* A `texture { }` item of an object or a material (target: its pov_appearance): the first one
 * replaces the texture it started from, each later one is a layer over it. */
vbnl_result pov_appearance_texture_item(const pov_item *it);
void pov_appearance_clear(pov_appearance *a);

/* ---- the blocks; each is called after its keyword and reads from its '{' ------------------------ */

/* texture { } read over *tx (its identifier, if any, replaces it; texture.c). */
vbnl_result pov_texture_parse(pov_ctx *c, pov_texture **tx);
/* Rows whose target is a pov_texture **: the items of a texture (pigment finish normal vbnl_bsdf
 * uv_mapping), which may also stand directly in an object. */
extern const pov_row pov_texture_item_rows[];
/* The body of a texture_map entry, or a texture after its '{' up to (not including) `close`. */
vbnl_result pov_texture_body(pov_ctx *c, pov_texture **tx, int close);

/* A pigment body up to (not including) `close` (']' in pigment_map entries, '}' in blocks). */
vbnl_result pov_pigment_body(pov_ctx *c, pov_pigment *pg, int close);

vbnl_result pov_normal_parse(pov_ctx *c, pov_normal **n);           /* normal.c: normal { } */
vbnl_result pov_normal_body(pov_ctx *c, pov_normal **n, int close);

/* color_map, pigment_map, normal_map, texture_map, slope_map (color_map.c): the map block after
 * its keyword, into m (replaced). `average` allows entries without a value (POV-Ray's average). */
vbnl_result pov_map_parse(pov_ctx *c, pov_map *m, pov_map_kind kind, int average);

vbnl_result pov_image_map_parse(pov_ctx *c, pov_pigment *pg);      /* image_map.c */
vbnl_result pov_bump_map_parse(pov_ctx *c, pov_normal *n);
vbnl_result pov_image_pattern_parse(pov_ctx *c, pov_pattern *pat);
/* material_map { file [once interpolate map_type] texture {} ... } into tx (a MATERIAL_MAP). */
vbnl_result pov_material_map_parse(pov_ctx *c, pov_texture *tx);

void pov_finish_init(pov_finish *f);                           /* finish.c */
vbnl_result pov_finish_parse(pov_ctx *c, pov_finish *f);
/* A colour (its first three components). */
vbnl_result pov_parse_color3(pov_ctx *c, double out[3]);

void pov_interior_init(pov_interior *in);                      /* interior.c: ior 1, no fade, no media */
vbnl_result pov_interior_parse(pov_ctx *c, pov_interior *in);
void pov_interior_transform(pov_interior *in, const double m[16]); /* moves the media it has */
/* POV-Ray's fade as an absorption coefficient per channel (docs/scene-language.md, "Media"):
 * 1 when the interior fades (fade_distance > 0 and fade_power > 0), else 0. */
int pov_interior_fade(const pov_interior *in, float sigma[3]);
/* The density { } block (after its keyword) into a new entry of the state's densities: *id. */
vbnl_result pov_density_parse(pov_ctx *c, uint32_t *id);
pov_pigment *pov_density_at(pov_ctx *c, uint32_t id);
/* density { } after its keyword, read over pg (pigment.c). */
vbnl_result pov_density_body(pov_ctx *c, pov_pigment *pg);
vbnl_result pov_material_parse(pov_ctx *c, pov_appearance *a);

vbnl_result pov_bsdf_parse(pov_ctx *c, pov_ext_bsdf *e);       /* vbnl_bsdf.c */

/* ---- patterns (pattern.c, warp.c) ---------------------------------------------------------------- */

/* What a pattern is read into: the pattern, and the map or list of its node. */
typedef struct pov_pattern_target {
    pov_pattern *pat;
    pov_map *map;            /* block patterns' lists of colours / pigments / normals / textures */
    pov_map_kind list_kind;  /* what their entries are */
    double *amount;          /* normals: the amount after the pattern (bumps 0.5), else NULL */
} pov_pattern_target;

/* When the next token is a pattern keyword: reads it with its arguments (and a block pattern's
 * list) into the target and returns 1; 0 when it is not one; -1 on error. */
int pov_pattern_keyword(pov_ctx *c, const pov_pattern_target *t);
/* Pattern modifiers (waves, frequency, phase, turbulence, octaves, omega, lambda, warp,
 * noise_generator and the patterns' own parameters) whose target is a pov_pattern. */
extern const pov_row pov_pattern_modifier_rows[];
/* POV-Ray 3.7's default colour maps of the patterns (pigment.cpp); black to white otherwise. */
void pov_default_color_map(const pov_pattern *p, pov_map *m);
/* 1 for the block patterns (checker brick hexagon square triangular cubic object): values are
 * block indices, entries come as a list. */
int pov_pattern_is_block(const pov_pattern *p);

/* warp { } (warp.c) into the pattern. */
vbnl_result pov_warp_parse(pov_ctx *c, pov_pattern *p);

/* ---- transforms inside appearances (transform.c) ----------------------------------------------- */

/* translate rotate scale matrix transform { }: rows that hand the matrix to the block's
 * transform callback. */
extern const pov_row pov_pattern_transform_rows[];

/* ---- functions (core_material.c) -------------------------------------------------------------------- */

/* The core image id of state image i (added to the scene on first use). */
vbnl_result pov_image_core_id(pov_ctx *c, int i, uint32_t *out, vbnl_error *err);

/* The evaluator of a pattern function (pigment 0: g's pattern) or a pigment function (1: g) for
 * the language layer (function.c). */
vbnl_result pov_function_block_build(pov_ctx *c, const pov_pigment *g, int pigment, vbnl_sdl_fn_block *out,
                                     vbnl_error *err);

/* ---- test accessors (core_material.c) ---------------------------------------------------------- */

/* The description of the plain core material an appearance made (for a textured one, its top
 * layer's BSDF; NULL when that id was not made by the texture part). */
const vbnl_material_desc *pov_texture_material_desc(const pov_ctx *c, uint32_t material);
/* Distinct core materials added so far. */
uint32_t pov_texture_material_count(const pov_ctx *c);

#endif
