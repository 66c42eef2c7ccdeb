/* vbnl scene parser: private declarations shared by the language-layer files. Never installed. */
#ifndef VBI_SDL_INTERNAL_H
#define VBI_SDL_INTERNAL_H

#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "vbnl/sdl.h"

/* Keywords the language layer interprets. Object keywords are plain identifiers here. */
#define VBI_SDL_KEYWORDS(X)                                                                      \
    X(declare) X(local) X(undef) X(include) X(version) X(if) X(ifdef) X(ifndef) X(elseif)          \
    X(else) X(end) X(while) X(for) X(switch) X(case) X(range) X(break) X(macro) X(debug)           \
    X(warning) X(error) X(default) X(fopen) X(fclose) X(read) X(write) X(render) X(statistics)     \
    X(deprecated) X(once) X(optional)                                                              \
    X(abs) X(acos) X(acosh) X(asc) X(asin) X(asinh) X(atan) X(atan2) X(atanh) X(bitwise_and)      \
    X(bitwise_or) X(bitwise_xor) X(ceil) X(chr) X(clock) X(clock_delta) X(clock_on) X(color)      \
    X(colour) X(concat) X(cos) X(cosh) X(defined) X(degrees) X(dimension_size) X(dimensions)      \
    X(div) X(exp) X(false) X(file_exists) X(filter) X(final_clock) X(final_frame) X(floor)        \
    X(frame_number) X(function) X(gray) X(grey) X(green) X(blue) X(red) X(image_height)          \
    X(image_width) X(initial_clock) X(initial_frame) X(inside) X(int) X(ln) X(log) X(max) X(min)  \
    X(mod) X(no) X(now) X(off) X(on) X(pi) X(pow) X(radians) X(rand) X(rgb) X(rgbf) X(rgbft)      \
    X(rgbt) X(srgb) X(srgbf) X(srgbft) X(srgbt) X(seed) X(select) X(sin) X(sinh) X(sqrt) X(sqr)   \
    X(str) X(strcmp) X(strlen) X(strlwr) X(strupr) X(substr) X(tan) X(tanh) X(tau) X(transmit)   \
    X(true) X(u) X(v) X(val) X(vaxis_rotate) X(vcross) X(vdot) X(vlength) X(vnormalize)           \
    X(vrotate) X(vstr) X(vturbulence) X(x) X(y) X(z) X(t) X(yes) X(array) X(internal) X(datetime) \
    X(hf) X(trace) X(min_extent) X(max_extent) X(prod) X(sum) X(input_file_name) X(append) X(mixed)

enum {
    VBI_KW_NONE = 0,
#define VBI_KW_ENUM(n) VBI_KW_##n,
    VBI_SDL_KEYWORDS(VBI_KW_ENUM)
#undef VBI_KW_ENUM
    VBI_KW_COUNT
};

/* ---- interned names, files --------------------------------------------------------------- */

typedef struct sdl_name {
    const char *s;
    size_t len;
    int kw;
} sdl_name;

typedef struct sdl_file {
    const char *name; /* interned */
    char *text;       /* NUL-terminated */
    size_t len;
    struct sdl_file *next;
} sdl_file;

/* A position inside a file: what the lexer needs to resume. */
typedef struct sdl_pos {
    size_t off;
    int line, col;
} sdl_pos;

/* ---- symbols ----------------------------------------------------------------------------- */

typedef struct sdl_sym {
    const char *name; /* interned; NULL: empty slot; (char*)1: tombstone */
    vbnl_sdl_value val;
    const char *ref;  /* macro parameter passed as a bare identifier: an alias of `ref` */
    int ref_frame;    /* ... resolved from this frame downwards */
} sdl_sym;

typedef struct sdl_table {
    sdl_sym *slots;
    size_t cap, count, used; /* used includes tombstones */
} sdl_table;

struct vbnl_sdl_array {
    int pins;  /* > 0: in use across a lookahead; freeing is deferred */
    bool dead; /* freed while pinned */
    int rank;
    size_t dims[5];
    size_t count;
    vbnl_sdl_value *elems;
};

struct vbnl_sdl_block {
    int refs;
    const char *keyword;
    vbnl_sdl_loc loc;
};

struct vbnl_sdl_macro {
    int refs;             /* the symbol and every running invocation */
    const char *name;
    sdl_file *file;
    sdl_pos body;         /* just after the ')' of the parameter list */
    vbnl_sdl_loc loc;     /* of the name */
    int nparams;
    const char **params;  /* interned */
    bool *optional;
};

