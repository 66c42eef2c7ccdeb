/* vbnl scene parser: user functions, function { ... } and function(a, b) { ... }.
 *
 * A function body compiles to a small expression tree over its parameters (x, y, z by default)
 * with the same operators and maths built-ins as SDL expressions. Declared floats are captured as
 * constants when the function is defined, declared functions are called (shared reference), so
 * the call graph is acyclic. Bodies that are patterns or pigments ("function { pattern { ... } }")
 * are read by the object layer's function_block hook, which hands back an evaluator; without the
 * hook they are kept but evaluate to 0 with a warning. A pigment function's value is its red
 * component unless a member names another: F(x, y, z).green. POV-Ray's internal(N) functions
 * that are geometry are evaluated here (f_ellipsoid, f_ph, f_r, f_rounded_box, f_sphere,
 * f_superellipsoid, f_th, f_torus: functions.inc's definitions); the others evaluate to 0 with a
 * warning. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sdl_internal.h"

enum { FN_NUM, FN_PARAM, FN_NEG, FN_NOT, FN_BIN, FN_COND, FN_BUILTIN, FN_USER, FN_INTERNAL };

typedef struct fn_node {
    int kind, op;
    double num;
    int a, b, c;      /* children */
    int args, nargs;  /* into argv */
    vbnl_sdl_function *callee;
} fn_node;

struct vbnl_sdl_function {
    int refs;
    int arity;
    const char *params[32];
    fn_node *nodes;
    int nnodes, capnodes;
    int *argv;
    int nargv, capargv;
    int root;
    bool block;       /* pattern/pigment function */
    bool has_ext;     /* ... evaluated by the object layer through ext */
    vbnl_sdl_fn_block ext;
    bool internal;    /* POV-Ray internal(N) */
    int internal_id;  /* its N */
    bool warned;
    bool detached;    /* a standalone copy (vbnl_sdl_function_detach): plain malloc, no parser */
    vbnl_sdl_loc loc;
};

typedef struct fn_ctx {
    vbnl_sdl_parser *p;
    vbnl_sdl_function *f;
    bool default_params;
} fn_ctx;

void sdl_function_retain(vbnl_sdl_function *f)
{
    if (f)
        f->refs++;
}

void sdl_function_release(vbnl_sdl_parser *p, vbnl_sdl_function *f)
{
    if (!f || --f->refs > 0)
        return;
    for (int i = 0; i < f->nnodes; i++)
        if (f->nodes[i].kind == FN_USER)
            sdl_function_release(p, f->nodes[i].callee);
    if (f->has_ext && f->ext.release)
        f->ext.release(f->ext.user);
    sdl_free(p, f->nodes, (size_t)f->capnodes * sizeof *f->nodes);
    sdl_free(p, f->argv, (size_t)f->capargv * sizeof *f->argv);
    sdl_free(p, f, sizeof *f);
}

int vbnl_sdl_function_arity(const vbnl_sdl_function *f)
{
    return f ? f->arity : 0;
}

/* Appends n bytes at *at when they fit. */
static int key_put(unsigned char *buf, size_t cap, size_t *at, const void *p, size_t n)
{
    if (n == 0)
        return 1;
    if (*at + n > cap)
        return 0;
    memcpy(buf + *at, p, n);
    *at += n;
    return 1;
}

static int key_fn(const vbnl_sdl_function *f, unsigned char *buf, size_t cap, size_t *at, int depth)
{
    if (depth > 16 || f->block || !key_put(buf, cap, at, &f->arity, sizeof f->arity) ||
        !key_put(buf, cap, at, &f->internal_id, sizeof f->internal_id) || !key_put(buf, cap, at, &f->internal, 1) ||
        !key_put(buf, cap, at, &f->root, sizeof f->root) || !key_put(buf, cap, at, &f->nnodes, sizeof f->nnodes) ||
        !key_put(buf, cap, at, f->argv, (size_t)f->nargv * sizeof *f->argv))
        return 0;
    for (int i = 0; i < f->nnodes; ++i) {
        const fn_node *n = &f->nodes[i];
        int ints[7] = {n->kind, n->op, n->a, n->b, n->c, n->args, n->nargs};
        if (!key_put(buf, cap, at, ints, sizeof ints) || !key_put(buf, cap, at, &n->num, sizeof n->num))
            return 0;
        if (n->kind == FN_USER && !key_fn(n->callee, buf, cap, at, depth + 1))
            return 0;
    }
    return 1;
}

