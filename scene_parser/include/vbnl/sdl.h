/* vbnl: the language layer of the POV-Ray 3.7 scene description language (SDL).
 *
 * This layer owns everything in SDL that is not about scene objects: the tokenizer, the
 * directives (#declare #local #undef #include #version #if #ifdef #ifndef #elseif #else #end
 * #while #for #switch #case #range #break #macro #debug #warning #error #default), macros,
 * expressions (floats, vectors, colours, strings, arrays, user functions), the symbol tables,
 * include search and diagnostics.
 *
 * The object layer (objects, textures, cameras, lights) is written on top of this one: it drives
 * a vbnl_sdl_parser through the token API (vbnl_sdl_peek/vbnl_sdl_next return tokens after
 * directive processing and macro expansion) and the value API (vbnl_sdl_parse_float ...), and
 * plugs in through vbnl_sdl_hooks. Without hooks (or when a hook declines), statements and
 * declarations the language layer does not know ("sphere { ... }", "#declare T = texture { ... }")
 * are consumed structurally by a fallback that skips a balanced { } block; identifiers declared
 * to such a block hold a VBNL_SDL_BLOCK value.
 *
 * Errors: the first error stops the parse (as in POV-Ray). Every diagnostic is formatted as
 *     file:line:col: error: message
 *     <source line>
 *     <caret under the column>
 *       in macro 'M' invoked from a.pov:3:5
 *       included from b.pov:1:1
 * and is passed to the diagnostics callback (if any) and kept in a list (vbnl_sdl_diag_count).
 *
 * Ownership: a parser owns every value, token text and diagnostic it returns; pointers stay
 * valid until the call documented next to each function.
 *
 * Threads: a parser is single-threaded; distinct parsers share nothing (no global mutable
 * state) and may run concurrently. vbnl_sdl_parse_* run the parse on a private thread with a
 * large stack (vbnl_sdl_limits.stack_bytes) so deep but legal nesting cannot overflow the
 * caller's stack; the diagnostics callback and hooks are called on that thread, one at a time.
 */
#ifndef VBNL_SDL_H
#define VBNL_SDL_H

#include <stddef.h>
#include <stdint.h>

#include "vbnl/result.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vbnl_sdl_parser vbnl_sdl_parser;

/* ---- limits ------------------------------------------------------------------------------ */

/* Every limit produces a clear "limit exceeded" error instead of a hang or a crash. */
typedef struct vbnl_sdl_limits {
    int max_include_depth;        /* nested #include (default 64) */
    int max_macro_depth;          /* nested macro invocations (default 256) */
    int max_nesting;              /* nested expressions/blocks/directives (default 512) */
    uint64_t max_loop_iterations; /* total #while/#for iterations (default 10 000 000) */
    uint64_t max_tokens;          /* total tokens read (default 500 000 000) */
    size_t max_memory;            /* bytes of strings, arrays, files and placed objects (default 1 GiB) */
    size_t stack_bytes;           /* stack of the parse thread (default 256 MiB, virtual) */
} vbnl_sdl_limits;

/* Fills `limits` with the defaults listed above. */
void vbnl_sdl_limits_default(vbnl_sdl_limits *limits);

/* ---- locations, tokens ------------------------------------------------------------------- */

typedef struct vbnl_sdl_loc {
    const char *file; /* interned by the parser; valid until vbnl_sdl_parser_destroy */
    int line;         /* 1-based */
    int col;          /* 1-based, in bytes */
} vbnl_sdl_loc;

typedef enum vbnl_sdl_token_kind {
    VBNL_SDL_TOK_EOF = 0,
    VBNL_SDL_TOK_IDENT,  /* identifiers and keywords; text is interned (pointer-comparable) */
    VBNL_SDL_TOK_NUMBER, /* number holds the value */
    VBNL_SDL_TOK_STRING, /* text holds the decoded contents */
    VBNL_SDL_TOK_PUNCT,  /* op holds the operator, text its spelling */
} vbnl_sdl_token_kind;

