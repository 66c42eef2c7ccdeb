/* vbnl object layer, texture part: the interface the object part uses (pov_internal.h): the
 * texture state, appearance modifiers of objects, `#declare` values, #default, and appearances
 * as values. */
#include <stdlib.h>
#include <string.h>

#include "pov_texture.h"

/* ---- declared values ----------------------------------------------------------------------------- */

enum { TAG_TEXTURE = 1, TAG_PIGMENT, TAG_FINISH, TAG_NORMAL, TAG_INTERIOR, TAG_MATERIAL, TAG_COLOR_MAP,
       TAG_PIGMENT_MAP, TAG_NORMAL_MAP, TAG_TEXTURE_MAP, TAG_SLOPE_MAP, TAG_DENSITY };

static void free_texture(void *ptr, void *user)
{
    (void)user;
    pov_texture_free(ptr);
}
static void *copy_texture(const void *ptr, void *user)
{
    (void)user;
    return pov_texture_dup(ptr);
}
/* `#declare T = texture { A } texture { B }`: B is a layer over A, as on an object. */
static void *layer_texture(void *below, void *above, void *user)
{
    (void)user;
    pov_texture *stack = below;
    pov_texture_put_layer(&stack, above);
    return stack;
}

static void free_pigment(void *ptr, void *user)
{
    (void)user;
    pov_pigment_free(ptr);
}
static void *copy_pigment(const void *ptr, void *user)
{
    (void)user;
    return pov_pigment_dup(ptr);
}
static void free_normal(void *ptr, void *user)
{
    (void)user;
    pov_normal_free(ptr);
}
static void *copy_normal(const void *ptr, void *user)
{
    (void)user;
    return pov_normal_dup(ptr);
}
static void free_map(void *ptr, void *user)
{
    (void)user;
    pov_map_free(ptr);
    free(ptr);
}
static void *copy_map(const void *ptr, void *user)
{
    (void)user;
    pov_map *m = malloc(sizeof(*m));
    if (m && !pov_map_copy(m, ptr)) {
        free(m);
        return NULL;
    }
    return m;
}
static void free_material(void *ptr, void *user)
{
    (void)user;
    pov_appearance_clear(ptr);
    free(ptr);
}
static void *copy_material(const void *ptr, void *user)
{
    (void)user;
    const pov_appearance *a = ptr;
    pov_appearance *b = malloc(sizeof(*b));
    if (!b)
        return NULL;
    *b = *a;
    if (a->tex && !(b->tex = pov_texture_dup(a->tex))) {
        free(b);
        return NULL;
    }
    return b;
}
/* Plain structs (finish, interior): `user` is their size. */
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

const vbnl_sdl_opaque_type pov_type_texture = {"texture", free_texture, copy_texture, NULL, layer_texture};
const vbnl_sdl_opaque_type pov_type_pigment = {"pigment", free_pigment, copy_pigment, NULL, NULL};
const vbnl_sdl_opaque_type pov_type_normal = {"normal", free_normal, copy_normal, NULL, NULL};
const vbnl_sdl_opaque_type pov_type_finish = {"finish", blob_free, blob_copy, (void *)(uintptr_t)sizeof(pov_finish), NULL};
const vbnl_sdl_opaque_type pov_type_interior = {"interior", blob_free, blob_copy, (void *)(uintptr_t)sizeof(pov_interior),
                                                NULL};
const vbnl_sdl_opaque_type pov_type_material = {"material", free_material, copy_material, NULL, NULL};
const vbnl_sdl_opaque_type pov_type_color_map = {"color_map", free_map, copy_map, NULL, NULL};
const vbnl_sdl_opaque_type pov_type_pigment_map = {"pigment_map", free_map, copy_map, NULL, NULL};
const vbnl_sdl_opaque_type pov_type_normal_map = {"normal_map", free_map, copy_map, NULL, NULL};
const vbnl_sdl_opaque_type pov_type_texture_map = {"texture_map", free_map, copy_map, NULL, NULL};
const vbnl_sdl_opaque_type pov_type_slope_map = {"slope_map", free_map, copy_map, NULL, NULL};