size_t sdl_function_key(const vbnl_sdl_function *f, unsigned char *buf, size_t cap)
{
    size_t at = 0;
    return f && key_fn(f, buf, cap, &at, 0) ? at : 0;
}

static int node(fn_ctx *c, int kind)
{
    vbnl_sdl_function *f = c->f;
    if (f->nnodes == f->capnodes) {
        int cap = f->capnodes ? f->capnodes * 2 : 16;
        fn_node *q = sdl_realloc(c->p, f->nodes, (size_t)f->capnodes * sizeof *q, (size_t)cap * sizeof *q);
        if (!q)
            return -1;
        f->nodes = q;
        f->capnodes = cap;
    }
    fn_node *n = &f->nodes[f->nnodes];
    memset(n, 0, sizeof *n);
    n->kind = kind;
    n->a = n->b = n->c = -1;
    return f->nnodes++;
}

static int f_ternary(fn_ctx *c);

static int num_node(fn_ctx *c, double v)
{
    int n = node(c, FN_NUM);
    if (n >= 0)
        c->f->nodes[n].num = v;
    return n;
}

/* Parses '(' args ')' into argv; returns the count or -1. */
static int call_args(fn_ctx *c, int *first)
{
    vbnl_sdl_parser *p = c->p;
    int tmp[64], n = 0;
    if (!sdl_expect_op(p, '(', "after function name"))
        return -1;
    if (!vbnl_sdl_accept(p, ')')) {
        for (;;) {
            if (n == 64) {
                sdl_errorf(p, NULL, "too many arguments in function call (at most 64)");
                return -1;
            }
            int a = f_ternary(c);
            if (a < 0)
                return -1;
            tmp[n++] = a;
            if (vbnl_sdl_accept(p, ','))
                continue;
            if (!sdl_expect_op(p, ')', "or ',' in function call"))
                return -1;
            break;
        }
    }
    vbnl_sdl_function *f = c->f;
    if (f->nargv + n > f->capargv) {
        int cap = (f->capargv + n) * 2;
        int *q = sdl_realloc(p, f->argv, (size_t)f->capargv * sizeof *q, (size_t)cap * sizeof *q);
        if (!q)
            return -1;
        f->argv = q;
        f->capargv = cap;
    }
    *first = f->nargv;
    memcpy(f->argv + f->nargv, tmp, (size_t)n * sizeof *tmp);
    f->nargv += n;
    return n;
}

static const int fn_builtins[] = {
    VBI_KW_abs, VBI_KW_acos, VBI_KW_acosh, VBI_KW_asin, VBI_KW_asinh, VBI_KW_atan, VBI_KW_atan2,
    VBI_KW_atanh, VBI_KW_ceil, VBI_KW_cos, VBI_KW_cosh, VBI_KW_degrees, VBI_KW_div, VBI_KW_exp,
    VBI_KW_floor, VBI_KW_int, VBI_KW_ln, VBI_KW_log, VBI_KW_max, VBI_KW_min, VBI_KW_mod, VBI_KW_pow,
    VBI_KW_radians, VBI_KW_select, VBI_KW_sin, VBI_KW_sinh, VBI_KW_sqrt, VBI_KW_sqr, VBI_KW_tan,
    VBI_KW_tanh, VBI_KW_bitwise_and, VBI_KW_bitwise_or, VBI_KW_bitwise_xor, 0
};

