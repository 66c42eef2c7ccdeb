/* vbnl object layer, texture part: texture { } (reference manual, "Texture", "Patterned
 * Textures", "Layered Textures"), as POV-Ray's Parse_Texture: a texture starts from a declared
 * texture or a copy of the #default one; a plain texture takes pigment, normal and finish items
 * (and declared ones) and transforms; otherwise it is a pattern with a texture_map or a list of
 * textures, `tiles`, a `material_map` or an `average`. */
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

typedef struct tex_block {
    pov_texture **tx;   /* the stack being read; (*tx) is its top layer */
} tex_block;

static pov_texture *top(const pov_item *it) { return *((tex_block *)it->target)->tx; }

/* ---- the items of a plain texture (also directly in objects) ------------------------------------ */

static vbnl_result item_pigment(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    pov_texture *t = *(pov_texture **)it->target;
    return pov_pigment_parse(it->ctx, t->pig);
}

static vbnl_result item_finish(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_finish_parse(it->ctx, &(*(pov_texture **)it->target)->fin);
}

static vbnl_result item_normal(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_normal_parse(it->ctx, &(*(pov_texture **)it->target)->nrm);
}

static vbnl_result item_bsdf(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_bsdf_parse(it->ctx, &(*(pov_texture **)it->target)->ext);
}

static vbnl_result item_uv_mapping(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    (*(pov_texture **)it->target)->uv_mapping = 1;
    return VBNL_OK;
}

/* The target of these rows is a pov_texture ** (the texture's top layer). */
const pov_row pov_texture_item_rows[] = {
    {"pigment", item_pigment, 0},
    {"finish", item_finish, 0},
    {"normal", item_normal, 0},
    {"vbnl_bsdf", item_bsdf, 0},
    {"uv_mapping", item_uv_mapping, 0},
    {NULL, NULL, 0},
};

/* ---- patterned textures ------------------------------------------------------------------------- */

static vbnl_result texture_map(const pov_item *it)
{
    pov_texture *t = top(it);
    vbnl_sdl_next(it->p);
    if (t->kind == POV_TEX_PLAIN || pov_pattern_is_block(&t->pat) || t->kind == POV_TEX_MATERIAL_MAP)
        return vbnl_sdl_error(it->p, &it->loc, "a texture_map needs a pattern that takes one (gradient, bozo, ...)");
    return pov_map_parse(it->ctx, &t->map, POV_MAP_TEXTURE, t->kind == POV_TEX_AVERAGE);
}

/* tiles { texture { } ... tile2 texture { } ... }: a checker of the two (layered) textures; the
 * first tile is the checker's 1, as POV-Ray's Parse_Tiles has it. */
static vbnl_result tiles(const pov_item *it)
{
    pov_ctx *c = it->ctx;
    vbnl_sdl_parser *p = it->p;
    pov_texture *t = top(it);
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '{', "after 'tiles'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_texture *tile[2] = {NULL, NULL};
    for (int k = 0; k < 2; ++k) {
        if (k == 1) {
            const vbnl_sdl_token *n = vbnl_sdl_peek(p);
            if (!pov_is_word(n, "tile2")) {
                pov_texture_free(tile[0]);
                return vbnl_sdl_error(p, &n->loc, "expected 'tile2' in tiles");
            }
            vbnl_sdl_next(p);
        }
        while (pov_is_word(vbnl_sdl_peek(p), "texture")) {
            vbnl_sdl_next(p);
            pov_texture *layer = NULL;
            if (pov_texture_parse(c, &layer) != VBNL_OK) {
                pov_texture_free(layer);
                pov_texture_free(tile[0]);
                pov_texture_free(tile[1]);
                return VBNL_ERR_PARSE;
            }
            pov_texture_put_layer(&tile[k], layer);
        }
    }
    if (vbnl_sdl_expect(p, '}', "to close tiles") != VBNL_OK || !tile[0]) {
        if (!tile[0])
            vbnl_sdl_error(p, &it->loc, "the first texture is missing from tiles");
        pov_texture_free(tile[0]);
        pov_texture_free(tile[1]);
        return VBNL_ERR_PARSE;
    }
    if (!tile[1])
        tile[1] = pov_texture_dup(c->tex->deflt.tex);
    pov_pattern_init(&t->pat);
    t->kind = POV_TEX_MAP;
    t->pat.d.kind = VBNL_PATTERN_CHECKER;
    t->pat.name = "checker";
    t->pat.d.frequency = 0.0f;
    pov_map_free(&t->map);
    t->map.kind = POV_MAP_TEXTURE;
    for (int k = 0; k < 2; ++k) {
        pov_map_entry *e = pov_map_add(&t->map);
        e->value = k;
        e->sub = tile[1 - k];
    }
    return VBNL_OK;
}

static vbnl_result material_map(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    pov_texture *t = top(it);
    t->kind = POV_TEX_MATERIAL_MAP;
    return pov_material_map_parse(it->ctx, t);
}

static vbnl_result average(const pov_item *it)
{
    pov_texture *t = top(it);
    vbnl_sdl_next(it->p);
    t->kind = POV_TEX_AVERAGE;
    t->pat.name = NULL;
    return VBNL_OK;
}

