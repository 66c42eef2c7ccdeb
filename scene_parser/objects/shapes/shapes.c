/* vbnl object layer: the table of shapes, and the POV-Ray shapes read but left out. */
#include <string.h>

#include "pov_shape.h"

static const pov_shape_row shapes[] = {
    {"sphere", pov_shape_sphere},
    {"box", pov_shape_box},
    {"plane", pov_shape_plane},
    {"cylinder", pov_shape_cone},
    {"cone", pov_shape_cone},
    {"disc", pov_shape_disc},
    {"torus", pov_shape_torus},
    {"triangle", pov_shape_triangle},
    {"smooth_triangle", pov_shape_triangle},
    {"polygon", pov_shape_polygon},
    {"mesh", pov_shape_mesh},
    {"mesh2", pov_shape_mesh2},
    {"union", pov_shape_union},
    {"merge", pov_shape_csg},
    {"object", pov_shape_object},
    {"light_source", pov_shape_light},
    {"intersection", pov_shape_csg},
    {"difference", pov_shape_csg},
    {"vbnl_mesh", pov_shape_vbnl_mesh},
    {"light_group", pov_shape_union},
    {"text", pov_shape_text},
    {"poly", pov_shape_poly},
    {"polynomial", pov_shape_poly},
    {"cubic", pov_shape_poly},
    {"quartic", pov_shape_poly},
    {"quadric", pov_shape_poly},
    {"isosurface", pov_shape_isosurface},
    {"parametric", pov_shape_parametric},
    {"lathe", pov_shape_lathe},
    {"sor", pov_shape_lathe},
    {"prism", pov_shape_prism},
    {"height_field", pov_shape_height_field},
    {"blob", pov_shape_blob},
    {"superellipsoid", pov_shape_superellipsoid},
    {"julia_fractal", pov_shape_julia},
    {"bicubic_patch", pov_shape_bicubic},
    {"ovus", pov_shape_ovus},
    {"lemon", pov_shape_ovus},
    {"sphere_sweep", pov_shape_sphere_sweep},
};

/* Parsed (their block skipped) and left out with a warning where they are placed. */
static const char *const unsupported[] = {NULL};

const pov_shape_row *pov_shape_find(const char *keyword)
{
    for (size_t i = 0; i < sizeof shapes / sizeof shapes[0]; ++i)
        if (strcmp(shapes[i].keyword, keyword) == 0)
            return &shapes[i];
    return NULL;
}

int pov_shape_unsupported(const char *keyword)
{
    for (size_t i = 0; unsupported[i]; ++i)
        if (strcmp(unsupported[i], keyword) == 0)
            return 1;
    return 0;
}

vbnl_result pov_shape_modifiers(const pov_shape *s)
{
    pov_mods m = {s->L, s->o, 1, 0, {0}, {0}};
    vbnl_result r = pov_mods_parse(&m, s->keyword, 0);
    if (r == VBNL_OK)
        r = pov_mods_finish(&m);
    pov_mods_clear(&m);
    return r;
}

vbnl_result pov_shape_add_mesh(const pov_shape *s, pov_mesh *m)
{
    if (!m)
        return pov_oom(s->L);
    pov_prim *pr = pov_obj_add(s->o, POV_PRIM_MESH, s->loc);
    if (!pr) {
        pov_mesh_unref(m);
        return pov_oom(s->L);
    }
    pr->mesh = m;
    return VBNL_OK;
}

vbnl_result pov_shape_vector_float(const pov_shape *s, double v[3], double *f)
{
    if (pov_vec3(s->L, v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(s->L);
    return pov_float(s->L, f);
}

vbnl_result pov_shape_add_analytic(const pov_shape *s, int kind, const double v[3], double f)
{
    pov_prim *pr = pov_obj_add(s->o, kind, s->loc);
    if (!pr)
        return pov_oom(s->L);
    pov_set3(pr->a, v[0], v[1], v[2]);
    pr->a[3] = f;
    return pov_shape_modifiers(s);
}
