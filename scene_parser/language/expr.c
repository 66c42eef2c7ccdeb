/* vbnl scene parser: expressions (floats, vectors, colours, strings, arrays, operators).
 *
 * Precedence, lowest first (as POV-Ray): ?:  |  &  comparisons  + -  * /  unary + - !
 * then postfix .x/.red/... Vectors and colours combine component-wise; a float meets a vector by
 * being promoted to all components; a vector meets a longer one by padding with zeros. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sdl_internal.h"

#define VBI_SDL_EPSILON 1e-10

static bool ternary(vbnl_sdl_parser *p, vbnl_sdl_value *out);
static bool additive(vbnl_sdl_parser *p, vbnl_sdl_value *out);

const char *sdl_op_name(int op)
{
    static char buf[8][2];
    static const char *const two[] = { "<=", ">=", "!=", "==" };
    if (op >= VBNL_SDL_OP_LE && op <= VBNL_SDL_OP_EQ2)
        return two[op - VBNL_SDL_OP_LE];
    (void)buf;
    switch (op) {
    case '(': return "("; case ')': return ")"; case '[': return "["; case ']': return "]";
    case '{': return "{"; case '}': return "}"; case '<': return "<"; case '>': return ">";
    case ',': return ","; case ';': return ";"; case '=': return "="; case ':': return ":";
    case '?': return "?"; case '.': return "."; default: return "?";
    }
}

bool sdl_expect_op(vbnl_sdl_parser *p, int op, const char *context)
{
    if (p->failed)
        return false;
    if (vbnl_sdl_accept(p, op))
        return true;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (p->failed)
        return false;
    char b[80];
    sdl_errorf(p, &t->loc, "expected '%s' %s, found %s", sdl_op_name(op), context, sdl_token_describe(t, b, sizeof b));
    return false;
}

vbnl_result vbnl_sdl_expect(vbnl_sdl_parser *p, int op, const char *context)
{
    if (!p)
        return VBNL_ERR_INVALID_ARGUMENT;
    return sdl_expect_op(p, op, context ? context : "") ? VBNL_OK : VBNL_ERR_PARSE;
}

static bool is_num(const vbnl_sdl_value *v)
{
    return v->kind == VBNL_SDL_FLOAT || v->kind == VBNL_SDL_VECTOR || v->kind == VBNL_SDL_COLOR;
}

static const char *kind_of(const vbnl_sdl_value *v)
{
    return vbnl_sdl_kind_name(v->kind);
}

bool sdl_truth(vbnl_sdl_parser *p, const vbnl_sdl_value *v, const vbnl_sdl_loc *loc)
{
    if (v->kind == VBNL_SDL_FLOAT)
        return fabs(v->v[0]) > VBI_SDL_EPSILON;
    if (!p->failed)
        sdl_errorf(p, loc, "expected a float condition, found a %s", kind_of(v));
    return false;
}

bool sdl_expr_float(vbnl_sdl_parser *p, double *out, const char *what)
{
    vbnl_sdl_value v;
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    *out = 0;
    if (!sdl_expr(p, &v))
        return false;
    if (v.kind != VBNL_SDL_FLOAT) {
        sdl_errorf(p, &loc, "expected a float for %s, found a %s", what, kind_of(&v));
        vbnl_sdl_value_clear(p, &v);
        return false;
    }
    *out = v.v[0];
    return true;
}

/* Makes a and b the same shape for a component-wise operation. */
static bool promote(vbnl_sdl_parser *p, vbnl_sdl_value *a, vbnl_sdl_value *b, int op, const vbnl_sdl_loc *loc)
{
    if (!is_num(a) || !is_num(b)) {
        char opn[4];
        snprintf(opn, sizeof opn, "%s", op < 256 ? (char[]){ (char)op, 0 } : sdl_op_name(op));
        sdl_errorf(p, loc, "operator '%s' cannot combine a %s and a %s", opn, kind_of(a), kind_of(b));
        return false;
    }
    if (a->kind == VBNL_SDL_FLOAT && b->kind == VBNL_SDL_FLOAT)
        return true;
    int dim = a->dim > b->dim ? a->dim : b->dim;
    vbnl_sdl_kind kind = (a->kind == VBNL_SDL_COLOR || b->kind == VBNL_SDL_COLOR) ? VBNL_SDL_COLOR : VBNL_SDL_VECTOR;
    if (kind == VBNL_SDL_COLOR)
        dim = 5;
    vbnl_sdl_value *vs[2] = { a, b };
    for (int k = 0; k < 2; k++) {
        vbnl_sdl_value *v = vs[k];
        if (v->kind == VBNL_SDL_FLOAT) {
            for (int i = 1; i < dim; i++)
                v->v[i] = v->v[0];
        } else {
            for (int i = v->dim; i < dim; i++)
                v->v[i] = 0;
        }
        v->kind = kind;
        v->dim = dim;
    }
    return true;
}

