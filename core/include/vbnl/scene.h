/* vbnl: scene-building API.
 *
 * A vbnl_scene collects geometry (triangle meshes, analytic spheres, instances of groups),
 * materials, lights and a camera, then is committed once: commit builds the Embree BVH and the
 * light-selection tables. After commit the scene is immutable and may be shared by any number of
 * renderers and threads. Before commit, a scene must only be used from one thread at a time.
 *
 * Ownership: every array passed in is copied; the caller may free it as soon as the call returns.
 * Ids returned through out-parameters are dense small integers, stable for the scene's life.
 *
 * Descriptors (vbnl_*_desc) start with their own size: fill one with its init function, which sets
 * `size` and the defaults, then change the fields you need. The core refuses a descriptor whose
 * size is not one it knows (VBNL_ERR_INVALID_ARGUMENT, or VBNL_ERR_UNSUPPORTED for one from a
 * newer vbnl), and new fields only ever come at the end, with defaults for older callers.
 *
 * Errors: every function that returns a vbnl_result writes one sentence into `err` (may be NULL)
 * when it fails, and then changes nothing (the scene is as before the call, out-parameters are
 * not written). VBNL_ERR_INVALID_ARGUMENT for a NULL scene or descriptor and the bad values each
 * function names; VBNL_ERR_STATE for an add or set after vbnl_scene_commit;
 * VBNL_ERR_OUT_OF_MEMORY.
 *
 * Units and conventions: right-handed world space (the scene parser converts POV-Ray's
 * left-handed one); colours are linear Rec.709 RGB; radiance in W/(m^2 sr), intensity in W/sr;
 * transforms are row-major 4x4 affine matrices applied as p' = M p. */
#ifndef VBNL_SCENE_H
#define VBNL_SCENE_H

#include <stdint.h>

#include "vbnl/result.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vbnl_context vbnl_context;
typedef struct vbnl_scene vbnl_scene;

/* ---- materials ---------------------------------------------------------------------------- */

typedef enum vbnl_material_type {
    VBNL_MATERIAL_LAMBERT = 0,    /* diffuse: albedo = base_color */
    VBNL_MATERIAL_CONDUCTOR = 1,  /* GGX metal: F0 = base_color, or complex IOR eta + i k */
    VBNL_MATERIAL_PLASTIC = 2,    /* Lambertian base (base_color) under a GGX dielectric coat (ior) */
    VBNL_MATERIAL_MIRROR = 3,     /* perfect specular reflection tinted by base_color */
    VBNL_MATERIAL_DIELECTRIC = 4, /* smooth glass: Fresnel reflection + refraction, tint base_color */
} vbnl_material_type;

typedef struct vbnl_material_desc {
    uint32_t size;        /* sizeof(vbnl_material_desc): set by vbnl_material_desc_init */
    vbnl_material_type type;
    float base_color[3];  /* see the type; each component in [0, 1] */
    float alpha;          /* GGX roughness alpha (not squared "perceptual" roughness), [1e-3, 1] */
    float ior;            /* dielectric and plastic-coat index of refraction, > 1 */
    int conductor_use_ior;/* conductor: 1 = use eta/k, 0 = use base_color as F0 (Schlick) */
    float eta[3], k[3];   /* conductor complex index of refraction per RGB channel */
    float emission[3];    /* emitted radiance Le; any non-zero value makes the surface a light */
    int two_sided;        /* emission on both sides (default: front side = geometric normal side) */
    uint32_t base_texture;/* 0 = none; else (texture id + 1) from vbnl_scene_add_texture: the colour
                           * used at a hit is base_color * texture colour there (component-wise;
                           * set base_color to 1 to let the texture replace it). Emission is not
                           * textured. */
} vbnl_material_desc;

/* Fills `d` with its size and the defaults: Lambertian, base colour 0.8, alpha 0.1, ior 1.5, no
 * emission, no texture. */
void vbnl_material_desc_init(vbnl_material_desc *d);

