/* vbnl scene parser: parser lifecycle, configuration, the statement loop and the skip fallback. */
#include <ctype.h>
#include <limits.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "sdl_internal.h"

void vbnl_sdl_limits_default(vbnl_sdl_limits *l)
{
    if (!l)
        return;
    l->max_include_depth = 64;
    l->max_macro_depth = 256;
    l->max_nesting = 512;
    l->max_loop_iterations = 10000000ull;
    l->max_tokens = 500000000ull;
    l->max_memory = (size_t)1 << 30;
    l->stack_bytes = (size_t)256 << 20;
}

bool sdl_enter(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc)
{
    if (p->failed)
        return false;
    if (++p->depth > p->limits.max_nesting) {
        sdl_errorf(p, loc, "nesting too deep (more than %d levels of expressions, blocks or directives)",
                   p->limits.max_nesting);
        p->depth--;
        return false;
    }
    return true;
}

void sdl_leave(vbnl_sdl_parser *p)
{
    if (p->depth > 0)
        p->depth--;
}

static const char *const keyword_names[] = {
    "",
#define VBI_KW_NAME(n) #n,
    VBI_SDL_KEYWORDS(VBI_KW_NAME)
#undef VBI_KW_NAME
};

static void detect_system_dir(vbnl_sdl_parser *p)
{
    static const char *const cands[] = { "/usr/share/povray-3.7/include", "/usr/share/povray/include",
                                         "/usr/local/share/povray-3.7/include" };
    for (size_t i = 0; i < sizeof cands / sizeof cands[0]; i++) {
        struct stat st;
        if (stat(cands[i], &st) == 0 && S_ISDIR(st.st_mode)) {
            p->system_dir = strdup(cands[i]);
            return;
        }
    }
}

static void declare_float(vbnl_sdl_parser *p, const char *name, double v)
{
    const char *n = sdl_intern(p, name, strlen(name), NULL);
    if (!n)
        return;
    sdl_sym *s = sdl_table_insert(p, &p->globals, n);
    if (s) {
        vbnl_sdl_value_clear(p, &s->val);
        sdl_set_float(&s->val, v);
    }
}

