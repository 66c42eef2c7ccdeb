/* vbnl object layer: intersection / difference / merge { objects... modifiers }. The operands
 * come first (as in POV-Ray); the surface is built (../csg_build.c) when the first modifier or
 * the '}' comes, so the modifiers apply to it as to any object. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

/* The bytes a CSG's result depends on: the operation and every operand's primitives (their
 * geometry by reference: shared meshes and solids, so equal operands made from the shape cache
 * give equal keys). 0 when an operand holds what is not geometry (lights, files) or an appearance
 * of its own (appearances are copied per object, so they never compare equal). */
static int csg_key(int op, const pov_obj *ops, size_t nops, pov_key *k)
{
    pov_key_add(k, "csg", 4);
    pov_key_add(k, &op, sizeof op);
    pov_key_add(k, &nops, sizeof nops);
    for (size_t i = 0; i < nops; ++i) {
        pov_key_add(k, &ops[i].n, sizeof ops[i].n);
        for (size_t j = 0; j < ops[i].n; ++j) {
            const pov_prim *pr = &ops[i].v[j];
            if (pr->app || (pr->kind != POV_PRIM_SPHERE && pr->kind != POV_PRIM_PLANE && pr->kind != POV_PRIM_MESH &&
                            pr->kind != POV_PRIM_SURFACE))
                return 0;
            pov_key_add(k, &pr->kind, sizeof pr->kind);
            pov_key_add(k, pr->m, sizeof pr->m);
            pov_key_add(k, pr->a, sizeof pr->a);
            pov_key_add(k, &pr->mesh, sizeof pr->mesh);
            pov_key_add(k, &pr->solid, sizeof pr->solid);
            pov_key_add(k, &pr->inverse, sizeof pr->inverse);
        }
    }
    return !k->failed;
}

vbnl_result pov_shape_csg(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    const char *w = s->keyword;
    pov_obj *ops = NULL;
    size_t nops = 0;
    vbnl_result r = VBNL_OK;
    while (pov_is_shape(vbnl_sdl_peek(p))) {
        pov_obj *n = realloc(ops, (nops + 1) * sizeof *n);
        if (!n) {
            r = pov_oom(L);
            goto done;
        }
        ops = n;
        memset(&ops[nops], 0, sizeof ops[nops]);
        nops++;
        if (pov_parse_object(L, &ops[nops - 1]) != VBNL_OK || !pov_obj_finish(&ops[nops - 1])) {
            r = vbnl_sdl_failed(p) ? VBNL_ERR_PARSE : pov_oom(L);
            goto done;
        }
    }
    int op = w[0] == 'i' ? POV_CSG_INTERSECTION : w[0] == 'd' ? POV_CSG_DIFFERENCE : POV_CSG_MERGE;
    if (nops == 0) {
        vbnl_sdl_warning(p, &s->loc, "'%s' without objects is empty", w);
    } else {
        const char *error = NULL;
        /* an equal CSG made before (a macro's): its pieces shared */
        pov_key key = {0};
        int cacheable = csg_key(op, ops, nops, &key), oom = 0;
        size_t first = s->o->n;
        if (cacheable && pov_shape_cache_get_obj(L, key.b, key.n, s->o, &oom)) {
            pov_key_free(&key);
            if (oom) {
                r = pov_oom(L);
                goto done;
            }
        } else if (!pov_csg_build(op, ops, nops, s->o, &error)) {
            pov_key_free(&key);
            r = strcmp(error, "out of memory") ? vbnl_sdl_error(p, &s->loc, "%s: %s", w, error) : pov_oom(L);
            goto done;
        } else {
            if (cacheable && first == 0)
                pov_shape_cache_put_obj(L, key.b, key.n, s->o);
            pov_key_free(&key);
        }
    }
    r = pov_modifiers(L, s->o, w);
done:
    for (size_t i = 0; i < nops; ++i)
        pov_obj_clear(&ops[i]);
    free(ops);
    return r;
}
