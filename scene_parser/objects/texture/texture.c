/* vbnl object layer, texture part: texture { }, the items a texture holds, texture patterns and
 * texture_map, and layered textures. */
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

void pov_texture_init(pov_texture *t)
{
    memset(t, 0, sizeof(*t));
    pov_pigment_init(&t->pig);
    pov_finish_init(&t->fin);
}

/* Layered textures (POV-Ray shows lower layers through the transparent parts of upper ones) are
 * rendered as one layer: the next layer replaces the one below unless its pigment is mostly
 * transparent (filter + transmit >= 0.5 on average), as the top layers of stones.inc are. */
void pov_texture_put_layer(pov_texture *below, const pov_texture *above)
{
    if (pov_pigment_transparency(&above->pig) < 0.5)
        *below = *above;
}

/* ---- texture, pigment finish normal vbnl_bsdf uv_mapping ------------------------------------------ */

static vbnl_result item_pigment(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_pigment_parse(it->ctx, &((pov_texture *)it->target)->pig);
}

static vbnl_result item_finish(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_finish_parse(it->ctx, &((pov_texture *)it->target)->fin);
}

static vbnl_result item_normal(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_normal_parse(it->ctx, &it->loc);
}

static vbnl_result item_bsdf(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_bsdf_parse(it->ctx, &((pov_texture *)it->target)->ext);
}

static vbnl_result item_uv_mapping(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((pov_texture *)it->target)->pig.uv_mapping = 1;
    return VBNL_OK;
}

static vbnl_result item_texture(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_texture_parse(it->ctx, it->target);
}

const pov_row pov_texture_rows[] = {{"texture", item_texture, 0}, {NULL, NULL, 0}};

const pov_row pov_texture_item_rows[] = {
    {"pigment", item_pigment, 0},
    {"finish", item_finish, 0},
    {"normal", item_normal, 0},
    {"vbnl_bsdf", item_bsdf, 0},
    {"uv_mapping", item_uv_mapping, 0},
    {NULL, NULL, 0},
};

/* ---- texture patterns -------------------------------------------------------------------------- */

/* `texture { checker texture {A} texture {B} }`, `texture { gradient y texture_map { ... } }`:
 * parsed in full; the first texture of the list or map is used, with a warning, as texture
 * layers are not blended per point here. */
typedef struct texture_pattern {
    pov_texture *tx;
    pov_pigment *scratch; /* the pattern's own modifiers */
    pov_texture *entry;   /* a texture of the list or map */
    int have;             /* the first texture was taken */
    double xf[16];        /* the pattern's transforms */
} texture_pattern;

static void take_first(texture_pattern *tp)
{
    if (!tp->have) {
        *tp->tx = *tp->entry;
        tp->have = 1;
    }
}

static int map_entry_texture(const pov_item *it)
{
    return pov_take_ident(it->ctx, &pov_type_texture, it->target, sizeof(pov_texture));
}

static const pov_row *const map_entry_tables[] = {pov_texture_rows, pov_texture_item_rows, NULL};
/* [value texture-identifier | texture { } | pigment/finish/normal items] */
static const pov_block map_entry_items = {.name = "a texture_map entry",
                                          .tables = map_entry_tables,
                                          .before = map_entry_texture,
                                          .unknown = pov_block_unexpected_word,
                                          .eof = "unexpected end of file in texture_map",
                                          .close = ']'};

