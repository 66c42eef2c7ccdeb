/* vbnl scene parser: directives (#declare ... #end), conditional skipping, loops, #switch. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sdl_internal.h"

static void free_tok(vbnl_sdl_token *t)
{
    sdl_token_free(t);
}

int sdl_skip_to(vbnl_sdl_parser *p, bool stop_at_else, vbnl_sdl_loc *kwloc)
{
    int depth = 0;
    vbnl_sdl_token t, k;
    for (;;) {
        sdl_raw(p, &t);
        if (t.kind == VBNL_SDL_TOK_EOF || p->failed) {
            free_tok(&t);
            return 0;
        }
        bool hash = t.kind == VBNL_SDL_TOK_PUNCT && t.op == '#';
        free_tok(&t);
        if (!hash)
            continue;
        sdl_raw(p, &k);
        int kw = k.kind == VBNL_SDL_TOK_IDENT ? k.keyword : 0;
        if (kwloc)
            *kwloc = k.loc;
        free_tok(&k);
        switch (kw) {
        case VBI_KW_if: case VBI_KW_ifdef: case VBI_KW_ifndef: case VBI_KW_while:
        case VBI_KW_for: case VBI_KW_switch: case VBI_KW_macro:
            depth++;
            break;
        case VBI_KW_end:
            if (depth == 0)
                return kw;
            depth--;
            break;
        case VBI_KW_else: case VBI_KW_elseif: case VBI_KW_case: case VBI_KW_range: case VBI_KW_break:
            if (depth == 0 && stop_at_else)
                return kw;
            break;
        default:
            break;
        }
    }
}

/* Skips to the #end matching an open construct; reports `what` when the file ends first. */
static bool skip_to_end(vbnl_sdl_parser *p, const vbnl_sdl_loc *open, const char *what)
{
    if (sdl_skip_to(p, false, NULL) == VBI_KW_end)
        return true;
    sdl_errorf(p, open, "missing #end for %s", what);
    return false;
}

/* '(' float ')' with '#' ending expressions. */
static bool paren_float(vbnl_sdl_parser *p, double *out, const char *what)
{
    int fi = p->nframes - 1;
    p->frames[fi].in_directive++;
    bool ok = sdl_expect_op(p, '(', what) && sdl_expr_float(p, out, what) && sdl_expect_op(p, ')', what);
    if (fi < p->nframes)
        p->frames[fi].in_directive--;
    return ok && !p->failed;
}

static bool paren_cond(vbnl_sdl_parser *p, bool *out, const char *what)
{
    int fi = p->nframes - 1;
    p->frames[fi].in_directive++;
    vbnl_sdl_value v = { 0 };
    bool ok = sdl_expect_op(p, '(', what);
    const vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    ok = ok && sdl_expr(p, &v) && sdl_expect_op(p, ')', what);
    if (ok)
        *out = sdl_truth(p, &v, &loc);
    vbnl_sdl_value_clear(p, &v);
    if (fi < p->nframes)
        p->frames[fi].in_directive--;
    return ok && !p->failed;
}

static const vbnl_sdl_token *next_name(vbnl_sdl_parser *p)
{
    p->no_expand = true;
    const vbnl_sdl_token *t = vbnl_sdl_next(p);
    p->no_expand = false;
    return t;
}

static bool expect_name(vbnl_sdl_parser *p, const char *context, const char **name, vbnl_sdl_loc *loc)
{
    const vbnl_sdl_token *t = next_name(p);
    *loc = t->loc;
    if (t->kind != VBNL_SDL_TOK_IDENT) {
        char b[80];
        sdl_errorf(p, &t->loc, "expected an identifier %s, found %s", context, sdl_token_describe(t, b, sizeof b));
        return false;
    }
    if (t->keyword) {
        sdl_errorf(p, &t->loc, "'%s' is a reserved keyword and cannot be used as an identifier", t->text);
        return false;
    }
    *name = t->text;
    return true;
}

void sdl_declare(vbnl_sdl_parser *p, const char *name, int frame, vbnl_sdl_value *val,
                 const vbnl_sdl_loc *loc)
{
    (void)loc;
    int fr;
    sdl_sym *b = sdl_lookup_binding(p, name, &fr);
    sdl_sym *s;
    bool local = frame > 0 && frame < p->nframes;
    if (b && b->ref && (!local || fr == frame)) {
        /* assignment to a macro parameter that aliases the caller's identifier */
        s = sdl_resolve(p, b);
        if (!s) {
            int top = b->ref_frame;
            sdl_table *t = top >= 1 ? &p->frames[top].locals : &p->globals;
            s = sdl_table_insert(p, t, b->ref);
        }
    } else if (b && !local) {
        /* POV-Ray: #declare of a visible identifier updates it where it lives, even when it
         * is a #local of an enclosing macro ("#local K = 0; ... #declare K = K + 1;") */
        s = b;
    } else {
        sdl_table *t = local ? &p->frames[frame].locals : &p->globals;
        s = sdl_table_insert(p, t, name);
    }
    if (!s) {
        vbnl_sdl_value_clear(p, val);
        return;
    }
    vbnl_sdl_value_clear(p, &s->val);
    s->val = *val;
    memset(val, 0, sizeof *val);
}

