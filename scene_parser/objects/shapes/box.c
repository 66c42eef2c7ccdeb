/* vbnl object layer: box { <corner>, <corner> } (a mesh with its exact solid for CSG). */
#include "pov_shape.h"

vbnl_result pov_shape_box(const pov_shape *s)
{
    pov_loader *L = s->L;
    double a[3], b[3];
    if (pov_vec3(L, a) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_vec3(L, b) != VBNL_OK || pov_shape_add_mesh(s, pov_tess_box(a, b)) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(s->o->v[s->o->n - 1].solid = pov_solid_box(a, b)))
        return pov_oom(L);
    return pov_shape_modifiers(s);
}
