/* vbnl object layer: POV-Ray 3.7 objects, camera, lights and global_settings onto the core scene.
 * See pov_scene.h for the API and scene_parser/README.md for the mapping and its reasons. */
#include "vbnl/pov_scene.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_object.h"
#include "sdl_internal.h"
#include "vbnl/integrator.h"
#include "vbnl/mesh_import.h"

#define PI 3.14159265358979323846
/* An infinite plane becomes a square patch this many times the scene's bounding radius. */
#define POV_PLANE_EXTENT 100.0

typedef struct pov_cam {
    double loc[3], dir[3], right[3], up[3], sky[3], look_at[3];
    double angle;
    int have_look_at, have_angle, other_type;
    double m[16];
} pov_cam;

typedef struct loader {
    pov_ctx c;
    pov_obj world;
    double geo_centre[3]; /* centre of the geometry's bounds (build), for unfaded lights */
    int have_geo;
    pov_cam cam;
    int have_camera;
    double env[3];
    int have_env;
    char integrator[64];
    vbnl_params *params;
    char **diags;
    size_t ndiags;
    vbnl_sdl_diag_fn user_diag;
    void *user_diag_user;
    int warned_shadowless, warned_no_shadow, warned_fade;
    int files_disabled; /* includes disabled: vbnl_mesh is refused too */
    vbnl_sdl_loc *warned;    /* skipped shapes already warned about */
    size_t nwarned;
    uint32_t *sphere_groups; /* per material: group holding a unit sphere (ellipsoids), or 0 */
    uint32_t nsphere_groups;
} loader;

struct vbnl_pov_scene {
    vbnl_scene *scene;
    char integrator[64];
    vbnl_params *params;
    char **diags;
    size_t ndiags;
};

static vbnl_result parse_object(loader *L, pov_obj *o);
static vbnl_result parse_light(loader *L, pov_obj *o);

/* ---- small helpers --------------------------------------------------------------------------- */

static int is_word(const vbnl_sdl_token *t, const char *w)
{
    return t->kind == VBNL_SDL_TOK_IDENT && strcmp(t->text, w) == 0;
}

static int is_punct(const vbnl_sdl_token *t, int op) { return t->kind == VBNL_SDL_TOK_PUNCT && t->op == op; }

static int in_list(const char *w, const char *const *list)
{
    for (int i = 0; list[i]; ++i)
        if (strcmp(w, list[i]) == 0)
            return 1;
    return 0;
}

static const char *const shape_words[] = {
    "sphere", "box", "plane", "cylinder", "cone", "disc", "torus", "triangle", "smooth_triangle",
    "polygon", "mesh", "mesh2", "union", "merge", "object", "light_source", "intersection",
    "difference", "vbnl_mesh", "light_group", NULL};

/* Shapes parsed (their block skipped) and left out with a warning. */
static const char *const skipped_shapes[] = {
    "height_field", "isosurface", "blob", "lathe", "sor", "prism", "text", "julia_fractal",
    "superellipsoid", "parametric", "poly", "polynomial", "quartic", "cubic", "quadric",
    "sphere_sweep", "bicubic_patch", "ovus", "lemon", "fractal", NULL};

static int is_shape(const vbnl_sdl_token *t)
{
    return t->kind == VBNL_SDL_TOK_IDENT && (in_list(t->text, shape_words) || in_list(t->text, skipped_shapes));
}

static void v3(double o[3], double a, double b, double c)
{
    o[0] = a;
    o[1] = b;
    o[2] = c;
}

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static double len3(const double a[3]) { return sqrt(dot3(a, a)); }
static void cross3(const double a[3], const double b[3], double o[3])
{
    double r[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    memcpy(o, r, sizeof r);
}
static void scale3(double a[3], double s)
{
    for (int i = 0; i < 3; ++i)
        a[i] *= s;
}

static vbnl_result oom(loader *L) { return vbnl_sdl_error(L->c.parser, NULL, "out of memory"); }

static vbnl_result vec3(loader *L, double o[3]) { return vbnl_sdl_parse_vector(L->c.parser, 3, o); }
static vbnl_result flt(loader *L, double *o) { return vbnl_sdl_parse_float(L->c.parser, o); }

/* The count of a list ("vertex_vectors { 14 <..>, ...}"): '<' after it starts the first item,
 * as in POV-Ray, instead of comparing. */
static vbnl_result list_count(loader *L, double *o)
{
    L->c.parser->in_count++;
    vbnl_result r = vbnl_sdl_parse_float(L->c.parser, o);
    L->c.parser->in_count--;
    return r;
}
static void comma(loader *L) { vbnl_sdl_accept(L->c.parser, ','); }

/* An optional boolean after a flag keyword ("hollow", "hollow on", "hollow false"). */
static vbnl_result opt_bool(loader *L, double *out)
{
    static const char *const words[] = {"on", "off", "true", "false", "yes", "no", NULL};
    const vbnl_sdl_token *t = vbnl_sdl_peek(L->c.parser);
    *out = 1;
    if (t->kind == VBNL_SDL_TOK_NUMBER || is_punct(t, '(') || is_punct(t, '!') ||
        (t->kind == VBNL_SDL_TOK_IDENT && in_list(t->text, words)))
        return flt(L, out);
    if (t->kind == VBNL_SDL_TOK_IDENT) {
        const vbnl_sdl_value *v = vbnl_sdl_lookup(L->c.parser, t->text);
        if (v && v->kind == VBNL_SDL_FLOAT)
            return flt(L, out);
    }
    return VBNL_OK;
}

/* ---- object values --------------------------------------------------------------------------- */

static void obj_clear(pov_obj *o)
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

static pov_prim *obj_add(pov_obj *o, int kind, vbnl_sdl_loc loc);
pov_prim *pov_obj_add(pov_obj *o, int kind, vbnl_sdl_loc loc) { return obj_add(o, kind, loc); }

static pov_prim *obj_add(pov_obj *o, int kind, vbnl_sdl_loc loc)
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

/* Appends deep copies of src's primitives (meshes shared). Returns 0 when out of memory. */
static int obj_append_copy(pov_obj *dst, const pov_obj *src)
{
    for (size_t i = 0; i < src->n; ++i) {
        const pov_prim *s = &src->v[i];
        pov_prim *d = obj_add(dst, s->kind, s->loc);
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

/* Moves src's primitives into dst (src is left empty). */
static int obj_move(pov_obj *dst, pov_obj *src)
{
    for (size_t i = 0; i < src->n; ++i) {
        pov_prim *d = obj_add(dst, 0, src->loc);
        if (!d)
            return 0;
        *d = src->v[i];
    }
    src->n = 0;
    return 1;
}

/* Hands the object's own appearance to primitives without one (POV-Ray's CSG inheritance). */
static int obj_finish(pov_obj *o)
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

static void obj_transform(pov_obj *o, const double m[16])
{
    for (size_t i = 0; i < o->n; ++i) {
        pov_m4_mul(m, o->v[i].m, o->v[i].m);
        if (o->v[i].app)
            pov_appearance_transform(o->v[i].app, m);
    }
    if (o->app)
        pov_appearance_transform(o->app, m);
}

static void objv_destroy(void *ptr, void *user)
{
    (void)user;
    obj_clear(ptr);
    free(ptr);
}

static void *objv_copy(const void *ptr, void *user)
{
    (void)user;
    const pov_obj *s = ptr;
    pov_obj *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    d->loc = s->loc;
    if (!obj_append_copy(d, s) || (s->app && !(d->app = pov_appearance_copy(s->app)))) {
        objv_destroy(d, NULL);
        return NULL;
    }
    return d;
}

static void *memv_copy_m4(const void *ptr, void *user)
{
    (void)user;
    double *d = malloc(16 * sizeof *d);
    if (d)
        memcpy(d, ptr, 16 * sizeof *d);
    return d;
}

static void *memv_copy_cam(const void *ptr, void *user)
{
    (void)user;
    pov_cam *d = malloc(sizeof *d);
    if (d)
        *d = *(const pov_cam *)ptr;
    return d;
}

static void memv_destroy(void *ptr, void *user)
{
    (void)user;
    free(ptr);
}

static const vbnl_sdl_opaque_type object_type = {"object", objv_destroy, objv_copy, NULL, NULL};
static const vbnl_sdl_opaque_type transform_type = {"transform", memv_destroy, memv_copy_m4, NULL, NULL};
static const vbnl_sdl_opaque_type camera_type = {"camera", memv_destroy, memv_copy_cam, NULL, NULL};

static const void *declared(loader *L, const vbnl_sdl_token *t, const vbnl_sdl_opaque_type *type)
{
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return NULL;
    const vbnl_sdl_value *v = vbnl_sdl_lookup(L->c.parser, t->text);
    return v && v->kind == VBNL_SDL_OBJECT && v->u.obj.type == type ? v->u.obj.ptr : NULL;
}

/* ---- transforms ------------------------------------------------------------------------------ */

static vbnl_result parse_transform_block(loader *L, double m[16]);

/* If the next token is a transform keyword, consumes the item and returns 1 with its matrix;
 * 0 when it is not one; -1 on error. */
static int parse_transform_item(loader *L, double m[16])
{
    vbnl_sdl_parser *p = L->c.parser;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    vbnl_sdl_loc loc = t->loc;
    double v[12];
    if (is_word(t, "translate")) {
        vbnl_sdl_next(p);
        if (vec3(L, v) != VBNL_OK)
            return -1;
        pov_m4_translate(v, m);
        return 1;
    }
    if (is_word(t, "rotate")) {
        vbnl_sdl_next(p);
        if (vec3(L, v) != VBNL_OK)
            return -1;
        pov_m4_rotate(v, m);
        return 1;
    }
    if (is_word(t, "scale")) {
        vbnl_sdl_next(p);
        if (vec3(L, v) != VBNL_OK)
            return -1;
        if (v[0] == 0 || v[1] == 0 || v[2] == 0)
            vbnl_sdl_warning(p, &loc, "scale by 0 changed to 1 (as POV-Ray does)");
        for (int i = 0; i < 3; ++i)
            if (v[i] == 0)
                v[i] = 1;
        pov_m4_scale(v, m);
        return 1;
    }
    if (is_word(t, "matrix")) {
        vbnl_sdl_next(p);
        if (vbnl_sdl_expect(p, '<', "to open the 12 values of 'matrix'") != VBNL_OK)
            return -1;
        p->in_vector++; /* '>' closes the list */
        for (int i = 0; i < 12; ++i) {
            if ((i && vbnl_sdl_expect(p, ',', "between the 12 values of 'matrix'") != VBNL_OK) ||
                flt(L, &v[i]) != VBNL_OK) {
                p->in_vector--;
                return -1;
            }
        }
        p->in_vector--;
        if (vbnl_sdl_expect(p, '>', "after the 12 values of 'matrix'") != VBNL_OK)
            return -1;
        pov_m4_from_pov(v, m);
        double inv[16];
        if (!pov_m4_invert(m, inv)) {
            vbnl_sdl_error(p, &loc, "matrix is singular");
            return -1;
        }
        return 1;
    }
    if (is_word(t, "transform")) {
        vbnl_sdl_next(p);
        t = vbnl_sdl_peek(p);
        const double *d = declared(L, t, &transform_type);
        if (d) {
            vbnl_sdl_next(p);
            memcpy(m, d, 16 * sizeof *m);
            return 1;
        }
        return parse_transform_block(L, m) == VBNL_OK ? 1 : -1;
    }
    return 0;
}

/* transform { [ID] items [inverse] } (the parser is on '{'). */
static vbnl_result parse_transform_block(loader *L, double m[16])
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'transform'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_m4_identity(m);
    int inverse = 0;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (is_punct(t, '}')) {
            vbnl_sdl_next(p);
            break;
        }
        const double *d = declared(L, t, &transform_type);
        double it[16];
        if (d) {
            vbnl_sdl_next(p);
            pov_m4_mul(d, m, m);
            continue;
        }
        if (is_word(t, "inverse")) {
            vbnl_sdl_next(p);
            inverse = !inverse;
            continue;
        }
        int r = parse_transform_item(L, it);
        if (r < 0)
            return VBNL_ERR_PARSE;
        if (r == 0) {
            char buf[80];
            return vbnl_sdl_error(p, &t->loc, "expected translate, rotate, scale, matrix, transform or inverse in 'transform', found %s",
                                  sdl_token_describe(t, buf, sizeof buf));
        }
        pov_m4_mul(it, m, m);
    }
    if (inverse && !pov_m4_invert(m, m))
        return vbnl_sdl_error(p, NULL, "cannot invert a singular transform");
    return VBNL_OK;
}

/* ---- object modifiers ------------------------------------------------------------------------ */

typedef struct shape_flags {
    int open;      /* cylinder/cone: "open" seen */
    int allow_open;
    pov_obj clip;  /* clipped_by shapes, applied once the shape is built (a cylinder's mesh is
                    * made after its modifiers) */
    vbnl_sdl_loc clip_loc;
} shape_flags;

static vbnl_result unexpected(loader *L, const char *what);

/* clipped_by: the object keeps its surface inside the union of the clipping shapes (POV-Ray's
 * clipping; the shapes' own surfaces are not added). Consumes clip. */
static vbnl_result apply_clip(loader *L, pov_obj *o, pov_obj *clip, vbnl_sdl_loc loc)
{
    pov_obj ops[2];
    memset(ops, 0, sizeof ops);
    ops[1] = *clip;
    memset(clip, 0, sizeof *clip);
    /* the object's primitives so far are the clipped operand; its own appearance stays with it
     * and reaches the pieces later, as it would have reached the primitives */
    ops[0].v = o->v;
    ops[0].n = o->n;
    ops[0].cap = o->cap;
    o->v = NULL;
    o->n = o->cap = 0;
    vbnl_result r = VBNL_OK;
    const char *error = NULL;
    if (!pov_csg_build_surfaces(POV_CSG_INTERSECTION, ops, 2, 1, o, &error))
        r = strcmp(error, "out of memory") ? vbnl_sdl_error(L->c.parser, &loc, "clipped_by: %s", error) : oom(L);
    obj_clear(&ops[0]);
    obj_clear(&ops[1]);
    return r;
}

/* clipped_by { shapes } (the parser is on the keyword) into clip (shapes added). */
static vbnl_result parse_clipped_by(loader *L, pov_obj *clip)
{
    vbnl_sdl_parser *p = L->c.parser;
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '{', "after 'clipped_by'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (is_word(vbnl_sdl_peek(p), "bounded_by")) { /* clipped_by { bounded_by }: no clipping */
        vbnl_sdl_next(p);
        return vbnl_sdl_expect(p, '}', "after 'bounded_by' in 'clipped_by'");
    }
    while (!is_punct(vbnl_sdl_peek(p), '}')) {
        if (!is_shape(vbnl_sdl_peek(p)))
            return unexpected(L, "clipped_by");
        pov_obj child = {0};
        if (parse_object(L, &child) != VBNL_OK || !obj_move(clip, &child)) {
            obj_clear(&child);
            return vbnl_sdl_failed(p) ? VBNL_ERR_PARSE : oom(L);
        }
        obj_clear(&child);
    }
    vbnl_sdl_next(p);
    return VBNL_OK;
}

