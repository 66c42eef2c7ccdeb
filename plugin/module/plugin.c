/* The vbnl plugin module: vbnl_plugin_entry and the function table of vbnl_plugin.h, on top of the
 * core's public API (render.h, integrator.h, params.h), the scene loaders (POV-Ray language,
 * mesh import), the EXR/PNG writers and the OpenColorIO shim. The developer commands that
 * command_at / run_command reach are in plugin/commands/. */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "atomic_file.h"
#include "commands.h"
#include "image_io.h"
#include "module.h"
#include "ocio_shim.h"
#include "vbnl/pov_scene.h"
#include "vbnl/vbnl.h"
#include "vbnl/vbnl_plugin.h"

#define VBI_PLUGIN_EXPORT __attribute__((visibility("default")))
/* VBNL_PLUGIN_ABI_MAJOR.MINOR as text, for messages */
#define VBI_PLUGIN_ABI_STR "1.3"
_Static_assert(VBNL_PLUGIN_ABI_MAJOR == 1u && VBNL_PLUGIN_ABI_MINOR == 3u, "update VBI_PLUGIN_ABI_STR");
_Static_assert(VBNL_PLUGIN_TEST_PAUSE_WRITES == (unsigned)VBNL_TEST_HOOK_PAUSE_WRITES, "test hooks must match");

/* The plugin's result codes are the core's. */
_Static_assert(VBNL_PLUGIN_ERR_CORRUPT == (int)VBNL_ERR_CORRUPT, "result codes must match");
_Static_assert(VBNL_PLUGIN_ERR_CANCELLED == (int)VBNL_ERR_CANCELLED, "result codes must match");
_Static_assert(VBNL_PLUGIN_PARAM_STRING == (int)VBNL_PARAM_STRING, "parameter types must match");
_Static_assert(VBNL_PLUGIN_ERROR == (int)VBNL_SDL_ERROR && VBNL_PLUGIN_NOTE == (int)VBNL_SDL_NOTE,
               "severities must match");

/* A list of strings the renderer owns. */
typedef struct string_list {
    char **v;
    size_t n;
} string_list;

/* set_scene_option's settings of the POV-Ray scenes a renderer loads. */
typedef struct scene_settings {
    double clock, clock_delta, initial_clock, final_clock;
    int frame_number, initial_frame, final_frame, clock_on;
    vbnl_pov_declare *declares;   /* names and strings point into declare_text */
    string_list declare_text;     /* per declare: "NAME\0VALUE" */
    size_t ndeclares;
    string_list include_dirs, read_dirs, write_dirs;
} scene_settings;

struct vbnl_plugin_renderer {
    vbnl_plugin_options opt;
    char integrator[64];          /* opt.integrator points here when set */
    vbnl_sampler_kind sampler;    /* opt.sampler resolved */
    vbnl_params *host_params;     /* set_param, in order */
    vbnl_context *ctx;            /* created with the first scene (fixes the thread count) */
    vbnl_scene *scene;
    char scene_integrator[64];    /* a .pov scene's choice, "" for mesh files */
    vbnl_params *scene_params;    /* a .pov scene's parameters, or NULL */
    vbnl_params *merged;          /* scene parameters then host parameters */
    vbnl_render_settings settings;
    char resolved[64];
    vbnl_renderer *core;          /* after configure */
    int partial;
    vbnl_plugin_message_fn message;
    void *message_user;
    scene_settings pov;           /* set_scene_option: what the next .pov load reads */
};

static vbnl_result to_msg(vbnl_result r, const vbnl_error *e, char *msg, size_t n)
{
    if (r != VBNL_OK && msg && n)
        snprintf(msg, n, "%s", e->message[0] ? e->message : vbnl_result_name(r));
    return r;
}

static vbnl_result fail(char *msg, size_t n, vbnl_result code, const char *text)
{
    if (msg && n)
        snprintf(msg, n, "%s", text);
    return code;
}

/* ---- library and integrators ------------------------------------------------------------------ */

static const char *p_version(void) { return VBNL_VERSION_STRING; }

static uint32_t p_integrator_count(void) { return vbnl_integrator_count(); }

static vbnl_plugin_result p_integrator_info(uint32_t index, vbnl_plugin_integrator_info *out, char *msg, size_t n)
{
    const vbnl_integrator_class *c = vbnl_integrator_at(index);
    if (!out || !c)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "integrator_info: NULL output or index past the end");
    out->name = c->name;
    out->summary = c->summary;
    out->param_count = c->param_count;
    return VBNL_OK;
}

static vbnl_plugin_result p_integrator_param(uint32_t index, uint32_t param, vbnl_plugin_param_info *out, char *msg,
                                      size_t n)
{
    const vbnl_integrator_class *c = vbnl_integrator_at(index);
    if (!out || !c || param >= c->param_count)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "integrator_param: NULL output or index past the end");
    const vbnl_param_spec *s = &c->params[param];
    out->name = s->name;
    out->type = (vbnl_plugin_param_type)s->type;
    out->default_number = s->default_number;
    out->default_string = s->default_string;
    out->min = s->min;
    out->max = s->max;
    out->choices = s->choices;
    out->doc = s->doc;
    return VBNL_OK;
}