vbnl_result vbnl_sdl_parser_create(vbnl_sdl_parser **out, vbnl_error *err)
{
    if (!out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_sdl_parser_create: out is NULL");
    *out = NULL;
    vbnl_sdl_parser *p = calloc(1, sizeof *p);
    if (!p)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory creating the scene parser");
    vbnl_sdl_limits_default(&p->limits);
    p->includes_enabled = true;
    p->language_version = 3.7;
    p->vbnl_version = 0.1;
    p->image_width = 320;
    p->image_height = 240;
    p->final_clock = 1;
    p->cur.text = "";
    p->peek.text = "";
    sdl_table_init(&p->globals);
    for (int k = 1; k < VBI_KW_COUNT; k++) {
        p->kw[k] = sdl_intern_keyword(p, keyword_names[k], k);
        if (!p->kw[k]) {
            vbnl_sdl_parser_destroy(p);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory creating the scene parser");
        }
    }
    declare_float(p, "vbnl_version", p->vbnl_version);
    if (p->failed) {
        vbnl_sdl_parser_destroy(p);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory creating the scene parser");
    }
    detect_system_dir(p);
    *out = p;
    return VBNL_OK;
}

static void reset_frames(vbnl_sdl_parser *p)
{
    while (p->nframes)
        sdl_pop_frame(p);
    sdl_token_free(&p->cur);
    if (p->have_peek)
        sdl_token_free(&p->peek);
    p->have_peek = false;
    p->macro_depth = 0;
    p->include_depth = 0;
    p->depth = 0;
    p->in_vector = 0;
    p->no_expand = false;
}

void vbnl_sdl_parser_destroy(vbnl_sdl_parser *p)
{
    if (!p)
        return;
    reset_frames(p);
    free(p->frames);
    sdl_table_free(p, &p->globals);
    for (size_t i = 0; i < p->ndefaults; i++)
        vbnl_sdl_value_clear(p, &p->defaults[i]);
    free(p->defaults);
    sdl_file *f = p->files;
    while (f) {
        sdl_file *n = f->next;
        free(f->text);
        free(f);
        f = n;
    }
    for (size_t i = 0; i < p->name_blocks_count; i++)
        free(p->name_blocks[i]);
    free(p->name_blocks);
    free(p->names);
    for (int i = 0; i < p->nuser_dirs; i++)
        free(p->user_dirs[i]);
    free(p->user_dirs);
    for (int i = 0; i < p->nread_dirs; i++)
        free(p->read_dirs[i]);
    free(p->read_dirs);
    for (int i = 0; i < p->nwrite_dirs; i++)
        free(p->write_dirs[i]);
    free(p->write_dirs);
    free(p->system_dir);
    free(p->scene_dir);
    free(p->rngs);
    sdl_diag_free(&p->diags);
    sdl_defer_free(p);
    free(p);
}

vbnl_result vbnl_sdl_set_limits(vbnl_sdl_parser *p, const vbnl_sdl_limits *l)
{
    if (!p || !l || l->max_include_depth < 1 || l->max_macro_depth < 1 || l->max_nesting < 8 ||
        l->max_loop_iterations < 1 || l->max_tokens < 1 || l->max_memory < 4096)
        return VBNL_ERR_INVALID_ARGUMENT;
    p->limits = *l;
    return VBNL_OK;
}

/* Appends a copy of `dir` (without trailing slashes) to a list of folders. */
static vbnl_result append_dir(char ***list, int *n, const char *dir)
{
    char **q = realloc(*list, (size_t)(*n + 1) * sizeof *q);
    if (!q)
        return VBNL_ERR_OUT_OF_MEMORY;
    *list = q;
    size_t len = strlen(dir);
    while (len > 1 && dir[len - 1] == '/')
        len--;
    q[*n] = strndup(dir, len);
    if (!q[*n])
        return VBNL_ERR_OUT_OF_MEMORY;
    (*n)++;
    return VBNL_OK;
}

vbnl_result vbnl_sdl_add_include_dir(vbnl_sdl_parser *p, const char *dir)
{
    if (!p || !dir || !dir[0])
        return VBNL_ERR_INVALID_ARGUMENT;
    return append_dir(&p->user_dirs, &p->nuser_dirs, dir);
}

vbnl_result vbnl_sdl_permit_dir(vbnl_sdl_parser *p, const char *dir, int writable)
{
    if (!p || !dir || !dir[0])
        return VBNL_ERR_INVALID_ARGUMENT;
    char real[PATH_MAX];
    struct stat st;
    if (!realpath(dir, real) || stat(real, &st) != 0 || !S_ISDIR(st.st_mode))
        return VBNL_ERR_IO;
    return writable ? append_dir(&p->write_dirs, &p->nwrite_dirs, real)
                    : append_dir(&p->read_dirs, &p->nread_dirs, real);
}

vbnl_result vbnl_sdl_set_system_include_dir(vbnl_sdl_parser *p, const char *dir)
{
    if (!p)
        return VBNL_ERR_INVALID_ARGUMENT;
    free(p->system_dir);
    p->system_dir = NULL;
    if (dir && !(p->system_dir = strdup(dir)))
        return VBNL_ERR_OUT_OF_MEMORY;
    return VBNL_OK;
}

void vbnl_sdl_set_includes_enabled(vbnl_sdl_parser *p, int enabled)
{
    if (p)
        p->includes_enabled = enabled != 0;
}

void vbnl_sdl_set_image_size(vbnl_sdl_parser *p, int width, int height)
{
    if (p) {
        p->image_width = width;
        p->image_height = height;
    }
}

void vbnl_sdl_set_clock(vbnl_sdl_parser *p, double clock, double delta, double initial, double final_clock,
                        int frame_number, int clock_on)
{
    if (!p)
        return;
    p->clock = clock;
    p->clock_delta = delta;
    p->initial_clock = initial;
    p->final_clock = final_clock;
    p->frame_number = frame_number;
    p->clock_on = clock_on;
}

void vbnl_sdl_set_frames(vbnl_sdl_parser *p, int initial_frame, int final_frame)
{
    if (!p)
        return;
    p->initial_frame = initial_frame;
    p->final_frame = final_frame;
}

vbnl_result vbnl_sdl_declare_constant(vbnl_sdl_parser *p, const char *name, const char *string, double number)
{
    if (!p || !name)
        return VBNL_ERR_INVALID_ARGUMENT;
    size_t len = strlen(name);
    int ident = len > 0 && (isalpha((unsigned char)name[0]) || name[0] == '_');
    for (size_t i = 1; ident && i < len; ++i)
        ident = isalnum((unsigned char)name[i]) || name[i] == '_';
    int kw = 0;
    const char *n = ident ? sdl_intern(p, name, len, &kw) : NULL;
    if (!ident || kw)
        return VBNL_ERR_INVALID_ARGUMENT;
    if (!n)
        return VBNL_ERR_OUT_OF_MEMORY;
    sdl_sym *sym = sdl_table_insert(p, &p->globals, n);
    if (!sym)
        return VBNL_ERR_OUT_OF_MEMORY;
    vbnl_sdl_value_clear(p, &sym->val);
    if (!string) {
        sdl_set_float(&sym->val, number);
        return VBNL_OK;
    }
    return sdl_set_string(p, &sym->val, string, strlen(string)) ? VBNL_OK : VBNL_ERR_OUT_OF_MEMORY;
}

void vbnl_sdl_set_vbnl_version(vbnl_sdl_parser *p, double version)
{
    if (!p)
        return;
    p->vbnl_version = version;
    declare_float(p, "vbnl_version", version);
}

void vbnl_sdl_set_diag_callback(vbnl_sdl_parser *p, vbnl_sdl_diag_fn fn, void *user)
{
    if (p) {
        p->diag_fn = fn;
        p->diag_user = user;
    }
}

void vbnl_sdl_set_function_block_hook(vbnl_sdl_parser *p, vbnl_sdl_function_block_fn fn, void *user)
{
    if (p) {
        p->function_block = fn;
        p->function_block_user = user;
    }
}

void vbnl_sdl_set_hooks(vbnl_sdl_parser *p, const vbnl_sdl_hooks *hooks)
{
    if (p) {
        if (hooks)
            p->hooks = *hooks;
        else
            memset(&p->hooks, 0, sizeof p->hooks);
    }
}

const vbnl_sdl_value *vbnl_sdl_lookup(vbnl_sdl_parser *p, const char *name)
{
    if (!p || !name)
        return NULL;
    /* Intern only names that exist: look them up without growing the table. */
    int kw;
    const char *n = sdl_intern(p, name, strlen(name), &kw);
    if (!n)
        return NULL;
    sdl_sym *s = sdl_lookup(p, n);
    return s && s->val.kind != VBNL_SDL_NONE ? &s->val : NULL;
}

size_t vbnl_sdl_default_count(const vbnl_sdl_parser *p) { return p ? p->ndefaults : 0; }
const vbnl_sdl_value *vbnl_sdl_default_get(const vbnl_sdl_parser *p, size_t i)
{
    return p && i < p->ndefaults ? &p->defaults[i] : NULL;
}
double vbnl_sdl_language_version(const vbnl_sdl_parser *p) { return p ? p->language_version : 0; }

/* ---- statements ---------------------------------------------------------------------------- */

vbnl_result vbnl_sdl_skip_block(vbnl_sdl_parser *p)
{
    if (!p || !p->nframes)
        return VBNL_ERR_STATE; /* only during a parse (from a hook) */
    vbnl_sdl_loc open = vbnl_sdl_peek(p)->loc;
    if (!sdl_expect_op(p, '{', "to open a block"))
        return VBNL_ERR_PARSE;
    /* Directives and macros inside a block run even when the block is the value of a #declare. */
    int fi = p->nframes - 1, saved = p->frames[fi].in_directive;
    p->frames[fi].in_directive = 0;
    int depth = 1;
    while (depth > 0) {
        const vbnl_sdl_token *t = depth == 1 ? vbnl_sdl_peek(p) : vbnl_sdl_next(p);
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}' && depth == 1) {
            /* restore before the lookahead after the block */
            if (fi < p->nframes)
                p->frames[fi].in_directive = saved;
            vbnl_sdl_next(p);
            return p->failed ? VBNL_ERR_PARSE : VBNL_OK;
        }
        if (depth == 1)
            t = vbnl_sdl_next(p);
        if (t->kind == VBNL_SDL_TOK_EOF) {
            if (!p->failed)
                sdl_errorf(p, &open, "missing '}' for the block opened here");
            break;
        }
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '{') {
            if (++depth > p->limits.max_nesting) {
                sdl_errorf(p, &t->loc, "blocks nested too deeply (more than %d levels)", p->limits.max_nesting);
                break;
            }
        } else if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            depth--;
        }
    }
    if (fi < p->nframes)
        p->frames[fi].in_directive = saved;
    return VBNL_ERR_PARSE;
}

