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
 * Units and conventions: world space of either handedness (no formula of the core depends on it;
 * cameras, where it would matter, take explicit right and up vectors, so the scene parser keeps
 * POV-Ray's left-handed coordinates unchanged); colours are linear Rec.709 RGB; radiance in W/(m^2 sr), intensity in W/sr;
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
    VBNL_MATERIAL_DIELECTRIC = 4, /* smooth glass: Fresnel reflection + refraction, tint base_color;
                                   * ior 1 lets light through unchanged */
    VBNL_MATERIAL_BRILLIANCE = 5, /* diffuse with POV-Ray's brilliance b >= 1: f = albedo (b + 1) /
                                   * (2 pi) (cos_i cos_o)^(b - 1), reciprocal and energy-conserving
                                   * (albedo base_color cos_o^(b - 1)); b = 1 is Lambertian */
} vbnl_material_type;

typedef struct vbnl_material_desc {
    uint32_t size;        /* sizeof(vbnl_material_desc): set by vbnl_material_desc_init */
    vbnl_material_type type;
    float base_color[3];  /* see the type; each component in [0, 1] */
    float alpha;          /* GGX roughness alpha (not squared "perceptual" roughness), [1e-3, 1] */
    float ior;            /* dielectric (>= 1) and plastic-coat (> 1) index of refraction */
    int conductor_use_ior;/* conductor: 1 = use eta/k, 0 = use base_color as F0 (Schlick) */
    float eta[3], k[3];   /* conductor complex index of refraction per RGB channel */
    float emission[3];    /* emitted radiance Le; any non-zero value makes the surface a light */
    int two_sided;        /* emission on both sides (default: front side = geometric normal side) */
    uint32_t base_texture;/* 0 = none; else (pigment id + 1) from vbnl_scene_add_texture or
                           * vbnl_scene_add_pigment: the colour used at a hit is base_color * the
                           * pigment's (r, g, b) there (component-wise; set base_color to 1 to let
                           * the pigment replace it; its filter and transmit are not used here:
                           * see VBNL_NODE_TEXTURED). Emission is not textured. */
    uint32_t interior;    /* what a ray that crosses the surface inward (against the geometric
                           * normal, through a transmitting BSDF) travels in: VBNL_INTERIOR_SAME
                           * (0, the medium outside continues), VBNL_INTERIOR_CLEAR (nothing), or
                           * a medium id + 1 (vbnl_scene_add_medium); crossing outward returns to
                           * what the ray was in before */
    float brilliance;     /* VBNL_MATERIAL_BRILLIANCE: the exponent b, >= 1 */
    /* VBNL_MATERIAL_PLASTIC: the coat's reflectance curve (POV-Ray's variable reflection,
     * docs/scene-language.md "Reflection"). VBNL_COAT_DIELECTRIC (the default) is the Fresnel
     * term of `ior` with the base coupled to the coat (albedo E_s + base_color (1 - E_s)); the
     * other curves give per RGB channel, at the cosine c between the view and the (micro)facet
     * normal, F(c) = T(c) (coat_min + (coat_max - coat_min) w(c)) with
     *   VBNL_COAT_SCHLICK:  w(c) = (1 - c)^coat_falloff (generalised Schlick; falloff 5 is Schlick's)
     *   VBNL_COAT_FRESNEL:  w(c) = the dielectric Fresnel reflectance of `ior` at c
     * and T(c) = 1 + coat_metallic (1 - M(c)) (base_color - 1) the surface-colour tint of POV-Ray's
     * `metallic` (M: POV-Ray's empirical Fresnel-like curve, 0 head-on, 1 at grazing). Under
     * such a coat (smooth for alpha 1e-3, GGX otherwise) the Lambertian base k = base_scale
     * base_color is either added (coat_conserve 0, POV-Ray's diffuse + reflection: f_base = k / pi
     * g(mu_o) g(mu_i), g(mu) = min(1, (1 - F(mu)) / k), so k / pi wherever k + F <= 1 and less
     * only at the angles where the sum would reflect more than the surface receives) or weighted
     * by what the coat lets through both ways (coat_conserve 1: f_base = k / pi (1 - F(mu_o))
     * (1 - F(mu_i)) / (1 - F_avg), F_avg = 2 int F mu dmu, albedo k (1 - F(mu_o))). */
    int coat_curve;       /* vbnl_coat_curve */
    float coat_min[3];    /* the reflectance where w = 0 (head-on for SCHLICK), each in [0, 1] */
    float coat_max[3];    /* the reflectance where w = 1 (at grazing), each in [0, 1] */
    float coat_falloff;   /* SCHLICK: the exponent p, in (0, 1000] */
    float coat_metallic;  /* [0, 1] */
    int coat_conserve;    /* 0: base added to the coat; 1: base weighted by (1 - F) */
    float base_scale;     /* the base's weight (POV-Ray's diffuse) for the SCHLICK and FRESNEL curves, [0, 1] */
} vbnl_material_desc;

/* The reflectance curves of a plastic's coat (vbnl_material_desc.coat_curve). */
typedef enum vbnl_coat_curve {
    VBNL_COAT_DIELECTRIC = 0,
    VBNL_COAT_SCHLICK = 1,
    VBNL_COAT_FRESNEL = 2,
} vbnl_coat_curve;

#define VBNL_INTERIOR_SAME 0u
#define VBNL_INTERIOR_CLEAR UINT32_MAX

/* Fills `d` with its size and the defaults: Lambertian, base colour 0.8, alpha 0.1, ior 1.5, no
 * emission, no texture, interior VBNL_INTERIOR_SAME, brilliance 1, a dielectric coat (coat_min 0,
 * coat_max 1, falloff 1, metallic 0, not conserving, base_scale 1). */
void vbnl_material_desc_init(vbnl_material_desc *d);

/* ---- textures: patterns, pigments, normals and materials that vary over surfaces ---------- */