static bool is_object_like(const vbnl_sdl_value *v)
{
    return v->kind == VBNL_SDL_BLOCK || v->kind == VBNL_SDL_OBJECT;
}

bool sdl_parse_rvalue(vbnl_sdl_parser *p, vbnl_sdl_value *out)
{
    memset(out, 0, sizeof *out);
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '#') {
        /* "#declare S = #if (A) sphere {...} #else box {...} #end" */
        int fi = p->nframes - 1, saved = p->frames[fi].in_directive;
        p->frames[fi].in_directive = 0;
        vbnl_sdl_peek(p);
        if (fi < p->nframes)
            p->frames[fi].in_directive = saved;
    }
    while (sdl_expand_here(p))
        ;
    t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_IDENT) {
        if (t->keyword == VBI_KW_array)
            return sdl_parse_array_decl(p, out, &t->loc);
        if (t->keyword == VBI_KW_function)
            return sdl_parse_function(p, out, &t->loc);
        if (!t->keyword && !sdl_lookup(p, t->text)) {
            if (p->hooks.rvalue) {
                vbnl_sdl_token copy = *t;
                /* object blocks run their directives, as in POV-Ray */
                int fi = p->nframes - 1, saved = p->frames[fi].in_directive;
                p->frames[fi].in_directive = 0;
                int r = p->hooks.rvalue(p, &copy, out, p->hooks.user);
                if (fi < p->nframes)
                    p->frames[fi].in_directive = saved;
                /* Layered textures, `texture { A } texture { B }`: combined by the value's type
                 * (else the last layer replaces the others). The layers' deferred warnings are
                 * reported where the result is used. */
                const char *kw = copy.text;
                while (r > 0 && !p->failed && strcmp(kw, "texture") == 0) {
                    const vbnl_sdl_token *n = vbnl_sdl_peek(p);
                    if (!(n->kind == VBNL_SDL_TOK_IDENT && strcmp(n->text, "texture") == 0))
                        break;
                    vbnl_sdl_token layer = *n;
                    vbnl_sdl_value top;
                    memset(&top, 0, sizeof top);
                    fi = p->nframes - 1, saved = p->frames[fi].in_directive;
                    p->frames[fi].in_directive = 0;
                    r = p->hooks.rvalue(p, &layer, &top, p->hooks.user);
                    if (fi < p->nframes)
                        p->frames[fi].in_directive = saved;
                    if (r <= 0) {
                        vbnl_sdl_value_clear(p, &top);
                        if (r == 0)
                            sdl_errorf(p, &layer.loc, "unexpected texture layer");
                        return false;
                    }
                    int group = out->kind == VBNL_SDL_OBJECT ? out->u.obj.deferred : 0;
                    if (!group && (group = vbnl_sdl_defer_begin(p)))
                        vbnl_sdl_defer_end(p, group);
                    if (top.kind == VBNL_SDL_OBJECT)
                        sdl_defer_link(p, group, top.u.obj.deferred);
                    if (out->kind == VBNL_SDL_OBJECT && top.kind == VBNL_SDL_OBJECT &&
                        out->u.obj.type == top.u.obj.type && top.u.obj.type->layer) {
                        void *m = top.u.obj.type->layer(out->u.obj.ptr, top.u.obj.ptr, top.u.obj.type->user);
                        out->u.obj.ptr = NULL; /* taken */
                        top.u.obj.ptr = m;
                        if (!m) {
                            top.u.obj.type = NULL;
                            sdl_errorf(p, &layer.loc, "out of memory combining texture layers");
                            return false;
                        }
                    }
                    vbnl_sdl_value_clear(p, out);
                    *out = top;
                    if (out->kind == VBNL_SDL_OBJECT)
                        out->u.obj.deferred = group;
                }
                if (r != 0)
                    return r > 0 && !p->failed;
            }
            vbnl_sdl_token kwt = *vbnl_sdl_next(p);
            const vbnl_sdl_token *b = vbnl_sdl_peek(p);
            if (!(b->kind == VBNL_SDL_TOK_PUNCT && b->op == '{')) {
                const char *s = sdl_suggest(p, kwt.text);
                if (s)
                    sdl_errorf(p, &kwt.loc, "undeclared identifier '%s'; did you mean '%s'?", kwt.text, s);
                else
                    sdl_errorf(p, &kwt.loc, "undeclared identifier '%s'", kwt.text);
                return false;
            }
            if (strcmp(kwt.text, "spline") == 0)
                return sdl_parse_spline(p, out, &kwt.loc);
            /* Fallback until the object layer exists: keep the block unevaluated. */
            for (;;) {
                if (vbnl_sdl_skip_block(p) != VBNL_OK)
                    return false;
                const vbnl_sdl_token *n = vbnl_sdl_peek(p);
                /* Layered textures: texture { } texture { } */
                if (!(n->kind == VBNL_SDL_TOK_IDENT && n->text == kwt.text && strcmp(kwt.text, "texture") == 0))
                    break;
                vbnl_sdl_next(p);
            }
            vbnl_sdl_block *blk = sdl_alloc(p, sizeof *blk);
            if (!blk)
                return false;
            blk->refs = 1;
            blk->keyword = kwt.text;
            blk->loc = kwt.loc;
            out->kind = VBNL_SDL_BLOCK;
            out->u.block = blk;
            return true;
        }
    }
    return sdl_expr(p, out);
}