static void p_options_init(vbnl_plugin_options *o)
{
    if (!o)
        return;
    vbnl_render_settings s;
    vbnl_render_settings_init(&s);
    memset(o, 0, sizeof(*o));
    o->size = sizeof(*o);
    o->seed = s.seed;
    o->spp = s.spp;
    o->width = s.width;
    o->height = s.height;
}

static void p_view_init(vbnl_plugin_view *v)
{
    if (!v)
        return;
    memset(v, 0, sizeof(*v));
    v->size = sizeof(*v);
    v->png_bits = 8;
    v->dither = 1;
}

/* ---- renderer --------------------------------------------------------------------------------- */

static void drop_configuration(vbnl_plugin_renderer *r)
{
    vbnl_renderer_destroy(r->core);
    r->core = NULL;
    vbnl_params_destroy(r->merged);
    r->merged = NULL;
    r->partial = 0;
}

static vbnl_plugin_result p_renderer_create(vbnl_plugin_renderer **out, char *msg, size_t n)
{
    if (!out)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "renderer_create: out is NULL");
    *out = NULL;
    vbnl_plugin_renderer *r = calloc(1, sizeof(*r));
    vbnl_error e = {0};
    if (!r)
        return fail(msg, n, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbnl_result res = vbnl_params_create(&r->host_params, &e);
    if (res != VBNL_OK) {
        free(r);
        return to_msg(res, &e, msg, n);
    }
    p_options_init(&r->opt);
    *out = r;
    return VBNL_OK;
}

static void string_list_free(string_list *l)
{
    for (size_t i = 0; i < l->n; ++i)
        free(l->v[i]);
    free(l->v);
    l->v = NULL;
    l->n = 0;
}

static int string_list_add(string_list *l, const char *text, size_t len)
{
    char **v = realloc(l->v, (l->n + 1) * sizeof(*v));
    if (!v)
        return -1;
    l->v = v;
    if (!(v[l->n] = malloc(len + 1)))
        return -1;
    memcpy(v[l->n], text, len);
    v[l->n++][len] = '\0';
    return 0;
}

static void p_renderer_destroy(vbnl_plugin_renderer *r)
{
    if (!r)
        return;
    string_list_free(&r->pov.declare_text);
    string_list_free(&r->pov.include_dirs);
    string_list_free(&r->pov.read_dirs);
    string_list_free(&r->pov.write_dirs);
    free(r->pov.declares);
    drop_configuration(r);
    vbnl_params_destroy(r->scene_params);
    vbnl_params_destroy(r->host_params);
    vbnl_scene_destroy(r->scene);
    vbnl_context_destroy(r->ctx);
    free(r);
}

static vbnl_plugin_result p_set_options(vbnl_plugin_renderer *r, const vbnl_plugin_options *given, char *msg,
                                        size_t n)
{
    if (!r || !given)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "set_options: NULL renderer or options");
    /* A host built for an older minor passes a shorter struct: later fields keep their defaults. */
    if (given->size < offsetof(vbnl_plugin_options, camera_fov_y) + sizeof(given->camera_fov_y) ||
        given->size > sizeof(vbnl_plugin_options))
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT,
                    "set_options: options.size does not match this ABI (use options_init)");
    vbnl_plugin_options o;
    p_options_init(&o);
    memcpy(&o, given, given->size);
    o.size = sizeof(o);
    char text[256];
    if (o.width < 1 || o.height < 1 || o.width > 65536 || o.height > 65536) {
        snprintf(text, sizeof(text), "image size %ux%u: width and height must lie in 1..65536", o.width, o.height);
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, text);
    }
    if (!(o.time_budget >= 0.0) || !isfinite(o.time_budget) || (o.spp == 0 && o.time_budget == 0.0))
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "give samples per pixel > 0 or a time budget > 0 seconds");
    if ((o.crop[0] | o.crop[1] | o.crop[2] | o.crop[3]) &&
        (o.crop[0] >= o.crop[2] || o.crop[1] >= o.crop[3] || o.crop[2] > o.width || o.crop[3] > o.height))
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "the crop window must be non-empty and inside the image");
    if (o.integrator && !vbnl_integrator_find(o.integrator)) {
        size_t len = (size_t)snprintf(text, sizeof(text), "unknown integrator '%.64s' (available:", o.integrator);
        for (uint32_t i = 0; i < vbnl_integrator_count() && len < sizeof(text); ++i)
            len += (size_t)snprintf(text + len, sizeof(text) - len, " %s", vbnl_integrator_at(i)->name);
        if (len < sizeof(text))
            snprintf(text + len, sizeof(text) - len, ")");
        return fail(msg, n, VBNL_ERR_UNKNOWN_NAME, text);
    }
    if (o.camera_given) {
        const float *v[2] = {o.camera_position, o.camera_target};
        for (int i = 0; i < 2; ++i)
            if (!isfinite(v[i][0]) || !isfinite(v[i][1]) || !isfinite(v[i][2]))
                return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "camera position and target must be finite");
        if (!(o.camera_fov_y > 0.0f && o.camera_fov_y < 180.0f))
            return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "camera field of view must lie in (0, 180) degrees");
    }
    vbnl_sampler_kind sampler = VBNL_SAMPLER_SOBOL;
    if (o.sampler) {
        vbnl_error e = {0};
        vbnl_result res = vbnl_sampler_find(o.sampler, &sampler, &e);
        if (res != VBNL_OK)
            return to_msg(res, &e, msg, n);
    }
    if (r->ctx && (o.threads != r->opt.threads || o.test_hooks != r->opt.test_hooks))
        return fail(msg, n, VBNL_ERR_STATE, "the thread count and test hooks cannot change once a scene is loaded");
    drop_configuration(r);
    r->opt = o;
    r->sampler = sampler;
    r->opt.sampler = vbnl_sampler_name(sampler);
    if (o.integrator) {
        snprintf(r->integrator, sizeof(r->integrator), "%s", o.integrator);
        r->opt.integrator = r->integrator;
    }
    return VBNL_OK;
}