/* Surfaces that vary from point to point are built from small immutable nodes, each added once
 * and referred to by id (id + 1 where 0 means "none"); a node may only refer to nodes added before
 * it, so the nodes form a DAG, at most VBNL_TEXTURE_DEPTH_MAX deep. They follow POV-Ray 3.7's
 * texture model (its reference manual, "Patterns", "Pattern Modifiers", "Warps", "Pigment",
 * "Normal", "Texture" sections) and compute POV-Ray's values:
 *
 *   image     texels (vbnl_scene_add_image), looked up by IMAGE patterns
 *   pattern   a number at each point: one of POV-Ray's patterns, after its warps, turbulence,
 *             frequency, phase and wave shape (vbnl_scene_add_pattern)
 *   pigment   a colour (r, g, b, filter, transmit) at each point: solid, a pattern through a map
 *             of colours or other pigments, an image, or an average (vbnl_scene_add_pigment)
 *   normal    a perturbation of the shading normal: a pattern's slope, one of POV-Ray's normal
 *             patterns (bumps, dents, ripples, waves, wrinkles, quilted, facets), a bump map, a
 *             normal map or an average (vbnl_scene_add_normal)
 *   material  node: a material whose BSDF is chosen per point (vbnl_scene_add_material_node):
 *             a material with a pigment, a normal and a transmission part, a pattern through a
 *             map of materials (POV-Ray's texture_map, material_map, tiles), layers, an average.
 *
 * Points: a node a material uses directly receives the world-space hit point (or (u, v, 0) with
 * `uv`); a node inside a map receives its parent's point after the parent's own transform and
 * warps (POV-Ray evaluates map entries in the pattern's warped space). A node maps the point it
 * receives by its `transform`, then its warps in order, before its pattern. Evaluation is
 * deterministic, allocation-free and safe from any number of threads once the scene is committed.
 *
 * Blending whole materials: at each hit one material of the blend is chosen with probability
 * equal to its weight there (colour-valued weights, from filter and layers: probability
 * proportional to the weight's largest channel, the rest kept as a colour factor), by a hash of
 * the hit, the same choice for every integrator and every ray reaching that point. The expected
 * BSDF is POV-Ray's blend, and each path vertex uses one material's BSDF with that BSDF's own
 * pdfs, so next-event estimation, BSDF sampling and their MIS weights stay consistent. */

#define VBNL_TEXTURE_DEPTH_MAX 64u /* nodes nested in maps, layers and pattern pigments */
#define VBNL_TEXTURE_MAP_MAX 256u  /* entries of one map */
#define VBNL_TEXTURE_WARP_MAX 64u  /* warps of one pattern */
#define VBNL_NOISE_WAVES_MAX 1024  /* centres of ripples and waves (POV-Ray's number_of_waves) */

/* ---- images ---- */

typedef struct vbnl_image_desc {
    uint32_t size;           /* sizeof(vbnl_image_desc) (vbnl_image_desc_init) */
    uint32_t width, height;  /* 1 .. 65536 each */
    uint32_t channels;       /* 1 (grey), 2 (grey, alpha), 3 (RGB) or 4 (RGBA) */
    const float *texels;     /* width * height * channels floats, row 0 at the top, linear values;
                              * alpha is opacity (POV-Ray: transmit = 1 - alpha) */
    const uint8_t *indices;  /* palette images: the palette index of each texel (bump_map and
                              * material_map use it, as POV-Ray does); NULL otherwise */
} vbnl_image_desc;

void vbnl_image_desc_init(vbnl_image_desc *d);
/* Adds an image (arrays copied). Errors: VBNL_ERR_INVALID_ARGUMENT for a wrong size field, an
 * empty or oversized image, an unknown channel count or non-finite texels. */
vbnl_result vbnl_scene_add_image(vbnl_scene *scene, const vbnl_image_desc *desc, uint32_t *out_id,
                                 vbnl_error *err);

/* ---- patterns ---- */

/* The patterns of POV-Ray 3.7 (reference manual, "Patterns"; pavement and the Penrose tilings are
 * not implemented). Pattern and warp parameters have
 * POV-Ray's own precision (double, or float where POV-Ray keeps a float: frequency, phase,
 * exponent, agate_turb, mortar, quilted controls, turbulence omega and lambda, repeat width):
 * patterns whose raw values are large (fractal exteriors, gradients far from the origin) wrap
 * them into [0, 1), where another precision would show. Values are POV-Ray's: mostly in
 * [0, 1]; block patterns give block indices (checker 0/1, brick 0 mortar / 1 brick, hexagon 0..2,
 * square 0..3, triangular and cubic 0..5, object 0 outside / 1 inside). */
typedef enum vbnl_pattern_kind {
    VBNL_PATTERN_AGATE = 0,
    VBNL_PATTERN_AOI,          /* angle between the normal and the direction from the camera: acos / pi */
    VBNL_PATTERN_BOXED,
    VBNL_PATTERN_BOZO,         /* noise */
    VBNL_PATTERN_BRICK,
    VBNL_PATTERN_BUMPS,        /* noise (as a normal: the noise gradient) */
    VBNL_PATTERN_CELLS,
    VBNL_PATTERN_CHECKER,
    VBNL_PATTERN_CRACKLE,
    VBNL_PATTERN_CUBIC,
    VBNL_PATTERN_CYLINDRICAL,
    VBNL_PATTERN_DENSITY,      /* density_file: a voxel grid over the unit cube */
    VBNL_PATTERN_DENTS,
    VBNL_PATTERN_FACETS,       /* normals only */
    VBNL_PATTERN_FUNCTION,     /* a callback (function { }); values above 1 wrap (fmod 1) */
    VBNL_PATTERN_GRADIENT,
    VBNL_PATTERN_GRANITE,
    VBNL_PATTERN_HEXAGON,
    VBNL_PATTERN_IMAGE,        /* image_map, bump_map, image_pattern, material_map lookups */
    VBNL_PATTERN_JULIA,
    VBNL_PATTERN_LEOPARD,
    VBNL_PATTERN_MAGNET,
    VBNL_PATTERN_MANDEL,
    VBNL_PATTERN_MARBLE,
    VBNL_PATTERN_OBJECT,       /* a callback returning 1 inside, 0 outside */
    VBNL_PATTERN_ONION,
    VBNL_PATTERN_PAVEMENT,     /* not implemented: refused */
    VBNL_PATTERN_PIGMENT,      /* pigment_pattern: the greyscale of a pigment */
    VBNL_PATTERN_PLANAR,
    VBNL_PATTERN_QUILTED,
    VBNL_PATTERN_RADIAL,
    VBNL_PATTERN_RIPPLES,
    VBNL_PATTERN_SLOPE,
    VBNL_PATTERN_SPHERICAL,
    VBNL_PATTERN_SPIRAL1,
    VBNL_PATTERN_SPIRAL2,
    VBNL_PATTERN_SPOTTED,      /* noise */
    VBNL_PATTERN_SQUARE,
    VBNL_PATTERN_TILING,
    VBNL_PATTERN_TRIANGULAR,
    VBNL_PATTERN_WAVES,
    VBNL_PATTERN_WOOD,
    VBNL_PATTERN_WRINKLES,
    VBNL_PATTERN_KIND_COUNT
} vbnl_pattern_kind;