static int f_primary(fn_ctx *c)
{
    vbnl_sdl_parser *p = c->p;
    while (sdl_expand_here(p))
        ;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    vbnl_sdl_token tok = *t;
    char b[80];
    if (t->kind == VBNL_SDL_TOK_NUMBER) {
        vbnl_sdl_next(p);
        return num_node(c, tok.number);
    }
    if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '(') {
        vbnl_sdl_next(p);
        int n = f_ternary(c);
        if (n < 0 || !sdl_expect_op(p, ')', "to close '(' in function"))
            return -1;
        return n;
    }
    if (t->kind != VBNL_SDL_TOK_IDENT) {
        sdl_errorf(p, &t->loc, "expected an expression in function body, found %s", sdl_token_describe(t, b, sizeof b));
        return -1;
    }
    vbnl_sdl_next(p);
    /* parameters first: they shadow everything */
    for (int i = 0; i < c->f->arity; i++) {
        if (c->f->params[i] == tok.text) {
            int n = node(c, FN_PARAM);
            if (n >= 0)
                c->f->nodes[n].op = i;
            return n;
        }
    }
    if (c->default_params && (tok.keyword == VBI_KW_u || tok.keyword == VBI_KW_v)) {
        int n = node(c, FN_PARAM);
        if (n >= 0)
            c->f->nodes[n].op = tok.keyword == VBI_KW_u ? 0 : 1;
        return n;
    }
    switch (tok.keyword) {
    case VBI_KW_pi: return num_node(c, M_PI);
    case VBI_KW_tau: return num_node(c, 2 * M_PI);
    case VBI_KW_true: case VBI_KW_yes: case VBI_KW_on: return num_node(c, 1);
    case VBI_KW_false: case VBI_KW_no: case VBI_KW_off: return num_node(c, 0);
    case VBI_KW_clock: return num_node(c, p->clock);
    case VBI_KW_image_width: return num_node(c, p->image_width);
    case VBI_KW_image_height: return num_node(c, p->image_height);
    case VBI_KW_internal: {
        double id;
        if (!sdl_expect_op(p, '(', "after 'internal'") || !sdl_expr_float(p, &id, "internal()") ||
            !sdl_expect_op(p, ')', "after internal() argument"))
            return -1;
        c->f->internal = true;
        c->f->internal_id = (int)id;
        return node(c, FN_INTERNAL);
    }
    default: break;
    }
    if (tok.keyword) {
        for (const int *k = fn_builtins; *k; k++) {
            if (*k != tok.keyword)
                continue;
            int n = node(c, FN_BUILTIN);
            if (n < 0)
                return -1;
            int first, na = call_args(c, &first);
            if (na < 0)
                return -1;
            fn_node *nd = &c->f->nodes[n];
            nd->op = tok.keyword;
            nd->args = first;
            nd->nargs = na;
            if (na == 0) {
                sdl_errorf(p, &tok.loc, "%s() needs arguments", tok.text);
                return -1;
            }
            return n;
        }
        sdl_errorf(p, &tok.loc, "'%s' cannot be used in a function body", tok.text);
        return -1;
    }
    sdl_sym *s = sdl_lookup(p, tok.text);
    if (!s) {
        const char *sug = sdl_suggest(p, tok.text);
        if (sug)
            sdl_errorf(p, &tok.loc, "undeclared identifier '%s' in function body; did you mean '%s'?", tok.text, sug);
        else
            sdl_errorf(p, &tok.loc, "undeclared identifier '%s' in function body", tok.text);
        return -1;
    }
    if (s->val.kind == VBNL_SDL_FLOAT)
        return num_node(c, s->val.v[0]);
    if ((s->val.kind == VBNL_SDL_VECTOR || s->val.kind == VBNL_SDL_COLOR) && vbnl_sdl_accept(p, '.')) {
        const vbnl_sdl_token *cn = vbnl_sdl_next(p);
        static const struct { int kw, idx; } comps[] = {
            { VBI_KW_x, 0 }, { VBI_KW_y, 1 }, { VBI_KW_z, 2 }, { VBI_KW_t, 3 }, { VBI_KW_u, 0 }, { VBI_KW_v, 1 },
            { VBI_KW_red, 0 }, { VBI_KW_green, 1 }, { VBI_KW_blue, 2 }, { VBI_KW_filter, 3 }, { VBI_KW_transmit, 4 },
        };
        for (size_t i = 0; i < sizeof comps / sizeof comps[0]; i++)
            if (cn->keyword == comps[i].kw && comps[i].idx < s->val.dim)
                return num_node(c, s->val.v[comps[i].idx]);
        sdl_errorf(p, &cn->loc, "invalid component '.%s' of vector '%s'", cn->text, tok.text);
        return -1;
    }
    if (s->val.kind == VBNL_SDL_FUNCTION) {
        vbnl_sdl_function *callee = s->val.u.fn;
        int n = node(c, FN_USER);
        if (n < 0)
            return -1;
        sdl_function_retain(callee);
        c->f->nodes[n].callee = callee;
        int first, na = call_args(c, &first);
        if (na < 0)
            return -1;
        c->f->nodes[n].args = first;
        c->f->nodes[n].nargs = na;
        if (vbnl_sdl_accept(p, '.')) { /* a component of a pigment (or spline) function's value */
            const vbnl_sdl_token *cn = vbnl_sdl_next(p);
            static const struct { int kw, idx; } comps[] = {
                { VBI_KW_x, 0 }, { VBI_KW_y, 1 }, { VBI_KW_z, 2 }, { VBI_KW_t, 4 }, { VBI_KW_red, 0 },
                { VBI_KW_green, 1 }, { VBI_KW_blue, 2 }, { VBI_KW_filter, 3 }, { VBI_KW_transmit, 4 },
            };
            int idx = -1;
            for (size_t i = 0; i < sizeof comps / sizeof comps[0]; i++)
                if (cn->keyword == comps[i].kw)
                    idx = comps[i].idx;
            if (cn->keyword == VBI_KW_gray)
                idx = 5;
            /* a block function (pigment, spline) gives a colour or a vector; a float function none */
            if (idx < 0 || !callee->block || (callee->has_ext && callee->ext.dims < 5)) {
                sdl_errorf(p, &cn->loc, "'.%s': only a pigment or spline function's value has components", cn->text);
                return -1;
            }
            c->f->nodes[n].op = idx;
        }
        return n;
    }
    sdl_errorf(p, &tok.loc, "'%s' is a %s; a function body can use floats and functions", tok.text,
               vbnl_sdl_kind_name(s->val.kind));
    return -1;
}

