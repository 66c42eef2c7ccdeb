/* vbnl object layer, texture part: the interface the object part uses (pov_internal.h): the
 * texture state, appearance modifiers of objects, `#declare` values, #default, and appearances
 * as values. */
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

/* ---- declared values ----------------------------------------------------------------------------- */

enum { TAG_TEXTURE = 1, TAG_PIGMENT, TAG_FINISH, TAG_NORMAL, TAG_INTERIOR, TAG_MATERIAL, TAG_COLOR_MAP };

/* Values are plain structs: `user` is their size. */
static void *blob_copy(const void *ptr, void *user)
{
    size_t n = (size_t)(uintptr_t)user;
    void *q = malloc(n);
    if (q)
        memcpy(q, ptr, n);
    return q;
}

static void blob_free(void *ptr, void *user)
{
    (void)user;
    free(ptr);
}

/* `#declare T = texture { A } texture { B }`: the layers make one texture as on an object. */
static void *texture_layer(void *below, void *above, void *user)
{
    (void)user;
    pov_texture_put_layer(below, above);
    free(above);
    return below;
}

#define BLOB(T) blob_free, blob_copy, (void *)(uintptr_t)sizeof(T)
const vbnl_sdl_opaque_type pov_type_texture = {"texture", BLOB(pov_texture), texture_layer};
const vbnl_sdl_opaque_type pov_type_pigment = {"pigment", BLOB(pov_pigment), NULL};
const vbnl_sdl_opaque_type pov_type_finish = {"finish", BLOB(pov_finish), NULL};
const vbnl_sdl_opaque_type pov_type_normal = {"normal", BLOB(pov_normal), NULL};
const vbnl_sdl_opaque_type pov_type_interior = {"interior", BLOB(pov_interior), NULL};
const vbnl_sdl_opaque_type pov_type_material = {"material", BLOB(pov_appearance), NULL};
const vbnl_sdl_opaque_type pov_type_color_map = {"color_map", BLOB(pov_color_map), NULL};
#undef BLOB

int pov_take_ident(pov_ctx *c, const vbnl_sdl_opaque_type *type, void *dst, size_t size)
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *tok = vbnl_sdl_peek(p);
    if (tok->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    const vbnl_sdl_value *v = vbnl_sdl_lookup(p, tok->text);
    if (!v)
        return 0;
    if (v->kind == VBNL_SDL_OBJECT && v->u.obj.type == type) {
        vbnl_sdl_loc use = tok->loc;
        memcpy(dst, v->u.obj.ptr, size);
        vbnl_sdl_defer_use(p, v->u.obj.deferred, &use);
        vbnl_sdl_next(p);
        return 1;
    }
    if (v->kind != VBNL_SDL_ARRAY)
        return 0;
    vbnl_sdl_loc loc = tok->loc;
    vbnl_sdl_value e;
    if (vbnl_sdl_parse_expression(p, &e) != VBNL_OK)
        return -1;
    if (e.kind != VBNL_SDL_OBJECT || e.u.obj.type != type) {
        const char *kind = e.kind == VBNL_SDL_OBJECT ? e.u.obj.type->name : vbnl_sdl_kind_name(e.kind);
        vbnl_sdl_value_clear(p, &e);
        vbnl_sdl_error(p, &loc, "array element is a %s, not a %s", kind, type->name);
        return -1;
    }
    memcpy(dst, e.u.obj.ptr, size);
    vbnl_sdl_defer_use(p, e.u.obj.deferred, &loc);
    vbnl_sdl_value_clear(p, &e);
    return 1;
}

/* `#declare X = texture { ... }` (pigment, ...): `arg` is the value's tag. */
static vbnl_result declared_value(const pov_item *it)
{
    static const vbnl_sdl_opaque_type *const types[] = {
        [TAG_TEXTURE] = &pov_type_texture,   [TAG_PIGMENT] = &pov_type_pigment,   [TAG_FINISH] = &pov_type_finish,
        [TAG_NORMAL] = &pov_type_normal,     [TAG_INTERIOR] = &pov_type_interior, [TAG_MATERIAL] = &pov_type_material,
        [TAG_COLOR_MAP] = &pov_type_color_map};
    pov_ctx *c = it->ctx;
    int tag = (int)it->arg;
    void *v = calloc(1, (size_t)(uintptr_t)types[tag]->user);
    if (!v)
        return vbnl_sdl_error(it->p, &it->loc, "out of memory");
    vbnl_result r = VBNL_ERR_PARSE;
    switch (tag) {
    case TAG_TEXTURE:
        pov_texture_init(v);
        vbnl_sdl_next(it->p);
        r = pov_texture_parse(c, v);
        break;
    case TAG_PIGMENT:
        pov_pigment_init(v);
        vbnl_sdl_next(it->p);
        r = pov_pigment_parse(c, v);
        break;
    case TAG_FINISH:
        pov_finish_init(v);
        vbnl_sdl_next(it->p);
        r = pov_finish_parse(c, v);
        break;
    case TAG_NORMAL:
        vbnl_sdl_next(it->p);
        r = pov_normal_parse(c, &it->loc);
        break;
    case TAG_INTERIOR:
        ((pov_interior *)v)->ior = 1.0;
        vbnl_sdl_next(it->p);
        r = pov_interior_parse(c, v);
        break;
    case TAG_MATERIAL:
        pov_appearance_init(v);
        ((pov_appearance *)v)->loc = it->loc;
        vbnl_sdl_next(it->p);
        r = pov_material_parse(c, v);
        break;
    case TAG_COLOR_MAP:
        vbnl_sdl_next(it->p);
        r = pov_color_map_parse(c, v);
        break;
    }
    if (r != VBNL_OK) {
        free(v);
        return VBNL_ERR_PARSE;
    }
    vbnl_sdl_value_object(it->target, v, types[tag], tag);
    return VBNL_OK;
}