vbnl_result vbnl_sdl_parse_rvalue(vbnl_sdl_parser *p, vbnl_sdl_value *out)
{
    if (!p || !out)
        return VBNL_ERR_INVALID_ARGUMENT;
    if (!sdl_parse_rvalue(p, out)) {
        vbnl_sdl_value_clear(p, out);
        return VBNL_ERR_PARSE;
    }
    return VBNL_OK;
}

static void do_declare(vbnl_sdl_parser *p, bool local, int fi, const vbnl_sdl_loc *hash)
{
    const char *name;
    vbnl_sdl_loc loc;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_IDENT && t->keyword == VBI_KW_deprecated) {
        vbnl_sdl_next(p);
        if (vbnl_sdl_peek(p)->keyword == VBI_KW_once)
            vbnl_sdl_next(p);
        if (vbnl_sdl_peek(p)->kind == VBNL_SDL_TOK_STRING)
            vbnl_sdl_next(p);
    }
    if (!expect_name(p, local ? "after #local" : "after #declare", &name, &loc))
        return;
    /* Element assignment: #declare A[i][j] = ... */
    size_t idx[5];
    int nidx = 0;
    while (vbnl_sdl_accept(p, '[')) {
        double d;
        if (nidx == 5) {
            sdl_errorf(p, &loc, "too many array indices (arrays have at most 5 dimensions)");
            return;
        }
        vbnl_sdl_loc il = vbnl_sdl_peek(p)->loc;
        if (!sdl_expr_float(p, &d, "array index") || !sdl_expect_op(p, ']', "after array index"))
            return;
        if (!(d >= 0) || d >= 1e15) {
            sdl_errorf(p, &il, "array index %g out of range", d);
            return;
        }
        idx[nidx++] = (size_t)d;
    }
    if (!sdl_expect_op(p, '=', local ? "after the name in #local" : "after the name in #declare"))
        return;
    vbnl_sdl_value v;
    if (!sdl_parse_rvalue(p, &v)) {
        vbnl_sdl_value_clear(p, &v);
        return;
    }
    if (!is_object_like(&v))
        vbnl_sdl_accept(p, ';');
    else
        vbnl_sdl_accept(p, ';');
    if (nidx) {
        sdl_sym *s = sdl_lookup(p, name);
        if (!s || s->val.kind != VBNL_SDL_ARRAY) {
            sdl_errorf(p, &loc, s ? "'%s' is not an array" : "undeclared array '%s'", name);
            vbnl_sdl_value_clear(p, &v);
            return;
        }
        vbnl_sdl_array *a = s->val.u.array;
        if (nidx != a->rank) {
            sdl_errorf(p, &loc, "array '%s' has %d dimension%s, %d index%s given", name, a->rank,
                       a->rank == 1 ? "" : "s", nidx, nidx == 1 ? "" : "es");
            vbnl_sdl_value_clear(p, &v);
            return;
        }
        size_t flat = 0;
        for (int i = 0; i < nidx; i++) {
            if (idx[i] >= a->dims[i]) {
                sdl_errorf(p, &loc, "index %zu out of range for dimension %d of array '%s' (size %zu)",
                           idx[i], i + 1, name, a->dims[i]);
                vbnl_sdl_value_clear(p, &v);
                return;
            }
            flat = flat * a->dims[i] + idx[i];
        }
        vbnl_sdl_value_clear(p, &a->elems[flat]);
        a->elems[flat] = v;
        return;
    }
    (void)hash;
    sdl_declare(p, name, local ? fi : -1, &v, &loc);
}