/* ---- control stack, source frames -------------------------------------------------------- */

typedef enum sdl_cond_kind { SDL_COND_IF, SDL_COND_WHILE, SDL_COND_FOR, SDL_COND_SWITCH } sdl_cond_kind;

typedef struct sdl_cond {
    sdl_cond_kind kind;
    vbnl_sdl_loc loc; /* of the opening directive */
    sdl_pos pos;      /* WHILE: start of the condition; FOR: start of the body */
    const char *var;  /* FOR: loop variable */
    bool var_local;
    double end, step; /* FOR */
    double value;     /* SWITCH */
    bool taken;       /* IF: a branch ran; SWITCH: a case matched */
} sdl_cond;

typedef enum sdl_frame_kind { SDL_FRAME_FILE, SDL_FRAME_MACRO } sdl_frame_kind;

typedef struct sdl_frame {
    sdl_frame_kind kind;
    sdl_file *file;
    sdl_pos pos;
    vbnl_sdl_loc from;          /* where the include/invocation was */
    vbnl_sdl_macro *macro;      /* retained while the invocation runs */
    sdl_table locals;
    sdl_cond *conds;
    int nconds, capconds;
    int in_directive;           /* > 0: '#' ends expressions instead of starting a directive */
    vbnl_sdl_token pending;     /* read ahead before a frame was pushed on top of this one */
    bool has_pending;
} sdl_frame;

/* ---- diagnostics --------------------------------------------------------------------------- */

typedef struct sdl_diag_store {
    vbnl_sdl_diag *items;
    size_t count, cap, warnings;
} sdl_diag_store;

/* A group of deferred warnings (vbnl_sdl_defer_begin). */
typedef struct sdl_defer_group {
    vbnl_sdl_diag *items; /* formatted when they happened; delivered at the first use */
    size_t count, cap;
    int *children;        /* groups used while this one was open */
    size_t nchildren, capchildren;
    bool delivered;
} sdl_defer_group;

typedef struct sdl_rng {
    uint64_t state;
} sdl_rng;

/* ---- the parser ---------------------------------------------------------------------------- */

struct vbnl_sdl_parser {
    vbnl_sdl_limits limits;
    /* names */
    sdl_name *names;
    size_t names_cap, names_count;
    const char *kw[VBI_KW_COUNT];
    char **name_blocks; /* storage of interned strings */
    size_t name_blocks_count, name_blocks_cap;
    /* files */
    sdl_file *files;
    char **user_dirs;
    int nuser_dirs;
    char **read_dirs, **write_dirs; /* canonical folders the user opened to the scene (vbnl_sdl_permit_dir) */
    int nread_dirs, nwrite_dirs;
    char *system_dir;
    char *scene_dir;
    bool includes_enabled;
    /* frames */
    sdl_frame *frames;
    int nframes, capframes;
    int macro_depth, include_depth;
    sdl_table globals;
    /* tokens */
    vbnl_sdl_token cur, peek;
    bool have_peek;
    bool no_expand;  /* next identifier is a name, not a macro invocation */
    vbnl_sdl_loc last_loc;
    /* state */
    bool failed;
    vbnl_result fail_code;
    char fail_message[VBNL_ERROR_MESSAGE_SIZE];
    int depth;        /* C recursion guard */
    uint64_t loop_iterations, tokens;
    size_t memory;
    double language_version;
    double vbnl_version;
    int image_width, image_height;
    double clock, clock_delta, initial_clock, final_clock;
    int frame_number, clock_on, initial_frame, final_frame;
    sdl_rng *rngs;
    int nrngs, caprngs;
    vbnl_sdl_value *defaults;
    size_t ndefaults, capdefaults;
    sdl_diag_store diags;
    vbnl_sdl_diag_fn diag_fn;
    void *diag_user;
    vbnl_sdl_hooks hooks;
    vbnl_sdl_function_block_fn function_block; /* vbnl_sdl_set_function_block_hook */
    void *function_block_user;
    vbnl_sdl_object_queries object_queries; /* vbnl_sdl_set_object_queries */
    int in_vector; /* > 0: '>' closes a vector literal instead of comparing */
    int in_count;  /* > 0: '<' ends the float (a list count followed by vectors, as in mesh2) */
    unsigned warned; /* one-time warnings already given (bit per kind) */
    sdl_defer_group *defer;  /* group g is defer[g - 1] */
    int ndefer, capdefer;
    int *defer_open;         /* stack of open groups */
    int ndefer_open, capdefer_open;
};

