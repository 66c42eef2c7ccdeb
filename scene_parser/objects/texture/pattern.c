/* vbnl object layer, texture part: patterns (reference manual, "Patterns", "Pattern Modifiers"):
 * the pattern keywords with their arguments and block lists, the pattern modifiers, and POV-Ray
 * 3.7's default colour maps. A pattern is read into a pov_pattern (the core's vbnl_pattern_desc
 * and the warps), with POV-Ray's parser defaults: block patterns take frequency 0, marble, wood
 * and the spirals the triangle wave, brick POV-Ray's size and mortar. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

/* ---- the pattern keywords ------------------------------------------------------------------------ */

enum {
    PAT_BLOCK = 1,    /* values are block indices; a list of up to `list` entries may follow */
    PAT_TRIANGLE = 2, /* POV-Ray's parser gives it the triangle wave */
    PAT_FREQ0 = 4,    /* frequency 0 (no frequency / phase step) */
};

typedef struct pat_kw {
    const char *name;
    vbnl_pattern_kind kind;
    int flags;
    int list; /* block patterns: the number of list entries */
} pat_kw;

static const pat_kw keywords[] = {
    {"agate", VBNL_PATTERN_AGATE, 0, 0},
    {"aoi", VBNL_PATTERN_AOI, 0, 0},
    {"boxed", VBNL_PATTERN_BOXED, 0, 0},
    {"bozo", VBNL_PATTERN_BOZO, 0, 0},
    {"brick", VBNL_PATTERN_BRICK, PAT_BLOCK | PAT_FREQ0, 2},
    {"bumps", VBNL_PATTERN_BUMPS, 0, 0},
    {"cells", VBNL_PATTERN_CELLS, 0, 0},
    {"checker", VBNL_PATTERN_CHECKER, PAT_BLOCK | PAT_FREQ0, 2},
    {"crackle", VBNL_PATTERN_CRACKLE, 0, 0},
    {"cubic", VBNL_PATTERN_CUBIC, PAT_BLOCK | PAT_FREQ0, 6},
    {"cylindrical", VBNL_PATTERN_CYLINDRICAL, 0, 0},
    {"density_file", VBNL_PATTERN_DENSITY, 0, 0},
    {"dents", VBNL_PATTERN_DENTS, 0, 0},
    {"facets", VBNL_PATTERN_FACETS, 0, 0},
    {"function", VBNL_PATTERN_FUNCTION, 0, 0},
    {"gradient", VBNL_PATTERN_GRADIENT, 0, 0},
    {"granite", VBNL_PATTERN_GRANITE, 0, 0},
    {"hexagon", VBNL_PATTERN_HEXAGON, PAT_BLOCK | PAT_FREQ0, 3},
    {"image_pattern", VBNL_PATTERN_IMAGE, PAT_FREQ0, 0},
    {"julia", VBNL_PATTERN_JULIA, 0, 0},
    {"leopard", VBNL_PATTERN_LEOPARD, 0, 0},
    {"magnet", VBNL_PATTERN_MAGNET, 0, 0},
    {"mandel", VBNL_PATTERN_MANDEL, 0, 0},
    {"marble", VBNL_PATTERN_MARBLE, PAT_TRIANGLE, 0},
    {"object", VBNL_PATTERN_OBJECT, PAT_BLOCK | PAT_FREQ0, 2},
    {"onion", VBNL_PATTERN_ONION, 0, 0},
    {"pavement", VBNL_PATTERN_PAVEMENT, 0, 0},
    {"pigment_pattern", VBNL_PATTERN_PIGMENT, 0, 0},
    {"planar", VBNL_PATTERN_PLANAR, 0, 0},
    {"quilted", VBNL_PATTERN_QUILTED, PAT_FREQ0, 0},
    {"radial", VBNL_PATTERN_RADIAL, 0, 0},
    {"ripples", VBNL_PATTERN_RIPPLES, 0, 0},
    {"slope", VBNL_PATTERN_SLOPE, 0, 0},
    {"spherical", VBNL_PATTERN_SPHERICAL, 0, 0},
    {"spiral1", VBNL_PATTERN_SPIRAL1, PAT_TRIANGLE, 0},
    {"spiral2", VBNL_PATTERN_SPIRAL2, PAT_TRIANGLE, 0},
    {"spotted", VBNL_PATTERN_SPOTTED, 0, 0},
    {"square", VBNL_PATTERN_SQUARE, PAT_BLOCK | PAT_FREQ0, 4},
    {"tiling", VBNL_PATTERN_TILING, 0, 0},
    {"triangular", VBNL_PATTERN_TRIANGULAR, PAT_BLOCK | PAT_FREQ0, 6},
    {"waves", VBNL_PATTERN_WAVES, 0, 0},
    {"wood", VBNL_PATTERN_WOOD, PAT_TRIANGLE, 0},
    {"wrinkles", VBNL_PATTERN_WRINKLES, 0, 0},
};