/* ---- textures ----------------------------------------------------------------------------- */

/* A colour varying over surfaces, looked up at every hit of a material that names it
 * (vbnl_material_desc.base_texture). Every texture first maps the world-space hit point p into
 * texture space: q = pattern_from_world * p.
 *
 *   IMAGE     RGB float texels, row 0 at the top (v = 1). The lookup coordinate (u, v) is the
 *             hit's mesh UV (projection UV) or a projection of q, POV-Ray's image_map ones:
 *             PLANAR (u, v) = (q.x, q.y); SPHERICAL u = longitude around +y measured from +x
 *             towards +z (atan2(q.z, q.x) / 2 pi, in [0, 1)), v = latitude (0 at -y, 1 at +y);
 *             CYLINDRICAL u as spherical, v = q.y.
 *             Texel centres sit at ((i + 0.5) / width, 1 - (j + 0.5) / height); bilinear
 *             (interpolate = 1) or nearest; wrap REPEAT (fractional part) or CLAMP.
 *   CHECKER   value floor(q.x + e) + floor(q.y + e) + floor(q.z + e) mod 2 (0 or 1): unit
 *             cubes (POV-Ray's; e = 1e-4, so surfaces lying on integer planes, hit at single
 *             precision, stay in one cell).
 *   GRADIENT  value = dot(q, normalize(gradient)) (POV-Ray normalises the vector too), then
 *             frequency/phase/wave (below).
 *   BRICK     POV-Ray's brick: bricks of brick_size (x width w, y height h, z depth d) in
 *             courses along y. With p = q + mortar (+1e-10): mortar (value 0) where
 *             frac(p.y / h) <= mortar / h, or frac(p.x / w + s) <= mortar / w, or
 *             frac(p.z / d + 0.5 - s) <= mortar / d, where s = 0.5 on odd courses
 *             (frac(p.y / 2h) > 0.5) and 0 on even ones; 1 in a brick.
 *
 * Pattern values become colours through the colour map: entries sorted by value, linear
 * interpolation between neighbours, the first / last colour outside their range. CHECKER and
 * BRICK are block patterns (values exactly 0 or 1: give entries at 0 and 1). For GRADIENT the
 * raw value v is turned into v' = frac(v * frequency + phase) (POV-Ray: fmod by 1.00001, then
 * the same for negatives) then shaped by the wave: RAMP v',
 * TRIANGLE 1 - |2 v' - 1|, SINE (1 + sin(2 pi v')) / 2, SCALLOP
 * |sin(pi v')|. */
typedef enum vbnl_texture_kind {
    VBNL_TEXTURE_IMAGE = 0,
    VBNL_TEXTURE_CHECKER = 1,
    VBNL_TEXTURE_GRADIENT = 2,
    VBNL_TEXTURE_BRICK = 3,
} vbnl_texture_kind;

typedef enum vbnl_texture_projection {
    VBNL_PROJECTION_UV = 0,
    VBNL_PROJECTION_PLANAR = 1,
    VBNL_PROJECTION_SPHERICAL = 2,
    VBNL_PROJECTION_CYLINDRICAL = 3,
} vbnl_texture_projection;

typedef enum vbnl_texture_wrap { VBNL_WRAP_REPEAT = 0, VBNL_WRAP_CLAMP = 1 } vbnl_texture_wrap;

typedef enum vbnl_texture_wave {
    VBNL_WAVE_RAMP = 0,
    VBNL_WAVE_TRIANGLE = 1,
    VBNL_WAVE_SINE = 2,
    VBNL_WAVE_SCALLOP = 3,
} vbnl_texture_wave;

typedef struct vbnl_color_map_entry {
    float value;
    float color[3];
} vbnl_color_map_entry;

#define VBNL_COLOR_MAP_MAX 256u