/* POV-Ray's turbulence (`turbulence <v> octaves n omega w lambda l`): amount per axis, octaves
 * 1..10 (default 6), omega (0.5) and lambda (2). */
typedef struct vbnl_turbulence_desc {
    double amount[3];
    int octaves;
    float omega, lambda;
} vbnl_turbulence_desc;

/* Warps (reference manual, "Warps"), applied to the point in order. */
typedef enum vbnl_warp_kind {
    VBNL_WARP_TRANSFORM = 0,   /* p' = matrix p: the inverse of POV-Ray's translate/rotate/scale */
    VBNL_WARP_TURBULENCE,      /* p' = p + amount * vector turbulence(p) */
    VBNL_WARP_REPEAT,
    VBNL_WARP_BLACK_HOLE,
    VBNL_WARP_SPHERICAL,
    VBNL_WARP_CYLINDRICAL,
    VBNL_WARP_TOROIDAL,
    VBNL_WARP_PLANAR,
    VBNL_WARP_CUBIC,
} vbnl_warp_kind;

typedef struct vbnl_warp_desc {
    uint32_t size;                    /* sizeof(vbnl_warp_desc) (vbnl_warp_desc_init) */
    vbnl_warp_kind kind;
    double matrix[16];               /* TRANSFORM: row-major affine, p' = M p */
    vbnl_turbulence_desc turbulence;  /* TURBULENCE */
    struct {                          /* REPEAT: along one axis, every `width` */
        int axis;                     /* 0 x, 1 y, 2 z */
        float width;                  /* != 0 */
        double offset[3];             /* added per repetition */
        int flip[3];                  /* mirror odd repetitions along each axis */
    } repeat;
    struct {                          /* BLACK_HOLE: pulls points within radius towards center */
        double center[3];
        double radius, strength, falloff; /* radius > 0; strength 1, falloff 2 by default */
        int inverse;                  /* push instead */
        double repeat[3];             /* a grid of holes (0: none on that axis) */
        double turbulence[3];         /* random offset of each repeated hole */
    } black_hole;
    struct {                          /* SPHERICAL, CYLINDRICAL, TOROIDAL, PLANAR mappings */
        double orientation[3];        /* unit; default <0, 0, 1> */
        double dist_exp;              /* 0 */
        double major_radius;          /* TOROIDAL: 1 */
        double offset;                /* PLANAR: 0 */
    } mapping;
} vbnl_warp_desc;

void vbnl_warp_desc_init(vbnl_warp_desc *d);

/* Wave shapes; POV-Ray's Evaluate_TPat order: v' = fmod(v * frequency + phase, 1.00001) (skipped
 * when frequency is 0), wrapped into [0, 1) when negative, then the wave. */
typedef enum vbnl_texture_wave {
    VBNL_WAVE_RAMP = 0,        /* v */
    VBNL_WAVE_TRIANGLE = 1,    /* 2v below 1/2, 2(1 - v) above */
    VBNL_WAVE_SINE = 2,        /* (1 + sin(2 pi v)) / 2 */
    VBNL_WAVE_SCALLOP = 3,     /* |sin(pi v)| */
    VBNL_WAVE_CUBIC = 4,       /* 3 v^2 - 2 v^3 */
    VBNL_WAVE_POLY = 5,        /* v^exponent */
} vbnl_texture_wave;

/* Callback of FUNCTION and OBJECT patterns: must be thread-safe and deterministic; `p` is the
 * point in the pattern's space. */
typedef double (*vbnl_pattern_fn)(void *user, const double p[3]);

