/* vbnl object layer, texture part: normal { } (reference manual, "Normal"): a pattern and its
 * amount (`bumps 0.4`, `bump_size`), slope_map, normal_map, a block list of normals, bump_map,
 * average, accuracy, no_bump_scale; pattern modifiers and transforms. Read over the normal it
 * starts from (the #default's, a declared one, or none), as POV-Ray's Parse_Tnormal. */
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

static pov_normal *nrm_of(const pov_item *it) { return it->target; }

static void normal_transform(const pov_item *it, const double m[16])
{
    if (!pov_pattern_transform(&nrm_of(it)->pat, m))
        vbnl_sdl_error(it->p, &it->loc, "a pattern has at most %d warps and transforms", POV_WARP_MAX);
}

static vbnl_result float_of(const pov_item *it, double *v)
{
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_float(it->p, v);
}

static vbnl_result bump_size(const pov_item *it) { return float_of(it, &nrm_of(it)->amount); }

static vbnl_result accuracy(const pov_item *it)
{
    double v;
    if (float_of(it, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(v > 0.0))
        return vbnl_sdl_error(it->p, &it->loc, "accuracy must be > 0 (got %g)", v);
    nrm_of(it)->accuracy = (float)v;
    return VBNL_OK;
}

static vbnl_result flag(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    if (!strcmp(it->kw, "no_bump_scale"))
        nrm_of(it)->no_bump_scale = 1;
    else
        nrm_of(it)->uv_mapping = 1;
    return VBNL_OK;
}

static vbnl_result map(const pov_item *it)
{
    pov_normal *n = nrm_of(it);
    const int slope = !strcmp(it->kw, "slope_map");
    vbnl_sdl_next(it->p);
    if (pov_pattern_is_block(&n->pat) || n->kind == POV_NRM_IMAGE)
        return vbnl_sdl_error(it->p, &it->loc, "a %s cannot be used with this pattern", it->kw);
    if (slope)
        return pov_map_parse(it->ctx, &n->slopes, POV_MAP_SLOPE, 0);
    return pov_map_parse(it->ctx, &n->map, POV_MAP_NORMAL, n->kind == POV_NRM_AVERAGE);
}

static vbnl_result bump_map(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_bump_map_parse(it->ctx, nrm_of(it));
}

static vbnl_result average(const pov_item *it)
{
    pov_normal *n = nrm_of(it);
    vbnl_sdl_next(it->p);
    n->kind = POV_NRM_AVERAGE;
    n->pat.name = NULL;
    return VBNL_OK;
}

static const pov_row normal_rows[] = {
    {"bump_size", bump_size, 0},
    {"accuracy", accuracy, 0},
    {"no_bump_scale", flag, 0},
    {"uv_mapping", flag, 0},
    {"slope_map", map, 0},
    {"normal_map", map, 0},
    {"bump_map", bump_map, 0},
    {"average", average, 0},
    {NULL, NULL, 0},
};

static int pattern_modifier(const pov_item *it)
{
    return pov_row_dispatch(pov_pattern_modifier_rows, it->p, it->ctx, &nrm_of(it)->pat);
}

static int pattern(const pov_item *it)
{
    pov_normal *n = nrm_of(it);
    pov_pattern_target t = {&n->pat, &n->map, POV_MAP_NORMAL, &n->amount};
    int r = pov_pattern_keyword(it->ctx, &t);
    if (r > 0 && n->kind == POV_NRM_IMAGE)
        n->kind = POV_NRM_PATTERN;
    return r;
}

static const pov_row *const normal_tables[] = {pov_pattern_transform_rows, normal_rows, NULL};
static const pov_block normal_items = {.name = "normal",
                                       .tables = normal_tables,
                                       .before = pattern_modifier,
                                       .after = pattern,
                                       .unknown = pov_block_unexpected_word,
                                       .transform = normal_transform,
                                       .eof = "unexpected end of file in normal"};
static const pov_block normal_entry_items = {.name = "a normal_map entry",
                                             .tables = normal_tables,
                                             .before = pattern_modifier,
                                             .after = pattern,
                                             .unknown = pov_block_unexpected_word,
                                             .transform = normal_transform,
                                             .eof = "unexpected end of file in normal_map",
                                             .close = ']',
                                             .keep_close = 1};

static int copy_normal(void *dst, const void *src)
{
    pov_normal **d = dst;
    pov_normal *n = pov_normal_dup(src);
    if (!n)
        return 0;
    pov_normal_free(*d);
    *d = n;
    return 1;
}

vbnl_result pov_normal_body(pov_ctx *c, pov_normal **n, int close)
{
    if (pov_take_ident(c, &pov_type_normal, n, copy_normal) < 0)
        return VBNL_ERR_PARSE;
    if (!*n && !(*n = pov_normal_new()))
        return vbnl_sdl_error(c->parser, NULL, "out of memory");
    const pov_block *b = close == ']' ? &normal_entry_items : &normal_items;
    if (pov_block_parse(b, c->parser, c, *n, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_normal *nm = *n;
    /* POV-Ray's Perturb_Normal: a map of normals blends them, else the pattern's own perturbation */
    if (nm->kind == POV_NRM_PATTERN || nm->kind == POV_NRM_MAP)
        nm->kind = nm->map.count ? POV_NRM_MAP : POV_NRM_PATTERN;
    if (nm->kind == POV_NRM_AVERAGE && nm->map.count == 0)
        return vbnl_sdl_error(c->parser, NULL, "an average normal needs a normal_map");
    if (nm->kind == POV_NRM_PATTERN && !nm->pat.name) {
        /* POV-Ray refuses a normal without a pattern when the scene is rendered: here it is no normal */
        pov_normal_free(nm);
        *n = NULL;
    }
    return VBNL_OK;
}

vbnl_result pov_normal_parse(pov_ctx *c, pov_normal **n)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'normal'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_normal_body(c, n, '}');
}
