/* vbnl object layer, texture part: finish { }. Its mapping onto a core material is in
 * core_material.c (the table in scene_parser/README.md). */
#include <math.h>
#include <string.h>

#include "pov_texture.h"

void pov_finish_init(pov_finish *f)
{
    memset(f, 0, sizeof(*f));
    f->diffuse = 0.6;
    f->roughness = 0.05;
    f->phong_size = 40.0;
    f->brilliance = 1.0;
    f->falloff = 1.0;
}

vbnl_result pov_parse_color3(pov_ctx *c, double out[3])
{
    double col[5];
    if (vbnl_sdl_parse_color(c->parser, col) != VBNL_OK)
        return VBNL_ERR_PARSE;
    out[0] = col[0];
    out[1] = col[1];
    out[2] = col[2];
    return VBNL_OK;
}

/* An optional float after a flag keyword (`metallic [amount]`, `fresnel [on]`): a value starts
 * unless the next token ends the block or is another finish / reflection keyword. */
static int optional_value_follows(const vbnl_sdl_token *n)
{
    static const char *const kws[] = {
        "ambient", "diffuse", "specular", "emission", "roughness", "phong", "phong_size", "brilliance",
        "crand", "reflection_exponent", "metallic", "reflection", "irid", "subsurface", "conserve_energy",
        "fresnel", "falloff", "exponent", "color", "colour", "rgb", "rgbf", "rgbt", "rgbft", "srgb",
        "srgbf", "srgbt", "srgbft", "albedo", NULL};
    if (n->kind == VBNL_SDL_TOK_PUNCT)
        return n->op == '(' || n->op == '-' || n->op == '+';
    if (n->kind == VBNL_SDL_TOK_NUMBER)
        return 1;
    if (n->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    for (int i = 0; kws[i]; ++i)
        if (!strcmp(n->text, kws[i]))
            return 0;
    return 1;
}

/* ---- reflection { [min colour,] max colour [metallic [m]] [fresnel [on]] [falloff f] [exponent e] } --
 * POV-Ray 3.7 reference, "Reflection": the reflectivity is min + (max - min) (1 - cos)^falloff at
 * the angle of incidence (with `fresnel`, the interior's Fresnel reflectance in place of the
 * curve); one colour gives min = max. core_material.c maps it onto the core's coat curves. */

typedef struct reflection_block {
    pov_finish *f;
    int colours; /* colours given so far (the first is the minimum, a second the maximum) */
} reflection_block;

static vbnl_result refl_metallic(const pov_item *it)
{
    double v = 1.0;
    vbnl_sdl_next(it->p);
    if (optional_value_follows(vbnl_sdl_peek(it->p)) && vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(v >= 0.0 && v <= 1.0))
        return vbnl_sdl_error(it->p, &it->loc, "reflection 'metallic' must lie in [0, 1] (got %g)", v);
    ((reflection_block *)it->target)->f->reflect_metallic = v;
    return VBNL_OK;
}

/* fresnel [on]: the reflection follows the Fresnel term of the interior's ior */
static vbnl_result refl_fresnel(const pov_item *it)
{
    double v = 1;
    vbnl_sdl_next(it->p);
    if (optional_value_follows(vbnl_sdl_peek(it->p)) && vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    ((reflection_block *)it->target)->f->fresnel = v != 0;
    return VBNL_OK;
}

static vbnl_result refl_falloff(const pov_item *it)
{
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(v > 0.0 && v <= 1000.0))
        return vbnl_sdl_error(it->p, &it->loc, "reflection 'falloff' must lie in (0, 1000] (got %g)", v);
    ((reflection_block *)it->target)->f->falloff = v;
    return VBNL_OK;
}

/* reflection { exponent e } and finish { reflection_exponent e }: POV-Ray raises the light
 * arriving along the mirror direction to the power 1 / e before weighting it by the reflectivity
 * (its trace.cpp), a function of the light itself that no reflectance (linear in the light) can
 * express. */
static vbnl_result refl_exponent(const pov_item *it)
{
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (v != 1.0)
        vbnl_sdl_warning(it->p, &it->loc,
                         "'%s' %g is ignored: it raises the reflected light to the power %.3g, which a linear "
                         "reflectance cannot do",
                         it->kw, v, v != 0.0 ? 1.0 / v : HUGE_VAL);
    return VBNL_OK;
}

static int refl_color(const pov_item *it)
{
    reflection_block *b = it->target;
    pov_finish *f = b->f;
    double col[3];
    if (b->colours >= 2) {
        vbnl_sdl_error(it->p, &it->loc, "reflection takes at most two colours (minimum, maximum)");
        return -1;
    }
    if (pov_parse_color3(it->ctx, col) != VBNL_OK)
        return -1;
    vbnl_sdl_accept(it->p, ',');
    if (b->colours == 0)
        memcpy(f->reflection_min, col, sizeof(col));
    memcpy(f->reflection, col, sizeof(col));
    b->colours++;
    return 1;
}

static const pov_row reflection_rows[] = {
    {"metallic", refl_metallic, 0},
    {"fresnel", refl_fresnel, 0},
    {"falloff", refl_falloff, 0},
    {"exponent", refl_exponent, 0},
    {NULL, NULL, 0},
};
static const pov_row *const reflection_tables[] = {reflection_rows, NULL};
static const pov_block reflection_items = {.name = "reflection",
                                           .tables = reflection_tables,
                                           .after = refl_color,
                                           .eof = "unexpected end of file in reflection"};

/* ---- finish { } -------------------------------------------------------------------------------- */

static vbnl_result ambient(const pov_item *it) /* ignored under global illumination */
{
    double col[3];
    vbnl_sdl_next(it->p);
    return pov_parse_color3(it->ctx, col);
}

/* diffuse [albedo] d [, back] and specular [albedo] s */
static vbnl_result diffuse_specular(const pov_item *it)
{
    pov_finish *f = it->target;
    vbnl_sdl_parser *p = it->p;
    int diff = !strcmp(it->kw, "diffuse");
    double v;
    vbnl_sdl_next(p);
    if (pov_is_word(vbnl_sdl_peek(p), "albedo"))
        vbnl_sdl_next(p);
    if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (diff && vbnl_sdl_accept(p, ',')) { /* diffuse front, back */
        double back;
        if (vbnl_sdl_parse_float(p, &back) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
    if (!(v >= 0.0))
        return vbnl_sdl_error(p, &it->loc, "'%s' must be >= 0", diff ? "diffuse" : "specular");
    *(diff ? &f->diffuse : &f->specular) = v;
    return VBNL_OK;
}

static vbnl_result emission(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_parse_color3(it->ctx, ((pov_finish *)it->target)->emission);
}

/* keyword amount (metallic [amount]): roughness phong phong_size brilliance crand
 * metallic */
static vbnl_result amount(const pov_item *it)
{
    pov_finish *f = it->target;
    vbnl_sdl_parser *p = it->p;
    const char *kw = it->kw;
    vbnl_sdl_next(p);
    int is_metal = !strcmp(kw, "metallic");
    double v = 1.0;
    if ((!is_metal || optional_value_follows(vbnl_sdl_peek(p))) && vbnl_sdl_parse_float(p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!strcmp(kw, "roughness")) {
        if (!(v > 0.0))
            return vbnl_sdl_error(p, &it->loc, "roughness must be > 0");
        f->roughness = v;
    } else if (!strcmp(kw, "phong")) {
        if (pov_is_word(vbnl_sdl_peek(p), "albedo"))
            vbnl_sdl_next(p);
        f->phong = v;
    } else if (!strcmp(kw, "phong_size")) {
        if (!(v >= 0.0))
            return vbnl_sdl_error(p, &it->loc, "phong_size must be >= 0");
        f->phong_size = v;
    } else if (is_metal) {
        f->metallic = v > 0.0;
    } else if (!strcmp(kw, "brilliance")) {
        /* b > 1: the core's brilliance BSDF (docs/scene-language.md); b < 1 widens POV-Ray's
         * falloff beyond Lambert's, which no energy-conserving reciprocal lobe does */
        if (v < 1.0)
            vbnl_sdl_warning(p, &it->loc, "'brilliance' %g below 1 is rendered as 1 (Lambertian)", v);
        f->brilliance = v > 1000.0 ? 1000.0 : v < 1.0 ? 1.0 : v;
    }
    return VBNL_OK;
}

/* reflection colour | reflection { ... } */
static vbnl_result reflection(const pov_item *it)
{
    pov_finish *f = it->target;
    vbnl_sdl_next(it->p);
    f->falloff = 1.0; /* a new reflection starts over, as in POV-Ray */
    if (vbnl_sdl_accept(it->p, '{')) {
        reflection_block b = {f, 0};
        if (pov_block_parse(&reflection_items, it->p, it->ctx, &b, NULL) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (b.colours == 0)
            return vbnl_sdl_error(it->p, &it->loc, "reflection { } needs a colour");
        return VBNL_OK;
    }
    if (pov_parse_color3(it->ctx, f->reflection) != VBNL_OK)
        return VBNL_ERR_PARSE;
    memcpy(f->reflection_min, f->reflection, sizeof(f->reflection));
    return VBNL_OK;
}

static vbnl_result unsupported(const pov_item *it) /* irid { }, subsurface { } */
{
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_skip_block(it->p) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(it->p, &it->loc, "finish '%s' is not supported: ignored", it->kw);
    return VBNL_OK;
}

static const pov_row finish_rows[] = {
    {"ambient", ambient, 0},
    {"diffuse", diffuse_specular, 0},
    {"specular", diffuse_specular, 0},
    {"emission", emission, 0},
    {"roughness", amount, 0},
    {"phong", amount, 0},
    {"phong_size", amount, 0},
    {"brilliance", amount, 0},
    {"crand", amount, 0},
    {"reflection_exponent", refl_exponent, 0},
    {"metallic", amount, 0},
    {"reflection", reflection, 0},
    {"irid", unsupported, 0},
    {"subsurface", unsupported, 0},
    {"conserve_energy", pov_item_word, 0},
    {NULL, NULL, 0},
};
static const pov_row *const finish_tables[] = {finish_rows, NULL};
static const pov_block finish_items = {.name = "finish",
                                       .tables = finish_tables,
                                       .unknown = pov_block_unexpected_word};

static int copy_finish(void *dst, const void *src)
{
    memcpy(dst, src, sizeof(pov_finish));
    return 1;
}

vbnl_result pov_finish_parse(pov_ctx *c, pov_finish *f)
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'finish'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (pov_take_ident(c, &pov_type_finish, f, copy_finish) < 0)
        return VBNL_ERR_PARSE;
    return pov_block_parse(&finish_items, c->parser, c, f, NULL);
}
