/* BSDFs built from a material description, shared by the unit tests (header-only; needs the
 * core's private bsdf.h on the include path). */
#ifndef VBI_TEST_BSDFS_H
#define VBI_TEST_BSDFS_H

#include <string.h>

#include "bsdf.h"

/* A material of the given type, base colour (r, g, b), GGX alpha and index of refraction. */
static inline vbi_bsdf tb_bsdf(vbnl_material_type type, float r, float g, float b, float alpha, float ior)
{
    vbnl_material_desc m;
    memset(&m, 0, sizeof(m));
    m.type = type;
    m.base_color[0] = r;
    m.base_color[1] = g;
    m.base_color[2] = b;
    m.alpha = alpha;
    m.ior = ior;
    vbi_bsdf bsdf;
    vbi_bsdf_from_material(&bsdf, &m);
    return bsdf;
}

#endif