/* pigment_map, normal_map, texture_map, slope_map, density, media and interior_texture are not
 * rendered: their declarations are left to the language layer's block fallback, and the
 * modifiers that use them warn. */
static const pov_row rvalue_rows[] = {
    {"texture", declared_value, TAG_TEXTURE},
    {"pigment", declared_value, TAG_PIGMENT},
    {"finish", declared_value, TAG_FINISH},
    {"normal", declared_value, TAG_NORMAL},
    {"interior", declared_value, TAG_INTERIOR},
    {"material", declared_value, TAG_MATERIAL},
    {"color_map", declared_value, TAG_COLOR_MAP},
    {"colour_map", declared_value, TAG_COLOR_MAP},
    {NULL, NULL, 0},
};

/* A declared texture (pigment, finish, ...) warns about what it cannot render where the scene
 * uses it, not where it is declared: POV-Ray's standard includes declare many. */
int pov_appearance_rvalue(pov_ctx *c, const vbnl_sdl_token *tok, vbnl_sdl_value *out)
{
    (void)tok;
    int group = vbnl_sdl_defer_begin(c->parser);
    int r = pov_row_dispatch(rvalue_rows, c->parser, c, out);
    vbnl_sdl_defer_end(c->parser, group);
    if (r > 0)
        out->u.obj.deferred = group;
    return r;
}

/* ---- appearance modifiers of objects ---------------------------------------------------------- */

