/* vbnl object layer: the table-driven block reader (pov_block.h). */
#include <string.h>

#include "pov_block.h"
#include "sdl_internal.h"

const pov_row *pov_row_find(const pov_row *rows, const char *word)
{
    for (; rows->keyword; ++rows)
        if (strcmp(rows->keyword, word) == 0)
            return rows;
    return NULL;
}

int pov_row_dispatch(const pov_row *rows, vbnl_sdl_parser *p, void *ctx, void *target)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    const pov_row *row = t->kind == VBNL_SDL_TOK_IDENT ? pov_row_find(rows, t->text) : NULL;
    if (!row)
        return 0;
    pov_item it = {p, ctx, target, NULL, NULL, t, t->loc, t->text, row->arg};
    return row->fn(&it) == VBNL_OK ? 1 : -1;
}

/* One item: 1 read, 0 nothing reads it, -1 error. */
static int read_item(pov_item *it)
{
    const pov_block *b = it->block;
    int r = b->before ? b->before(it) : 0;
    if (r)
        return r;
    if (it->tok->kind == VBNL_SDL_TOK_IDENT)
        for (const pov_row *const *tab = b->tables; tab && *tab; ++tab) {
            const pov_row *row = pov_row_find(*tab, it->tok->text);
            if (row) {
                it->kw = it->tok->text;
                it->arg = row->arg;
                return row->fn(it) == VBNL_OK ? 1 : -1;
            }
        }
    return b->after ? b->after(it) : 0;
}

static void item_at(pov_item *it, const vbnl_sdl_token *t)
{
    it->tok = t;
    it->loc = t->loc;
    it->kw = NULL;
    it->arg = 0;
}

vbnl_result pov_block_parse(const pov_block *b, vbnl_sdl_parser *p, void *ctx, void *target, const char *what)
{
    pov_item it = {p, ctx, target, b, what ? what : b->name, NULL, {0}, NULL, 0};
    int close = b->close ? b->close : '}';
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (pov_is_punct(t, close)) {
            if (!b->keep_close)
                vbnl_sdl_next(p);
            return VBNL_OK;
        }
        if (t->kind == VBNL_SDL_TOK_EOF && b->eof)
            return vbnl_sdl_error(p, &t->loc, "%s", b->eof);
        item_at(&it, t);
        int r = read_item(&it);
        if (r < 0)
            return VBNL_ERR_PARSE;
        if (r == 0 && (b->unknown ? b->unknown(&it) : pov_block_unexpected(&it)) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
}

vbnl_result pov_block_prefix(const pov_block *b, vbnl_sdl_parser *p, void *ctx, void *target)
{
    pov_item it = {p, ctx, target, b, b->name, NULL, {0}, NULL, 0};
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        const pov_row *row = NULL;
        for (const pov_row *const *tab = b->tables; !row && t->kind == VBNL_SDL_TOK_IDENT && *tab; ++tab)
            row = pov_row_find(*tab, t->text);
        if (!row)
            return VBNL_OK;
        item_at(&it, t);
        it.kw = t->text;
        it.arg = row->arg;
        if (row->fn(&it) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
}

vbnl_result pov_block_unexpected(const pov_item *it)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(it->p);
    char buf[80];
    if (t->kind == VBNL_SDL_TOK_EOF)
        return vbnl_sdl_failed(it->p) ? VBNL_ERR_PARSE
                                      : vbnl_sdl_error(it->p, &t->loc, "missing '}' at the end of '%s'", it->what);
    return vbnl_sdl_error(it->p, &t->loc, "unexpected %s in '%s'", sdl_token_describe(t, buf, sizeof buf), it->what);
}

vbnl_result pov_block_unexpected_word(const pov_item *it)
{
    return vbnl_sdl_error(it->p, &it->loc, "unexpected '%s' in %s", it->tok->text, it->what);
}

/* ---- generic handlers ------------------------------------------------------------------------ */

vbnl_result pov_item_float(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_float(it->p, pov_item_field(it));
}

vbnl_result pov_item_vec3(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_vector(it->p, 3, pov_item_field(it));
}

vbnl_result pov_item_word(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return VBNL_OK;
}

vbnl_result pov_item_skip(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return vbnl_sdl_skip_block(it->p);
}

vbnl_result pov_item_any_float(const pov_item *it)
{
    double v;
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_float(it->p, &v);
}

vbnl_result pov_item_any_vec3(const pov_item *it)
{
    double v[3];
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_vector(it->p, 3, v);
}

vbnl_result pov_item_any_bool(const pov_item *it)
{
    double v;
    vbnl_sdl_next(it->p);
    return pov_opt_bool(it->p, &v);
}

vbnl_result pov_opt_bool(vbnl_sdl_parser *p, double *out)
{
    static const char *const words[] = {"on", "off", "true", "false", "yes", "no", NULL};
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    *out = 1;
    int word = 0;
    for (int i = 0; t->kind == VBNL_SDL_TOK_IDENT && words[i]; ++i)
        word |= strcmp(t->text, words[i]) == 0;
    if (t->kind == VBNL_SDL_TOK_NUMBER || pov_is_punct(t, '(') || pov_is_punct(t, '!') || word)
        return vbnl_sdl_parse_float(p, out);
    if (t->kind == VBNL_SDL_TOK_IDENT) {
        const vbnl_sdl_value *v = vbnl_sdl_lookup(p, t->text);
        if (v && v->kind == VBNL_SDL_FLOAT)
            return vbnl_sdl_parse_float(p, out);
    }
    return VBNL_OK;
}
