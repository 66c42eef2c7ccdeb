/* The prepared virtual-light set of VBNL (private header).
 *
 * What preparation produces and rendering consumes: per light its position, normal, material
 * (and the texture colour there),
 * radius r_i = alpha_r r_i,max (§3.2), density rho_i (Eq. 8), and its emission profile (§3.3).
 * The set is a value: it can be saved to a versioned, checksummed file and loaded again for the
 * same scene (vl_file.h: vbi_vl_file_save / _load), which is what lets preparation and shading run in
 * different processes, and photon splitting of several runs be summed. */
#ifndef VBI_VL_SET_H
#define VBI_VL_SET_H

#include <stdint.h>

#include "vbnl/result.h"
#include "vmath.h"

typedef struct vbi_vl_set {
    uint32_t count;
    vec3 *position;
    vec3 *normal;        /* unit, facing the side the placing camera path came from */
    uint32_t *material;  /* the material resolved at the light (vbi_surface_light_material) */
    vec3 *tint;          /* its colour factor there (1 when untextured): the light's BSDF is the
                          * material's with the colour scaled by it */
    float *radius;       /* r_i */
    float *density;      /* rho_i, Eq. 8 */
} vbi_vl_set;

/* Allocates arrays for `count` lights (contents undefined). */
vbnl_result vbi_vl_set_alloc(vbi_vl_set *s, uint32_t count, vbnl_error *err);
void vbi_vl_set_free(vbi_vl_set *s);
/* Bytes held by the arrays. */
size_t vbi_vl_set_bytes(const vbi_vl_set *s);

#endif
