/* vbnl object layer, texture part: pigment { }. Solid colours, checker, gradient, brick and
 * image_map become what the core renders; other patterns their colour map's average. */
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

void pov_pigment_init(pov_pigment *p)
{
    memset(p, 0, sizeof(*p));
    p->kind = POV_PIG_SOLID; /* POV-Ray's default pigment: black */
    p->gradient[0] = 1.0;
    p->brick_size[0] = 8.0;
    p->brick_size[1] = 3.0;
    p->brick_size[2] = 4.5;
    p->mortar = 0.5;
    p->frequency = 1.0;
    p->image = -1;
    pov_m4_identity(p->xf);
}

/* The words a colour may start with. */
static int is_color_word(const vbnl_sdl_token *t)
{
    static const char *const words[] = {"color", "colour", "rgb", "rgbf", "rgbt", "rgbft", "srgb", "srgbf",
                                        "srgbt", "srgbft", "red", "green", "blue", NULL};
    for (int i = 0; t->kind == VBNL_SDL_TOK_IDENT && words[i]; ++i)
        if (!strcmp(t->text, words[i]))
            return 1;
    return 0;
}

/* A pigment list entry (`checker pigment { A } pigment { B }`) gives its representative colour. */
vbnl_result pov_block_colors(pov_ctx *c, pov_pigment *pg, int max)
{
    vbnl_sdl_parser *p = c->parser;
    int n = 0;
    for (; n < max; ++n) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        int starts = is_color_word(t) || pov_is_punct(t, '<');
        if (!starts && t->kind == VBNL_SDL_TOK_IDENT) {
            const vbnl_sdl_value *v = vbnl_sdl_lookup(p, t->text);
            starts = v && (v->kind == VBNL_SDL_COLOR || v->kind == VBNL_SDL_VECTOR);
        }
        if (pov_is_word(t, "pigment")) {
            /* a pigment list entry: its representative colour */
            vbnl_sdl_loc loc = t->loc;
            vbnl_sdl_next(p);
            if (c->tex->depth >= POV_NEST_MAX)
                return vbnl_sdl_error(p, &loc, "pigments nested more than 64 deep");
            pov_pigment *sub = malloc(sizeof(*sub));
            if (!sub)
                return vbnl_sdl_error(p, &loc, "out of memory");
            pov_pigment_init(sub);
            c->tex->depth++;
            vbnl_result r = pov_pigment_parse(c, sub);
            c->tex->depth--;
            if (r == VBNL_OK) {
                if (sub->kind == POV_PIG_SOLID)
                    memcpy(pg->map.e[n].color, sub->color, sizeof(sub->color));
                else
                    pov_color_map_average(&sub->map, pg->map.e[n].color);
                if (sub->kind != POV_PIG_SOLID)
                    vbnl_sdl_warning(p, &loc, "a patterned pigment inside a pattern's list is replaced by its average colour");
            }
            free(sub);
            if (r != VBNL_OK)
                return r;
            pg->map.e[n].value = (double)n;
            vbnl_sdl_accept(p, ',');
            continue;
        }
        if (!starts)
            break;
        if (vbnl_sdl_parse_color(p, pg->map.e[n].color) != VBNL_OK)
            return VBNL_ERR_PARSE;
        pg->map.e[n].value = (double)n;
        vbnl_sdl_accept(p, ',');
    }
    if (n > 0)
        pg->map.count = (uint32_t)n;
    return VBNL_OK;
}

/* ---- pigment { } ------------------------------------------------------------------------------- */

typedef struct pigment_block {
    pov_ctx *c;
    pov_pigment *pg;
    const char *fallback; /* the last pattern rendered as an average, NULL after a solid colour */
    vbnl_sdl_loc fallback_loc;
} pigment_block;

static pov_pigment *pigment_of(const pov_item *it) { return ((pigment_block *)it->target)->pg; }

static void pigment_transform(const pov_item *it, const double m[16])
{
    pov_pigment *pg = pigment_of(it);
    pov_m4_mul(m, pg->xf, pg->xf);
}

static vbnl_result checker_brick(const pov_item *it)
{
    pov_pigment *pg = pigment_of(it);
    int brick = !strcmp(it->kw, "brick");
    vbnl_sdl_next(it->p);
    pg->kind = brick ? POV_PIG_BRICK : POV_PIG_CHECKER;
    /* POV-Ray's defaults: checker blue / green, brick grey mortar / red bricks */
    pov_map_entry d0 = {0.0, {0, 0, 1, 0, 0}}, d1 = {1.0, {0, 1, 0, 0, 0}};
    if (brick) {
        d0 = (pov_map_entry){0.0, {0.5, 0.5, 0.5, 0, 0}};
        d1 = (pov_map_entry){1.0, {0.6, 0.15, 0.15, 0, 0}};
    }
    pg->map.count = 2;
    pg->map.e[0] = d0;
    pg->map.e[1] = d1;
    if (pov_block_colors(it->ctx, pg, 2) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pg->map.count == 1) {
        pg->map.e[1] = d1;
        pg->map.count = 2;
    }
    return VBNL_OK;
}

