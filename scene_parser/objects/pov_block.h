/* vbnl object layer: the table-driven reader of `{ keyword ... }` blocks (block.c).
 *
 * A block is described once, as data: tables of rows {keyword, handler, argument}, optional
 * hooks for items that are not keywords (a declared identifier, a colour expression), the
 * closing punctuation, and how an unknown item is reported. pov_block_parse reads items until the
 * closing token: for each item it tries `before`, then the rows of every table in order (the
 * first row whose keyword is the item's identifier wins), then `after`, and reports anything else
 * through `unknown`. Shapes, object modifiers, the camera, lights, global_settings and every
 * texture block (pigment, finish, interior, ...) are read this way, so a new keyword is one row
 * and a new block is one table. */
#ifndef VBI_POV_BLOCK_H
#define VBI_POV_BLOCK_H

#include <stddef.h>
#include <string.h>

#include "vbnl/sdl.h"

typedef struct pov_block pov_block;

/* What a handler sees. The parser is on the item's first token (peeked, not consumed): a handler
 * consumes its keyword itself (most begin with vbnl_sdl_next). */
typedef struct pov_item {
    vbnl_sdl_parser *p;
    void *ctx;                 /* the caller's state: the loader (objects) or the pov_ctx (textures) */
    void *target;              /* what the block fills */
    const pov_block *block;
    const char *what;          /* the block's name in messages ("camera", "sphere", "finish") */
    const vbnl_sdl_token *tok; /* the item's first token; valid until the next vbnl_sdl_peek/next */
    vbnl_sdl_loc loc;          /* its location (stays valid) */
    const char *kw;            /* row handlers: the keyword (interned: stays valid) */
    size_t arg;                /* row handlers: the row's argument (often an offset into target) */
} pov_item;

/* A row's handler: VBNL_OK, or VBNL_ERR_PARSE after the error was reported. */
typedef vbnl_result (*pov_item_fn)(const pov_item *it);

typedef struct pov_row {
    const char *keyword;
    pov_item_fn fn;
    size_t arg;
} pov_row; /* a table ends with a row whose keyword is NULL */

struct pov_block {
    const char *name;             /* in messages, unless the caller names the block */
    const pov_row *const *tables; /* NULL-terminated list */
    /* Optional hooks for items that are not rows: 1 read one, 0 not one, -1 error. */
    int (*before)(const pov_item *it);
    int (*after)(const pov_item *it);
    /* Reports an item nothing read (NULL: pov_block_unexpected). It may also consume the item
     * and return VBNL_OK, and the block goes on. */
    vbnl_result (*unknown)(const pov_item *it);
    /* Rows that read a transform (pov_transform_rows, pov_pattern_transform_rows) hand the matrix
     * to the block: p' = m p applied after what the target has. */
    void (*transform)(const pov_item *it, const double m[16]);
    const char *eof; /* non-NULL: the error at the end of the file before the closing token */
    int close;       /* the closing punctuation: '}' (0 also means '}') or ']' */
    int keep_close;  /* 1: stop before the closing token, for the caller to consume */
};

/* Reads items up to and including the closing token (the opening one was read by the caller).
 * `what` names the block in messages (NULL: b->name). */
vbnl_result pov_block_parse(const pov_block *b, vbnl_sdl_parser *p, void *ctx, void *target,
                            const char *what);
/* Reads items while the next token is the keyword of one of b's rows, and stops before the first
 * other token (a block whose leading items come in a fixed order, as mesh2's lists). */
vbnl_result pov_block_prefix(const pov_block *b, vbnl_sdl_parser *p, void *ctx, void *target);
/* The row of `rows` for `word`, or NULL. */
const pov_row *pov_row_find(const pov_row *rows, const char *word);
/* One item outside a block: when the next token is the keyword of a row, runs its handler (the
 * item's block is NULL) and returns 1, or -1 on error; 0 when no row names it. */
int pov_row_dispatch(const pov_row *rows, vbnl_sdl_parser *p, void *ctx, void *target);

/* The usual reports of an unknown item:
 *   pov_block_unexpected:      "unexpected <token> in '<what>'"; at the end of the file
 *                              "missing '}' at the end of '<what>'" (the object part's wording)
 *   pov_block_unexpected_word: "unexpected '<text>' in <what>" (the texture part's wording) */
vbnl_result pov_block_unexpected(const pov_item *it);
vbnl_result pov_block_unexpected_word(const pov_item *it);

/* Generic handlers; `arg` is the offset of a double (or double[3]) in the target:
 *   pov_item_float, pov_item_vec3   keyword, then the value into the target
 *   pov_item_word                   a keyword without value that changes nothing
 *   pov_item_skip                   keyword, then a { } block skipped
 *   pov_item_any_float, pov_item_any_vec3, pov_item_any_bool
 *                                   keyword, then a value read and dropped */
vbnl_result pov_item_float(const pov_item *it);
vbnl_result pov_item_vec3(const pov_item *it);
vbnl_result pov_item_word(const pov_item *it);
vbnl_result pov_item_skip(const pov_item *it);
vbnl_result pov_item_any_float(const pov_item *it);
vbnl_result pov_item_any_vec3(const pov_item *it);
vbnl_result pov_item_any_bool(const pov_item *it);

/* An optional boolean after a flag keyword ("hollow", "hollow on", "hollow false"): 1 unless a
 * value follows. */
vbnl_result pov_opt_bool(vbnl_sdl_parser *p, double *out);

/* Token tests for handlers. */
static inline int pov_is_word(const vbnl_sdl_token *t, const char *w)
{
    return t->kind == VBNL_SDL_TOK_IDENT && strcmp(t->text, w) == 0;
}
static inline int pov_is_punct(const vbnl_sdl_token *t, int op) { return t->kind == VBNL_SDL_TOK_PUNCT && t->op == op; }

/* The field `arg` bytes into the item's target. */
static inline void *pov_item_field(const pov_item *it) { return (char *)it->target + it->arg; }

#endif