static bool binop(vbnl_sdl_parser *p, int op, vbnl_sdl_value *a, vbnl_sdl_value *b, const vbnl_sdl_loc *loc)
{
    if (a->kind == VBNL_SDL_STRING && b->kind == VBNL_SDL_STRING && op != '+' && op != '-' && op != '*' &&
        op != '/' && op != '&' && op != '|') {
        int c = strcmp(a->u.str.s, b->u.str.s);
        double r = 0;
        switch (op) {
        case '<': r = c < 0; break;
        case '>': r = c > 0; break;
        case VBNL_SDL_OP_LE: r = c <= 0; break;
        case VBNL_SDL_OP_GE: r = c >= 0; break;
        case VBNL_SDL_OP_NE: r = c != 0; break;
        default: r = c == 0; break;
        }
        vbnl_sdl_value_clear(p, a);
        sdl_set_float(a, r);
        return true;
    }
    if (!promote(p, a, b, op, loc))
        return false;
    int n = a->kind == VBNL_SDL_FLOAT ? 1 : a->dim;
    for (int i = 0; i < n; i++) {
        double x = a->v[i], y = b->v[i], r = 0;
        switch (op) {
        case '+': r = x + y; break;
        case '-': r = x - y; break;
        case '*': r = x * y; break;
        case '/':
            if (y == 0) {
                sdl_errorf(p, loc, "division by zero");
                return false;
            }
            r = x / y;
            break;
        case '<': r = x < y; break;
        case '>': r = x > y; break;
        case VBNL_SDL_OP_LE: r = x <= y; break;
        case VBNL_SDL_OP_GE: r = x >= y; break;
        case '=': case VBNL_SDL_OP_EQ2: r = x == y; break;
        case VBNL_SDL_OP_NE: r = x != y; break;
        case '&': r = fabs(x) > VBI_SDL_EPSILON && fabs(y) > VBI_SDL_EPSILON; break;
        case '|': r = fabs(x) > VBI_SDL_EPSILON || fabs(y) > VBI_SDL_EPSILON; break;
        default: break;
        }
        a->v[i] = r;
    }
    return true;
}

bool sdl_to_vector(vbnl_sdl_parser *p, const vbnl_sdl_value *v, int dim, double *out,
                   const vbnl_sdl_loc *loc, const char *what)
{
    if (v->kind == VBNL_SDL_FLOAT) {
        for (int i = 0; i < dim; i++)
            out[i] = v->v[0];
        return true;
    }
    if (v->kind == VBNL_SDL_VECTOR || (v->kind == VBNL_SDL_COLOR && dim == 5)) {
        for (int i = 0; i < dim; i++)
            out[i] = i < v->dim ? v->v[i] : 0;
        return true;
    }
    sdl_errorf(p, loc, "expected a vector for %s, found a %s", what, kind_of(v));
    return false;
}

/* ---- colours ------------------------------------------------------------------------------- */

/* The sRGB transfer function's decoding (IEC 61966-2-1), as POV-Ray's SRGBGammaCurve::Decode:
 * linear below 0.04045 (negative values included), a 2.4 power above. */
static double sdl_srgb_decode(double v) { return v < 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }

static bool color_body_inner(vbnl_sdl_parser *p, vbnl_sdl_value *out, bool keyword_seen);

static bool color_body(vbnl_sdl_parser *p, vbnl_sdl_value *out, bool keyword_seen)
{
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    if (!sdl_enter(p, &loc))
        return false;
    bool ok = color_body_inner(p, out, keyword_seen);
    sdl_leave(p);
    return ok && !p->failed;
}

