/* Interim texture part (pov_internal.h), only so that the object layer builds and can be tested
 * before the real texture part lands; it is replaced by pov_texture*.c.
 *
 *   pigment { colour | ID }            solid colour (anything else in the block is skipped)
 *   finish  { diffuse d  emission e }  other finish items are skipped
 *   texture { ID pigment finish }      normal/interior/material/maps: skipped
 * Material: Lambertian, albedo = clamp(diffuse * colour) (diffuse 0.6 as POV-Ray),
 * emission = emission * colour (two-sided, as POV-Ray's emission). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_internal.h"

struct pov_appearance {
    double color[3];
    double diffuse;
    double emission[3];
};

typedef struct cached_material {
    vbnl_material_desc desc;
    uint32_t id;
} cached_material;

struct pov_texture_state {
    pov_appearance def;
    cached_material *cache;
    size_t ncache, capcache;
};

enum { IV_PIGMENT = 1, IV_FINISH, IV_TEXTURE, IV_OTHER };

static void iv_destroy(void *ptr, void *user)
{
    (void)user;
    free(ptr);
}

static void *iv_copy(const void *ptr, void *user)
{
    (void)user;
    pov_appearance *a = malloc(sizeof *a);
    if (a)
        *a = *(const pov_appearance *)ptr;
    return a;
}

static const vbnl_sdl_opaque_type iv_types[] = {
    {"none", iv_destroy, iv_copy, NULL},    {"pigment", iv_destroy, iv_copy, NULL},
    {"finish", iv_destroy, iv_copy, NULL},  {"texture", iv_destroy, iv_copy, NULL},
    {"appearance item", iv_destroy, iv_copy, NULL},
};

vbnl_result pov_texture_state_create(pov_ctx *c, vbnl_error *err)
{
    pov_texture_state *s = calloc(1, sizeof *s);
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    s->def.diffuse = 0.6;
    c->tex = s;
    return VBNL_OK;
}

void pov_texture_state_destroy(pov_ctx *c)
{
    if (!c->tex)
        return;
    free(c->tex->cache);
    free(c->tex);
    c->tex = NULL;
}

static int is_word(const vbnl_sdl_token *t, const char *w)
{
    return t->kind == VBNL_SDL_TOK_IDENT && strcmp(t->text, w) == 0;
}

int pov_appearance_is_modifier(const vbnl_sdl_token *tok)
{
    static const char *const words[] = {"texture", "pigment", "finish", "normal", "interior",
                                        "material", "interior_texture", NULL};
    for (int i = 0; words[i]; ++i)
        if (is_word(tok, words[i]))
            return 1;
    return 0;
}

/* Consumes the rest of a block whose '{' was read. */
static vbnl_result skip_rest(vbnl_sdl_parser *p)
{
    int depth = 1;
    while (depth > 0) {
        const vbnl_sdl_token *t = vbnl_sdl_next(p);
        if (t->kind == VBNL_SDL_TOK_EOF) {
            if (!vbnl_sdl_failed(p))
                vbnl_sdl_error(p, &t->loc, "missing '}'");
            return VBNL_ERR_PARSE;
        }
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '{')
            depth++;
        else if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}')
            depth--;
    }
    return VBNL_OK;
}

static const pov_appearance *declared(vbnl_sdl_parser *p, const vbnl_sdl_token *t, int tag)
{
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return NULL;
    const vbnl_sdl_value *v = vbnl_sdl_lookup(p, t->text);
    if (v && v->kind == VBNL_SDL_OBJECT && v->u.obj.type == &iv_types[tag])
        return v->u.obj.ptr;
    return NULL;
}

static int starts_color(vbnl_sdl_parser *p, const vbnl_sdl_token *t)
{
    if (t->kind == VBNL_SDL_TOK_NUMBER)
        return 1;
    if (t->kind == VBNL_SDL_TOK_PUNCT)
        return t->op == '<' || t->op == '(' || t->op == '-';
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    static const char *const words[] = {"color", "colour", "rgb", "rgbf", "rgbt", "rgbft", "srgb",
                                        "srgbf", "srgbt", "srgbft", "red", "green", "blue",
                                        "filter", "transmit", "gray", "grey", NULL};
    for (int i = 0; words[i]; ++i)
        if (is_word(t, words[i]))
            return 1;
    const vbnl_sdl_value *v = vbnl_sdl_lookup(p, t->text);
    return v && (v->kind == VBNL_SDL_COLOR || v->kind == VBNL_SDL_VECTOR || v->kind == VBNL_SDL_FLOAT);
}

