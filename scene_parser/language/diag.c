/* vbnl scene parser: diagnostics (formatting with source line, caret and include/macro chain). */
#include <stdlib.h>
#include <string.h>

#include "sdl_internal.h"

#define VBI_SDL_MAX_STORED_DIAGS 1000

/* Placeholder when a strdup failed; never freed (an empty message may be allocated). */
static const char no_text[] = "";

typedef struct sbuf {
    char *s;
    size_t n, cap;
} sbuf;

static void sb_add(sbuf *b, const char *s, size_t n)
{
    if (!b->s && b->cap == (size_t)-1)
        return;
    if (b->n + n + 1 > b->cap) {
        size_t cap = (b->n + n + 1) * 2;
        char *q = realloc(b->s, cap);
        if (!q) {
            free(b->s);
            b->s = NULL;
            b->cap = (size_t)-1;
            return;
        }
        b->s = q;
        b->cap = cap;
    }
    memcpy(b->s + b->n, s, n);
    b->n += n;
    b->s[b->n] = 0;
}

static void sb_printf(sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void sb_printf(sbuf *b, const char *fmt, ...)
{
    char tmp[1400];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n < 0)
        return;
    sb_add(b, tmp, (size_t)n < sizeof tmp ? (size_t)n : sizeof tmp - 1);
}

/* Whether byte i of s[0..n) is printed escaped: scene text reaches a terminal, where a control
 * character (ESC, CSI, BEL, CR, ...) would act instead of showing. Escaped: the C0 controls but
 * the newline and the tab, DEL, and the C1 controls U+0080..U+009F as UTF-8 (both their bytes). */
static bool escaped_byte(const unsigned char *s, size_t i, size_t n)
{
    unsigned char c = s[i];
    if (c < 0x20)
        return c != '\n' && c != '\t';
    if (c == 0x7f)
        return true;
    if (c == 0xc2)
        return i + 1 < n && s[i + 1] >= 0x80 && s[i + 1] <= 0x9f;
    return c >= 0x80 && c <= 0x9f && i > 0 && s[i - 1] == 0xc2;
}

/* Adds s[0..n) with every escaped byte as \xHH (four characters). */
static void sb_add_text(sbuf *b, const char *s, size_t n)
{
    const unsigned char *u = (const unsigned char *)s;
    size_t start = 0;
    for (size_t i = 0; i < n; i++) {
        if (!escaped_byte(u, i, n))
            continue;
        char hex[5];
        snprintf(hex, sizeof hex, "\\x%02x", u[i]);
        sb_add(b, s + start, i - start);
        sb_add(b, hex, 4);
        start = i + 1;
    }
    sb_add(b, s + start, n - start);
}

static const sdl_file *find_file(vbnl_sdl_parser *p, const char *name)
{
    for (sdl_file *f = p->files; f; f = f->next)
        if (f->name == name)
            return f;
    return NULL;
}

const char *sdl_word_at(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, char *buf, size_t n)
{
    const sdl_file *f = loc && loc->file ? find_file(p, loc->file) : NULL;
    if (!f || loc->line < 1 || loc->col < 1 || n < 2)
        return NULL;
    const char *s = f->text, *end = f->text + f->len;
    for (int l = 1; l < loc->line && s < end; s++)
        if (*s == '\n')
            l++;
    for (int c = 1; c < loc->col && s < end && *s != '\n'; c++)
        s++;
    size_t k = 0;
    while (s < end && k + 1 < n && (*s == '_' || (*s >= 'a' && *s <= 'z') || (*s >= 'A' && *s <= 'Z') ||
                                    (k > 0 && *s >= '0' && *s <= '9')))
        buf[k++] = *s++;
    buf[k] = '\0';
    return k ? buf : NULL;
}

static void add_source_line(vbnl_sdl_parser *p, sbuf *b, const vbnl_sdl_loc *loc)
{
    const sdl_file *f = find_file(p, loc->file);
    if (!f || loc->line < 1)
        return;
    const char *s = f->text, *end = f->text + f->len;
    for (int l = 1; l < loc->line && s < end; s++)
        if (*s == '\n')
            l++;
    const char *e = s;
    while (e < end && *e != '\n' && *e != '\r')
        e++;
    if (s >= end && loc->line > 1)
        return;
    size_t n = (size_t)(e - s);
    if (n > 300)
        n = 300;
    sb_add_text(b, s, n);
    sb_add(b, "\n", 1);
    for (size_t i = 0; i + 1 < (size_t)loc->col && i < n; i++) /* under an escaped byte, its 4 characters */
        if (s[i] == '\t')
            sb_add(b, "\t", 1);
        else
            sb_add(b, "    ", escaped_byte((const unsigned char *)s, i, n) ? 4 : 1);
    sb_add(b, "^\n", 2);
}

