/* vbnl scene parser: source frames (files, includes, macro bodies) and the expanded token stream.
 *
 * Tokens flow: file text -> sdl_lex (raw) -> fetch (runs directives, expands macro invocations,
 * pops finished frames) -> one token of lookahead (p->peek) -> vbnl_sdl_next/vbnl_sdl_peek.
 * Macros are textual as in POV-Ray: an invocation pushes a frame that reads the macro body from
 * its file, so M(1) inside an expression simply continues the expression with the body's tokens.
 * Nothing here recurses per macro level: depth costs C stack only through the expression parser,
 * which is bounded by limits.max_nesting. */
#include <errno.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "read_file.h"
#include "sdl_internal.h"

sdl_frame *sdl_top(vbnl_sdl_parser *p)
{
    return p->nframes ? &p->frames[p->nframes - 1] : NULL;
}

static sdl_frame *push_frame(vbnl_sdl_parser *p, sdl_frame_kind kind, sdl_file *file, sdl_pos pos,
                             const vbnl_sdl_loc *from)
{
    if (p->nframes == p->capframes) {
        int cap = p->capframes ? p->capframes * 2 : 16;
        sdl_frame *q = realloc(p->frames, (size_t)cap * sizeof *q);
        if (!q) {
            sdl_errorf(p, from, "out of memory");
            return NULL;
        }
        p->frames = q;
        p->capframes = cap;
    }
    /* A token read ahead in the outer frame belongs after the new frame's text. */
    if (p->have_peek && p->nframes) {
        sdl_frame *outer = &p->frames[p->nframes - 1];
        outer->pending = p->peek;
        outer->has_pending = true;
        p->have_peek = false;
    }
    sdl_frame *f = &p->frames[p->nframes++];
    memset(f, 0, sizeof *f);
    f->kind = kind;
    f->file = file;
    f->pos = pos;
    if (from)
        f->from = *from;
    sdl_table_init(&f->locals);
    return f;
}

bool sdl_push_file(vbnl_sdl_parser *p, sdl_file *file, const vbnl_sdl_loc *from)
{
    if (p->include_depth >= p->limits.max_include_depth) {
        sdl_errorf(p, from, "include depth limit exceeded (%d nested files)", p->limits.max_include_depth);
        return false;
    }
    sdl_pos start = { 0, 1, 1 };
    if (!push_frame(p, SDL_FRAME_FILE, file, start, from))
        return false;
    if (p->nframes > 1)
        p->include_depth++;
    return true;
}

void sdl_pop_frame(vbnl_sdl_parser *p)
{
    sdl_frame *f = sdl_top(p);
    if (!f)
        return;
    if (f->kind == SDL_FRAME_MACRO) {
        p->macro_depth--;
        sdl_macro_free(p, f->macro);
    }
    else if (p->nframes > 1)
        p->include_depth--;
    if (f->has_pending)
        sdl_token_free(&f->pending);
    free(f->conds);
    sdl_table_free(p, &f->locals);
    p->nframes--;
}

int sdl_macro_depth(vbnl_sdl_parser *p)
{
    return p->macro_depth;
}

void sdl_seek(vbnl_sdl_parser *p, sdl_pos pos)
{
    if (p->have_peek) {
        sdl_token_free(&p->peek);
        p->have_peek = false;
    }
    sdl_frame *f = sdl_top(p);
    if (f) {
        f->pos = pos;
        if (f->has_pending) {
            sdl_token_free(&f->pending);
            f->has_pending = false;
        }
    }
}

sdl_pos sdl_tell(vbnl_sdl_parser *p)
{
    sdl_frame *f = sdl_top(p);
    sdl_pos none = { 0, 1, 1 };
    return f ? f->pos : none;
}

void sdl_raw(vbnl_sdl_parser *p, vbnl_sdl_token *tok)
{
    if (p->have_peek) {
        *tok = p->peek;
        p->have_peek = false;
        return;
    }
    sdl_frame *f = sdl_top(p);
    if (!f || p->failed) {
        memset(tok, 0, sizeof *tok);
        tok->text = "";
        return;
    }
    if (f->has_pending) {
        *tok = f->pending;
        f->has_pending = false;
        return;
    }
    sdl_lex(p, f, tok);
}