/* Operators: single characters are their ASCII code, two-character ones below. */
enum {
    VBNL_SDL_OP_LE = 256, /* <= */
    VBNL_SDL_OP_GE,       /* >= */
    VBNL_SDL_OP_NE,       /* != */
    VBNL_SDL_OP_EQ2,      /* == (accepted as =) */
};

typedef struct vbnl_sdl_token {
    vbnl_sdl_token_kind kind;
    int op;           /* PUNCT only */
    int keyword;      /* IDENT: internal keyword id (0: not a language-layer keyword) */
    const char *text; /* never NULL ("" for EOF and numbers) */
    size_t len;       /* bytes in text */
    double number;
    vbnl_sdl_loc loc;
} vbnl_sdl_token;

/* ---- values ------------------------------------------------------------------------------ */

typedef enum vbnl_sdl_kind {
    VBNL_SDL_NONE = 0, /* uninitialised array element, failed parse */
    VBNL_SDL_FLOAT,
    VBNL_SDL_VECTOR,   /* dim 2..5 */
    VBNL_SDL_COLOR,    /* dim 5: red green blue filter transmit */
    VBNL_SDL_STRING,
    VBNL_SDL_ARRAY,
    VBNL_SDL_FUNCTION, /* user function: function(a,b) { expression } */
    VBNL_SDL_OBJECT,   /* opaque value defined by the object layer */
    VBNL_SDL_BLOCK,    /* unevaluated { } block kept by the skip fallback */
    VBNL_SDL_MACRO,    /* only seen through vbnl_sdl_lookup */
    VBNL_SDL_RNG,      /* not produced: seed() returns a FLOAT stream handle, as in POV-Ray */
    VBNL_SDL_SPLINE,   /* spline { ... }: S(t) evaluates it */
} vbnl_sdl_kind;

/* Type record of an opaque object-layer value. copy returns NULL on allocation failure. */
typedef struct vbnl_sdl_opaque_type {
    const char *name; /* "texture", "object", ... used in messages */
    void (*destroy)(void *ptr, void *user);
    void *(*copy)(const void *ptr, void *user);
    void *user;
    /* Optional: `#declare T = texture { A } texture { B }` (layers, lowest first). Combines the
     * value so far with the next layer, taking both; returns the combined value (NULL: out of
     * memory, both freed). Without it the last layer replaces the others. */
    void *(*layer)(void *below, void *above, void *user);
} vbnl_sdl_opaque_type;

typedef struct vbnl_sdl_array vbnl_sdl_array;
typedef struct vbnl_sdl_function vbnl_sdl_function;
typedef struct vbnl_sdl_block vbnl_sdl_block;
typedef struct vbnl_sdl_macro vbnl_sdl_macro;
typedef struct vbnl_sdl_spline vbnl_sdl_spline;

typedef struct vbnl_sdl_value {
    vbnl_sdl_kind kind;
    int dim;      /* FLOAT 1, VECTOR 2..5, COLOR 5 */
    double v[5];  /* FLOAT: v[0]; VECTOR/COLOR: components */
    union {
        struct { char *s; size_t len; } str;            /* STRING: owned, NUL-terminated */
        vbnl_sdl_array *array;                          /* ARRAY: owned */
        vbnl_sdl_function *fn;                          /* FUNCTION: shared, refcounted */
        struct { void *ptr; const vbnl_sdl_opaque_type *type; int tag; int deferred; } obj; /* OBJECT; deferred: warning group (vbnl_sdl_defer_begin) */
        vbnl_sdl_block *block;                          /* BLOCK: shared, refcounted */
        vbnl_sdl_macro *macro;                          /* MACRO: owned by the symbol table */
        vbnl_sdl_spline *spline;                        /* SPLINE: shared, refcounted */
    } u;
} vbnl_sdl_value;