static void deliver(vbnl_sdl_parser *p, const vbnl_sdl_diag *dp, char *m, char *text);

void sdl_diag_emit(vbnl_sdl_parser *p, vbnl_sdl_severity sev, const vbnl_sdl_loc *loc,
                   const char *raw)
{
    vbnl_sdl_loc l = loc ? *loc : p->last_loc;
    if (!l.file)
        l.file = "";
    if (sev == VBNL_SDL_WARNING)
        p->diags.warnings++;
    /* nobody will see it: a #debug or #warning in a long loop must stay cheap */
    if (sev != VBNL_SDL_ERROR && !p->diag_fn && p->diags.count >= VBI_SDL_MAX_STORED_DIAGS)
        return;
    /* the message (a #debug's text, a name from the scene) with its control characters escaped */
    sbuf clean = { 0 };
    sb_add_text(&clean, raw, strlen(raw));
    const char *msg = clean.s ? clean.s : raw[0] ? "out of memory" : "";
    static const char *const sevname[] = { "note", "warning", "error" };
    sbuf b = { 0 };
    const char *where = l.file[0] || l.line > 0 ? l.file : "vbnl";
    sb_add_text(&b, where, strlen(where));
    if (l.line > 0)
        sb_printf(&b, ":%d:%d", l.line, l.col);
    sb_printf(&b, ": %s: ", sevname[sev]);
    sb_add(&b, msg, strlen(msg));
    sb_add(&b, "\n", 1);
    if (sev != VBNL_SDL_NOTE && l.line > 0)
        add_source_line(p, &b, &l);
    for (int i = p->nframes - 1; i > 0; i--) {
        const sdl_frame *f = &p->frames[i];
        /* deep recursion: the innermost 8 and the outermost 4 levels */
        if (p->nframes > 13 && i == p->nframes - 9) {
            sb_printf(&b, "  ... %d more levels ...\n", p->nframes - 13);
            i = 5;
            continue;
        }
        if (f->kind == SDL_FRAME_MACRO)
            sb_printf(&b, "  in macro '%s' invoked from %s:%d:%d\n", f->macro->name, f->from.file,
                      f->from.line, f->from.col);
        else
            sb_printf(&b, "  included from %s:%d:%d\n", f->from.file, f->from.line, f->from.col);
    }
    if (sev == VBNL_SDL_ERROR) {
        p->failed = true;
        if (!p->fail_code)
            p->fail_code = VBNL_ERR_PARSE;
        if (l.line > 0)
            snprintf(p->fail_message, sizeof p->fail_message, "%s:%d:%d: %s", l.file, l.line, l.col, msg);
        else
            snprintf(p->fail_message, sizeof p->fail_message, "%s", msg);
    }
    vbnl_sdl_diag d = { sev, l, NULL, NULL };
    char *m = clean.s ? clean.s : strdup(msg);
    d.message = m ? m : no_text;
    d.text = b.s ? b.s : no_text;
    if (sev == VBNL_SDL_WARNING && p->ndefer_open > 0) {
        p->diags.warnings--;
        sdl_defer_group *g = &p->defer[p->defer_open[p->ndefer_open - 1] - 1];
        if (g->count == g->cap) {
            size_t cap = g->cap ? g->cap * 2 : 4;
            vbnl_sdl_diag *q = realloc(g->items, cap * sizeof *q);
            if (q) {
                g->items = q;
                g->cap = cap;
            }
        }
        if (g->count < g->cap) {
            g->items[g->count++] = d;
            return;
        }
        p->diags.warnings++; /* out of memory: report it now */
    }
    deliver(p, &d, m, b.s);
}