/* pigment / normal / finish identifiers stand for their block (POV-Ray's old syntax) */
static int copy_pigment(void *dst, const void *src)
{
    pov_pigment **g = dst, *d = pov_pigment_dup(src);
    if (!d)
        return 0;
    pov_pigment_free(*g);
    *g = d;
    return 1;
}
static int copy_normal(void *dst, const void *src)
{
    pov_normal **n = dst, *d = pov_normal_dup(src);
    if (!d)
        return 0;
    pov_normal_free(*n);
    *n = d;
    return 1;
}
static int copy_finish(void *dst, const void *src)
{
    memcpy(dst, src, sizeof(pov_finish));
    return 1;
}

/* A declared pigment, normal or finish, else a pattern keyword (a patterned texture). */
static int ident_or_pattern(const pov_item *it)
{
    pov_ctx *c = it->ctx;
    pov_texture *t = top(it);
    int r;
    if ((r = pov_take_ident(c, &pov_type_pigment, &t->pig, copy_pigment)) != 0 ||
        (r = pov_take_ident(c, &pov_type_normal, &t->nrm, copy_normal)) != 0 ||
        (r = pov_take_ident(c, &pov_type_finish, &t->fin, copy_finish)) != 0)
        return r;
    pov_pattern_target pt = {&t->pat, &t->map, POV_MAP_TEXTURE, NULL};
    if (t->kind == POV_TEX_PLAIN)
        pov_pattern_init(&t->pat);
    r = pov_pattern_keyword(c, &pt);
    if (r > 0 && t->kind != POV_TEX_AVERAGE)
        t->kind = POV_TEX_MAP;
    return r;
}

static int pattern_modifier(const pov_item *it)
{
    pov_texture *t = top(it);
    if (t->kind == POV_TEX_PLAIN)
        return 0;
    return pov_row_dispatch(pov_pattern_modifier_rows, it->p, it->ctx, &t->pat);
}

static void texture_transform(const pov_item *it, const double m[16])
{
    if (!pov_texture_transform(top(it), m))
        vbnl_sdl_error(it->p, &it->loc, "a pattern has at most %d warps and transforms", POV_WARP_MAX);
}

/* The items of a plain texture work on its top layer: the rows get the tex_block's pointer. */
static int plain_item(const pov_item *it)
{
    return pov_row_dispatch(pov_texture_item_rows, it->p, it->ctx, ((tex_block *)it->target)->tx);
}

static int before(const pov_item *it)
{
    int r = plain_item(it);
    return r ? r : pattern_modifier(it);
}

static const pov_row texture_rows[] = {
    {"texture_map", texture_map, 0},
    {"tiles", tiles, 0},
    {"material_map", material_map, 0},
    {"average", average, 0},
    {NULL, NULL, 0},
};
static const pov_row *const texture_tables[] = {pov_pattern_transform_rows, texture_rows, NULL};
static const pov_block texture_items = {.name = "texture",
                                        .tables = texture_tables,
                                        .before = before,
                                        .after = ident_or_pattern,
                                        .unknown = pov_block_unexpected_word,
                                        .transform = texture_transform,
                                        .eof = "unexpected end of file in texture"};
static const pov_block texture_entry_items = {.name = "a texture_map entry",
                                              .tables = texture_tables,
                                              .before = before,
                                              .after = ident_or_pattern,
                                              .unknown = pov_block_unexpected_word,
                                              .transform = texture_transform,
                                              .eof = "unexpected end of file in texture_map",
                                              .close = ']',
                                              .keep_close = 1};

static int copy_texture(void *dst, const void *src)
{
    pov_texture **t = dst, *d = pov_texture_dup(src);
    if (!d)
        return 0;
    pov_texture_free(*t);
    *t = d;
    return 1;
}

vbnl_result pov_texture_body(pov_ctx *c, pov_texture **tx, int close)
{
    vbnl_sdl_parser *p = c->parser;
    int r = pov_take_ident(c, &pov_type_texture, tx, copy_texture);
    if (r < 0)
        return VBNL_ERR_PARSE;
    if (r == 0) { /* a texture starts from the #default one (POV-Ray's Parse_Texture) */
        pov_texture_free(*tx);
        if (!(*tx = pov_texture_dup(c->tex->deflt.tex)))
            return vbnl_sdl_error(p, NULL, "out of memory");
    }
    tex_block b = {tx};
    if (pov_block_parse(close == ']' ? &texture_entry_items : &texture_items, p, c, &b, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_texture *t = *tx;
    if (t->kind == POV_TEX_AVERAGE && t->map.count == 0)
        return vbnl_sdl_error(p, NULL, "an average texture needs a texture_map");
    if (t->kind == POV_TEX_MAP && t->map.count == 0)
        return vbnl_sdl_error(p, NULL, "a patterned texture needs a texture_map or a list of textures");
    return VBNL_OK;
}

vbnl_result pov_texture_parse(pov_ctx *c, pov_texture **tx)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'texture'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_texture_body(c, tx, '}');
}