static int f_unary(fn_ctx *c)
{
    vbnl_sdl_parser *p = c->p;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_PUNCT && (t->op == '-' || t->op == '+' || t->op == '!')) {
        int op = t->op;
        vbnl_sdl_loc loc = t->loc;
        vbnl_sdl_next(p);
        if (!sdl_enter(p, &loc))
            return -1;
        int a = f_unary(c);
        sdl_leave(p);
        if (a < 0 || op == '+')
            return a;
        int n = node(c, op == '-' ? FN_NEG : FN_NOT);
        if (n >= 0)
            c->f->nodes[n].a = a;
        return n;
    }
    return f_primary(c);
}

static int f_level(fn_ctx *c, int level);

static const int fn_ops[][8] = {
    { '|', 0 },
    { '&', 0 },
    { '<', '>', VBNL_SDL_OP_LE, VBNL_SDL_OP_GE, '=', VBNL_SDL_OP_EQ2, VBNL_SDL_OP_NE, 0 },
    { '+', '-', 0 },
    { '*', '/', 0 },
};

static int f_level(fn_ctx *c, int level)
{
    if (level == 5)
        return f_unary(c);
    int a = f_level(c, level + 1);
    while (a >= 0) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(c->p);
        if (t->kind != VBNL_SDL_TOK_PUNCT)
            break;
        int op = t->op;
        bool match = false;
        for (const int *o = fn_ops[level]; *o; o++)
            match |= *o == op;
        if (!match)
            break;
        vbnl_sdl_next(c->p);
        int b = f_level(c, level + 1);
        if (b < 0)
            return -1;
        int n = node(c, FN_BIN);
        if (n < 0)
            return -1;
        c->f->nodes[n].op = op;
        c->f->nodes[n].a = a;
        c->f->nodes[n].b = b;
        a = n;
    }
    return a;
}

static int f_ternary(fn_ctx *c)
{
    vbnl_sdl_loc loc = vbnl_sdl_peek(c->p)->loc;
    if (!sdl_enter(c->p, &loc))
        return -1;
    int a = f_level(c, 0);
    if (a >= 0 && vbnl_sdl_accept(c->p, '?')) {
        int b = f_ternary(c);
        int d = -1;
        if (b >= 0 && sdl_expect_op(c->p, ':', "in conditional expression"))
            d = f_ternary(c);
        int n = d >= 0 ? node(c, FN_COND) : -1;
        if (n >= 0) {
            c->f->nodes[n].a = a;
            c->f->nodes[n].b = b;
            c->f->nodes[n].c = d;
        }
        a = n;
    }
    sdl_leave(c->p);
    return c->p->failed ? -1 : a;
}

bool sdl_parse_function(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *loc)
{
    vbnl_sdl_next(p); /* function */
    return sdl_parse_function_body(p, out, loc);
}