static void statements(vbnl_sdl_parser *p)
{
    while (!p->failed) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (t->kind == VBNL_SDL_TOK_EOF)
            return;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == ';') {
            vbnl_sdl_next(p);
            continue;
        }
        if (t->kind == VBNL_SDL_TOK_IDENT) {
            if (p->hooks.statement) {
                vbnl_sdl_token copy = *t;
                int r = p->hooks.statement(p, &copy, p->hooks.user);
                if (r < 0)
                    return;
                if (r > 0)
                    continue;
            }
            vbnl_sdl_token kw = *vbnl_sdl_next(p);
            const vbnl_sdl_token *b = vbnl_sdl_peek(p);
            if (b->kind == VBNL_SDL_TOK_PUNCT && b->op == '{') {
                /* Fallback until the object layer exists: consume the statement structurally. */
                vbnl_sdl_skip_block(p);
                continue;
            }
            if (p->failed)
                return;
            sdl_sym *s = sdl_lookup(p, kw.text);
            if (!s && !kw.keyword) {
                const char *sug = sdl_suggest(p, kw.text);
                if (sug)
                    sdl_errorf(p, &kw.loc, "undeclared identifier '%s'; did you mean '%s'?", kw.text, sug);
                else
                    sdl_errorf(p, &kw.loc, "undeclared identifier '%s'", kw.text);
            } else {
                char d[80];
                sdl_errorf(p, &kw.loc, "expected a statement such as an object, camera or light_source, found %s",
                           sdl_token_describe(&kw, d, sizeof d));
            }
            return;
        }
        char d[80];
        sdl_errorf(p, &t->loc, "expected a statement such as an object, camera or light_source, found %s",
                   sdl_token_describe(t, d, sizeof d));
        return;
    }
}

