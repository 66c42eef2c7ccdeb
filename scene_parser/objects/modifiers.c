/* vbnl object layer: object modifiers (appearance, transforms, inverse, clipped_by, and the
 * flags that change nothing under global illumination). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_loader.h"

/* clipped_by: the object keeps its surface inside every clipping shape (POV-Ray's clipping: a
 * point is kept when it is inside all of them; a union among them is one shape, see clip_shape;
 * the shapes' own surfaces are not added). Consumes clip. */
static vbnl_result apply_clip(pov_loader *L, pov_obj *o, pov_obj *clip, vbnl_sdl_loc loc)
{
    pov_obj *ops = calloc(clip->n + 1, sizeof *ops);
    if (!ops) {
        pov_obj_clear(clip);
        return pov_oom(L);
    }
    for (size_t i = 0; i < clip->n; ++i) { /* one operand per clipping shape */
        ops[i + 1].v = &clip->v[i];
        ops[i + 1].n = ops[i + 1].cap = 1;
    }
    /* the object's primitives so far are the clipped operand; its own appearance stays with it
     * and reaches the pieces later, as it would have reached the primitives */
    ops[0].v = o->v;
    ops[0].n = o->n;
    ops[0].cap = o->cap;
    o->v = NULL;
    o->n = o->cap = 0;
    vbnl_result r = VBNL_OK;
    const char *error = NULL;
    if (!pov_csg_build_surfaces(POV_CSG_INTERSECTION, ops, clip->n + 1, 1, o, &error))
        r = strcmp(error, "out of memory") ? vbnl_sdl_error(L->c.parser, &loc, "clipped_by: %s", error) : pov_oom(L);
    pov_obj_clear(&ops[0]);
    free(ops);
    pov_obj_clear(clip);
    return r;
}

/* The shapes of clipped_by { } join the clip object, one primitive each: a shape made of several
 * primitives (a union) becomes one primitive holding their union's solid. */
static int clip_shape(const pov_item *it)
{
    if (!pov_is_shape(it->tok))
        return 0;
    pov_loader *L = it->ctx;
    pov_obj child = {0}, one = {0};
    int r = 1;
    const char *error = NULL;
    if (pov_parse_object(L, &child) != VBNL_OK)
        r = -1;
    else if (child.n > 1 && !pov_csg_solid(POV_CSG_MERGE, &child, 1, &one, &error))
        r = error && strcmp(error, "out of memory") ? (vbnl_sdl_error(L->c.parser, &it->loc, "clipped_by: %s", error), -1)
                                                    : (pov_oom(L), -1);
    else if (!pov_obj_move(it->target, child.n > 1 ? &one : &child))
        r = (pov_oom(L), -1);
    pov_obj_clear(&child);
    pov_obj_clear(&one);
    return r;
}

static const pov_block clipped_by_block = {.name = "clipped_by", .after = clip_shape};

/* clipped_by { shapes } (the parser is on the keyword) into clip (shapes added). */
static vbnl_result parse_clipped_by(pov_loader *L, pov_obj *clip)
{
    vbnl_sdl_parser *p = L->c.parser;
    vbnl_sdl_next(p);
    return pov_clip_block(L, clip);
}

vbnl_result pov_clip_block(pov_loader *L, pov_obj *clip)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'clipped_by'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    /* clipped_by { bounded_by } and bounded_by { clipped_by }: no shape of their own */
    if (pov_is_word(t, "bounded_by") || pov_is_word(t, "clipped_by")) {
        char ctx[64];
        snprintf(ctx, sizeof ctx, "after '%s'", t->text);
        vbnl_sdl_next(p);
        return vbnl_sdl_expect(p, '}', ctx);
    }
    return pov_block_parse(&clipped_by_block, p, L, clip, NULL);
}

/* ---- the rows ---------------------------------------------------------------------------------- */

static vbnl_result mod_inverse(const pov_item *it) /* swaps inside and outside (CSG) */
{
    pov_obj *o = ((pov_mods *)it->target)->o;
    vbnl_sdl_next(it->p);
    for (size_t i = 0; i < o->n; ++i)
        o->v[i].inverse = !o->v[i].inverse;
    return VBNL_OK;
}

