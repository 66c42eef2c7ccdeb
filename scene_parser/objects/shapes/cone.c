/* vbnl object layer: cylinder { <base>, <cap>, radius [open] } and
 * cone { <base>, base radius, <cap>, cap radius [open] }: meshes with their exact solid for CSG.
 * The mesh is made after the modifiers, since `open` may come among them. */
#include "pov_shape.h"

vbnl_result pov_shape_cone(const pov_shape *s)
{
    pov_loader *L = s->L;
    int cone = s->keyword[1] == 'o';
    double a[3], b[3], ra = 0, rb;
    if (pov_vec3(L, a) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (cone) {
        if (pov_float(L, &ra) != VBNL_OK)
            return VBNL_ERR_PARSE;
        pov_comma(L);
    }
    if (pov_vec3(L, b) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_float(L, &rb) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!cone)
        ra = rb;
    double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    int degenerate = !(pov_len3(d) > 0);
    if (cone && !(ra >= 0 && rb >= 0 && ra + rb > 0))
        return vbnl_sdl_error(L->c.parser, &s->loc, "cone radii must be >= 0 and not both 0");
    if (!cone && pov_positive(L, ra, "cylinder radius", s->loc) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!pov_obj_add(s->o, POV_PRIM_MESH, s->loc))
        return pov_oom(L);
    size_t idx = s->o->n - 1;
    pov_mods m = {L, s->o, 1, 0, {0}, {0}};
    vbnl_result r = pov_mods_parse(&m, s->keyword, 1);
    pov_prim *pr = &s->o->v[idx];
    if (r == VBNL_OK && degenerate) { /* POV-Ray warns and drops it too */
        vbnl_sdl_warning(L->c.parser, &s->loc, "%s: the two end points coincide; the object is skipped", s->keyword);
        if (!(pr->mesh = pov_mesh_new()))
            r = pov_oom(L);
    } else if (r == VBNL_OK) {
        double key[9] = {a[0], a[1], a[2], ra, b[0], b[1], b[2], rb, m.open};
        if (!pov_shape_cache_find(L, "cone", key, 9, &pr->mesh, &pr->solid)) {
            if (!(pr->mesh = pov_tess_cone(a, ra, b, rb, m.open)) || !(pr->solid = pov_solid_cone(a, ra, b, rb)))
                r = pov_oom(L);
            else
                pov_shape_cache_keep(L, "cone", key, 9, pr->mesh, pr->solid);
        }
    }
    if (r == VBNL_OK)
        r = pov_mods_finish(&m);
    pov_mods_clear(&m);
    return r;
}