static void do_macro(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash)
{
    const char *name;
    vbnl_sdl_loc loc;
    if (!expect_name(p, "after #macro", &name, &loc) || !sdl_expect_op(p, '(', "after the macro name"))
        return;
    vbnl_sdl_macro *m = sdl_alloc(p, sizeof *m);
    if (!m)
        return;
    m->refs = 1;
    m->name = name;
    m->loc = loc;
    if (!vbnl_sdl_accept(p, ')')) {
        for (;;) {
            bool opt = false;
            if (m->nparams > 0 && vbnl_sdl_accept(p, ')'))
                break; /* trailing comma, accepted by POV-Ray */
            if (vbnl_sdl_peek(p)->keyword == VBI_KW_optional) {
                vbnl_sdl_next(p);
                opt = true;
            }
            const char *pn;
            vbnl_sdl_loc pl;
            if (!expect_name(p, "as macro parameter", &pn, &pl))
                goto fail;
            for (int i = 0; i < m->nparams; i++)
                if (m->params[i] == pn) {
                    sdl_errorf(p, &pl, "duplicate parameter '%s' in macro '%s'", pn, name);
                    goto fail;
                }
            const char **np = realloc(m->params, (size_t)(m->nparams + 1) * sizeof *np);
            if (np)
                m->params = np;
            bool *no = realloc(m->optional, (size_t)(m->nparams + 1) * sizeof *no);
            if (no)
                m->optional = no;
            if (!np || !no) {
                sdl_errorf(p, &pl, "out of memory");
                goto fail;
            }
            m->params[m->nparams] = pn;
            m->optional[m->nparams] = opt;
            m->nparams++;
            if (vbnl_sdl_accept(p, ','))
                continue;
            const vbnl_sdl_token *nt = vbnl_sdl_peek(p);
            if (nt->kind == VBNL_SDL_TOK_IDENT)
                continue; /* POV-Ray tolerates a missing comma between parameters */
            if (!sdl_expect_op(p, ')', "in macro parameter list"))
                goto fail;
            break;
        }
    }
    if (p->have_peek) {
        sdl_errorf(p, &loc, "internal error: lookahead after macro parameters");
        goto fail;
    }
    m->file = sdl_top(p)->file;
    m->body = sdl_tell(p);
    if (!skip_to_end(p, hash, "#macro"))
        goto fail;
    vbnl_sdl_value v = { 0 };
    v.kind = VBNL_SDL_MACRO;
    v.u.macro = m;
    sdl_declare(p, name, -1, &v, &loc);
    return;
fail:
    sdl_macro_free(p, m);
}

/* The IF entry on top is not taken: find the branch to run. */
static void find_if_branch(vbnl_sdl_parser *p)
{
    for (;;) {
        vbnl_sdl_loc kl;
        sdl_frame *f = sdl_top(p);
        sdl_cond c = f->conds[f->nconds - 1];
        int k = sdl_skip_to(p, true, &kl);
        if (k == VBI_KW_end) {
            sdl_cond_pop(p);
            return;
        }
        if (k == 0) {
            if (!p->failed)
                sdl_errorf(p, &c.loc, "missing #end for #if");
            return;
        }
        if (k == VBI_KW_else) {
            sdl_top(p)->conds[sdl_top(p)->nconds - 1].taken = true;
            return;
        }
        if (k == VBI_KW_elseif) {
            bool b;
            if (!paren_cond(p, &b, "in #elseif"))
                return;
            if (b) {
                sdl_top(p)->conds[sdl_top(p)->nconds - 1].taken = true;
                return;
            }
            continue;
        }
        /* #break/#case/#range inside a skipped branch belong to an enclosing construct */
        continue;
    }
}

static bool case_matches(vbnl_sdl_parser *p, int k, double value, bool *match)
{
    if (k == VBI_KW_case) {
        double c;
        if (!paren_float(p, &c, "in #case"))
            return false;
        *match = c == value;
        return true;
    }
    int fi = p->nframes - 1;
    p->frames[fi].in_directive++;
    double lo = 0, hi = 0;
    bool ok = sdl_expect_op(p, '(', "in #range") && sdl_expr_float(p, &lo, "#range low bound") &&
              sdl_expect_op(p, ',', "between #range bounds") && sdl_expr_float(p, &hi, "#range high bound") &&
              sdl_expect_op(p, ')', "in #range");
    if (fi < p->nframes)
        p->frames[fi].in_directive--;
    *match = value >= lo && value <= hi;
    return ok;
}

