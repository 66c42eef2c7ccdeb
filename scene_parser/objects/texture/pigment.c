/* vbnl object layer, texture part: pigment { } (reference manual, "Pigment"): a colour, a
 * pattern with a colour map, a pigment map or a list, an image_map, an average; pattern
 * modifiers and transforms. Read over the pigment it starts from (a copy of the #default's, or of
 * a declared pigment), as POV-Ray's Parse_Pigment reads over its argument. */
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

static pov_pigment *pig_of(const pov_item *it) { return it->target; }

static void pigment_transform(const pov_item *it, const double m[16])
{
    if (!pov_pattern_transform(&pig_of(it)->pat, m))
        vbnl_sdl_error(it->p, &it->loc, "a pattern has at most %d warps and transforms", POV_WARP_MAX);
}

static vbnl_result image_map(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_image_map_parse(it->ctx, pig_of(it));
}

static vbnl_result color_map(const pov_item *it)
{
    pov_pigment *g = pig_of(it);
    vbnl_sdl_next(it->p);
    if (pov_pattern_is_block(&g->pat) || g->kind == POV_PIG_IMAGE || g->kind == POV_PIG_AVERAGE)
        return vbnl_sdl_error(it->p, &it->loc, "a color_map cannot be used with this pattern");
    return pov_map_parse(it->ctx, &g->map, POV_MAP_COLOR, 0);
}

static vbnl_result pigment_map(const pov_item *it)
{
    pov_pigment *g = pig_of(it);
    vbnl_sdl_next(it->p);
    if (pov_pattern_is_block(&g->pat) || g->kind == POV_PIG_IMAGE)
        return vbnl_sdl_error(it->p, &it->loc, "a pigment_map cannot be used with this pattern");
    return pov_map_parse(it->ctx, &g->map, POV_MAP_PIGMENT, g->kind == POV_PIG_AVERAGE);
}

static vbnl_result uv_mapping(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    pig_of(it)->uv_mapping = 1;
    return VBNL_OK;
}

static vbnl_result average(const pov_item *it)
{
    pov_pigment *g = pig_of(it);
    vbnl_sdl_next(it->p);
    g->kind = POV_PIG_AVERAGE;
    g->pat.name = NULL;
    return VBNL_OK;
}

static const pov_row pigment_rows[] = {
    {"image_map", image_map, 0},
    {"color_map", color_map, 0},
    {"colour_map", color_map, 0},
    {"pigment_map", pigment_map, 0},
    {"uv_mapping", uv_mapping, 0},
    {"average", average, 0},
    {NULL, NULL, 0},
};

static int pattern_modifier(const pov_item *it)
{
    return pov_row_dispatch(pov_pattern_modifier_rows, it->p, it->ctx, &pig_of(it)->pat);
}

/* A pattern keyword, else a colour (color / rgb... / a colour expression). */
static int pattern_or_color(const pov_item *it)
{
    pov_pigment *g = pig_of(it);
    pov_pattern_target t = {&g->pat, &g->map, POV_MAP_COLOR, NULL};
    int r = pov_pattern_keyword(it->ctx, &t);
    if (r != 0) {
        if (r > 0 && g->kind != POV_PIG_AVERAGE)
            g->kind = POV_PIG_MAP;
        return r;
    }
    if (vbnl_sdl_parse_color(it->p, g->color) != VBNL_OK)
        return -1;
    g->kind = POV_PIG_SOLID;
    return 1;
}

static const pov_row *const pigment_tables[] = {pov_pattern_transform_rows, pigment_rows, NULL};
static const pov_block pigment_items = {.name = "pigment",
                                        .tables = pigment_tables,
                                        .before = pattern_modifier,
                                        .after = pattern_or_color,
                                        .transform = pigment_transform,
                                        .eof = "unexpected end of file in pigment"};
static const pov_block pigment_entry_items = {.name = "a pigment_map entry",
                                              .tables = pigment_tables,
                                              .before = pattern_modifier,
                                              .after = pattern_or_color,
                                              .transform = pigment_transform,
                                              .eof = "unexpected end of file in pigment_map",
                                              .close = ']',
                                              .keep_close = 1};

static int copy_pigment(void *dst, const void *src)
{
    pov_pigment *d = pov_pigment_dup(src);
    if (!d)
        return 0;
    pov_pigment *g = dst;
    pov_pigment_clear(g);
    *g = *d;
    free(d);
    return 1;
}

/* A pigment's (or density's) items through block b, over a declared value it may start with. */
static vbnl_result body(pov_ctx *c, pov_pigment *pg, const pov_block *b, const char *what)
{
    if (pov_take_ident(c, &pov_type_pigment, pg, copy_pigment) < 0)
        return VBNL_ERR_PARSE;
    if (pov_block_parse(b, c->parser, c, pg, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pg->kind == POV_PIG_AVERAGE && pg->map.count == 0)
        return vbnl_sdl_error(c->parser, NULL, "an average %s needs a %s_map", what, what);
    if (pg->kind == POV_PIG_MAP && !pg->pat.name)
        pg->kind = POV_PIG_SOLID; /* modifiers without a pattern: POV-Ray's pigment stays a colour */
    return VBNL_OK;
}

vbnl_result pov_pigment_body(pov_ctx *c, pov_pigment *pg, int close)
{
    return body(c, pg, close == ']' ? &pigment_entry_items : &pigment_items, "pigment");
}

/* density { } (reference "Density"): a pigment's pattern, colour_map and transforms, and
 * density_map (a pigment_map of densities). A declared density is a pigment value. */
static const pov_row density_rows[] = {
    {"density_map", pigment_map, 0},
    {NULL, NULL, 0},
};
static const pov_row *const density_tables[] = {pov_pattern_transform_rows, pigment_rows, density_rows, NULL};
static const pov_block density_items = {.name = "density",
                                        .tables = density_tables,
                                        .before = pattern_modifier,
                                        .after = pattern_or_color,
                                        .transform = pigment_transform,
                                        .eof = "unexpected end of file in density"};

vbnl_result pov_density_body(pov_ctx *c, pov_pigment *pg)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'density'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    return body(c, pg, &density_items, "density");
}

vbnl_result pov_pigment_parse(pov_ctx *c, pov_pigment *pg)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'pigment'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_pigment_body(c, pg, '}');
}
