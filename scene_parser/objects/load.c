/* vbnl object layer: loading a scene (vbnl/pov_scene.h): the language layer's parse with the
 * object layer's hooks, then the core scene built from what was collected. */
#include "vbnl/pov_scene.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_loader.h"
#include "sdl_internal.h"

struct vbnl_pov_scene {
    vbnl_scene *scene;
    char integrator[64];
    vbnl_params *params;
    char **diags;
    size_t ndiags;
};

/* ---- statements ---------------------------------------------------------------------------------- */

/* Once per skipped shape (a declared one may be placed many times). */
static void warn_skipped(pov_loader *L, const pov_prim *pr)
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

/* A shape placed in the scene: its primitives join the world, with the #default appearance where
 * they have none. */
static vbnl_result place_object(pov_loader *L)
{
    pov_obj o = {0};
    vbnl_result r = pov_parse_object(L, &o);
    if (r == VBNL_OK && !pov_obj_finish(&o))
        r = pov_oom(L);
    for (size_t i = 0; r == VBNL_OK && i < o.n; ++i)
        if (o.v[i].kind != POV_PRIM_LIGHT && o.v[i].kind != POV_PRIM_IMPORT && o.v[i].kind != POV_PRIM_SKIPPED && !o.v[i].app &&
            !(o.v[i].app = pov_appearance_default_shared(&L->c)))
            r = pov_oom(L);
    for (size_t i = 0; r == VBNL_OK && i < o.n; ++i)
        if (o.v[i].kind == POV_PRIM_SKIPPED)
            warn_skipped(L, &o.v[i]);
    /* what the placed primitives hold counts against the parser's memory limit, so that a loop
     * of objects ends with an error instead of exhausting the machine */
    size_t bytes = 0;
    for (size_t i = 0; i < o.n; ++i) {
        const pov_mesh *m = o.v[i].mesh;
        /* a mesh shared with a declaration (an instance) holds no new data */
        bytes += sizeof(pov_prim) + (m && m->refs == 1 ? (size_t)m->nv * 32u + (size_t)m->nt * 16u : 0u);
    }
    if (r == VBNL_OK && !sdl_charge(L->c.parser, bytes))
        r = VBNL_ERR_PARSE;
    if (r == VBNL_OK && !pov_obj_move(&L->world, &o))
        r = pov_oom(L);
    pov_obj_clear(&o);
    return r;
}

static vbnl_result st_camera(const pov_item *it)
{
    pov_loader *L = it->ctx;
    pov_cam c;
    vbnl_camera_desc cd;
    vbnl_sdl_next(it->p);
    pov_camera_default(&c);
    if (pov_camera_parse(L, &c) != VBNL_OK || pov_camera_resolve(L, &c, it->loc, &cd) != VBNL_OK) {
        pov_camera_release(&c);
        return VBNL_ERR_PARSE;
    }
    pov_camera_release(&L->cam);
    L->cam = c;
    L->have_camera = 1;
    return VBNL_OK;
}

static vbnl_result st_global_settings(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_global_settings_parse(it->ctx);
}

static vbnl_result st_background(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_background_parse(it->ctx);
}

static vbnl_result st_sky_sphere(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_sky_sphere_parse(it->ctx, &it->loc);
}

static vbnl_result st_fog(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_fog_parse(it->ctx, &it->loc);
}

/* media { } at the top level: atmospheric media, filling the space outside objects */
static vbnl_result st_media(const pov_item *it)
{
    pov_loader *L = it->ctx;
    vbnl_sdl_next(it->p);
    if (L->natmosphere >= VBNL_MEDIUM_PARTS_MAX)
        return vbnl_sdl_error(it->p, &it->loc, "a scene holds at most %u atmospheric media", VBNL_MEDIUM_PARTS_MAX);
    vbnl_result r = pov_media_parse(&L->c, &L->atmosphere[L->natmosphere], NULL);
    if (r == VBNL_OK && L->atmosphere[L->natmosphere].phase)
        L->natmosphere++;
    return r;
}

static vbnl_result st_unsupported(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    vbnl_sdl_warning(it->p, &it->loc, "'%s' is not supported; skipped", it->kw);
    return vbnl_sdl_skip_block(it->p);
}

static const pov_row statement_rows[] = {
    {"camera", st_camera, 0},
    {"global_settings", st_global_settings, 0},
    {"background", st_background, 0},
    {"sky_sphere", st_sky_sphere, 0},
    {"fog", st_fog, 0},
    {"rainbow", st_unsupported, 0},
    {"media", st_media, 0},
    {"atmosphere", st_unsupported, 0},
    {NULL, NULL, 0},
};

static int hook_statement(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, void *user)
{
    pov_loader *L = user;
    if (pov_is_shape(tok))
        return place_object(L) == VBNL_OK ? 1 : -1;
    int r = pov_row_dispatch(statement_rows, p, L, L);
    if (r != 0)
        return r;
    if (!tok->keyword && !vbnl_sdl_lookup(p, tok->text)) {
        const char *name = tok->text; /* interned: stays valid */
        vbnl_sdl_loc loc = tok->loc;
        vbnl_sdl_next(p);
        if (pov_is_punct(vbnl_sdl_peek(p), '{')) {
            vbnl_sdl_warning(p, &loc, "unknown statement '%.63s'; its block is skipped", name);
            return vbnl_sdl_skip_block(p) == VBNL_OK ? 1 : -1;
        }
        vbnl_sdl_error(p, &loc, "undeclared identifier '%.63s'", name);
        return -1;
    }
    return 0;
}

/* ---- values of #declare -------------------------------------------------------------------------- */