static bool color_body_inner(vbnl_sdl_parser *p, vbnl_sdl_value *out, bool keyword_seen)
{
    double c[5] = { 0, 0, 0, 0, 0 };
    bool any = false;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        int kw = t->kind == VBNL_SDL_TOK_IDENT ? t->keyword : 0;
        int first = -1, count = 0, srgb = 0;
        switch (kw) {
        case VBI_KW_srgb: srgb = 1; /* fall through */
        case VBI_KW_rgb: first = 0; count = 3; break;
        case VBI_KW_srgbf: srgb = 1; /* fall through */
        case VBI_KW_rgbf: first = 0; count = 4; break;
        case VBI_KW_srgbt: srgb = 1; /* fall through */
        case VBI_KW_rgbt: first = 0; count = -4; break;
        case VBI_KW_srgbft: srgb = 1; /* fall through */
        case VBI_KW_rgbft: first = 0; count = 5; break;
        case VBI_KW_red: first = 0; count = 1; break;
        case VBI_KW_green: first = 1; count = 1; break;
        case VBI_KW_blue: first = 2; count = 1; break;
        case VBI_KW_filter: first = 3; count = 1; break;
        case VBI_KW_transmit: first = 4; count = 1; break;
        default: break;
        }
        vbnl_sdl_value v;
        if (first < 0) {
            bool start = t->kind == VBNL_SDL_TOK_NUMBER ||
                         (t->kind == VBNL_SDL_TOK_IDENT && !(t->keyword >= VBI_KW_declare && t->keyword <= VBI_KW_optional)) ||
                         (t->kind == VBNL_SDL_TOK_PUNCT && (t->op == '<' || t->op == '(' || t->op == '-' || t->op == '+'));
            if (any || !start)
                break;
            if (!additive(p, &v))
                return false;
            double tmp[5];
            if (v.kind == VBNL_SDL_COLOR) {
                memcpy(c, v.v, sizeof c);
            } else if (sdl_to_vector(p, &v, 5, tmp, &loc, "a color")) {
                memcpy(c, tmp, sizeof c);
            } else {
                vbnl_sdl_value_clear(p, &v);
                return false;
            }
            any = true;
            continue;
        }
        /* A whole-colour keyword after the colour has begun starts the next colour (POV-Ray's
         * Parse_Colour): `checker rgb <1,0,0> rgb <0,0,1>` is two colours. */
        if (any && count != 1)
            break;
        const char *kwname = t->text;
        vbnl_sdl_next(p);
        if (!additive(p, &v))
            return false;
        if (count == 1) {
            if (v.kind != VBNL_SDL_FLOAT) {
                sdl_errorf(p, &loc, "expected a float after '%s', found a %s", kwname, kind_of(&v));
                vbnl_sdl_value_clear(p, &v);
                return false;
            }
            c[first] = v.v[0];
        } else {
            int n = count < 0 ? 4 : count;
            double tmp[5] = { 0 };
            if (v.kind == VBNL_SDL_COLOR) {
                memcpy(tmp, v.v, sizeof tmp);
            } else if (!sdl_to_vector(p, &v, n, tmp, &loc, "a color")) {
                vbnl_sdl_value_clear(p, &v);
                return false;
            }
            if (v.kind == VBNL_SDL_FLOAT && n > 3)
                tmp[3] = n == 5 ? tmp[0] : tmp[0];
            c[0] = tmp[0]; c[1] = tmp[1]; c[2] = tmp[2];
            c[3] = 0; c[4] = 0;
            if (count == 4) c[3] = tmp[3];
            if (count == -4) c[4] = tmp[3];
            if (count == 5) { c[3] = tmp[3]; c[4] = tmp[4]; }
            /* srgb*: the colour channels are sRGB-encoded (POV-Ray decodes them into its working
             * space; vbnl's is linear, POV-Ray's assumed_gamma 1.0); filter and transmit are not */
            for (int i = 0; srgb && i < 3; i++)
                c[i] = sdl_srgb_decode(c[i]);
        }
        any = true;
    }
    if (!any && keyword_seen) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        char b[80];
        sdl_errorf(p, &t->loc, "expected a color after 'color', found %s", sdl_token_describe(t, b, sizeof b));
        return false;
    }
    memset(out, 0, sizeof *out);
    out->kind = VBNL_SDL_COLOR;
    out->dim = 5;
    memcpy(out->v, c, sizeof c);
    return any;
}

vbnl_result vbnl_sdl_parse_color(vbnl_sdl_parser *p, double out[5])
{
    if (!p || !out)
        return VBNL_ERR_INVALID_ARGUMENT;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    bool kw = t->keyword == VBI_KW_color || t->keyword == VBI_KW_colour;
    if (kw)
        vbnl_sdl_next(p);
    vbnl_sdl_value v;
    if (!color_body(p, &v, true))
        return VBNL_ERR_PARSE;
    memcpy(out, v.v, 5 * sizeof *out);
    return VBNL_OK;
}

/* ---- primaries ----------------------------------------------------------------------------- */

static bool vector_literal(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *open)
{
    double c[5];
    int n = 0;
    p->in_vector++;
    for (;;) {
        vbnl_sdl_value v;
        vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
        if (!ternary(p, &v))
            break;
        if (v.kind != VBNL_SDL_FLOAT) {
            sdl_errorf(p, &loc, "vector components must be floats, found a %s", kind_of(&v));
            vbnl_sdl_value_clear(p, &v);
            break;
        }
        if (n == 5) {
            sdl_errorf(p, &loc, "too many components in vector (at most 5)");
            break;
        }
        c[n++] = v.v[0];
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == ',') {
            vbnl_sdl_next(p);
            /* POV-Ray accepts a comma before the closing '>': <0.2, 0.1, 0.5,> */
            t = vbnl_sdl_peek(p);
            if (!(t->kind == VBNL_SDL_TOK_PUNCT && t->op == '>'))
                continue;
        }
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '>') {
            vbnl_sdl_next(p);
            p->in_vector--;
            if (n < 2) {
                sdl_errorf(p, open, "a vector needs at least 2 components, found %d", n);
                return false;
            }
            sdl_set_vector(out, n, c);
            return true;
        }
        /* POV-Ray tolerates missing commas: <1 2 3> */
        if (t->kind == VBNL_SDL_TOK_NUMBER || (t->kind == VBNL_SDL_TOK_IDENT && t->keyword < VBI_KW_declare) ||
            (t->kind == VBNL_SDL_TOK_IDENT && t->keyword > VBI_KW_optional) ||
            (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '(')) {
            if (t->kind != VBNL_SDL_TOK_IDENT || t->keyword != 0 || sdl_lookup(p, t->text))
                continue;
        }
        char b[80];
        sdl_errorf(p, &t->loc, "expected ',' or '>' in vector, found %s", sdl_token_describe(t, b, sizeof b));
        break;
    }
    p->in_vector--;
    return false;
}