typedef struct vbnl_pattern_desc {
    uint32_t size;                     /* sizeof(vbnl_pattern_desc) (vbnl_pattern_desc_init) */
    vbnl_pattern_kind kind;
    double transform[16];              /* row-major affine applied first; identity by default */
    const vbnl_warp_desc *warps;       /* applied after `transform`, in order (0..64) */
    uint32_t warp_count;
    vbnl_turbulence_desc turbulence;   /* POV-Ray's classic turbulence (amount 0 = none): applied
                                        * after the warps, except that agate, marble, wood and
                                        * spiral1/2 feed it into their own formula */
    int noise_generator;               /* 1, 2 (POV-Ray's default) or 3 */
    vbnl_texture_wave wave;
    float frequency, phase;            /* 1 and 0; POV-Ray's parser gives block patterns 0 */
    float exponent;                    /* POLY wave: 1 */
    struct { double direction[3]; } gradient;              /* normalised by the core */
    struct { double size[3]; float mortar; } brick;        /* <8, 3, 4.5>, 0.5 */
    float agate_turb;                                      /* 1 */
    struct { float control0, control1; } quilted;          /* 1, 1 */
    int spiral_arms;                                       /* SPIRAL1/2 */
    struct { double form[3], metric, offset; int solid; } crackle; /* <-1, 1, 0>, 2, 0, 0 */
    struct {
        int iterations;                /* >= 1 */
        int exponent;                  /* MANDEL, JULIA: 2..33 */
        int magnet;                    /* MAGNET: formula 1 or 2 */
        int julia;                     /* MAGNET: 1 = julia form (uses coord), 0 = mandel */
        double coord[2];               /* JULIA, MAGNET julia: the constant */
        int interior, exterior;        /* colouring types 0..6 and 0..8; defaults 0 and 1 */
        double interior_factor, exterior_factor; /* 1 */
    } fractal;
    struct { double size, coords, metric; } facets;        /* 0.1, 0, 2 */
    int tiling;                                            /* TILING: 1..24 (not the Penrose 25..27) */
    struct { int sides, tiles, pattern, form, interior, exterior; } pavement; /* 3, 1, 1, 0, 0, 0; kept for a
                                                                              * later PAVEMENT */
    struct {
        double direction[3];           /* or the point with point_at */
        double low, high;              /* slope range (0, 0: whole) */
        double altitude[3];            /* 0: no altitude term */
        double alt_low, alt_high;
        int point_at;
    } slope;
    struct {
        uint32_t nx, ny, nz;           /* >= 1 */
        const float *values;           /* nx * ny * nz in [0, 1], x fastest */
        int interpolate;               /* 0 none, 1 trilinear, 2 tricubic */
    } density;
    struct {
        uint32_t image;                /* image id + 1 */
        int map_type;                  /* 0 planar, 1 spherical, 2 cylindrical, 5 torus */
        int once;                      /* no repetition: outside is clear */
        int interpolate;               /* 0 none, 2 bilinear, 3 bicubic, 4 normalised distance */
        int use;                       /* the IMAGE value, POV-Ray's image_pattern: 0 the palette
                                        * index / 255 (palette images) or else the greyscale;
                                        * 1 and 2 the greyscale; 3 alpha as transmit (red without
                                        * alpha); 4 material_map's index: the palette index or
                                        * red * 255 */
        double filter_all, transmit_all; /* added to every texel (image_map filter / transmit all) */
        double major_radius;           /* map_type 5: 1 */
    } image;
    struct {                           /* FUNCTION, OBJECT */
        vbnl_pattern_fn fn;
        void *user;
        void (*destroy)(void *user);   /* optional: called with user when the scene is destroyed */
    } function;
    uint32_t pigment;                  /* PIGMENT: pigment id + 1 */
    int waves;                         /* RIPPLES, WAVES: number of centres, 1..VBNL_NOISE_WAVES_MAX (10) */
} vbnl_pattern_desc;

void vbnl_pattern_desc_init(vbnl_pattern_desc *d);
/* Adds a pattern (arrays copied; a callback's user data must live until the scene is destroyed,
 * which calls function.destroy when given; on an error the caller keeps it). Errors:
 * VBNL_ERR_INVALID_ARGUMENT for a wrong size field, an unknown kind, a singular or non-finite
 * transform, invalid warps or parameters, unknown image or pigment ids, nesting beyond
 * VBNL_TEXTURE_DEPTH_MAX. */
vbnl_result vbnl_scene_add_pattern(vbnl_scene *scene, const vbnl_pattern_desc *desc, uint32_t *out_id,
                                   vbnl_error *err);

/* ---- pigments ---- */

typedef enum vbnl_pigment_kind {
    VBNL_PIGMENT_SOLID = 0,   /* color */
    VBNL_PIGMENT_MAP,         /* pattern value through the map: colour and pigment entries */
    VBNL_PIGMENT_IMAGE,       /* the colour of the pattern's image (an IMAGE pattern) */
    VBNL_PIGMENT_AVERAGE,     /* entries weighted by their value */
} vbnl_pigment_kind;

/* Map entries, sorted by value. A value between two entries interpolates them linearly; equal
 * values make a step; below the first / above the last the end entry holds (POV-Ray's
 * Search_Blend_Map). */
typedef struct vbnl_pigment_map_entry {
    float value;
    float color[5];           /* r g b filter transmit, used when pigment is 0 */
    uint32_t pigment;         /* pigment id + 1, or 0 */
} vbnl_pigment_map_entry;

typedef struct vbnl_pigment_desc {
    uint32_t size;            /* sizeof(vbnl_pigment_desc) (vbnl_pigment_desc_init) */
    vbnl_pigment_kind kind;
    float color[5];           /* SOLID */
    uint32_t pattern;         /* MAP, IMAGE: pattern id + 1; AVERAGE: optional (its warps) */
    const vbnl_pigment_map_entry *map; /* MAP, AVERAGE: 1..VBNL_TEXTURE_MAP_MAX entries */
    uint32_t map_count;
    int uv;                   /* 1: evaluate at the hit's (u, v, 0) (uv_mapping) */
} vbnl_pigment_desc;

void vbnl_pigment_desc_init(vbnl_pigment_desc *d);
/* Adds a pigment. Material base_texture refers to it as id + 1 (the same id space as
 * vbnl_scene_add_texture). Errors: VBNL_ERR_INVALID_ARGUMENT for a wrong size field, an unknown
 * kind, a missing or unsorted map, non-finite colours, unknown ids, nesting too deep. */
vbnl_result vbnl_scene_add_pigment(vbnl_scene *scene, const vbnl_pigment_desc *desc, uint32_t *out_id,
                                   vbnl_error *err);

/* ---- normals ---- */

typedef enum vbnl_normal_kind {
    VBNL_NORMAL_PATTERN = 0,  /* the pattern's perturbation (see below) scaled by amount */
    VBNL_NORMAL_MAP,          /* pattern value through a map of normals */
    VBNL_NORMAL_AVERAGE,      /* entries weighted by their value */
    VBNL_NORMAL_IMAGE,        /* bump_map: the image (an IMAGE pattern) as a height field */
} vbnl_normal_kind;

typedef struct vbnl_normal_map_entry {
    float value;
    uint32_t normal;          /* normal id (not + 1) */
} vbnl_normal_map_entry;

/* slope_map entries: the height and slope the pattern value maps to (Hermite interpolation). */
typedef struct vbnl_slope_map_entry {
    float value, height, slope;
} vbnl_slope_map_entry;

/* PATTERN: bumps, dents, ripples, waves, wrinkles, quilted and facets perturb the normal by
 * their own formulas; every other pattern by the gradient of its value (through the slope map)
 * estimated from four evaluations `accuracy` apart, scaled by -5 amount 0.02 / accuracy
 * (POV-Ray's normal.cpp convention). The perturbation is added in the pattern's space to the
 * unit normal and the result carried back and normalised. */
