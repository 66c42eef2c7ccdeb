/* vbnl object layer: object { ID | Arr[i] | shape  modifiers }, a copy of a declared object (its
 * meshes shared) or a nested shape. */
#include "pov_shape.h"

/* object { Arr[i] } */
static vbnl_result array_element(const pov_shape *s)
{
    vbnl_sdl_parser *p = s->L->c.parser;
    vbnl_sdl_loc el = vbnl_sdl_peek(p)->loc;
    vbnl_sdl_value v;
    if (vbnl_sdl_parse_expression(p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (v.kind != VBNL_SDL_OBJECT || v.u.obj.type != &pov_object_type) {
        const char *kind = v.kind == VBNL_SDL_OBJECT ? v.u.obj.type->name : vbnl_sdl_kind_name(v.kind);
        vbnl_sdl_value_clear(p, &v);
        return vbnl_sdl_error(p, &el, "array element is a %s, not an object", kind);
    }
    const pov_obj *ao = v.u.obj.ptr;
    int good = pov_obj_append_copy(s->o, ao) && (!ao->app || (s->o->app = pov_appearance_copy(ao->app)));
    vbnl_sdl_value_clear(p, &v);
    return good ? VBNL_OK : pov_oom(s->L);
}

vbnl_result pov_shape_object(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    const pov_obj *d = pov_declared(L, t, &pov_object_type);
    const vbnl_sdl_value *v = t->kind == VBNL_SDL_TOK_IDENT ? vbnl_sdl_lookup(p, t->text) : NULL;
    if (d) {
        vbnl_sdl_next(p);
        if (!pov_obj_append_copy(s->o, d) || (d->app && !(s->o->app = pov_appearance_copy(d->app))))
            return pov_oom(L);
    } else if (pov_is_shape(t)) {
        if (pov_parse_member(L, s->o) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (v && v->kind == VBNL_SDL_ARRAY) {
        if (array_element(s) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (v) {
        return vbnl_sdl_error(p, &t->loc, "'%s' is a %s, not an object", t->text,
                              v->kind == VBNL_SDL_OBJECT ? v->u.obj.type->name : vbnl_sdl_kind_name(v->kind));
    } else if (t->kind == VBNL_SDL_TOK_IDENT && !pov_appearance_is_modifier(t) && !pov_row_find(pov_transform_rows, t->text)) {
        return vbnl_sdl_error(p, &t->loc, "undeclared object identifier '%s'", t->text);
    }
    return pov_shape_modifiers(s);
}