static vbnl_plugin_result p_set_param(vbnl_plugin_renderer *r, const char *kv, const char *where, char *msg, size_t n)
{
    if (!r || !kv)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "set_param: NULL renderer or text");
    vbnl_error e = {0};
    drop_configuration(r);
    return to_msg(vbnl_params_set_text(r->host_params, kv, where, &e), &e, msg, n);
}

static vbnl_result ensure_context(vbnl_plugin_renderer *r, vbnl_error *e)
{
    if (r->ctx)
        return VBNL_OK;
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = r->opt.threads;
    cd.test_hooks = r->opt.test_hooks;
    return vbnl_context_create(&cd, &r->ctx, e);
}

static void replace_scene(vbnl_plugin_renderer *r, vbnl_scene *scene, const char *integrator, vbnl_params *params)
{
    drop_configuration(r);
    vbnl_scene_destroy(r->scene);
    vbnl_params_destroy(r->scene_params);
    r->scene = scene;
    r->scene_params = params;
    snprintf(r->scene_integrator, sizeof(r->scene_integrator), "%s", integrator ? integrator : "");
}

/* A loaded POV-Ray scene: keep its scene, its integrator and a copy of its parameters. */
static vbnl_result adopt_pov(vbnl_plugin_renderer *r, vbnl_pov_scene *ps, vbnl_error *e)
{
    vbnl_params *params = NULL;
    vbnl_result res = vbnl_params_create(&params, e);
    if (res == VBNL_OK)
        res = vbnl_params_append(params, vbnl_pov_scene_params(ps), e);
    if (res != VBNL_OK) {
        vbnl_params_destroy(params);
        vbnl_pov_scene_destroy(ps);
        return res;
    }
    char name[64];
    snprintf(name, sizeof(name), "%s", vbnl_pov_scene_integrator(ps) ? vbnl_pov_scene_integrator(ps) : "");
    replace_scene(r, vbnl_pov_scene_take_scene(ps), name, params);
    vbnl_pov_scene_destroy(ps);
    return VBNL_OK;
}

static void forward_diag(const vbnl_sdl_diag *d, void *user)
{
    const vbnl_plugin_renderer *r = user;
    r->message(r->message_user, (vbnl_plugin_severity)d->severity, d->text ? d->text : d->message);
}

static void pov_options(vbnl_plugin_renderer *r, vbnl_pov_options *po)
{
    vbnl_pov_options_init(po);
    po->width = (int)r->opt.width;
    po->height = (int)r->opt.height;
    const scene_settings *ss = &r->pov;
    po->clock = ss->clock;
    po->clock_delta = ss->clock_delta;
    po->initial_clock = ss->initial_clock;
    po->final_clock = ss->final_clock;
    po->frame_number = ss->frame_number;
    po->initial_frame = ss->initial_frame;
    po->final_frame = ss->final_frame;
    po->clock_on = ss->clock_on;
    po->declares = ss->declares;
    po->declare_count = ss->ndeclares;
    po->include_dirs = (const char *const *)ss->include_dirs.v;
    po->include_dir_count = ss->include_dirs.n;
    po->read_dirs = (const char *const *)ss->read_dirs.v;
    po->read_dir_count = ss->read_dirs.n;
    po->write_dirs = (const char *const *)ss->write_dirs.v;
    po->write_dir_count = ss->write_dirs.n;
    if (r->message) {
        po->diag = forward_diag;
        po->diag_user = r;
    }
}