typedef struct vbnl_normal_desc {
    uint32_t size;            /* sizeof(vbnl_normal_desc) (vbnl_normal_desc_init) */
    vbnl_normal_kind kind;
    uint32_t pattern;         /* pattern id + 1 (AVERAGE: optional, its warps) */
    float amount;             /* bump_size: 0.5 */
    float accuracy;           /* 0.02 */
    const vbnl_slope_map_entry *slope_map; /* optional, sorted */
    uint32_t slope_map_count;
    const vbnl_normal_map_entry *map; /* MAP, AVERAGE */
    uint32_t map_count;
    int no_bump_scale;        /* the perturbation is not normalised with the pattern's scale */
    int uv;                   /* evaluate at (u, v, 0) */
} vbnl_normal_desc;

void vbnl_normal_desc_init(vbnl_normal_desc *d);
vbnl_result vbnl_scene_add_normal(vbnl_scene *scene, const vbnl_normal_desc *desc, uint32_t *out_id,
                                  vbnl_error *err);

/* ---- materials chosen per point ---- */

typedef enum vbnl_material_node_kind {
    VBNL_NODE_TEXTURED = 0,   /* a material with a pigment, a normal and a transmission part */
    VBNL_NODE_MAP,            /* pattern value through a map of materials (blends neighbours) */
    VBNL_NODE_LAYERS,         /* POV-Ray's layered textures, top first */
    VBNL_NODE_AVERAGE,        /* entries weighted by their value */
} vbnl_material_node_kind;

typedef struct vbnl_material_map_entry {
    float value;
    uint32_t material;        /* material id (a plain material or another node) */
} vbnl_material_map_entry;

/* TEXTURED: at each point the pigment gives (r, g, b, f, t); the surface reflects as `material`
 * with its base colour multiplied by (r, g, b), with weight 1 - f - t, and lets the rest through
 * as `transmission` tinted by f (r, g, b) + t (POV-Ray 3.7's layer arithmetic, trace.cpp). The
 * normal perturbs the shading normal of both. LAYERS: layer i (a TEXTURED node or a plain
 * material) has weight (1 - f_i - t_i) prod_{j<i} (f_j c_j + t_j); what passes all layers takes
 * the bottom layer's transmission. Emission is the node's own `emission` (a constant; the
 * materials inside a node do not emit). */
typedef struct vbnl_material_node_desc {
    uint32_t size;            /* sizeof(vbnl_material_node_desc) (vbnl_material_node_desc_init) */
    vbnl_material_node_kind kind;
    uint32_t material;        /* TEXTURED: the plain material giving the BSDF */
    uint32_t pigment;         /* TEXTURED: pigment id + 1, 0 = the material's own colour */
    uint32_t normal;          /* TEXTURED: normal id + 1, 0 = none */
    uint32_t transmission;    /* TEXTURED: material id + 1 for the light the pigment lets through;
                               * 0 = straight through, unchanged (a dielectric of ior 1) */
    uint32_t pattern;         /* MAP: pattern id + 1; AVERAGE: optional (its warps) */
    const vbnl_material_map_entry *map; /* MAP, AVERAGE */
    uint32_t map_count;
    const uint32_t *layers;   /* LAYERS: material ids, top first (1..VBNL_TEXTURE_MAP_MAX) */
    uint32_t layer_count;
    float emission[3];        /* emitted radiance of the whole node */
    int two_sided;
    int uv;                   /* MAP: evaluate at (u, v, 0) */
} vbnl_material_node_desc;

void vbnl_material_node_desc_init(vbnl_material_node_desc *d);
/* Adds a material node and returns its *material* id (geometry uses it like any material).
 * Errors: VBNL_ERR_INVALID_ARGUMENT for a wrong size field, unknown ids or kind, a missing or
 * unsorted map, nesting too deep, a TEXTURED material that is itself a node. */
vbnl_result vbnl_scene_add_material_node(vbnl_scene *scene, const vbnl_material_node_desc *desc,
                                         uint32_t *out_id, vbnl_error *err);

/* ---- simple textures ---- */

/* A pigment in one call, for the common cases (and the mesh importer): every texture first maps
 * the world-space hit point p into texture space: q = pattern_from_world * p.
 *
 *   IMAGE     RGB float texels, row 0 at the top (v = 1). The lookup coordinate (u, v) is the
 *             hit's mesh UV (projection UV) or a projection of q, POV-Ray's image_map ones:
 *             PLANAR (u, v) = (q.x, q.y); SPHERICAL u = longitude around +y measured from +x
 *             towards +z (atan2(q.z, q.x) / 2 pi, in [0, 1)), v = latitude (0 at -y, 1 at +y);
 *             CYLINDRICAL u as spherical, v = q.y.
 *             Texel centres sit at ((i + 0.5) / width, 1 - (j + 0.5) / height); bilinear
 *             (interpolate = 1) or nearest; wrap REPEAT (fractional part) or CLAMP.
 *   CHECKER   POV-Ray's checker (unit cubes, values 0 and 1), with an offset of 1e-4 instead of
 *             POV-Ray's 1e-10 so that faces on integer planes, hit in single precision, stay in
 *             one cell.
 *   GRADIENT  value = dot(q, normalize(gradient)), then frequency, phase and wave (above).
 *   BRICK     POV-Ray's brick: bricks of brick_size (x width w, y height h, z depth d) in
 *             courses along y, joints `mortar` wide.
 *
 * Pattern values become colours through the colour map (POV-Ray's Search_Blend_Map, above).
 * CHECKER and BRICK are block patterns (values exactly 0 or 1: give entries at 0 and 1). The
 * result is a pigment (vbnl_scene_add_pigment's id space). */
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

/* Adds a texture as a pigment (arrays copied) and returns its pigment id. Errors:
 * VBNL_ERR_INVALID_ARGUMENT for a missing or unsorted colour map, empty or non-finite texels, a
 * singular or non-finite matrix, a zero gradient, non-positive brick sizes or negative mortar. A
 * material refers to it as id + 1. */
vbnl_result vbnl_scene_add_texture(vbnl_scene *scene, const vbnl_texture_desc *desc,
                                   uint32_t *out_id, vbnl_error *err);

/* ---- patterns and pigments outside a scene ---- */