bool sdl_parse_function_body(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *loc)
{
    memset(out, 0, sizeof *out);
    vbnl_sdl_function *f = sdl_alloc(p, sizeof *f);
    if (!f)
        return false;
    f->refs = 1;
    f->loc = *loc;
    f->root = -1;
    fn_ctx c = { p, f, true };
    if (vbnl_sdl_accept(p, '(')) {
        c.default_params = false;
        if (!vbnl_sdl_accept(p, ')')) {
            for (;;) {
                const vbnl_sdl_token *t = vbnl_sdl_next(p);
                /* x, y, z, u, v are keywords but legal parameter names */
                if (t->kind != VBNL_SDL_TOK_IDENT || (t->keyword && t->keyword != VBI_KW_x && t->keyword != VBI_KW_y &&
                                                      t->keyword != VBI_KW_z && t->keyword != VBI_KW_u &&
                                                      t->keyword != VBI_KW_v && t->keyword != VBI_KW_t)) {
                    char b[80];
                    sdl_errorf(p, &t->loc, "expected a parameter name in function(...), found %s", sdl_token_describe(t, b, sizeof b));
                    goto fail;
                }
                if (f->arity == 32) {
                    sdl_errorf(p, &t->loc, "too many function parameters (at most 32)");
                    goto fail;
                }
                f->params[f->arity++] = t->text;
                if (vbnl_sdl_accept(p, ','))
                    continue;
                if (!sdl_expect_op(p, ')', "or ',' in function parameters"))
                    goto fail;
                break;
            }
        }
    } else {
        f->arity = 3;
        f->params[0] = p->kw[VBI_KW_x];
        f->params[1] = p->kw[VBI_KW_y];
        f->params[2] = p->kw[VBI_KW_z];
    }
    if (!sdl_expect_op(p, '{', "to start the function body"))
        goto fail;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    bool is_param = false;
    for (int i = 0; i < f->arity; i++)
        is_param |= t->kind == VBNL_SDL_TOK_IDENT && f->params[i] == t->text;
    if (t->kind == VBNL_SDL_TOK_IDENT && !t->keyword && !is_param && !sdl_lookup(p, t->text)) {
        /* function { pattern { ... } } and friends: the object layer's evaluator, or an
         * unevaluated block */
        vbnl_sdl_token kw = *vbnl_sdl_next(p);
        const vbnl_sdl_token *b = vbnl_sdl_peek(p);
        if (b->kind == VBNL_SDL_TOK_PUNCT && b->op == '{' && p->function_block) {
            vbnl_sdl_fn_block ext;
            memset(&ext, 0, sizeof ext);
            int r = p->function_block(p, &kw, &ext, p->function_block_user);
            if (r < 0)
                goto fail;
            if (r > 0) {
                f->block = true;
                f->has_ext = ext.eval != NULL;
                f->ext = ext;
                if (!f->has_ext && ext.release)
                    ext.release(ext.user);
                if (!sdl_expect_op(p, '}', "to close the function body"))
                    goto fail;
                goto done;
            }
            b = vbnl_sdl_peek(p);
        }
        if (b->kind == VBNL_SDL_TOK_PUNCT && b->op == '{') {
            if (vbnl_sdl_skip_block(p) != VBNL_OK)
                goto fail;
            f->block = true;
            if (!sdl_expect_op(p, '}', "to close the function body"))
                goto fail;
            goto done;
        }
        const char *sug = sdl_suggest(p, kw.text);
        if (sug)
            sdl_errorf(p, &kw.loc, "undeclared identifier '%s' in function body; did you mean '%s'?", kw.text, sug);
        else
            sdl_errorf(p, &kw.loc, "undeclared identifier '%s' in function body", kw.text);
        goto fail;
    }
    f->root = f_ternary(&c);
    if (f->root < 0 || !sdl_expect_op(p, '}', "to close the function body"))
        goto fail;
done:
    out->kind = VBNL_SDL_FUNCTION;
    out->u.fn = f;
    return true;
fail:
    sdl_function_release(p, f);
    return false;
}

/* ---- evaluation -------------------------------------------------------------------------- */

typedef struct fn_eval {
    vbnl_sdl_parser *p;
    uint64_t steps;
    int depth;
    bool failed;
} fn_eval;

static double eval(fn_eval *e, vbnl_sdl_function *f, int n, const double *args, int nargs);

/* A block function's value: component `comp` of what the object layer's evaluator gives at
 * (x, y, z) (5: a colour's grey, POV-Ray's 0.297 r + 0.589 g + 0.114 b). */
static double call_ext(const vbnl_sdl_function *g, const double *args, int nargs, int comp, double col[5])
{
    double q[3] = { 0, 0, 0 }, v[5] = { 0, 0, 0, 0, 0 };
    for (int i = 0; i < 3 && i < nargs; i++)
        q[i] = args[i];
    g->ext.eval(g->ext.user, q, v);
    if (col)
        memcpy(col, v, sizeof v);
    if (comp == 5)
        return 0.297 * v[0] + 0.589 * v[1] + 0.114 * v[2];
    return comp >= 0 && comp < 5 ? v[comp] : v[0];
}

