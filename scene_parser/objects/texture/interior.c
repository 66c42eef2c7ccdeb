/* vbnl object layer, texture part: interior { } and material { texture interior vbnl_bsdf }. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

/* ---- interior { } ------------------------------------------------------------------------------ */

static vbnl_result ior(const pov_item *it)
{
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(v >= 1.0 && v < 10.0))
        return vbnl_sdl_error(it->p, &it->loc, "ior must lie in [1, 10) (got %g)", v);
    ((pov_interior *)it->target)->ior = v;
    return VBNL_OK;
}

static vbnl_result fade_color(const pov_item *it)
{
    pov_interior *in = it->target;
    vbnl_sdl_next(it->p);
    if (pov_parse_color3(it->ctx, in->fade_color) != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (int k = 0; k < 3; ++k)
        if (!isfinite(in->fade_color[k]))
            return vbnl_sdl_error(it->p, &it->loc, "fade_color must be finite (got %g)", in->fade_color[k]);
    return VBNL_OK;
}

static vbnl_result fade_number(const pov_item *it, double *out)
{
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, out) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!isfinite(*out))
        return vbnl_sdl_error(it->p, &it->loc, "%s must be finite (got %g)", it->kw, *out);
    return VBNL_OK;
}

static vbnl_result fade_distance(const pov_item *it) { return fade_number(it, &((pov_interior *)it->target)->fade_distance); }
static vbnl_result fade_power(const pov_item *it) { return fade_number(it, &((pov_interior *)it->target)->fade_power); }

int pov_interior_fade(const pov_interior *in, float sigma[3])
{
    const double dist = in->fade_distance, power = in->fade_power;
    if (!(dist > 0.0) || !(power > 0.0))
        return 0;
    for (int k = 0; k < 3; ++k) {
        /* a colour outside [0, 1] would make the interior amplify light: held to [0, 1] */
        const double fc = in->fade_color[k] < 0.0 ? 0.0 : (in->fade_color[k] > 1.0 ? 1.0 : in->fade_color[k]);
        /* exponential (power >= 1000): POV-Ray's exp(-(1 - fc) d / dist) is Beer-Lambert's law
         * exactly; the power law fc + (1 - fc) / (1 + (d / dist)^power) is matched where it is
         * defined, at d = dist, where it lets (1 + fc) / 2 through */
        const double s = power >= 1000.0 ? (1.0 - fc) / dist : log(2.0 / (1.0 + fc)) / dist;
        sigma[k] = (float)s;
    }
    return sigma[0] > 0.0f || sigma[1] > 0.0f || sigma[2] > 0.0f;
}

/* ---- density { } ------------------------------------------------------------------------------ */

vbnl_result pov_density_parse(pov_ctx *c, uint32_t *id)
{
    pov_texture_state *s = c->tex;
    if (s->density_count == s->density_cap) {
        uint32_t cap = s->density_cap ? 2 * s->density_cap : 8;
        pov_pigment **grown = realloc(s->densities, sizeof(*grown) * cap);
        if (!grown)
            return vbnl_sdl_error(c->parser, NULL, "out of memory");
        s->densities = grown;
        s->density_cap = cap;
    }
    /* POV-Ray's density starts as a new pigment (black: a density { } without a pattern is 0) */
    pov_pigment *g = pov_pigment_new();
    if (!g)
        return vbnl_sdl_error(c->parser, NULL, "out of memory");
    if (pov_density_body(c, g) != VBNL_OK) {
        pov_pigment_free(g);
        return VBNL_ERR_PARSE;
    }
    *id = s->density_count;
    s->densities[s->density_count++] = g;
    return VBNL_OK;
}

pov_pigment *pov_density_at(pov_ctx *c, uint32_t id) { return c->tex->densities[id]; }

/* ---- media { } ------------------------------------------------------------------------------ */

typedef struct media_item {
    vbnl_medium_part_desc *part;
    double extinction;          /* the scattering's extinction e (1) */
    vbnl_sdl_loc extinction_loc;
    uint32_t *density; /* where the density { } blocks go (indices + 1), NULL: not kept (warned) */
    uint32_t ndensity;
    int warned_density;
    int declared; /* a declared media identifier was named: the block is left out */
} media_item;