/* A set of images, patterns and pigments evaluated on their own, without a scene or a hit:
 * POV-Ray's pattern and pigment functions (`function { pattern { ... } }`, `function { pigment
 * { ... } }`). Nodes are added as to a scene (the same descriptors, checks and id spaces within
 * the set); evaluation reads the set only, so once built it may be evaluated from any number of
 * threads. Patterns that depend on a surface see none, as in POV-Ray's functions: aoi and slope
 * give 0, uv-mapped lookups read (u, v) = (0, 0). */
typedef struct vbnl_pattern_set vbnl_pattern_set;

vbnl_result vbnl_pattern_set_create(vbnl_pattern_set **out, vbnl_error *err);
/* Frees the set and calls the destroy callbacks of its FUNCTION and OBJECT patterns. NULL is
 * accepted. */
void vbnl_pattern_set_destroy(vbnl_pattern_set *set);
vbnl_result vbnl_pattern_set_add_image(vbnl_pattern_set *set, const vbnl_image_desc *desc, uint32_t *out_id,
                                       vbnl_error *err);
vbnl_result vbnl_pattern_set_add_pattern(vbnl_pattern_set *set, const vbnl_pattern_desc *desc, uint32_t *out_id,
                                         vbnl_error *err);
vbnl_result vbnl_pattern_set_add_pigment(vbnl_pattern_set *set, const vbnl_pigment_desc *desc, uint32_t *out_id,
                                         vbnl_error *err);
/* The value of pattern `pattern` at p (what a map would look up; 0 for an unknown id). */
double vbnl_pattern_set_value(const vbnl_pattern_set *set, uint32_t pattern, const double p[3]);
/* The colour (r, g, b, filter, transmit) of pigment `pigment` at p (zero for an unknown id). */
void vbnl_pattern_set_color(const vbnl_pattern_set *set, uint32_t pigment, const double p[3], float out[5]);

/* POV-Ray's vector turbulence at p (its vturbulence(lambda, omega, octaves, p)): the noise
 * gradient summed over octaves 1..10 (clamped), each at `lambda` times the frequency and `omega`
 * times the weight of the one before. */
void vbnl_vturbulence(double lambda, double omega, int octaves, const double p[3], double out[3]);

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

/* An environment whose radiance varies with direction: POV-Ray's sky_sphere (reference section
 * "Sky Sphere"). For a ray leaving the scene along the unit direction d, every pigment is
 * evaluated at q = pattern_from_world (d, 1) (the sky_sphere's transforms inverted; d is taken as
 * a point, as POV-Ray does). The pigments are layers, the last one on top: each adds its
 * rgb (1 - filter - transmit) times `emission` to what shows through the layers above it and lets
 * rgb filter + transmit of the layers below through; `background` lies below them all (POV-Ray
 * 3.7's sky over its background colour). The environment lights the scene and is what rays that
 * leave it see; it is baked into a sampling table at commit (docs/environment.md). */
#define VBNL_ENVIRONMENT_LAYERS_MAX 64u
typedef struct vbnl_environment_desc {
    uint32_t size;                  /* sizeof(vbnl_environment_desc) (vbnl_environment_desc_init) */
    const uint32_t *pigments;       /* pigment ids (vbnl_scene_add_pigment), bottom layer first */
    uint32_t pigment_count;         /* 1..VBNL_ENVIRONMENT_LAYERS_MAX */
    double pattern_from_world[16];  /* row-major 4x4 affine; identity by default */
    float emission[3];              /* scales the layers (POV-Ray 3.7.1's `emission`); 1 by default */
    float background[3];            /* radiance below the layers; 0 by default */
    int legacy_layers;              /* 1: POV-Ray's composition for scenes before #version 3.7
                                     * (docs/environment.md); 0 by default */
} vbnl_environment_desc;

/* Fills `d` with its size, the identity transform, emission 1 and the rest zero. */
void vbnl_environment_desc_init(vbnl_environment_desc *d);
/* Sets the environment to the pigment stack `d` (copied; replaces a constant environment, and a
 * later vbnl_scene_set_environment replaces this one). Errors: VBNL_ERR_INVALID_ARGUMENT for a
 * wrong size field, no pigments or more than VBNL_ENVIRONMENT_LAYERS_MAX, an unknown pigment id, a
 * non-finite or non-affine transform, a negative or non-finite emission or background;
 * VBNL_ERR_OUT_OF_MEMORY. Not thread-safe (as every scene edit). */
vbnl_result vbnl_scene_set_environment_pigments(vbnl_scene *scene, const vbnl_environment_desc *d,
                                                vbnl_error *err);
/* Opacity (alpha) of the pixels where camera rays see only the environment: 1 by default (an
 * opaque background), 0 for POV-Ray's transparent background under Output_Alpha (+UA). Seen through
 * transmitting surfaces and media, the alpha is 1 - (1 - this) x the light they let through. */
vbnl_result vbnl_scene_set_background_alpha(vbnl_scene *scene, float alpha, vbnl_error *err);

/* Per-geometry visibility (POV-Ray's object modifiers), for a mesh, sphere or instance id: */
enum {
    VBNL_VISIBLE_NO_SHADOW = 1u << 0,     /* blocks no shadow ray: casts no shadow (no_shadow) */
    VBNL_VISIBLE_NO_IMAGE = 1u << 1,      /* invisible to camera rays (no_image) */
    VBNL_VISIBLE_NO_REFLECTION = 1u << 2, /* invisible after a specular reflection (no_reflection) */
};
/* Sets the flags (a combination of VBNL_VISIBLE_*) of geometry `geom` (an id of add_mesh,
 * add_sphere or add_instance). Errors: VBNL_ERR_INVALID_ARGUMENT for an unknown id. */
vbnl_result vbnl_scene_set_visibility(vbnl_scene *scene, uint32_t geom, uint32_t flags, vbnl_error *err);

/* A light of add_*_light (not an emissive surface) that casts no shadow: POV-Ray's `shadowless`.
 * Its direct light is found by next-event estimation without shadow rays (and only by it);
 * photons and virtual lights still see occluders. */
vbnl_result vbnl_scene_set_light_shadowless(vbnl_scene *scene, uint32_t light, int shadowless, vbnl_error *err);