static bool component(vbnl_sdl_parser *p, vbnl_sdl_value *v, const vbnl_sdl_token *name)
{
    int idx = -1;
    bool gray = false;
    switch (name->keyword) {
    case VBI_KW_x: case VBI_KW_u: case VBI_KW_red: idx = 0; break;
    case VBI_KW_y: case VBI_KW_v: case VBI_KW_green: idx = 1; break;
    case VBI_KW_z: case VBI_KW_blue: idx = 2; break;
    case VBI_KW_t: case VBI_KW_filter: idx = 3; break;
    case VBI_KW_transmit: idx = 4; break;
    case VBI_KW_gray: case VBI_KW_grey: gray = true; break;
    default: break;
    }
    if (idx < 0 && !gray) {
        char b[80];
        sdl_errorf(p, &name->loc, "unknown component %s after '.' (use x y z t u v red green blue filter transmit gray)",
                   sdl_token_describe(name, b, sizeof b));
        return false;
    }
    if (v->kind != VBNL_SDL_VECTOR && v->kind != VBNL_SDL_COLOR) {
        sdl_errorf(p, &name->loc, "'.%s' needs a vector or color, found a %s", name->text, kind_of(v));
        return false;
    }
    double r;
    if (gray) {
        r = 0.3 * v->v[0] + 0.59 * (v->dim > 1 ? v->v[1] : 0) + 0.11 * (v->dim > 2 ? v->v[2] : 0);
    } else {
        if (idx >= v->dim) {
            sdl_errorf(p, &name->loc, "'.%s' is out of range for a %d-component %s", name->text, v->dim, kind_of(v));
            return false;
        }
        r = v->v[idx];
    }
    sdl_set_float(v, r);
    return true;
}

static bool index_array(vbnl_sdl_parser *p, const char *name, const vbnl_sdl_loc *nloc, const vbnl_sdl_array *a,
                        const vbnl_sdl_value **elem)
{
    size_t flat = 0;
    int n = 0;
    while (vbnl_sdl_accept(p, '[')) {
        double d;
        vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
        if (!sdl_expr_float(p, &d, "array index") || !sdl_expect_op(p, ']', "after array index"))
            return false;
        if (n >= a->rank) {
            sdl_errorf(p, &loc, "too many indices for array '%s' (%d dimension%s)", name, a->rank, a->rank == 1 ? "" : "s");
            return false;
        }
        if (!(d >= 0) || d >= (double)a->dims[n]) {
            sdl_errorf(p, &loc, "index %g out of range for dimension %d of array '%s' (size %zu)", d, n + 1, name, a->dims[n]);
            return false;
        }
        flat = flat * a->dims[n] + (size_t)d;
        n++;
    }
    if (n != a->rank) {
        sdl_errorf(p, nloc, "array '%s' has %d dimensions, %d index%s given", name, a->rank, n, n == 1 ? "" : "es");
        return false;
    }
    *elem = &a->elems[flat];
    if ((*elem)->kind == VBNL_SDL_NONE) {
        sdl_errorf(p, nloc, "element of array '%s' used before it was initialized", name);
        return false;
    }
    return true;
}