/* One object modifier (the parser is on it). Returns 1 if consumed, 0 if not a modifier. */
static int parse_modifier(loader *L, pov_obj *o, shape_flags *sf)
{
    vbnl_sdl_parser *p = L->c.parser;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    vbnl_sdl_loc loc = t->loc;
    if (pov_appearance_is_modifier(t))
        return pov_appearance_parse_modifier(&L->c, &o->app) == VBNL_OK ? 1 : -1;
    double m[16];
    int r = parse_transform_item(L, m);
    if (r < 0)
        return -1;
    if (r > 0) {
        obj_transform(o, m);
        if (sf)
            obj_transform(&sf->clip, m);
        return 1;
    }
    static const char *const flags[] = {"no_image", "no_reflection", "no_radiosity", "double_illuminate",
                                        "smooth", "uv_mapping", "cutaway_textures", NULL};
    static const char *const bool_flags[] = {"hollow", "sturm", "split_union", "hierarchy", NULL};
    static const char *const skipped_blocks[] = {"bounded_by", "photons", "radiosity", NULL};
    if (is_word(t, "inverse")) { /* swaps inside and outside (CSG) */
        vbnl_sdl_next(p);
        for (size_t i = 0; i < o->n; ++i)
            o->v[i].inverse = !o->v[i].inverse;
        return 1;
    }
    if (is_word(t, "no_shadow")) {
        vbnl_sdl_next(p);
        if (!L->warned_no_shadow++)
            vbnl_sdl_warning(p, &loc, "no_shadow is ignored: every object casts shadows under global illumination");
        return 1;
    }
    if (in_list(t->text, flags)) {
        vbnl_sdl_next(p);
        return 1;
    }
    if (in_list(t->text, bool_flags)) {
        double b;
        vbnl_sdl_next(p);
        return opt_bool(L, &b) == VBNL_OK ? 1 : -1;
    }
    if (sf && sf->allow_open && is_word(t, "open")) {
        vbnl_sdl_next(p);
        sf->open = 1;
        return 1;
    }
    if (in_list(t->text, skipped_blocks)) {
        vbnl_sdl_next(p);
        return vbnl_sdl_skip_block(p) == VBNL_OK ? 1 : -1;
    }
    if (is_word(t, "clipped_by")) {
        if (sf) { /* applied by the shape when it is built */
            sf->clip_loc = loc;
            return parse_clipped_by(L, &sf->clip) == VBNL_OK ? 1 : -1;
        }
        pov_obj clip = {0};
        if (parse_clipped_by(L, &clip) != VBNL_OK) {
            obj_clear(&clip);
            return -1;
        }
        return apply_clip(L, o, &clip, loc) == VBNL_OK ? 1 : -1;
    }
    return 0;
}

static vbnl_result unexpected(loader *L, const char *what)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(L->c.parser);
    char buf[80];
    if (t->kind == VBNL_SDL_TOK_EOF)
        return vbnl_sdl_failed(L->c.parser) ? VBNL_ERR_PARSE : vbnl_sdl_error(L->c.parser, &t->loc, "missing '}' at the end of '%s'", what);
    return vbnl_sdl_error(L->c.parser, &t->loc, "unexpected %s in '%s'", sdl_token_describe(t, buf, sizeof buf), what);
}

/* Modifiers up to and including the closing '}'. */
static vbnl_result parse_modifiers(loader *L, pov_obj *o, shape_flags *sf, const char *what)
{
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(L->c.parser);
        if (is_punct(t, '}')) {
            vbnl_sdl_next(L->c.parser);
            return VBNL_OK;
        }
        int r = parse_modifier(L, o, sf);
        if (r < 0)
            return VBNL_ERR_PARSE;
        if (r == 0)
            return unexpected(L, what);
    }
}

/* ---- shapes ---------------------------------------------------------------------------------- */

static vbnl_result add_mesh_prim(loader *L, pov_obj *o, pov_mesh *m, vbnl_sdl_loc loc)
{
    if (!m)
        return oom(L);
    pov_prim *pr = obj_add(o, POV_PRIM_MESH, loc);
    if (!pr) {
        pov_mesh_unref(m);
        return oom(L);
    }
    pr->mesh = m;
    return VBNL_OK;
}

static vbnl_result positive(loader *L, double v, const char *what, vbnl_sdl_loc loc)
{
    if (!(v > 0) || !isfinite(v))
        return vbnl_sdl_error(L->c.parser, &loc, "%s must be positive, got %g", what, v);
    return VBNL_OK;
}