static const pat_kw *find_keyword(const vbnl_sdl_token *t)
{
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return NULL;
    for (size_t i = 0; i < sizeof(keywords) / sizeof(keywords[0]); ++i)
        if (!strcmp(t->text, keywords[i].name))
            return &keywords[i];
    return NULL;
}

int pov_pattern_is_block(const pov_pattern *p)
{
    switch (p->d.kind) {
    case VBNL_PATTERN_BRICK:
    case VBNL_PATTERN_CHECKER:
    case VBNL_PATTERN_CUBIC:
    case VBNL_PATTERN_HEXAGON:
    case VBNL_PATTERN_OBJECT:
    case VBNL_PATTERN_SQUARE:
    case VBNL_PATTERN_TRIANGULAR:
        return p->name != NULL;
    default:
        return 0;
    }
}

/* ---- block lists ------------------------------------------------------------------------------- */

/* The words a colour may start with. */
static int starts_color(vbnl_sdl_parser *p, const vbnl_sdl_token *t)
{
    static const char *const words[] = {"color", "colour", "rgb", "rgbf", "rgbt", "rgbft", "srgb", "srgbf",
                                        "srgbt", "srgbft", "red", "green", "blue", "filter", "transmit", NULL};
    if (t->kind == VBNL_SDL_TOK_NUMBER || pov_is_punct(t, '<') || pov_is_punct(t, '(') || pov_is_punct(t, '-'))
        return 1;
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    for (int i = 0; words[i]; ++i)
        if (!strcmp(t->text, words[i]))
            return 1;
    const vbnl_sdl_value *v = vbnl_sdl_lookup(p, t->text);
    return v && (v->kind == VBNL_SDL_COLOR || v->kind == VBNL_SDL_VECTOR || v->kind == VBNL_SDL_FLOAT);
}

/* POV-Ray's Parse_Blend_List: after a block pattern, up to n colours or `pigment { }` (pigments),
 * `normal { }` or `texture { }` entries, at values 0, 1, ...; missing entries keep POV-Ray's
 * defaults (the pattern's default colours, or the #default pigment / normal / texture). */
