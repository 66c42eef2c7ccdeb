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

vbnl_result pov_shape_implicit(const pov_shape *s, pov_prim *pr, const pov_implicit *im, const pov_solid_fn *fn,
                               void **data, const double lo[3], const double hi[3])
{
    pov_loader *L = s->L;
    const char *why = NULL;
    pov_mesh *m = pov_implicit_mesh(im, &why);
    if (vbnl_sdl_failed(L->c.parser)) { /* the shape's function failed (too deep, ...) */
        pov_mesh_unref(m);
        return VBNL_ERR_PARSE;
    }
    if (!m)
        return strcmp(why, "out of memory") ? vbnl_sdl_error(L->c.parser, &s->loc, "%s: %s", s->keyword, why) : pov_oom(L);
    pr->mesh = m;
    pr->solid = pov_solid_custom(fn, *data, lo, hi);
    *data = NULL; /* the solid's now, or freed */
    return pr->solid ? VBNL_OK : pov_oom(L);
}

vbnl_result pov_container_parse(const pov_item *it, pov_container *c)
{
    pov_loader *L = it->ctx;
    vbnl_sdl_parser *p = it->p;
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '{', "after 'contained_by'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (pov_is_word(t, "box")) {
        double a[3], b[3];
        vbnl_sdl_next(p);
        if (vbnl_sdl_expect(p, '{', "after 'box'") != VBNL_OK || pov_vec3(L, a) != VBNL_OK ||
            (pov_comma(L), pov_vec3(L, b)) != VBNL_OK || vbnl_sdl_expect(p, '}', "after the box's corners") != VBNL_OK)
            return VBNL_ERR_PARSE;
        c->sphere = 0;
        for (int k = 0; k < 3; ++k) {
            c->lo[k] = fmin(a[k], b[k]);
            c->hi[k] = fmax(a[k], b[k]);
        }
    } else if (pov_is_word(t, "sphere")) {
        vbnl_sdl_next(p);
        if (vbnl_sdl_expect(p, '{', "after 'sphere'") != VBNL_OK || pov_vec3(L, c->c) != VBNL_OK ||
            (pov_comma(L), pov_float(L, &c->r)) != VBNL_OK || vbnl_sdl_expect(p, '}', "after the sphere's radius") != VBNL_OK ||
            pov_positive(L, c->r, "contained_by sphere radius", it->loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
        c->sphere = 1;
    }
    return vbnl_sdl_expect(p, '}', "after the container (contained_by takes a box or a sphere)");
}

void pov_container_bounds(const pov_container *c, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; ++k) {
        lo[k] = c->sphere ? c->c[k] - c->r : c->lo[k];
        hi[k] = c->sphere ? c->c[k] + c->r : c->hi[k];
    }
}

double pov_container_dist(const pov_container *c, const double q[3])
{
    if (c->sphere) {
        double x = q[0] - c->c[0], y = q[1] - c->c[1], z = q[2] - c->c[2];
        return sqrt(x * x + y * y + z * z) - c->r;
    }
    double m = -INFINITY;
    for (int k = 0; k < 3; ++k)
        m = fmax(m, fmax(c->lo[k] - q[k], q[k] - c->hi[k]));
    return m;
}

vbnl_result pov_container_clip(const pov_shape *s, pov_mods *mods, const pov_prim *pr, const pov_container *c)
{
    pov_prim *k = pov_obj_add(&mods->clip, c->sphere ? POV_PRIM_SPHERE : POV_PRIM_MESH, s->loc);
    if (!k)
        return pov_oom(s->L);
    memcpy(k->m, pr->m, sizeof k->m);
    if (c->sphere) {
        memcpy(k->a, c->c, sizeof c->c);
        k->a[3] = c->r;
    } else if (!(k->mesh = pov_tess_box(c->lo, c->hi)) || !(k->solid = pov_solid_box(c->lo, c->hi))) {
        return pov_oom(s->L);
    }
    if (!mods->clip_loc.file)
        mods->clip_loc = s->loc;
    return VBNL_OK;
}

void pov_container_default(pov_container *c)
{
    memset(c, 0, sizeof *c);
    for (int k = 0; k < 3; ++k) {
        c->lo[k] = -1;
        c->hi[k] = 1;
    }
}

double pov_box_radius(const double lo[3], const double hi[3])
{
    double d2 = 0;
    for (int k = 0; k < 3; ++k)
        d2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return 0.5 * sqrt(d2);
}

/* True when `path` names something other than a folder: the file is found there (a special file
 * is refused where it is opened, with the reason, instead of "cannot find"). */
static int is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && !S_ISDIR(st.st_mode);
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