/* POV-Ray's no_shadow: shadow rays pass the object (docs/integrators.md, "Media": visibility) */
static vbnl_result mod_no_shadow(const pov_item *it)
{
    pov_obj *o = ((pov_mods *)it->target)->o;
    vbnl_sdl_next(it->p);
    for (size_t i = 0; i < o->n; ++i)
        o->v[i].no_shadow = 1;
    return VBNL_OK;
}

static vbnl_result mod_clipped_by(const pov_item *it)
{
    pov_mods *m = it->target;
    if (m->shape) { /* applied by the shape when it is complete */
        m->clip_loc = it->loc;
        return parse_clipped_by(m->L, &m->clip);
    }
    pov_obj clip = {0};
    if (parse_clipped_by(m->L, &clip) != VBNL_OK) {
        pov_obj_clear(&clip);
        return VBNL_ERR_PARSE;
    }
    return apply_clip(m->L, m->o, &clip, it->loc);
}

static vbnl_result mod_open(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((pov_mods *)it->target)->open = 1;
    return VBNL_OK;
}

const pov_row pov_modifier_rows[] = {
    {"inverse", mod_inverse, 0},
    {"no_shadow", mod_no_shadow, 0},
    {"no_image", pov_item_word, 0},
    {"no_reflection", pov_item_word, 0},
    {"no_radiosity", pov_item_word, 0},
    {"double_illuminate", pov_item_word, 0},
    {"smooth", pov_item_word, 0},
    {"cutaway_textures", pov_item_word, 0},
    {"hollow", pov_item_any_bool, 0},
    {"sturm", pov_item_any_bool, 0},
    {"split_union", pov_item_any_bool, 0},
    {"hierarchy", pov_item_any_bool, 0},
    {"bounded_by", pov_item_skip, 0},
    {"photons", pov_item_skip, 0},
    {"radiosity", pov_item_skip, 0},
    {"clipped_by", mod_clipped_by, 0},
    {NULL, NULL, 0},
};

static const pov_row open_rows[] = {{"open", mod_open, 0}, {NULL, NULL, 0}};

int pov_modifier_appearance(const pov_item *it)
{
    if (it->tok->kind != VBNL_SDL_TOK_IDENT || !pov_appearance_is_modifier(it->tok))
        return 0;
    pov_mods *m = it->target;
    return pov_appearance_parse_modifier(&m->L->c, &m->o->app) == VBNL_OK ? 1 : -1;
}

void pov_modifier_transform(const pov_item *it, const double m[16])
{
    pov_mods *mods = it->target;
    pov_obj_transform(mods->o, m);
    if (mods->shape)
        pov_obj_transform(&mods->clip, m);
}

static const pov_row *const modifier_tables[] = {pov_transform_rows, pov_modifier_rows, NULL};
static const pov_row *const open_modifier_tables[] = {pov_transform_rows, pov_modifier_rows, open_rows, NULL};

static const pov_block modifier_block = {.tables = modifier_tables,
                                         .before = pov_modifier_appearance,
                                         .transform = pov_modifier_transform};
static const pov_block open_modifier_block = {.tables = open_modifier_tables,
                                              .before = pov_modifier_appearance,
                                              .transform = pov_modifier_transform};

/* ---- the interface ------------------------------------------------------------------------------ */

vbnl_result pov_mods_parse(pov_mods *m, const char *what, int open)
{
    return pov_block_parse(open ? &open_modifier_block : &modifier_block, m->L->c.parser, m->L, m, what);
}

vbnl_result pov_mods_finish(pov_mods *m)
{
    return m->clip.n ? apply_clip(m->L, m->o, &m->clip, m->clip_loc) : VBNL_OK;
}

void pov_mods_clear(pov_mods *m) { pov_obj_clear(&m->clip); }

vbnl_result pov_modifiers(pov_loader *L, pov_obj *o, const char *what)
{
    pov_mods m = {L, o, 0, 0, {0}, {0}};
    return pov_mods_parse(&m, what, 0);
}