static vbnl_result block_list(pov_ctx *c, const pov_pattern_target *t, int n)
{
    vbnl_sdl_parser *p = c->parser;
    pov_map *m = t->map;
    if (!m)
        return VBNL_OK;
    const vbnl_sdl_token *first = vbnl_sdl_peek(p);
    pov_map_kind kind = t->list_kind;
    const char *word = kind == POV_MAP_NORMAL ? "normal" : kind == POV_MAP_TEXTURE ? "texture" : "pigment";
    if (kind == POV_MAP_COLOR && pov_is_word(first, "pigment"))
        kind = POV_MAP_PIGMENT;
    int given = 0;
    pov_map list = {kind, 0, NULL};
    for (; given < n; ++given) {
        const vbnl_sdl_token *tk = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = tk->loc;
        if (kind == POV_MAP_COLOR ? !starts_color(p, tk) : !pov_is_word(tk, word))
            break;
        pov_map_entry *e = pov_map_add(&list);
        if (!e) {
            pov_map_free(&list);
            return vbnl_sdl_error(p, &loc, "out of memory");
        }
        e->value = given;
        vbnl_result r = VBNL_OK;
        if (kind == POV_MAP_COLOR) {
            r = vbnl_sdl_parse_color(p, e->color);
        } else {
            vbnl_sdl_next(p);
            if (c->tex->depth >= POV_NEST_MAX) {
                pov_map_free(&list);
                return vbnl_sdl_error(p, &loc, "textures nested more than %d deep", POV_NEST_MAX);
            }
            c->tex->depth++;
            if (kind == POV_MAP_PIGMENT) {
                pov_pigment *g = pov_pigment_dup(c->tex->deflt.tex->pig);
                r = g ? pov_pigment_parse(c, g) : vbnl_sdl_error(p, &loc, "out of memory");
                e->sub = g;
            } else if (kind == POV_MAP_NORMAL) {
                pov_normal *nm = c->tex->deflt.tex->nrm ? pov_normal_dup(c->tex->deflt.tex->nrm) : NULL;
                r = pov_normal_parse(c, &nm);
                e->sub = nm;
            } else {
                pov_texture *tx = NULL;
                r = pov_texture_parse(c, &tx);
                e->sub = tx;
            }
            c->tex->depth--;
        }
        if (r != VBNL_OK) {
            pov_map_free(&list);
            return VBNL_ERR_PARSE;
        }
        vbnl_sdl_accept(p, ',');
    }
    if (given == 0 && kind == POV_MAP_NORMAL) { /* no list: the pattern's own slope */
        pov_map_free(&list);
        return VBNL_OK;
    }
    /* the rest: POV-Ray's defaults */
    pov_map def = {POV_MAP_COLOR, 0, NULL};
    pov_default_color_map(t->pat, &def);
    for (int i = given; i < n; ++i) {
        pov_map_entry *e = pov_map_add(&list);
        if (!e) {
            pov_map_free(&list);
            pov_map_free(&def);
            return vbnl_sdl_error(p, NULL, "out of memory");
        }
        e->value = i;
        if (kind == POV_MAP_COLOR && (uint32_t)i < def.count)
            memcpy(e->color, def.e[i].color, sizeof(e->color));
        else if (kind == POV_MAP_PIGMENT)
            e->sub = pov_pigment_dup(c->tex->deflt.tex->pig);
        else if (kind == POV_MAP_NORMAL)
            e->sub = c->tex->deflt.tex->nrm ? pov_normal_dup(c->tex->deflt.tex->nrm) : NULL;
        else if (kind == POV_MAP_TEXTURE)
            e->sub = pov_texture_dup(c->tex->deflt.tex);
    }
    pov_map_free(&def);
    pov_map_free(m);
    *m = list;
    return VBNL_OK;
}

/* ---- arguments --------------------------------------------------------------------------------- */

static vbnl_result fractal_args(pov_ctx *c, pov_pattern *pat, const vbnl_sdl_loc *loc, int julia)
{
    vbnl_sdl_parser *p = c->parser;
    double v[2], it;
    if (julia) {
        if (vbnl_sdl_parse_vector(p, 2, v) != VBNL_OK)
            return VBNL_ERR_PARSE;
        vbnl_sdl_accept(p, ',');
        pat->d.fractal.coord[0] = v[0];
        pat->d.fractal.coord[1] = v[1];
    }
    if (vbnl_sdl_parse_float(p, &it) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(it >= 1.0 && it <= 1e6))
        return vbnl_sdl_error(p, loc, "fractal iterations must lie in [1, 1000000] (got %g)", it);
    pat->d.fractal.iterations = (int)it;
    return VBNL_OK;
}