/* The SWITCH entry on top has not matched: find the clause to run. */
static void find_switch_case(vbnl_sdl_parser *p)
{
    for (;;) {
        vbnl_sdl_loc kl;
        sdl_frame *f = sdl_top(p);
        sdl_cond c = f->conds[f->nconds - 1];
        int k = sdl_skip_to(p, true, &kl);
        if (k == VBI_KW_end) {
            sdl_cond_pop(p);
            return;
        }
        if (k == 0) {
            if (!p->failed)
                sdl_errorf(p, &c.loc, "missing #end for #switch");
            return;
        }
        if (k == VBI_KW_else) {
            sdl_top(p)->conds[sdl_top(p)->nconds - 1].taken = true;
            return;
        }
        if (k == VBI_KW_case || k == VBI_KW_range) {
            bool match;
            if (!case_matches(p, k, c.value, &match))
                return;
            if (match) {
                sdl_top(p)->conds[sdl_top(p)->nconds - 1].taken = true;
                return;
            }
            continue;
        }
        if (k == VBI_KW_elseif) {
            sdl_errorf(p, &kl, "#elseif inside #switch");
            return;
        }
        /* #break while searching: nothing to do */
    }
}

static bool count_iteration(vbnl_sdl_parser *p, const vbnl_sdl_loc *loc)
{
    if (++p->loop_iterations > p->limits.max_loop_iterations) {
        sdl_errorf(p, loc, "loop iteration limit exceeded (%llu iterations in total; infinite #while?)",
                   (unsigned long long)p->limits.max_loop_iterations);
        return false;
    }
    return true;
}

static void do_end(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash)
{
    sdl_frame *f = sdl_top(p);
    if (f->nconds == 0) {
        if (f->kind == SDL_FRAME_MACRO) {
            sdl_pop_frame(p); /* macro return */
            return;
        }
        sdl_errorf(p, hash, "#end without matching #if, #while, #for, #switch or #macro");
        return;
    }
    sdl_cond c = f->conds[f->nconds - 1];
    if (c.kind == SDL_COND_IF || c.kind == SDL_COND_SWITCH) {
        sdl_cond_pop(p);
        return;
    }
    if (c.kind == SDL_COND_WHILE) {
        sdl_seek(p, c.pos);
        bool b;
        if (!paren_cond(p, &b, "in #while"))
            return;
        if (b) {
            count_iteration(p, &c.loc);
            return;
        }
        if (skip_to_end(p, &c.loc, "#while"))
            sdl_cond_pop(p);
        return;
    }
    /* FOR */
    sdl_sym *s = sdl_lookup(p, c.var);
    if (!s || s->val.kind != VBNL_SDL_FLOAT) {
        sdl_errorf(p, &c.loc, "#for loop variable '%s' was undefined or changed type inside the loop", c.var);
        return;
    }
    double nv = s->val.v[0] + c.step;
    s->val.v[0] = nv;
    if (c.step > 0 ? nv <= c.end + 1e-12 * fabs(c.end) : nv >= c.end - 1e-12 * fabs(c.end)) {
        if (count_iteration(p, &c.loc))
            sdl_seek(p, c.pos);
        return;
    }
    sdl_cond_pop(p);
}

static void do_break(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash)
{
    sdl_frame *f = sdl_top(p);
    int i = f->nconds - 1;
    while (i >= 0 && f->conds[i].kind == SDL_COND_IF)
        i--;
    if (i < 0) {
        if (f->kind == SDL_FRAME_MACRO) {
            /* POV-Ray allows #break to leave a macro early. */
            int levels = f->nconds + 1;
            for (int k = 0; k < levels; k++)
                if (!skip_to_end(p, hash, "#macro"))
                    return;
            sdl_pop_frame(p);
            return;
        }
        sdl_errorf(p, hash, "#break outside #switch, #while or #for");
        return;
    }
    int levels = f->nconds - i;
    vbnl_sdl_loc open = f->conds[i].loc;
    for (int k = 0; k < levels; k++) {
        if (!skip_to_end(p, &open, "#break target"))
            return;
        sdl_cond_pop(p);
    }
}