/* Frees what `v` owns and sets it to NONE. */
void vbnl_sdl_value_clear(vbnl_sdl_parser *p, vbnl_sdl_value *v);
/* Deep copy (arrays and opaque values copied, functions and blocks shared). */
vbnl_result vbnl_sdl_value_copy(vbnl_sdl_parser *p, vbnl_sdl_value *dst, const vbnl_sdl_value *src);
/* Wraps an opaque object-layer value (takes ownership of ptr). */
void vbnl_sdl_value_object(vbnl_sdl_value *out, void *ptr, const vbnl_sdl_opaque_type *type, int tag);
/* "float", "vector", "color", "string", "array", ... */
const char *vbnl_sdl_kind_name(vbnl_sdl_kind kind);

/* Arrays: dims 1..5, elements in row-major order. */
int vbnl_sdl_array_rank(const vbnl_sdl_array *a);
size_t vbnl_sdl_array_size(const vbnl_sdl_array *a, int dim);
const vbnl_sdl_value *vbnl_sdl_array_at(const vbnl_sdl_array *a, size_t flat_index);
/* Blocks: the keyword ("texture", ...) and where the block starts. */
const char *vbnl_sdl_block_keyword(const vbnl_sdl_block *b);
vbnl_sdl_loc vbnl_sdl_block_loc(const vbnl_sdl_block *b);
/* Evaluates a user function with `n` arguments (missing ones are 0). */
vbnl_result vbnl_sdl_function_call(vbnl_sdl_parser *p, const vbnl_sdl_function *f,
                                   const double *args, int n, double *out);
int vbnl_sdl_function_arity(const vbnl_sdl_function *f);
/* A standalone copy of a user function and the functions it calls, for evaluation outside the
 * parse (patterns evaluated while rendering): it needs no parser and outlives it; free it with
 * vbnl_sdl_function_free_detached. NULL when out of memory. */
vbnl_sdl_function *vbnl_sdl_function_detach(const vbnl_sdl_function *f);
void vbnl_sdl_function_free_detached(vbnl_sdl_function *f);
/* Evaluates a detached function: thread-safe, no diagnostics; 0 where evaluation fails (too deep
 * or too long, as vbnl_sdl_function_call reports) and for pattern and internal functions. */
double vbnl_sdl_function_eval_detached(const vbnl_sdl_function *f, const double *args, int n);

/* ---- diagnostics ------------------------------------------------------------------------- */

typedef enum vbnl_sdl_severity {
    VBNL_SDL_NOTE = 0, /* #debug output */
    VBNL_SDL_WARNING,
    VBNL_SDL_ERROR,
} vbnl_sdl_severity;

typedef struct vbnl_sdl_diag {
    vbnl_sdl_severity severity;
    vbnl_sdl_loc loc;
    const char *message; /* the bare message: "undeclared identifier 'Foo'" */
    const char *text;    /* the full formatted text (location, source line, caret, chain) */
} vbnl_sdl_diag;

typedef void (*vbnl_sdl_diag_fn)(const vbnl_sdl_diag *d, void *user);

/* ---- hooks for the object layer ---------------------------------------------------------- */

/* What the object layer makes of a function body that is a block (`function { pattern { ... } }`,
 * `function { pigment { ... } }`): an evaluator of the point (x, y, z). `eval` must be
 * thread-safe and deterministic (detached functions call it while rendering); it fills `dims`
 * values: 1 for a pattern, 5 (r, g, b, filter, transmit) for a pigment. `retain` takes one more
 * reference to `user` and `release` drops one (the last frees it). */
typedef struct vbnl_sdl_fn_block {
    void *user;
    int dims;
    void (*eval)(void *user, const double p[3], double out[5]);
    void (*retain)(void *user);
    void (*release)(void *user);
} vbnl_sdl_fn_block;

