/* vbnl object layer: background { } and sky_sphere { } (POV-Ray 3.7 reference "Background",
 * "Sky Sphere"), the core scene's environment. `background` alone is a constant environment; a
 * sky_sphere is the core's pigment environment (vbnl_scene_set_environment_pigments): its
 * pigments evaluated on the unit sphere, layered over the background colour. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_loader.h"
#include "pov_matrix.h"

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

struct pov_sky {
    pov_pigment **layers;    /* in the file's order: the last is the top layer */
    uint32_t count, cap;
    double xf[16];           /* the sky_sphere's transform (its pigments see its inverse) */
    double emission[3];
};

void pov_sky_free(pov_sky *s)
{
    if (!s)
        return;
    for (uint32_t i = 0; i < s->count; ++i)
        pov_pigment_free(s->layers[i]);
    free(s->layers);
    free(s);
}

static pov_sky *sky_new(void)
{
    pov_sky *s = calloc(1, sizeof(*s));
    if (!s)
        return NULL;
    pov_m4_identity(s->xf);
    pov_set3(s->emission, 1, 1, 1);
    return s;
}

static int sky_push(pov_sky *s, pov_pigment *g)
{
    if (s->count == s->cap) {
        uint32_t cap = s->cap ? 2 * s->cap : 4;
        pov_pigment **n = realloc(s->layers, sizeof(*n) * cap);
        if (!n)
            return 0;
        s->layers = n;
        s->cap = cap;
    }
    s->layers[s->count++] = g;
    return 1;
}

static pov_sky *sky_dup(const pov_sky *src)
{
    pov_sky *s = sky_new();
    if (!s)
        return NULL;
    memcpy(s->xf, src->xf, sizeof(s->xf));
    memcpy(s->emission, src->emission, sizeof(s->emission));
    for (uint32_t i = 0; i < src->count; ++i) {
        pov_pigment *g = pov_pigment_dup(src->layers[i]);
        if (!g || !sky_push(s, g)) {
            pov_pigment_free(g);
            pov_sky_free(s);
            return NULL;
        }
    }
    return s;
}

static void sky_type_destroy(void *ptr, void *user)
{
    (void)user;
    pov_sky_free(ptr);
}

static void *sky_type_copy(const void *ptr, void *user)
{
    (void)user;
    return sky_dup(ptr);
}

const vbnl_sdl_opaque_type pov_sky_type = {"sky_sphere", sky_type_destroy, sky_type_copy, NULL, NULL};

typedef struct sky_parse {
    pov_sky *sky;
    int items;               /* items read so far (a declared sky_sphere must come first) */
} sky_parse;

static vbnl_result sky_pigment(const pov_item *it)
{
    pov_loader *L = it->ctx;
    sky_parse *sp = it->target;
    sp->items++;
    vbnl_sdl_next(it->p);
    pov_pigment *g = pov_pigment_new();
    if (!g)
        return pov_oom(L);
    if (pov_pigment_parse(&L->c, g) != VBNL_OK) {
        pov_pigment_free(g);
        return VBNL_ERR_PARSE;
    }
    if (!sky_push(sp->sky, g)) {
        pov_pigment_free(g);
        return pov_oom(L);
    }
    return VBNL_OK;
}

static vbnl_result sky_emission(const pov_item *it)
{
    double col[5];
    ((sky_parse *)it->target)->items++;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_color(it->p, col) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_set3(((sky_parse *)it->target)->sky->emission, col[0], col[1], col[2]);
    return VBNL_OK;
}

static void sky_transform(const pov_item *it, const double m[16])
{
    sky_parse *sp = it->target;
    double t[16];
    sp->items++;
    pov_m4_mul(m, sp->sky->xf, t);
    memcpy(sp->sky->xf, t, sizeof(t));
}

/* A declared sky_sphere as the first item: the block starts from a copy of it. */
static vbnl_result sky_unknown(const pov_item *it)
{
    pov_loader *L = it->ctx;
    sky_parse *sp = it->target;
    const pov_sky *d = pov_declared(L, it->tok, &pov_sky_type);
    if (!d || sp->items > 0)
        return pov_block_unexpected(it);
    sp->items++;
    vbnl_sdl_next(it->p);
    pov_sky *copy = sky_dup(d);
    if (!copy)
        return pov_oom(L);
    pov_sky_free(sp->sky);
    sp->sky = copy;
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
                                    .unknown = sky_unknown,
                                    .transform = sky_transform};

vbnl_result pov_sky_parse(pov_loader *L, const vbnl_sdl_loc *loc, pov_sky **out)
{
    vbnl_sdl_parser *p = L->c.parser;
    *out = NULL;
    if (vbnl_sdl_expect(p, '{', "after 'sky_sphere'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    sky_parse sp = {sky_new(), 0};
    if (!sp.sky)
        return pov_oom(L);
    if (pov_block_parse(&sky_block, p, L, &sp, NULL) != VBNL_OK) {
        pov_sky_free(sp.sky);
        return VBNL_ERR_PARSE;
    }
    if (sp.sky->count == 0) { /* as POV-Ray: "Empty sky_sphere statement." */
        pov_sky_free(sp.sky);
        return vbnl_sdl_error(p, loc, "sky_sphere needs at least one pigment");
    }
    *out = sp.sky;
    return VBNL_OK;
}

/* sky_sphere { [SKY_IDENT] pigment { ... } ... [emission c] [transforms] }: the scene's sky (the
 * last one given, as in POV-Ray). */
vbnl_result pov_sky_sphere_parse(pov_loader *L, const vbnl_sdl_loc *loc)
{
    pov_sky *s;
    if (pov_sky_parse(L, loc, &s) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (L->sky)
        vbnl_sdl_warning(L->c.parser, loc, "a second sky_sphere replaces the first (POV-Ray uses the last one)");
    pov_sky_free(L->sky);
    L->sky = s;
    return VBNL_OK;
}

vbnl_result pov_environment_build(pov_loader *L, vbnl_error *err)
{
    float bg[3] = {0, 0, 0};
    if (L->have_env)
        for (int k = 0; k < 3; ++k)
            bg[k] = (float)L->env[k];
    if (!L->sky) {
        if (bg[0] > 0 || bg[1] > 0 || bg[2] > 0)
            return vbnl_scene_set_environment(L->c.scene, bg, err);
        return VBNL_OK;
    }
    const pov_sky *s = L->sky;
    vbnl_environment_desc d;
    vbnl_environment_desc_init(&d);
    if (!pov_m4_invert(s->xf, d.pattern_from_world)) /* the transform rows refuse singular matrices */
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "the sky_sphere's transform is singular");
    for (int k = 0; k < 3; ++k) {
        /* POV-Ray scales the layers by the emission colour as given; a negative one would make a
         * negative radiance, which no light has */
        d.emission[k] = (float)fmax(s->emission[k], 0.0);
        d.background[k] = bg[k];
    }
    /* POV-Ray composes the layers by its older rule for scenes before 3.7 (its language version
     * when the parse ends) */
    d.legacy_layers = vbnl_sdl_language_version(L->c.parser) < 3.7 - 1e-9;
    uint32_t *ids = malloc(sizeof(uint32_t) * s->count);
    if (!ids)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbnl_result r = VBNL_OK;
    for (uint32_t i = 0; i < s->count && r == VBNL_OK; ++i)
        r = pov_pigment_core(&L->c, s->layers[i], &ids[i], err);
    if (r == VBNL_OK) {
        d.pigments = ids;
        d.pigment_count = s->count;
        r = vbnl_scene_set_environment_pigments(L->c.scene, &d, err);
    }
    free(ids);
    return r;
}