/* One texture_map entry into tp->entry; its value (or two) is read and dropped. */
static int map_entry(const pov_item *it)
{
    texture_pattern *tp = it->target;
    vbnl_sdl_parser *p = it->p;
    double v;
    if (vbnl_sdl_expect(p, '[', "to start a texture_map entry") != VBNL_OK || vbnl_sdl_parse_float(p, &v) != VBNL_OK)
        return -1;
    if (vbnl_sdl_accept(p, ',')) {
        const vbnl_sdl_token *n = vbnl_sdl_peek(p);
        const vbnl_sdl_value *nv = n->kind == VBNL_SDL_TOK_IDENT ? vbnl_sdl_lookup(p, n->text) : NULL;
        if ((n->kind == VBNL_SDL_TOK_NUMBER || (nv && nv->kind == VBNL_SDL_FLOAT)) && vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return -1;
    }
    pov_texture_init(tp->entry);
    if (pov_block_parse(&map_entry_items, p, it->ctx, tp->entry, NULL) != VBNL_OK)
        return -1;
    take_first(tp);
    return 1;
}

static const pov_block texture_map_items = {.name = "texture_map", .after = map_entry};

static vbnl_result tp_texture(const pov_item *it)
{
    texture_pattern *tp = it->target;
    vbnl_sdl_next(it->p);
    pov_texture_init(tp->entry);
    vbnl_result r = pov_texture_parse(it->ctx, tp->entry);
    if (r == VBNL_OK)
        take_first(tp);
    vbnl_sdl_accept(it->p, ',');
    return r;
}

static vbnl_result tp_texture_map(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_expect(it->p, '{', "after 'texture_map'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_block_parse(&texture_map_items, it->p, it->ctx, it->target, NULL);
}

static int tp_modifier(const pov_item *it)
{
    return pov_row_dispatch(pov_pattern_modifier_rows, it->p, it->ctx, ((texture_pattern *)it->target)->scratch);
}

static void tp_transform(const pov_item *it, const double m[16])
{
    texture_pattern *tp = it->target;
    pov_m4_mul(m, tp->xf, tp->xf);
}

static const pov_row texture_pattern_rows[] = {
    {"texture", tp_texture, 0},
    {"texture_map", tp_texture_map, 0},
    {"brick_size", pov_item_any_vec3, 0},
    {"mortar", pov_item_any_float, 0},
    {NULL, NULL, 0},
};
static const pov_row *const texture_pattern_tables[] = {texture_pattern_rows, pov_pattern_transform_rows, NULL};
/* The rest of the texture after the pattern keyword; the texture's own block closes it. */
static const pov_block texture_pattern_items = {.name = "a patterned texture",
                                                .tables = texture_pattern_tables,
                                                .before = tp_modifier,
                                                .unknown = pov_block_unexpected_word,
                                                .transform = tp_transform,
                                                .eof = "unexpected end of file in texture",
                                                .keep_close = 1};

/* After the pattern keyword `name` at ploc. */
static vbnl_result texture_pattern_parse(pov_ctx *c, pov_texture *tx, const char *name, const vbnl_sdl_loc *ploc)
{
    vbnl_sdl_parser *p = c->parser;
    texture_pattern tp = {tx, malloc(sizeof(pov_pigment)), malloc(sizeof(pov_texture)), 0, {0}};
    vbnl_result r = tp.scratch && tp.entry ? VBNL_OK : vbnl_sdl_error(p, ploc, "out of memory");
    pov_m4_identity(tp.xf);
    if (r == VBNL_OK) {
        pov_pigment_init(tp.scratch);
        r = pov_pattern_args(c, NULL, name);
    }
    if (r == VBNL_OK)
        r = pov_block_parse(&texture_pattern_items, p, c, &tp, NULL);
    if (r == VBNL_OK) {
        pov_m4_mul(tp.xf, tx->pig.xf, tx->pig.xf);
        vbnl_sdl_warning(p, ploc,
                         tp.have ? "texture pattern '%s' is not supported: its first texture is used everywhere"
                                 : "texture pattern '%s' is not supported and lists no texture: ignored",
                         name);
    }
    free(tp.scratch);
    free(tp.entry);
    return r;
}

/* ---- texture { } ------------------------------------------------------------------------------- */

static int pattern(const pov_item *it)
{
    if (!pov_is_pattern(it->tok))
        return 0;
    pov_ctx *c = it->ctx;
    const char *name = it->tok->text;
    vbnl_sdl_next(it->p);
    if (c->tex->depth >= POV_NEST_MAX) {
        vbnl_sdl_error(it->p, &it->loc, "textures nested more than 64 deep");
        return -1;
    }
    c->tex->depth++;
    vbnl_result r = texture_pattern_parse(c, it->target, name, &it->loc);
    c->tex->depth--;
    return r == VBNL_OK ? 1 : -1;
}

static vbnl_result not_supported(const pov_item *it)
{
    return vbnl_sdl_error(it->p, &it->loc, "'%s' is not supported", it->kw);
}

static void texture_transform(const pov_item *it, const double m[16])
{
    pov_texture *tx = it->target;
    pov_m4_mul(m, tx->pig.xf, tx->pig.xf);
}

static const pov_row unsupported_rows[] = {{"material_map", not_supported, 0}, {"tiles", not_supported, 0}, {NULL, NULL, 0}};
static const pov_row *const texture_tables[] = {pov_texture_item_rows, pov_pattern_transform_rows, unsupported_rows, NULL};
static const pov_block texture_items = {.name = "texture",
                                        .tables = texture_tables,
                                        .after = pattern,
                                        .unknown = pov_block_unexpected_word,
                                        .transform = texture_transform,
                                        .eof = "unexpected end of file in texture"};

vbnl_result pov_texture_parse(pov_ctx *c, pov_texture *tx)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'texture'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pov_take_ident(c, &pov_type_texture, tx, sizeof *tx) < 0)
        return VBNL_ERR_PARSE;
    return pov_block_parse(&texture_items, c->parser, c, tx, NULL);
}