typedef struct vbnl_sdl_hooks {
    void *user;
    /* Statement level: `tok` (peeked, not consumed) is an identifier the language layer does
     * not handle. Return 1 if the hook consumed a statement, 0 to fall back to the skip, -1 on
     * error (after vbnl_sdl_error). */
    int (*statement)(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, void *user);
    /* Right-hand side of #declare/#local, a macro argument or array element that starts with
     * identifier `tok` (peeked) which is not an expression. Same return convention; on 1 the
     * hook has filled `out`. */
    int (*rvalue)(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_value *out, void *user);
    /* #default { ... }: the parser is positioned on '{'. Same return convention. */
    int (*default_block)(vbnl_sdl_parser *p, void *user);
} vbnl_sdl_hooks;

/* ---- parser lifecycle -------------------------------------------------------------------- */

/* A parser with the default limits and no hooks into *out. Errors: VBNL_ERR_INVALID_ARGUMENT
 * (NULL out), VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_sdl_parser_create(vbnl_sdl_parser **out, vbnl_error *err);
/* Frees the parser and everything it returned (accepts NULL). */
void vbnl_sdl_parser_destroy(vbnl_sdl_parser *p);

/* Replaces the limits (copied). Returns VBNL_ERR_INVALID_ARGUMENT (and keeps the old ones) for a
 * NULL argument or a limit below its floor (depths and counts 1, nesting 8, memory 4096 bytes). */
vbnl_result vbnl_sdl_set_limits(vbnl_sdl_parser *p, const vbnl_sdl_limits *limits);
/* Appends a directory to the user include path (searched after the scene's folder). */
vbnl_result vbnl_sdl_add_include_dir(vbnl_sdl_parser *p, const char *dir);
/* Opens the folder `dir` and everything below it to the scene, as POV-Ray's I/O restriction
 * settings ("read*" and "read+write*" permitted paths) do: the scene may then read files there
 * (#include by an absolute or '..' name, file_exists, image_map, vbnl_mesh, load_lights) and, when
 * `writable`, also write them (save_lights). The folder is not searched for includes (that is
 * vbnl_sdl_add_include_dir). Errors: VBNL_ERR_IO when `dir` is not an existing folder. */
vbnl_result vbnl_sdl_permit_dir(vbnl_sdl_parser *p, const char *dir, int writable);
/* Overrides the detected POV-Ray standard include directory (NULL: none). */
vbnl_result vbnl_sdl_set_system_include_dir(vbnl_sdl_parser *p, const char *dir);
/* Disables #include entirely (fuzzing, untrusted input). */
void vbnl_sdl_set_includes_enabled(vbnl_sdl_parser *p, int enabled);
void vbnl_sdl_set_image_size(vbnl_sdl_parser *p, int width, int height);
/* clock, clock_delta, initial_clock, final_clock, frame_number, clock_on */
void vbnl_sdl_set_clock(vbnl_sdl_parser *p, double clock, double delta, double initial,
                        double final_clock, int frame_number, int clock_on);
/* initial_frame, final_frame (0 and 0, POV-Ray's values for a still image) */
void vbnl_sdl_set_frames(vbnl_sdl_parser *p, int initial_frame, int final_frame);
/* Declares the global identifier `name` before the parse, as POV-Ray's Declare=NAME=VALUE option
 * does: a string when `string` is non-NULL (copied), else the float `number`. Errors:
 * VBNL_ERR_INVALID_ARGUMENT when `name` is not an identifier or is a reserved word of the
 * language (clock, pi, ...), VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_sdl_declare_constant(vbnl_sdl_parser *p, const char *name, const char *string, double number);
/* Value of the predefined identifier vbnl_version (default 0.1). */
void vbnl_sdl_set_vbnl_version(vbnl_sdl_parser *p, double version);
void vbnl_sdl_set_diag_callback(vbnl_sdl_parser *p, vbnl_sdl_diag_fn fn, void *user);
void vbnl_sdl_set_hooks(vbnl_sdl_parser *p, const vbnl_sdl_hooks *hooks);
/* A function body that is identifier `tok` (consumed) followed by a block: the parser is
 * positioned on the block's '{'; the hook reads the block and fills *out. Same return convention
 * as the hooks above; on 0 (reading nothing) or without this hook the block is skipped and the
 * function evaluates as 0 with a warning. NULL removes the hook. */