sdl_cond *sdl_cond_push(vbnl_sdl_parser *p, sdl_cond_kind kind, const vbnl_sdl_loc *loc)
{
    sdl_frame *f = sdl_top(p);
    if (f->nconds >= p->limits.max_nesting) {
        sdl_errorf(p, loc, "directive nesting limit exceeded (%d)", p->limits.max_nesting);
        return NULL;
    }
    if (f->nconds == f->capconds) {
        int cap = f->capconds ? f->capconds * 2 : 8;
        sdl_cond *q = realloc(f->conds, (size_t)cap * sizeof *q);
        if (!q) {
            sdl_errorf(p, loc, "out of memory");
            return NULL;
        }
        f->conds = q;
        f->capconds = cap;
    }
    sdl_cond *c = &f->conds[f->nconds++];
    memset(c, 0, sizeof *c);
    c->kind = kind;
    c->loc = *loc;
    return c;
}

void sdl_cond_pop(vbnl_sdl_parser *p)
{
    sdl_frame *f = sdl_top(p);
    if (f && f->nconds)
        f->nconds--;
}

static const char *cond_name(sdl_cond_kind k)
{
    switch (k) {
    case SDL_COND_IF: return "#if";
    case SDL_COND_WHILE: return "#while";
    case SDL_COND_FOR: return "#for";
    default: return "#switch";
    }
}

/* End of the top frame's text. */
static bool frame_ended(vbnl_sdl_parser *p, const vbnl_sdl_token *eof)
{
    sdl_frame *f = sdl_top(p);
    if (f->nconds) {
        sdl_cond *c = &f->conds[f->nconds - 1];
        sdl_errorf(p, &c->loc, "missing #end for %s (reached the end of '%s')", cond_name(c->kind), f->file->name);
        return false;
    }
    if (f->kind == SDL_FRAME_MACRO) {
        sdl_errorf(p, &eof->loc, "macro '%s' body reached the end of the file without #end", f->macro->name);
        return false;
    }
    /* A directive looking ahead at the end of its file (#include "x" EOF) sees the end; the
     * frame is popped when the stream reaches the end again after the directive. */
    if (p->nframes == 1 || f->in_directive > 0)
        return false;
    sdl_pop_frame(p);
    return true;
}

/* The next token after directives and macro invocations. Returns with p->have_peek false. */
static void fetch(vbnl_sdl_parser *p, vbnl_sdl_token *out)
{
    vbnl_sdl_token tok;
    for (;;) {
        if (p->failed || !p->nframes) {
            if (p->have_peek) {
                sdl_token_free(&p->peek);
                p->have_peek = false;
            }
            memset(out, 0, sizeof *out);
            out->text = "";
            out->loc = p->last_loc;
            return;
        }
        sdl_raw(p, &tok);
        if (tok.kind == VBNL_SDL_TOK_EOF) {
            if (!p->failed && frame_ended(p, &tok))
                continue;
            *out = tok;
            return;
        }
        p->last_loc = tok.loc;
        if (tok.kind == VBNL_SDL_TOK_PUNCT && tok.op == '#' && sdl_top(p)->in_directive == 0) {
            sdl_directive(p, &tok.loc);
            continue;
        }
        if (tok.kind == VBNL_SDL_TOK_IDENT && !p->no_expand && !tok.keyword) {
            sdl_sym *s = sdl_lookup(p, tok.text);
            if (s && s->val.kind == VBNL_SDL_MACRO) {
                /* Inside a directive's expression a macro runs when the expression reaches it
                 * (sdl_expand_here), not when it is merely looked at: "#declare C = "" M()" */
                if (sdl_top(p)->in_directive > 0) {
                    *out = tok;
                    return;
                }
                sdl_invoke_macro(p, s->val.u.macro, &tok.loc);
                continue;
            }
        }
        *out = tok;
        return;
    }
}

/* A token read ahead while a directive was parsed that must now be processed. */
static bool stale_peek(vbnl_sdl_parser *p)
{
    if (!p->have_peek || !sdl_top(p) || sdl_top(p)->in_directive > 0)
        return false;
    const vbnl_sdl_token *t = &p->peek;
    if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '#')
        return true;
    if (t->kind == VBNL_SDL_TOK_IDENT && !t->keyword && !p->no_expand) {
        sdl_sym *s = sdl_lookup(p, t->text);
        return s && s->val.kind == VBNL_SDL_MACRO;
    }
    return false;
}

static const vbnl_sdl_token null_eof = { VBNL_SDL_TOK_EOF, 0, 0, "", 0, 0.0, { "", 0, 0 } };

const vbnl_sdl_token *vbnl_sdl_next(vbnl_sdl_parser *p)
{
    vbnl_sdl_token t;
    if (!p)
        return &null_eof;
    if (p->have_peek && !stale_peek(p)) {
        t = p->peek;
        p->have_peek = false;
    } else {
        fetch(p, &t);
    }
    sdl_token_free(&p->cur);
    p->cur = t;
    if (t.kind != VBNL_SDL_TOK_EOF)
        p->last_loc = t.loc;
    return &p->cur;
}

