/* vbnl object layer: the state of one load and the functions the object part's files share
 * (objects, shapes, modifiers, transforms, camera, lights, global settings, the environment,
 * building the core scene). The texture part is reached through pov_internal.h only. */
#ifndef VBI_POV_LOADER_H
#define VBI_POV_LOADER_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "pov_block.h"
#include "pov_object.h"
#include "pov_transform.h"
#include "vbnl/params.h"

#define POV_PI 3.14159265358979323846

/* A camera as written: POV-Ray's vectors, resolved onto the core camera by pov_camera_resolve. */
typedef struct pov_cam {
    double loc[3], dir[3], right[3], up[3], sky[3], look_at[3];
    double angle, angle_v;         /* angle_v: the spherical camera's vertical angle */
    int have_look_at, have_angle, have_up, have_right, have_angle_v;
    vbnl_camera_projection projection;
    double aperture, blur_samples; /* focal blur when both are non-zero */
    double focal_distance;         /* |focal_point - location| as written; < 0: |direction| */
    double m[16];
    /* mesh_camera: its meshes (shared between copies: pov_camera_copy, pov_camera_release) */
    struct pov_cam_meshes *meshes;
    unsigned mesh_rays, mesh_distribution;
    int mesh_smooth;
} pov_cam;

/* A fog { } block as read (fog.c). */
typedef struct pov_fog {
    double type, distance, color[5], offset, alt, up[3];
    double turbulence[3], turb_depth, omega, lambda, octaves;
    vbnl_sdl_loc loc;
} pov_fog;

typedef struct pov_loader {
    pov_ctx c;
    pov_obj world;           /* every object placed in the scene */
    double geo_centre[3];    /* centre of the geometry's bounds (build), for unfaded lights */
    int have_geo;
    pov_cam cam;
    int have_camera;
    double env[3];           /* background colour */
    int have_env;
    struct pov_sky *sky;     /* the sky_sphere (environment.c) or NULL */
    pov_fog *fogs;           /* fog { } blocks, in order */
    size_t nfogs;
    vbnl_medium_part_desc atmosphere[VBNL_MEDIUM_PARTS_MAX]; /* top-level media { } blocks */
    uint32_t natmosphere;
    char integrator[64];
    vbnl_params *params;
    char **diags;            /* warnings and notes, kept for vbnl_pov_scene_diag_text */
    size_t ndiags;
    vbnl_sdl_diag_fn user_diag;
    void *user_diag_user;
    int warned_shadowless;   /* a shadowless area_light was warned about */
    int files_disabled;      /* includes disabled: vbnl_mesh is refused too */
    vbnl_sdl_loc *warned;    /* skipped shapes already warned about */
    size_t nwarned;
    uint32_t *sphere_groups; /* per material: group holding a unit sphere (ellipsoids), or 0 */
    uint32_t nsphere_groups;
    struct pov_shape_cache *shape_cache; /* shapes made once and shared (shapes/shape_cache.c) */
    int build_error_located; /* pov_build's error names the statement's file:line:col */
    struct pov_query_cache *query_cache; /* Embree scenes of the meshes trace() met (query.c) */
} pov_loader;

/* ---- 3-vectors --------------------------------------------------------------------------------- */