static vbnl_result rv_transform(const pov_item *it)
{
    pov_loader *L = it->ctx;
    double *m = malloc(16 * sizeof *m);
    if (!m)
        return pov_oom(L);
    vbnl_sdl_next(it->p);
    const double *d = pov_declared(L, vbnl_sdl_peek(it->p), &pov_transform_type);
    if (d) {
        vbnl_sdl_next(it->p);
        memcpy(m, d, 16 * sizeof *m);
    } else if (pov_transform_block(L, m) != VBNL_OK) {
        free(m);
        return VBNL_ERR_PARSE;
    }
    vbnl_sdl_value_object(it->target, m, &pov_transform_type, 0);
    return VBNL_OK;
}

static vbnl_result rv_camera(const pov_item *it)
{
    pov_cam *c = malloc(sizeof *c);
    if (!c)
        return pov_oom(it->ctx);
    pov_camera_default(c);
    vbnl_sdl_next(it->p);
    if (pov_camera_parse(it->ctx, c) != VBNL_OK) {
        pov_camera_release(c);
        free(c);
        return VBNL_ERR_PARSE;
    }
    vbnl_sdl_value_object(it->target, c, &pov_camera_type, 0);
    return VBNL_OK;
}

static vbnl_result rv_sky_sphere(const pov_item *it)
{
    pov_sky *s;
    vbnl_sdl_next(it->p);
    if (pov_sky_parse(it->ctx, &it->loc, &s) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_value_object(it->target, s, &pov_sky_type, 0);
    return VBNL_OK;
}

static const pov_row rvalue_rows[] = {
    {"transform", rv_transform, 0},
    {"camera", rv_camera, 0},
    {"sky_sphere", rv_sky_sphere, 0},
    {NULL, NULL, 0},
};

static int hook_rvalue(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_value *out, void *user)
{
    pov_loader *L = user;
    if (pov_is_shape(tok)) {
        pov_obj *o = calloc(1, sizeof *o);
        if (!o) {
            pov_oom(L);
            return -1;
        }
        if (pov_parse_object(L, o) != VBNL_OK || !pov_obj_finish(o)) {
            if (!vbnl_sdl_failed(p))
                pov_oom(L);
            pov_object_destroy(o, NULL);
            return -1;
        }
        vbnl_sdl_value_object(out, o, &pov_object_type, 0);
        return 1;
    }
    int r = pov_row_dispatch(rvalue_rows, p, L, out);
    return r ? r : pov_appearance_rvalue(&L->c, tok, out);
}

static int hook_default(vbnl_sdl_parser *p, void *user)
{
    (void)p;
    return pov_appearance_default_block(&((pov_loader *)user)->c);
}

static int hook_function_block(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_fn_block *out, void *user)
{
    (void)p;
    return pov_function_block(&((pov_loader *)user)->c, tok, out);
}

static void on_diag(const vbnl_sdl_diag *d, void *user)
{
    pov_loader *L = user;
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
    pov_loader *L = calloc(1, sizeof *L);
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
    vbnl_sdl_set_clock(p, opt->clock, opt->clock_delta, opt->initial_clock, opt->final_clock, opt->frame_number,
                       opt->clock_on);
    vbnl_sdl_set_frames(p, opt->initial_frame, opt->final_frame);
    for (size_t i = 0; i < opt->declare_count; ++i) {
        const vbnl_pov_declare *d = &opt->declares[i];
        if ((r = vbnl_sdl_declare_constant(p, d->name, d->string, d->number)) != VBNL_OK) {
            vbnl_error_set(err, r, r == VBNL_ERR_INVALID_ARGUMENT
                                       ? "Declare=%s: not an identifier, or a reserved word of the scene language"
                                       : "out of memory declaring %s",
                           d->name ? d->name : "(null)");
            goto done;
        }
    }
    for (size_t i = 0; i < opt->read_dir_count + opt->write_dir_count; ++i) {
        int w = i >= opt->read_dir_count;
        const char *dir = w ? opt->write_dirs[i - opt->read_dir_count] : opt->read_dirs[i];
        if ((r = vbnl_sdl_permit_dir(p, dir, w)) != VBNL_OK) {
            vbnl_error_set(err, r, "%s '%s' is not a folder that can be opened to the scene",
                           w ? "write folder" : "read folder", dir ? dir : "(null)");
            goto done;
        }
    }
    if (opt->includes_disabled) {
        vbnl_sdl_set_includes_enabled(p, 0);
        L->files_disabled = 1;
    }
    vbnl_sdl_set_diag_callback(p, on_diag, L);
    vbnl_sdl_hooks h = {L, hook_statement, hook_rvalue, hook_default};
    vbnl_sdl_set_hooks(p, &h);
    vbnl_sdl_set_function_block_hook(p, hook_function_block, L);
    pov_queries_install(L);
    r = text ? vbnl_sdl_parse_text(p, name, text, len, err) : vbnl_sdl_parse_file(p, name, err);
    if (r != VBNL_OK)
        goto done;
    if ((r = pov_build(L, err)) != VBNL_OK || (!opt->no_commit && (r = vbnl_scene_commit(L->c.scene, err)) != VBNL_OK)) {
        if (!L->build_error_located) { /* the message names no statement: it names the scene */
            char msg[VBNL_ERROR_MESSAGE_SIZE];
            snprintf(msg, sizeof msg, "%s", err ? err->message : "");
            vbnl_error_set(err, r, "%s: %s", name, msg);
        }
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
    pov_obj_clear(&L->world);
    pov_camera_release(&L->cam);
    pov_shape_cache_free(L); /* before the parser: solids may hold its functions */
    pov_query_cache_free(L);
    free(L->sphere_groups);
    free(L->warned);
    pov_sky_free(L->sky);
    free(L->fogs);
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
