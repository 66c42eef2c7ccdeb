/* vbnl object layer: sphere { <centre>, radius } (an analytic primitive of the core). */
#include "pov_shape.h"

vbnl_result pov_shape_sphere(const pov_shape *s)
{
    double c[3], r;
    if (pov_shape_vector_float(s, c, &r) != VBNL_OK || pov_positive(s->L, r, "sphere radius", s->loc) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_shape_add_analytic(s, POV_PRIM_SPHERE, c, r);
}