/* texture { }: the first one is the object's; each later one is a layer over it. */
static vbnl_result mod_texture(const pov_item *it)
{
    pov_ctx *c = it->ctx;
    pov_appearance *a = it->target;
    vbnl_sdl_next(it->p);
    if (!a->own_texture) {
        if (pov_texture_parse(c, &a->tex) != VBNL_OK)
            return VBNL_ERR_PARSE;
        a->own_texture = 1;
        return VBNL_OK;
    }
    if (a->own_texture == 1)
        vbnl_sdl_warning(it->p, &it->loc, "layered textures are rendered as one layer (the top opaque one)");
    a->own_texture = 2;
    pov_texture layer = c->tex->deflt.tex;
    if (pov_texture_parse(c, &layer) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_texture_put_layer(&a->tex, &layer);
    return VBNL_OK;
}

static vbnl_result mod_interior(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_interior_parse(it->ctx, &((pov_appearance *)it->target)->interior);
}

static vbnl_result mod_material(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_material_parse(it->ctx, it->target);
}

static vbnl_result mod_interior_texture(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    vbnl_sdl_warning(it->p, &it->loc, "'interior_texture' is not supported: ignored");
    return vbnl_sdl_skip_block(it->p);
}

/* The modifiers beside the texture items (pov_texture_item_rows). */
static const pov_row modifier_rows[] = {
    {"texture", mod_texture, 0},
    {"interior", mod_interior, 0},
    {"material", mod_material, 0},
    {"interior_texture", mod_interior_texture, 0},
    {NULL, NULL, 0},
};

int pov_appearance_is_modifier(const vbnl_sdl_token *tok)
{
    return tok->kind == VBNL_SDL_TOK_IDENT &&
           (pov_row_find(modifier_rows, tok->text) || pov_row_find(pov_texture_item_rows, tok->text));
}

vbnl_result pov_appearance_parse_modifier(pov_ctx *c, pov_appearance **app)
{
    vbnl_sdl_parser *p = c->parser;
    if (!*app) {
        *app = pov_appearance_default(c);
        if (!*app)
            return vbnl_sdl_error(p, NULL, "out of memory");
    }
    pov_appearance *a = *app;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    vbnl_sdl_loc loc = t->loc;
    if (!a->loc.file)
        a->loc = loc;
    int r = pov_row_dispatch(modifier_rows, p, c, a);
    if (r == 0)
        r = pov_row_dispatch(pov_texture_item_rows, p, c, &a->tex);
    if (r == 0)
        return vbnl_sdl_error(p, &loc, "'%s' is not an appearance modifier", t->text);
    return r > 0 ? VBNL_OK : VBNL_ERR_PARSE;
}

/* ---- #default { texture/pigment/finish/normal } ------------------------------------------------ */

static const pov_row *const default_tables[] = {pov_texture_rows, pov_texture_item_rows, NULL};
static const pov_block default_items = {.name = "#default (texture pigment finish normal)",
                                        .tables = default_tables,
                                        .unknown = pov_block_unexpected_word};

int pov_appearance_default_block(pov_ctx *c)
{
    if (vbnl_sdl_expect(c->parser, '{', "after '#default'") != VBNL_OK)
        return -1;
    /* objects placed from here on start from the new default */
    pov_appearance_free(c->tex->deflt_shared);
    c->tex->deflt_shared = NULL;
    return pov_block_parse(&default_items, c->parser, c, &c->tex->deflt.tex, NULL) == VBNL_OK ? 1 : -1;
}

/* ---- the state and appearances as values ------------------------------------------------------ */

void pov_appearance_init(pov_appearance *a)
{
    memset(a, 0, sizeof(*a));
    pov_texture_init(&a->tex);
    a->interior.ior = 1.0;
}

vbnl_result pov_texture_state_create(pov_ctx *c, vbnl_error *err)
{
    c->tex = calloc(1, sizeof(*c->tex));
    if (!c->tex)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    pov_appearance_init(&c->tex->deflt);
    return VBNL_OK;
}

void pov_texture_state_destroy(pov_ctx *c)
{
    if (!c || !c->tex)
        return;
    for (uint32_t i = 0; i < c->tex->image_count; ++i)
        free(c->tex->images[i].texels);
    free(c->tex->images);
    for (uint32_t i = 0; i < c->tex->cache_count; ++i)
        free(c->tex->cache[i]);
    free(c->tex->cache);
    pov_appearance_free(c->tex->deflt_shared);
    free(c->tex);
    c->tex = NULL;
}

void pov_appearance_average_color(pov_ctx *c, const pov_appearance *a, double rgb[3])
{
    const pov_pigment *g = &a->tex.pig;
    double col[5] = {0, 0, 0, 0, 0};
    if (g->kind == POV_PIG_SOLID) {
        memcpy(col, g->color, sizeof col);
    } else if (g->kind == POV_PIG_IMAGE) {
        const pov_image *im = g->image >= 0 && (uint32_t)g->image < c->tex->image_count ? &c->tex->images[g->image] : NULL;
        size_t n = im ? (size_t)im->width * im->height : 0;
        for (size_t i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k)
                col[k] += im->texels[3 * i + k] / (double)n;
    } else {
        pov_color_map_average(&g->map, col);
    }
    for (int k = 0; k < 3; ++k)
        rgb[k] = col[k] > 0 ? col[k] : 0;
}

pov_appearance *pov_appearance_copy(const pov_appearance *a)
{
    if (!a)
        return NULL;
    pov_appearance *b = malloc(sizeof(*b));
    if (b) {
        *b = *a;
        b->refs = 1;
    }
    return b;
}

void pov_appearance_free(pov_appearance *a)
{
    if (a && --a->refs <= 0)
        free(a);
}

pov_appearance *pov_appearance_default_shared(pov_ctx *c)
{
    if (!c->tex->deflt_shared && !(c->tex->deflt_shared = pov_appearance_default(c)))
        return NULL;
    c->tex->deflt_shared->refs++;
    return c->tex->deflt_shared;
}

pov_appearance *pov_appearance_default(pov_ctx *c)
{
    pov_appearance *a = pov_appearance_copy(&c->tex->deflt);
    if (a) {
        memset(&a->loc, 0, sizeof(a->loc));
        a->own_texture = 0;
    }
    return a;
}

void pov_appearance_transform(pov_appearance *a, const double m[16])
{
    if (a)
        pov_m4_mul(m, a->tex.pig.xf, a->tex.pig.xf);
}

int pov_appearance_is_emissive(const pov_appearance *a)
{
    if (!a)
        return 0;
    if (a->tex.ext.set)
        return a->tex.ext.desc.emission[0] > 0 || a->tex.ext.desc.emission[1] > 0 || a->tex.ext.desc.emission[2] > 0;
    const pov_pigment *g = &a->tex.pig;
    double col[5];
    if (g->kind == POV_PIG_SOLID)
        memcpy(col, g->color, sizeof(col));
    else
        pov_color_map_average(&g->map, col);
    for (int k = 0; k < 3; ++k)
        if (a->tex.fin.emission[k] * (g->kind == POV_PIG_IMAGE ? 1.0 : col[k]) > 0.0)
            return 1;
    return 0;
}
