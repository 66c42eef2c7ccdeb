/* vbnl object layer: what the curved shapes share besides their geometry: the block of a shape
 * whose mesh is made after its modifiers, setting its mesh and solid, and finding the files a
 * shape names (pov_surface.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "pov_files.h"
#include "pov_surface.h"
#include "sdl_internal.h"

vbnl_result pov_shape_deferred(const pov_shape *s, const pov_block *block, pov_mods *mods, pov_make_fn make)
{
    pov_loader *L = s->L;
    mods->L = L;
    mods->o = s->o;
    mods->shape = 1;
    if (!pov_obj_add(s->o, POV_PRIM_MESH, s->loc))
        return pov_oom(L);
    size_t idx = s->o->n - 1;
    vbnl_result r = pov_block_parse(block, L->c.parser, L, mods, s->keyword);
    if (r == VBNL_OK)
        r = make(s, mods, &s->o->v[idx]);
    if (r == VBNL_OK && idx < s->o->n && !s->o->v[idx].mesh && s->o->v[idx].kind == POV_PRIM_MESH &&
        !(s->o->v[idx].mesh = pov_mesh_new()))
        r = pov_oom(L);
    if (r == VBNL_OK)
        r = pov_mods_finish(mods);
    pov_mods_clear(mods);
    return r;
}

vbnl_result pov_shape_set_mesh(const pov_shape *s, pov_prim *pr, pov_smesh *m, int with_uv, pov_solid *solid)
{
    int capped = m->capped, oom = m->oom;
    pov_mesh *mesh = oom ? NULL : pov_smesh_to_mesh(m, with_uv);
    pov_smesh_free(m);
    if (!mesh) {
        pov_solid_unref(solid);
        return pov_oom(s->L);
    }
    pov_mesh_unref(pr->mesh);
    pr->mesh = mesh;
    pov_solid_unref(pr->solid);
    pr->solid = solid;
    if (capped)
        vbnl_sdl_warning(s->L->c.parser, &s->loc, "%s: the surface needs more than %u triangles; it is made coarser",
                         s->keyword, POV_TESS_MAX_TRIANGLES);
    return VBNL_OK;
}

double pov_box_radius(const double lo[3], const double hi[3])
{
    double d2 = 0;
    for (int k = 0; k < 3; ++k)
        d2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return 0.5 * sqrt(d2);
}

static int is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static int is_file_in(const char *dir, const char *name)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return is_file(path);
}

char *pov_shape_find_file(pov_loader *L, const char *name, const char *ext, const vbnl_sdl_loc *loc, const char *what)
{
    vbnl_sdl_parser *p = L->c.parser;
    char here[1024] = ".", list[2048] = "", path[4096];
    const char *file = loc && loc->file ? loc->file : "";
    const char *slash = strrchr(file, '/');
    if (slash)
        snprintf(here, sizeof here, "%.*s", (int)(slash - file > 0 ? slash - file : 1), file);
    /* the folder of the file that names it, the scene's, the include folders: the folders a
     * scene may read (docs/untrusted-input.md) */
    const char *cand[66];
    int nc = 0;
    cand[nc++] = here;
    cand[nc++] = p->scene_dir ? p->scene_dir : ".";
    for (int i = 0; i < p->nuser_dirs && nc < 64; i++)
        cand[nc++] = p->user_dirs[i];
    if (p->system_dir)
        cand[nc++] = p->system_dir;
    if (name[0] == '/' || pov_file_name_escapes(name)) {
        if (is_file(name) && sdl_path_readable(p, name)) {
            char *r = strdup(name);
            if (!r)
                pov_oom(L);
            return r;
        }
        vbnl_sdl_error(p, loc, "%s: cannot read '%s' (a scene reads files in its own folder and the include folders)",
                       what, name);
        return NULL;
    }
    for (int i = 0; i < nc; i++) {
        int dup = 0;
        for (int j = 0; j < i; j++)
            dup |= strcmp(cand[i], cand[j]) == 0;
        if (dup)
            continue;
        snprintf(path, sizeof path, "%s/%s%s", cand[i], name, ext && !is_file_in(cand[i], name) ? ext : "");
        /* the system include folder is the installation's: its links are followed (Debian links
         * POV-Ray's fonts there from /usr/share/fonts) */
        int system = p->system_dir && strcmp(cand[i], p->system_dir) == 0;
        if (is_file(path) && (system || sdl_path_readable(p, path))) {
            char *r = strdup(path);
            if (!r)
                pov_oom(L);
            return r;
        }
        size_t l = strlen(list);
        snprintf(list + l, sizeof list - l, "%s%s", l ? ", " : "", cand[i]);
    }
    vbnl_sdl_error(p, loc, "%s: cannot find '%s' (searched: %s)", what, name, list);
    return NULL;
}