static void do_for(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash)
{
    const char *name;
    vbnl_sdl_loc loc;
    double a, b, step = 1;
    int fi = p->nframes - 1;
    p->frames[fi].in_directive++;
    bool ok = sdl_expect_op(p, '(', "after #for") && expect_name(p, "as #for loop variable", &name, &loc) &&
              sdl_expect_op(p, ',', "after the #for variable") && sdl_expr_float(p, &a, "#for start") &&
              sdl_expect_op(p, ',', "after the #for start value") && sdl_expr_float(p, &b, "#for end");
    if (ok && vbnl_sdl_accept(p, ','))
        ok = sdl_expr_float(p, &step, "#for step");
    ok = ok && sdl_expect_op(p, ')', "to close #for");
    if (fi < p->nframes)
        p->frames[fi].in_directive--;
    if (!ok || p->failed)
        return;
    if (step == 0) {
        sdl_errorf(p, hash, "#for step must not be zero");
        return;
    }
    vbnl_sdl_value v;
    sdl_set_float(&v, a);
    sdl_declare(p, name, p->nframes - 1, &v, &loc);
    if (step > 0 ? a > b : a < b) {
        skip_to_end(p, hash, "#for");
        return;
    }
    sdl_cond *c = sdl_cond_push(p, SDL_COND_FOR, hash);
    if (!c)
        return;
    c->var = name;
    c->end = b;
    c->step = step;
    c->pos = sdl_tell(p);
    count_iteration(p, hash);
}

static bool paren_string(vbnl_sdl_parser *p, char **out, const char *what, bool parens)
{
    int fi = p->nframes - 1;
    p->frames[fi].in_directive++;
    bool ok = true;
    if (parens)
        ok = sdl_expect_op(p, '(', what);
    ok = ok && vbnl_sdl_parse_string(p, out) == VBNL_OK;
    if (ok && parens)
        ok = sdl_expect_op(p, ')', what);
    if (fi < p->nframes)
        p->frames[fi].in_directive--;
    return ok && !p->failed;
}

static void do_message(vbnl_sdl_parser *p, int kw, const vbnl_sdl_loc *hash)
{
    char *s = NULL;
    if (!paren_string(p, &s, "in message directive", false)) {
        free(s);
        return;
    }
    if (kw == VBI_KW_error)
        sdl_errorf(p, hash, "#error: %s", s);
    else if (kw == VBI_KW_warning)
        sdl_warnf(p, hash, "%s", s);
    else if (!p->failed)
        sdl_diag_emit(p, VBNL_SDL_NOTE, hash, s);
    free(s);
}

static void do_ifdef(vbnl_sdl_parser *p, bool want, const vbnl_sdl_loc *hash)
{
    int fi = p->nframes - 1;
    p->frames[fi].in_directive++;
    const char *name = NULL;
    vbnl_sdl_loc loc;
    bool ok = sdl_expect_op(p, '(', want ? "after #ifdef" : "after #ifndef");
    const vbnl_sdl_token *t = ok ? next_name(p) : NULL;
    if (ok && t->kind != VBNL_SDL_TOK_IDENT) {
        char b[80];
        sdl_errorf(p, &t->loc, "expected an identifier in #if%sdef, found %s", want ? "" : "n", sdl_token_describe(t, b, sizeof b));
        ok = false;
    }
    if (ok) {
        name = t->text;
        loc = t->loc;
    }
    bool defined = false;
    if (ok) {
        sdl_sym *s = sdl_lookup(p, name);
        defined = s && s->val.kind != VBNL_SDL_NONE;
        if (s && s->val.kind == VBNL_SDL_ARRAY && vbnl_sdl_accept(p, '[')) {
            vbnl_sdl_array *a = s->val.u.array;
            a->pins++;
            size_t flat = 0;
            int n = 0;
            for (;;) {
                double d;
                if (!sdl_expr_float(p, &d, "array index") || !sdl_expect_op(p, ']', "after array index")) {
                    ok = false;
                    break;
                }
                if (n < a->rank && d >= 0 && d < (double)a->dims[n])
                    flat = flat * a->dims[n] + (size_t)d;
                else
                    flat = (size_t)-1;
                n++;
                if (!vbnl_sdl_accept(p, '['))
                    break;
            }
            defined = ok && n == a->rank && flat < a->count && a->elems[flat].kind != VBNL_SDL_NONE;
            sdl_array_unpin(p, a);
        }
        ok = ok && sdl_expect_op(p, ')', want ? "to close #ifdef" : "to close #ifndef");
    }
    (void)loc;
    if (fi < p->nframes)
        p->frames[fi].in_directive--;
    if (!ok || p->failed)
        return;
    sdl_cond *c = sdl_cond_push(p, SDL_COND_IF, hash);
    if (!c)
        return;
    c->taken = defined == want;
    if (!c->taken)
        find_if_branch(p);
}

static void do_include(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash)
{
    char *name = NULL;
    if (!paren_string(p, &name, "after #include", false)) {
        free(name);
        return;
    }
    if (!p->includes_enabled) {
        sdl_errorf(p, hash, "#include is disabled for this parse ('%s')", name);
        free(name);
        return;
    }
    sdl_file *f = sdl_find_include(p, name, hash);
    free(name);
    if (f)
        sdl_push_file(p, f, hash);
}