static vbnl_plugin_result p_set_message_callback(vbnl_plugin_renderer *r, vbnl_plugin_message_fn fn, void *user,
                                                 char *msg, size_t n)
{
    if (!r)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "set_message_callback: renderer is NULL");
    r->message = fn;
    r->message_user = user;
    return VBNL_OK;
}

/* Reads a whole number or a finite number; -1 when `text` is not one. */
static int scene_number(const char *text, double *out)
{
    char *end;
    double v = strtod(text, &end);
    if (end == text || *end || !isfinite(v))
        return -1;
    *out = v;
    return 0;
}

/* A declare's value: a float, or a string in double quotes (POV-Ray's Declare=NAME="text"). */
static vbnl_plugin_result add_declare(scene_settings *ss, const char *value, char *msg, size_t n)
{
    const char *eq = strchr(value, '=');
    char text[512];
    if (!eq || eq == value) {
        snprintf(text, sizeof(text), "declare '%.400s': give NAME=VALUE", value);
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, text);
    }
    const char *v = eq + 1;
    size_t vl = strlen(v);
    int quoted = vl >= 2 && v[0] == '"' && v[vl - 1] == '"';
    double number = 0;
    if (!quoted && scene_number(v, &number) != 0) {
        snprintf(text, sizeof(text), "declare '%.400s': the value is neither a number nor a string in double quotes",
                 value);
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, text);
    }
    /* the name is checked by the parser (an identifier, no reserved word); a quick check here
     * reports it at once */
    for (const char *c = value; c < eq; ++c)
        if (!(isalnum((unsigned char)*c) || *c == '_') || (c == value && isdigit((unsigned char)*c))) {
            snprintf(text, sizeof(text), "declare '%.400s': the name is not an identifier", value);
            return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, text);
        }
    /* "NAME\0VALUE" in one string the renderer keeps; the array of declares is rebuilt */
    char buf[4096];
    size_t nl = (size_t)(eq - value), sl = quoted ? vl - 2 : 0;
    if (nl + 1 + sl + 1 > sizeof(buf))
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "declare: the text is too long");
    memcpy(buf, value, nl);
    buf[nl] = '\0';
    memcpy(buf + nl + 1, v + 1, sl);
    vbnl_pov_declare *d = realloc(ss->declares, (ss->ndeclares + 1) * sizeof(*d));
    if (!d)
        return fail(msg, n, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    ss->declares = d;
    if (string_list_add(&ss->declare_text, buf, nl + 1 + sl) != 0)
        return fail(msg, n, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    const char *kept = ss->declare_text.v[ss->declare_text.n - 1];
    d[ss->ndeclares++] = (vbnl_pov_declare){kept, quoted ? kept + nl + 1 : NULL, number};
    return VBNL_OK;
}

static vbnl_plugin_result p_set_scene_option(vbnl_plugin_renderer *r, const char *key, const char *value, char *msg,
                                             size_t n)
{
    if (!r || !key || !value)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "set_scene_option: NULL renderer, key or value");
    scene_settings *ss = &r->pov;
    char text[512];
    static const char *const numbers[] = {"clock",        "clock_delta",   "initial_clock", "final_clock",
                                          "frame_number", "initial_frame", "final_frame",   "clock_on"};
    for (size_t i = 0; i < sizeof(numbers) / sizeof(numbers[0]); ++i) {
        if (strcmp(key, numbers[i]))
            continue;
        double v;
        if (scene_number(value, &v) != 0 || (i >= 4 && (v != floor(v) || fabs(v) > 2e9))) {
            snprintf(text, sizeof(text), "%s takes a %s, got '%.300s'", key, i >= 4 ? "whole number" : "number",
                     value);
            return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, text);
        }
        double *f[4] = {&ss->clock, &ss->clock_delta, &ss->initial_clock, &ss->final_clock};
        int *k[4] = {&ss->frame_number, &ss->initial_frame, &ss->final_frame, &ss->clock_on};
        if (i < 4)
            *f[i] = v;
        else
            *k[i - 4] = (int)v;
        return VBNL_OK;
    }
    if (!strcmp(key, "declare"))
        return add_declare(ss, value, msg, n);
    string_list *dirs = !strcmp(key, "include_dir") ? &ss->include_dirs
                        : !strcmp(key, "read_dir")  ? &ss->read_dirs
                        : !strcmp(key, "write_dir") ? &ss->write_dirs
                                                    : NULL;
    if (!dirs) {
        snprintf(text, sizeof(text),
                 "unknown scene option '%.200s' (known: clock clock_delta initial_clock final_clock frame_number "
                 "initial_frame final_frame clock_on declare include_dir read_dir write_dir)",
                 key);
        return fail(msg, n, VBNL_ERR_UNKNOWN_NAME, text);
    }
    struct stat st;
    if (dirs != &ss->include_dirs && (stat(value, &st) != 0 || !S_ISDIR(st.st_mode))) {
        snprintf(text, sizeof(text), "%s '%.300s' is not an existing folder", key, value);
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, text);
    }
    if (!value[0]) {
        snprintf(text, sizeof(text), "%s takes a folder", key);
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, text);
    }
    return string_list_add(dirs, value, strlen(value)) == 0 ? VBNL_OK
                                                           : fail(msg, n, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
}