int pov_take_ident(pov_ctx *c, const vbnl_sdl_opaque_type *type, void *dst, int (*copy)(void *dst, const void *src))
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *tok = vbnl_sdl_peek(p);
    if (tok->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    const vbnl_sdl_value *v = vbnl_sdl_lookup(p, tok->text);
    if (!v)
        return 0;
    vbnl_sdl_loc loc = tok->loc;
    if (v->kind == VBNL_SDL_OBJECT && v->u.obj.type == type) {
        if (!copy(dst, v->u.obj.ptr)) {
            vbnl_sdl_error(p, &loc, "out of memory");
            return -1;
        }
        vbnl_sdl_defer_use(p, v->u.obj.deferred, &loc);
        vbnl_sdl_next(p);
        return 1;
    }
    if (v->kind != VBNL_SDL_ARRAY)
        return 0;
    /* an array element of this type (Arr[i]...) */
    const vbnl_sdl_array *arr = v->u.array;
    const vbnl_sdl_value *first = vbnl_sdl_array_size(arr, 0) ? vbnl_sdl_array_at(arr, 0) : NULL;
    /* an array of other items, or of colours (pigment { Colours[i] } is a colour: the block's own
     * parse reads it) */
    if (first && first->kind != VBNL_SDL_NONE && (first->kind != VBNL_SDL_OBJECT || first->u.obj.type != type))
        return 0;
    vbnl_sdl_value e;
    if (vbnl_sdl_parse_expression(p, &e) != VBNL_OK)
        return -1;
    if (e.kind != VBNL_SDL_OBJECT || e.u.obj.type != type) {
        const char *kind = e.kind == VBNL_SDL_OBJECT ? e.u.obj.type->name : vbnl_sdl_kind_name(e.kind);
        vbnl_sdl_value_clear(p, &e);
        vbnl_sdl_error(p, &loc, "array element is a %s, not a %s", kind, type->name);
        return -1;
    }
    int ok = copy(dst, e.u.obj.ptr);
    vbnl_sdl_defer_use(p, e.u.obj.deferred, &loc);
    vbnl_sdl_value_clear(p, &e);
    if (!ok) {
        vbnl_sdl_error(p, &loc, "out of memory");
        return -1;
    }
    return 1;
}

/* `#declare X = texture { ... }` (pigment, ...): `arg` is the value's tag. Declared textures,
 * pigments, normals and finishes start from the #default ones, as POV-Ray's Parse_RValue does. */
static vbnl_result declared_value(const pov_item *it)
{
    static const vbnl_sdl_opaque_type *const types[] = {
        [TAG_TEXTURE] = &pov_type_texture,         [TAG_PIGMENT] = &pov_type_pigment,
        [TAG_FINISH] = &pov_type_finish,           [TAG_NORMAL] = &pov_type_normal,
        [TAG_INTERIOR] = &pov_type_interior,       [TAG_MATERIAL] = &pov_type_material,
        [TAG_COLOR_MAP] = &pov_type_color_map,     [TAG_PIGMENT_MAP] = &pov_type_pigment_map,
        [TAG_NORMAL_MAP] = &pov_type_normal_map,   [TAG_TEXTURE_MAP] = &pov_type_texture_map,
        [TAG_SLOPE_MAP] = &pov_type_slope_map,     [TAG_DENSITY] = &pov_type_pigment};
    static const pov_map_kind map_kinds[] = {[TAG_COLOR_MAP] = POV_MAP_COLOR, [TAG_PIGMENT_MAP] = POV_MAP_PIGMENT,
                                             [TAG_NORMAL_MAP] = POV_MAP_NORMAL, [TAG_TEXTURE_MAP] = POV_MAP_TEXTURE,
                                             [TAG_SLOPE_MAP] = POV_MAP_SLOPE};
    pov_ctx *c = it->ctx;
    const pov_texture *deflt = c->tex->deflt.tex;
    int tag = (int)it->arg;
    void *v = NULL;
    vbnl_result r = VBNL_ERR_PARSE;
    vbnl_sdl_next(it->p);
    switch (tag) {
    case TAG_TEXTURE: {
        pov_texture *t = NULL;
        r = pov_texture_parse(c, &t);
        v = t;
        break;
    }
    case TAG_PIGMENT: {
        pov_pigment *g = pov_pigment_dup(deflt->pig);
        r = g ? pov_pigment_parse(c, g) : vbnl_sdl_error(it->p, &it->loc, "out of memory");
        v = g;
        break;
    }
    case TAG_DENSITY: { /* a pigment value (density { D } takes it as POV-Ray's Copy_Pigment does) */
        pov_pigment *g = pov_pigment_new();
        r = g ? pov_density_body(c, g) : vbnl_sdl_error(it->p, &it->loc, "out of memory");
        v = g;
        break;
    }
    case TAG_FINISH: {
        pov_finish *f = malloc(sizeof(*f));
        if (f)
            *f = deflt->fin;
        r = f ? pov_finish_parse(c, f) : vbnl_sdl_error(it->p, &it->loc, "out of memory");
        v = f;
        break;
    }
    case TAG_NORMAL: {
        pov_normal *n = deflt->nrm ? pov_normal_dup(deflt->nrm) : NULL;
        r = pov_normal_parse(c, &n);
        if (r == VBNL_OK && !n && !(n = pov_normal_new())) /* a declared empty normal: no perturbation */
            r = vbnl_sdl_error(it->p, &it->loc, "out of memory");
        v = n;
        break;
    }
    case TAG_INTERIOR: {
        pov_interior *in = malloc(sizeof(*in));
        if (in)
            pov_interior_init(in);
        r = in ? pov_interior_parse(c, in) : vbnl_sdl_error(it->p, &it->loc, "out of memory");
        v = in;
        break;
    }
    case TAG_MATERIAL: {
        pov_appearance *a = malloc(sizeof(*a));
        if (a) {
            pov_appearance_init(a);
            a->tex = pov_texture_dup(deflt);
            a->loc = it->loc;
        }
        r = a && a->tex ? pov_material_parse(c, a) : vbnl_sdl_error(it->p, &it->loc, "out of memory");
        v = a;
        break;
    }
    default: {
        pov_map *m = calloc(1, sizeof(*m));
        r = m ? pov_map_parse(c, m, map_kinds[tag], 0) : vbnl_sdl_error(it->p, &it->loc, "out of memory");
        v = m;
        break;
    }
    }
    if (r != VBNL_OK) {
        if (v)
            types[tag]->destroy(v, types[tag]->user);
        return VBNL_ERR_PARSE;
    }
    vbnl_sdl_value_object(it->target, v, types[tag], tag);
    return VBNL_OK;
}