static bool identifier(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_value *out)
{
    sdl_sym *s = sdl_lookup(p, tok->text);
    const char *name = tok->text;
    vbnl_sdl_loc loc = tok->loc;
    if (!s || s->val.kind == VBNL_SDL_NONE) {
        const char *sug = sdl_suggest(p, name);
        if (sug)
            sdl_errorf(p, &loc, "undeclared identifier '%s'; did you mean '%s'?", name, sug);
        else
            sdl_errorf(p, &loc, "undeclared identifier '%s'", name);
        return false;
    }
    /* Take the value before looking ahead: the lookahead may end the macro that declared it
     * ("#local R = ...; R #end") or run directives that move the table. Arrays are pinned
     * rather than copied so that A[i] stays cheap. */
    vbnl_sdl_value held;
    memset(&held, 0, sizeof held);
    vbnl_sdl_array *a = NULL;
    vbnl_sdl_function *fn = NULL;
    vbnl_sdl_spline *sp = NULL;
    if (s->val.kind == VBNL_SDL_SPLINE) {
        sp = s->val.u.spline;
        sdl_spline_retain(sp);
    } else if (s->val.kind == VBNL_SDL_ARRAY) {
        a = s->val.u.array;
        a->pins++;
    } else if (s->val.kind == VBNL_SDL_FUNCTION) {
        fn = s->val.u.fn;
        sdl_function_retain(fn);
    } else if (vbnl_sdl_value_copy(p, &held, &s->val) != VBNL_OK) {
        return false;
    }
    const vbnl_sdl_token *n = vbnl_sdl_peek(p);
    bool paren = n->kind == VBNL_SDL_TOK_PUNCT && n->op == '(';
    bool bracket = n->kind == VBNL_SDL_TOK_PUNCT && n->op == '[';
    bool ok;
    if (a) {
        if (bracket) {
            const vbnl_sdl_value *e;
            ok = index_array(p, name, &loc, a, &e) && vbnl_sdl_value_copy(p, out, e) == VBNL_OK;
        } else {
            vbnl_sdl_value tmp;
            memset(&tmp, 0, sizeof tmp);
            tmp.kind = VBNL_SDL_ARRAY;
            tmp.u.array = a;
            ok = vbnl_sdl_value_copy(p, out, &tmp) == VBNL_OK;
        }
        sdl_array_unpin(p, a);
        return ok && !p->failed;
    }
    if (fn) {
        if (paren) {
            ok = sdl_call_function(p, fn, &loc, out);
            sdl_function_release(p, fn);
            return ok;
        }
        memset(out, 0, sizeof *out);
        out->kind = VBNL_SDL_FUNCTION;
        out->u.fn = fn;
        return true;
    }
    if (sp) {
        if (paren) {
            ok = sdl_call_spline(p, sp, &loc, out);
            sdl_spline_release(p, sp);
            return ok && !p->failed;
        }
        memset(out, 0, sizeof *out);
        out->kind = VBNL_SDL_SPLINE;
        out->u.spline = sp;
        return true;
    }
    *out = held;
    return true;
}

static bool primary(vbnl_sdl_parser *p, vbnl_sdl_value *out)
{
    memset(out, 0, sizeof *out);
    while (sdl_expand_here(p))
        ;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (p->failed)
        return false;
    vbnl_sdl_loc loc = t->loc;
    char b[80];
    switch (t->kind) {
    case VBNL_SDL_TOK_NUMBER:
        sdl_set_float(out, t->number);
        vbnl_sdl_next(p);
        return true;
    case VBNL_SDL_TOK_STRING: {
        vbnl_sdl_token s = *vbnl_sdl_next(p);
        return sdl_set_string(p, out, s.text, s.len);
    }
    case VBNL_SDL_TOK_PUNCT:
        if (t->op == '(') {
            vbnl_sdl_next(p);
            int saved = p->in_vector, saved_count = p->in_count;
            p->in_vector = 0;
            p->in_count = 0;
            bool ok = sdl_expr(p, out) && sdl_expect_op(p, ')', "to close '('");
            p->in_vector = saved;
            p->in_count = saved_count;
            if (!ok)
                vbnl_sdl_value_clear(p, out);
            return ok;
        }
        if (t->op == '<') {
            vbnl_sdl_next(p);
            int saved = p->in_vector, saved_count = p->in_count;
            p->in_vector = 0;
            p->in_count = 0;
            bool ok = vector_literal(p, out, &loc);
            p->in_vector = saved;
            p->in_count = saved_count;
            return ok;
        }
        break;
    case VBNL_SDL_TOK_IDENT: {
        int kw = t->keyword;
        double c[5] = { 0, 0, 0, 0, 0 };
        switch (kw) {
        case 0: {
            vbnl_sdl_token id = *vbnl_sdl_next(p);
            return identifier(p, &id, out);
        }
        case VBI_KW_pi: vbnl_sdl_next(p); sdl_set_float(out, M_PI); return true;
        case VBI_KW_tau: vbnl_sdl_next(p); sdl_set_float(out, 2 * M_PI); return true;
        case VBI_KW_true: case VBI_KW_yes: case VBI_KW_on:
            vbnl_sdl_next(p); sdl_set_float(out, 1); return true;
        case VBI_KW_false: case VBI_KW_no: case VBI_KW_off:
            vbnl_sdl_next(p); sdl_set_float(out, 0); return true;
        case VBI_KW_clock: vbnl_sdl_next(p); sdl_set_float(out, p->clock); return true;
        case VBI_KW_clock_delta: vbnl_sdl_next(p); sdl_set_float(out, p->clock_delta); return true;
        case VBI_KW_clock_on: vbnl_sdl_next(p); sdl_set_float(out, p->clock_on); return true;
        case VBI_KW_initial_clock: vbnl_sdl_next(p); sdl_set_float(out, p->initial_clock); return true;
        case VBI_KW_final_clock: vbnl_sdl_next(p); sdl_set_float(out, p->final_clock); return true;
        case VBI_KW_frame_number: vbnl_sdl_next(p); sdl_set_float(out, p->frame_number); return true;
        case VBI_KW_initial_frame: vbnl_sdl_next(p); sdl_set_float(out, p->initial_frame); return true;
        case VBI_KW_final_frame: vbnl_sdl_next(p); sdl_set_float(out, p->final_frame); return true;
        case VBI_KW_image_width: vbnl_sdl_next(p); sdl_set_float(out, p->image_width); return true;
        case VBI_KW_image_height: vbnl_sdl_next(p); sdl_set_float(out, p->image_height); return true;
        case VBI_KW_version: vbnl_sdl_next(p); sdl_set_float(out, p->language_version); return true;
        case VBI_KW_x: c[0] = 1; vbnl_sdl_next(p); sdl_set_vector(out, 3, c); return true;
        case VBI_KW_y: c[1] = 1; vbnl_sdl_next(p); sdl_set_vector(out, 3, c); return true;
        case VBI_KW_z: c[2] = 1; vbnl_sdl_next(p); sdl_set_vector(out, 3, c); return true;
        case VBI_KW_t: c[3] = 1; vbnl_sdl_next(p); sdl_set_vector(out, 4, c); return true;
        case VBI_KW_u: c[0] = 1; vbnl_sdl_next(p); sdl_set_vector(out, 2, c); return true;
        case VBI_KW_v: c[1] = 1; vbnl_sdl_next(p); sdl_set_vector(out, 2, c); return true;
        case VBI_KW_input_file_name: {
            vbnl_sdl_next(p);
            const char *n = p->nframes ? p->frames[0].file->name : "";
            return sdl_set_string(p, out, n, strlen(n));
        }
        case VBI_KW_color: case VBI_KW_colour:
            vbnl_sdl_next(p);
            return color_body(p, out, true);
        case VBI_KW_rgb: case VBI_KW_rgbf: case VBI_KW_rgbt: case VBI_KW_rgbft:
        case VBI_KW_srgb: case VBI_KW_srgbf: case VBI_KW_srgbt: case VBI_KW_srgbft:
        case VBI_KW_red: case VBI_KW_green: case VBI_KW_blue: case VBI_KW_filter: case VBI_KW_transmit:
            return color_body(p, out, true);
        case VBI_KW_array: return sdl_parse_array_decl(p, out, &loc);
        case VBI_KW_function: return sdl_parse_function(p, out, &loc);
        default:
            if (sdl_is_builtin(kw)) {
                vbnl_sdl_token id = *vbnl_sdl_next(p);
                return sdl_builtin_call(p, kw, &id, out);
            }
            sdl_errorf(p, &loc, "expected an expression, found keyword '%s'", t->text);
            return false;
        }
    }
    default:
        break;
    }
    sdl_errorf(p, &loc, "expected an expression, found %s", sdl_token_describe(t, b, sizeof b));
    return false;
}