static void do_default(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (!(t->kind == VBNL_SDL_TOK_PUNCT && t->op == '{')) {
        char b[80];
        sdl_errorf(p, &t->loc, "expected '{' after #default, found %s", sdl_token_describe(t, b, sizeof b));
        return;
    }
    if (p->hooks.default_block) {
        if (p->hooks.default_block(p, p->hooks.user) != 0)
            return;
    }
    if (p->ndefaults == p->capdefaults) {
        size_t cap = p->capdefaults ? p->capdefaults * 2 : 4;
        vbnl_sdl_value *q = realloc(p->defaults, cap * sizeof *q);
        if (!q) {
            sdl_errorf(p, hash, "out of memory");
            return;
        }
        p->defaults = q;
        p->capdefaults = cap;
    }
    vbnl_sdl_block *blk = sdl_alloc(p, sizeof *blk);
    if (!blk)
        return;
    blk->refs = 1;
    blk->keyword = "default";
    blk->loc = *hash;
    vbnl_sdl_value *v = &p->defaults[p->ndefaults++];
    memset(v, 0, sizeof *v);
    v->kind = VBNL_SDL_BLOCK;
    v->u.block = blk;
    vbnl_sdl_skip_block(p);
}

/* #fopen/#fclose/#write/#read: writes are discarded (the parser never writes files). */
static void do_file_io(vbnl_sdl_parser *p, int kw, const vbnl_sdl_loc *hash)
{
    int fi = p->nframes - 1;
    p->frames[fi].in_directive++;
    const char *name;
    vbnl_sdl_loc loc;
    if (kw == VBI_KW_fopen) {
        char *path = NULL;
        if (expect_name(p, "after #fopen", &name, &loc) && vbnl_sdl_parse_string(p, &path) == VBNL_OK) {
            const vbnl_sdl_token *m = vbnl_sdl_next(p);
            if (m->keyword == VBI_KW_read) {
                sdl_errorf(p, &m->loc, "#fopen for reading is not supported by vbnl ('%s')", path);
            } else if (m->keyword != VBI_KW_write && m->keyword != VBI_KW_append) {
                char b[80];
                sdl_errorf(p, &m->loc, "expected read, write or append in #fopen, found %s", sdl_token_describe(m, b, sizeof b));
            } else {
                vbnl_sdl_value v;
                sdl_set_float(&v, -1);
                sdl_declare(p, name, -1, &v, &loc);
                sdl_warnf(p, hash, "#fopen \"%s\" for writing: output is discarded", path);
            }
        }
        free(path);
    } else if (kw == VBI_KW_fclose) {
        expect_name(p, "after #fclose", &name, &loc);
    } else if (kw == VBI_KW_write) {
        if (sdl_expect_op(p, '(', "after #write") && expect_name(p, "in #write", &name, &loc)) {
            /* commas are optional in POV-Ray */
            while (!p->failed && !vbnl_sdl_accept(p, ')')) {
                vbnl_sdl_accept(p, ',');
                vbnl_sdl_value v;
                if (vbnl_sdl_peek(p)->kind == VBNL_SDL_TOK_EOF) {
                    sdl_expect_op(p, ')', "to close #write");
                    break;
                }
                sdl_expr(p, &v);
                vbnl_sdl_value_clear(p, &v);
            }
        }
    } else {
        sdl_errorf(p, hash, "#read is not supported by vbnl");
    }
    if (fi < p->nframes)
        p->frames[fi].in_directive--;
}

static void directive(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash);

void sdl_directive(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash)
{
    /* A directive met while a caller's expression looks ahead parses its own expressions. */
    int saved_vector = p->in_vector, saved_count = p->in_count;
    p->in_vector = 0;
    p->in_count = 0;
    directive(p, hash);
    p->in_vector = saved_vector;
    p->in_count = saved_count;
}

