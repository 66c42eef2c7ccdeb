/* vbnl object layer, texture part: patterns. checker, gradient and brick become core textures;
 * the other POV-Ray patterns are read in full and rendered as the average colour of their colour
 * map (POV-Ray's default map of the pattern when none is given), with a warning. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

static const char *const fallback_patterns[] = {
    "agate", "bozo", "granite", "marble", "wood", "leopard", "onion", "spotted", "wrinkles", "ripples",
    "waves", "crackle", "dents", "bumps", "radial", "spherical", "cylindrical", "boxed", "planar",
    "quilted", "cells", "mandel", "julia", "facets", "average", "aoi", "slope", "tiling", "pavement",
    "object", "function", "density_file", "spiral1", "spiral2", "hexagon", "square", "triangular",
    "cubic", "pigment_pattern", "magnet", "image_pattern", NULL};

int pov_is_fallback_pattern(const vbnl_sdl_token *t)
{
    for (int i = 0; t->kind == VBNL_SDL_TOK_IDENT && fallback_patterns[i]; ++i)
        if (!strcmp(t->text, fallback_patterns[i]))
            return 1;
    return 0;
}

int pov_is_pattern(const vbnl_sdl_token *t)
{
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    return !strcmp(t->text, "checker") || !strcmp(t->text, "brick") || !strcmp(t->text, "gradient") ||
           pov_is_fallback_pattern(t);
}

int pov_discrete_pattern(const char *name)
{
    if (!strcmp(name, "hexagon"))
        return 3;
    if (!strcmp(name, "square"))
        return 4;
    if (!strcmp(name, "triangular") || !strcmp(name, "cubic"))
        return 6;
    if (!strcmp(name, "object"))
        return 2;
    return 0;
}

void pov_default_color_map(const char *name, pov_color_map *m)
{
    typedef struct { double v, r, g, b; } E;
    static const E agate[] = {{0.0, 1, 1, 1}, {0.5, 0.95, 0.75, 0.5}, {0.5, 0.9, 0.7, 0.5},
                              {0.6, 0.9, 0.7, 0.4}, {0.6, 1, 0.7, 0.4}, {1.0, 0.6, 0.3, 0}};
    static const E bozo[] = {{0.4, 1, 1, 1}, {0.4, 0, 1, 0}, {0.6, 0, 1, 0},
                             {0.6, 0, 0, 1}, {0.8, 0, 0, 1}, {0.8, 1, 0, 0}};
    static const E marble[] = {{0.0, 0.9, 0.8, 0.8}, {0.9, 0.9, 0.08, 0.08}, {0.9, 0, 0, 0}};
    static const E radial[] = {{0.0, 0, 1, 1}, {0.333, 1, 1, 0}, {0.666, 1, 0, 1}, {1.0, 0, 1, 1}};
    static const E wood[] = {{0.6, 0.666, 0.312, 0.2}, {0.6, 0.4, 0.1333, 0.066}};
    static const E mandel[] = {{0.001, 0, 0, 0}, {0.001, 0, 1, 1}, {0.012, 1, 1, 0}, {0.015, 1, 0, 1}, {0.1, 0, 1, 1}};
    static const E hexagon[] = {{0, 0, 0, 1}, {1, 0, 1, 0}, {2, 1, 0, 0}};
    static const E six[] = {{0, 1, 0, 0}, {1, 0, 1, 0}, {2, 0, 0, 1}, {3, 1, 1, 0}, {4, 0, 1, 1}, {5, 1, 0, 1}};
    static const E checker[] = {{0, 0, 0, 1}, {1, 0, 1, 0}};
    static const E gray[] = {{0, 0, 0, 0}, {1, 1, 1, 1}};
#define MAP(kw, arr, n) {kw, arr, n}
#define ALL(arr) (uint32_t)(sizeof(arr) / sizeof(arr[0]))
    static const struct { const char *name; const E *e; uint32_t n; } maps[] = {
        MAP("agate", agate, ALL(agate)),    MAP("bozo", bozo, ALL(bozo)),       MAP("marble", marble, ALL(marble)),
        MAP("radial", radial, ALL(radial)), MAP("wood", wood, ALL(wood)),       MAP("mandel", mandel, ALL(mandel)),
        MAP("hexagon", hexagon, ALL(hexagon)), MAP("object", checker, ALL(checker)), MAP("square", six, 4),
        MAP("triangular", six, ALL(six)),   MAP("cubic", six, ALL(six)),
    };
#undef MAP
#undef ALL
    const E *e = gray;
    uint32_t n = 2;
    for (size_t i = 0; i < sizeof maps / sizeof maps[0]; ++i)
        if (!strcmp(name, maps[i].name)) {
            e = maps[i].e;
            n = maps[i].n;
        }
    m->count = n;
    for (uint32_t i = 0; i < n; ++i) {
        m->e[i].value = e[i].v;
        m->e[i].color[0] = e[i].r;
        m->e[i].color[1] = e[i].g;
        m->e[i].color[2] = e[i].b;
        m->e[i].color[3] = m->e[i].color[4] = 0.0;
    }
}

/* ---- pattern modifiers ------------------------------------------------------------------------ */

#define PIG_FIELD(f) offsetof(pov_pigment, f)

static vbnl_result wave(const pov_item *it)
{
    ((pov_pigment *)it->target)->wave = (int)it->arg;
    vbnl_sdl_next(it->p);
    return VBNL_OK;
}