typedef int (*vbnl_sdl_function_block_fn)(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_fn_block *out,
                                          void *user);
void vbnl_sdl_set_function_block_hook(vbnl_sdl_parser *p, vbnl_sdl_function_block_fn fn, void *user);
/* What the object layer answers about an object value (VBNL_SDL_OBJECT, the first argument of
 * the built-in functions min_extent, max_extent, inside and trace; POV-Ray 3.7 reference,
 * "Functions"). Each returns 1 when it answered, 0 when `obj` is not a value it knows (the
 * language layer then reports a wrong argument), -1 on error (after vbnl_sdl_error). They are
 * called on the parse thread, only when a scene calls one of these functions.
 * - extent: the corners of the object's bounding box in world (POV-Ray) coordinates.
 * - inside: *in = 1 when q is inside the object (0 also for objects that have no inside).
 * - trace: the first surface point of the ray org + t dir (t > 0, dir of unit length) in *hit and
 *   the unit surface normal there in normal; *found = 0 when the ray misses. */
typedef struct vbnl_sdl_object_queries {
    void *user;
    int (*extent)(vbnl_sdl_parser *p, const vbnl_sdl_value *obj, double lo[3], double hi[3], void *user);
    int (*inside)(vbnl_sdl_parser *p, const vbnl_sdl_value *obj, const double q[3], int *in, void *user);
    int (*trace)(vbnl_sdl_parser *p, const vbnl_sdl_value *obj, const double org[3], const double dir[3],
                 double hit[3], double normal[3], int *found, void *user);
} vbnl_sdl_object_queries;
/* Sets the object queries (copied; NULL removes them). Without them, min_extent, max_extent and
 * trace return <0,0,0> and inside returns 0, with a warning. */
void vbnl_sdl_set_object_queries(vbnl_sdl_parser *p, const vbnl_sdl_object_queries *q);

/* Parse a whole scene. `name` labels the text in messages and gives the folder searched first
 * for includes ("scene.pov" -> "."). On failure `err` holds the first line of the error
 * diagnostic. Symbols persist after the call (vbnl_sdl_lookup). */
vbnl_result vbnl_sdl_parse_file(vbnl_sdl_parser *p, const char *path, vbnl_error *err);
vbnl_result vbnl_sdl_parse_text(vbnl_sdl_parser *p, const char *name, const char *text,
                                size_t len, vbnl_error *err);

/* The diagnostics of the parses so far (0 for NULL); diagnostic i (NULL past the end), valid
 * until the parser is destroyed; how many of them are warnings. */
size_t vbnl_sdl_diag_count(const vbnl_sdl_parser *p);
const vbnl_sdl_diag *vbnl_sdl_diag_get(const vbnl_sdl_parser *p, size_t i);
size_t vbnl_sdl_warning_count(const vbnl_sdl_parser *p);

/* Global (or, during a parse, innermost visible) identifier; NULL if undeclared. Valid until
 * the identifier is redeclared or the parser destroyed. */
const vbnl_sdl_value *vbnl_sdl_lookup(vbnl_sdl_parser *p, const char *name);
/* #default blocks in order (kept as BLOCK values while no default_block hook is set). */
size_t vbnl_sdl_default_count(const vbnl_sdl_parser *p);
const vbnl_sdl_value *vbnl_sdl_default_get(const vbnl_sdl_parser *p, size_t i);
/* The #version in effect (3.7 unless the scene says otherwise). */
double vbnl_sdl_language_version(const vbnl_sdl_parser *p);