const vbnl_sdl_token *vbnl_sdl_peek(vbnl_sdl_parser *p)
{
    if (!p)
        return &null_eof;
    if (stale_peek(p)) {
        /* A '#' or macro name read ahead inside a directive: now it runs. */
        vbnl_sdl_token t;
        fetch(p, &t);
        p->peek = t;
        p->have_peek = true;
    }
    if (!p->have_peek) {
        vbnl_sdl_token t;
        fetch(p, &t);
        p->peek = t;
        p->have_peek = true;
    }
    return &p->peek;
}

int vbnl_sdl_accept(vbnl_sdl_parser *p, int op)
{
    if (!p)
        return 0;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_PUNCT && (t->op == op || (op == '=' && t->op == VBNL_SDL_OP_EQ2))) {
        vbnl_sdl_next(p);
        return 1;
    }
    return 0;
}

/* ---- files ------------------------------------------------------------------------------- */

sdl_file *sdl_add_text(vbnl_sdl_parser *p, const char *name, const char *text, size_t len)
{
    const char *iname = sdl_intern(p, name, strlen(name), NULL);
    if (!iname)
        return NULL;
    sdl_file *f = calloc(1, sizeof *f);
    char *copy = sdl_alloc(p, len + 1);
    if (!f || !copy) {
        free(f);
        sdl_free(p, copy, len + 1);
        if (!p->failed)
            sdl_errorf(p, NULL, "out of memory");
        return NULL;
    }
    if (len)
        memcpy(copy, text, len);
    f->name = iname;
    f->text = copy;
    f->len = len;
    f->next = p->files;
    p->files = f;
    return f;
}

sdl_file *sdl_load_file(vbnl_sdl_parser *p, const char *path, const char **why)
{
    *why = NULL;
    const char *iname = sdl_intern(p, path, strlen(path), NULL);
    if (!iname)
        return NULL;
    for (sdl_file *f = p->files; f; f = f->next)
        if (f->name == iname)
            return f;
    FILE *fp = vbi_read_fopen(path, NULL, why);
    if (!fp)
        return NULL;
    char *buf = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (n + 65536 > cap) {
            cap = cap * 2 + 65536;
            if (cap > p->limits.max_memory) {
                free(buf);
                fclose(fp);
                sdl_errorf(p, NULL, "'%s' is larger than the memory limit", path);
                return NULL;
            }
            char *q = realloc(buf, cap);
            if (!q) {
                free(buf);
                fclose(fp);
                sdl_errorf(p, NULL, "out of memory reading '%s'", path);
                return NULL;
            }
            buf = q;
        }
        size_t r = fread(buf + n, 1, cap - n - 1, fp);
        n += r;
        if (r == 0)
            break;
    }
    fclose(fp);
    sdl_file *f = sdl_add_text(p, path, buf ? buf : "", n);
    free(buf);
    return f;
}

/* True when `path` names something other than a folder: an include is found there (a special
 * file is then refused by sdl_load_file with the reason, instead of "cannot find"). */
static bool is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && !S_ISDIR(st.st_mode);
}

/* The include file at `path`, or NULL after an error at `loc`. */
static sdl_file *load_include(vbnl_sdl_parser *p, const char *path, const vbnl_sdl_loc *loc)
{
    const char *why;
    sdl_file *f = sdl_load_file(p, path, &why);
    if (!f && !p->failed)
        sdl_errorf(p, loc, "cannot open include file '%s': %s", path, why ? why : "out of memory");
    return f;
}

static void dirname_of(const char *path, char *out, size_t n)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(out, n, ".");
    else if (slash == path)
        snprintf(out, n, "/");
    else
        snprintf(out, n, "%.*s", (int)(slash - path), path);
}

static bool path_inside(const char *dir, const char *path)
{
    size_t n = strlen(dir);
    return !strncmp(path, dir, n) && (path[n] == '/' || path[n] == '\0' || (n == 1 && dir[0] == '/'));
}

bool sdl_path_permitted(const vbnl_sdl_parser *p, const char *real, bool write)
{
    for (int i = 0; i < p->nwrite_dirs; i++)
        if (path_inside(p->write_dirs[i], real))
            return true;
    for (int i = 0; !write && i < p->nread_dirs; i++)
        if (path_inside(p->read_dirs[i], real))
            return true;
    return false;
}