typedef struct vbnl_texture_desc {
    uint32_t size;                    /* sizeof(vbnl_texture_desc): set by vbnl_texture_desc_init */
    vbnl_texture_kind kind;
    float pattern_from_world[16];     /* row-major 4x4 affine, p' = M p; identity by default */
    /* IMAGE */
    const float *texels;              /* width * height * 3 floats, each finite and >= 0 */
    uint32_t width, height;
    vbnl_texture_projection projection;
    vbnl_texture_wrap wrap;
    int interpolate;                  /* 1 = bilinear (default), 0 = nearest texel */
    /* patterns */
    float gradient[3];                /* GRADIENT axis (non-zero), default +x */
    float brick_size[3];              /* BRICK, default POV-Ray's <8, 3, 4.5> */
    float mortar;                     /* BRICK, default 0.5 */
    const vbnl_color_map_entry *color_map; /* 1..VBNL_COLOR_MAP_MAX entries, sorted by value */
    uint32_t color_map_count;
    float frequency, phase;           /* GRADIENT: default 1 and 0 */
    vbnl_texture_wave wave;
} vbnl_texture_desc;

/* Fills `d` with its size and the defaults above (a CHECKER with no colour map: set one). */
void vbnl_texture_desc_init(vbnl_texture_desc *d);

/* Adds a texture (arrays copied). Errors: VBNL_ERR_INVALID_ARGUMENT for a missing or unsorted
 * colour map, empty or non-finite texels, a singular or non-finite matrix, a zero gradient,
 * non-positive brick sizes or negative mortar. A material refers to it as id + 1. */
vbnl_result vbnl_scene_add_texture(vbnl_scene *scene, const vbnl_texture_desc *desc,
                                   uint32_t *out_id, vbnl_error *err);

/* ---- geometry ----------------------------------------------------------------------------- */

/* Group 0 is the world. Geometry added to another group is only visible through instances. */
#define VBNL_GROUP_WORLD 0u

typedef struct vbnl_mesh_desc {
    uint32_t size;                 /* sizeof(vbnl_mesh_desc): set by vbnl_mesh_desc_init */
    const float *positions;        /* 3 floats per vertex (required) */
    const float *normals;          /* 3 floats per vertex, or NULL: flat shading */
    const float *uvs;              /* 2 floats per vertex, or NULL */
    uint32_t vertex_count;
    const uint32_t *indices;       /* 3 per triangle (required) */
    uint32_t triangle_count;
    uint32_t material;             /* material of every triangle ... */
    const uint32_t *face_materials;/* ... unless this per-triangle array is given */
    const float *transform;        /* optional 4x4 applied to positions and normals when added */
    uint32_t group;                /* VBNL_GROUP_WORLD or an id from vbnl_scene_add_group */
} vbnl_mesh_desc;

/* Fills `d` with its size and no mesh (NULL arrays, zero counts, material 0, the world group). */
void vbnl_mesh_desc_init(vbnl_mesh_desc *d);

/* Adds a triangle mesh (arrays copied). Errors: VBNL_ERR_INVALID_ARGUMENT for a NULL array, an
 * index out of range, a non-finite position, an unknown material or group, a bad transform (as
 * for instances); VBNL_ERR_UNSUPPORTED for an emissive material outside the world group. */
vbnl_result vbnl_scene_add_mesh(vbnl_scene *scene, const vbnl_mesh_desc *desc, uint32_t *out_id,
                                vbnl_error *err);

/* Adds an analytic sphere (exact intersection, exact normals). Emissive spheres become area
 * lights sampled uniformly over their surface. `group` as for meshes. Errors:
 * VBNL_ERR_INVALID_ARGUMENT for a non-finite centre, a radius that is not positive and finite,
 * an unknown material or group; VBNL_ERR_UNSUPPORTED for an emissive material outside the world
 * group. */
vbnl_result vbnl_scene_add_sphere(vbnl_scene *scene, const float center[3], float radius,
                                  uint32_t material, uint32_t group, uint32_t *out_id,
                                  vbnl_error *err);

/* Creates an empty group whose content can be instanced any number of times; its id goes to
 * *out_group. Errors: the common ones (above). */
