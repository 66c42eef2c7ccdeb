/* vbnl object layer: background { } and sky_sphere { }, the core scene's constant environment. */
#include <math.h>
#include <stdio.h>

#include "pov_loader.h"

vbnl_result pov_background_parse(pov_loader *L)
{
    vbnl_sdl_parser *p = L->c.parser;
    double col[5];
    if (vbnl_sdl_expect(p, '{', "after 'background'") != VBNL_OK || vbnl_sdl_parse_color(p, col) != VBNL_OK ||
        vbnl_sdl_expect(p, '}', "after the background colour") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_set3(L->env, fmax(col[0], 0), fmax(col[1], 0), fmax(col[2], 0));
    L->have_env = 1;
    return VBNL_OK;
}

/* ---- sky_sphere -------------------------------------------------------------------------------- */

typedef struct sky {
    pov_appearance *app;
    double emission[3];
    const vbnl_sdl_loc *loc; /* of the keyword */
    int skipped;             /* an item that is not supported: the sky is left out */
} sky;

static vbnl_result sky_pigment(const pov_item *it)
{
    pov_loader *L = it->ctx;
    return pov_appearance_parse_modifier(&L->c, &((sky *)it->target)->app);
}

static vbnl_result sky_emission(const pov_item *it)
{
    double col[5];
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_color(it->p, col) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_set3(((sky *)it->target)->emission, col[0], col[1], col[2]);
    return VBNL_OK;
}

static void sky_transform(const pov_item *it, const double m[16]) /* a constant sky does not turn */
{
    (void)it;
    (void)m;
}

/* A declared sky_sphere, a pigment_map, ...: the rest of the block is skipped, and the sky with it. */
static vbnl_result sky_unsupported(const pov_item *it)
{
    sky *s = it->target;
    vbnl_sdl_parser *p = it->p;
    char what[64];
    snprintf(what, sizeof what, "%s", it->tok->text ? it->tok->text : "?");
    for (int depth = 1;;) {
        const vbnl_sdl_token *n = vbnl_sdl_peek(p);
        if (n->kind == VBNL_SDL_TOK_EOF)
            return vbnl_sdl_failed(p) ? VBNL_ERR_PARSE : vbnl_sdl_error(p, s->loc, "missing '}' at the end of 'sky_sphere'");
        int close = pov_is_punct(n, '}'), open = pov_is_punct(n, '{');
        if (close && depth == 1)
            break; /* the block's own '}' ends the block */
        depth += open - close;
        vbnl_sdl_next(p);
    }
    vbnl_sdl_warning(p, &it->loc, "'%s' in sky_sphere is not supported; the sky_sphere is skipped", what);
    s->skipped = 1;
    return VBNL_OK;
}

static const pov_row sky_rows[] = {
    {"pigment", sky_pigment, 0},
    {"emission", sky_emission, 0},
    {NULL, NULL, 0},
};

static const pov_row *const sky_tables[] = {sky_rows, pov_transform_rows, NULL};
static const pov_block sky_block = {.name = "sky_sphere",
                                    .tables = sky_tables,
                                    .unknown = sky_unsupported,
                                    .transform = sky_transform};

/* sky_sphere { pigment { ... } [emission c] [transforms] }: a constant environment of the
 * pigment's average colour, which lights the scene as the sky does in POV-Ray with radiosity and
 * is what rays that leave the scene see (replaces `background`). */
vbnl_result pov_sky_sphere_parse(pov_loader *L, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'sky_sphere'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    sky s = {NULL, {1, 1, 1}, loc, 0};
    vbnl_result r = pov_block_parse(&sky_block, p, L, &s, NULL);
    if (r == VBNL_OK && !s.skipped) {
        double rgb[3] = {0, 0, 0};
        if (s.app)
            pov_appearance_average_color(&L->c, s.app, rgb);
        for (int k = 0; k < 3; ++k)
            L->env[k] = fmax(rgb[k] * s.emission[k], 0);
        L->have_env = 1;
        vbnl_sdl_warning(p, loc, "sky_sphere is rendered as a constant sky of its pigment's average colour (%.3g %.3g %.3g)",
                         L->env[0], L->env[1], L->env[2]);
    }
    pov_appearance_free(s.app);
    return r;
}