static vbnl_result media_colour(const pov_item *it, float out[3])
{
    double col[3];
    vbnl_sdl_next(it->p);
    if (pov_parse_color3(it->ctx, col) != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (int k = 0; k < 3; ++k) {
        if (!(col[k] >= 0.0) || !(col[k] < 1e30))
            return vbnl_sdl_error(it->p, &it->loc, "media %s must be finite and not negative (got %g)", it->kw, col[k]);
        out[k] = (float)col[k];
    }
    return VBNL_OK;
}

static vbnl_result media_absorption(const pov_item *it)
{
    return media_colour(it, ((media_item *)it->target)->part->absorption);
}

static vbnl_result media_emission(const pov_item *it)
{
    return media_colour(it, ((media_item *)it->target)->part->emission);
}

static vbnl_result scat_eccentricity(const pov_item *it)
{
    double g;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &g) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(g > -1.0 && g < 1.0))
        return vbnl_sdl_error(it->p, &it->loc, "eccentricity must lie in (-1, 1) (got %g)", g);
    ((media_item *)it->target)->part->g = (float)g;
    return VBNL_OK;
}

/* extinction e: the share of the scattering in the extinction (POV-Ray's media.cpp: extinction =
 * absorption + e scattering), the in-scattering unchanged; held where the albedo stays at most 1
 * when the media block ends (media_extinction) */
static vbnl_result scat_extinction(const pov_item *it)
{
    media_item *m = it->target;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &m->extinction) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(m->extinction >= 0.0) || !(m->extinction < 1e30))
        return vbnl_sdl_error(it->p, &it->loc, "scattering extinction must be finite and not negative (got %g)",
                              m->extinction);
    m->extinction_loc = it->loc;
    return VBNL_OK;
}

/* The part's extinction deficit 1 - e. POV-Ray scatters light once (from the lights and photons),
 * so its e < 1 only brightens; a path tracer scatters many times, and where sigma_a + e sigma_s <
 * sigma_s every scattering gains energy and the radiance of an optically thick medium grows
 * without bound. So e is raised to the least value that keeps the albedo at most 1 in every
 * channel, 1 - sigma_a / sigma_s (warned). */
static void media_extinction(pov_ctx *c, media_item *m)
{
    vbnl_medium_part_desc *part = m->part;
    double e = m->extinction, least = 0.0;
    for (int k = 0; k < 3; ++k)
        if (part->scattering[k] > 0.0f) {
            double l = 1.0 - (double)part->absorption[k] / part->scattering[k];
            least = l > least ? l : least;
        }
    if (e < least) {
        vbnl_sdl_warning(c->parser, &m->extinction_loc,
                         "scattering extinction %g would make the media gain energy when light scatters more than "
                         "once (POV-Ray scatters once): raised to %g, where its albedo is 1",
                         e, least);
        e = least;
    }
    part->extinction_deficit = (float)(1.0 - e);
}

static const pov_row scattering_rows[] = {
    {"eccentricity", scat_eccentricity, 0},
    {"extinction", scat_extinction, 0},
    {NULL, NULL, 0},
};
static const pov_row *const scattering_tables[] = {scattering_rows, NULL};
static const pov_block scattering_items = {.name = "scattering",
                                           .tables = scattering_tables,
                                           .unknown = pov_block_unexpected_word};