vbnl_result vbnl_scene_add_group(vbnl_scene *scene, uint32_t *out_group, vbnl_error *err);

/* Places group `group` in the world with the 4x4 transform (copied). Errors:
 * VBNL_ERR_INVALID_ARGUMENT for an unknown group, the world group, a NULL transform, one with a
 * non-finite entry, one that is not affine (last row 0 0 0 1) or not invertible. */
vbnl_result vbnl_scene_add_instance(vbnl_scene *scene, uint32_t group, const float transform[16],
                                    uint32_t *out_id, vbnl_error *err);

/* Adds a material (the descriptor is copied). Errors: VBNL_ERR_INVALID_ARGUMENT for an unknown
 * type, colours outside [0, 1], negative or non-finite emission, alpha outside [0, 1], an ior
 * outside (1, 10), conductor eta <= 0 or k < 0, a texture that does not exist (yet). */
vbnl_result vbnl_scene_add_material(vbnl_scene *scene, const vbnl_material_desc *desc,
                                    uint32_t *out_id, vbnl_error *err);

/* ---- lights ------------------------------------------------------------------------------- */

/* Point light with radiant intensity I (W/sr); irradiance falls off as 1/r^2. Errors:
 * VBNL_ERR_INVALID_ARGUMENT for a non-finite position or a negative or non-finite intensity. */
vbnl_result vbnl_scene_add_point_light(vbnl_scene *scene, const float position[3],
                                       const float intensity[3], uint32_t *out_id, vbnl_error *err);

typedef struct vbnl_spot_light_desc {
    uint32_t size;            /* sizeof(vbnl_spot_light_desc): set by vbnl_spot_light_desc_init */
    float position[3];
    float direction[3];       /* need not be normalised */
    float intensity[3];       /* on the axis, W/sr */
    float cos_inner;          /* full intensity inside this cone (cosine of the half-angle) */
    float cos_outer;          /* zero outside; smoothstep falloff between (pbrt's spot light) */
    float exponent;           /* extra cos(theta)^exponent concentration (POV-Ray tightness); 0 = none */
} vbnl_spot_light_desc;
/* Fills `d` with its size and zeros (every field to be set). */
void vbnl_spot_light_desc_init(vbnl_spot_light_desc *d);
/* Adds a spot light. Errors: VBNL_ERR_INVALID_ARGUMENT for non-finite values, a zero direction,
 * negative intensity, cone cosines not in -1 <= cos_outer <= cos_inner <= 1 with cos_outer < 1,
 * a negative exponent. */
vbnl_result vbnl_scene_add_spot_light(vbnl_scene *scene, const vbnl_spot_light_desc *desc,
                                      uint32_t *out_id, vbnl_error *err);

/* Rectangular area light: the parallelogram corner + s*edge_u + t*edge_v, s,t in [0,1], emitting
 * radiance Le from the side of cross(edge_u, edge_v) (or both sides). It is also geometry: rays hit
 * it and see its radiance. */
typedef struct vbnl_area_light_desc {
    uint32_t size;            /* sizeof(vbnl_area_light_desc): set by vbnl_area_light_desc_init */
    float corner[3], edge_u[3], edge_v[3];
    float radiance[3];
    int two_sided;
} vbnl_area_light_desc;
/* Fills `d` with its size and zeros (every field to be set; one-sided). */
void vbnl_area_light_desc_init(vbnl_area_light_desc *d);
/* Adds the light and its quad (in the world group). Errors: VBNL_ERR_INVALID_ARGUMENT for
 * non-finite values, parallel or zero edges, negative radiance. */
vbnl_result vbnl_scene_add_area_light(vbnl_scene *scene, const vbnl_area_light_desc *desc,
                                      uint32_t *out_id, vbnl_error *err);

/* Distant light arriving from the direction opposite to `direction` with irradiance E (W/m^2)
 * on a surface facing it. Errors: VBNL_ERR_INVALID_ARGUMENT for a zero or non-finite direction,
 * a negative or non-finite irradiance. */
