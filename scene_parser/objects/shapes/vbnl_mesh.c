/* vbnl object layer: vbnl_mesh { "file" [modifiers] }, a mesh file read through assimp when the
 * scene is built (a vbnl extension; the file is found next to the scene file that names it,
 * never outside its folder: pov_files.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_files.h"
#include "pov_shape.h"

vbnl_result pov_shape_vbnl_mesh(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    vbnl_sdl_loc sl = vbnl_sdl_peek(p)->loc;
    char *name = NULL;
    if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (L->files_disabled) {
        free(name);
        return vbnl_sdl_error(p, &sl, "vbnl_mesh: file access is disabled");
    }
    const char *why = NULL;
    char *path = pov_file_resolve(p, &sl, name, POV_FILE_READ, &why);
    if (!path) {
        vbnl_result r = vbnl_sdl_error(p, &sl, "vbnl_mesh: '%s' is %s", name, why);
        free(name);
        return r;
    }
    free(name);
    pov_prim *pr = pov_obj_add(s->o, POV_PRIM_IMPORT, s->loc);
    if (!pr) {
        free(path);
        return pov_oom(L);
    }
    pr->path = path;
    return pov_shape_modifiers(s);
}