/* magnet n mandel|julia <c> iterations */
static vbnl_result magnet_args(pov_ctx *c, pov_pattern *pat, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = c->parser;
    double n;
    if (vbnl_sdl_parse_float(p, &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    int julia = pov_is_word(t, "julia");
    if (!julia && !pov_is_word(t, "mandel"))
        return vbnl_sdl_error(p, &t->loc, "expected 'mandel' or 'julia' after 'magnet %g'", n);
    if (n != 1.0 && n != 2.0)
        return vbnl_sdl_error(p, loc, "magnet type must be 1 or 2 (got %g)", n);
    vbnl_sdl_next(p);
    pat->d.fractal.magnet = (int)n;
    pat->d.fractal.julia = julia;
    return fractal_args(c, pat, loc, julia);
}

/* slope <v> | slope { [point_at] <v> [, low [, high]] [altitude <v> [, low [, high]]] } */
static vbnl_result slope_args(pov_ctx *c, pov_pattern *pat)
{
    vbnl_sdl_parser *p = c->parser;
    if (!vbnl_sdl_accept(p, '{'))
        return vbnl_sdl_parse_vector(p, 3, pat->d.slope.direction);
    if (pov_is_word(vbnl_sdl_peek(p), "point_at")) {
        vbnl_sdl_next(p);
        pat->d.slope.point_at = 1;
    }
    if (vbnl_sdl_parse_vector(p, 3, pat->d.slope.direction) != VBNL_OK)
        return VBNL_ERR_PARSE;
    double *ranges[2][2] = {{&pat->d.slope.low, &pat->d.slope.high}, {&pat->d.slope.alt_low, &pat->d.slope.alt_high}};
    for (int part = 0; part < 2; ++part) {
        for (int k = 0; k < 2; ++k) {
            if (!vbnl_sdl_accept(p, ','))
                break;
            if (vbnl_sdl_parse_float(p, ranges[part][k]) != VBNL_OK)
                return VBNL_ERR_PARSE;
        }
        if (part == 0) {
            const vbnl_sdl_token *t = vbnl_sdl_peek(p);
            if (!pov_is_word(t, "altitude"))
                break;
            if (pat->d.slope.point_at)
                return vbnl_sdl_error(p, &t->loc, "'altitude' cannot be used with 'point_at' in slope");
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_vector(p, 3, pat->d.slope.altitude) != VBNL_OK)
                return VBNL_ERR_PARSE;
        }
    }
    return vbnl_sdl_expect(p, '}', "to close the slope pattern");
}

vbnl_result pov_density_read(pov_ctx *c, pov_pattern *pat, const vbnl_sdl_loc *loc); /* image_map.c */
vbnl_result pov_function_pattern(pov_ctx *c, pov_pattern *pat, const vbnl_sdl_loc *loc); /* core_material.c */

static vbnl_result args(pov_ctx *c, const pat_kw *k, const pov_pattern_target *t, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = c->parser;
    pov_pattern *pat = t->pat;
    switch (k->kind) {
    case VBNL_PATTERN_GRADIENT: {
        double v[3];
        if (vbnl_sdl_parse_vector(p, 3, v) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0)
            return vbnl_sdl_error(p, loc, "gradient needs a non-zero vector");
        memcpy(pat->d.gradient.direction, v, sizeof(v));
        return VBNL_OK;
    }
    case VBNL_PATTERN_JULIA:
        return fractal_args(c, pat, loc, 1);
    case VBNL_PATTERN_MANDEL:
        return fractal_args(c, pat, loc, 0);
    case VBNL_PATTERN_MAGNET:
        return magnet_args(c, pat, loc);
    case VBNL_PATTERN_SPIRAL1:
    case VBNL_PATTERN_SPIRAL2: {
        double arms;
        if (vbnl_sdl_parse_float(p, &arms) != VBNL_OK)
            return VBNL_ERR_PARSE;
        pat->d.spiral_arms = (int)arms;
        return VBNL_OK;
    }
    case VBNL_PATTERN_TILING: {
        double n;
        if (vbnl_sdl_parse_float(p, &n) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!(n >= 1.0 && n <= 27.0))
            return vbnl_sdl_error(p, loc, "tiling type must lie in 1..27 (got %g)", n);
        pat->d.tiling = (int)n;
        if (pat->d.tiling >= 25) {
            vbnl_sdl_warning(p, loc, "tiling %d (a Penrose tiling) is not supported: tiling 1 (squares) is used",
                             pat->d.tiling);
            pat->d.tiling = 1;
        }
        return VBNL_OK;
    }
    case VBNL_PATTERN_PAVEMENT:
        vbnl_sdl_warning(p, loc, "pattern 'pavement' is not supported: rendered as the tiling of its cells "
                                 "(triangles, squares or hexagons)");
        return VBNL_OK;
    case VBNL_PATTERN_SLOPE:
        return slope_args(c, pat);
    case VBNL_PATTERN_DENSITY:
        return pov_density_read(c, pat, loc);
    case VBNL_PATTERN_FUNCTION:
        return pov_function_pattern(c, pat, loc);
    case VBNL_PATTERN_IMAGE:
        return pov_image_pattern_parse(c, pat);
    case VBNL_PATTERN_PIGMENT: {
        if (vbnl_sdl_expect(p, '{', "after 'pigment_pattern'") != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (c->tex->depth >= POV_NEST_MAX)
            return vbnl_sdl_error(p, loc, "textures nested more than %d deep", POV_NEST_MAX);
        pov_pigment_free(pat->pigment);
        pat->pigment = pov_pigment_dup(c->tex->deflt.tex->pig);
        if (!pat->pigment)
            return vbnl_sdl_error(p, loc, "out of memory");
        c->tex->depth++;
        vbnl_result r = pov_pigment_body(c, pat->pigment, '}');
        c->tex->depth--;
        return r;
    }
    case VBNL_PATTERN_OBJECT:
        /* an inside test of an object: the object is read and the pattern is 0 (outside) */
        if (vbnl_sdl_skip_block(p) != VBNL_OK)
            return VBNL_ERR_PARSE;
        vbnl_sdl_warning(p, loc, "pattern 'object' is not supported: every point counts as outside the object");
        return block_list(c, t, k->list);
    default:
        if (k->flags & PAT_BLOCK)
            return block_list(c, t, k->list);
        return VBNL_OK;
    }
}

int pov_pattern_keyword(pov_ctx *c, const pov_pattern_target *t)
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *tok = vbnl_sdl_peek(p);
    const pat_kw *k = find_keyword(tok);
    if (!k)
        return 0;
    vbnl_sdl_loc loc = tok->loc;
    if (k->kind != VBNL_PATTERN_FUNCTION) /* the function's own parse reads its keyword */
        vbnl_sdl_next(p);
    pov_pattern *pat = t->pat;
    const int was_brick = pat->d.kind == VBNL_PATTERN_BRICK && pat->name;
    pat->d.kind = k->kind;
    pat->name = k->name;
    if (k->flags & PAT_TRIANGLE)
        pat->d.wave = VBNL_WAVE_TRIANGLE;
    if (k->flags & PAT_FREQ0)
        pat->d.frequency = 0.0f;
    if (k->kind == VBNL_PATTERN_BRICK && !was_brick) {
        pat->d.brick.size[0] = 8.0;
        pat->d.brick.size[1] = 3.0;
        pat->d.brick.size[2] = 4.5;
        pat->d.brick.mortar = 0.5f;
    }
    if (k->kind == VBNL_PATTERN_JULIA || k->kind == VBNL_PATTERN_MANDEL || k->kind == VBNL_PATTERN_MAGNET) {
        pat->d.fractal.exponent = 2;
        pat->d.fractal.interior = 0;
        pat->d.fractal.exterior = 1;
        pat->d.fractal.interior_factor = pat->d.fractal.exterior_factor = 1.0;
    }
    if (k->kind == VBNL_PATTERN_CRACKLE) {
        pat->d.crackle.form[0] = -1.0;
        pat->d.crackle.form[1] = 1.0;
        pat->d.crackle.form[2] = 0.0;
        pat->d.crackle.metric = 2.0;
        pat->d.crackle.offset = 0.0;
        pat->d.crackle.solid = 0;
    }
    if (k->kind == VBNL_PATTERN_AGATE)
        pat->d.agate_turb = 1.0f;
    if (k->kind == VBNL_PATTERN_QUILTED)
        pat->d.quilted.control0 = pat->d.quilted.control1 = 1.0f;
    if (args(c, k, t, &loc) != VBNL_OK)
        return -1;
    /* normals: an amount may follow the pattern (bumps 0.4) */
    if (t->amount) {
        vbnl_sdl_accept(p, ',');
        const vbnl_sdl_token *n = vbnl_sdl_peek(p);
        const vbnl_sdl_value *nv = n->kind == VBNL_SDL_TOK_IDENT ? vbnl_sdl_lookup(p, n->text) : NULL;
        if ((n->kind == VBNL_SDL_TOK_NUMBER || pov_is_punct(n, '(') || pov_is_punct(n, '-') ||
             (nv && nv->kind == VBNL_SDL_FLOAT)) &&
            vbnl_sdl_parse_float(p, t->amount) != VBNL_OK)
            return -1;
    }
    return 1;
}

/* ---- default colour maps ------------------------------------------------------------------------ */

void pov_default_color_map(const pov_pattern *p, pov_map *m)
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
    static const E brick[] = {{0, 0.5, 0.5, 0.5}, {1, 0.6, 0.15, 0.15}};
    static const E hexagon[] = {{0, 0, 0, 1}, {1, 0, 1, 0}, {2, 1, 0, 0}};
    /* POV-Ray gives square, triangular and cubic the same six colours (its Cubic_Entries) */
    static const E six[] = {{0, 1, 0, 0}, {1, 0, 1, 0}, {1, 0, 0, 1}, {1, 1, 1, 0}, {1, 0, 1, 1}, {2, 1, 0, 1}};
    static const E gray[] = {{0, 0, 0, 0}, {1, 1, 1, 1}};
    const E *e = gray;
    uint32_t n = 2;
#define VBI_MAP(arr) (e = (arr), n = (uint32_t)(sizeof(arr) / sizeof((arr)[0])))
    switch (p->name ? p->d.kind : VBNL_PATTERN_KIND_COUNT) {
    case VBNL_PATTERN_AGATE: VBI_MAP(agate); break;
    case VBNL_PATTERN_BOZO: VBI_MAP(bozo); break;
    case VBNL_PATTERN_MARBLE: VBI_MAP(marble); break;
    case VBNL_PATTERN_RADIAL: VBI_MAP(radial); break;
    case VBNL_PATTERN_WOOD: VBI_MAP(wood); break;
    case VBNL_PATTERN_MANDEL: VBI_MAP(mandel); break;
    case VBNL_PATTERN_BRICK: VBI_MAP(brick); break;
    case VBNL_PATTERN_CHECKER:
    case VBNL_PATTERN_OBJECT: e = hexagon, n = 2; break; /* POV-Ray's checker uses the hexagon's first two */
    case VBNL_PATTERN_HEXAGON: VBI_MAP(hexagon); break;
    case VBNL_PATTERN_SQUARE: e = six, n = 4; break;
    case VBNL_PATTERN_TRIANGULAR:
    case VBNL_PATTERN_CUBIC: VBI_MAP(six); break;
    default: break;
    }
#undef VBI_MAP
    pov_map_free(m);
    m->kind = POV_MAP_COLOR;
    for (uint32_t i = 0; i < n; ++i) {
        pov_map_entry *x = pov_map_add(m);
        if (!x)
            return;
        /* block patterns take their colours at their indices */
        x->value = pov_pattern_is_block(p) ? (double)i : e[i].v;
        x->color[0] = e[i].r;
        x->color[1] = e[i].g;
        x->color[2] = e[i].b;
    }
}