vbnl_result vbnl_scene_add_directional_light(vbnl_scene *scene, const float direction[3],
                                             const float irradiance[3], uint32_t *out_id,
                                             vbnl_error *err);

/* Constant environment radiance seen by every ray that leaves the scene (0 = black); a later
 * call replaces it. Errors: VBNL_ERR_INVALID_ARGUMENT for a negative or non-finite radiance. */
vbnl_result vbnl_scene_set_environment(vbnl_scene *scene, const float radiance[3], vbnl_error *err);

/* ---- camera ------------------------------------------------------------------------------- */

/* Pinhole camera in POV-Ray's general form: the primary ray through the normalised image point
 * (sx, sy), sx in [-0.5, 0.5] from the left to the right edge and sy in [-0.5, 0.5] from the
 * bottom to the top edge, has direction forward + sx*right + sy*up (then normalised). The lengths
 * of right and up set the field of view and the aspect ratio; mirrored cameras are allowed. */
typedef struct vbnl_camera_desc {
    uint32_t size;            /* sizeof(vbnl_camera_desc): set by vbnl_camera_desc_init and look_at */
    float position[3];
    float forward[3];
    float right[3];
    float up[3];
} vbnl_camera_desc;

/* Fills `d` with its size and zeros (every vector to be set), for cameras in the general form;
 * vbnl_camera_look_at fills a whole one. */
void vbnl_camera_desc_init(vbnl_camera_desc *d);

/* Convenience: fills *out (size included) with a camera at `position` looking at `target` with
 * `up` roughly up, vertical field of view `fov_y_degrees` in (0, 180) and image aspect
 * width/height `aspect` > 0. Errors: VBNL_ERR_INVALID_ARGUMENT for non-finite values, a target at
 * the position, `up` along the view, a field of view or aspect out of range; *out is not
 * written. Pure: any thread. */
vbnl_result vbnl_camera_look_at(vbnl_camera_desc *out, const float position[3],
                                const float target[3], const float up[3], float fov_y_degrees,
                                float aspect, vbnl_error *err);

/* Sets the camera (copied; a later call replaces it). Errors: VBNL_ERR_INVALID_ARGUMENT for
 * non-finite vectors or forward, right and up vectors that are not linearly independent. */
vbnl_result vbnl_scene_set_camera(vbnl_scene *scene, const vbnl_camera_desc *camera, vbnl_error *err);

/* ---- life cycle --------------------------------------------------------------------------- */

/* Creates an empty scene on `ctx` (which must outlive it) into *out. Errors:
 * VBNL_ERR_INVALID_ARGUMENT (NULL ctx or out), VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_scene_create(vbnl_context *ctx, vbnl_scene **out, vbnl_error *err);
/* Builds the BVH and light tables; afterwards the scene is immutable and may be read by any
 * number of threads and renderers. Errors: VBNL_ERR_INVALID_ARGUMENT for a scene without a camera
 * or without any light, VBNL_ERR_STATE when already committed, VBNL_ERR_BACKEND (Embree),
 * VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_scene_commit(vbnl_scene *scene, vbnl_error *err);
/* Frees the scene (accepts NULL). No renderer of it may remain. */
void vbnl_scene_destroy(vbnl_scene *scene);

typedef struct vbnl_scene_info {
    uint64_t triangle_count;   /* world triangles plus instanced ones counted once per instance */
    uint32_t sphere_count;
    uint32_t instance_count;
    uint32_t material_count;
    uint32_t light_count;      /* after commit: each emissive triangle counts as one light */
    float bounds_min[3], bounds_max[3];
} vbnl_scene_info;
/* The scene's counts and bounds (light_count and bounds after commit). Errors:
 * VBNL_ERR_INVALID_ARGUMENT for NULL arguments. Any thread once committed. */
vbnl_result vbnl_scene_get_info(const vbnl_scene *scene, vbnl_scene_info *out, vbnl_error *err);

#ifdef __cplusplus
}
#endif
#endif
