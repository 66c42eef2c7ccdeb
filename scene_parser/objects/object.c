/* vbnl object layer: object values (lists of primitives), their `#declare` types, and the
 * dispatch of a shape keyword to its parser (shapes/shapes.c holds the table). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_loader.h"
#include "pov_shape.h"
#include "sdl_internal.h"

/* ---- reading values -------------------------------------------------------------------------- */

vbnl_result pov_oom(pov_loader *L) { return vbnl_sdl_error(L->c.parser, NULL, "out of memory"); }
/* A shape's or a light's value: a NaN (`pow(-8, 1/3)`) or an infinity (`1e400`) is an error at the
 * expression, where the shape would otherwise be made of it (fmin drops a NaN corner silently). */
static vbnl_result finite_value(pov_loader *L, const vbnl_sdl_loc *at, const double *v, int n)
{
    for (int i = 0; i < n; ++i)
        if (!isfinite(v[i]))
            return vbnl_sdl_error(L->c.parser, at, "%s%s is %s, not a finite number", n > 1 ? "this vector's " : "this value",
                                  n > 1 ? (i == 0 ? "x" : i == 1 ? "y" : "z") : "", isnan(v[i]) ? "NaN" : "infinite");
    return VBNL_OK;
}

vbnl_result pov_vec3(pov_loader *L, double o[3])
{
    vbnl_sdl_loc at = vbnl_sdl_peek(L->c.parser)->loc;
    vbnl_result r = vbnl_sdl_parse_vector(L->c.parser, 3, o);
    return r == VBNL_OK ? finite_value(L, &at, o, 3) : r;
}

vbnl_result pov_float(pov_loader *L, double *o)
{
    vbnl_sdl_loc at = vbnl_sdl_peek(L->c.parser)->loc;
    vbnl_result r = vbnl_sdl_parse_float(L->c.parser, o);
    return r == VBNL_OK ? finite_value(L, &at, o, 1) : r;
}
void pov_comma(pov_loader *L) { vbnl_sdl_accept(L->c.parser, ','); }

vbnl_result pov_list_count(pov_loader *L, double *o)
{
    L->c.parser->in_count++;
    vbnl_result r = vbnl_sdl_parse_float(L->c.parser, o);
    L->c.parser->in_count--;
    return r;
}

vbnl_result pov_positive(pov_loader *L, double v, const char *what, vbnl_sdl_loc loc)
{
    if (!(v > 0) || !isfinite(v))
        return vbnl_sdl_error(L->c.parser, &loc, "%s must be positive, got %g", what, v);
    return VBNL_OK;
}

/* ---- object values --------------------------------------------------------------------------- */

void pov_obj_clear(pov_obj *o)
{
    for (size_t i = 0; i < o->n; ++i) {
        pov_appearance_free(o->v[i].app);
        pov_mesh_unref(o->v[i].mesh);
        pov_solid_unref(o->v[i].solid);
        free(o->v[i].path);
    }
    free(o->v);
    pov_appearance_free(o->app);
    memset(o, 0, sizeof *o);
}

pov_prim *pov_obj_add(pov_obj *o, int kind, vbnl_sdl_loc loc)
{
    if (o->n == o->cap) {
        size_t cap = o->cap ? 2 * o->cap : 4;
        pov_prim *n = realloc(o->v, cap * sizeof *n);
        if (!n)
            return NULL;
        o->v = n;
        o->cap = cap;
    }
    pov_prim *p = &o->v[o->n++];
    memset(p, 0, sizeof *p);
    p->kind = kind;
    p->loc = loc;
    pov_m4_identity(p->m);
    return p;
}

int pov_obj_append_copy(pov_obj *dst, const pov_obj *src)
{
    for (size_t i = 0; i < src->n; ++i) {
        const pov_prim *s = &src->v[i];
        pov_prim *d = pov_obj_add(dst, s->kind, s->loc);
        if (!d)
            return 0;
        *d = *s;
        d->app = NULL;
        d->path = NULL;
        if (s->mesh)
            s->mesh->refs++;
        pov_solid_ref(s->solid);
        if ((s->app && !(d->app = pov_appearance_copy(s->app))) || (s->path && !(d->path = strdup(s->path))))
            return 0;
    }
    return 1;
}

int pov_obj_move(pov_obj *dst, pov_obj *src)
{
    for (size_t i = 0; i < src->n; ++i) {
        pov_prim *d = pov_obj_add(dst, 0, src->loc);
        if (!d)
            return 0;
        *d = src->v[i];
    }
    src->n = 0;
    return 1;
}

