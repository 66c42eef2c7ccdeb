/* vbnl object layer: disc { <centre>, <normal>, radius [, hole radius] }. */
#include "pov_shape.h"

vbnl_result pov_shape_disc(const pov_shape *s)
{
    pov_loader *L = s->L;
    double c[3], n[3], r, hole = 0;
    if (pov_vec3(L, c) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_vec3(L, n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_float(L, &r) != VBNL_OK || pov_positive(L, r, "disc radius", s->loc) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (vbnl_sdl_accept(L->c.parser, ',') && pov_float(L, &hole) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(pov_len3(n) > 0))
        return vbnl_sdl_error(L->c.parser, &s->loc, "disc normal must not be zero");
    if (pov_shape_add_mesh(s, pov_tess_disc(c, n, r, fmax(0, fmin(hole, r)))) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_shape_modifiers(s);
}
