/* vbnl: the object layer's two parts and what they share.
 *
 *   objects/, objects/shapes/  the object part: objects, shapes, CSG, transforms, camera,
 *                              lights, global_settings and the integrator block, building the
 *                              vbnl_scene (pov_loader.h)
 *   objects/texture/           the texture part: texture, pigment, finish, normal, interior,
 *                              material, maps, #default, and the mapping of a POV-Ray
 *                              appearance onto a core material and texture (pov_texture.h)
 *
 * The object part owns the parser hooks (vbnl_sdl_hooks) and hands every appearance keyword to
 * the texture part through the functions below.
 *
 * Matrices are 4x4 row-major affine maps (pov_matrix.h). The object part chooses how POV-Ray's
 * left-handed world maps onto the core's (keeping coordinates unchanged works: the core camera
 * takes explicit forward/right/up vectors) and passes that map to pov_appearance_material as
 * world_from_pov, so patterns stay attached to their objects. */
#ifndef VBI_POV_INTERNAL_H
#define VBI_POV_INTERNAL_H

#include <stdint.h>

#include "pov_block.h"
#include "vbnl/scene.h"
#include "vbnl/sdl.h"

typedef struct pov_texture_state pov_texture_state; /* owned by the texture part */
typedef struct pov_appearance pov_appearance;       /* one object's texture + interior */

/* What both parts share during one load. Created and owned by the object part. */
typedef struct pov_ctx {
    vbnl_sdl_parser *parser;
    vbnl_scene *scene;       /* the scene being built (not committed until the parse ends) */
    pov_texture_state *tex;  /* pov_texture_state_create / _destroy */
} pov_ctx;

/* ---- media (texture/interior.c) ------------------------------------------------------------ */

/* media { } (POV-Ray 3.7 reference "Media"), the parser on '{': absorption, emission and
 * scattering { type, colour [eccentricity] [extinction] } onto one part of a core medium; the
 * sampling controls (method, intervals, samples, ...) are read and not needed (the core samples
 * media without bias). Its density { } blocks go into `density` (state density indices + 1, the
 * rest 0), made core pigments when an object using the media is built; with density NULL (the
 * atmosphere) they are warned about and the media taken as constant. A scattering extinction e
 * becomes part->extinction_deficit = 1 - e, e raised (warned) where the albedo would exceed 1
 * (docs/scene-language.md, "Fog and media"). A declared
 * media identifier inside is not supported: warned, and part->phase is 0 (the caller leaves the
 * part out). */
vbnl_result pov_media_parse(pov_ctx *c, vbnl_medium_part_desc *part, uint32_t density[VBNL_MEDIUM_DENSITY_MAX]);

/* ---- texture part: state ------------------------------------------------------------------ */

vbnl_result pov_texture_state_create(pov_ctx *c, vbnl_error *err);
void pov_texture_state_destroy(pov_ctx *c);

/* ---- texture part: parsing ---------------------------------------------------------------- */

/* 1 when the identifier token starts an appearance modifier inside an object:
 * texture pigment finish normal interior material interior_texture (and identifiers declared
 * to such values, e.g. `texture { T_Gold }` is handled inside, but a bare `T_Gold` is not
 * a modifier). */
int pov_appearance_is_modifier(const vbnl_sdl_token *tok);

/* Parses one modifier (the parser is positioned on its keyword, not yet consumed) and applies
 * it to *app, creating *app from the current #default when it is NULL. Returns VBNL_OK or
 * VBNL_ERR_PARSE after vbnl_sdl_error. */
vbnl_result pov_appearance_parse_modifier(pov_ctx *c, pov_appearance **app);

/* The rvalue hook's share: `#declare X = texture { ... }` and the same for pigment, finish,
 * normal, interior, material and color_map/colour_map. Same return convention as
 * vbnl_sdl_hooks.rvalue (0: not one of these; the language layer's block fallback then keeps
 * the block). */
int pov_appearance_rvalue(pov_ctx *c, const vbnl_sdl_token *tok, vbnl_sdl_value *out);

/* Pigments on their own, for sky_sphere (the object part keeps them opaque):
 * pov_pigment_new a black pigment; pov_pigment_parse reads `{ ... }` after the keyword `pigment`
 * into it (VBNL_ERR_PARSE after the error); pov_pigment_dup / _free copy and free (NULL accepted);
 * pov_pigment_core adds it to the scene as a core pigment (its id into *out) whose colours are
 * radiances: unlike a surface's, they are not clamped to [0, 1]. */
typedef struct pov_pigment pov_pigment;
pov_pigment *pov_pigment_new(void);
vbnl_result pov_pigment_parse(pov_ctx *c, pov_pigment *pg);
pov_pigment *pov_pigment_dup(const pov_pigment *g);
void pov_pigment_free(pov_pigment *g);
vbnl_result pov_pigment_core(pov_ctx *c, const pov_pigment *g, uint32_t *out, vbnl_error *err);

/* The default_block hook: `#default { texture/pigment/finish/normal { ... } }`. */
int pov_appearance_default_block(pov_ctx *c);

/* The function_block hook (vbnl_sdl_set_function_block_hook): `function { pattern { ... } }` and
 * `function { pigment { ... } }` (texture/function.c). */
int pov_function_block(pov_ctx *c, const vbnl_sdl_token *tok, vbnl_sdl_fn_block *out);

/* Copies / frees (NULL accepted). An object without its own appearance inherits its parent's
 * (CSG) or the #default one, which the object part asks for with pov_appearance_default. */
pov_appearance *pov_appearance_copy(const pov_appearance *a);
void pov_appearance_free(pov_appearance *a);
pov_appearance *pov_appearance_default(pov_ctx *c);
/* The #default appearance as it is now, shared (one reference more; release with
 * pov_appearance_free): for objects placed in the world without one, which nothing changes
 * afterwards. A scene of a million untextured spheres holds one appearance, not a million. */
pov_appearance *pov_appearance_default_shared(pov_ctx *c);

/* An object transform given after the appearance moves its patterns with the object. */
void pov_appearance_transform(pov_appearance *a, const double m[16]);

/* global_settings items of the texture part (noise_generator, number_of_waves); the block's
 * context must start with the pov_ctx (the loader does). */
extern const pov_row pov_texture_global_rows[];

/* ---- texture part: mapping onto the core --------------------------------------------------- */

/* Resolves the appearance to a core material (added to c->scene once per distinct content and
 * reused). `world_from_pov` converts POV world coordinates to the core's (the z flip), for
 * pattern textures evaluated at world-space hit points. Warnings (unsupported pattern, ignored
 * finish item) are reported once per appearance at its location. */
vbnl_result pov_appearance_material(pov_ctx *c, const pov_appearance *a,
                                    const double world_from_pov[16], uint32_t *material,
                                    vbnl_error *err);

/* 1 when the appearance emits light (finish { emission > 0 } times the pigment). */
int pov_appearance_is_emissive(const pov_appearance *a);

#endif