static vbnl_result other_wave(const pov_item *it) /* cubic_wave, poly_wave [exponent] */
{
    int poly = !strcmp(it->kw, "poly_wave");
    double v;
    vbnl_sdl_next(it->p);
    const vbnl_sdl_token *n = vbnl_sdl_peek(it->p);
    if (poly && (n->kind == VBNL_SDL_TOK_NUMBER || pov_is_punct(n, '(')) &&
        vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(it->p, &it->loc, "'%s' is not supported: using ramp_wave", poly ? "poly_wave" : "cubic_wave");
    return VBNL_OK;
}

static vbnl_result turbulence(const pov_item *it)
{
    double v[3];
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_vector(it->p, 3, v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(it->p, &it->loc, "'turbulence' is not supported: the pattern is rendered without it");
    return VBNL_OK;
}

static vbnl_result two_floats(const pov_item *it) /* fractal patterns: interior / exterior type, factor */
{
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_accept(it->p, ',');
    return vbnl_sdl_parse_float(it->p, &v);
}

static vbnl_result warp(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_skip_block(it->p) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(it->p, &it->loc, "'warp' is not supported: the pattern is rendered without it");
    return VBNL_OK;
}

static vbnl_result quick_color(const pov_item *it)
{
    double q[5];
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_color(it->p, q);
}

/* The parameters of the patterns rendered as averages are read and dropped. */
const pov_row pov_pattern_modifier_rows[] = {
    {"frequency", pov_item_float, PIG_FIELD(frequency)},
    {"phase", pov_item_float, PIG_FIELD(phase)},
    {"ramp_wave", wave, VBNL_WAVE_RAMP},
    {"triangle_wave", wave, VBNL_WAVE_TRIANGLE},
    {"sine_wave", wave, VBNL_WAVE_SINE},
    {"scallop_wave", wave, VBNL_WAVE_SCALLOP},
    {"cubic_wave", other_wave, 0},
    {"poly_wave", other_wave, 0},
    {"turbulence", turbulence, 0},
    {"octaves", pov_item_any_float, 0},
    {"omega", pov_item_any_float, 0},
    {"lambda", pov_item_any_float, 0},
    {"agate_turb", pov_item_any_float, 0},
    {"control0", pov_item_any_float, 0},
    {"control1", pov_item_any_float, 0},
    {"noise_generator", pov_item_any_float, 0},
    {"offset", pov_item_any_float, 0},
    {"metric", pov_item_any_float, 0},
    {"max_iteration", pov_item_any_float, 0},
    {"exponent", pov_item_any_float, 0},
    {"precision", pov_item_any_float, 0},
    {"coords", pov_item_any_float, 0},
    {"form", pov_item_any_vec3, 0},
    {"orientation", pov_item_any_vec3, 0},
    {"dist_exp", pov_item_any_float, 0},
    {"interior", two_floats, 0},
    {"exterior", two_floats, 0},
    {"interpolate", pov_item_any_float, 0},
    {"solid", pov_item_word, 0},
    {"warp", warp, 0},
    {"quick_color", quick_color, 0},
    {"quick_colour", quick_color, 0},
    {NULL, NULL, 0},
};

/* ---- pattern arguments ------------------------------------------------------------------------ */

vbnl_result pov_pattern_args(pov_ctx *c, pov_pigment *pg, const char *name)
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *n = vbnl_sdl_peek(p);
    double v, vv[3];
    if (!strcmp(name, "spiral1") || !strcmp(name, "spiral2") || !strcmp(name, "mandel") ||
        !strcmp(name, "tiling") || !strcmp(name, "pavement")) {
        if ((!strcmp(name, "tiling") || !strcmp(name, "pavement")) && !(n->kind == VBNL_SDL_TOK_NUMBER))
            return VBNL_OK;
        return vbnl_sdl_parse_float(p, &v);
    }
    if (!strcmp(name, "julia")) {
        if (vbnl_sdl_parse_vector(p, 2, vv) != VBNL_OK)
            return VBNL_ERR_PARSE;
        vbnl_sdl_accept(p, ',');
        return vbnl_sdl_parse_float(p, &v);
    }
    if (!strcmp(name, "magnet")) {
        if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return VBNL_ERR_PARSE;
        n = vbnl_sdl_peek(p);
        if (pov_is_word(n, "julia")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_vector(p, 2, vv) != VBNL_OK)
                return VBNL_ERR_PARSE;
            vbnl_sdl_accept(p, ',');
        } else if (pov_is_word(n, "mandel")) {
            vbnl_sdl_next(p);
        } else {
            return vbnl_sdl_error(p, &n->loc, "expected 'mandel' or 'julia' after 'magnet %g'", v);
        }
        return vbnl_sdl_parse_float(p, &v);
    }
    if (!strcmp(name, "density_file")) {
        if (pov_is_word(n, "df3"))
            vbnl_sdl_next(p);
        char *file = NULL;
        vbnl_result r = vbnl_sdl_parse_string(p, &file);
        free(file);
        return r;
    }
    if (!strcmp(name, "slope")) {
        if (pov_is_punct(n, '{'))
            return vbnl_sdl_skip_block(p);
        return vbnl_sdl_parse_vector(p, 3, vv);
    }
    if (!strcmp(name, "gradient"))
        return vbnl_sdl_parse_vector(p, 3, vv);
    if (!strcmp(name, "object") || !strcmp(name, "function") || !strcmp(name, "pigment_pattern") ||
        !strcmp(name, "image_pattern")) {
        if (pov_is_punct(n, '{') && vbnl_sdl_skip_block(p) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (strcmp(name, "object"))
            return VBNL_OK;
    }
    if (pov_discrete_pattern(name) && pg) {
        pg->map.count = 0;
        return pov_block_colors(c, pg, pov_discrete_pattern(name));
    }
    return VBNL_OK;
}