/* scattering { type, colour [eccentricity g] [extinction e] } */
static vbnl_result media_scattering(const pov_item *it)
{
    media_item *m = it->target;
    vbnl_sdl_next(it->p);
    double type;
    if (vbnl_sdl_expect(it->p, '{', "after 'scattering'") != VBNL_OK || vbnl_sdl_parse_float(it->p, &type) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(type == 1 || type == 2 || type == 3 || type == 4 || type == 5))
        return vbnl_sdl_error(it->p, &it->loc, "scattering type must be 1 to 5 (got %g)", type);
    m->part->phase = (vbnl_phase_kind)(int)type;
    if (pov_is_punct(vbnl_sdl_peek(it->p), ','))
        vbnl_sdl_next(it->p);
    double col[3];
    if (pov_parse_color3(it->ctx, col) != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (int k = 0; k < 3; ++k) {
        if (!(col[k] >= 0.0) || !(col[k] < 1e30))
            return vbnl_sdl_error(it->p, &it->loc, "scattering colour must be finite and not negative (got %g)", col[k]);
        m->part->scattering[k] = (float)col[k];
    }
    return pov_block_parse(&scattering_items, it->p, it->ctx, m, NULL);
}

/* density { } (reference "Density"): a pigment whose colour multiplies the media at a point;
 * several multiply. Kept in the state's list and named by index, so that interiors stay plain
 * values; the atmosphere's media do not keep them (warned: taken as constant). */
static vbnl_result media_density(const pov_item *it)
{
    media_item *m = it->target;
    vbnl_sdl_next(it->p);
    if (!m->density) {
        if (vbnl_sdl_skip_block(it->p) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!m->warned_density)
            vbnl_sdl_warning(it->p, &it->loc, "a density in the atmosphere's media is not supported: taken as constant");
        m->warned_density = 1;
        return VBNL_OK;
    }
    if (m->ndensity >= VBNL_MEDIUM_DENSITY_MAX)
        return vbnl_sdl_error(it->p, &it->loc, "a media holds at most %u density blocks", VBNL_MEDIUM_DENSITY_MAX);
    uint32_t id;
    if (pov_density_parse(it->ctx, &id) != VBNL_OK)
        return VBNL_ERR_PARSE;
    m->density[m->ndensity++] = id + 1;
    return VBNL_OK;
}

/* Sampling controls: one float, or two for `samples min, max`. */
static vbnl_result media_control(const pov_item *it)
{
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pov_is_punct(vbnl_sdl_peek(it->p), ',')) {
        vbnl_sdl_next(it->p);
        if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
    return VBNL_OK;
}

/* POV-Ray's media transforms move the densities given before them (Transform_Media). */
static void media_transform(const pov_item *it, const double m[16])
{
    const media_item *mi = it->target;
    for (uint32_t k = 0; k < mi->ndensity; ++k)
        if (!pov_pattern_transform(&pov_density_at(it->ctx, mi->density[k] - 1)->pat, m))
            vbnl_sdl_error(it->p, &it->loc, "a pattern has at most %d warps and transforms", POV_WARP_MAX);
}

static const pov_row media_rows[] = {
    {"absorption", media_absorption, 0},
    {"emission", media_emission, 0},
    {"scattering", media_scattering, 0},
    {"density", media_density, 0},
    {"method", media_control, 0},
    {"intervals", media_control, 0},
    {"samples", media_control, 0},
    {"confidence", media_control, 0},
    {"variance", media_control, 0},
    {"ratio", media_control, 0},
    {"jitter", media_control, 0},
    {"aa_threshold", media_control, 0},
    {"aa_level", media_control, 0},
    {NULL, NULL, 0},
};
/* A declared media (`media { Media }`): not kept as a value, so the block is left out, warned. */
static vbnl_result media_unknown(const pov_item *it)
{
    if (it->tok->kind != VBNL_SDL_TOK_IDENT || !vbnl_sdl_lookup(it->p, it->tok->text))
        return pov_block_unexpected_word(it);
    vbnl_sdl_warning(it->p, &it->loc, "declared media '%s' is not supported: the media is left out", it->tok->text);
    ((media_item *)it->target)->declared = 1;
    vbnl_sdl_next(it->p);
    return VBNL_OK;
}

static const pov_row *const media_tables[] = {media_rows, pov_pattern_transform_rows, NULL};
static const pov_block media_items = {.name = "media",
                                      .tables = media_tables,
                                      .unknown = media_unknown,
                                      .transform = media_transform};

vbnl_result pov_media_parse(pov_ctx *c, vbnl_medium_part_desc *part, uint32_t density[VBNL_MEDIUM_DENSITY_MAX])
{
    memset(part, 0, sizeof(*part));
    part->phase = VBNL_PHASE_ISOTROPIC;
    if (density)
        memset(density, 0, sizeof(uint32_t) * VBNL_MEDIUM_DENSITY_MAX);
    if (vbnl_sdl_expect(c->parser, '{', "after 'media'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    media_item m = {.part = part, .extinction = 1.0, .density = density};
    vbnl_result r = pov_block_parse(&media_items, c->parser, c, &m, NULL);
    if (r == VBNL_OK)
        media_extinction(c, &m);
    if (m.declared)
        part->phase = 0; /* left out: the callers keep only parts with a phase */
    return r;
}

static vbnl_result media(const pov_item *it)
{
    pov_interior *in = it->target;
    vbnl_sdl_next(it->p);
    if (in->nmedia >= VBNL_MEDIUM_PARTS_MAX)
        return vbnl_sdl_error(it->p, &it->loc, "an interior holds at most %u media", VBNL_MEDIUM_PARTS_MAX);
    vbnl_result r = pov_media_parse(it->ctx, &in->media[in->nmedia], in->density[in->nmedia]);
    if (r == VBNL_OK && in->media[in->nmedia].phase) {
        pov_m4_identity(in->xf[in->nmedia]); /* the transforms from here on move it */
        in->nmedia++;
    }
    return r;
}

static int copy_interior(void *dst, const void *src)
{
    memcpy(dst, src, sizeof(pov_interior));
    return 1;
}

static const pov_row interior_rows[] = {
    {"ior", ior, 0},
    {"caustics", pov_item_any_float, 0},
    {"dispersion", pov_item_any_float, 0},
    {"dispersion_samples", pov_item_any_float, 0},
    {"fade_distance", fade_distance, 0},
    {"fade_power", fade_power, 0},
    {"fade_color", fade_color, 0},
    {"fade_colour", fade_color, 0},
    {"media", media, 0},
    {NULL, NULL, 0},
};
static const pov_row *const interior_tables[] = {interior_rows, NULL};
static const pov_block interior_items = {.name = "interior",
                                         .tables = interior_tables,
                                         .unknown = pov_block_unexpected_word};

void pov_interior_init(pov_interior *in)
{
    memset(in, 0, sizeof(*in));
    in->ior = 1.0;
    for (uint32_t i = 0; i < VBNL_MEDIUM_PARTS_MAX; ++i)
        pov_m4_identity(in->xf[i]);
}

void pov_interior_transform(pov_interior *in, const double m[16])
{
    for (uint32_t i = 0; i < in->nmedia; ++i)
        pov_m4_mul(m, in->xf[i], in->xf[i]);
}

vbnl_result pov_interior_parse(pov_ctx *c, pov_interior *in)
{
    vbnl_sdl_loc loc = vbnl_sdl_peek(c->parser)->loc;
    if (vbnl_sdl_expect(c->parser, '{', "after 'interior'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pov_take_ident(c, &pov_type_interior, in, copy_interior) < 0)
        return VBNL_ERR_PARSE;
    vbnl_result r = pov_block_parse(&interior_items, c->parser, c, in, NULL);
    in->medium = 0;
    if (r == VBNL_OK && in->fade_distance > 0.0 && !(in->fade_power > 0.0))
        vbnl_sdl_warning(c->parser, &loc,
                         "fade_power %g: POV-Ray fades with distance only for a fade_power above 0: no fade",
                         in->fade_power);
    return r;
}

/* ---- material { } ------------------------------------------------------------------------------ */

static vbnl_result mat_interior(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_interior_parse(it->ctx, &((pov_appearance *)it->target)->interior);
}

static vbnl_result mat_bsdf(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_bsdf_parse(it->ctx, &((pov_appearance *)it->target)->tex->ext);
}

/* POV-Ray's material transforms move its textures (Transform_Textures). */
static void mat_transform(const pov_item *it, const double m[16])
{
    pov_appearance *a = it->target;
    pov_interior_transform(&a->interior, m);
    if (!pov_texture_transform(a->tex, m))
        vbnl_sdl_error(it->p, &it->loc, "a pattern has at most %d warps and transforms", POV_WARP_MAX);
}

static const pov_row material_rows[] = {
    {"texture", pov_appearance_texture_item, 0},
    {"interior", mat_interior, 0},
    {"vbnl_bsdf", mat_bsdf, 0},
    {NULL, NULL, 0},
};
static const pov_row *const material_tables[] = {material_rows, pov_pattern_transform_rows, NULL};
static const pov_block material_items = {.name = "material",
                                         .tables = material_tables,
                                         .unknown = pov_block_unexpected_word,
                                         .transform = mat_transform};

static int copy_material(void *dst, const void *src)
{
    pov_appearance *a = dst;
    const pov_appearance *m = src;
    pov_texture *t = m->tex ? pov_texture_dup(m->tex) : NULL;
    if (m->tex && !t)
        return 0;
    pov_texture_free(a->tex);
    a->tex = t;
    a->interior = m->interior;
    a->own_texture = 1;
    return 1;
}

vbnl_result pov_material_parse(pov_ctx *c, pov_appearance *a)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'material'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    /* POV-Ray's material starts over: its first texture replaces the object's */
    int had = a->own_texture;
    a->own_texture = 0;
    if (pov_take_ident(c, &pov_type_material, a, copy_material) < 0)
        return VBNL_ERR_PARSE;
    vbnl_result r = pov_block_parse(&material_items, c->parser, c, a, NULL);
    a->own_texture |= had;
    return r;
}