int pov_obj_finish(pov_obj *o)
{
    if (o->app) {
        for (size_t i = 0; i < o->n; ++i)
            if (!o->v[i].app && o->v[i].kind != POV_PRIM_LIGHT && o->v[i].kind != POV_PRIM_SKIPPED &&
                !(o->v[i].app = pov_appearance_copy(o->app)))
                return 0;
        pov_appearance_free(o->app);
        o->app = NULL;
    }
    return 1;
}

void pov_obj_transform(pov_obj *o, const double m[16])
{
    for (size_t i = 0; i < o->n; ++i) {
        pov_m4_mul(m, o->v[i].m, o->v[i].m);
        if (o->v[i].app)
            pov_appearance_transform(o->v[i].app, m);
    }
    if (o->app)
        pov_appearance_transform(o->app, m);
}

/* ---- #declare types ---------------------------------------------------------------------------- */

void pov_object_destroy(void *ptr, void *user)
{
    (void)user;
    pov_obj_clear(ptr);
    free(ptr);
}

static void *object_copy(const void *ptr, void *user)
{
    (void)user;
    const pov_obj *s = ptr;
    pov_obj *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    d->loc = s->loc;
    if (!pov_obj_append_copy(d, s) || (s->app && !(d->app = pov_appearance_copy(s->app)))) {
        pov_object_destroy(d, NULL);
        return NULL;
    }
    return d;
}

static void *transform_copy(const void *ptr, void *user)
{
    (void)user;
    double *d = malloc(16 * sizeof *d);
    if (d)
        memcpy(d, ptr, 16 * sizeof *d);
    return d;
}

static void *camera_copy(const void *ptr, void *user)
{
    (void)user;
    pov_cam *d = malloc(sizeof *d);
    if (d)
        pov_camera_copy(d, ptr);
    return d;
}

static void camera_destroy(void *ptr, void *user)
{
    (void)user;
    if (ptr)
        pov_camera_release(ptr);
    free(ptr);
}

static void plain_destroy(void *ptr, void *user)
{
    (void)user;
    free(ptr);
}

const vbnl_sdl_opaque_type pov_object_type = {"object", pov_object_destroy, object_copy, NULL, NULL};
const vbnl_sdl_opaque_type pov_transform_type = {"transform", plain_destroy, transform_copy, NULL, NULL};
const vbnl_sdl_opaque_type pov_camera_type = {"camera", camera_destroy, camera_copy, NULL, NULL};

const void *pov_declared(pov_loader *L, const vbnl_sdl_token *t, const vbnl_sdl_opaque_type *type)
{
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return NULL;
    const vbnl_sdl_value *v = vbnl_sdl_lookup(L->c.parser, t->text);
    return v && v->kind == VBNL_SDL_OBJECT && v->u.obj.type == type ? v->u.obj.ptr : NULL;
}

/* ---- shapes ------------------------------------------------------------------------------------ */

int pov_is_shape(const vbnl_sdl_token *t)
{
    return t->kind == VBNL_SDL_TOK_IDENT && (pov_shape_find(t->text) || pov_shape_unsupported(t->text));
}

static vbnl_result parse_object_inner(pov_loader *L, pov_obj *o)
{
    vbnl_sdl_parser *p = L->c.parser;
    vbnl_sdl_token kw = *vbnl_sdl_next(p);
    o->loc = kw.loc;
    if (pov_shape_unsupported(kw.text)) {
        /* The warning comes where the shape is placed in the scene (a declared but unused one,
         * as in shapes.inc, is silent). */
        pov_prim *pr = pov_obj_add(o, POV_PRIM_SKIPPED, kw.loc);
        if (!pr || !(pr->path = strdup(kw.text)))
            return pov_oom(L);
        return vbnl_sdl_skip_block(p);
    }
    char ctx[64];
    snprintf(ctx, sizeof ctx, "after '%s'", kw.text);
    if (vbnl_sdl_expect(p, '{', ctx) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_shape s = {L, o, kw.text, kw.loc};
    return pov_shape_find(kw.text)->parse(&s);
}

vbnl_result pov_parse_object(pov_loader *L, pov_obj *o)
{
    vbnl_sdl_loc loc = vbnl_sdl_peek(L->c.parser)->loc;
    if (!sdl_enter(L->c.parser, &loc))
        return VBNL_ERR_PARSE;
    vbnl_result r = parse_object_inner(L, o);
    sdl_leave(L->c.parser);
    return r;
}

vbnl_result pov_parse_member(pov_loader *L, pov_obj *o)
{
    pov_obj child = {0};
    vbnl_result r = VBNL_OK;
    if (pov_parse_object(L, &child) != VBNL_OK || !pov_obj_finish(&child) || !pov_obj_move(o, &child))
        r = vbnl_sdl_failed(L->c.parser) ? VBNL_ERR_PARSE : pov_oom(L);
    pov_obj_clear(&child);
    return r;
}