static vbnl_plugin_result p_load_scene_file(vbnl_plugin_renderer *r, const char *path, char *msg, size_t n)
{
    if (!r || !path)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "load_scene_file: NULL renderer or path");
    vbnl_error e = {0};
    vbnl_result res = ensure_context(r, &e);
    if (res != VBNL_OK)
        return to_msg(res, &e, msg, n);
    if (module_is_pov(path)) {
        if (r->opt.camera_given)
            return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT,
                        "a camera option applies to mesh files; a .pov scene sets its own camera");
        vbnl_pov_options po;
        pov_options(r, &po);
        vbnl_pov_scene *ps = NULL;
        if ((res = vbnl_pov_load_file(r->ctx, path, &po, &ps, &e)) != VBNL_OK)
            return to_msg(res, &e, msg, n);
        return to_msg(adopt_pov(r, ps, &e), &e, msg, n);
    }
    /* Mesh files: scene_load.c frames them (or uses the given camera). */
    module_camera cam = {0};
    if (r->opt.camera_given) {
        cam.given = 1;
        memcpy(cam.position, r->opt.camera_position, sizeof(cam.position));
        memcpy(cam.target, r->opt.camera_target, sizeof(cam.target));
        cam.fov_y = r->opt.camera_fov_y;
    }
    vbnl_scene *scene = NULL;
    if ((res = module_load_scene(r->ctx, path, &cam, (float)r->opt.width / (float)r->opt.height, &scene, &e)) !=
        VBNL_OK)
        return to_msg(res, &e, msg, n);
    replace_scene(r, scene, NULL, NULL);
    return VBNL_OK;
}

static vbnl_plugin_result p_load_scene_text(vbnl_plugin_renderer *r, const char *name, const char *text, size_t len,
                                     char *msg, size_t n)
{
    if (!r || !name || !text)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "load_scene_text: NULL renderer, name or text");
    if (r->opt.camera_given)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT,
                    "a camera option applies to mesh files; scene text sets its own camera");
    vbnl_error e = {0};
    vbnl_result res = ensure_context(r, &e);
    if (res != VBNL_OK)
        return to_msg(res, &e, msg, n);
    vbnl_pov_options po;
    pov_options(r, &po);
    vbnl_pov_scene *ps = NULL;
    if ((res = vbnl_pov_load_text(r->ctx, name, text, len, &po, &ps, &e)) != VBNL_OK)
        return to_msg(res, &e, msg, n);
    return to_msg(adopt_pov(r, ps, &e), &e, msg, n);
}

static vbnl_plugin_result p_configure(vbnl_plugin_renderer *r, char *msg, size_t n)
{
    if (!r)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "configure: renderer is NULL");
    if (r->core)
        return VBNL_OK;
    if (!r->scene)
        return fail(msg, n, VBNL_ERR_STATE, "no scene loaded");
    vbnl_error e = {0};
    const char *name = r->opt.integrator ? r->opt.integrator : r->scene_integrator[0] ? r->scene_integrator : "path";
    snprintf(r->resolved, sizeof(r->resolved), "%s", name);
    if (r->opt.integrator && r->scene_integrator[0] && strcmp(r->opt.integrator, r->scene_integrator) &&
        r->message) {
        char note[192];
        snprintf(note, sizeof(note), "note: integrator '%s' replaces the scene's '%s' and its parameters",
                 r->opt.integrator, r->scene_integrator);
        r->message(r->message_user, VBNL_PLUGIN_NOTE, note);
    }
    vbnl_result res = vbnl_params_create(&r->merged, &e);
    if (res == VBNL_OK && r->scene_params && !r->opt.integrator)
        res = vbnl_params_append(r->merged, r->scene_params, &e);
    /* A scene's parameters belong to the scene's integrator: with another integrator chosen by
     * the host they are dropped (they may not exist there); the host's own always apply. */
    if (res == VBNL_OK && r->scene_params && r->opt.integrator && !strcmp(r->opt.integrator, r->scene_integrator))
        res = vbnl_params_append(r->merged, r->scene_params, &e);
    if (res == VBNL_OK)
        res = vbnl_params_append(r->merged, r->host_params, &e);
    if (res != VBNL_OK) {
        drop_configuration(r);
        return to_msg(res, &e, msg, n);
    }
    vbnl_render_settings *s = &r->settings;
    vbnl_render_settings_init(s);
    s->width = r->opt.width;
    s->height = r->opt.height;
    s->spp = r->opt.spp;
    s->time_budget = r->opt.time_budget;
    s->seed = r->opt.seed;
    s->sampler = r->sampler;
    s->integrator = r->resolved;
    s->params = r->merged;
    memcpy(s->crop, r->opt.crop, sizeof(s->crop));
    if ((res = vbnl_renderer_create(r->ctx, r->scene, s, &r->core, &e)) != VBNL_OK) {
        drop_configuration(r);
        return to_msg(res, &e, msg, n);
    }
    return VBNL_OK;
}

