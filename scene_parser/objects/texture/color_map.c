/* vbnl object layer, texture part: the maps (reference manual, "Color Maps", "Pigment Maps",
 * "Normal Maps", "Slope Maps", "Texture Maps"): `{ [value entry] ... }` or a declared map, with
 * POV-Ray's entry forms (Parse_Colour_Map, Parse_Blend_Map): `[v colour]`, `[v, colour]`,
 * `[v1, v2 colour1 colour2]`, `[v pigment body]`, `[v normal body]`, `[v texture body]`,
 * `[v, <height, slope>]`; an average's entries may leave out the value (weight 1). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pov_texture.h"

static const char *map_name(pov_map_kind k)
{
    static const char *const names[] = {"color_map", "pigment_map", "normal_map", "texture_map", "slope_map"};
    return names[k];
}

static const vbnl_sdl_opaque_type *map_type(pov_map_kind k)
{
    const vbnl_sdl_opaque_type *const types[] = {&pov_type_color_map, &pov_type_pigment_map, &pov_type_normal_map,
                                                 &pov_type_texture_map, &pov_type_slope_map};
    return types[k];
}

static int copy_map(void *dst, const void *src) { return pov_map_copy(dst, src); }

static int next_is_float(vbnl_sdl_parser *p)
{
    const vbnl_sdl_token *n = vbnl_sdl_peek(p);
    const vbnl_sdl_value *nv = n->kind == VBNL_SDL_TOK_IDENT ? vbnl_sdl_lookup(p, n->text) : NULL;
    return n->kind == VBNL_SDL_TOK_NUMBER || (nv && nv->kind == VBNL_SDL_FLOAT) ||
           (n->kind == VBNL_SDL_TOK_PUNCT && (n->op == '(' || n->op == '-' || n->op == '+'));
}

typedef struct map_block {
    pov_map *m;
    int average;
    int unsorted; /* warned about decreasing values */
} map_block;

/* The sub-node of one entry, after its value: up to the closing ']' (read here). */
static vbnl_result entry_body(pov_ctx *c, pov_map *m, pov_map_entry *e, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = c->parser;
    if (c->tex->depth >= POV_NEST_MAX)
        return vbnl_sdl_error(p, loc, "textures nested more than %d deep", POV_NEST_MAX);
    c->tex->depth++;
    vbnl_result r;
    switch (m->kind) {
    case POV_MAP_PIGMENT: {
        pov_pigment *g = pov_pigment_dup(c->tex->deflt.tex->pig);
        e->sub = g;
        r = g ? pov_pigment_body(c, g, ']') : vbnl_sdl_error(p, loc, "out of memory");
        break;
    }
    case POV_MAP_NORMAL: {
        pov_normal *n = c->tex->deflt.tex->nrm ? pov_normal_dup(c->tex->deflt.tex->nrm) : NULL;
        r = pov_normal_body(c, &n, ']');
        e->sub = n;
        break;
    }
    default: {
        pov_texture *t = NULL;
        r = pov_texture_body(c, &t, ']');
        e->sub = t;
        break;
    }
    }
    c->tex->depth--;
    if (r != VBNL_OK)
        return VBNL_ERR_PARSE;
    return vbnl_sdl_expect(p, ']', "to end a map entry");
}

static int entry(const pov_item *it)
{
    map_block *b = it->target;
    pov_map *m = b->m;
    pov_ctx *c = it->ctx;
    vbnl_sdl_parser *p = it->p;
    vbnl_sdl_loc loc = it->loc;
    if (vbnl_sdl_expect(p, '[', m->kind == POV_MAP_COLOR ? "to start a color_map entry" : "to start a map entry") != VBNL_OK)
        return -1;
    double v0 = 1.0, v1 = 0.0;
    int two = 0;
    if ((!b->average || next_is_float(p)) && vbnl_sdl_parse_float_sum(p, &v0) != VBNL_OK)
        return -1;
    vbnl_sdl_accept(p, ',');
    if (m->kind == POV_MAP_COLOR) {
        /* [v1, v2 colour1 colour2] (the comma is optional): a second value follows */
        two = next_is_float(p);
        if (two && vbnl_sdl_parse_float_sum(p, &v1) != VBNL_OK)
            return -1;
    }
    pov_map_entry *e = pov_map_add(m);
    if (!e || (two && m->count >= POV_MAP_MAX)) {
        vbnl_sdl_error(p, &loc, "%s has more than %d entries", map_name(m->kind), POV_MAP_MAX);
        return -1;
    }
    e->value = v0;
    switch (m->kind) {
    case POV_MAP_COLOR:
        if (vbnl_sdl_parse_color(p, e->color) != VBNL_OK)
            return -1;
        if (two) {
            vbnl_sdl_accept(p, ',');
            pov_map_entry *e2 = pov_map_add(m);
            e2->value = v1;
            if (vbnl_sdl_parse_color(p, e2->color) != VBNL_OK)
                return -1;
        }
        if (vbnl_sdl_expect(p, ']', "to end a color_map entry") != VBNL_OK)
            return -1;
        break;
    case POV_MAP_SLOPE: {
        double hs[2];
        if (vbnl_sdl_parse_vector(p, 2, hs) != VBNL_OK || vbnl_sdl_expect(p, ']', "to end a slope_map entry") != VBNL_OK)
            return -1;
        e->slope[0] = hs[0];
        e->slope[1] = hs[1];
        break;
    }
    default:
        if (entry_body(c, m, e, &loc) != VBNL_OK)
            return -1;
        break;
    }
    if (!isfinite(v0) || !isfinite(v1)) {
        vbnl_sdl_error(p, &loc, "%s values must be finite", map_name(m->kind));
        return -1;
    }
    if (!b->average && m->count > 1 && m->e[m->count - 1].value < m->e[m->count - 2].value && !b->unsorted) {
        b->unsorted = 1;
        vbnl_sdl_warning(p, &loc, "%s values decrease (%g after %g): entries sorted by value", map_name(m->kind),
                         m->e[m->count - 1].value, m->e[m->count - 2].value);
    }
    return 1;
}

static const pov_block map_items = {.name = "map", .after = entry};

vbnl_result pov_map_parse(pov_ctx *c, pov_map *m, pov_map_kind kind, int average)
{
    vbnl_sdl_parser *p = c->parser;
    char ctx[64];
    snprintf(ctx, sizeof ctx, "after '%s'", map_name(kind));
    if (vbnl_sdl_expect(p, '{', ctx) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_map read = {kind, 0, NULL};
    int taken = pov_take_ident(c, map_type(kind), &read, copy_map);
    if (taken < 0)
        return VBNL_ERR_PARSE;
    map_block b = {&read, average, 0};
    if (pov_block_parse(&map_items, p, c, &b, map_name(kind)) != VBNL_OK) {
        pov_map_free(&read);
        return VBNL_ERR_PARSE;
    }
    if (read.count == 0) {
        pov_map_free(&read);
        return vbnl_sdl_error(p, NULL, "empty %s", map_name(kind));
    }
    /* stable insertion sort: equal values keep their order (a sharp step) */
    for (uint32_t i = 1; i < read.count && !average; ++i) {
        pov_map_entry e = read.e[i];
        uint32_t j = i;
        while (j > 0 && read.e[j - 1].value > e.value) {
            read.e[j] = read.e[j - 1];
            --j;
        }
        read.e[j] = e;
    }
    pov_map_free(m);
    *m = read;
    return VBNL_OK;
}
