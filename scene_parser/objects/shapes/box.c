/* vbnl object layer: box { <corner>, <corner> } (a mesh with its exact solid for CSG). */
#include "pov_shape.h"

vbnl_result pov_shape_box(const pov_shape *s)
{
    pov_loader *L = s->L;
    double a[3], b[3];
    if (pov_vec3(L, a) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_vec3(L, b) != VBNL_OK)
        return VBNL_ERR_PARSE;
    double key[6] = {a[0], a[1], a[2], b[0], b[1], b[2]};
    pov_mesh *m = NULL;
    pov_solid *solid = NULL;
    if (!pov_shape_cache_find(L, "box", key, 6, &m, &solid)) {
        m = pov_tess_box(a, b);
        solid = m ? pov_solid_box(a, b) : NULL;
        if (!solid) {
            pov_mesh_unref(m);
            return pov_oom(L);
        }
        pov_shape_cache_keep(L, "box", key, 6, m, solid);
    }
    if (pov_shape_add_mesh(s, m) != VBNL_OK) {
        pov_solid_unref(solid);
        return VBNL_ERR_PARSE;
    }
    s->o->v[s->o->n - 1].solid = solid;
    return pov_shape_modifiers(s);
}