typedef struct progress_bridge {
    vbnl_plugin_progress_fn fn;
    void *user;
} progress_bridge;

static int bridge_progress(void *user, const vbnl_progress *p)
{
    const progress_bridge *b = user;
    vbnl_plugin_progress q = {p->stage, p->done, p->total, p->unit, p->elapsed, p->rate, p->eta};
    return b->fn(b->user, &q);
}

static vbnl_plugin_result p_prepare(vbnl_plugin_renderer *r, vbnl_plugin_progress_fn fn, void *user, char *msg, size_t n)
{
    vbnl_result res = p_configure(r, msg, n);
    if (res != VBNL_OK)
        return res;
    vbnl_error e = {0};
    progress_bridge b = {fn, user};
    res = vbnl_renderer_prepare(r->core, fn ? bridge_progress : NULL, &b, &e);
    r->partial = res == VBNL_ERR_CANCELLED;
    vbnl_render_stats st;
    if (res == VBNL_OK && r->message && r->settings.time_budget > 0.0 &&
        vbnl_renderer_get_stats(r->core, &st, NULL) == VBNL_OK) {
        /* what the integrator chose for the budget, before rendering starts */
        for (uint32_t i = 0; i < st.choice_count; ++i) {
            char note[512];
            snprintf(note, sizeof(note), "budget %g s: %s = %.6g (%s)", r->settings.time_budget, st.choices[i].name,
                     st.choices[i].value, st.choices[i].why);
            r->message(r->message_user, VBNL_PLUGIN_NOTE, note);
        }
    }
    return to_msg(res, &e, msg, n);
}

static vbnl_plugin_result p_render(vbnl_plugin_renderer *r, vbnl_plugin_progress_fn fn, void *user, char *msg, size_t n)
{
    if (!r)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "render: renderer is NULL");
    if (!r->core)
        return fail(msg, n, VBNL_ERR_STATE, "render before prepare");
    vbnl_error e = {0};
    progress_bridge b = {fn, user};
    vbnl_result res = vbnl_renderer_render(r->core, fn ? bridge_progress : NULL, &b, &e);
    r->partial = res == VBNL_ERR_CANCELLED;
    return to_msg(res, &e, msg, n);
}

static vbnl_plugin_result p_get_stats(const vbnl_plugin_renderer *r, vbnl_plugin_stats *out, char *msg, size_t n)
{
    if (!r || !out || out->size < sizeof(vbnl_plugin_stats))
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "get_stats: NULL argument or stats.size too small");
    if (!r->core)
        return fail(msg, n, VBNL_ERR_STATE, "get_stats before configure");
    vbnl_render_stats st;
    vbnl_error e = {0};
    vbnl_result res = vbnl_renderer_get_stats(r->core, &st, &e);
    if (res != VBNL_OK)
        return to_msg(res, &e, msg, n);
    out->spp = st.spp;
    out->passes = st.passes;
    out->threads = vbnl_context_thread_count(r->ctx);
    out->samples = st.samples;
    out->rays = st.rays;
    out->prepare_seconds = st.prepare_seconds;
    out->render_seconds = st.render_seconds;
    out->partial = r->partial;
    return VBNL_OK;
}

/* ---- framebuffer and files -------------------------------------------------------------------- */

static uint32_t p_layer_count(const vbnl_plugin_renderer *r)
{
    return r && r->core ? vbnl_film_layer_count(vbnl_renderer_film(r->core)) : 0;
}

static vbnl_plugin_result p_layer_info(const vbnl_plugin_renderer *r, uint32_t index, const char **name,
                                uint32_t *channels, char *msg, size_t n)
{
    if (!r || !r->core)
        return fail(msg, n, !r ? VBNL_ERR_INVALID_ARGUMENT : VBNL_ERR_STATE, "layer_info before configure");
    vbnl_layer_info info;
    vbnl_error e = {0};
    vbnl_result res = vbnl_film_layer(vbnl_renderer_film(r->core), index, &info, &e);
    if (res != VBNL_OK)
        return to_msg(res, &e, msg, n);
    if (name)
        *name = info.name;
    if (channels)
        *channels = info.channels;
    return VBNL_OK;
}

static vbnl_plugin_result p_read_layer(const vbnl_plugin_renderer *r, const char *layer, float *dst, size_t count,
                                char *msg, size_t n)
{
    if (!r || !r->core)
        return fail(msg, n, !r ? VBNL_ERR_INVALID_ARGUMENT : VBNL_ERR_STATE, "read_layer before configure");
    vbnl_error e = {0};
    return to_msg(vbnl_film_read(vbnl_renderer_film(r->core), layer ? layer : "", dst, count, &e), &e, msg, n);
}