static bool postfix(vbnl_sdl_parser *p, vbnl_sdl_value *out)
{
    if (!primary(p, out))
        return false;
    while (vbnl_sdl_peek(p)->kind == VBNL_SDL_TOK_PUNCT && vbnl_sdl_peek(p)->op == '.') {
        vbnl_sdl_next(p);
        vbnl_sdl_token name = *vbnl_sdl_next(p);
        if (name.kind != VBNL_SDL_TOK_IDENT) {
            char b[80];
            sdl_errorf(p, &name.loc, "expected a component name after '.', found %s", sdl_token_describe(&name, b, sizeof b));
            vbnl_sdl_value_clear(p, out);
            return false;
        }
        if (!component(p, out, &name)) {
            vbnl_sdl_value_clear(p, out);
            return false;
        }
    }
    return true;
}

static bool unary(vbnl_sdl_parser *p, vbnl_sdl_value *out)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_PUNCT && (t->op == '-' || t->op == '+' || t->op == '!')) {
        int op = t->op;
        vbnl_sdl_loc loc = t->loc;
        vbnl_sdl_next(p);
        if (!sdl_enter(p, &loc))
            return false;
        bool ok = unary(p, out);
        sdl_leave(p);
        if (!ok)
            return false;
        if (op == '+' && is_num(out))
            return true;
        if (!is_num(out)) {
            sdl_errorf(p, &loc, "unary '%c' needs a number, found a %s", op, kind_of(out));
            vbnl_sdl_value_clear(p, out);
            return false;
        }
        int n = out->kind == VBNL_SDL_FLOAT ? 1 : out->dim;
        for (int i = 0; i < n; i++)
            out->v[i] = op == '-' ? -out->v[i] : (fabs(out->v[i]) > VBI_SDL_EPSILON ? 0.0 : 1.0);
        return true;
    }
    return postfix(p, out);
}

typedef bool (*level_fn)(vbnl_sdl_parser *, vbnl_sdl_value *);

