/* vbnl object layer: polygon { n, points } (POV-Ray's sub-polygons, ear-clipped in their plane). */
#include <stdlib.h>

#include "pov_shape.h"

vbnl_result pov_shape_polygon(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    double n;
    if (pov_list_count(L, &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(n >= 3 && n <= 1e7) || n != floor(n))
        return vbnl_sdl_error(p, &s->loc, "polygon needs a whole number of at least 3 points, got %g", n);
    double *pts = malloc(sizeof(double) * 3 * (size_t)n);
    if (!pts)
        return pov_oom(L);
    for (size_t i = 0; i < (size_t)n; ++i) {
        vbnl_sdl_value v;
        pov_comma(L);
        if (vbnl_sdl_parse_expression(p, &v) != VBNL_OK) {
            free(pts);
            return VBNL_ERR_PARSE;
        }
        if (v.kind == VBNL_SDL_VECTOR && v.dim == 2) {
            pov_set3(pts + 3 * i, v.v[0], v.v[1], 0);
        } else if (v.kind == VBNL_SDL_VECTOR || v.kind == VBNL_SDL_COLOR) {
            pov_set3(pts + 3 * i, v.v[0], v.v[1], v.v[2]);
        } else if (v.kind == VBNL_SDL_FLOAT) {
            pov_set3(pts + 3 * i, v.v[0], v.v[0], v.v[0]);
        } else {
            vbnl_sdl_value_clear(p, &v);
            free(pts);
            return vbnl_sdl_error(p, NULL, "polygon point %zu must be a vector", i + 1);
        }
        vbnl_sdl_value_clear(p, &v);
    }
    int nested, open_last, huge;
    pov_mesh *m = pov_tess_polygon(pts, (int)n, &nested, &open_last, &huge);
    if (huge)
        vbnl_sdl_warning(p, &s->loc, "polygon: a sub-polygon has more than %d points; it is triangulated as a fan from its first point (exact when convex)",
                         POV_EAR_CLIP_MAX);
    free(pts);
    if (nested)
        vbnl_sdl_warning(p, &s->loc, "polygon: a sub-polygon inside another is filled, not cut out as a hole");
    if (open_last)
        vbnl_sdl_warning(p, &s->loc, "polygon: the last sub-polygon is not closed (its first point is not repeated); closed automatically");
    if (pov_shape_add_mesh(s, m) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_shape_modifiers(s);
}