static vbnl_plugin_result p_check_writable(const char *path, char *msg, size_t n)
{
    if (!path)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "check_writable: path is NULL");
    vbnl_error e = {0};
    return to_msg(module_check_writable(path, &e), &e, msg, n);
}

static vbnl_plugin_result p_write_exr(const vbnl_plugin_renderer *r, const char *path, int half, char *msg, size_t n)
{
    if (!r || !path || !r->core)
        return fail(msg, n, !r || !path ? VBNL_ERR_INVALID_ARGUMENT : VBNL_ERR_STATE,
                    "write_exr: NULL argument or nothing rendered");
    vbnl_error e = {0};
    return to_msg(module_write_outputs(r->core, &r->settings, r->scene, path, NULL, 0.0f, half, r->partial, &e), &e, msg, n);
}

static int view_valid(const vbnl_plugin_view *v, char *msg, size_t n)
{
    if (!v)
        return 1; /* defaults */
    if (v->size < offsetof(vbnl_plugin_view, dither) + sizeof(v->dither) || v->size > sizeof(vbnl_plugin_view)) {
        fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "view.size does not match this ABI (use view_init)");
        return 0;
    }
    if (!isfinite(v->exposure) || fabsf(v->exposure) >= 64.0f) {
        fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "exposure must lie in (-64, 64) stops");
        return 0;
    }
    if (v->png_bits != 8 && v->png_bits != 16) {
        fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "PNG bit depth must be 8 or 16");
        return 0;
    }
    return 1;
}

/* Exposure, then the OpenColorIO display/view, in place on w x h RGBA floats. */
static vbnl_result view_in_place(const vbnl_plugin_view *v, float *rgba, uint32_t w, uint32_t h, char *msg, size_t n)
{
    const float scale = exp2f(v->exposure);
    for (size_t i = 0; i < (size_t)w * h; ++i)
        for (int c = 0; c < 3; ++c)
            rgba[4 * i + c] *= scale;
    return (vbnl_result)vbi_ocio_apply(v->config, v->display, v->view, rgba, w, h, 4, msg, n);
}

static vbnl_plugin_result p_apply_view(const vbnl_plugin_renderer *r, const vbnl_plugin_view *view, float *dst,
                                size_t count, char *msg, size_t n)
{
    if (!r || !dst)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "apply_view: NULL renderer or buffer");
    if (!r->core)
        return fail(msg, n, VBNL_ERR_STATE, "apply_view: nothing rendered");
    if (!view_valid(view, msg, n))
        return VBNL_ERR_INVALID_ARGUMENT;
    vbnl_plugin_view v;
    p_view_init(&v);
    if (view)
        memcpy(&v, view, view->size);
    vbnl_error e = {0};
    vbnl_result res = vbnl_film_read(vbnl_renderer_film(r->core), "", dst, count, &e);
    if (res != VBNL_OK)
        return to_msg(res, &e, msg, n);
    return view_in_place(&v, dst, r->opt.width, r->opt.height, msg, n);
}

vbnl_result module_write_png(const char *path, float *rgba, uint32_t w, uint32_t h, const vbnl_plugin_view *view,
                             char *msg, size_t n)
{
    if (!rgba)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "write_png: NULL pixels");
    if (!view_valid(view, msg, n))
        return VBNL_ERR_INVALID_ARGUMENT;
    vbnl_plugin_view v;
    p_view_init(&v);
    if (view)
        memcpy(&v, view, view->size);
    const uint32_t channels = v.alpha ? 4 : 3; /* view.alpha (ABI 1.3): RGBA */
    void *q = malloc((size_t)w * h * channels * (v.png_bits / 8));
    if (!q)
        return fail(msg, n, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbnl_result res = view_in_place(&v, rgba, w, h, msg, n);
    vbnl_error e = {0};
    if (res == VBNL_OK && !path) { /* a check of the view only */
        free(q);
        return VBNL_OK;
    }
    /* Views may leave [0, 1] (Standard passes values above 1, ACES gives negatives for saturated
     * colours): vbi_display_quantise clamps before quantising. */
    if (res == VBNL_OK) {
        res = vbi_display_quantise(rgba, w, h, 4, v.png_bits, v.dither, q, channels, &e);
        if (res == VBNL_OK)
            res = vbi_png_write(path, w, h, channels, v.png_bits, q, &e);
        to_msg(res, &e, msg, n);
    }
    free(q);
    return res;
}