bool sdl_path_readable(const vbnl_sdl_parser *p, const char *path)
{
    char real[PATH_MAX], dir[PATH_MAX];
    if (!realpath(path, real))
        return false;
    if (sdl_path_permitted(p, real, false))
        return true;
    if (realpath(p->scene_dir ? p->scene_dir : ".", dir) && path_inside(dir, real))
        return true;
    for (int i = 0; i < p->nuser_dirs; i++)
        if (realpath(p->user_dirs[i], dir) && path_inside(dir, real))
            return true;
    return p->system_dir && realpath(p->system_dir, dir) && path_inside(dir, real);
}

static const char outside_text[] =
    "include file '%s' is outside the folders a scene may read (its own, the include path, POV-Ray's)";

/* Include search: the scene's folder, the including file's folder, user dirs, POV-Ray's; only
 * files inside the folders sdl_path_readable allows. */
sdl_file *sdl_find_include(vbnl_sdl_parser *p, const char *name, const vbnl_sdl_loc *loc)
{
    char path[4096], dirs[8][1024], list[2048] = "";
    int nd = 0;
    if (name[0] == '/') {
        if (!is_file(name)) {
            sdl_errorf(p, loc, "cannot open include file '%s'", name);
            return NULL;
        }
        if (!sdl_path_readable(p, name)) {
            sdl_errorf(p, loc, outside_text, name);
            return NULL;
        }
        return load_include(p, name, loc);
    }
    const char *cand[64];
    int nc = 0;
    cand[nc++] = p->scene_dir ? p->scene_dir : ".";
    sdl_frame *top = sdl_top(p);
    char here[1024];
    if (top) {
        dirname_of(top->file->name, here, sizeof here);
        cand[nc++] = here;
    }
    for (int i = 0; i < p->nuser_dirs && nc < 62; i++)
        cand[nc++] = p->user_dirs[i];
    if (p->system_dir)
        cand[nc++] = p->system_dir;
    for (int i = 0; i < nc; i++) {
        bool dup = false;
        for (int j = 0; j < i; j++)
            if (strcmp(cand[i], cand[j]) == 0)
                dup = true;
        if (dup)
            continue;
        if (strcmp(cand[i], ".") == 0)
            snprintf(path, sizeof path, "%s", name);
        else
            snprintf(path, sizeof path, "%s/%s", cand[i], name);
        if (is_file(path)) {
            if (!sdl_path_readable(p, path)) {
                sdl_errorf(p, loc, outside_text, name);
                return NULL;
            }
            return load_include(p, path, loc);
        }
        if (nd < 8)
            snprintf(dirs[nd++], sizeof dirs[0], "%s", cand[i]);
        size_t l = strlen(list);
        snprintf(list + l, sizeof list - l, "%s%s", l ? ", " : "", cand[i]);
    }
    sdl_errorf(p, loc, "cannot find include file '%s' (searched: %s)", name, list);
    return NULL;
}

/* ---- macro invocation -------------------------------------------------------------------- */

void sdl_unread(vbnl_sdl_parser *p, const vbnl_sdl_token *tok)
{
    sdl_frame *f = sdl_top(p);
    if (p->have_peek) {
        if (f->has_pending) {
            sdl_errorf(p, &tok->loc, "internal error: two tokens of lookahead");
            return;
        }
        f->pending = p->peek;
        f->has_pending = true;
    }
    p->peek = *tok;
    p->have_peek = true;
}

bool sdl_expand_here(vbnl_sdl_parser *p)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind != VBNL_SDL_TOK_IDENT || t->keyword)
        return false;
    sdl_sym *s = sdl_lookup(p, t->text);
    if (!s || s->val.kind != VBNL_SDL_MACRO)
        return false;
    vbnl_sdl_loc loc = t->loc;
    vbnl_sdl_macro *m = s->val.u.macro;
    vbnl_sdl_next(p);
    sdl_invoke_macro(p, m, &loc);
    return !p->failed;
}

/* A macro argument that is a bare identifier is passed by reference (POV-Ray semantics:
 * "#declare Param = ..." inside the macro assigns the caller's identifier). */
static bool ref_argument(vbnl_sdl_parser *p, const char **ref)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    *ref = NULL;
    if (t->kind != VBNL_SDL_TOK_IDENT || t->keyword)
        return false;
    sdl_sym *s = sdl_lookup_binding(p, t->text, NULL);
    if (!s || (!s->ref && s->val.kind == VBNL_SDL_MACRO))
        return false;
    vbnl_sdl_token id = *vbnl_sdl_next(p);
    const vbnl_sdl_token *n = vbnl_sdl_peek(p);
    if (n->kind == VBNL_SDL_TOK_PUNCT && (n->op == ',' || n->op == ')')) {
        *ref = id.text;
        return true;
    }
    sdl_unread(p, &id);
    return false;
}