/* Hands a diagnostic to the callback and the store (which takes the strings, or they are freed). */
static void deliver(vbnl_sdl_parser *p, const vbnl_sdl_diag *dp, char *m, char *text)
{
    vbnl_sdl_diag d = *dp;
    if (p->diag_fn)
        p->diag_fn(&d, p->diag_user);
    sdl_diag_store *st = &p->diags;
    if (st->count < VBI_SDL_MAX_STORED_DIAGS || d.severity == VBNL_SDL_ERROR) {
        if (st->count == st->cap) {
            size_t cap = st->cap ? st->cap * 2 : 16;
            vbnl_sdl_diag *q = realloc(st->items, cap * sizeof *q);
            if (q) {
                st->items = q;
                st->cap = cap;
            }
        }
        if (st->count < st->cap) {
            st->items[st->count++] = d;
            return;
        }
    }
    free(m);
    free(text);
}

void sdl_errorf(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *fmt, ...)
{
    if (p->failed)
        return;
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    sdl_diag_emit(p, VBNL_SDL_ERROR, loc, msg);
}

void sdl_warnf(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *fmt, ...)
{
    if (p->failed)
        return;
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    sdl_diag_emit(p, VBNL_SDL_WARNING, loc, msg);
}

vbnl_result vbnl_sdl_error(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *fmt, ...)
{
    if (!p)
        return VBNL_ERR_INVALID_ARGUMENT;
    if (!p->failed) {
        char msg[1024];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(msg, sizeof msg, fmt, ap);
        va_end(ap);
        sdl_diag_emit(p, VBNL_SDL_ERROR, loc, msg);
    }
    return VBNL_ERR_PARSE;
}

void vbnl_sdl_warning(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *fmt, ...)
{
    if (!p || p->failed)
        return;
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    sdl_diag_emit(p, VBNL_SDL_WARNING, loc, msg);
}

int vbnl_sdl_failed(const vbnl_sdl_parser *p)
{
    return !p || p->failed;
}

void sdl_diag_free(sdl_diag_store *d)
{
    for (size_t i = 0; i < d->count; i++) {
        if (d->items[i].message != no_text)
            free((char *)d->items[i].message);
        if (d->items[i].text != no_text)
            free((char *)d->items[i].text);
    }
    free(d->items);
    memset(d, 0, sizeof *d);
}

size_t vbnl_sdl_diag_count(const vbnl_sdl_parser *p)
{
    return p ? p->diags.count : 0;
}

const vbnl_sdl_diag *vbnl_sdl_diag_get(const vbnl_sdl_parser *p, size_t i)
{
    return p && i < p->diags.count ? &p->diags.items[i] : NULL;
}

size_t vbnl_sdl_warning_count(const vbnl_sdl_parser *p)
{
    return p ? p->diags.warnings : 0;
}

/* Case-insensitive Levenshtein distance, capped (names are short). */
static int distance(const char *a, const char *b)
{
    size_t na = strlen(a), nb = strlen(b);
    if (na > 64 || nb > 64)
        return 100;
    int row[65];
    for (size_t j = 0; j <= nb; j++)
        row[j] = (int)j;
    for (size_t i = 1; i <= na; i++) {
        int prev = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= nb; j++) {
            int ca = a[i - 1] | 32, cb = b[j - 1] | 32;
            int cost = ca == cb ? (a[i - 1] == b[j - 1] ? 0 : 0) : 1;
            int v = prev + cost;
            if (row[j] + 1 < v) v = row[j] + 1;
            if (row[j - 1] + 1 < v) v = row[j - 1] + 1;
            prev = row[j];
            row[j] = v;
        }
    }
    return row[nb];
}

static void consider(const char *name, const char *cand, const char **best, int *bestd)
{
    if (!cand || cand == name || cand == (const char *)1)
        return;
    int d = distance(name, cand);
    if (d < *bestd || (d == *bestd && *best && strcmp(cand, *best) < 0)) {
        *bestd = d;
        *best = cand;
    }
}

/* The closest visible identifier or keyword to `name`, or NULL when nothing is close. */
const char *sdl_suggest(vbnl_sdl_parser *p, const char *name)
{
    const char *best = NULL;
    size_t n = strlen(name);
    int bestd = n <= 3 ? 2 : (n <= 6 ? 3 : 4);
    for (int i = p->nframes - 1; i >= 0; i--) {
        const sdl_table *t = &p->frames[i].locals;
        for (size_t k = 0; k < t->cap; k++)
            consider(name, t->slots[k].name, &best, &bestd);
    }
    for (size_t k = 0; k < p->globals.cap; k++)
        consider(name, p->globals.slots[k].name, &best, &bestd);
    return best;
}