static vbnl_plugin_result p_write_png(const vbnl_plugin_renderer *r, const char *path, const vbnl_plugin_view *view,
                               char *msg, size_t n)
{
    if (!r || !path)
        return fail(msg, n, VBNL_ERR_INVALID_ARGUMENT, "write_png: NULL renderer or path");
    if (!r->core)
        return fail(msg, n, VBNL_ERR_STATE, "write_png: nothing rendered");
    uint32_t w = r->opt.width, h = r->opt.height;
    float *rgba = malloc(sizeof(float) * 4 * (size_t)w * h);
    if (!rgba)
        return fail(msg, n, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbnl_error e = {0};
    vbnl_result res = vbnl_film_read(vbnl_renderer_film(r->core), "", rgba, 4 * (size_t)w * h, &e);
    if (res != VBNL_OK)
        to_msg(res, &e, msg, n);
    else
        res = module_write_png(path, rgba, w, h, view, msg, n);
    free(rgba);
    return res;
}

/* Async-signal-safe (see vbnl_plugin.h): the registry of temporaries lives in the core
 * (core/src/atomic_file.c) and lists every file the module writes, the save_lights file included. */
static void p_abandon_writes(void) { vbi_atomic_file_abandon_all(); }

/* ---- what the module's commands see of a renderer (module.h) ---------------------------------- */

const vbnl_render_settings *module_renderer_settings(const vbnl_plugin_renderer *r)
{
    return r && r->core ? &r->settings : NULL;
}

/* ---- developer commands that need the core beyond this ABI ------------------------------------ */

typedef struct plugin_command {
    const char *name, *summary;
    int (*main)(int argc, char **argv);
} plugin_command;

static const plugin_command commands[] = {
    {"bench", "path tracer speed against the raw Embree ray rate; --equal-time / --equal-count: every method", cmd_bench},
    {"compare", "error of images against a reference: table, error maps, montage", cmd_compare},
    {"farm", "render a frame or an animation over a Slurm cluster (docs/farm.md)", cmd_farm},
    {"prepare", "vbnl: placement and elimination only, saved as a placement for photon jobs", cmd_prepare},
    {"photons", "vbnl: trace one photon range on a placement and save it", cmd_photons},
    {"merge-lights", "sum the photon ranges of light files into one", cmd_merge_lights},
    {"merge-tiles", "join the tiles of crop renders into the whole image (EXR, PNG)", cmd_merge_tiles},
};

static const char *p_command_at(uint32_t i, const char **summary)
{
    if (i >= sizeof(commands) / sizeof(commands[0]))
        return NULL;
    if (summary)
        *summary = commands[i].summary;
    return commands[i].name;
}

static int p_run_command(const char *name, int argc, char **argv)
{
    for (size_t i = 0; name && i < sizeof(commands) / sizeof(commands[0]); ++i)
        if (!strcmp(commands[i].name, name))
            return commands[i].main(argc, argv);
    fprintf(stderr, "vbnl: the plugin has no command '%s'\n", name ? name : "(null)");
    return VBI_EXIT_USAGE;
}

/* ---- the table -------------------------------------------------------------------------------- */

static const vbnl_plugin_api api = {
    .abi_major = VBNL_PLUGIN_ABI_MAJOR,
    .abi_minor = VBNL_PLUGIN_ABI_MINOR,
    .size = sizeof(vbnl_plugin_api),
    .version = p_version,
    .integrator_count = p_integrator_count,
    .integrator_info = p_integrator_info,
    .integrator_param = p_integrator_param,
    .options_init = p_options_init,
    .view_init = p_view_init,
    .renderer_create = p_renderer_create,
    .renderer_destroy = p_renderer_destroy,
    .set_options = p_set_options,
    .set_param = p_set_param,
    .set_message_callback = p_set_message_callback,
    .load_scene_file = p_load_scene_file,
    .load_scene_text = p_load_scene_text,
    .configure = p_configure,
    .prepare = p_prepare,
    .render = p_render,
    .get_stats = p_get_stats,
    .layer_count = p_layer_count,
    .layer_info = p_layer_info,
    .read_layer = p_read_layer,
    .check_writable = p_check_writable,
    .write_exr = p_write_exr,
    .apply_view = p_apply_view,
    .write_png = p_write_png,
    .command_at = p_command_at,
    .run_command = p_run_command,
    .abandon_writes = p_abandon_writes,
    .set_scene_option = p_set_scene_option,
};

const vbnl_plugin_api *module_api(void) { return &api; }

VBI_PLUGIN_EXPORT const vbnl_plugin_api *vbnl_plugin_entry(uint32_t host_abi_major, const char **why);

const vbnl_plugin_api *vbnl_plugin_entry(uint32_t host_abi_major, const char **why)
{
    if (host_abi_major != VBNL_PLUGIN_ABI_MAJOR) {
        /* constant strings only: the module keeps no state */
        if (why)
            *why = host_abi_major < VBNL_PLUGIN_ABI_MAJOR
                       ? "the host was built for an older plugin ABI major version than this module's ("
                         "module ABI " VBI_PLUGIN_ABI_STR "); rebuild the host against this vbnl_plugin.h"
                       : "the host was built for a newer plugin ABI major version than this module's ("
                         "module ABI " VBI_PLUGIN_ABI_STR "); install a matching vbnl plugin";
        return NULL;
    }
    if (why)
        *why = NULL;
    return &api;
}
