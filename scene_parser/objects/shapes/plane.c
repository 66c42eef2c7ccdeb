/* vbnl object layer: plane { <normal>, distance } (a primitive; its patch is made at build). */
#include "pov_shape.h"

vbnl_result pov_shape_plane(const pov_shape *s)
{
    double n[3], d;
    if (pov_shape_vector_float(s, n, &d) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(pov_len3(n) > 0))
        return vbnl_sdl_error(s->L->c.parser, &s->loc, "plane normal must not be zero");
    return pov_shape_add_analytic(s, POV_PRIM_PLANE, n, d);
}