static void *parse_thread(void *arg)
{
    statements((vbnl_sdl_parser *)arg);
    return NULL;
}

static vbnl_result run(vbnl_sdl_parser *p, sdl_file *f, vbnl_error *err)
{
    if (f && sdl_push_file(p, f, NULL)) {
        bool done = false;
        if (p->limits.stack_bytes > 0) {
            pthread_attr_t attr;
            pthread_t th;
            if (pthread_attr_init(&attr) == 0) {
                if (pthread_attr_setstacksize(&attr, p->limits.stack_bytes) == 0 &&
                    pthread_create(&th, &attr, parse_thread, p) == 0) {
                    pthread_join(th, NULL);
                    done = true;
                }
                pthread_attr_destroy(&attr);
            }
        }
        if (!done)
            statements(p);
    }
    reset_frames(p);
    if (p->failed) {
        vbnl_result r = p->fail_code ? p->fail_code : VBNL_ERR_PARSE;
        return vbnl_error_set(err, r, "%s", p->fail_message);
    }
    return VBNL_OK;
}

static void begin(vbnl_sdl_parser *p, const char *name)
{
    reset_frames(p);
    p->failed = false;
    p->fail_code = VBNL_OK;
    p->fail_message[0] = 0;
    p->loop_iterations = 0;
    p->tokens = 0;
    free(p->scene_dir);
    const char *slash = strrchr(name, '/');
    p->scene_dir = slash ? strndup(name, slash == name ? 1 : (size_t)(slash - name)) : strdup(".");
}

vbnl_result vbnl_sdl_parse_file(vbnl_sdl_parser *p, const char *path, vbnl_error *err)
{
    if (!p || !path)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_sdl_parse_file: NULL argument");
    begin(p, path);
    const char *why;
    sdl_file *f = sdl_load_file(p, path, &why);
    if (!f) {
        if (p->failed)
            return vbnl_error_set(err, p->fail_code ? p->fail_code : VBNL_ERR_IO, "%s", p->fail_message);
        return vbnl_error_set(err, why ? VBNL_ERR_IO : VBNL_ERR_OUT_OF_MEMORY, "cannot open scene file '%s': %s", path,
                              why ? why : "out of memory");
    }
    return run(p, f, err);
}

vbnl_result vbnl_sdl_parse_text(vbnl_sdl_parser *p, const char *name, const char *text, size_t len,
                                vbnl_error *err)
{
    if (!p || (!text && len))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_sdl_parse_text: NULL argument");
    if (!name)
        name = "<string>";
    begin(p, name);
    sdl_file *f = sdl_add_text(p, name, text ? text : "", len);
    if (!f)
        return vbnl_error_set(err, p->fail_code ? p->fail_code : VBNL_ERR_OUT_OF_MEMORY, "%s", p->fail_message);
    return run(p, f, err);
}