/* value.c: interned names, tracked memory; parser.c: the recursion guard */
const char *sdl_intern(vbnl_sdl_parser *p, const char *s, size_t len, int *kw);
const char *sdl_intern_keyword(vbnl_sdl_parser *p, const char *s, int kw);
void *sdl_alloc(vbnl_sdl_parser *p, size_t n);    /* zeroed; reports OOM/limit, NULL on failure */
/* Counts n bytes the object layer holds for the scene (placed objects, their meshes) against
 * limits.max_memory, as sdl_alloc does for strings and arrays; false (error reported) past it. */
bool sdl_charge(vbnl_sdl_parser *p, size_t n);
void *sdl_realloc(vbnl_sdl_parser *p, void *ptr, size_t old, size_t n);
void sdl_free(vbnl_sdl_parser *p, void *ptr, size_t n);
char *sdl_strdup(vbnl_sdl_parser *p, const char *s, size_t len);
bool sdl_enter(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc); /* recursion guard */
void sdl_leave(vbnl_sdl_parser *p);

/* lexer.c: raw tokens from the top frame. */
void sdl_lex(vbnl_sdl_parser *p, sdl_frame *f, vbnl_sdl_token *tok);
void sdl_token_free(vbnl_sdl_token *tok);
const char *sdl_token_describe(const vbnl_sdl_token *tok, char *buf, size_t n);

/* diag.c */
void sdl_diag_emit(vbnl_sdl_parser *p, vbnl_sdl_severity sev, const vbnl_sdl_loc *loc,
                   const char *msg);