static bool binary_level(vbnl_sdl_parser *p, vbnl_sdl_value *out, level_fn next, const int *ops)
{
    if (!next(p, out))
        return false;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (t->kind != VBNL_SDL_TOK_PUNCT)
            return true;
        int op = t->op;
        bool match = false;
        for (const int *o = ops; *o; o++)
            if (*o == op)
                match = true;
        if (!match || (op == '>' && p->in_vector > 0))
            return true;
        /* "<1,2> <3,4>" in an initializer without commas: a new vector, not a comparison */
        if (op == '<' && (out->kind == VBNL_SDL_VECTOR || out->kind == VBNL_SDL_COLOR || p->in_count > 0))
            return true;
        vbnl_sdl_loc loc = t->loc;
        vbnl_sdl_next(p);
        vbnl_sdl_value rhs;
        if (!next(p, &rhs)) {
            vbnl_sdl_value_clear(p, out);
            return false;
        }
        bool ok = binop(p, op, out, &rhs, &loc);
        vbnl_sdl_value_clear(p, &rhs);
        if (!ok) {
            vbnl_sdl_value_clear(p, out);
            return false;
        }
    }
}

static const int mul_ops[] = { '*', '/', 0 };
static const int add_ops[] = { '+', '-', 0 };
static const int cmp_ops[] = { '<', '>', VBNL_SDL_OP_LE, VBNL_SDL_OP_GE, '=', VBNL_SDL_OP_EQ2, VBNL_SDL_OP_NE, 0 };
static const int and_ops[] = { '&', 0 };
static const int or_ops[] = { '|', 0 };

static bool multiplicative(vbnl_sdl_parser *p, vbnl_sdl_value *out) { return binary_level(p, out, unary, mul_ops); }
static bool additive(vbnl_sdl_parser *p, vbnl_sdl_value *out) { return binary_level(p, out, multiplicative, add_ops); }
static bool comparison(vbnl_sdl_parser *p, vbnl_sdl_value *out) { return binary_level(p, out, additive, cmp_ops); }
static bool logical_and(vbnl_sdl_parser *p, vbnl_sdl_value *out) { return binary_level(p, out, comparison, and_ops); }
static bool logical_or(vbnl_sdl_parser *p, vbnl_sdl_value *out) { return binary_level(p, out, logical_and, or_ops); }

static bool ternary(vbnl_sdl_parser *p, vbnl_sdl_value *out)
{
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    if (!sdl_enter(p, &loc))
        return false;
    bool ok = logical_or(p, out);
    if (ok && vbnl_sdl_accept(p, '?')) {
        bool c = sdl_truth(p, out, &loc);
        vbnl_sdl_value_clear(p, out);
        vbnl_sdl_value a, b;
        memset(&b, 0, sizeof b);
        ok = !p->failed && ternary(p, &a);
        if (ok && !sdl_expect_op(p, ':', "in conditional expression")) {
            vbnl_sdl_value_clear(p, &a);
            ok = false;
        }
        if (ok && !ternary(p, &b)) {
            vbnl_sdl_value_clear(p, &a);
            ok = false;
        }
        if (ok) {
            *out = c ? a : b;
            vbnl_sdl_value_clear(p, c ? &b : &a);
        }
    }
    sdl_leave(p);
    if (!ok || p->failed) {
        /* callers may ignore *out on failure */
        vbnl_sdl_value_clear(p, out);
        return false;
    }
    return true;
}

bool sdl_expr(vbnl_sdl_parser *p, vbnl_sdl_value *out)
{
    memset(out, 0, sizeof *out);
    if (p->failed)
        return false;
    bool ok = ternary(p, out);
    if (!ok || p->failed) {
        vbnl_sdl_value_clear(p, out);
        return false;
    }
    return true;
}

/* ---- arrays -------------------------------------------------------------------------------- */

static bool array_init(vbnl_sdl_parser *p, vbnl_sdl_array *a, int dim, size_t base)
{
    vbnl_sdl_loc open = vbnl_sdl_peek(p)->loc;
    if (!sdl_expect_op(p, '{', "to start an array initializer"))
        return false;
    if (!sdl_enter(p, &open))
        return false;
    size_t n = 0;
    bool ok = true;
    while (ok) {
        if (vbnl_sdl_accept(p, '}'))
            break;
        if (n >= a->dims[dim]) {
            const vbnl_sdl_token *t = vbnl_sdl_peek(p);
            sdl_errorf(p, &t->loc, "too many elements in array initializer (dimension %d has size %zu)", dim + 1, a->dims[dim]);
            ok = false;
            break;
        }
        size_t stride = 1;
        for (int d = dim + 1; d < a->rank; d++)
            stride *= a->dims[d];
        if (dim + 1 < a->rank) {
            ok = array_init(p, a, dim + 1, base + n * stride);
        } else {
            vbnl_sdl_value v;
            ok = sdl_parse_rvalue(p, &v);
            if (ok)
                a->elems[base + n] = v;
        }
        n++;
        if (!ok)
            break;
        if (vbnl_sdl_accept(p, ','))
            continue;
        const vbnl_sdl_token *nt = vbnl_sdl_peek(p);
        if (nt->kind == VBNL_SDL_TOK_PUNCT && nt->op == '}')
            continue;
        if (nt->kind != VBNL_SDL_TOK_EOF && !(nt->kind == VBNL_SDL_TOK_PUNCT && (nt->op < 128 && strchr(");]>", nt->op))))
            continue; /* POV-Ray tolerates missing commas between elements */
        if (!sdl_expect_op(p, '}', "or ',' in array initializer"))
            ok = false;
        break;
    }
    if (ok && n != a->dims[dim]) {
        sdl_errorf(p, &open, "array initializer has %zu element%s, dimension %d has size %zu", n, n == 1 ? "" : "s",
                   dim + 1, a->dims[dim]);
        ok = false;
    }
    sdl_leave(p);
    return ok;
}