bool sdl_invoke_macro(vbnl_sdl_parser *p, vbnl_sdl_macro *m, const vbnl_sdl_loc *loc)
{
    if (p->macro_depth >= p->limits.max_macro_depth) {
        sdl_errorf(p, loc, "macro recursion limit exceeded (%d nested invocations of '%s' and others)",
                   p->limits.max_macro_depth, m->name);
        return false;
    }
    m->refs++; /* the macro may be redefined while its arguments are parsed or it runs */
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (!(t->kind == VBNL_SDL_TOK_PUNCT && t->op == '(')) {
        char b[80];
        sdl_errorf(p, &t->loc, "expected '(' after macro name '%s', found %s", m->name,
                   sdl_token_describe(t, b, sizeof b));
        sdl_macro_free(p, m);
        return false;
    }
    vbnl_sdl_next(p);
    int n = m->nparams;
    vbnl_sdl_value *args = calloc((size_t)(n ? n : 1), sizeof *args);
    bool *given = calloc((size_t)(n ? n : 1), sizeof *given);
    const char **refs = calloc((size_t)(n ? n : 1), sizeof *refs);
    bool ok = args && given && refs;
    int got = 0;
    int caller = p->nframes - 1;
    if (!ok)
        sdl_errorf(p, loc, "out of memory");
    if (ok && !vbnl_sdl_accept(p, ')')) {
        for (;;) {
            t = vbnl_sdl_peek(p);
            bool empty = t->kind == VBNL_SDL_TOK_PUNCT && (t->op == ',' || t->op == ')');
            vbnl_sdl_value v = { 0 };
            const char *ref = NULL;
            if (!empty && !ref_argument(p, &ref) && !sdl_parse_rvalue(p, &v)) {
                ok = false;
                break;
            }
            if (got < n) {
                args[got] = v;
                given[got] = !empty;
                refs[got] = ref;
            } else {
                vbnl_sdl_value_clear(p, &v);
            }
            got++;
            if (vbnl_sdl_accept(p, ','))
                continue;
            if (vbnl_sdl_accept(p, ')'))
                break;
            t = vbnl_sdl_peek(p);
            /* POV-Ray's commas are optional: "M(A -y)" passes two arguments */
            if (t->kind == VBNL_SDL_TOK_NUMBER || t->kind == VBNL_SDL_TOK_STRING || t->kind == VBNL_SDL_TOK_IDENT ||
                (t->kind == VBNL_SDL_TOK_PUNCT && (t->op == '-' || t->op == '+' || t->op == '<' || t->op == '(' ||
                                                    t->op == '!')))
                continue;
            char b[80];
            sdl_errorf(p, &t->loc, "expected ',' or ')' in arguments of macro '%s', found %s", m->name,
                       sdl_token_describe(t, b, sizeof b));
            ok = false;
            break;
        }
    }
    if (ok) {
        int required = 0;
        for (int i = 0; i < n; i++)
            if (!m->optional[i])
                required = i + 1;
        bool missing = false;
        for (int i = 0; i < n && i < got; i++)
            if (!given[i] && !m->optional[i])
                missing = true;
        if (got > n || got < required || missing) {
            sdl_errorf(p, loc, "macro '%s' expects %d argument%s, got %d (defined at %s:%d:%d)", m->name,
                       n, n == 1 ? "" : "s", got, m->loc.file, m->loc.line, m->loc.col);
            ok = false;
        }
    }
    sdl_frame *f = NULL;
    if (ok && caller != p->nframes - 1) {
        sdl_errorf(p, loc, "the arguments of macro '%s' end in another file or macro", m->name);
        ok = false;
    }
    if (ok) {
        f = push_frame(p, SDL_FRAME_MACRO, m->file, m->body, loc);
        ok = f != NULL;
    }
    if (ok) {
        f->macro = m;
        p->macro_depth++;
        for (int i = 0; i < n; i++) {
            /* an omitted optional parameter is an undefined local: it hides outer names */
            sdl_sym *s = sdl_table_insert(p, &f->locals, m->params[i]);
            if (!s) {
                ok = false;
                break;
            }
            if (i >= got || !given[i])
                continue;
            if (refs[i]) {
                s->ref = refs[i];
                s->ref_frame = caller;
            } else {
                s->val = args[i];
                args[i].kind = VBNL_SDL_NONE;
            }
        }
    } else {
        sdl_macro_free(p, m);
    }
    for (int i = 0; args && i < n; i++)
        vbnl_sdl_value_clear(p, &args[i]);
    free(args);
    free(given);
    free(refs);
    return ok;
}