static const pov_row rvalue_rows[] = {
    {"texture", declared_value, TAG_TEXTURE},
    {"pigment", declared_value, TAG_PIGMENT},
    {"finish", declared_value, TAG_FINISH},
    {"normal", declared_value, TAG_NORMAL},
    {"interior", declared_value, TAG_INTERIOR},
    {"material", declared_value, TAG_MATERIAL},
    {"color_map", declared_value, TAG_COLOR_MAP},
    {"colour_map", declared_value, TAG_COLOR_MAP},
    {"pigment_map", declared_value, TAG_PIGMENT_MAP},
    {"normal_map", declared_value, TAG_NORMAL_MAP},
    {"texture_map", declared_value, TAG_TEXTURE_MAP},
    {"slope_map", declared_value, TAG_SLOPE_MAP},
    {"density", declared_value, TAG_DENSITY},
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

vbnl_result pov_appearance_texture_item(const pov_item *it)
{
    pov_appearance *a = it->target;
    vbnl_sdl_next(it->p);
    pov_texture *t = NULL;
    vbnl_result r = pov_texture_parse(it->ctx, &t);
    if (r != VBNL_OK) {
        pov_texture_free(t);
        return r;
    }
    if (!a->own_texture) {
        pov_texture_free(a->tex);
        a->tex = t;
        a->own_texture = 1;
    } else {
        pov_texture_put_layer(&a->tex, t);
    }
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
    {"texture", pov_appearance_texture_item, 0},
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
    if (r == 0) /* pigment { } and friends directly in the object change its (top) texture */
        r = pov_row_dispatch(pov_texture_item_rows, p, c, &a->tex);
    if (r == 0)
        return vbnl_sdl_error(p, &loc, "'%s' is not an appearance modifier", t->text);
    return r > 0 ? VBNL_OK : VBNL_ERR_PARSE;
}

/* ---- #default { texture/pigment/finish/normal } ------------------------------------------------ */

static vbnl_result default_texture(const pov_item *it)
{
    pov_ctx *c = it->ctx;
    vbnl_sdl_next(it->p);
    pov_texture *t = NULL;
    if (pov_texture_parse(c, &t) != VBNL_OK) {
        pov_texture_free(t);
        return VBNL_ERR_PARSE;
    }
    if (t->kind != POV_TEX_PLAIN || t->below) {
        pov_texture_free(t);
        return vbnl_sdl_error(it->p, &it->loc, "#default takes a plain texture (no pattern, no layers)");
    }
    pov_texture_free(c->tex->deflt.tex);
    c->tex->deflt.tex = t;
    return VBNL_OK;
}

static const pov_row default_rows[] = {{"texture", default_texture, 0}, {NULL, NULL, 0}};
static const pov_row *const default_tables[] = {default_rows, pov_texture_item_rows, NULL};
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
    pov_interior_init(&a->interior);
    pov_m4_identity(a->xf);
}