/* A light of add_*_light whose light participating media do not scatter (interacts = 0): POV-Ray's
 * `media_interaction off`. Points in media get no light from it (next-event and equiangular
 * estimates leave it out); surfaces are lit by it as before, through the media's transmittance.
 * Errors: VBNL_ERR_INVALID_ARGUMENT for an unknown light. */
vbnl_result vbnl_scene_set_light_media_interaction(vbnl_scene *scene, uint32_t light, int interacts,
                                                   vbnl_error *err);

/* ---- participating media and fog ---------------------------------------------------------- */

/* A medium fills the inside of the surfaces whose material names it (vbnl_material_desc.interior)
 * or, as the atmosphere, all space outside them (vbnl_scene_set_atmosphere). Each medium is a sum
 * of up to VBNL_MEDIUM_PARTS_MAX parts (POV-Ray's media blocks of one interior): absorption
 * sigma_a, scattering sigma_s (per unit length) with a phase function, and emitted radiance per
 * unit length, each multiplied at a point by the product of the part's density pigments there
 * (their r, g, b; filter and transmit unused). Rendering: delta tracking with the medium's
 * majorant for the distance to the next interaction, ratio tracking for the transmittance of
 * shadow rays, closed forms where a medium has no density pattern (README: docs/integrators.md,
 * "Media"). */
#define VBNL_MEDIUM_PARTS_MAX 8u
#define VBNL_MEDIUM_DENSITY_MAX 8u

/* Phase functions, normalised over the sphere, of the cosine mu between the directions of travel
 * before and after scattering (POV-Ray's scattering types 1 to 5 in its order). */
typedef enum vbnl_phase_kind {
    VBNL_PHASE_ISOTROPIC = 1,         /* 1 / (4 pi) */
    VBNL_PHASE_MIE_HAZY = 2,          /* (1 + 9 ((1 + mu) / 2)^8) / (8 pi) */
    VBNL_PHASE_MIE_MURKY = 3,         /* (1 + 50 ((1 + mu) / 2)^32) 33 / (332 pi) */
    VBNL_PHASE_RAYLEIGH = 4,          /* 3 (1 + mu^2) / (16 pi) */
    VBNL_PHASE_HENYEY_GREENSTEIN = 5, /* (1 - g^2) / (4 pi (1 + g^2 - 2 g mu)^1.5), g in (-1, 1) */
} vbnl_phase_kind;

typedef struct vbnl_medium_part_desc {
    float absorption[3];      /* sigma_a, >= 0 */
    float scattering[3];      /* sigma_s, >= 0 */
    float emission[3];        /* radiance emitted per unit length, >= 0 */
    vbnl_phase_kind phase;
    float g;                  /* HENYEY_GREENSTEIN: the eccentricity */
    const uint32_t *density;  /* pigment ids (not + 1) whose colours multiply the part, evaluated at
                               * the world point; 0..VBNL_MEDIUM_DENSITY_MAX of them */
    uint32_t density_count;
    float extinction_deficit; /* 1 - e, with e >= 0 the share of sigma_s in the extinction (POV-Ray's
                               * scattering `extinction`): sigma_t = sigma_a + e sigma_s while the
                               * in-scattering keeps sigma_s; 0 (physical: e = 1) by default. e < 1
                               * does not conserve energy (the albedo may exceed 1). At most 1 */
} vbnl_medium_part_desc;

typedef struct vbnl_medium_desc {
    uint32_t size;            /* sizeof(vbnl_medium_desc) (vbnl_medium_desc_init) */
    const vbnl_medium_part_desc *parts; /* 1..VBNL_MEDIUM_PARTS_MAX */
    uint32_t part_count;
} vbnl_medium_desc;

void vbnl_medium_desc_init(vbnl_medium_desc *d);
/* Adds a medium (arrays copied). Errors: VBNL_ERR_INVALID_ARGUMENT for a wrong size field, no
 * parts or too many, negative or non-finite coefficients, an extinction deficit above 1 or not
 * finite, an unknown phase function or |g| >= 1,
 * unknown pigment ids, a density pigment whose colours have no finite upper bound. */
vbnl_result vbnl_scene_add_medium(vbnl_scene *scene, const vbnl_medium_desc *desc, uint32_t *out_id,
                                  vbnl_error *err);
/* The medium filling space outside every surface whose material has an interior of its own
 * (id + 1; 0 = none, the default). Rays start from the camera and lights in it. */
vbnl_result vbnl_scene_set_atmosphere(vbnl_scene *scene, uint32_t medium, vbnl_error *err);

/* POV-Ray's fog (reference "Fog"): applied over every ray segment travelled outside surfaces
 * whose material has an interior (where the atmosphere is), in closed form per segment of length
 * d, as POV-Ray applies it per ray: attenuation a = max(exp(-d' / distance), transmit), with d' =
 * d for constant fog and, for ground fog, d times the mean of the density 1 / (1 + h^2) (1 below
 * the offset) along the segment, h = (height along `up` - offset) / alt; turbulence scales d' by
 * 1 - exp(-d / distance) min(1, turbulence(p) turb_depth) at the segment's midpoint p. The
 * segment lets through a (1 - filter + filter colour) of what arrives from its far end and adds
 * (1 - a) colour: an absorbing medium emitting the fog colour, which reproduces POV-Ray's blend
 * exactly on camera rays. Several fogs multiply their attenuations and add their colours, as in
 * POV-Ray. */
typedef enum vbnl_fog_kind {
    VBNL_FOG_CONSTANT = 1,
    VBNL_FOG_GROUND = 2,
} vbnl_fog_kind;

typedef struct vbnl_fog_desc {
    uint32_t size;                  /* sizeof(vbnl_fog_desc) (vbnl_fog_desc_init) */
    vbnl_fog_kind kind;
    float distance;                 /* > 0 */
    float color[5];                 /* r, g, b, filter, transmit */
    float offset, alt;              /* GROUND: fog_offset, fog_alt (> 0) */
    float up[3];                    /* GROUND: the up direction (normalised by the core) */
    vbnl_turbulence_desc turbulence; /* amount 0: none */
    float turb_depth;               /* 0.5 */
    int noise_generator;            /* 1, 2 or 3 */
} vbnl_fog_desc;

void vbnl_fog_desc_init(vbnl_fog_desc *d);
/* Adds a fog. Errors: VBNL_ERR_INVALID_ARGUMENT for a wrong size field, an unknown kind, a
 * distance or alt that is not positive and finite, non-finite colours or a zero up vector. */