static vbnl_result gradient(const pov_item *it)
{
    pov_pigment *pg = pigment_of(it);
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_vector(it->p, 3, pg->gradient) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pg->gradient[0] == 0.0 && pg->gradient[1] == 0.0 && pg->gradient[2] == 0.0)
        return vbnl_sdl_error(it->p, &it->loc, "gradient needs a non-zero vector");
    pg->kind = POV_PIG_GRADIENT;
    return VBNL_OK;
}

static vbnl_result image_map(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_image_map_parse(it->ctx, pigment_of(it));
}

static vbnl_result color_map(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_color_map_parse(it->ctx, &pigment_of(it)->map);
}

static vbnl_result mortar(const pov_item *it)
{
    pov_pigment *pg = pigment_of(it);
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &pg->mortar) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(pg->mortar >= 0.0))
        return vbnl_sdl_error(it->p, &it->loc, "mortar must be >= 0");
    return VBNL_OK;
}

static vbnl_result brick_size(const pov_item *it)
{
    pov_pigment *pg = pigment_of(it);
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_vector(it->p, 3, pg->brick_size) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(pg->brick_size[0] > 0 && pg->brick_size[1] > 0 && pg->brick_size[2] > 0))
        return vbnl_sdl_error(it->p, &it->loc, "brick_size components must be > 0");
    return VBNL_OK;
}

static vbnl_result uv_mapping(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    pigment_of(it)->uv_mapping = 1;
    return VBNL_OK;
}

static vbnl_result pigment_map(const pov_item *it)
{
    pigment_block *b = it->target;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_skip_block(it->p) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(it->p, &it->loc, "'pigment_map' is not supported: using the colour map's average (grey without one)");
    b->fallback = "pigment_map";
    b->fallback_loc = it->loc;
    return VBNL_OK;
}

static const pov_row pigment_rows[] = {
    {"checker", checker_brick, 0},
    {"brick", checker_brick, 0},
    {"gradient", gradient, 0},
    {"image_map", image_map, 0},
    {"color_map", color_map, 0},
    {"colour_map", color_map, 0},
    {"mortar", mortar, 0},
    {"brick_size", brick_size, 0},
    {"uv_mapping", uv_mapping, 0},
    {"pigment_map", pigment_map, 0},
    {"color_map_bump", pigment_map, 0},
    {NULL, NULL, 0},
};

static int pattern_modifier(const pov_item *it)
{
    return pov_row_dispatch(pov_pattern_modifier_rows, it->p, it->ctx, pigment_of(it));
}

/* A pattern rendered as an average, else a solid colour (color / rgb... / a colour expression). */
static int pattern_or_color(const pov_item *it)
{
    pigment_block *b = it->target;
    if (pov_is_fallback_pattern(it->tok)) {
        b->fallback = it->tok->text;
        b->fallback_loc = it->loc;
        vbnl_sdl_next(it->p);
        if (pov_pattern_args(it->ctx, b->pg, b->fallback) != VBNL_OK)
            return -1;
        b->pg->kind = POV_PIG_SOLID;
        return 1;
    }
    if (vbnl_sdl_parse_color(it->p, b->pg->color) != VBNL_OK)
        return -1;
    b->pg->kind = POV_PIG_SOLID;
    b->fallback = NULL;
    return 1;
}

static const pov_row *const pigment_tables[] = {pov_pattern_transform_rows, pigment_rows, NULL};
static const pov_block pigment_items = {.name = "pigment",
                                        .tables = pigment_tables,
                                        .before = pattern_modifier,
                                        .after = pattern_or_color,
                                        .transform = pigment_transform,
                                        .eof = "unexpected end of file in pigment"};

vbnl_result pov_pigment_parse(pov_ctx *c, pov_pigment *pg)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'pigment'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pov_take_ident(c, &pov_type_pigment, pg, sizeof *pg) < 0)
        return VBNL_ERR_PARSE;
    pigment_block b = {c, pg, NULL, {0}};
    if (pov_block_parse(&pigment_items, p, c, &b, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (b.fallback) {
        if (pg->map.count == 0)
            pov_default_color_map(b.fallback, &pg->map);
        if (pov_discrete_pattern(b.fallback)) {
            /* block patterns: every colour covers the same share of space */
            memset(pg->color, 0, sizeof(pg->color));
            for (uint32_t i = 0; i < pg->map.count; ++i)
                for (int k = 0; k < 5; ++k)
                    pg->color[k] += pg->map.e[i].color[k] / pg->map.count;
        } else {
            pov_color_map_average(&pg->map, pg->color);
        }
        pg->kind = POV_PIG_SOLID;
        vbnl_sdl_warning(p, &b.fallback_loc,
                         "pattern '%s' is not supported: using the average colour of its colour map (%.3g %.3g %.3g)",
                         b.fallback, pg->color[0], pg->color[1], pg->color[2]);
    }
    if (pg->kind == POV_PIG_GRADIENT && pg->map.count == 0) {
        /* POV-Ray's default map for a pattern without one: black to white is the plain ramp */
        pg->map.count = 2;
        pg->map.e[0] = (pov_map_entry){0.0, {0, 0, 0, 0, 0}};
        pg->map.e[1] = (pov_map_entry){1.0, {1, 1, 1, 0, 0}};
    }
    return VBNL_OK;
}