void pov_appearance_clear(pov_appearance *a)
{
    pov_texture_free(a->tex);
    a->tex = NULL;
}

vbnl_result pov_texture_state_create(pov_ctx *c, vbnl_error *err)
{
    c->tex = calloc(1, sizeof(*c->tex));
    if (!c->tex)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    pov_appearance_init(&c->tex->deflt);
    if (!(c->tex->deflt.tex = pov_texture_new())) {
        free(c->tex);
        c->tex = NULL;
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    return VBNL_OK;
}

void pov_material_cache_free(pov_ctx *c); /* core_material.c */

void pov_texture_state_destroy(pov_ctx *c)
{
    if (!c || !c->tex)
        return;
    for (uint32_t i = 0; i < c->tex->image_count; ++i) {
        free(c->tex->images[i].texels);
        free(c->tex->images[i].indices);
    }
    free(c->tex->images);
    pov_material_cache_free(c);
    for (uint32_t i = 0; i < c->tex->density_count; ++i)
        pov_pigment_free(c->tex->densities[i]);
    free(c->tex->densities);
    pov_appearance_free(c->tex->deflt_shared);
    pov_appearance_clear(&c->tex->deflt);
    free(c->tex);
    c->tex = NULL;
}

pov_appearance *pov_appearance_copy(const pov_appearance *a)
{
    if (!a)
        return NULL;
    pov_appearance *b = malloc(sizeof(*b));
    if (!b)
        return NULL;
    *b = *a;
    b->refs = 1;
    if (a->tex && !(b->tex = pov_texture_dup(a->tex))) {
        free(b);
        return NULL;
    }
    return b;
}

void pov_appearance_free(pov_appearance *a)
{
    if (a && --a->refs <= 0) {
        pov_appearance_clear(a);
        free(a);
    }
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
    if (a) {
        pov_m4_mul(m, a->xf, a->xf);
        pov_interior_transform(&a->interior, m); /* POV-Ray's object transforms move its media */
    }
}

int pov_appearance_is_emissive(const pov_appearance *a)
{
    if (!a || !a->tex)
        return 0;
    for (const pov_texture *t = a->tex; t; t = t->below) {
        if (t->kind != POV_TEX_PLAIN)
            continue; /* patterned textures: their entries' emission is not rendered (core nodes emit
                       * their own, see core_material.c) */
        if (t->ext.set) {
            if (t->ext.desc.emission[0] > 0 || t->ext.desc.emission[1] > 0 || t->ext.desc.emission[2] > 0)
                return 1;
            continue;
        }
        for (int k = 0; k < 3; ++k)
            if (t->fin.emission[k] > 0.0)
                return 1;
    }
    return 0;
}

/* ---- global_settings { noise_generator n number_of_waves n } ------------------------------------ */

static vbnl_result global_number(const pov_item *it)
{
    pov_ctx *c = it->ctx;
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!strcmp(it->kw, "noise_generator")) {
        if (!(v >= 1.0 && v <= 3.0))
            return vbnl_sdl_error(it->p, &it->loc, "noise_generator must be 1, 2 or 3 (got %g)", v);
        c->tex->noise_generator = (int)v;
    } else {
        if (!(v >= 1.0 && v <= VBNL_NOISE_WAVES_MAX))
            return vbnl_sdl_error(it->p, &it->loc, "number_of_waves must lie in [1, %d] (got %g)", VBNL_NOISE_WAVES_MAX, v);
        c->tex->waves = (int)v;
    }
    return VBNL_OK;
}

const pov_row pov_texture_global_rows[] = {
    {"noise_generator", global_number, 0},
    {"number_of_waves", global_number, 0},
    {NULL, NULL, 0},
};