static void directive(vbnl_sdl_parser *p, const vbnl_sdl_loc *hash)
{
    if (!sdl_enter(p, hash))
        return;
    int fi = p->nframes - 1;
    p->frames[fi].in_directive++;
    vbnl_sdl_token t = *next_name(p);
    p->frames[fi].in_directive--;
    int kw = t.kind == VBNL_SDL_TOK_IDENT ? t.keyword : 0;
    if (t.kind == VBNL_SDL_TOK_STRING)
        kw = -1;
    sdl_frame *f = sdl_top(p);
    sdl_cond *top = f->nconds ? &f->conds[f->nconds - 1] : NULL;
    switch (kw) {
    case VBI_KW_declare:
    case VBI_KW_local:
        p->frames[fi].in_directive++;
        do_declare(p, kw == VBI_KW_local, fi, hash);
        if (fi < p->nframes)
            p->frames[fi].in_directive--;
        break;
    case VBI_KW_undef: {
        const char *name;
        vbnl_sdl_loc loc;
        p->frames[fi].in_directive++;
        if (expect_name(p, "after #undef", &name, &loc)) {
            bool removed = false;
            for (int i = p->nframes - 1; i >= 0 && !removed; i--)
                removed = sdl_table_remove(p, &p->frames[i].locals, name);
            if (!removed && !sdl_table_remove(p, &p->globals, name))
                sdl_warnf(p, &loc, "#undef of undeclared identifier '%s'", name);
        }
        p->frames[fi].in_directive--;
        break;
    }
    case VBI_KW_include: do_include(p, hash); break;
    case VBI_KW_version: {
        double v;
        p->frames[fi].in_directive++;
        if (sdl_expr_float(p, &v, "#version")) {
            vbnl_sdl_accept(p, ';');
            p->language_version = v;
        }
        p->frames[fi].in_directive--;
        break;
    }
    case VBI_KW_if: {
        bool b;
        if (!paren_cond(p, &b, "in #if"))
            break;
        sdl_cond *c = sdl_cond_push(p, SDL_COND_IF, hash);
        if (!c)
            break;
        c->taken = b;
        if (!b)
            find_if_branch(p);
        break;
    }
    case VBI_KW_ifdef: do_ifdef(p, true, hash); break;
    case VBI_KW_ifndef: do_ifdef(p, false, hash); break;
    case VBI_KW_elseif:
    case VBI_KW_else:
        if (top && top->kind == SDL_COND_IF) {
            if (skip_to_end(p, &top->loc, "#if"))
                sdl_cond_pop(p);
        } else if (top && top->kind == SDL_COND_SWITCH && kw == VBI_KW_else) {
            /* POV-Ray: a running case falls through #else as through #case, up to #break. */
        } else {
            sdl_errorf(p, hash, "#%s without matching #if", t.text);
        }
        break;
    case VBI_KW_while: {
        sdl_pos pos = sdl_tell(p);
        bool b;
        if (!paren_cond(p, &b, "in #while"))
            break;
        if (!b) {
            skip_to_end(p, hash, "#while");
            break;
        }
        sdl_cond *c = sdl_cond_push(p, SDL_COND_WHILE, hash);
        if (c) {
            c->pos = pos;
            count_iteration(p, hash);
        }
        break;
    }
    case VBI_KW_for: do_for(p, hash); break;
    case VBI_KW_switch: {
        double v;
        if (!paren_float(p, &v, "in #switch"))
            break;
        sdl_cond *c = sdl_cond_push(p, SDL_COND_SWITCH, hash);
        if (!c)
            break;
        c->value = v;
        find_switch_case(p);
        break;
    }
    case VBI_KW_case:
    case VBI_KW_range:
        if (top && top->kind == SDL_COND_SWITCH) {
            bool match; /* falling through from the previous case: the test is ignored */
            case_matches(p, kw, top->value, &match);
        } else {
            sdl_errorf(p, hash, "#%s outside #switch", t.text);
        }
        break;
    case VBI_KW_break: do_break(p, hash); break;
    case VBI_KW_end: do_end(p, hash); break;
    case VBI_KW_macro: do_macro(p, hash); break;
    case VBI_KW_debug:
    case VBI_KW_warning:
    case VBI_KW_error:
    case VBI_KW_render:
    case VBI_KW_statistics:
        do_message(p, kw, hash);
        break;
    case VBI_KW_default: do_default(p, hash); break;
    case VBI_KW_fopen:
    case VBI_KW_fclose:
    case VBI_KW_write:
    case VBI_KW_read:
        do_file_io(p, kw, hash);
        break;
    default: {
        char b[80];
        if (t.kind == VBNL_SDL_TOK_IDENT) {
            sdl_errorf(p, &t.loc, "unknown directive '#%s'", t.text);
        } else if (t.kind == VBNL_SDL_TOK_EOF) {
            sdl_errorf(p, hash, "expected a directive name after '#', found end of file");
        } else {
            /* POV-Ray ignores a '#' that does not start a directive */
            sdl_warnf(p, hash, "stray '#' ignored (followed by %s)", sdl_token_describe(&t, b, sizeof b));
            vbnl_sdl_token copy = t;
            if (t.kind == VBNL_SDL_TOK_STRING) {
                copy.text = strdup(t.text);
                if (!copy.text) {
                    sdl_errorf(p, hash, "out of memory");
                    break;
                }
            }
            if (!p->have_peek)
                sdl_unread(p, &copy);
            else
                sdl_token_free(&copy);
        }
        break;
    }
    }
    sdl_leave(p);
}