/* POV-Ray's internal functions (functions.inc) that are geometry, by their documented definitions;
 * -1 for the others (noise and patterns belong to the texture part). args: x, y, z, then the
 * function's own parameters. */
static int internal_eval(int id, const double *a, int n, double *out)
{
    double x = a[0], y = n > 1 ? a[1] : 0, z = n > 2 ? a[2] : 0, p[4] = {0, 0, 0, 0};
    for (int i = 0; i < 4 && 3 + i < n; ++i)
        p[i] = a[3 + i];
    switch (id) {
    case 17: /* f_ellipsoid(x, y, z, sx, sy, sz) */
        *out = sqrt(x * x * p[0] * p[0] + y * y * p[1] * p[1] + z * z * p[2] * p[2]);
        return 0;
    case 47: /* f_ph: the angle from +y */
        *out = atan2(sqrt(x * x + z * z), y);
        return 0;
    case 57: /* f_r */
        *out = sqrt(x * x + y * y + z * z);
        return 0;
    case 60: { /* f_rounded_box(x, y, z, radius, sx, sy, sz): the distance to the box shrunk by the
                * radius, less the radius */
        double d[3] = {fabs(x) - (p[1] - p[0]), fabs(y) - (p[2] - p[0]), fabs(z) - (p[3] - p[0])}, s2 = 0;
        for (int k = 0; k < 3; ++k)
            s2 += d[k] > 0 ? d[k] * d[k] : 0;
        *out = sqrt(s2) - p[0] - 1e-6;
        return 0;
    }
    case 61: /* f_sphere(x, y, z, radius) */
        *out = sqrt(x * x + y * y + z * z) - p[0];
        return 0;
    case 68: /* f_superellipsoid(x, y, z, e, n): positive inside */
        *out = 1 - pow(pow(pow(fabs(x), 2 / p[0]) + pow(fabs(y), 2 / p[0]), p[0] / p[1]) + pow(fabs(z), 2 / p[1]), p[1] / 2);
        return 0;
    case 69: /* f_th: the angle around y from +z towards +x */
        *out = atan2(x, z);
        return 0;
    case 70: { /* f_torus(x, y, z, major, minor) */
        double r = sqrt(x * x + z * z) - p[0];
        *out = sqrt(r * r + y * y) - p[1];
        return 0;
    }
    default:
        return -1;
    }
}

static double call_user(fn_eval *e, vbnl_sdl_function *g, const double *args, int nargs)
{
    if (g->has_ext)
        return call_ext(g, args, nargs, 0, NULL);
    double v;
    if (g->internal && internal_eval(g->internal_id, args, nargs, &v) == 0)
        return v;
    if (g->block || g->internal || g->root < 0) {
        if (e->p && !g->warned) {
            g->warned = true;
            sdl_warnf(e->p, &g->loc, "%s function evaluated as 0 (needs the object layer)",
                      g->internal ? "internal" : "pattern");
        }
        return 0;
    }
    return eval(e, g, g->root, args, nargs);
}