vbnl_result vbnl_scene_add_fog(vbnl_scene *scene, const vbnl_fog_desc *desc, vbnl_error *err);

/* ---- camera ------------------------------------------------------------------------------- */

/* The camera's projection: POV-Ray 3.7's camera types (reference section "Camera", "Camera
 * Types"), each from its position and its forward, right and up vectors. (sx, sy) is the
 * normalised image point, sx in [-0.5, 0.5] from the left to the right edge and sy in [-0.5, 0.5]
 * from the bottom to the top edge. */
typedef enum vbnl_camera_projection {
    /* direction forward + sx*right + sy*up */
    VBNL_CAMERA_PERSPECTIVE = 0,
    /* parallel rays along forward from position + sx*right + sy*up */
    VBNL_CAMERA_ORTHOGRAPHIC = 1,
    /* angle[0] degrees across the circle of radius 1 in (2 sx |right|, 2 sy |up|); nothing outside */
    VBNL_CAMERA_FISHEYE = 2,
    /* angle[0] degrees across the width, angle[0] * |up| / |right| across the height */
    VBNL_CAMERA_ULTRA_WIDE_ANGLE = 3,
    /* 180 degrees across the width (cylindrical), the tangent of up to 90 degrees across the height */
    VBNL_CAMERA_PANORAMIC = 4,
    /* angle[0] degrees of longitude across the width, angle[1] of latitude across the height */
    VBNL_CAMERA_SPHERICAL = 5,
    /* cylinder 1..4: the axis along up (1, 3) or right (2, 4), angle[0] degrees around it, |up|
     * (1, 3) or |right| (2, 4) along it; 3 and 4 are orthographic along the axis */
    VBNL_CAMERA_CYLINDER_1 = 6,
    VBNL_CAMERA_CYLINDER_2 = 7,
    VBNL_CAMERA_CYLINDER_3 = 8,
    VBNL_CAMERA_CYLINDER_4 = 9,
    /* POV-Ray's mesh_camera: rays leave the faces of meshes (vbnl_camera_mesh); the vectors and
     * angles are not used */
    VBNL_CAMERA_MESH = 10,
} vbnl_camera_projection;

/* One mesh of a mesh camera (reference section "Mesh Camera"), as separate triangles. A ray of a
 * face starts at its centroid (distributions 0 to 2) or at the point of the face whose uv is the
 * image point (distribution 3), along the face normal cross(c - a, b - a) / |...| of its corners
 * a, b, c (or, with `smooth`, the corner normals interpolated there), moved `mesh_offset` along
 * that direction, reversed with `mesh_reverse`, then carried to the world by `transform` (points)
 * and its inverse transpose (the direction). */
typedef struct vbnl_camera_mesh {
    uint32_t triangle_count;
    const float *positions; /* 9 per triangle: the corners a, b, c in the mesh's space */
    const float *normals;   /* NULL, or 9 per triangle: corner normals (distribution 3 with smooth) */
    const float *uvs;       /* NULL, or 6 per triangle: corner uvs (distribution 3 needs them) */
    float transform[16];    /* row-major, the mesh's space to the world */
} vbnl_camera_mesh;

/* A camera in POV-Ray's general form. The lengths of right and up set the field of view and the
 * aspect ratio; mirrored cameras are allowed. The fields after `up` are zero for the pinhole
 * perspective camera (a zero-initialised struct, or vbnl_camera_look_at).
 *
 * Thin lens (POV-Ray's focal blur): with lens_radius > 0 each camera sample's ray starts at a
 * point of the disc of that radius around the pinhole ray's origin, perpendicular to forward,
 * and passes through the pinhole ray's point at focal_distance: the point origin + D *
 * focal_distance / |forward|, where D is the projection's unnormalised direction (for the
 * perspective camera, forward + sx*right + sy*up: the plane at focal_distance along forward is
 * sharp). The disc is sampled with each sample's second pair of random numbers. */
typedef struct vbnl_camera_desc {
    uint32_t size;            /* sizeof(vbnl_camera_desc): set by vbnl_camera_desc_init and look_at */
    float position[3];
    float forward[3];
    float right[3];
    float up[3];
    vbnl_camera_projection projection;
    float angle[2];       /* degrees, for the projections that name them above */
    float lens_radius;    /* 0: pinhole */
    float focal_distance; /* > 0 when lens_radius > 0 */
    /* VBNL_CAMERA_MESH. Distribution 0: pixel (x, y) (row 0 at the top) is face y * width + x of
     * mesh k for its k-th ray; 1: face y * width + x + k * width * height of the meshes taken as
     * one; 2: the meshes side by side, each over width / mesh_count columns, pixel (x, y) face
     * y * columns + (x - its mesh's first column); 3: the first face of the first mesh whose uvs
     * hold (x / width, 1 - y / height). A camera sample takes ray k of its pixel's
     * mesh_rays_per_pixel uniformly (from its lens numbers: the lens is not used); a pixel or
     * ray without a face sees nothing (transparent black). vbnl_scene_set_camera copies the
     * meshes. */
    const vbnl_camera_mesh *meshes;
    uint32_t mesh_count;
    uint32_t mesh_distribution;   /* 0 to 3 */
    uint32_t mesh_rays_per_pixel; /* >= 1; 1 for distributions 2 and 3; at most mesh_count for 0 */
    uint32_t mesh_smooth;         /* distribution 3: interpolated corner normals */
    uint32_t mesh_reverse;        /* rays against the face normals */
    float mesh_offset;            /* how far along its direction a ray starts */
    const void *mesh_index;       /* set in the scene's own copy (a uv index); NULL in a caller's */
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

/* Sets the camera (copied, a mesh camera's meshes included; a later call replaces it). Errors:
 * VBNL_ERR_INVALID_ARGUMENT for non-finite vectors or forward, right and up vectors that are not
 * linearly independent; for a mesh camera, no meshes, a distribution above 3, a ray count out of
 * range, corners that are not finite, a transform that cannot be inverted, or distribution 3
 * without uvs or smooth without normals; VBNL_ERR_OUT_OF_MEMORY. */
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
