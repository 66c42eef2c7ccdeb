/* vbnl scene parser: spline { } values and their evaluation S(t).
 *
 * linear_spline: piecewise linear. cubic_spline: Catmull-Rom/Hermite through the inner points
 * (the first and last points only shape the ends, as in POV-Ray). natural_spline: natural cubic
 * through all points. quadratic_spline is evaluated as a natural spline (an approximation).
 * Outside the key range the value is clamped to the nearest defined end. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sdl_internal.h"

enum { VBI_SPLINE_LINEAR, VBI_SPLINE_QUADRATIC, VBI_SPLINE_CUBIC, VBI_SPLINE_NATURAL };

struct vbnl_sdl_spline {
    int refs;
    int type;
    int dim;
    int n, cap;
    double *t;     /* n keys, sorted */
    double (*v)[5];
};

void sdl_spline_retain(vbnl_sdl_spline *s)
{
    if (s)
        s->refs++;
}

void sdl_spline_release(vbnl_sdl_parser *p, vbnl_sdl_spline *s)
{
    if (!s || --s->refs > 0)
        return;
    sdl_free(p, s->t, (size_t)s->cap * sizeof *s->t);
    sdl_free(p, s->v, (size_t)s->cap * sizeof *s->v);
    sdl_free(p, s, sizeof *s);
}

static bool add_point(vbnl_sdl_parser *p, vbnl_sdl_spline *s, double t, const double *v)
{
    if (s->n == s->cap) {
        int cap = s->cap ? s->cap * 2 : 8;
        double *nt = sdl_realloc(p, s->t, (size_t)s->cap * sizeof *nt, (size_t)cap * sizeof *nt);
        if (!nt)
            return false;
        s->t = nt;
        double(*nv)[5] = sdl_realloc(p, s->v, (size_t)s->cap * sizeof *nv, (size_t)cap * sizeof *nv);
        if (!nv)
            return false;
        s->v = nv;
        s->cap = cap;
    }
    /* keep keys sorted; a repeated key replaces the point */
    int i = s->n;
    while (i > 0 && s->t[i - 1] > t)
        i--;
    if (i > 0 && s->t[i - 1] == t) {
        memcpy(s->v[i - 1], v, sizeof s->v[0]);
        return true;
    }
    memmove(s->t + i + 1, s->t + i, (size_t)(s->n - i) * sizeof *s->t);
    memmove(s->v + i + 1, s->v + i, (size_t)(s->n - i) * sizeof *s->v);
    s->t[i] = t;
    memcpy(s->v[i], v, sizeof s->v[0]);
    s->n++;
    return true;
}

bool sdl_parse_spline(vbnl_sdl_parser *p, vbnl_sdl_value *out, const vbnl_sdl_loc *loc)
{
    memset(out, 0, sizeof *out);
    if (!sdl_expect_op(p, '{', "after 'spline'"))
        return false;
    int fi = p->nframes - 1, saved = p->frames[fi].in_directive;
    p->frames[fi].in_directive = 0;
    vbnl_sdl_spline *s = sdl_alloc(p, sizeof *s);
    bool ok = s != NULL;
    if (s) {
        s->refs = 1;
        s->type = VBI_SPLINE_LINEAR;
        s->dim = 1;
    }
    while (ok && !p->failed) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            if (fi < p->nframes)
                p->frames[fi].in_directive = saved;
            vbnl_sdl_next(p);
            break;
        }
        if (t->kind == VBNL_SDL_TOK_IDENT && !t->keyword) {
            static const char *const types[] = { "linear_spline", "quadratic_spline", "cubic_spline", "natural_spline" };
            bool found = false;
            for (int k = 0; k < 4; k++)
                if (strcmp(t->text, types[k]) == 0) {
                    s->type = k;
                    found = true;
                }
            if (found) {
                vbnl_sdl_next(p);
                continue;
            }
            sdl_sym *sym = sdl_lookup(p, t->text);
            if (sym && sym->val.kind == VBNL_SDL_SPLINE) {
                const vbnl_sdl_spline *o = sym->val.u.spline;
                s->type = o->type;
                s->dim = o->dim > s->dim ? o->dim : s->dim;
                for (int i = 0; ok && i < o->n; i++)
                    ok = add_point(p, s, o->t[i], o->v[i]);
                vbnl_sdl_next(p);
                continue;
            }
        }
        if (t->kind == VBNL_SDL_TOK_EOF) {
            sdl_errorf(p, loc, "missing '}' for the spline opened here");
            ok = false;
            break;
        }
        double key;
        vbnl_sdl_value v;
        vbnl_sdl_loc vl;
        if (!sdl_expr_float(p, &key, "a spline key")) {
            ok = false;
            break;
        }
        vbnl_sdl_accept(p, ',');
        vl = vbnl_sdl_peek(p)->loc;
        if (!sdl_expr(p, &v)) {
            ok = false;
            break;
        }
        double c[5] = { 0, 0, 0, 0, 0 };
        int d = v.kind == VBNL_SDL_FLOAT ? 1 : v.dim;
        if (v.kind != VBNL_SDL_FLOAT && v.kind != VBNL_SDL_VECTOR && v.kind != VBNL_SDL_COLOR) {
            sdl_errorf(p, &vl, "spline points must be floats or vectors, found a %s", vbnl_sdl_kind_name(v.kind));
            vbnl_sdl_value_clear(p, &v);
            ok = false;
            break;
        }
        memcpy(c, v.v, sizeof c);
        vbnl_sdl_value_clear(p, &v);
        if (d > s->dim)
            s->dim = d;
        ok = add_point(p, s, key, c);
        vbnl_sdl_accept(p, ',');
    }
    if (fi < p->nframes)
        p->frames[fi].in_directive = saved;
    if (!ok || p->failed) {
        sdl_spline_release(p, s);
        return false;
    }
    out->kind = VBNL_SDL_SPLINE;
    out->u.spline = s;
    return true;
}