static double eval(fn_eval *e, vbnl_sdl_function *f, int n, const double *args, int nargs)
{
    if (e->failed)
        return 0;
    if (++e->steps > 200000000ull || ++e->depth > 20000) {
        if (e->p)
            sdl_errorf(e->p, &f->loc, "function evaluation too deep or too long");
        e->failed = true;
        return 0;
    }
    const fn_node *nd = &f->nodes[n];
    double r = 0, a, b;
    switch (nd->kind) {
    case FN_NUM: r = nd->num; break;
    case FN_PARAM: r = nd->op < nargs ? args[nd->op] : 0; break;
    case FN_NEG: r = -eval(e, f, nd->a, args, nargs); break;
    case FN_NOT: r = fabs(eval(e, f, nd->a, args, nargs)) > 1e-10 ? 0 : 1; break;
    case FN_COND: r = fabs(eval(e, f, nd->a, args, nargs)) > 1e-10 ? eval(e, f, nd->b, args, nargs) : eval(e, f, nd->c, args, nargs); break;
    case FN_INTERNAL: r = call_user(e, f, args, nargs); break;
    case FN_BIN:
        a = eval(e, f, nd->a, args, nargs);
        b = eval(e, f, nd->b, args, nargs);
        switch (nd->op) {
        case '+': r = a + b; break;
        case '-': r = a - b; break;
        case '*': r = a * b; break;
        case '/': r = a / b; break;
        case '<': r = a < b; break;
        case '>': r = a > b; break;
        case VBNL_SDL_OP_LE: r = a <= b; break;
        case VBNL_SDL_OP_GE: r = a >= b; break;
        case '=': case VBNL_SDL_OP_EQ2: r = a == b; break;
        case VBNL_SDL_OP_NE: r = a != b; break;
        case '&': r = fabs(a) > 1e-10 && fabs(b) > 1e-10; break;
        case '|': r = fabs(a) > 1e-10 || fabs(b) > 1e-10; break;
        default: break;
        }
        break;
    case FN_USER: {
        double av[64];
        for (int i = 0; i < nd->nargs; i++)
            av[i] = eval(e, f, f->argv[nd->args + i], args, nargs);
        r = nd->callee->has_ext ? call_ext(nd->callee, av, nd->nargs, nd->op, NULL)
                                : call_user(e, nd->callee, av, nd->nargs);
        break;
    }
    case FN_BUILTIN: {
        double av[64];
        int k = nd->nargs;
        av[0] = 0;
        if (nd->op == VBI_KW_select) {
            double s = eval(e, f, f->argv[nd->args], args, nargs);
            int pick = k == 3 ? (s < 0 ? 1 : 2) : (s < 0 ? 1 : s == 0 ? 2 : 3);
            r = pick < k ? eval(e, f, f->argv[nd->args + pick], args, nargs) : 0;
            break;
        }
        for (int i = 0; i < k; i++)
            av[i] = eval(e, f, f->argv[nd->args + i], args, nargs);
        double x = av[0], y = k > 1 ? av[1] : 0;
        switch (nd->op) {
        case VBI_KW_abs: r = fabs(x); break;
        case VBI_KW_acos: r = acos(x); break;
        case VBI_KW_acosh: r = acosh(x); break;
        case VBI_KW_asin: r = asin(x); break;
        case VBI_KW_asinh: r = asinh(x); break;
        case VBI_KW_atan: r = atan(x); break;
        case VBI_KW_atan2: r = atan2(x, y); break;
        case VBI_KW_atanh: r = atanh(x); break;
        case VBI_KW_ceil: r = ceil(x); break;
        case VBI_KW_cos: r = cos(x); break;
        case VBI_KW_cosh: r = cosh(x); break;
        case VBI_KW_degrees: r = x * 180 / M_PI; break;
        case VBI_KW_radians: r = x * M_PI / 180; break;
        case VBI_KW_div: r = trunc(x / y); break;
        case VBI_KW_mod: r = fmod(x, y); break;
        case VBI_KW_exp: r = exp(x); break;
        case VBI_KW_floor: r = floor(x); break;
        case VBI_KW_int: r = trunc(x); break;
        case VBI_KW_ln: r = log(x); break;
        case VBI_KW_log: r = log10(x); break;
        case VBI_KW_pow: r = pow(x, y); break;
        case VBI_KW_sin: r = sin(x); break;
        case VBI_KW_sinh: r = sinh(x); break;
        case VBI_KW_sqrt: r = sqrt(x); break;
        case VBI_KW_sqr: r = x * x; break;
        case VBI_KW_tan: r = tan(x); break;
        case VBI_KW_tanh: r = tanh(x); break;
        case VBI_KW_min: case VBI_KW_max:
            r = x;
            for (int i = 1; i < k; i++)
                r = nd->op == VBI_KW_min ? fmin(r, av[i]) : fmax(r, av[i]);
            break;
        case VBI_KW_bitwise_and: case VBI_KW_bitwise_or: case VBI_KW_bitwise_xor: {
            long long acc = fabs(x) < 9e18 ? (long long)x : 0;
            for (int i = 1; i < k; i++) {
                long long v = fabs(av[i]) < 9e18 ? (long long)av[i] : 0;
                acc = nd->op == VBI_KW_bitwise_and ? (acc & v) : nd->op == VBI_KW_bitwise_or ? (acc | v) : (acc ^ v);
            }
            r = (double)acc;
            break;
        }
        default: break;
        }
        break;
    }
    default: break;
    }
    e->depth--;
    return r;
}

