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
    double key[2] = {major, minor};
    pov_mesh *m = NULL;
    pov_solid *solid = NULL;
    if (!pov_shape_cache_find(L, "torus", key, 2, &m, &solid)) {
        m = pov_tess_torus(major, minor);
        solid = m ? pov_solid_torus(major, minor) : NULL;
        if (!solid) {
            pov_mesh_unref(m);
            return pov_oom(L);
        }
        pov_shape_cache_keep(L, "torus", key, 2, m, solid);
    }
    if (pov_shape_add_mesh(s, m) != VBNL_OK) {
        pov_solid_unref(solid);
        return VBNL_ERR_PARSE;
    }
    s->o->v[s->o->n - 1].solid = solid;
    return pov_shape_modifiers(s);
}