/* triangle { a, b, c } / smooth_triangle { a, na, b, nb, c, nc } values (after '{'). */
static vbnl_result tri_values(loader *L, int smooth, double v[3][3], double n[3][3])
{
    for (int k = 0; k < 3; ++k) {
        if (k)
            comma(L);
        if (vec3(L, v[k]) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (smooth) {
            comma(L);
            if (vec3(L, n[k]) != VBNL_OK)
                return VBNL_ERR_PARSE;
        }
    }
    return VBNL_OK;
}

static void fix_normals(double v[3][3], double n[3][3], int smooth)
{
    double e1[3], e2[3], f[3];
    for (int i = 0; i < 3; ++i) {
        e1[i] = v[1][i] - v[0][i];
        e2[i] = v[2][i] - v[0][i];
    }
    cross3(e1, e2, f);
    double lf = len3(f);
    for (int k = 0; k < 3; ++k) {
        double l = smooth ? len3(n[k]) : 0;
        if (l > 0)
            scale3(n[k], 1 / l);
        else if (lf > 0)
            for (int i = 0; i < 3; ++i)
                n[k][i] = f[i] / lf;
        else
            v3(n[k], 0, 1, 0);
    }
}

/* mesh { triangle { ... [texture { T }] } smooth_triangle { ... } inside_vector V modifiers } */
static vbnl_result parse_mesh(loader *L, pov_obj *o, vbnl_sdl_loc loc)
{
    vbnl_sdl_parser *p = L->c.parser;
    typedef struct { double v[3][3], n[3][3]; int smooth; int32_t tex; } tri;
    tri *tris = NULL;
    size_t nt = 0, cap = 0;
    int any_smooth = 0;
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return oom(L);
    vbnl_result r = VBNL_OK;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        int smooth = is_word(t, "smooth_triangle");
        if (!smooth && !is_word(t, "triangle"))
            break;
        vbnl_sdl_next(p);
        if (nt == cap) {
            cap = cap ? 2 * cap : 64;
            tri *n = realloc(tris, cap * sizeof *n);
            if (!n) {
                r = oom(L);
                goto done;
            }
            tris = n;
        }
        tri *tr = &tris[nt++];
        tr->smooth = smooth;
        tr->tex = -1;
        any_smooth |= smooth;
        if ((r = vbnl_sdl_expect(p, '{', smooth ? "after 'smooth_triangle'" : "after 'triangle'")) != VBNL_OK ||
            (r = tri_values(L, smooth, tr->v, tr->n)) != VBNL_OK)
            goto done;
        fix_normals(tr->v, tr->n, smooth);
        for (;;) {
            t = vbnl_sdl_peek(p);
            if (is_punct(t, '}')) {
                vbnl_sdl_next(p);
                break;
            }
            if (is_word(t, "uv_vectors")) { /* per-triangle uv: accepted (patterns use world space) */
                double uvv[2];
                vbnl_sdl_next(p);
                for (int k = 0; k < 3; ++k) {
                    if (k)
                        comma(L);
                    if ((r = vbnl_sdl_parse_vector(p, 2, uvv)) != VBNL_OK)
                        goto done;
                }
                continue;
            }
            if (is_word(t, "texture") || is_word(t, "texture_list")) {
                pov_appearance *a = NULL;
                if ((r = pov_appearance_parse_modifier(&L->c, &a)) != VBNL_OK)
                    goto done;
                pov_appearance **nx = realloc(m->texs, (m->ntex + 1) * sizeof *nx);
                if (!nx) {
                    pov_appearance_free(a);
                    r = oom(L);
                    goto done;
                }
                m->texs = nx;
                m->texs[m->ntex] = a;
                tr->tex = (int32_t)m->ntex++;
                continue;
            }
            r = unexpected(L, smooth ? "smooth_triangle" : "triangle");
            goto done;
        }
    }
    for (size_t i = 0; i < nt; ++i) {
        uint32_t id[3];
        for (int k = 0; k < 3; ++k)
            id[k] = pov_mesh_vertex(m, tris[i].v[k], any_smooth ? tris[i].n[k] : NULL, NULL);
        if (!pov_mesh_tri(m, id[0], id[1], id[2], tris[i].tex)) {
            r = oom(L);
            goto done;
        }
    }
    if (nt == 0)
        vbnl_sdl_warning(p, &loc, "mesh without triangles");
    free(tris);
    tris = NULL;
    r = add_mesh_prim(L, o, m, loc);
    m = NULL;
    if (r != VBNL_OK)
        return r;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (is_word(t, "inside_vector")) {
            double v[3];
            vbnl_sdl_next(p);
            if (vec3(L, v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            continue;
        }
        break;
    }
    return VBNL_OK;
done:
    free(tris);
    pov_mesh_unref(m);
    return r;
}

/* A counted list "{ n, item, item ... }" of vectors (dim 2 or 3). */
static vbnl_result counted_vectors(loader *L, const char *what, int dim, double **out, size_t *count)
{
    vbnl_sdl_parser *p = L->c.parser;
    double n;
    *out = NULL;
    *count = 0;
    if (vbnl_sdl_expect(p, '{', "after the list keyword") != VBNL_OK || list_count(L, &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    if (!(n >= 0 && n <= 1e8) || n != floor(n))
        return vbnl_sdl_error(p, &loc, "%s: the count must be a whole number in [0, 1e8], got %g", what, n);
    double *v = malloc(sizeof(double) * (size_t)dim * ((size_t)n + 1));
    if (!v)
        return oom(L);
    for (size_t i = 0; i < (size_t)n; ++i) {
        comma(L);
        if (is_punct(vbnl_sdl_peek(p), '}')) {
            free(v);
            return vbnl_sdl_error(p, NULL, "%s: %zu items given, %g declared", what, i, n);
        }
        if (vbnl_sdl_parse_vector(p, dim, v + (size_t)dim * i) != VBNL_OK) {
            free(v);
            return VBNL_ERR_PARSE;
        }
    }
    comma(L);
    if (vbnl_sdl_expect(p, '}', "after the declared number of items") != VBNL_OK) {
        free(v);
        return VBNL_ERR_PARSE;
    }
    *out = v;
    *count = (size_t)n;
    return VBNL_OK;
}

/* mesh2 { vertex_vectors normal_vectors uv_vectors texture_list face_indices normal_indices
 *         uv_indices inside_vector modifiers } */
static vbnl_result parse_mesh2(loader *L, pov_obj *o, vbnl_sdl_loc loc)
{
    vbnl_sdl_parser *p = L->c.parser;
    double *vv = NULL, *nv = NULL, *uv = NULL, *fi = NULL, *ni = NULL, *ui = NULL;
    size_t nvv = 0, nnv = 0, nuv = 0, nfi = 0, nni = 0, nui = 0;
    int32_t *ftex = NULL; /* per face: first texture index or -1 */
    pov_appearance **texs = NULL;
    size_t ntex = 0;
    pov_mesh *m = NULL;
    vbnl_result r = VBNL_OK;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        vbnl_sdl_loc tl = t->loc;
        if (is_word(t, "vertex_vectors")) {
            vbnl_sdl_next(p);
            free(vv);
            if ((r = counted_vectors(L, "vertex_vectors", 3, &vv, &nvv)) != VBNL_OK)
                goto done;
        } else if (is_word(t, "normal_vectors")) {
            vbnl_sdl_next(p);
            free(nv);
            if ((r = counted_vectors(L, "normal_vectors", 3, &nv, &nnv)) != VBNL_OK)
                goto done;
        } else if (is_word(t, "uv_vectors")) {
            vbnl_sdl_next(p);
            free(uv);
            if ((r = counted_vectors(L, "uv_vectors", 2, &uv, &nuv)) != VBNL_OK)
                goto done;
        } else if (is_word(t, "normal_indices")) {
            vbnl_sdl_next(p);
            free(ni);
            if ((r = counted_vectors(L, "normal_indices", 3, &ni, &nni)) != VBNL_OK)
                goto done;
        } else if (is_word(t, "uv_indices")) {
            vbnl_sdl_next(p);
            free(ui);
            if ((r = counted_vectors(L, "uv_indices", 3, &ui, &nui)) != VBNL_OK)
                goto done;
        } else if (is_word(t, "texture_list")) {
            double n;
            vbnl_sdl_next(p);
            if ((r = vbnl_sdl_expect(p, '{', "after 'texture_list'")) != VBNL_OK || (r = flt(L, &n)) != VBNL_OK)
                goto done;
            if (!(n >= 0 && n <= 1e6) || n != floor(n)) {
                r = vbnl_sdl_error(p, &tl, "texture_list: the count must be a whole number in [0, 1e6], got %g", n);
                goto done;
            }
            for (size_t i = 0; i < ntex; ++i)
                pov_appearance_free(texs[i]);
            free(texs);
            ntex = 0;
            texs = calloc((size_t)n + 1, sizeof *texs);
            if (!texs) {
                r = oom(L);
                goto done;
            }
            for (size_t i = 0; i < (size_t)n; ++i) {
                comma(L);
                if (!is_word(vbnl_sdl_peek(p), "texture")) {
                    r = vbnl_sdl_error(p, NULL, "texture_list: expected 'texture' (%zu of %g)", i + 1, n);
                    goto done;
                }
                if ((r = pov_appearance_parse_modifier(&L->c, &texs[ntex])) != VBNL_OK)
                    goto done;
                ntex++;
            }
            comma(L);
            if ((r = vbnl_sdl_expect(p, '}', "after the textures of 'texture_list'")) != VBNL_OK)
                goto done;
        } else if (is_word(t, "face_indices")) {
            double n;
            vbnl_sdl_next(p);
            if ((r = vbnl_sdl_expect(p, '{', "after 'face_indices'")) != VBNL_OK || (r = list_count(L, &n)) != VBNL_OK)
                goto done;
            if (!(n >= 0 && n <= 1e8) || n != floor(n)) {
                r = vbnl_sdl_error(p, &tl, "face_indices: the count must be a whole number in [0, 1e8], got %g", n);
                goto done;
            }
            free(fi);
            free(ftex);
            nfi = (size_t)n;
            fi = malloc(sizeof(double) * 3 * (nfi + 1));
            ftex = malloc(sizeof(int32_t) * (nfi + 1));
            if (!fi || !ftex) {
                r = oom(L);
                goto done;
            }
            for (size_t i = 0; i < nfi; ++i) {
                comma(L);
                if ((r = vbnl_sdl_parse_vector(p, 3, fi + 3 * i)) != VBNL_OK)
                    goto done;
                ftex[i] = -1;
                /* texture indices, only after a texture_list (as POV-Ray reads them): one, or
                 * three (per vertex; the first is used) */
                for (int k = 0; k < (ntex > 0 ? 3 : 0); ++k) {
                    const vbnl_sdl_token *a = vbnl_sdl_peek(p);
                    if (!is_punct(a, ','))
                        break;
                    vbnl_sdl_next(p);
                    a = vbnl_sdl_peek(p);
                    if (is_punct(a, '<') || is_punct(a, '}'))
                        break;
                    double ti;
                    if ((r = flt(L, &ti)) != VBNL_OK)
                        goto done;
                    if (k == 0)
                        ftex[i] = (int32_t)fmax(-1, fmin(ti, 2e9));
                }
            }
            comma(L);
            if ((r = vbnl_sdl_expect(p, '}', "after the declared number of faces")) != VBNL_OK)
                goto done;
        } else {
            break;
        }
    }
    if (!vv || !fi) {
        r = vbnl_sdl_error(p, &loc, "mesh2 needs vertex_vectors and face_indices");
        goto done;
    }
    if (ni && nni != nfi) {
        r = vbnl_sdl_error(p, &loc, "mesh2: normal_indices has %zu entries, face_indices %zu", nni, nfi);
        goto done;
    }
    if (ui && nui != nfi) {
        r = vbnl_sdl_error(p, &loc, "mesh2: uv_indices has %zu entries, face_indices %zu", nui, nfi);
        goto done;
    }
    m = pov_mesh_new();
    if (!m) {
        r = oom(L);
        goto done;
    }
    int use_n = nv && (ni || nnv == nvv), use_uv = uv && (ui || nuv == nvv);
    for (size_t f = 0; f < nfi; ++f) {
        uint32_t id[3];
        double tv[3][3], tn[3][3];
        for (int k = 0; k < 3; ++k) {
            double iv = fi[3 * f + k];
            if (!(iv >= 0 && iv < (double)nvv) || iv != floor(iv)) {
                r = vbnl_sdl_error(p, &loc, "mesh2: face %zu uses vertex index %g; vertex_vectors has %zu", f, iv, nvv);
                goto done;
            }
            memcpy(tv[k], vv + 3 * (size_t)iv, sizeof tv[k]);
            v3(tn[k], 0, 0, 0);
            if (use_n) {
                double in = ni ? ni[3 * f + k] : iv;
                if (!(in >= 0 && in < (double)nnv) || in != floor(in)) {
                    r = vbnl_sdl_error(p, &loc, "mesh2: face %zu uses normal index %g; normal_vectors has %zu", f, in, nnv);
                    goto done;
                }
                memcpy(tn[k], nv + 3 * (size_t)in, sizeof tn[k]);
            }
        }
        fix_normals(tv, tn, use_n);
        for (int k = 0; k < 3; ++k) {
            double tuv[2] = {0, 0};
            if (use_uv) {
                double iu = ui ? ui[3 * f + k] : fi[3 * f + k];
                if (!(iu >= 0 && iu < (double)nuv) || iu != floor(iu)) {
                    r = vbnl_sdl_error(p, &loc, "mesh2: face %zu uses uv index %g; uv_vectors has %zu", f, iu, nuv);
                    goto done;
                }
                memcpy(tuv, uv + 2 * (size_t)iu, sizeof tuv);
            }
            id[k] = pov_mesh_vertex(m, tv[k], use_n ? tn[k] : NULL, use_uv ? tuv : NULL);
        }
        int32_t tx = ftex[f];
        if (tx >= (int32_t)ntex) {
            r = vbnl_sdl_error(p, &loc, "mesh2: face %zu uses texture %d; texture_list has %zu", f, (int)tx, ntex);
            goto done;
        }
        if (!pov_mesh_tri(m, id[0], id[1], id[2], tx)) {
            r = oom(L);
            goto done;
        }
    }
    m->texs = texs;
    m->ntex = (uint32_t)ntex;
    texs = NULL;
    ntex = 0;
    r = add_mesh_prim(L, o, m, loc);
    m = NULL;
    while (r == VBNL_OK && is_word(vbnl_sdl_peek(p), "inside_vector")) {
        double v[3];
        vbnl_sdl_next(p);
        r = vec3(L, v);
    }
done:
    free(vv);
    free(nv);
    free(uv);
    free(fi);
    free(ni);
    free(ui);
    free(ftex);
    for (size_t i = 0; i < ntex; ++i)
        pov_appearance_free(texs[i]);
    free(texs);
    pov_mesh_unref(m);
    return r;
}

static vbnl_result parse_polygon(loader *L, pov_obj *o, vbnl_sdl_loc loc)
{
    vbnl_sdl_parser *p = L->c.parser;
    double n;
    if (list_count(L, &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(n >= 3 && n <= 1e7) || n != floor(n))
        return vbnl_sdl_error(p, &loc, "polygon needs a whole number of at least 3 points, got %g", n);
    double *pts = malloc(sizeof(double) * 3 * (size_t)n);
    if (!pts)
        return oom(L);
    for (size_t i = 0; i < (size_t)n; ++i) {
        vbnl_sdl_value v;
        comma(L);
        if (vbnl_sdl_parse_expression(p, &v) != VBNL_OK) {
            free(pts);
            return VBNL_ERR_PARSE;
        }
        if (v.kind == VBNL_SDL_VECTOR && v.dim == 2) {
            v3(pts + 3 * i, v.v[0], v.v[1], 0);
        } else if (v.kind == VBNL_SDL_VECTOR || v.kind == VBNL_SDL_COLOR) {
            v3(pts + 3 * i, v.v[0], v.v[1], v.v[2]);
        } else if (v.kind == VBNL_SDL_FLOAT) {
            v3(pts + 3 * i, v.v[0], v.v[0], v.v[0]);
        } else {
            vbnl_sdl_value_clear(p, &v);
            free(pts);
            return vbnl_sdl_error(p, NULL, "polygon point %zu must be a vector", i + 1);
        }
        vbnl_sdl_value_clear(p, &v);
    }
    int nested, open_last, huge;
    pov_mesh *m = pov_tess_polygon(pts, (int)n, &nested, &open_last, &huge);
    if (huge)
        vbnl_sdl_warning(p, &loc, "polygon: a sub-polygon has more than %d points; it is triangulated as a fan from its first point (exact when convex)",
                         POV_EAR_CLIP_MAX);
    free(pts);
    if (nested)
        vbnl_sdl_warning(p, &loc, "polygon: a sub-polygon inside another is filled, not cut out as a hole");
    if (open_last)
        vbnl_sdl_warning(p, &loc, "polygon: the last sub-polygon is not closed (its first point is not repeated); closed automatically");
    return add_mesh_prim(L, o, m, loc);
}

/* vbnl_mesh { "file" [appearance] [transforms] }: mesh file import (vbnl extension). */
static vbnl_result parse_vbnl_mesh(loader *L, pov_obj *o, vbnl_sdl_loc loc)
{
    vbnl_sdl_parser *p = L->c.parser;
    vbnl_sdl_loc sl = vbnl_sdl_peek(p)->loc;
    char *name = NULL;
    if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (L->files_disabled) {
        free(name);
        return vbnl_sdl_error(p, &sl, "vbnl_mesh: file access is disabled");
    }
    char *path;
    const char *slash = strrchr(sl.file ? sl.file : "", '/');
    if (name[0] == '/' || !slash) {
        path = strdup(name);
    } else {
        size_t dl = (size_t)(slash - sl.file) + 1;
        path = malloc(dl + strlen(name) + 1);
        if (path) {
            memcpy(path, sl.file, dl);
            strcpy(path + dl, name);
        }
    }
    free(name);
    if (!path)
        return oom(L);
    FILE *f = fopen(path, "rb");
    if (!f) {
        vbnl_result r = vbnl_sdl_error(p, &sl, "vbnl_mesh: cannot open '%s'", path);
        free(path);
        return r;
    }
    fclose(f);
    pov_prim *pr = obj_add(o, POV_PRIM_IMPORT, loc);
    if (!pr) {
        free(path);
        return oom(L);
    }
    pr->path = path;
    return VBNL_OK;
}

static vbnl_result parse_object_inner(loader *L, pov_obj *o);

/* The statement/value starting with a shape keyword (not consumed yet). Nested objects count
 * against the language layer's nesting limit, so deep CSG cannot exhaust the stack. */
static vbnl_result parse_object(loader *L, pov_obj *o)
{
    vbnl_sdl_loc loc = vbnl_sdl_peek(L->c.parser)->loc;
    if (!sdl_enter(L->c.parser, &loc))
        return VBNL_ERR_PARSE;
    vbnl_result r = parse_object_inner(L, o);
    sdl_leave(L->c.parser);
    return r;
}

/* intersection / difference / merge { objects... modifiers } (after the '{'): the operands
 * come first (as in POV-Ray); the surface is built when the first modifier or the '}' comes, so
 * the modifiers apply to it as to any object. */
static vbnl_result parse_csg(loader *L, pov_obj *o, const char *w, vbnl_sdl_loc loc)
{
    vbnl_sdl_parser *p = L->c.parser;
    pov_obj *ops = NULL;
    size_t nops = 0;
    vbnl_result r = VBNL_OK;
    while (is_shape(vbnl_sdl_peek(p))) {
        pov_obj *n = realloc(ops, (nops + 1) * sizeof *n);
        if (!n) {
            r = oom(L);
            goto done;
        }
        ops = n;
        memset(&ops[nops], 0, sizeof ops[nops]);
        nops++;
        if (parse_object(L, &ops[nops - 1]) != VBNL_OK || !obj_finish(&ops[nops - 1])) {
            r = vbnl_sdl_failed(p) ? VBNL_ERR_PARSE : oom(L);
            goto done;
        }
    }
    int op = w[0] == 'i' ? POV_CSG_INTERSECTION : w[0] == 'd' ? POV_CSG_DIFFERENCE : POV_CSG_MERGE;
    if (nops == 0) {
        vbnl_sdl_warning(p, &loc, "'%s' without objects is empty", w);
    } else {
        const char *error = NULL;
        if (!pov_csg_build(op, ops, nops, o, &error)) {
            r = strcmp(error, "out of memory") ? vbnl_sdl_error(p, &loc, "%s: %s", w, error) : oom(L);
            goto done;
        }
    }
    r = parse_modifiers(L, o, NULL, w);
done:
    for (size_t i = 0; i < nops; ++i)
        obj_clear(&ops[i]);
    free(ops);
    return r;
}

static vbnl_result parse_object_inner(loader *L, pov_obj *o)
{
    vbnl_sdl_parser *p = L->c.parser;
    vbnl_sdl_token kw = *vbnl_sdl_next(p);
    const char *w = kw.text;
    vbnl_sdl_loc loc = kw.loc;
    o->loc = loc;
    if (in_list(w, skipped_shapes)) {
        /* The warning comes where the shape is placed in the scene (a declared but unused one,
         * as in shapes.inc, is silent). */
        pov_prim *pr = obj_add(o, POV_PRIM_SKIPPED, loc);
        if (!pr || !(pr->path = strdup(w)))
            return oom(L);
        return vbnl_sdl_skip_block(p);
    }
    if (strcmp(w, "light_source") == 0)
        return parse_light(L, o);
    char ctx[64];
    snprintf(ctx, sizeof ctx, "after '%s'", w);
    if (vbnl_sdl_expect(p, '{', ctx) != VBNL_OK)
        return VBNL_ERR_PARSE;
    shape_flags sf;
    memset(&sf, 0, sizeof sf);
    double a[3], b[3], r1, r2;
    if (strcmp(w, "sphere") == 0) {
        if (vec3(L, a) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (flt(L, &r1) != VBNL_OK || positive(L, r1, "sphere radius", loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
        pov_prim *pr = obj_add(o, POV_PRIM_SPHERE, loc);
        if (!pr)
            return oom(L);
        v3(pr->a, a[0], a[1], a[2]);
        pr->a[3] = r1;
    } else if (strcmp(w, "box") == 0) {
        if (vec3(L, a) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (vec3(L, b) != VBNL_OK || add_mesh_prim(L, o, pov_tess_box(a, b), loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!(o->v[o->n - 1].solid = pov_solid_box(a, b)))
            return oom(L);
    } else if (strcmp(w, "plane") == 0) {
        if (vec3(L, a) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (flt(L, &r1) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!(len3(a) > 0))
            return vbnl_sdl_error(p, &loc, "plane normal must not be zero");
        pov_prim *pr = obj_add(o, POV_PRIM_PLANE, loc);
        if (!pr)
            return oom(L);
        v3(pr->a, a[0], a[1], a[2]);
        pr->a[3] = r1;
    } else if (strcmp(w, "cylinder") == 0 || strcmp(w, "cone") == 0) {
        int cone = w[1] == 'o';
        if (vec3(L, a) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (cone) {
            if (flt(L, &r1) != VBNL_OK)
                return VBNL_ERR_PARSE;
            comma(L);
        }
        if (vec3(L, b) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (flt(L, &r2) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!cone)
            r1 = r2;
        double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        int degenerate = !(len3(d) > 0);
        if (cone ? !(r1 >= 0 && r2 >= 0 && r1 + r2 > 0) : positive(L, r1, "cylinder radius", loc) != VBNL_OK)
            return cone ? vbnl_sdl_error(p, &loc, "cone radii must be >= 0 and not both 0") : VBNL_ERR_PARSE;
        sf.allow_open = 1;
        /* the mesh is built after the modifiers ("open" may come among them) */
        pov_prim *pr = obj_add(o, POV_PRIM_MESH, loc);
        if (!pr)
            return oom(L);
        size_t idx = o->n - 1;
        if (parse_modifiers(L, o, &sf, w) != VBNL_OK) {
            obj_clear(&sf.clip);
            return VBNL_ERR_PARSE;
        }
        if (degenerate) { /* POV-Ray warns and drops it too */
            vbnl_sdl_warning(p, &loc, "%s: the two end points coincide; the object is skipped", w);
            o->v[idx].mesh = pov_mesh_new();
        } else {
            o->v[idx].mesh = pov_tess_cone(a, r1, b, r2, sf.open);
            if (!(o->v[idx].solid = pov_solid_cone(a, r1, b, r2)))
                return oom(L);
        }
        if (!o->v[idx].mesh) {
            obj_clear(&sf.clip);
            return oom(L);
        }
        return sf.clip.n ? apply_clip(L, o, &sf.clip, sf.clip_loc) : VBNL_OK;
    } else if (strcmp(w, "disc") == 0) {
        double n[3], hole = 0;
        if (vec3(L, a) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (vec3(L, n) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (flt(L, &r1) != VBNL_OK || positive(L, r1, "disc radius", loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (vbnl_sdl_accept(p, ',') && flt(L, &hole) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!(len3(n) > 0))
            return vbnl_sdl_error(p, &loc, "disc normal must not be zero");
        if (add_mesh_prim(L, o, pov_tess_disc(a, n, r1, fmax(0, fmin(hole, r1))), loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (strcmp(w, "torus") == 0) {
        if (flt(L, &r1) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (flt(L, &r2) != VBNL_OK || positive(L, r1, "torus major radius", loc) != VBNL_OK ||
            positive(L, r2, "torus minor radius", loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (add_mesh_prim(L, o, pov_tess_torus(r1, r2), loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!(o->v[o->n - 1].solid = pov_solid_torus(r1, r2)))
            return oom(L);
    } else if (strcmp(w, "triangle") == 0 || strcmp(w, "smooth_triangle") == 0) {
        int smooth = w[0] == 's';
        double v[3][3], n[3][3];
        if (tri_values(L, smooth, v, n) != VBNL_OK)
            return VBNL_ERR_PARSE;
        fix_normals(v, n, smooth);
        pov_mesh *m = pov_mesh_new();
        if (!m)
            return oom(L);
        uint32_t id[3];
        for (int k = 0; k < 3; ++k)
            id[k] = pov_mesh_vertex(m, v[k], smooth ? n[k] : NULL, NULL);
        if (!pov_mesh_tri(m, id[0], id[1], id[2], -1)) {
            pov_mesh_unref(m);
            return oom(L);
        }
        if (add_mesh_prim(L, o, m, loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (strcmp(w, "polygon") == 0) {
        if (parse_polygon(L, o, loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (strcmp(w, "mesh") == 0) {
        if (parse_mesh(L, o, loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (strcmp(w, "mesh2") == 0) {
        if (parse_mesh2(L, o, loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (strcmp(w, "vbnl_mesh") == 0) {
        if (parse_vbnl_mesh(L, o, loc) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (strcmp(w, "object") == 0) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        const pov_obj *d = declared(L, t, &object_type);
        if (d) {
            vbnl_sdl_next(p);
            if (!obj_append_copy(o, d) || (d->app && !(o->app = pov_appearance_copy(d->app))))
                return oom(L);
        } else if (is_shape(t)) {
            pov_obj child = {0};
            if (parse_object(L, &child) != VBNL_OK || !obj_finish(&child) || !obj_move(o, &child)) {
                obj_clear(&child);
                return vbnl_sdl_failed(p) ? VBNL_ERR_PARSE : oom(L);
            }
            obj_clear(&child);
        } else if (t->kind == VBNL_SDL_TOK_IDENT && vbnl_sdl_lookup(p, t->text) &&
                   vbnl_sdl_lookup(p, t->text)->kind == VBNL_SDL_ARRAY) {
            /* object { Arr[i] } */
            vbnl_sdl_loc el = t->loc;
            vbnl_sdl_value v;
            if (vbnl_sdl_parse_expression(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (v.kind != VBNL_SDL_OBJECT || v.u.obj.type != &object_type) {
                const char *kind = v.kind == VBNL_SDL_OBJECT ? v.u.obj.type->name : vbnl_sdl_kind_name(v.kind);
                vbnl_sdl_value_clear(p, &v);
                return vbnl_sdl_error(p, &el, "array element is a %s, not an object", kind);
            }
            const pov_obj *ao = v.u.obj.ptr;
            int good = obj_append_copy(o, ao) && (!ao->app || (o->app = pov_appearance_copy(ao->app)));
            vbnl_sdl_value_clear(p, &v);
            if (!good)
                return oom(L);
        } else if (t->kind == VBNL_SDL_TOK_IDENT && vbnl_sdl_lookup(p, t->text)) {
            return vbnl_sdl_error(p, &t->loc, "'%s' is a %s, not an object", t->text,
                                  vbnl_sdl_lookup(p, t->text)->kind == VBNL_SDL_OBJECT
                                      ? vbnl_sdl_lookup(p, t->text)->u.obj.type->name
                                      : vbnl_sdl_kind_name(vbnl_sdl_lookup(p, t->text)->kind));
        } else if (t->kind == VBNL_SDL_TOK_IDENT && !pov_appearance_is_modifier(t) &&
                   !in_list(t->text, (const char *const[]){"translate", "rotate", "scale", "matrix", "transform", NULL})) {
            return vbnl_sdl_error(p, &t->loc, "undeclared object identifier '%s'", t->text);
        }
    } else if (strcmp(w, "intersection") == 0 || strcmp(w, "difference") == 0 || strcmp(w, "merge") == 0) {
        return parse_csg(L, o, w, loc);
    } else if (strcmp(w, "union") == 0 || strcmp(w, "light_group") == 0) {
        if (w[0] == 'l')
            vbnl_sdl_warning(p, &loc, "light_group is rendered as a union: its lights illuminate the whole scene");
        for (;;) {
            const vbnl_sdl_token *t = vbnl_sdl_peek(p);
            if (is_punct(t, '}')) {
                vbnl_sdl_next(p);
                break;
            }
            if (is_shape(t)) {
                pov_obj child = {0};
                if (parse_object(L, &child) != VBNL_OK || !obj_finish(&child) || !obj_move(o, &child)) {
                    obj_clear(&child);
                    return vbnl_sdl_failed(p) ? VBNL_ERR_PARSE : oom(L);
                }
                obj_clear(&child);
                continue;
            }
            if (w[0] == 'l' && is_word(t, "global_lights")) {
                double on;
                vbnl_sdl_next(p);
                if (opt_bool(L, &on) != VBNL_OK)
                    return VBNL_ERR_PARSE;
                continue;
            }
            int r = parse_modifier(L, o, NULL);
            if (r < 0)
                return VBNL_ERR_PARSE;
            if (r == 0)
                return unexpected(L, w);
        }
        return VBNL_OK;
    } else {
        return vbnl_sdl_error(p, &loc, "unknown object '%s'", w);
    }
    vbnl_result r = parse_modifiers(L, o, &sf, w);
    if (r == VBNL_OK && sf.clip.n)
        return apply_clip(L, o, &sf.clip, sf.clip_loc);
    obj_clear(&sf.clip);
    return r;
}

/* ---- light_source ---------------------------------------------------------------------------- */

static vbnl_result parse_light(loader *L, pov_obj *o)
{
    vbnl_sdl_parser *p = L->c.parser;
    vbnl_sdl_loc loc = o->loc;
    if (vbnl_sdl_expect(p, '{', "after 'light_source'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_prim *pr = obj_add(o, POV_PRIM_LIGHT, loc);
    if (!pr)
        return oom(L);
    pov_light *l = &pr->light;
    double col[5];
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    const pov_obj *d = declared(L, t, &object_type);
    if (d && d->n == 1 && d->v[0].kind == POV_PRIM_LIGHT) {
        vbnl_sdl_next(p);
        *pr = d->v[0];
        l = &pr->light;
    } else {
        if (vec3(L, l->pos) != VBNL_OK)
            return VBNL_ERR_PARSE;
        comma(L);
        if (vbnl_sdl_parse_color(p, col) != VBNL_OK)
            return VBNL_ERR_PARSE;
        v3(l->color, col[0], col[1], col[2]);
        v3(l->point_at, 0, 0, 1);
        l->radius = 30;
        l->falloff = 45;
        l->tightness = 0;
        l->fade_power = 0;
        l->fade_distance = 0;
    }
    for (;;) {
        t = vbnl_sdl_peek(p);
        vbnl_sdl_loc tl = t->loc;
        if (is_punct(t, '}')) {
            double ax[3] = {l->point_at[0] - l->pos[0], l->point_at[1] - l->pos[1], l->point_at[2] - l->pos[2]};
            if (l->type != POV_LIGHT_POINT && !(len3(ax) > 0))
                return vbnl_sdl_error(p, &loc, "light_source: %s point_at equals the location",
                                      l->type == POV_LIGHT_SPOT ? "spotlight" : "parallel");
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        double m[16], b;
        int r = parse_transform_item(L, m);
        if (r < 0)
            return VBNL_ERR_PARSE;
        if (r > 0) {
            pov_m4_mul(m, pr->m, pr->m);
            continue;
        }
        if (t->kind != VBNL_SDL_TOK_IDENT)
            return unexpected(L, "light_source");
        const char *w = t->text;
        vbnl_result rr = VBNL_OK;
        if (strcmp(w, "spotlight") == 0) {
            vbnl_sdl_next(p);
            l->type = POV_LIGHT_SPOT;
        } else if (strcmp(w, "cylinder") == 0) {
            vbnl_sdl_next(p);
            l->type = POV_LIGHT_SPOT;
            l->cylinder = 1;
            vbnl_sdl_warning(p, &tl, "cylinder light_source is rendered as a spotlight with the same angles");
        } else if (strcmp(w, "parallel") == 0) {
            vbnl_sdl_next(p);
            l->type = POV_LIGHT_PARALLEL;
        } else if (strcmp(w, "point_at") == 0) {
            vbnl_sdl_next(p);
            rr = vec3(L, l->point_at);
        } else if (strcmp(w, "radius") == 0) {
            vbnl_sdl_next(p);
            rr = flt(L, &l->radius);
        } else if (strcmp(w, "falloff") == 0) {
            vbnl_sdl_next(p);
            rr = flt(L, &l->falloff);
        } else if (strcmp(w, "tightness") == 0) {
            vbnl_sdl_next(p);
            rr = flt(L, &l->tightness);
        } else if (strcmp(w, "fade_distance") == 0) {
            vbnl_sdl_next(p);
            rr = flt(L, &l->fade_distance);
        } else if (strcmp(w, "fade_power") == 0) {
            vbnl_sdl_next(p);
            rr = flt(L, &l->fade_power);
        } else if (strcmp(w, "area_light") == 0) {
            double n1, n2;
            vbnl_sdl_next(p);
            if (vec3(L, l->axis1) != VBNL_OK)
                return VBNL_ERR_PARSE;
            comma(L);
            if (vec3(L, l->axis2) != VBNL_OK)
                return VBNL_ERR_PARSE;
            comma(L);
            if (flt(L, &n1) != VBNL_OK)
                return VBNL_ERR_PARSE;
            comma(L);
            rr = flt(L, &n2);
            l->area = 1;
        } else if (strcmp(w, "adaptive") == 0 || strcmp(w, "area_illumination") == 0 ||
                   strcmp(w, "media_interaction") == 0 || strcmp(w, "media_attenuation") == 0 ||
                   strcmp(w, "jitter") == 0 || strcmp(w, "circular") == 0 || strcmp(w, "orient") == 0) {
            vbnl_sdl_next(p);
            rr = strcmp(w, "adaptive") == 0 ? flt(L, &b) : opt_bool(L, &b);
        } else if (strcmp(w, "shadowless") == 0) {
            vbnl_sdl_next(p);
            if (!L->warned_shadowless++)
                vbnl_sdl_warning(p, &tl, "shadowless is ignored: the light casts shadows");
        } else if (strcmp(w, "looks_like") == 0 || strcmp(w, "projected_through") == 0) {
            vbnl_sdl_next(p);
            if (strcmp(w, "looks_like") == 0)
                vbnl_sdl_warning(p, &tl, "looks_like: the object is not rendered (it would enclose the point light and block it)");
            else
                vbnl_sdl_warning(p, &tl, "projected_through is ignored");
            rr = vbnl_sdl_skip_block(p);
        } else if (strcmp(w, "photons") == 0) {
            vbnl_sdl_next(p);
            rr = vbnl_sdl_skip_block(p);
        } else if (strcmp(w, "color") == 0 || strcmp(w, "colour") == 0 || strcmp(w, "rgb") == 0) {
            rr = vbnl_sdl_parse_color(p, col);
            v3(l->color, col[0], col[1], col[2]);
        } else {
            return unexpected(L, "light_source");
        }
        if (rr != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
}

/* ---- camera ---------------------------------------------------------------------------------- */

static void cam_default(pov_cam *c)
{
    memset(c, 0, sizeof *c);
    v3(c->dir, 0, 0, 1);
    v3(c->up, 0, 1, 0);
    v3(c->right, 1.33, 0, 0);
    v3(c->sky, 0, 1, 0);
    pov_m4_identity(c->m);
}

static vbnl_result parse_camera_body(loader *L, pov_cam *c)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'camera'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const pov_cam *d = declared(L, vbnl_sdl_peek(p), &camera_type);
    if (d) {
        vbnl_sdl_next(p);
        *c = *d;
    }
    static const char *const other_types[] = {"orthographic", "fisheye", "ultra_wide_angle", "omnimax",
                                              "panoramic", "spherical", "cylinder", "mesh_camera", NULL};
    static const char *const ignored_floats[] = {"aperture", "confidence", "variance", NULL};
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        vbnl_sdl_loc tl = t->loc;
        if (is_punct(t, '}')) {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        double m[16], v[3], f;
        int r = parse_transform_item(L, m);
        if (r < 0)
            return VBNL_ERR_PARSE;
        if (r > 0) {
            pov_m4_mul(m, c->m, c->m);
            continue;
        }
        if (t->kind != VBNL_SDL_TOK_IDENT)
            return unexpected(L, "camera");
        char w[32];
        snprintf(w, sizeof w, "%s", t->text);
        vbnl_result rr = VBNL_OK;
        if (strcmp(w, "perspective") == 0) {
            vbnl_sdl_next(p);
        } else if (in_list(w, other_types)) {
            vbnl_sdl_next(p);
            vbnl_sdl_warning(p, &tl, "camera type '%s' is not supported; rendering with a perspective camera", w);
            c->other_type = 1;
            if (strcmp(w, "cylinder") == 0)
                rr = flt(L, &f);
            else if (strcmp(w, "mesh_camera") == 0)
                rr = vbnl_sdl_skip_block(p);
        } else if (strcmp(w, "location") == 0) {
            vbnl_sdl_next(p);
            rr = vec3(L, c->loc);
        } else if (strcmp(w, "look_at") == 0) {
            vbnl_sdl_next(p);
            rr = vec3(L, c->look_at);
            c->have_look_at = 1;
        } else if (strcmp(w, "right") == 0) {
            vbnl_sdl_next(p);
            rr = vec3(L, c->right);
        } else if (strcmp(w, "up") == 0) {
            vbnl_sdl_next(p);
            rr = vec3(L, c->up);
        } else if (strcmp(w, "direction") == 0) {
            vbnl_sdl_next(p);
            rr = vec3(L, c->dir);
        } else if (strcmp(w, "sky") == 0) {
            vbnl_sdl_next(p);
            rr = vec3(L, c->sky);
        } else if (strcmp(w, "angle") == 0) {
            vbnl_sdl_next(p);
            if ((rr = flt(L, &c->angle)) == VBNL_OK) {
                c->have_angle = 1;
                if (c->other_type && c->angle >= 170 && c->angle < 360.0001) {
                    vbnl_sdl_warning(p, &tl, "camera angle %g does not fit a perspective camera; using 170", c->angle);
                    c->angle = 170;
                }
                if (!(c->angle > 0 && c->angle < 180))
                    return vbnl_sdl_error(p, &tl, "camera angle must lie in (0, 180) degrees, got %g", c->angle);
                const vbnl_sdl_token *n = vbnl_sdl_peek(p);
                if (n->kind == VBNL_SDL_TOK_NUMBER) /* optional vertical angle: ignored, as in perspective */
                    rr = flt(L, &f);
            }
        } else if (strcmp(w, "focal_point") == 0) {
            vbnl_sdl_next(p);
            rr = vec3(L, v);
        } else if (in_list(w, ignored_floats)) {
            vbnl_sdl_next(p);
            rr = flt(L, &f);
            if (rr == VBNL_OK && strcmp(w, "aperture") == 0 && f > 0)
                vbnl_sdl_warning(p, &tl, "focal blur (aperture) is not supported; the camera is a pinhole");
        } else if (strcmp(w, "blur_samples") == 0) {
            vbnl_sdl_next(p);
            rr = flt(L, &f);
            if (rr == VBNL_OK && vbnl_sdl_accept(p, ','))
                rr = flt(L, &f);
        } else if (strcmp(w, "normal") == 0) {
            vbnl_sdl_next(p);
            vbnl_sdl_warning(p, &tl, "camera normal perturbation is ignored");
            rr = vbnl_sdl_skip_block(p);
        } else {
            return unexpected(L, "camera");
        }
        if (rr != VBNL_OK)
            return VBNL_ERR_PARSE;
        (void)v;
    }
}

/* POV-Ray 3.7's camera set-up (angle, then look_at, then transforms) onto the core camera. */
static vbnl_result cam_resolve(loader *L, const pov_cam *c, vbnl_sdl_loc loc, vbnl_camera_desc *out)
{
    double loc_[3], dir[3], right[3], up[3];
    memcpy(loc_, c->loc, sizeof loc_);
    memcpy(dir, c->dir, sizeof dir);
    memcpy(right, c->right, sizeof right);
    memcpy(up, c->up, sizeof up);
    if (c->have_angle) {
        double dl = len3(dir);
        if (!(dl > 0))
            return vbnl_sdl_error(L->c.parser, &loc, "camera direction must not be zero");
        scale3(dir, 0.5 * len3(right) / tan(c->angle * PI / 360.0) / dl);
    }
    if (c->have_look_at) {
        double dlen = len3(dir), ulen = len3(up), rlen = len3(right), tmp[3];
        cross3(up, dir, tmp);
        double handed = dot3(tmp, right);
        for (int i = 0; i < 3; ++i)
            dir[i] = c->look_at[i] - loc_[i];
        double l = len3(dir);
        if (!(l > 0))
            return vbnl_sdl_error(L->c.parser, &loc, "camera look_at equals location");
        scale3(dir, 1 / l);
        double saved[3];
        memcpy(saved, right, sizeof saved);
        cross3(c->sky, dir, right);
        if (len3(right) < 1e-10)
            memcpy(right, saved, sizeof right);
        l = len3(right);
        if (l > 0)
            scale3(right, 1 / l);
        cross3(dir, right, up);
        scale3(dir, dlen);
        scale3(right, handed > 0 ? rlen : -rlen);
        scale3(up, ulen);
    }
    pov_m4_point(c->m, loc_, loc_);
    pov_m4_dir(c->m, dir, dir);
    pov_m4_dir(c->m, right, right);
    pov_m4_dir(c->m, up, up);
    if (!(len3(dir) > 0) || !(len3(right) > 0) || !(len3(up) > 0))
        return vbnl_sdl_error(L->c.parser, &loc, "camera direction, right and up must not be zero");
    for (int i = 0; i < 3; ++i) {
        out->position[i] = (float)loc_[i];
        out->forward[i] = (float)dir[i];
        out->right[i] = (float)right[i];
        out->up[i] = (float)up[i];
    }
    return VBNL_OK;
}

/* ---- global_settings ------------------------------------------------------------------------- */

static vbnl_result parse_integrator(loader *L)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'integrator'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_loc nl = vbnl_sdl_peek(p)->loc;
    if (vbnl_sdl_peek(p)->kind != VBNL_SDL_TOK_STRING)
        return vbnl_sdl_error(p, &nl, "integrator block must start with the integrator's name as a string, e.g. \"vbnl\"");
    char *name = NULL;
    if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_integrator_class *cls = vbnl_integrator_find(name);
    if (!cls) {
        char list[512] = "";
        for (uint32_t i = 0; i < vbnl_integrator_count(); ++i) {
            size_t len = strlen(list);
            snprintf(list + len, sizeof list - len, "%s%s", i ? ", " : "", vbnl_integrator_at(i)->name);
        }
        vbnl_result r = vbnl_sdl_error(p, &nl, "unknown integrator '%s' (registered: %s)", name, list);
        free(name);
        return r;
    }
    snprintf(L->integrator, sizeof L->integrator, "%s", name);
    free(name);
    vbnl_params_destroy(L->params);
    L->params = NULL;
    vbnl_error e = {0};
    if (vbnl_params_create(&L->params, &e) != VBNL_OK)
        return oom(L);
    char owner[96];
    snprintf(owner, sizeof owner, "integrator '%s'", cls->name);
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (is_punct(t, '}')) {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        if (t->kind != VBNL_SDL_TOK_IDENT)
            return unexpected(L, "integrator");
        vbnl_sdl_token key = *vbnl_sdl_next(p);
        char kname[128];
        snprintf(kname, sizeof kname, "%s", key.text);
        vbnl_sdl_value v;
        if (vbnl_sdl_parse_expression(p, &v) != VBNL_OK)
            return VBNL_ERR_PARSE;
        char where[512];
        snprintf(where, sizeof where, "%s:%d:%d", key.loc.file ? key.loc.file : "", key.loc.line, key.loc.col);
        vbnl_params *one = NULL;
        vbnl_result r = vbnl_params_create(&one, &e);
        if (r == VBNL_OK) {
            if (v.kind == VBNL_SDL_STRING)
                r = vbnl_params_set_string(one, kname, v.u.str.s, NULL, &e);
            else if (v.kind == VBNL_SDL_FLOAT)
                r = vbnl_params_set_number(one, kname, v.v[0], NULL, &e);
            else
                r = vbnl_error_set(&e, VBNL_ERR_INVALID_ARGUMENT,
                                   "parameter '%s' of %s takes a number or a string, got a %s", kname,
                                   owner, vbnl_sdl_kind_name(v.kind));
        }
        if (r == VBNL_OK)
            r = vbnl_params_validate(one, cls->params, cls->param_count, owner, &e);
        if (r == VBNL_OK)
            r = v.kind == VBNL_SDL_STRING ? vbnl_params_set_string(L->params, kname, v.u.str.s, where, &e)
                                          : vbnl_params_set_number(L->params, kname, v.v[0], where, &e);
        vbnl_params_destroy(one);
        vbnl_sdl_value_clear(p, &v);
        if (r != VBNL_OK)
            return vbnl_sdl_error(p, &key.loc, "%s", e.message);
    }
}

static vbnl_result parse_global_settings(loader *L)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'global_settings'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    static const char *const floats[] = {"assumed_gamma", "max_trace_level", "adc_bailout",
                                         "number_of_waves", "noise_generator", "max_intersections",
                                         "mm_per_unit", NULL};
    static const char *const colors[] = {"ambient_light", "irid_wavelength", NULL};
    static const char *const blocks[] = {"photons", "subsurface", NULL};
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        vbnl_sdl_loc tl = t->loc;
        if (is_punct(t, '}')) {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        if (t->kind != VBNL_SDL_TOK_IDENT)
            return unexpected(L, "global_settings");
        char w[32];
        snprintf(w, sizeof w, "%s", t->text);
        double f, col[5];
        vbnl_result r = VBNL_OK;
        vbnl_sdl_next(p);
        if (strcmp(w, "integrator") == 0) {
            r = parse_integrator(L);
        } else if (strcmp(w, "radiosity") == 0) {
            sdl_diag_emit(p, VBNL_SDL_NOTE, &tl,
                          "radiosity: global illumination is always on in vbnl; the block's settings are ignored");
            r = vbnl_sdl_skip_block(p);
        } else if (in_list(w, blocks)) {
            r = vbnl_sdl_skip_block(p);
        } else if (in_list(w, floats)) {
            r = flt(L, &f);
        } else if (in_list(w, colors)) {
            r = vbnl_sdl_parse_color(p, col);
        } else if (strcmp(w, "charset") == 0) {
            vbnl_sdl_next(p);
        } else if (strcmp(w, "hf_gray_16") == 0) {
            r = opt_bool(L, &f);
        } else {
            return vbnl_sdl_error(p, &tl, "unknown global_settings item '%s'", w);
        }
        if (r != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
}

/* ---- hooks ----------------------------------------------------------------------------------- */

/* Once per skipped shape (a declared one may be placed many times). */
/* sky_sphere { pigment { ... } [emission c] [transforms] } (after the keyword): a constant
 * environment of the pigment's average colour, which lights the scene as the sky does in
 * POV-Ray with radiosity and is what rays that leave the scene see (replaces `background`). */
static vbnl_result parse_sky_sphere(loader *L, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'sky_sphere'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_appearance *app = NULL;
    double emission[3] = {1, 1, 1}, m[16];
    vbnl_result r = VBNL_OK;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (is_punct(t, '}')) {
            vbnl_sdl_next(p);
            break;
        }
        if (is_word(t, "pigment")) {
            if ((r = pov_appearance_parse_modifier(&L->c, &app)) != VBNL_OK)
                break;
            continue;
        }
        if (is_word(t, "emission")) {
            double col[5];
            vbnl_sdl_next(p);
            if ((r = vbnl_sdl_parse_color(p, col)) != VBNL_OK)
                break;
            v3(emission, col[0], col[1], col[2]);
            continue;
        }
        int tr = parse_transform_item(L, m); /* a constant sky does not turn */
        if (tr < 0) {
            r = VBNL_ERR_PARSE;
            break;
        }
        if (tr == 0) { /* a declared sky_sphere, pigment_map, ...: the sky is left out, as before */
            char what[64];
            snprintf(what, sizeof what, "%s", t->text ? t->text : "?");
            vbnl_sdl_loc wl = t->loc;
            for (int depth = 1; depth > 0;) {
                const vbnl_sdl_token *n = vbnl_sdl_next(p);
                if (n->kind == VBNL_SDL_TOK_EOF) {
                    pov_appearance_free(app);
                    return vbnl_sdl_failed(p) ? VBNL_ERR_PARSE : vbnl_sdl_error(p, loc, "missing '}' at the end of 'sky_sphere'");
                }
                depth += is_punct(n, '{') - is_punct(n, '}');
            }
            vbnl_sdl_warning(p, &wl, "'%s' in sky_sphere is not supported; the sky_sphere is skipped", what);
            pov_appearance_free(app);
            return VBNL_OK;
        }
    }
    if (r == VBNL_OK) {
        double rgb[3] = {0, 0, 0};
        if (app)
            pov_appearance_average_color(&L->c, app, rgb);
        for (int k = 0; k < 3; ++k)
            L->env[k] = fmax(rgb[k] * emission[k], 0);
        L->have_env = 1;
        vbnl_sdl_warning(p, loc, "sky_sphere is rendered as a constant sky of its pigment's average colour (%.3g %.3g %.3g)",
                         L->env[0], L->env[1], L->env[2]);
    }
    pov_appearance_free(app);
    return r;
}

static void warn_skipped(loader *L, const pov_prim *pr)
{
    for (size_t i = 0; i < L->nwarned; ++i)
        if (L->warned[i].file == pr->loc.file && L->warned[i].line == pr->loc.line && L->warned[i].col == pr->loc.col)
            return;
    vbnl_sdl_loc *n = realloc(L->warned, (L->nwarned + 1) * sizeof *n);
    if (n) {
        L->warned = n;
        L->warned[L->nwarned++] = pr->loc;
    }
    vbnl_sdl_warning(L->c.parser, &pr->loc, "'%s' is not supported; the object is skipped", pr->path);
}

static int hook_statement(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, void *user)
{
    loader *L = user;
    const char *w = tok->text;
    vbnl_sdl_loc loc = tok->loc;
    if (is_shape(tok)) {
        pov_obj o = {0};
        vbnl_result r = parse_object(L, &o);
        if (r == VBNL_OK && !obj_finish(&o))
            r = oom(L);
        for (size_t i = 0; r == VBNL_OK && i < o.n; ++i)
            if (o.v[i].kind != POV_PRIM_LIGHT && o.v[i].kind != POV_PRIM_IMPORT && o.v[i].kind != POV_PRIM_SKIPPED && !o.v[i].app &&
                !(o.v[i].app = pov_appearance_default(&L->c)))
                r = oom(L);
        for (size_t i = 0; r == VBNL_OK && i < o.n; ++i)
            if (o.v[i].kind == POV_PRIM_SKIPPED)
                warn_skipped(L, &o.v[i]);
        if (r == VBNL_OK && !obj_move(&L->world, &o))
            r = oom(L);
        obj_clear(&o);
        return r == VBNL_OK ? 1 : -1;
    }
    if (strcmp(w, "camera") == 0) {
        vbnl_sdl_next(p);
        pov_cam c;
        cam_default(&c);
        if (parse_camera_body(L, &c) != VBNL_OK)
            return -1;
        vbnl_camera_desc cd;
        if (cam_resolve(L, &c, loc, &cd) != VBNL_OK)
            return -1;
        L->cam = c;
        L->have_camera = 1;
        return 1;
    }
    if (strcmp(w, "global_settings") == 0) {
        vbnl_sdl_next(p);
        return parse_global_settings(L) == VBNL_OK ? 1 : -1;
    }
    if (strcmp(w, "background") == 0) {
        double col[5];
        vbnl_sdl_next(p);
        if (vbnl_sdl_expect(p, '{', "after 'background'") != VBNL_OK || vbnl_sdl_parse_color(p, col) != VBNL_OK ||
            vbnl_sdl_expect(p, '}', "after the background colour") != VBNL_OK)
            return -1;
        v3(L->env, fmax(col[0], 0), fmax(col[1], 0), fmax(col[2], 0));
        L->have_env = 1;
        return 1;
    }
    if (strcmp(w, "sky_sphere") == 0) {
        vbnl_sdl_next(p);
        return parse_sky_sphere(L, &loc) == VBNL_OK ? 1 : -1;
    }
    static const char *const skipped[] = {"fog", "rainbow", "media", "atmosphere", NULL};
    if (in_list(w, skipped)) {
        vbnl_sdl_next(p);
        vbnl_sdl_warning(p, &loc, "'%s' is not supported; skipped", w);
        return vbnl_sdl_skip_block(p) == VBNL_OK ? 1 : -1;
    }
    if (!tok->keyword && !vbnl_sdl_lookup(p, w)) {
        char name[64];
        snprintf(name, sizeof name, "%s", w);
        vbnl_sdl_next(p);
        if (is_punct(vbnl_sdl_peek(p), '{')) {
            vbnl_sdl_warning(p, &loc, "unknown statement '%s'; its block is skipped", name);
            return vbnl_sdl_skip_block(p) == VBNL_OK ? 1 : -1;
        }
        vbnl_sdl_error(p, &loc, "undeclared identifier '%s'", name);
        return -1;
    }
    return 0;
}

static int hook_rvalue(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_value *out, void *user)
{
    loader *L = user;
    if (is_shape(tok)) {
        pov_obj *o = calloc(1, sizeof *o);
        if (!o) {
            oom(L);
            return -1;
        }
        if (parse_object(L, o) != VBNL_OK || !obj_finish(o)) {
            if (!vbnl_sdl_failed(p))
                oom(L);
            objv_destroy(o, NULL);
            return -1;
        }
        vbnl_sdl_value_object(out, o, &object_type, 0);
        return 1;
    }
    if (is_word(tok, "transform")) {
        double *m = malloc(16 * sizeof *m);
        if (!m) {
            oom(L);
            return -1;
        }
        vbnl_sdl_next(p);
        const double *d = declared(L, vbnl_sdl_peek(p), &transform_type);
        if (d) {
            vbnl_sdl_next(p);
            memcpy(m, d, 16 * sizeof *m);
        } else if (parse_transform_block(L, m) != VBNL_OK) {
            free(m);
            return -1;
        }
        vbnl_sdl_value_object(out, m, &transform_type, 0);
        return 1;
    }
    if (is_word(tok, "camera")) {
        pov_cam *c = malloc(sizeof *c);
        if (!c) {
            oom(L);
            return -1;
        }
        cam_default(c);
        vbnl_sdl_next(p);
        if (parse_camera_body(L, c) != VBNL_OK) {
            free(c);
            return -1;
        }
        vbnl_sdl_value_object(out, c, &camera_type, 0);
        return 1;
    }
    return pov_appearance_rvalue(&L->c, tok, out);
}

static int hook_default(vbnl_sdl_parser *p, void *user)
{
    (void)p;
    return pov_appearance_default_block(&((loader *)user)->c);
}

static void on_diag(const vbnl_sdl_diag *d, void *user)
{
    loader *L = user;
    if (d->severity != VBNL_SDL_ERROR) {
        char **n = realloc(L->diags, (L->ndiags + 1) * sizeof *n);
        if (n) {
            L->diags = n;
            if ((n[L->ndiags] = strdup(d->text)))
                L->ndiags++;
        }
    }
    if (L->user_diag)
        L->user_diag(d, L->user_diag_user);
}

/* ---- building the core scene ----------------------------------------------------------------- */

static void bounds_add(double lo[3], double hi[3], const double p[3])
{
    for (int i = 0; i < 3; ++i) {
        lo[i] = fmin(lo[i], p[i]);
        hi[i] = fmax(hi[i], p[i]);
    }
}

static void m4f(const double m[16], float out[16])
{
    for (int i = 0; i < 16; ++i)
        out[i] = (float)m[i];
}

static vbnl_result emit_mesh(loader *L, const pov_prim *pr, const pov_mesh *m, vbnl_error *err)
{
    if (m->nt == 0)
        return VBNL_OK;
    const double *q = pr->m;
    double det = q[0] * (q[5] * q[10] - q[6] * q[9]) - q[1] * (q[4] * q[10] - q[6] * q[8]) +
                 q[2] * (q[4] * q[9] - q[5] * q[8]);
    if (!(fabs(det) > 1e-12)) { /* e.g. `scale <1e-16, 1, 1>` from a loop: nothing to see */
        vbnl_sdl_warning(L->c.parser, &pr->loc, "the object is scaled flat (singular transform): skipped");
        return VBNL_OK;
    }
    static const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    uint32_t mat;
    vbnl_result r = pov_appearance_material(&L->c, pr->app, ident, &mat, err);
    if (r != VBNL_OK)
        return r;
    uint32_t *fm = NULL;
    if (m->ftex) {
        uint32_t *tm = calloc(m->ntex + 1, sizeof *tm);
        fm = malloc(sizeof *fm * m->nt);
        if (!tm || !fm) {
            free(tm);
            free(fm);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        for (uint32_t i = 0; i < m->ntex && r == VBNL_OK; ++i) {
            pov_appearance *a = pov_appearance_copy(m->texs[i]);
            if (!a) {
                r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
                break;
            }
            pov_appearance_transform(a, pr->m);
            r = pov_appearance_material(&L->c, a, ident, &tm[i], err);
            pov_appearance_free(a);
        }
        for (uint32_t t = 0; t < m->nt; ++t)
            fm[t] = m->ftex[t] >= 0 ? tm[m->ftex[t]] : mat;
        free(tm);
    }
    float xf[16];
    m4f(pr->m, xf);
    vbnl_mesh_desc d;
    memset(&d, 0, sizeof d);
    d.positions = m->pos;
    d.normals = m->nrm;
    d.uvs = m->uv;
    d.vertex_count = m->nv;
    d.indices = m->idx;
    d.triangle_count = m->nt;
    d.material = mat;
    d.face_materials = fm;
    d.transform = xf;
    d.group = VBNL_GROUP_WORLD;
    if (r == VBNL_OK)
        r = vbnl_scene_add_mesh(L->c.scene, &d, NULL, err);
    free(fm);
    return r;
}

static vbnl_result emit_light(loader *L, const pov_prim *pr, vbnl_error *err)
{
    const pov_light *l = &pr->light;
    double pos[3], at[3], a1[3], a2[3];
    pov_m4_point(pr->m, l->pos, pos);
    pov_m4_point(pr->m, l->point_at, at);
    pov_m4_dir(pr->m, l->axis1, a1);
    pov_m4_dir(pr->m, l->axis2, a2);
    /* An unfaded POV-Ray light gives the same irradiance at any distance. Radiant intensity
     * I = colour D^2 (W/sr) matches it at distance D, the distance from the light to the centre
     * of the scene's geometry (at least 1): a distant "sun" lights the scene as in POV-Ray. With
     * fade_power 2, POV-Ray's 2/(1 + (d/D)^2) tends to 2 D^2 / d^2: I = 2 D^2 colour. */
    double s = 1;
    if (L->have_geo && !(l->fade_distance > 0 && l->fade_power > 0)) {
        double d[3] = {pos[0] - L->geo_centre[0], pos[1] - L->geo_centre[1], pos[2] - L->geo_centre[2]};
        double D = fmax(1.0, len3(d));
        s = D * D;
    }
    if (l->fade_distance > 0 && l->fade_power > 0) {
        if (fabs(l->fade_power - 2) < 1e-9) {
            s = 2 * l->fade_distance * l->fade_distance;
        } else {
            s = l->fade_distance * l->fade_distance;
            if (!L->warned_fade++) {
                char msg[256];
                snprintf(msg, sizeof msg, "fade_power %g: light falls off as 1/d^2; its intensity matches POV-Ray's at fade_distance", l->fade_power);
                sdl_diag_emit(L->c.parser, VBNL_SDL_WARNING, &pr->loc, msg);
            }
        }
    }
    float I[3];
    for (int i = 0; i < 3; ++i)
        I[i] = (float)(fmax(l->color[i], 0) * s);
    double dir[3] = {at[0] - pos[0], at[1] - pos[1], at[2] - pos[2]};
    if (l->type == POV_LIGHT_PARALLEL) {
        if (!(len3(dir) > 0))
            return vbnl_error_set(err, VBNL_ERR_PARSE, "%s:%d:%d: parallel light: point_at equals the location",
                                  pr->loc.file, pr->loc.line, pr->loc.col);
        float d[3] = {(float)dir[0], (float)dir[1], (float)dir[2]};
        float E[3] = {(float)fmax(l->color[0], 0), (float)fmax(l->color[1], 0), (float)fmax(l->color[2], 0)};
        return vbnl_scene_add_directional_light(L->c.scene, d, E, NULL, err);
    }
    float P[3] = {(float)pos[0], (float)pos[1], (float)pos[2]};
    if (l->type == POV_LIGHT_SPOT) {
        if (!(len3(dir) > 0))
            return vbnl_error_set(err, VBNL_ERR_PARSE, "%s:%d:%d: spotlight: point_at equals the location",
                                  pr->loc.file, pr->loc.line, pr->loc.col);
        vbnl_spot_light_desc sd;
        memcpy(sd.position, P, sizeof P);
        for (int i = 0; i < 3; ++i)
            sd.direction[i] = (float)dir[i];
        memcpy(sd.intensity, I, sizeof I);
        double rad = fmin(fmax(l->radius, 0), 180), fall = fmin(fmax(l->falloff, rad), 180);
        sd.cos_inner = (float)cos(rad * PI / 180);
        sd.cos_outer = (float)cos(fall * PI / 180);
        sd.exponent = (float)fmax(l->tightness, 0);
        return vbnl_scene_add_spot_light(L->c.scene, &sd, NULL, err);
    }
    double n[3];
    cross3(a1, a2, n);
    double area = len3(n);
    if (l->area && area > 0) {
        /* Two-sided Lambertian rectangle with the point light's power 4 pi I = 2 pi A L. */
        vbnl_area_light_desc ad;
        for (int i = 0; i < 3; ++i) {
            ad.corner[i] = (float)(pos[i] - 0.5 * a1[i] - 0.5 * a2[i]);
            ad.edge_u[i] = (float)a1[i];
            ad.edge_v[i] = (float)a2[i];
            ad.radiance[i] = (float)(2.0 * I[i] / area);
        }
        ad.two_sided = 1;
        return vbnl_scene_add_area_light(L->c.scene, &ad, NULL, err);
    }
    return vbnl_scene_add_point_light(L->c.scene, P, I, NULL, err);
}

static vbnl_result build(loader *L, vbnl_error *err)
{
    vbnl_result r = VBNL_OK;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    vbnl_camera_desc cd;
    pov_cam dc;
    if (!L->have_camera) {
        cam_default(&dc);
        L->cam = dc;
    }
    vbnl_sdl_loc nowhere = {"", 0, 0};
    if ((r = cam_resolve(L, &L->cam, nowhere, &cd)) != VBNL_OK)
        return vbnl_error_set(err, r, "camera: invalid vectors");
    double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < L->world.n; ++i) { /* the geometry alone (unfaded lights) */
        const pov_prim *pr = &L->world.v[i];
        double q[3];
        if (pr->kind == POV_PRIM_SPHERE) {
            pov_m4_point(pr->m, pr->a, q);
            bounds_add(glo, ghi, q);
        } else if (pr->kind == POV_PRIM_MESH) {
            for (uint32_t v = 0; v < pr->mesh->nv; ++v) {
                double pp[3] = {pr->mesh->pos[3 * v], pr->mesh->pos[3 * v + 1], pr->mesh->pos[3 * v + 2]};
                pov_m4_point(pr->m, pp, q);
                bounds_add(glo, ghi, q);
            }
        } else if (pr->kind == POV_PRIM_PLANE) { /* its point nearest the origin */
            double nl2 = dot3(pr->a, pr->a), p0[3];
            for (int k = 0; k < 3; ++k)
                p0[k] = pr->a[k] * pr->a[3] / nl2;
            pov_m4_point(pr->m, p0, q);
            bounds_add(glo, ghi, q);
        }
    }
    L->have_geo = glo[0] <= ghi[0];
    for (int k = 0; k < 3; ++k)
        L->geo_centre[k] = L->have_geo ? 0.5 * (glo[k] + ghi[k]) : 0.0;
    double cp[3] = {cd.position[0], cd.position[1], cd.position[2]};
    bounds_add(lo, hi, cp);
    for (size_t i = 0; i < L->world.n; ++i) {
        const pov_prim *pr = &L->world.v[i];
        double q[3];
        if (pr->kind == POV_PRIM_SPHERE) {
            double s = 0;
            for (int k = 0; k < 3; ++k)
                s = fmax(s, len3((double[3]){pr->m[k], pr->m[4 + k], pr->m[8 + k]}));
            pov_m4_point(pr->m, pr->a, q);
            for (int k = 0; k < 3; ++k) {
                double e[3] = {q[0], q[1], q[2]};
                e[k] += pr->a[3] * s;
                bounds_add(lo, hi, e);
                e[k] -= 2 * pr->a[3] * s;
                bounds_add(lo, hi, e);
            }
        } else if (pr->kind == POV_PRIM_MESH) {
            for (uint32_t v = 0; v < pr->mesh->nv; ++v) {
                double pp[3] = {pr->mesh->pos[3 * v], pr->mesh->pos[3 * v + 1], pr->mesh->pos[3 * v + 2]};
                pov_m4_point(pr->m, pp, q);
                bounds_add(lo, hi, q);
            }
        } else if (pr->kind == POV_PRIM_LIGHT && pr->light.type != POV_LIGHT_PARALLEL) {
            pov_m4_point(pr->m, pr->light.pos, q);
            bounds_add(lo, hi, q);
        }
    }
    double centre[3], radius = 0;
    for (int k = 0; k < 3; ++k) {
        centre[k] = 0.5 * (lo[k] + hi[k]);
        radius = fmax(radius, 0.5 * (hi[k] - lo[k]));
    }
    radius = fmax(radius * sqrt(3.0), 1.0);
    static const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    for (size_t i = 0; i < L->world.n && r == VBNL_OK; ++i) {
        pov_prim *pr = &L->world.v[i];
        double s;
        switch (pr->kind) {
        case POV_PRIM_SPHERE:
            if (pov_m4_is_similarity(pr->m, &s)) {
                uint32_t mat;
                double c[3];
                pov_m4_point(pr->m, pr->a, c);
                float cf[3] = {(float)c[0], (float)c[1], (float)c[2]};
                if ((r = pov_appearance_material(&L->c, pr->app, ident, &mat, err)) == VBNL_OK)
                    r = vbnl_scene_add_sphere(L->c.scene, cf, (float)(pr->a[3] * s), mat, VBNL_GROUP_WORLD, NULL, err);
            } else if (!pov_appearance_is_emissive(pr->app)) {
                /* An ellipsoid: an instance of an analytic unit sphere (exact surface and normals). */
                uint32_t mat;
                if ((r = pov_appearance_material(&L->c, pr->app, ident, &mat, err)) != VBNL_OK)
                    break;
                if (mat >= L->nsphere_groups) {
                    uint32_t *g = realloc(L->sphere_groups, sizeof *g * (mat + 1));
                    if (!g)
                        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
                    memset(g + L->nsphere_groups, 0, sizeof *g * (mat + 1 - L->nsphere_groups));
                    L->sphere_groups = g;
                    L->nsphere_groups = mat + 1;
                }
                if (!L->sphere_groups[mat]) {
                    static const float zero[3] = {0, 0, 0};
                    if ((r = vbnl_scene_add_group(L->c.scene, &L->sphere_groups[mat], err)) != VBNL_OK ||
                        (r = vbnl_scene_add_sphere(L->c.scene, zero, 1.0f, mat, L->sphere_groups[mat], NULL, err)) != VBNL_OK)
                        break;
                }
                double local[16], xf[16];
                pov_m4_scale((double[3]){pr->a[3], pr->a[3], pr->a[3]}, local);
                local[3] = pr->a[0];
                local[7] = pr->a[1];
                local[11] = pr->a[2];
                pov_m4_mul(pr->m, local, xf);
                float xff[16];
                m4f(xf, xff);
                r = vbnl_scene_add_instance(L->c.scene, L->sphere_groups[mat], xff, NULL, err);
            } else { /* emissive: emitters must be world geometry */
                pov_mesh *m = pov_tess_sphere(pr->a, pr->a[3]);
                if (!m)
                    return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
                r = emit_mesh(L, pr, m, err);
                pov_mesh_unref(m);
            }
            break;
        case POV_PRIM_PLANE: {
            /* The patch is built in world space around the scene's centre. */
            double inv[16], n[3], p0[3], pw[3], nw[3];
            if (!pov_m4_invert(pr->m, inv))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "plane: singular transform");
            double nl = len3(pr->a);
            for (int k = 0; k < 3; ++k) {
                n[k] = pr->a[k] / nl;
                p0[k] = n[k] * pr->a[3] / nl;
            }
            pov_m4_point(pr->m, p0, pw);
            for (int k = 0; k < 3; ++k) /* normal: inverse transpose */
                nw[k] = inv[k] * n[0] + inv[4 + k] * n[1] + inv[8 + k] * n[2];
            pov_mesh *m = pov_tess_plane(nw, dot3(nw, pw), centre, POV_PLANE_EXTENT * radius);
            if (!m)
                return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
            pov_prim tmp = *pr;
            memcpy(tmp.m, ident, sizeof ident);
            r = emit_mesh(L, &tmp, m, err);
            pov_mesh_unref(m);
            break;
        }
        case POV_PRIM_MESH:
            r = emit_mesh(L, pr, pr->mesh, err);
            break;
        case POV_PRIM_LIGHT:
            r = emit_light(L, pr, err);
            break;
        case POV_PRIM_SKIPPED:
            break;
        case POV_PRIM_IMPORT: {
            float xf[16];
            m4f(pr->m, xf);
            vbnl_mesh_import_options o;
            memset(&o, 0, sizeof o);
            o.transform = xf;
            o.group = VBNL_GROUP_WORLD;
            o.two_sided_emission = 1; /* as POV-Ray's emission */
            if (pr->app) { /* the scene gave an appearance: it overrides the file's materials */
                o.override_material = 1;
                if ((r = pov_appearance_material(&L->c, pr->app, ident, &o.material, err)) != VBNL_OK)
                    break;
            }
            r = vbnl_mesh_import(L->c.scene, pr->path, &o, NULL, err);
            break;
        }
        }
    }
    if (r != VBNL_OK)
        return r;
    if ((r = vbnl_scene_set_camera(L->c.scene, &cd, err)) != VBNL_OK)
        return r;
    if (L->have_env && (L->env[0] > 0 || L->env[1] > 0 || L->env[2] > 0)) {
        float e[3] = {(float)L->env[0], (float)L->env[1], (float)L->env[2]};
        if ((r = vbnl_scene_set_environment(L->c.scene, e, err)) != VBNL_OK)
            return r;
    }
    return VBNL_OK;
}

/* ---- public API ------------------------------------------------------------------------------ */

void vbnl_pov_options_init(vbnl_pov_options *o)
{
    memset(o, 0, sizeof(*o));
    o->width = 640;
    o->height = 480;
}

static vbnl_result load(vbnl_context *ctx, const char *name, const char *text, size_t len,
                        const vbnl_pov_options *opt_in, vbnl_pov_scene **out, vbnl_error *err)
{
    if (out)
        *out = NULL;
    if (!ctx || !name || !out || (text == NULL && len))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_pov_load: NULL argument");
    vbnl_pov_options def;
    vbnl_pov_options_init(&def);
    const vbnl_pov_options *opt = opt_in ? opt_in : &def;
    loader *L = calloc(1, sizeof *L);
    vbnl_pov_scene *s = calloc(1, sizeof *s);
    vbnl_result r = VBNL_OK;
    if (!L || !s) {
        free(L);
        free(s);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    snprintf(L->integrator, sizeof L->integrator, "vbnl");
    L->user_diag = opt->diag;
    L->user_diag_user = opt->diag_user;
    if ((r = vbnl_params_create(&L->params, err)) != VBNL_OK ||
        (r = vbnl_sdl_parser_create(&L->c.parser, err)) != VBNL_OK ||
        (r = vbnl_scene_create(ctx, &L->c.scene, err)) != VBNL_OK ||
        (r = pov_texture_state_create(&L->c, err)) != VBNL_OK)
        goto done;
    vbnl_sdl_parser *p = L->c.parser;
    if (opt->limits && (r = vbnl_sdl_set_limits(p, opt->limits)) != VBNL_OK)
        goto done;
    for (size_t i = 0; i < opt->include_dir_count; ++i)
        if ((r = vbnl_sdl_add_include_dir(p, opt->include_dirs[i])) != VBNL_OK)
            goto done;
    if (opt->system_include_dir && (r = vbnl_sdl_set_system_include_dir(p, opt->system_include_dir)) != VBNL_OK)
        goto done;
    vbnl_sdl_set_image_size(p, opt->width, opt->height);
    vbnl_sdl_set_clock(p, opt->clock, 0, 0, 0, 0, 0);
    if (opt->includes_disabled) {
        vbnl_sdl_set_includes_enabled(p, 0);
        L->files_disabled = 1;
    }
    vbnl_sdl_set_diag_callback(p, on_diag, L);
    vbnl_sdl_hooks h = {L, hook_statement, hook_rvalue, hook_default};
    vbnl_sdl_set_hooks(p, &h);
    r = text ? vbnl_sdl_parse_text(p, name, text, len, err) : vbnl_sdl_parse_file(p, name, err);
    if (r != VBNL_OK)
        goto done;
    if ((r = build(L, err)) != VBNL_OK || (!opt->no_commit && (r = vbnl_scene_commit(L->c.scene, err)) != VBNL_OK)) {
        char msg[VBNL_ERROR_MESSAGE_SIZE];
        snprintf(msg, sizeof msg, "%s", err ? err->message : "");
        vbnl_error_set(err, r, "%s: %s", name, msg);
        goto done;
    }
    s->scene = L->c.scene;
    L->c.scene = NULL;
    snprintf(s->integrator, sizeof s->integrator, "%s", L->integrator);
    s->params = L->params;
    L->params = NULL;
    s->diags = L->diags;
    s->ndiags = L->ndiags;
    L->diags = NULL;
    L->ndiags = 0;
    *out = s;
    s = NULL;
done:
    obj_clear(&L->world);
    free(L->sphere_groups);
    free(L->warned);
    pov_texture_state_destroy(&L->c);
    vbnl_sdl_parser_destroy(L->c.parser);
    vbnl_scene_destroy(L->c.scene);
    vbnl_params_destroy(L->params);
    for (size_t i = 0; i < L->ndiags; ++i)
        free(L->diags[i]);
    free(L->diags);
    free(L);
    free(s);
    return r;
}

vbnl_result vbnl_pov_load_file(vbnl_context *ctx, const char *path, const vbnl_pov_options *opt,
                               vbnl_pov_scene **out, vbnl_error *err)
{
    return load(ctx, path, NULL, 0, opt, out, err);
}

vbnl_result vbnl_pov_load_text(vbnl_context *ctx, const char *name, const char *text, size_t len,
                               const vbnl_pov_options *opt, vbnl_pov_scene **out, vbnl_error *err)
{
    if (!text)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_pov_load_text: text is NULL");
    return load(ctx, name, text, len, opt, out, err);
}

void vbnl_pov_scene_destroy(vbnl_pov_scene *s)
{
    if (!s)
        return;
    vbnl_scene_destroy(s->scene);
    vbnl_params_destroy(s->params);
    for (size_t i = 0; i < s->ndiags; ++i)
        free(s->diags[i]);
    free(s->diags);
    free(s);
}

const vbnl_scene *vbnl_pov_scene_get(const vbnl_pov_scene *s) { return s ? s->scene : NULL; }

vbnl_scene *vbnl_pov_scene_take_scene(vbnl_pov_scene *s)
{
    if (!s)
        return NULL;
    vbnl_scene *sc = s->scene;
    s->scene = NULL;
    return sc;
}

const char *vbnl_pov_scene_integrator(const vbnl_pov_scene *s) { return s ? s->integrator : "vbnl"; }
const vbnl_params *vbnl_pov_scene_params(const vbnl_pov_scene *s) { return s ? s->params : NULL; }
size_t vbnl_pov_scene_diag_count(const vbnl_pov_scene *s) { return s ? s->ndiags : 0; }
const char *vbnl_pov_scene_diag_text(const vbnl_pov_scene *s, size_t i)
{
    return s && i < s->ndiags ? s->diags[i] : NULL;
}
