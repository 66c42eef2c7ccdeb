/* vbnl object layer, texture part: interior { } and material { texture interior vbnl_bsdf }. */
#include <string.h>

#include "pov_texture.h"

/* ---- interior { } ------------------------------------------------------------------------------ */

static vbnl_result ior(const pov_item *it)
{
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(v >= 1.0 && v < 10.0))
        return vbnl_sdl_error(it->p, &it->loc, "ior must lie in [1, 10) (got %g)", v);
    ((pov_interior *)it->target)->ior = v;
    return VBNL_OK;
}

static vbnl_result fade_color(const pov_item *it)
{
    double col[3];
    vbnl_sdl_next(it->p);
    if (pov_parse_color3(it->ctx, col) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(it->p, &it->loc, "interior fade (absorption) is not supported: ignored");
    return VBNL_OK;
}

static vbnl_result media(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_skip_block(it->p) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(it->p, &it->loc, "'media' is not supported: ignored");
    return VBNL_OK;
}

static int copy_interior(void *dst, const void *src)
{
    memcpy(dst, src, sizeof(pov_interior));
    return 1;
}

static const pov_row interior_rows[] = {
    {"ior", ior, 0},
    {"caustics", pov_item_any_float, 0},
    {"dispersion", pov_item_any_float, 0},
    {"dispersion_samples", pov_item_any_float, 0},
    {"fade_distance", pov_item_any_float, 0},
    {"fade_power", pov_item_any_float, 0},
    {"fade_color", fade_color, 0},
    {"fade_colour", fade_color, 0},
    {"media", media, 0},
    {NULL, NULL, 0},
};
static const pov_row *const interior_tables[] = {interior_rows, NULL};
static const pov_block interior_items = {.name = "interior",
                                         .tables = interior_tables,
                                         .unknown = pov_block_unexpected_word};

vbnl_result pov_interior_parse(pov_ctx *c, pov_interior *in)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'interior'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pov_take_ident(c, &pov_type_interior, in, copy_interior) < 0)
        return VBNL_ERR_PARSE;
    return pov_block_parse(&interior_items, c->parser, c, in, NULL);
}

/* ---- material { } ------------------------------------------------------------------------------ */

static vbnl_result mat_interior(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_interior_parse(it->ctx, &((pov_appearance *)it->target)->interior);
}

static vbnl_result mat_bsdf(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_bsdf_parse(it->ctx, &((pov_appearance *)it->target)->tex->ext);
}

/* POV-Ray's material transforms move its textures (Transform_Textures). */
static void mat_transform(const pov_item *it, const double m[16])
{
    pov_appearance *a = it->target;
    if (!pov_texture_transform(a->tex, m))
        vbnl_sdl_error(it->p, &it->loc, "a pattern has at most %d warps and transforms", POV_WARP_MAX);
}

static const pov_row material_rows[] = {
    {"texture", pov_appearance_texture_item, 0},
    {"interior", mat_interior, 0},
    {"vbnl_bsdf", mat_bsdf, 0},
    {NULL, NULL, 0},
};
static const pov_row *const material_tables[] = {material_rows, pov_pattern_transform_rows, NULL};
static const pov_block material_items = {.name = "material",
                                         .tables = material_tables,
                                         .unknown = pov_block_unexpected_word,
                                         .transform = mat_transform};

static int copy_material(void *dst, const void *src)
{
    pov_appearance *a = dst;
    const pov_appearance *m = src;
    pov_texture *t = m->tex ? pov_texture_dup(m->tex) : NULL;
    if (m->tex && !t)
        return 0;
    pov_texture_free(a->tex);
    a->tex = t;
    a->interior = m->interior;
    a->own_texture = 1;
    return 1;
}

vbnl_result pov_material_parse(pov_ctx *c, pov_appearance *a)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'material'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    /* POV-Ray's material starts over: its first texture replaces the object's */
    int had = a->own_texture;
    a->own_texture = 0;
    if (pov_take_ident(c, &pov_type_material, a, copy_material) < 0)
        return VBNL_ERR_PARSE;
    vbnl_result r = pov_block_parse(&material_items, c->parser, c, a, NULL);
    a->own_texture |= had;
    return r;
}
