/* vbnl object layer, texture part: vbnl_bsdf { type items }, a core material given directly (a
 * vbnl extension inside texture { }, material { } or an object). It replaces the finish mapping;
 * values outside their ranges are errors. */
#include <math.h>
#include <string.h>

#include "pov_texture.h"

static vbnl_result bsdf_color(const pov_item *it) /* the keyword is part of the colour */
{
    pov_ext_bsdf *e = it->target;
    double v[3];
    if (pov_parse_color3(it->ctx, v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (int k = 0; k < 3; ++k) {
        if (!(v[k] >= 0.0 && v[k] <= 1.0))
            return vbnl_sdl_error(it->p, &it->loc, "vbnl_bsdf color components must lie in [0, 1]");
        e->desc.base_color[k] = (float)v[k];
    }
    e->has_color = 1;
    return VBNL_OK;
}

static vbnl_result bsdf_alpha_ior(const pov_item *it)
{
    pov_ext_bsdf *e = it->target;
    int alpha = !strcmp(it->kw, "alpha");
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (alpha && !(v >= 0.001 && v <= 1.0))
        return vbnl_sdl_error(it->p, &it->loc, "vbnl_bsdf alpha must lie in [0.001, 1] (got %g)", v);
    if (!alpha && !(v > 1.0 && v < 10.0))
        return vbnl_sdl_error(it->p, &it->loc, "vbnl_bsdf ior must lie in (1, 10) (got %g)", v);
    *(alpha ? &e->desc.alpha : &e->desc.ior) = (float)v;
    return VBNL_OK;
}

/* eta <v> and k <v> (the conductor's complex index: switches it from F0 to eta/k), emission <v> */
static vbnl_result bsdf_vector(const pov_item *it)
{
    pov_ext_bsdf *e = it->target;
    const char *kw = it->kw;
    double v[3];
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_vector(it->p, 3, v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    float *dst = !strcmp(kw, "eta") ? e->desc.eta : !strcmp(kw, "k") ? e->desc.k : e->desc.emission;
    for (int k = 0; k < 3; ++k) {
        if (!(v[k] >= 0.0) || !isfinite(v[k]) || (!strcmp(kw, "eta") && !(v[k] > 0.0)))
            return vbnl_sdl_error(it->p, &it->loc, "vbnl_bsdf %s components must be %s", kw, strcmp(kw, "eta") ? ">= 0" : "> 0");
        dst[k] = (float)v[k];
    }
    if (strcmp(kw, "emission"))
        e->desc.conductor_use_ior = 1;
    return VBNL_OK;
}

static vbnl_result bsdf_two_sided(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((pov_ext_bsdf *)it->target)->desc.two_sided = 1;
    return VBNL_OK;
}

static const pov_row bsdf_rows[] = {
    {"color", bsdf_color, 0},
    {"colour", bsdf_color, 0},
    {"alpha", bsdf_alpha_ior, 0},
    {"ior", bsdf_alpha_ior, 0},
    {"eta", bsdf_vector, 0},
    {"k", bsdf_vector, 0},
    {"emission", bsdf_vector, 0},
    {"two_sided", bsdf_two_sided, 0},
    {NULL, NULL, 0},
};
static const pov_row *const bsdf_tables[] = {bsdf_rows, NULL};
static const pov_block bsdf_items = {.name = "vbnl_bsdf (color alpha ior eta k emission two_sided)",
                                     .tables = bsdf_tables,
                                     .unknown = pov_block_unexpected_word};

vbnl_result pov_bsdf_parse(pov_ctx *c, pov_ext_bsdf *e)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'vbnl_bsdf'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_material_desc_init(&e->desc);
    e->set = 1;
    e->has_color = 0;
    /* the first word is the core type, in the order of vbnl_material_type */
    static const char *const types[] = {"lambert", "conductor", "plastic", "mirror", "dielectric"};
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    int found = -1;
    for (int i = 0; i < 5; ++i)
        if (pov_is_word(t, types[i]))
            found = i;
    if (found < 0)
        return vbnl_sdl_error(p, &t->loc, "vbnl_bsdf must start with lambert, conductor, plastic, mirror or dielectric (found '%s')",
                              t->text);
    vbnl_sdl_next(p);
    e->desc.type = (vbnl_material_type)found;
    return pov_block_parse(&bsdf_items, p, c, e, NULL);
}
