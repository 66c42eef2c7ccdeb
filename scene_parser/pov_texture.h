/* vbnl: texture part internals visible to its tests (not used by the object part). */
#ifndef VBNL_POV_TEXTURE_H
#define VBNL_POV_TEXTURE_H

#include "pov_internal.h"

/* The description of core material `material` as pov_appearance_material added it (NULL when
 * that id was not added by the texture part), and its texture (NULL: untextured). */
const vbnl_material_desc *pov_texture_material_desc(const pov_ctx *c, uint32_t material);
const vbnl_texture_desc *pov_texture_texture_desc(const pov_ctx *c, uint32_t material);
/* Distinct core materials added so far. */
uint32_t pov_texture_material_count(const pov_ctx *c);

#endif