/* ---- for the object layer, during a parse (called from hooks) --------------------------- */

/* Deferred warnings. A declaration in an include file (textures.inc declares a hundred textures)
 * should warn where a scene uses what it declares, not where it is declared. Between begin and
 * end, warnings are kept in a group (groups nest: the innermost collects). The value built is
 * tagged with the group (obj.deferred). vbnl_sdl_defer_use, where the value is used: inside an
 * open group, links the used group into it; otherwise reports the group's warnings (each once
 * per parse), noting the place of use. begin returns 0 when out of memory (warnings are then
 * reported at once); every call accepts group 0. */
int vbnl_sdl_defer_begin(vbnl_sdl_parser *p);
void vbnl_sdl_defer_end(vbnl_sdl_parser *p, int group);
void vbnl_sdl_defer_use(vbnl_sdl_parser *p, int group, const vbnl_sdl_loc *use);

/* Tokens after directive processing and macro expansion. The returned pointer is valid until
 * the next vbnl_sdl_next/vbnl_sdl_peek call. After an error both return EOF. */
const vbnl_sdl_token *vbnl_sdl_peek(vbnl_sdl_parser *p);
const vbnl_sdl_token *vbnl_sdl_next(vbnl_sdl_parser *p);
/* Consumes the next token if it is the punctuation `op`; returns 1 if it did. */
int vbnl_sdl_accept(vbnl_sdl_parser *p, int op);
/* Consumes punctuation `op` or reports "expected 'op' <context>, found 'x'". */
vbnl_result vbnl_sdl_expect(vbnl_sdl_parser *p, int op, const char *context);

/* Expression parsing; on error they report it, return VBNL_ERR_PARSE and leave *out NONE/0. */
vbnl_result vbnl_sdl_parse_expression(vbnl_sdl_parser *p, vbnl_sdl_value *out);
vbnl_result vbnl_sdl_parse_float(vbnl_sdl_parser *p, double *out);
/* A float as POV-Ray's Parse_Float reads one: sums and differences of terms; a comparison must be
 * in parentheses, so `[0 <0, 1>]` (a slope_map entry) reads 0 and leaves the vector. */
vbnl_result vbnl_sdl_parse_float_sum(vbnl_sdl_parser *p, double *out);
/* A vector of `dim` components (2..5); floats are promoted (<f,f,f>). */
vbnl_result vbnl_sdl_parse_vector(vbnl_sdl_parser *p, int dim, double *out);
/* [color|colour] followed by rgb/rgbf/rgbt/rgbft/red/green/blue/filter/transmit/expression. */
vbnl_result vbnl_sdl_parse_color(vbnl_sdl_parser *p, double out[5]);
vbnl_result vbnl_sdl_parse_string(vbnl_sdl_parser *p, char **out); /* caller frees */
/* What may follow '=' in #declare: an expression, array, function, spline, or (through the
 * rvalue hook / the block fallback) an object-layer value. *out is owned by the caller. */
vbnl_result vbnl_sdl_parse_rvalue(vbnl_sdl_parser *p, vbnl_sdl_value *out);
/* Skips `{ ... }` (balanced; directives and macros still run). Positioned on '{'. */
vbnl_result vbnl_sdl_skip_block(vbnl_sdl_parser *p);

/* Reports an error at `loc` (NULL: the last token) and stops the parse; returns VBNL_ERR_PARSE. */
vbnl_result vbnl_sdl_error(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* A warning at `loc` (NULL: the last token), kept and passed on like an error; the parse goes on
 * (inside a vbnl_sdl_defer_begin group it waits for the use). */
void vbnl_sdl_warning(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* 1 once the parse has failed (an error was reported; also for NULL), else 0. */
int vbnl_sdl_failed(const vbnl_sdl_parser *p);

#ifdef __cplusplus
}
#endif
#endif