/* Natural cubic second derivatives for component k over keys [a, b]. */
static void natural_eval(const vbnl_sdl_spline *s, int a, int b, double t, double *out)
{
    int n = b - a + 1;
    double m[64], u[64];
    if (n > 64) { /* long splines: evaluate on the 64 keys around t */
        int c = a;
        while (c < b && s->t[c + 1] < t)
            c++;
        a = c - 31 < a ? a : c - 31;
        b = a + 63 > b ? b : a + 63;
        n = b - a + 1;
    }
    for (int k = 0; k < 5; k++) {
        const double *x = s->t + a;
        m[0] = u[0] = 0;
        for (int i = 1; i < n - 1; i++) {
            double sig = (x[i] - x[i - 1]) / (x[i + 1] - x[i - 1]);
            double q = sig * m[i - 1] + 2;
            m[i] = (sig - 1) / q;
            double dy = (s->v[a + i + 1][k] - s->v[a + i][k]) / (x[i + 1] - x[i]) -
                        (s->v[a + i][k] - s->v[a + i - 1][k]) / (x[i] - x[i - 1]);
            u[i] = (6 * dy / (x[i + 1] - x[i - 1]) - sig * u[i - 1]) / q;
        }
        m[n - 1] = 0;
        for (int i = n - 2; i >= 0; i--)
            m[i] = m[i] * m[i + 1] + u[i];
        int lo = 0;
        while (lo < n - 2 && x[lo + 1] < t)
            lo++;
        double h = x[lo + 1] - x[lo], A = (x[lo + 1] - t) / h, B = (t - x[lo]) / h;
        out[k] = A * s->v[a + lo][k] + B * s->v[a + lo + 1][k] +
                 ((A * A * A - A) * m[lo] + (B * B * B - B) * m[lo + 1]) * h * h / 6;
    }
}

static void spline_eval(const vbnl_sdl_spline *s, int type, double t, double *out)
{
    memset(out, 0, 5 * sizeof *out);
    if (s->n == 0)
        return;
    int a = 0, b = s->n - 1;
    if (type == VBI_SPLINE_CUBIC && s->n >= 4) {
        a = 1;
        b = s->n - 2;
    }
    if (t <= s->t[a] || a == b) {
        memcpy(out, s->v[a], 5 * sizeof *out);
        return;
    }
    if (t >= s->t[b]) {
        memcpy(out, s->v[b], 5 * sizeof *out);
        return;
    }
    int i = a;
    while (i < b - 1 && s->t[i + 1] < t)
        i++;
    double t0 = s->t[i], t1 = s->t[i + 1], f = (t - t0) / (t1 - t0);
    if (type == VBI_SPLINE_LINEAR || s->n < 3) {
        for (int k = 0; k < 5; k++)
            out[k] = s->v[i][k] + (s->v[i + 1][k] - s->v[i][k]) * f;
        return;
    }
    if (type == VBI_SPLINE_CUBIC) {
        int im = i > 0 ? i - 1 : i, ip = i + 2 < s->n ? i + 2 : i + 1;
        double h = t1 - t0, f2 = f * f, f3 = f2 * f;
        for (int k = 0; k < 5; k++) {
            double m0 = (s->v[i + 1][k] - s->v[im][k]) / (s->t[i + 1] - s->t[im]) * h;
            double m1 = (s->v[ip][k] - s->v[i][k]) / (s->t[ip] - s->t[i]) * h;
            out[k] = (2 * f3 - 3 * f2 + 1) * s->v[i][k] + (f3 - 2 * f2 + f) * m0 + (-2 * f3 + 3 * f2) * s->v[i + 1][k] +
                     (f3 - f2) * m1;
        }
        return;
    }
    natural_eval(s, 0, s->n - 1, t, out);
}

bool sdl_call_spline(vbnl_sdl_parser *p, const vbnl_sdl_spline *s, const vbnl_sdl_loc *loc, vbnl_sdl_value *out)
{
    (void)loc;
    double t;
    int type = s->type;
    memset(out, 0, sizeof *out);
    if (!sdl_expect_op(p, '(', "after spline name") || !sdl_expr_float(p, &t, "the spline argument"))
        return false;
    if (vbnl_sdl_accept(p, ',')) {
        const vbnl_sdl_token *k = vbnl_sdl_next(p);
        static const char *const types[] = { "linear_spline", "quadratic_spline", "cubic_spline", "natural_spline" };
        type = -1;
        for (int i = 0; i < 4; i++)
            if (k->kind == VBNL_SDL_TOK_IDENT && strcmp(k->text, types[i]) == 0)
                type = i;
        if (type < 0) {
            char b[80];
            sdl_errorf(p, &k->loc, "expected a spline type, found %s", sdl_token_describe(k, b, sizeof b));
            return false;
        }
    }
    if (!sdl_expect_op(p, ')', "after the spline argument"))
        return false;
    double c[5];
    spline_eval(s, type, t, c);
    if (s->dim <= 1)
        sdl_set_float(out, c[0]);
    else
        sdl_set_vector(out, s->dim, c);
    return true;
}