static inline void pov_set3(double o[3], double a, double b, double c)
{
    o[0] = a;
    o[1] = b;
    o[2] = c;
}
static inline double pov_dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline double pov_len3(const double a[3]) { return sqrt(pov_dot3(a, a)); }
static inline void pov_cross3(const double a[3], const double b[3], double o[3])
{
    double r[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    memcpy(o, r, sizeof r);
}
static inline void pov_scale3(double a[3], double s)
{
    for (int i = 0; i < 3; ++i)
        a[i] *= s;
}

/* ---- reading values (object.c) ------------------------------------------------------------------ */

vbnl_result pov_oom(pov_loader *L); /* reports "out of memory" */
vbnl_result pov_vec3(pov_loader *L, double o[3]);
vbnl_result pov_float(pov_loader *L, double *o);
/* The count of a list ("vertex_vectors { 14 <..>, ...}"): '<' after it starts the first item,
 * as in POV-Ray, instead of comparing. */
vbnl_result pov_list_count(pov_loader *L, double *o);
void pov_comma(pov_loader *L); /* an optional ',' */
/* "<what> must be positive, got <v>" at loc unless v > 0 and finite. */
vbnl_result pov_positive(pov_loader *L, double v, const char *what, vbnl_sdl_loc loc);

/* ---- object values (object.c) ------------------------------------------------------------------ */

/* Opaque values of `#declare`: objects (pov_obj), transforms (double[16]) and cameras (pov_cam). */
extern const vbnl_sdl_opaque_type pov_object_type, pov_transform_type, pov_camera_type;
/* Answers min_extent, max_extent, inside and trace about object values (query.c) during L's
 * parse; pov_query_cache_free frees the Embree scenes trace() made (at the end of the load). */
void pov_queries_install(pov_loader *L);
void pov_query_cache_free(pov_loader *L);
/* The value of identifier `t` when it is declared with `type`, else NULL. */
const void *pov_declared(pov_loader *L, const vbnl_sdl_token *t, const vbnl_sdl_opaque_type *type);
void pov_object_destroy(void *ptr, void *user); /* a pov_obj value */

/* 1 when `t` is a shape keyword (supported or not): what a statement, a CSG operand or an
 * `object { }` starts with. */
int pov_is_shape(const vbnl_sdl_token *t);
/* The shape statement/value that starts at the next token (a shape keyword, not consumed) into o.
 * Nested objects count against the language layer's nesting limit. */
vbnl_result pov_parse_object(pov_loader *L, pov_obj *o);
/* A nested shape whose primitives join o (appearance handed down first): union members,
 * `object { shape }`. */
vbnl_result pov_parse_member(pov_loader *L, pov_obj *o);

/* ---- transforms (transform.c) -------------------------------------------------------------------- */

/* translate rotate scale matrix transform: rows that read the item and hand its matrix to the
 * block's transform callback (pov_block.transform). */
extern const pov_row pov_transform_rows[];
/* transform { [ID] items [inverse] }; the parser is on '{'. */
vbnl_result pov_transform_block(pov_loader *L, double m[16]);

/* ---- object modifiers (modifiers.c) -------------------------------------------------------------- */

/* A shape's modifiers. Simple shapes collect `clipped_by` and apply it when the shape is complete
 * (pov_mods_finish), since a cylinder's mesh is made after its modifiers; CSG and unions apply it
 * at once. */
typedef struct pov_mods {
    pov_loader *L;
    pov_obj *o;
    int shape;            /* 1: clipping deferred to pov_mods_finish */
    int open;             /* cylinder/cone: `open` seen */
    pov_obj clip;         /* clipped_by shapes (deferred) */
    vbnl_sdl_loc clip_loc;
} pov_mods;

/* The rows and hooks of the modifier block, for blocks that take modifiers among their own
 * items (union, light_group); their target is a pov_mods. */
extern const pov_row pov_modifier_rows[];
int pov_modifier_appearance(const pov_item *it); /* texture pigment finish ... (the texture part) */
void pov_modifier_transform(const pov_item *it, const double m[16]);

/* Modifiers up to and including the closing '}'. `open` accepts cylinder/cone's `open`. */
vbnl_result pov_mods_parse(pov_mods *m, const char *what, int open);
/* Applies the collected clipped_by (consumes it). */
vbnl_result pov_mods_finish(pov_mods *m);
void pov_mods_clear(pov_mods *m);
/* `{ shapes }` of clipped_by (the parser is on '{') into clip, one primitive per shape; `{
 * bounded_by }` and `{ clipped_by }` add none. Shapes whose bounded_by clips (the unbounded
 * ones) read theirs with it too. */
vbnl_result pov_clip_block(pov_loader *L, pov_obj *clip);
/* Modifiers of a CSG (clipping at once) up to and including the closing '}'. */
vbnl_result pov_modifiers(pov_loader *L, pov_obj *o, const char *what);

/* ---- camera (camera.c), lights (light.c) -------------------------------------------------------- */

void pov_camera_default(pov_cam *c);
/* *dst = *src, sharing src's mesh_camera meshes (dst holds none). */
void pov_camera_copy(pov_cam *dst, const pov_cam *src);
/* Lets go of the camera's mesh_camera meshes. */
void pov_camera_release(pov_cam *c);
/* The core's mesh camera of a resolved mesh_camera (out->projection VBNL_CAMERA_MESH): fills
 * out's mesh fields with arrays in *storage (free it after vbnl_scene_set_camera). */
vbnl_result pov_camera_meshes(pov_loader *L, const pov_cam *c, vbnl_camera_desc *out, void **storage, vbnl_error *err);
/* camera { [ID] items }; the parser is after the keyword. */
vbnl_result pov_camera_parse(pov_loader *L, pov_cam *c);
/* POV-Ray 3.7's camera set-up (angle, then look_at, then transforms) onto the core camera. */
vbnl_result pov_camera_resolve(pov_loader *L, const pov_cam *c, vbnl_sdl_loc loc, vbnl_camera_desc *out);
/* A light primitive onto the core light it maps to. */
vbnl_result pov_light_emit(pov_loader *L, const pov_prim *pr, vbnl_error *err);

/* ---- statements (settings.c, environment.c) ------------------------------------------------------ */

/* global_settings { ... } with the integrator block; the parser is after the keyword. */
vbnl_result pov_global_settings_parse(pov_loader *L);
/* background { colour } and sky_sphere { ... }; the parser is after the keyword at loc. */
vbnl_result pov_background_parse(pov_loader *L);
vbnl_result pov_sky_sphere_parse(pov_loader *L, const vbnl_sdl_loc *loc);
/* A sky_sphere block (the parser after the keyword at loc) into a new sky (`#declare`). */
typedef struct pov_sky pov_sky;
vbnl_result pov_sky_parse(pov_loader *L, const vbnl_sdl_loc *loc, pov_sky **out);
void pov_sky_free(pov_sky *s);
extern const vbnl_sdl_opaque_type pov_sky_type;
/* The environment onto the core scene: the sky_sphere over the background, or the background. */
vbnl_result pov_environment_build(pov_loader *L, vbnl_error *err);
/* fog { } (fog.c); the parser is after the keyword at loc. Errors name loc for a fog_type other
 * than 1 or 2, a distance or fog_alt that is not positive, a zero up vector. */
vbnl_result pov_fog_parse(pov_loader *L, const vbnl_sdl_loc *loc);
/* Adds the fogs read and the atmospheric media (top-level media { }: the core's atmosphere) to the
 * core scene. */
vbnl_result pov_fogs_build(pov_loader *L, vbnl_error *err);

/* ---- building (build.c) ------------------------------------------------------------------------ */

/* Frees the shapes kept for sharing (shapes/shape_cache.c); before the parser is destroyed. */
void pov_shape_cache_free(pov_loader *L);
/* Adds the world's primitives, the camera and the environment to the core scene. */
vbnl_result pov_build(pov_loader *L, vbnl_error *err);

#endif
