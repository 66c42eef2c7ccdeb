/* vbnl object layer: global_settings { }, and its integrator block (a vbnl extension) that
 * chooses the integrator and its parameters. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_files.h"
#include "pov_loader.h"
#include "sdl_internal.h"
#include "vbnl/integrator.h"

/* ---- integrator { "name" key value ... } --------------------------------------------------------- */

typedef struct integrator_block {
    const vbnl_integrator_class *cls;
    char owner[96]; /* "integrator 'name'" in messages */
} integrator_block;

/* `list` (one path, or load_lights' "a:b:...") with each path resolved next to the naming file;
 * -1 after reporting the first refused one at `loc`. */
static int path_list(const char *list, const vbnl_sdl_loc *loc, pov_file_use use, const char *kname,
                     vbnl_sdl_parser *p, char **out)
{
    size_t cap = 1, len = 0;
    char *acc = malloc(1);
    if (!acc)
        return vbnl_sdl_error(p, loc, "out of memory"), -1;
    acc[0] = '\0';
    for (const char *c = list;;) {
        size_t n = use == POV_FILE_READ ? strcspn(c, ":") : strlen(c);
        char *one = strndup(c, n);
        const char *why = "out of memory";
        char *r = one ? pov_file_resolve(p, loc, one, use, &why) : NULL;
        if (!r) {
            vbnl_sdl_error(p, loc, "%s '%s' is %s", kname, one ? one : "", why);
            free(one);
            free(acc);
            return -1;
        }
        free(one);
        size_t rl = strlen(r);
        char *grown = realloc(acc, cap + rl + 1);
        if (!grown) {
            free(r);
            free(acc);
            return vbnl_sdl_error(p, loc, "out of memory"), -1;
        }
        acc = grown;
        cap += rl + 1;
        if (len)
            acc[len++] = ':';
        memcpy(acc + len, r, rl + 1);
        len += rl;
        free(r);
        if (!c[n])
            break;
        c += n + 1;
    }
    *out = acc;
    return 0;
}

/* One `key value` pair, validated on its own against the integrator's parameters so that an
 * error points at the pair; the kept setting carries the pair's file:line:col as its origin. */
