/* vbnl object layer: intersection / difference / merge { objects... modifiers }. The operands
 * come first (as in POV-Ray); the surface is built (../csg_build.c) when the first modifier or
 * the '}' comes, so the modifiers apply to it as to any object. */
#include <stdlib.h>
#include <string.h>

#include "pov_shape.h"

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
        if (!pov_csg_build(op, ops, nops, s->o, &error)) {
            r = strcmp(error, "out of memory") ? vbnl_sdl_error(p, &s->loc, "%s: %s", w, error) : pov_oom(L);
            goto done;
        }
    }
    r = pov_modifiers(L, s->o, w);
done:
    for (size_t i = 0; i < nops; ++i)
        pov_obj_clear(&ops[i]);
    free(ops);
    return r;
}