void sdl_errorf(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
void sdl_warnf(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
void sdl_diag_free(sdl_diag_store *d);
void sdl_defer_free(vbnl_sdl_parser *p);
void sdl_defer_link(vbnl_sdl_parser *p, int parent, int child);
const char *sdl_suggest(vbnl_sdl_parser *p, const char *name);

/* value.c */
void sdl_table_init(sdl_table *t);
void sdl_table_free(vbnl_sdl_parser *p, sdl_table *t);
sdl_sym *sdl_table_find(const sdl_table *t, const char *name);
sdl_sym *sdl_table_insert(vbnl_sdl_parser *p, sdl_table *t, const char *name);
bool sdl_table_remove(vbnl_sdl_parser *p, sdl_table *t, const char *name);
sdl_sym *sdl_lookup(vbnl_sdl_parser *p, const char *name);
sdl_sym *sdl_lookup_binding(vbnl_sdl_parser *p, const char *name, int *frame);
sdl_sym *sdl_resolve(vbnl_sdl_parser *p, sdl_sym *s);
vbnl_sdl_array *sdl_array_new(vbnl_sdl_parser *p, int rank, const size_t *dims);
void sdl_array_unpin(vbnl_sdl_parser *p, vbnl_sdl_array *a);
void sdl_block_release(vbnl_sdl_parser *p, vbnl_sdl_block *b);
void sdl_macro_free(vbnl_sdl_parser *p, vbnl_sdl_macro *m);
void sdl_set_float(vbnl_sdl_value *v, double f);
void sdl_set_vector(vbnl_sdl_value *v, int dim, const double *c);
bool sdl_set_string(vbnl_sdl_parser *p, vbnl_sdl_value *v, const char *s, size_t len);

/* source.c: frames and the expanded token stream. */
sdl_frame *sdl_top(vbnl_sdl_parser *p);
bool sdl_push_file(vbnl_sdl_parser *p, sdl_file *f, const vbnl_sdl_loc *from);
void sdl_pop_frame(vbnl_sdl_parser *p);
void sdl_seek(vbnl_sdl_parser *p, sdl_pos pos);
sdl_pos sdl_tell(vbnl_sdl_parser *p);
void sdl_raw(vbnl_sdl_parser *p, vbnl_sdl_token *tok); /* from the top frame, no expansion */
/* The file at `path`, read once per parse (a regular file: a FIFO or device is refused without
 * waiting on it). NULL with *why set when it cannot be opened (nothing reported), or with
 * *why NULL after an error reported here (memory). */
sdl_file *sdl_load_file(vbnl_sdl_parser *p, const char *path, const char **why);
sdl_file *sdl_add_text(vbnl_sdl_parser *p, const char *name, const char *text, size_t len);
/* The identifier (a keyword such as `sphere`) that starts at `loc` in its file, copied into buf (n
 * bytes); NULL when the file is not the parser's or no identifier starts there. For messages
 * about a statement after the parse (the object layer's checks). */
const char *sdl_word_at(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc, char *buf, size_t n);
bool sdl_invoke_macro(vbnl_sdl_parser *p, vbnl_sdl_macro *m, const vbnl_sdl_loc *loc);
bool sdl_expand_here(vbnl_sdl_parser *p);
void sdl_unread(vbnl_sdl_parser *p, const vbnl_sdl_token *tok);
sdl_cond *sdl_cond_push(vbnl_sdl_parser *p, sdl_cond_kind kind, const vbnl_sdl_loc *loc);
void sdl_cond_pop(vbnl_sdl_parser *p);
sdl_file *sdl_find_include(vbnl_sdl_parser *p, const char *name, const vbnl_sdl_loc *loc);
/* True when `path` lies in a folder a scene may read: the scene's own, an include folder given
 * to the parser, POV-Ray's (the system include folder), or one the user opened with
 * vbnl_sdl_permit_dir, followed through links; a scene is untrusted input, kept to these as
 * POV-Ray's default I/O restriction keeps it. */
bool sdl_path_readable(const vbnl_sdl_parser *p, const char *path);
/* True when the canonical `real` lies in a folder the user opened to the scene with
 * vbnl_sdl_permit_dir: for reading (any of them) or for writing (writable ones). */
bool sdl_path_permitted(const vbnl_sdl_parser *p, const char *real, bool write);
int sdl_macro_depth(vbnl_sdl_parser *p);

/* directive.c */
void sdl_directive(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash_loc);
/* Skips raw text to the next #else/#elseif/#case/#range/#break/#end at nesting 0 of the top
 * frame; returns its keyword id (0 at end of file, after an error). `kwloc` gets its loc. */
int sdl_skip_to(vbnl_sdl_parser *p, bool stop_at_else, vbnl_sdl_loc *kwloc);
bool sdl_parse_rvalue(vbnl_sdl_parser *p, vbnl_sdl_value *out);
/* frame: index of the frame whose locals get the symbol (#local), -1 (or 0) for globals */
void sdl_declare(vbnl_sdl_parser *p, const char *name, int frame, vbnl_sdl_value *val,
                 const vbnl_sdl_loc *loc);

/* expr.c */
bool sdl_expr(vbnl_sdl_parser *p, vbnl_sdl_value *out);
bool sdl_expr_float(vbnl_sdl_parser *p, double *out, const char *what);
bool sdl_expect_op(vbnl_sdl_parser *p, int op, const char *context);
bool sdl_truth(vbnl_sdl_parser *p, const vbnl_sdl_value *v, const vbnl_sdl_loc *loc);
bool sdl_parse_array_decl(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *loc);
const char *sdl_op_name(int op);

/* builtin.c */
bool sdl_builtin_call(vbnl_sdl_parser *p, int kw, const vbnl_sdl_token *tok, vbnl_sdl_value *out);
bool sdl_is_builtin(int kw);
double sdl_rng_next(sdl_rng *r);
bool sdl_to_vector(vbnl_sdl_parser *p, const vbnl_sdl_value *v, int dim, double *out,
                   const vbnl_sdl_loc *loc, const char *what);

/* spline.c */
bool sdl_parse_spline(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *loc); /* on '{' */
bool sdl_call_spline(vbnl_sdl_parser *p, const vbnl_sdl_spline *s, const vbnl_sdl_loc *loc, vbnl_sdl_value *out);
void sdl_spline_retain(vbnl_sdl_spline *s);
void sdl_spline_release(vbnl_sdl_parser *p, vbnl_sdl_spline *s);

/* func.c */
bool sdl_parse_function(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *loc);
/* The same after the keyword: `(params) { body }` or `{ body }` (height_field's function W, H { }). */
bool sdl_parse_function_body(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *loc);
bool sdl_call_function(vbnl_sdl_parser *p, const vbnl_sdl_function *f, const vbnl_sdl_loc *loc,
                       vbnl_sdl_value *out);
void sdl_function_release(vbnl_sdl_parser *p, vbnl_sdl_function *f);
/* The bytes that identify what a function computes (its expression, constants and callees'
 * expressions), for sharing what the object layer makes from equal functions; 0 when they do not
 * fit in cap or the function is a pattern (nothing is shared then). */
size_t sdl_function_key(const vbnl_sdl_function *f, unsigned char *buf, size_t cap);
void sdl_function_retain(vbnl_sdl_function *f);

#endif