static int integrator_pair(const pov_item *it)
{
    if (it->tok->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    pov_loader *L = it->ctx;
    const integrator_block *ib = it->target;
    vbnl_sdl_parser *p = it->p;
    vbnl_error e = {0};
    vbnl_sdl_token key = *vbnl_sdl_next(p);
    char kname[128];
    snprintf(kname, sizeof kname, "%s", key.text);
    vbnl_sdl_value v;
    if (vbnl_sdl_parse_expression(p, &v) != VBNL_OK)
        return -1;
    char where[512];
    snprintf(where, sizeof where, "%s:%d:%d", key.loc.file ? key.loc.file : "", key.loc.line, key.loc.col);
    /* A scene's file parameters name files in its own folder (pov_files.h). */
    char *resolved = NULL;
    if (v.kind == VBNL_SDL_STRING && v.u.str.s[0] && (!strcmp(kname, "save_lights") || !strcmp(kname, "load_lights")) &&
        path_list(v.u.str.s, &key.loc, !strcmp(kname, "save_lights") ? POV_FILE_WRITE : POV_FILE_READ, kname, p,
                  &resolved) != 0) {
        vbnl_sdl_value_clear(p, &v);
        return -1;
    }
    const char *sval = v.kind == VBNL_SDL_STRING ? (resolved ? resolved : v.u.str.s) : NULL;
    vbnl_params *one = NULL;
    vbnl_result r = vbnl_params_create(&one, &e);
    if (r == VBNL_OK) {
        if (v.kind == VBNL_SDL_STRING)
            r = vbnl_params_set_string(one, kname, sval, NULL, &e);
        else if (v.kind == VBNL_SDL_FLOAT)
            r = vbnl_params_set_number(one, kname, v.v[0], NULL, &e);
        else
            r = vbnl_error_set(&e, VBNL_ERR_INVALID_ARGUMENT, "parameter '%s' of %s takes a number or a string, got a %s",
                               kname, ib->owner, vbnl_sdl_kind_name(v.kind));
    }
    if (r == VBNL_OK)
        r = vbnl_params_validate(one, ib->cls->params, ib->cls->param_count, ib->owner, &e);
    if (r == VBNL_OK)
        r = v.kind == VBNL_SDL_STRING ? vbnl_params_set_string(L->params, kname, sval, where, &e)
                                      : vbnl_params_set_number(L->params, kname, v.v[0], where, &e);
    vbnl_params_destroy(one);
    vbnl_sdl_value_clear(p, &v);
    free(resolved);
    if (r != VBNL_OK) {
        vbnl_sdl_error(p, &key.loc, "%s", e.message);
        return -1;
    }
    return 1;
}

static const pov_block integrator_items = {.name = "integrator", .before = integrator_pair};

static vbnl_result integrator(const pov_item *it)
{
    pov_loader *L = it->ctx;
    vbnl_sdl_parser *p = it->p;
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '{', "after 'integrator'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_loc nl = vbnl_sdl_peek(p)->loc;
    if (vbnl_sdl_peek(p)->kind != VBNL_SDL_TOK_STRING)
        return vbnl_sdl_error(p, &nl, "integrator block must start with the integrator's name as a string, e.g. \"vbnl\"");
    char *name = NULL;
    if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
        return VBNL_ERR_PARSE;
    integrator_block ib;
    ib.cls = vbnl_integrator_find(name);
    if (!ib.cls) {
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
        return pov_oom(L);
    snprintf(ib.owner, sizeof ib.owner, "integrator '%s'", ib.cls->name);
    return pov_block_parse(&integrator_items, p, L, &ib, NULL);
}

/* ---- global_settings { } ---------------------------------------------------------------------- */

static vbnl_result radiosity(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    sdl_diag_emit(it->p, VBNL_SDL_NOTE, &it->loc,
                  "radiosity: global illumination is always on in vbnl; the block's settings are ignored");
    return vbnl_sdl_skip_block(it->p);
}

static vbnl_result any_color(const pov_item *it)
{
    double col[5];
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_color(it->p, col);
}

static vbnl_result charset(const pov_item *it) /* charset NAME */
{
    vbnl_sdl_next(it->p);
    vbnl_sdl_next(it->p);
    return VBNL_OK;
}

static vbnl_result unknown_setting(const pov_item *it)
{
    if (it->tok->kind != VBNL_SDL_TOK_IDENT)
        return pov_block_unexpected(it);
    return vbnl_sdl_error(it->p, &it->loc, "unknown global_settings item '%.31s'", it->tok->text);
}

static const pov_row settings_rows[] = {
    {"integrator", integrator, 0},
    {"radiosity", radiosity, 0},
    {"photons", pov_item_skip, 0},
    {"subsurface", pov_item_skip, 0},
    {"assumed_gamma", pov_item_any_float, 0},
    {"max_trace_level", pov_item_any_float, 0},
    {"adc_bailout", pov_item_any_float, 0},
    {"max_intersections", pov_item_any_float, 0},
    {"mm_per_unit", pov_item_any_float, 0},
    {"ambient_light", any_color, 0},
    {"irid_wavelength", any_color, 0},
    {"charset", charset, 0},
    {"hf_gray_16", pov_item_any_bool, 0},
    {NULL, NULL, 0},
};

static const pov_row *const settings_tables[] = {settings_rows, pov_texture_global_rows, NULL};
static const pov_block settings_block = {.name = "global_settings",
                                         .tables = settings_tables,
                                         .unknown = unknown_setting};

vbnl_result pov_global_settings_parse(pov_loader *L)
{
    if (vbnl_sdl_expect(L->c.parser, '{', "after 'global_settings'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_block_parse(&settings_block, L->c.parser, L, L, NULL);
}