/* ---- pattern modifiers ------------------------------------------------------------------------- */

static pov_pattern *pat_of(const pov_item *it) { return it->target; }

static vbnl_result wave(const pov_item *it)
{
    pov_pattern *pat = pat_of(it);
    vbnl_sdl_next(it->p);
    pat->d.wave = (vbnl_texture_wave)it->arg;
    if (it->arg == VBNL_WAVE_POLY) {
        /* poly_wave [exponent] */
        const vbnl_sdl_token *n = vbnl_sdl_peek(it->p);
        const vbnl_sdl_value *nv = n->kind == VBNL_SDL_TOK_IDENT ? vbnl_sdl_lookup(it->p, n->text) : NULL;
        if (n->kind == VBNL_SDL_TOK_NUMBER || pov_is_punct(n, '(') || (nv && nv->kind == VBNL_SDL_FLOAT)) {
            double e;
            if (vbnl_sdl_parse_float(it->p, &e) != VBNL_OK)
                return VBNL_ERR_PARSE;
            pat->d.exponent = (float)e;
        }
    }
    return VBNL_OK;
}

static vbnl_result float_item(const pov_item *it, double *v)
{
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_float(it->p, v);
}

/* frequency phase agate_turb control0 control1 offset size coords omega lambda octaves
 * noise_generator number_of_sides number_of_tiles pattern exponent interpolate: one float each */
