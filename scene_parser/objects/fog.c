/* vbnl object layer: fog { } (POV-Ray 3.7 reference "Fog") onto the core's fog (vbnl_scene_add_fog),
 * and the atmospheric media of top-level media { } blocks (docs/integrators.md, "Media"). */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "pov_loader.h"
#include "pov_texture.h"

typedef struct fog_item {
    pov_fog f;
    pov_loader *L;
} fog_item;

static vbnl_result fog_colour(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_color(it->p, ((fog_item *)it->target)->f.color);
}

/* `turbulence` takes a float or a vector (a float is promoted, as in POV-Ray). */
static vbnl_result fog_turbulence(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_vector(it->p, 3, ((fog_item *)it->target)->f.turbulence);
}

/* A bare colour expression (`fog { rgb <...> distance 10 }`, `fog { distance 200 Wheat * .5 }`):
 * POV-Ray's Parse_Fog reads any expression that is not one of its keywords as the colour. */
static int fog_bare_colour(const pov_item *it)
{
    const vbnl_sdl_token *t = it->tok;
    int starts = pov_is_word(t, "rgb") || pov_is_word(t, "rgbf") || pov_is_word(t, "rgbt") ||
                 pov_is_word(t, "rgbft") || pov_is_word(t, "srgb") || pov_is_word(t, "srgbf") ||
                 pov_is_word(t, "srgbt") || pov_is_word(t, "srgbft") || t->kind == VBNL_SDL_TOK_NUMBER ||
                 pov_is_punct(t, '<') || pov_is_punct(t, '(') || pov_is_punct(t, '-');
    if (!starts && t->kind == VBNL_SDL_TOK_IDENT && !t->keyword) {
        const vbnl_sdl_value *v = vbnl_sdl_lookup(it->p, t->text);
        starts = v && (v->kind == VBNL_SDL_COLOR || v->kind == VBNL_SDL_VECTOR || v->kind == VBNL_SDL_FLOAT);
    }
    if (!starts)
        return 0;
    return vbnl_sdl_parse_color(it->p, ((fog_item *)it->target)->f.color) == VBNL_OK ? 1 : -1;
}

/* Transforms move the fog's turbulence pattern only, which is approximated (docs/integrators.md). */
static void fog_transform(const pov_item *it, const double m[16])
{
    (void)it;
    (void)m;
}

#define FOG_FIELD(name) offsetof(fog_item, f) + offsetof(pov_fog, name)

static const pov_row fog_rows[] = {
    {"fog_type", pov_item_float, FOG_FIELD(type)},
    {"distance", pov_item_float, FOG_FIELD(distance)},
    {"color", fog_colour, 0},
    {"colour", fog_colour, 0},
    {"fog_offset", pov_item_float, FOG_FIELD(offset)},
    {"fog_alt", pov_item_float, FOG_FIELD(alt)},
    {"up", pov_item_vec3, FOG_FIELD(up)},
    {"turbulence", fog_turbulence, 0},
    {"turb_depth", pov_item_float, FOG_FIELD(turb_depth)},
    {"omega", pov_item_float, FOG_FIELD(omega)},
    {"lambda", pov_item_float, FOG_FIELD(lambda)},
    {"octaves", pov_item_float, FOG_FIELD(octaves)},
    {NULL, NULL, 0},
};

static const pov_row *const fog_tables[] = {fog_rows, pov_transform_rows, NULL};
static const pov_block fog_block = {.name = "fog", .tables = fog_tables, .after = fog_bare_colour,
                                    .transform = fog_transform};

vbnl_result pov_fog_parse(pov_loader *L, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'fog'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    /* POV-Ray's defaults (its Create_Fog) */
    fog_item fi;
    memset(&fi, 0, sizeof(fi));
    fi.L = L;
    fi.f.type = 1;
    fi.f.alt = 1;
    fi.f.up[1] = 1;
    fi.f.turb_depth = 0.5;
    fi.f.omega = 0.5;
    fi.f.lambda = 2;
    fi.f.octaves = 6;
    fi.f.loc = *loc;
    vbnl_result r = pov_block_parse(&fog_block, p, L, &fi, NULL);
    if (r != VBNL_OK)
        return r;
    if (fi.f.type != 1 && fi.f.type != 2)
        return vbnl_sdl_error(p, loc, "fog_type must be 1 (constant) or 2 (ground), got %g", fi.f.type);
    if (!(fi.f.distance > 0) || !isfinite(fi.f.distance))
        return vbnl_sdl_error(p, loc, "fog distance must be positive, got %g", fi.f.distance);
    if (fi.f.type == 2 && (!(fi.f.alt > 0) || !isfinite(fi.f.alt)))
        return vbnl_sdl_error(p, loc, "fog_alt must be positive, got %g", fi.f.alt);
    if (!(pov_len3(fi.f.up) > 0))
        return vbnl_sdl_error(p, loc, "fog up vector must not be zero");
    pov_fog *n = realloc(L->fogs, (L->nfogs + 1) * sizeof *n);
    if (!n)
        return pov_oom(L);
    L->fogs = n;
    L->fogs[L->nfogs++] = fi.f;
    return VBNL_OK;
}

vbnl_result pov_fogs_build(pov_loader *L, vbnl_error *err)
{
    for (size_t i = 0; i < L->nfogs; ++i) {
        const pov_fog *f = &L->fogs[i];
        vbnl_fog_desc d;
        vbnl_fog_desc_init(&d);
        d.kind = f->type == 2 ? VBNL_FOG_GROUND : VBNL_FOG_CONSTANT;
        d.distance = (float)f->distance;
        for (int k = 0; k < 5; ++k)
            d.color[k] = (float)f->color[k];
        d.offset = (float)f->offset;
        d.alt = (float)f->alt;
        for (int k = 0; k < 3; ++k) {
            d.up[k] = (float)f->up[k];
            d.turbulence.amount[k] = f->turbulence[k];
        }
        d.turbulence.omega = f->omega;
        d.turbulence.lambda = f->lambda;
        d.turbulence.octaves = (int)f->octaves;
        d.turb_depth = (float)f->turb_depth;
        d.noise_generator = L->c.tex && L->c.tex->noise_generator ? L->c.tex->noise_generator : 2;
        vbnl_result r = vbnl_scene_add_fog(L->c.scene, &d, err);
        if (r != VBNL_OK)
            return r;
    }
    if (L->natmosphere) {
        vbnl_medium_desc md;
        vbnl_medium_desc_init(&md);
        md.parts = L->atmosphere;
        md.part_count = L->natmosphere;
        uint32_t id;
        vbnl_result r = vbnl_scene_add_medium(L->c.scene, &md, &id, err);
        if (r != VBNL_OK || (r = vbnl_scene_set_atmosphere(L->c.scene, id + 1, err)) != VBNL_OK)
            return r;
    }
    return VBNL_OK;
}
