/* vbnl object layer: torus { major, minor } (around +y; a mesh with its exact solid for CSG). */
#include "pov_shape.h"

vbnl_result pov_shape_torus(const pov_shape *s)
{
    pov_loader *L = s->L;
    double major, minor;
    if (pov_float(L, &major) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_float(L, &minor) != VBNL_OK || pov_positive(L, major, "torus major radius", s->loc) != VBNL_OK ||
        pov_positive(L, minor, "torus minor radius", s->loc) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pov_shape_add_mesh(s, pov_tess_torus(major, minor)) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(s->o->v[s->o->n - 1].solid = pov_solid_torus(major, minor)))
        return pov_oom(L);
    return pov_shape_modifiers(s);
}