vbnl_result vbnl_sdl_function_call(vbnl_sdl_parser *p, const vbnl_sdl_function *f, const double *args, int n,
                                   double *out)
{
    if (!p || !f || !out || (n > 0 && !args))
        return VBNL_ERR_INVALID_ARGUMENT;
    fn_eval e = { p, 0, 0, false };
    double av[64] = { 0 };
    for (int i = 0; i < n && i < 64; i++)
        av[i] = args[i];
    *out = call_user(&e, (vbnl_sdl_function *)f, av, n < 64 ? n : 64);
    return e.failed ? VBNL_ERR_PARSE : VBNL_OK;
}

bool sdl_call_function(vbnl_sdl_parser *p, const vbnl_sdl_function *f, const vbnl_sdl_loc *loc, vbnl_sdl_value *out)
{
    double av[64];
    int n = 0;
    memset(out, 0, sizeof *out);
    if (!sdl_expect_op(p, '(', "after function name"))
        return false;
    if (!vbnl_sdl_accept(p, ')')) {
        for (;;) {
            if (n == 64) {
                sdl_errorf(p, loc, "too many arguments in function call (at most 64)");
                return false;
            }
            if (!sdl_expr_float(p, &av[n], "a function argument"))
                return false;
            n++;
            if (vbnl_sdl_accept(p, ','))
                continue;
            if (!sdl_expect_op(p, ')', "or ',' in function call"))
                return false;
            break;
        }
    }
    if (n != f->arity && !f->internal && !f->block) {
        sdl_errorf(p, loc, "function expects %d argument%s, got %d", f->arity, f->arity == 1 ? "" : "s", n);
        return false;
    }
    if (f->has_ext && f->ext.dims >= 5) { /* a pigment function gives its colour */
        double col[5];
        call_ext(f, av, n, 0, col);
        out->kind = VBNL_SDL_COLOR;
        out->dim = 5;
        memcpy(out->v, col, sizeof col);
        return true;
    }
    double r;
    if (vbnl_sdl_function_call(p, f, av, n, &r) != VBNL_OK)
        return false;
    sdl_set_float(out, r);
    return true;
}

/* ---- detached copies (evaluated while rendering) ------------------------------------------------ */

vbnl_sdl_function *vbnl_sdl_function_detach(const vbnl_sdl_function *f)
{
    if (!f)
        return NULL;
    vbnl_sdl_function *d = malloc(sizeof *d);
    if (!d)
        return NULL;
    *d = *f;
    d->refs = 1;
    d->detached = true;
    if (d->has_ext && d->ext.retain)
        d->ext.retain(d->ext.user);
    d->nodes = d->nnodes ? malloc((size_t)d->nnodes * sizeof *d->nodes) : NULL;
    d->argv = d->nargv ? malloc((size_t)d->nargv * sizeof *d->argv) : NULL;
    d->capnodes = d->nnodes;
    d->capargv = d->nargv;
    if ((d->nnodes && !d->nodes) || (d->nargv && !d->argv)) {
        free(d->nodes);
        free(d->argv);
        free(d);
        return NULL;
    }
    if (d->nnodes)
        memcpy(d->nodes, f->nodes, (size_t)d->nnodes * sizeof *d->nodes);
    if (d->nargv)
        memcpy(d->argv, f->argv, (size_t)d->nargv * sizeof *d->argv);
    for (int i = 0; i < d->nnodes; i++) {
        if (d->nodes[i].kind != FN_USER)
            continue;
        d->nodes[i].callee = vbnl_sdl_function_detach(f->nodes[i].callee);
        if (!d->nodes[i].callee) {
            d->nnodes = i; /* free what was copied */
            vbnl_sdl_function_free_detached(d);
            return NULL;
        }
    }
    return d;
}

void vbnl_sdl_function_free_detached(vbnl_sdl_function *f)
{
    if (!f || !f->detached || --f->refs > 0)
        return;
    for (int i = 0; i < f->nnodes; i++)
        if (f->nodes[i].kind == FN_USER)
            vbnl_sdl_function_free_detached(f->nodes[i].callee);
    if (f->has_ext && f->ext.release)
        f->ext.release(f->ext.user);
    free(f->nodes);
    free(f->argv);
    free(f);
}

double vbnl_sdl_function_eval_detached(const vbnl_sdl_function *f, const double *args, int n)
{
    fn_eval e = { NULL, 0, 0, false };
    double av[64] = { 0 };
    for (int i = 0; i < n && i < 64; i++)
        av[i] = args[i];
    double r = call_user(&e, (vbnl_sdl_function *)f, av, n < 64 ? n : 64);
    return e.failed ? 0.0 : r;
}