static vbnl_result parse_pigment(vbnl_sdl_parser *p, pov_appearance *a)
{
    if (vbnl_sdl_expect(p, '{', "after 'pigment'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    const pov_appearance *d = declared(p, t, IV_PIGMENT);
    if (d) {
        memcpy(a->color, d->color, sizeof a->color);
        vbnl_sdl_next(p);
        t = vbnl_sdl_peek(p);
    }
    if (starts_color(p, t)) {
        double col[5];
        if (vbnl_sdl_parse_color(p, col) != VBNL_OK)
            return VBNL_ERR_PARSE;
        memcpy(a->color, col, sizeof a->color);
    }
    return skip_rest(p);
}

static vbnl_result parse_finish(vbnl_sdl_parser *p, pov_appearance *a)
{
    if (vbnl_sdl_expect(p, '{', "after 'finish'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (t->kind == VBNL_SDL_TOK_EOF)
            return skip_rest(p);
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        const pov_appearance *d = declared(p, t, IV_FINISH);
        if (d) {
            a->diffuse = d->diffuse;
            memcpy(a->emission, d->emission, sizeof a->emission);
            vbnl_sdl_next(p);
        } else if (is_word(t, "diffuse")) {
            vbnl_sdl_next(p);
            if (is_word(vbnl_sdl_peek(p), "albedo"))
                vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &a->diffuse) != VBNL_OK)
                return VBNL_ERR_PARSE;
        } else if (is_word(t, "emission")) {
            vbnl_sdl_next(p);
            double col[5];
            if (vbnl_sdl_parse_color(p, col) != VBNL_OK)
                return VBNL_ERR_PARSE;
            memcpy(a->emission, col, sizeof a->emission);
        } else if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '{') {
            if (vbnl_sdl_skip_block(p) != VBNL_OK)
                return VBNL_ERR_PARSE;
        } else {
            vbnl_sdl_next(p);
        }
    }
}