/* ---- deferred warnings ------------------------------------------------------------------- */

int vbnl_sdl_defer_begin(vbnl_sdl_parser *p)
{
    if (!p)
        return 0;
    if (p->ndefer == p->capdefer) {
        int cap = p->capdefer ? p->capdefer * 2 : 64;
        sdl_defer_group *q = realloc(p->defer, (size_t)cap * sizeof *q);
        if (!q)
            return 0;
        p->defer = q;
        p->capdefer = cap;
    }
    if (p->ndefer_open == p->capdefer_open) {
        int cap = p->capdefer_open ? p->capdefer_open * 2 : 16;
        int *q = realloc(p->defer_open, (size_t)cap * sizeof *q);
        if (!q)
            return 0;
        p->defer_open = q;
        p->capdefer_open = cap;
    }
    memset(&p->defer[p->ndefer], 0, sizeof p->defer[0]);
    int g = ++p->ndefer;
    p->defer_open[p->ndefer_open++] = g;
    return g;
}

void vbnl_sdl_defer_end(vbnl_sdl_parser *p, int group)
{
    if (!p || group <= 0)
        return;
    /* close it and anything left open above it */
    for (int i = p->ndefer_open - 1; i >= 0; i--)
        if (p->defer_open[i] == group) {
            p->ndefer_open = i;
            return;
        }
}

void sdl_defer_link(vbnl_sdl_parser *p, int parent, int child)
{
    if (parent <= 0 || parent > p->ndefer || child <= 0 || child > p->ndefer || parent == child)
        return;
    sdl_defer_group *g = &p->defer[parent - 1];
    for (size_t i = 0; i < g->nchildren; i++)
        if (g->children[i] == child)
            return;
    if (g->nchildren == g->capchildren) {
        size_t cap = g->capchildren ? g->capchildren * 2 : 4;
        int *q = realloc(g->children, cap * sizeof *q);
        if (!q)
            return;
        g->children = q;
        g->capchildren = cap;
    }
    g->children[g->nchildren++] = child;
}

static void deliver_group(vbnl_sdl_parser *p, int group, const vbnl_sdl_loc *use, int depth)
{
    if (group <= 0 || group > p->ndefer || depth > 64)
        return;
    sdl_defer_group *g = &p->defer[group - 1];
    if (g->delivered)
        return;
    g->delivered = true;
    for (size_t i = 0; i < g->count; i++) {
        vbnl_sdl_diag d = g->items[i];
        char *text = (char *)d.text;
        if (use && use->file && use->line > 0) {
            sbuf b = { 0 };
            sb_add(&b, d.text, strlen(d.text));
            sb_printf(&b, "  reported where it is used: %s:%d:%d\n", use->file, use->line, use->col);
            if (b.s) {
                if (text != no_text)
                    free(text);
                text = b.s;
            }
        }
        d.text = text;
        p->diags.warnings++;
        deliver(p, &d, (char *)d.message == no_text ? NULL : (char *)d.message, text == no_text ? NULL : text);
    }
    free(g->items);
    g->items = NULL;
    g->count = g->cap = 0;
    for (size_t i = 0; i < g->nchildren; i++)
        deliver_group(p, g->children[i], use, depth + 1);
}

void vbnl_sdl_defer_use(vbnl_sdl_parser *p, int group, const vbnl_sdl_loc *use)
{
    if (!p || group <= 0 || group > p->ndefer)
        return;
    if (p->ndefer_open > 0)
        sdl_defer_link(p, p->defer_open[p->ndefer_open - 1], group);
    else
        deliver_group(p, group, use, 0);
}

void sdl_defer_free(vbnl_sdl_parser *p)
{
    for (int i = 0; i < p->ndefer; i++) {
        sdl_defer_group *g = &p->defer[i];
        for (size_t k = 0; k < g->count; k++) {
            if (g->items[k].message != no_text)
                free((char *)g->items[k].message);
            if (g->items[k].text != no_text)
                free((char *)g->items[k].text);
        }
        free(g->items);
        free(g->children);
    }
    free(p->defer);
    free(p->defer_open);
    p->defer = NULL;
    p->defer_open = NULL;
    p->ndefer = p->capdefer = p->ndefer_open = p->capdefer_open = 0;
}