static vbnl_result number(const pov_item *it)
{
    pov_pattern *pat = pat_of(it);
    vbnl_sdl_parser *p = it->p;
    const char *kw = it->kw;
    double v;
    if (float_item(it, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_pattern_desc *d = &pat->d;
    if (!strcmp(kw, "frequency"))
        d->frequency = (float)v;
    else if (!strcmp(kw, "phase"))
        d->phase = (float)v;
    else if (!strcmp(kw, "agate_turb"))
        d->agate_turb = (float)v;
    else if (!strcmp(kw, "control0"))
        d->quilted.control0 = (float)v;
    else if (!strcmp(kw, "control1"))
        d->quilted.control1 = (float)v;
    else if (!strcmp(kw, "offset"))
        d->crackle.offset = v;
    else if (!strcmp(kw, "size"))
        d->facets.size = v;
    else if (!strcmp(kw, "coords"))
        d->facets.coords = v;
    else if (!strcmp(kw, "omega"))
        d->turbulence.omega = (float)v;
    else if (!strcmp(kw, "lambda"))
        d->turbulence.lambda = (float)v;
    else if (!strcmp(kw, "octaves"))
        d->turbulence.octaves = v < 1.0 ? 1 : (v > 10.0 ? 10 : (int)v);
    else if (!strcmp(kw, "noise_generator")) {
        if (!(v >= 0.0 && v <= 3.0))
            return vbnl_sdl_error(p, &it->loc, "noise_generator must be 0, 1, 2 or 3 (got %g)", v);
        d->noise_generator = (int)v; /* 0: the scene's (global_settings), set when the scene is built */
    } else if (!strcmp(kw, "number_of_sides"))
        d->pavement.sides = (int)v;
    else if (!strcmp(kw, "number_of_tiles"))
        d->pavement.tiles = (int)v;
    else if (!strcmp(kw, "pattern"))
        d->pavement.pattern = (int)v;
    else if (!strcmp(kw, "interpolate"))
        d->density.interpolate = (int)v;
    else if (!strcmp(kw, "exponent")) {
        if (!(v >= 2.0 && v <= 33.0))
            return vbnl_sdl_error(p, &it->loc, "fractal exponent must lie in [2, 33] (got %g)", v);
        d->fractal.exponent = (int)v;
    }
    return VBNL_OK;
}

/* turbulence <v> (a float means the same on every axis) */
static vbnl_result turbulence(const pov_item *it)
{
    pov_pattern *pat = pat_of(it);
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_vector(it->p, 3, pat->d.turbulence.amount);
}

static vbnl_result brick_size(const pov_item *it)
{
    pov_pattern *pat = pat_of(it);
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_vector(it->p, 3, pat->d.brick.size) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(pat->d.brick.size[0] > 0 && pat->d.brick.size[1] > 0 && pat->d.brick.size[2] > 0))
        return vbnl_sdl_error(it->p, &it->loc, "brick_size components must be > 0");
    return VBNL_OK;
}

static vbnl_result mortar(const pov_item *it)
{
    double v;
    if (float_item(it, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(v >= 0.0))
        return vbnl_sdl_error(it->p, &it->loc, "mortar must be >= 0");
    pat_of(it)->d.brick.mortar = (float)v;
    return VBNL_OK;
}

/* form: crackle <v>, pavement n; metric: crackle / facets <v> (x used, as POV-Ray) */
static vbnl_result form_metric(const pov_item *it)
{
    pov_pattern *pat = pat_of(it);
    vbnl_sdl_next(it->p);
    const int form = !strcmp(it->kw, "form");
    if (form && pat->d.kind == VBNL_PATTERN_PAVEMENT) {
        double v;
        if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
            return VBNL_ERR_PARSE;
        pat->d.pavement.form = (int)v;
        return VBNL_OK;
    }
    double v[3];
    if (vbnl_sdl_parse_vector(it->p, 3, v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (form) {
        memcpy(pat->d.crackle.form, v, sizeof(v));
    } else {
        if (!(v[0] > 0.0))
            return vbnl_sdl_error(it->p, &it->loc, "metric must be > 0 (got %g)", v[0]);
        pat->d.crackle.metric = v[0];
        pat->d.facets.metric = v[0];
    }
    return VBNL_OK;
}

static vbnl_result solid(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    pat_of(it)->d.crackle.solid = 1;
    return VBNL_OK;
}

/* interior / exterior: fractals type, factor; pavement n */
static vbnl_result interior_exterior(const pov_item *it)
{
    pov_pattern *pat = pat_of(it);
    vbnl_sdl_parser *p = it->p;
    const int in = !strcmp(it->kw, "interior");
    double type, factor = 1.0;
    if (float_item(it, &type) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pat->d.kind == VBNL_PATTERN_PAVEMENT) {
        *(in ? &pat->d.pavement.interior : &pat->d.pavement.exterior) = (int)type;
        return VBNL_OK;
    }
    vbnl_sdl_accept(p, ',');
    if (vbnl_sdl_parse_float(p, &factor) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(type >= 0.0 && type <= (in ? 6.0 : 8.0)))
        return vbnl_sdl_error(p, &it->loc, "fractal %s type must lie in 0..%d (got %g)", it->kw, in ? 6 : 8, type);
    if (in) {
        pat->d.fractal.interior = (int)type;
        pat->d.fractal.interior_factor = factor;
    } else {
        pat->d.fractal.exterior = (int)type;
        pat->d.fractal.exterior_factor = factor;
    }
    return VBNL_OK;
}

static vbnl_result warp(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_warp_parse(it->ctx, pat_of(it));
}

static vbnl_result quick_color(const pov_item *it)
{
    double q[5];
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_color(it->p, q);
}

const pov_row pov_pattern_modifier_rows[] = {
    {"frequency", number, 0},
    {"phase", number, 0},
    {"ramp_wave", wave, VBNL_WAVE_RAMP},
    {"triangle_wave", wave, VBNL_WAVE_TRIANGLE},
    {"sine_wave", wave, VBNL_WAVE_SINE},
    {"scallop_wave", wave, VBNL_WAVE_SCALLOP},
    {"cubic_wave", wave, VBNL_WAVE_CUBIC},
    {"poly_wave", wave, VBNL_WAVE_POLY},
    {"turbulence", turbulence, 0},
    {"octaves", number, 0},
    {"omega", number, 0},
    {"lambda", number, 0},
    {"agate_turb", number, 0},
    {"control0", number, 0},
    {"control1", number, 0},
    {"noise_generator", number, 0},
    {"offset", number, 0},
    {"size", number, 0},
    {"coords", number, 0},
    {"number_of_sides", number, 0},
    {"number_of_tiles", number, 0},
    {"pattern", number, 0},
    {"interpolate", number, 0},
    {"exponent", number, 0},
    {"brick_size", brick_size, 0},
    {"mortar", mortar, 0},
    {"form", form_metric, 0},
    {"metric", form_metric, 0},
    {"solid", solid, 0},
    {"interior", interior_exterior, 0},
    {"exterior", interior_exterior, 0},
    {"warp", warp, 0},
    {"quick_color", quick_color, 0},
    {"quick_colour", quick_color, 0},
    {NULL, NULL, 0},
};
