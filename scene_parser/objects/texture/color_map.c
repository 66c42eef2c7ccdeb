/* vbnl object layer, texture part: color_map { [v colour] [v1, v2 colour1 colour2] ... } and
 * the averages that stand for what the core does not render. */
#include <math.h>
#include <string.h>

#include "pov_texture.h"

typedef struct color_map_block {
    pov_color_map *m;
    int unsorted; /* warned about decreasing values */
} color_map_block;

/* One entry; `[v colour]` may also be written `[v, colour]`. */
static int entry(const pov_item *it)
{
    color_map_block *b = it->target;
    pov_color_map *m = b->m;
    vbnl_sdl_parser *p = it->p;
    vbnl_sdl_loc loc = it->loc;
    if (vbnl_sdl_expect(p, '[', "to start a color_map entry") != VBNL_OK)
        return -1;
    double v0, v1 = 0.0;
    if (vbnl_sdl_parse_float(p, &v0) != VBNL_OK)
        return -1;
    /* [v1, v2 colour1 colour2] (the comma is optional): a second value follows */
    vbnl_sdl_accept(p, ',');
    const vbnl_sdl_token *n = vbnl_sdl_peek(p);
    const vbnl_sdl_value *nv = n->kind == VBNL_SDL_TOK_IDENT ? vbnl_sdl_lookup(p, n->text) : NULL;
    int two = n->kind == VBNL_SDL_TOK_NUMBER || (nv && nv->kind == VBNL_SDL_FLOAT) ||
              (n->kind == VBNL_SDL_TOK_PUNCT && (n->op == '(' || n->op == '-' || n->op == '+'));
    if (two && vbnl_sdl_parse_float(p, &v1) != VBNL_OK)
        return -1;
    if (m->count + (two ? 2u : 1u) > POV_MAP_MAX) {
        vbnl_sdl_error(p, &loc, "color_map has more than %d entries", POV_MAP_MAX);
        return -1;
    }
    pov_map_entry *e = &m->e[m->count];
    e->value = v0;
    if (vbnl_sdl_parse_color(p, e->color) != VBNL_OK)
        return -1;
    m->count++;
    if (two) {
        vbnl_sdl_accept(p, ',');
        e[1].value = v1;
        if (vbnl_sdl_parse_color(p, e[1].color) != VBNL_OK)
            return -1;
        m->count++;
    }
    if (vbnl_sdl_expect(p, ']', "to end a color_map entry") != VBNL_OK)
        return -1;
    if (!isfinite(v0) || !isfinite(v1)) {
        vbnl_sdl_error(p, &loc, "color_map values must be finite");
        return -1;
    }
    if (m->count > 1 && m->e[m->count - 1].value < m->e[m->count - 2].value && !b->unsorted) {
        b->unsorted = 1;
        vbnl_sdl_warning(p, &loc, "color_map values decrease (%g after %g): entries sorted by value",
                         m->e[m->count - 1].value, m->e[m->count - 2].value);
    }
    return 1;
}

static const pov_block color_map_items = {.name = "color_map", .after = entry};

vbnl_result pov_color_map_parse(pov_ctx *c, pov_color_map *m)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'color_map'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    m->count = 0;
    if (pov_take_ident(c, &pov_type_color_map, m, sizeof *m) < 0)
        return VBNL_ERR_PARSE;
    color_map_block b = {m, 0};
    if (pov_block_parse(&color_map_items, p, c, &b, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (m->count == 0)
        return vbnl_sdl_error(p, NULL, "empty color_map");
    /* stable insertion sort: equal values keep their order (a sharp step) */
    for (uint32_t i = 1; i < m->count; ++i) {
        pov_map_entry e = m->e[i];
        uint32_t j = i;
        while (j > 0 && m->e[j - 1].value > e.value) {
            m->e[j] = m->e[j - 1];
            --j;
        }
        m->e[j] = e;
    }
    return VBNL_OK;
}

void pov_color_map_average(const pov_color_map *m, double out[5])
{
    memset(out, 0, 5 * sizeof(double));
    if (m->count == 0) {
        for (int k = 0; k < 3; ++k)
            out[k] = 0.5;
        return;
    }
    double prev_v = 0.0;
    const double *prev_c = m->e[0].color;
    for (uint32_t i = 0; i <= m->count; ++i) {
        double v = i < m->count ? m->e[i].value : 1.0;
        const double *col = i < m->count ? m->e[i].color : m->e[m->count - 1].color;
        double w = v - prev_v;
        for (int k = 0; k < 5; ++k)
            out[k] += w * 0.5 * (prev_c[k] + col[k]);
        prev_v = v;
        prev_c = col;
    }
}

double pov_pigment_transparency(const pov_pigment *g)
{
    double col[5];
    if (g->kind == POV_PIG_IMAGE)
        return 0.0;
    if (g->kind == POV_PIG_SOLID)
        memcpy(col, g->color, sizeof col);
    else
        pov_color_map_average(&g->map, col);
    return col[3] + col[4];
}