bool sdl_parse_array_decl(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *loc)
{
    memset(out, 0, sizeof *out);
    vbnl_sdl_next(p); /* array */
    if (vbnl_sdl_peek(p)->keyword == VBI_KW_mixed)
        vbnl_sdl_next(p);
    size_t dims[5];
    int rank = 0;
    while (vbnl_sdl_accept(p, '[')) {
        double d;
        vbnl_sdl_loc dl = vbnl_sdl_peek(p)->loc;
        if (rank == 5) {
            sdl_errorf(p, &dl, "arrays have at most 5 dimensions");
            return false;
        }
        if (!sdl_expr_float(p, &d, "array size") || !sdl_expect_op(p, ']', "after array size"))
            return false;
        if (!(d >= 1) || d > 1e9) {
            sdl_errorf(p, &dl, "invalid array size %g", d);
            return false;
        }
        dims[rank++] = (size_t)d;
    }
    if (rank == 0) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        char b[80];
        sdl_errorf(p, &t->loc, "expected '[' after 'array', found %s", sdl_token_describe(t, b, sizeof b));
        return false;
    }
    vbnl_sdl_array *a = sdl_array_new(p, rank, dims);
    if (!a)
        return false;
    out->kind = VBNL_SDL_ARRAY;
    out->u.array = a;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '{' && !array_init(p, a, 0, 0)) {
        vbnl_sdl_value_clear(p, out);
        return false;
    }
    (void)loc;
    return true;
}

/* ---- public wrappers ----------------------------------------------------------------------- */

vbnl_result vbnl_sdl_parse_expression(vbnl_sdl_parser *p, vbnl_sdl_value *out)
{
    if (!p || !out)
        return VBNL_ERR_INVALID_ARGUMENT;
    return sdl_expr(p, out) ? VBNL_OK : VBNL_ERR_PARSE;
}

vbnl_result vbnl_sdl_parse_float(vbnl_sdl_parser *p, double *out)
{
    if (!p || !out)
        return VBNL_ERR_INVALID_ARGUMENT;
    return sdl_expr_float(p, out, "a float value") ? VBNL_OK : VBNL_ERR_PARSE;
}

vbnl_result vbnl_sdl_parse_float_sum(vbnl_sdl_parser *p, double *out)
{
    if (!p || !out)
        return VBNL_ERR_INVALID_ARGUMENT;
    vbnl_sdl_value v;
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    *out = 0;
    if (!additive(p, &v))
        return VBNL_ERR_PARSE;
    if (v.kind != VBNL_SDL_FLOAT) {
        sdl_errorf(p, &loc, "expected a float for a float value, found a %s", kind_of(&v));
        vbnl_sdl_value_clear(p, &v);
        return VBNL_ERR_PARSE;
    }
    *out = v.v[0];
    return VBNL_OK;
}

vbnl_result vbnl_sdl_parse_vector(vbnl_sdl_parser *p, int dim, double *out)
{
    if (!p || !out)
        return VBNL_ERR_INVALID_ARGUMENT;
    vbnl_sdl_value v;
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    if (dim < 2 || dim > 5)
        return VBNL_ERR_INVALID_ARGUMENT;
    if (!sdl_expr(p, &v))
        return VBNL_ERR_PARSE;
    bool ok = sdl_to_vector(p, &v, dim, out, &loc, "a vector value");
    vbnl_sdl_value_clear(p, &v);
    return ok ? VBNL_OK : VBNL_ERR_PARSE;
}

vbnl_result vbnl_sdl_parse_string(vbnl_sdl_parser *p, char **out)
{
    if (!p || !out)
        return VBNL_ERR_INVALID_ARGUMENT;
    vbnl_sdl_value v;
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    *out = NULL;
    if (!sdl_expr(p, &v))
        return VBNL_ERR_PARSE;
    if (v.kind != VBNL_SDL_STRING) {
        sdl_errorf(p, &loc, "expected a string, found a %s", kind_of(&v));
        vbnl_sdl_value_clear(p, &v);
        return VBNL_ERR_PARSE;
    }
    *out = strdup(v.u.str.s);
    vbnl_sdl_value_clear(p, &v);
    if (!*out) {
        sdl_errorf(p, &loc, "out of memory");
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    return VBNL_OK;
}