static vbnl_result parse_texture(vbnl_sdl_parser *p, pov_appearance *a)
{
    if (vbnl_sdl_expect(p, '{', "after 'texture'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    const pov_appearance *d = declared(p, t, IV_TEXTURE);
    if (d) {
        *a = *d;
        vbnl_sdl_next(p);
    }
    for (;;) {
        t = vbnl_sdl_peek(p);
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        vbnl_result r;
        if (is_word(t, "pigment")) {
            vbnl_sdl_next(p);
            r = parse_pigment(p, a);
        } else if (is_word(t, "finish")) {
            vbnl_sdl_next(p);
            r = parse_finish(p, a);
        } else {
            return skip_rest(p);
        }
        if (r != VBNL_OK)
            return r;
    }
}

static vbnl_result parse_item(vbnl_sdl_parser *p, const char *kw, pov_appearance *a)
{
    if (strcmp(kw, "pigment") == 0)
        return parse_pigment(p, a);
    if (strcmp(kw, "finish") == 0)
        return parse_finish(p, a);
    if (strcmp(kw, "texture") == 0) {
        vbnl_result r = parse_texture(p, a);
        /* layered textures: the last layer wins here */
        while (r == VBNL_OK && is_word(vbnl_sdl_peek(p), "texture")) {
            vbnl_sdl_next(p);
            r = parse_texture(p, a);
        }
        return r;
    }
    return vbnl_sdl_skip_block(p);
}

vbnl_result pov_appearance_parse_modifier(pov_ctx *c, pov_appearance **app)
{
    vbnl_sdl_token kw = *vbnl_sdl_next(c->parser);
    if (!*app) {
        *app = pov_appearance_default(c);
        if (!*app)
            return vbnl_sdl_error(c->parser, &kw.loc, "out of memory");
    }
    return parse_item(c->parser, kw.text, *app);
}

int pov_appearance_rvalue(pov_ctx *c, const vbnl_sdl_token *tok, vbnl_sdl_value *out)
{
    static const char *const words[] = {"texture", "pigment", "finish", "normal", "interior",
                                        "material", "color_map", "colour_map", "pigment_map",
                                        "normal_map", "texture_map", "slope_map", "density",
                                        "media", NULL};
    int tag = 0;
    for (int i = 0; words[i]; ++i)
        if (is_word(tok, words[i]))
            tag = i == 0 ? IV_TEXTURE : i == 1 ? IV_PIGMENT : i == 2 ? IV_FINISH : IV_OTHER;
    if (!tag)
        return 0;
    pov_appearance *a = pov_appearance_default(c);
    if (!a) {
        vbnl_sdl_error(c->parser, &tok->loc, "out of memory");
        return -1;
    }
    vbnl_sdl_token kw = *vbnl_sdl_next(c->parser);
    if (parse_item(c->parser, kw.text, a) != VBNL_OK) {
        free(a);
        return -1;
    }
    vbnl_sdl_value_object(out, a, &iv_types[tag], tag);
    return 1;
}

int pov_appearance_default_block(pov_ctx *c)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after '#default'") != VBNL_OK)
        return -1;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return 1;
        }
        if (t->kind != VBNL_SDL_TOK_IDENT) {
            vbnl_sdl_error(p, &t->loc, "expected texture, pigment, finish or normal in #default");
            return -1;
        }
        vbnl_sdl_token kw = *vbnl_sdl_next(p);
        if (parse_item(p, kw.text, &c->tex->def) != VBNL_OK)
            return -1;
    }
}

pov_appearance *pov_appearance_copy(const pov_appearance *a)
{
    return a ? iv_copy(a, NULL) : NULL;
}

void pov_appearance_free(pov_appearance *a) { free(a); }

pov_appearance *pov_appearance_default(pov_ctx *c) { return pov_appearance_copy(&c->tex->def); }

void pov_appearance_transform(pov_appearance *a, const double m[16])
{
    (void)a; /* solid colours do not move */
    (void)m;
}

static float clamp01(double v) { return v < 0 ? 0.0f : v > 1 ? 1.0f : (float)v; }

vbnl_result pov_appearance_material(pov_ctx *c, const pov_appearance *a,
                                    const double world_from_pov[16], uint32_t *material,
                                    vbnl_error *err)
{
    (void)world_from_pov;
    vbnl_material_desc d;
    memset(&d, 0, sizeof d);
    vbnl_material_desc_init(&d);
    d.type = VBNL_MATERIAL_LAMBERT;
    for (int i = 0; i < 3; ++i) {
        d.base_color[i] = clamp01(a->diffuse * a->color[i]);
        double e = a->emission[i] * a->color[i];
        d.emission[i] = e > 0 && isfinite(e) ? (float)e : 0.0f;
    }
    d.two_sided = 1;
    pov_texture_state *s = c->tex;
    for (size_t i = 0; i < s->ncache; ++i)
        if (memcmp(&s->cache[i].desc, &d, sizeof d) == 0) {
            *material = s->cache[i].id;
            return VBNL_OK;
        }
    uint32_t id;
    vbnl_result r = vbnl_scene_add_material(c->scene, &d, &id, err);
    if (r != VBNL_OK)
        return r;
    if (s->ncache == s->capcache) {
        size_t cap = s->capcache ? 2 * s->capcache : 16;
        cached_material *n = realloc(s->cache, cap * sizeof *n);
        if (!n)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        s->cache = n;
        s->capcache = cap;
    }
    s->cache[s->ncache].desc = d;
    s->cache[s->ncache++].id = id;
    *material = id;
    return VBNL_OK;
}

int pov_appearance_is_emissive(const pov_appearance *a)
{
    for (int i = 0; i < 3; ++i)
        if (a->emission[i] * a->color[i] > 0)
            return 1;
    return 0;
}
