/* vbnl object layer: prism { [linear_sweep | conic_sweep]
 *                            [linear_spline | quadratic_spline | cubic_spline | bezier_spline]
 *                            height1, height2, n, <x, z> ... [open] [sturm] modifiers }
 *
 * POV-Ray 3.7's prism (prism.cpp): the outline's segments are built from the points like the
 * lathe's (linear P[i] to P[i+1], quadratic P[i+1] to P[i+2] with P[i], cubic Catmull-Rom
 * P[i+1] to P[i+2], bezier four points each), and a sub-outline closes when a segment ends on
 * its first point (linear: P[0], quadratic and cubic: P[1]); the next one starts after it. A
 * linear outline left open is closed (with a warning); another one leaves the prism empty, as in
 * POV-Ray. The region is the outline's by the even-odd rule, swept from height1 to height2 along
 * y (linear_sweep) or scaled by the height from the origin (conic_sweep: the outline at height
 * h is h times the points), closed by caps unless `open`. Curves are flattened to POV_TESS_TOL of
 * the prism's radius; walls have the exact normals of the flattened points. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

enum { SPL_LINEAR = 0, SPL_QUADRATIC, SPL_CUBIC, SPL_BEZIER };

typedef struct prism_data {
    pov_outline o;
    double h1, h2;
    int conic;
} prism_data;

static int prism_inside(const void *data, const double q[3])
{
    const prism_data *d = data;
    if (!(q[1] >= d->h1 && q[1] < d->h2))
        return 0;
    double x = q[0], z = q[2];
    if (d->conic) {
        if (!(fabs(q[1]) > 1e-10))
            return 0;
        x /= q[1];
        z /= q[1];
    }
    return pov_outline_inside(&d->o, x, z);
}

static void prism_destroy(void *data)
{
    prism_data *d = data;
    pov_outline_free(&d->o);
    free(d);
}

static const pov_solid_fn prism_fn = {prism_inside, prism_destroy, NULL};

typedef struct cap {
    const prism_data *d;
    double h;
} cap;

static void cap_pos(void *user, double x, double z, double p[3])
{
    const cap *c = user;
    double s = c->d->conic ? c->h : 1;
    p[0] = x * s;
    p[1] = c->h;
    p[2] = z * s;
}

static void wall(void *user, const double xz[2], const double nrm[2], int hi, double p[3], double n[3])
{
    const prism_data *d = user;
    double h = hi ? d->h2 : d->h1;
    if (!d->conic) {
        pov_set3(p, xz[0], h, xz[1]);
        pov_set3(n, nrm[0], 0, nrm[1]);
        return;
    }
    pov_set3(p, xz[0] * h, h, xz[1] * h);
    /* (x(s) h, h, z(s) h): the cross product of d/ds (tangent (t, u) = (-nz, nx) scaled by h)
     * and d/dh (x, 1, z), turned to the outline's outside (mirrored where h < 0) */
    double t[3] = {-nrm[1], 0, nrm[0]}, g[3] = {xz[0], 1, xz[1]};
    pov_cross3(t, g, n);
    double l = pov_len3(n), side = (n[0] * nrm[0] + n[2] * nrm[1]) * (h < 0 ? -1 : 1);
    pov_scale3(n, l > 0 ? (side < 0 ? -1 : 1) / l : 0);
}

typedef struct prism_shape {
    pov_mods mods;
    prism_data *d;
    int open, degenerate;
} prism_shape;

static vbnl_result prism_open(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((prism_shape *)it->target)->open = 1;
    return VBNL_OK;
}

static const pov_row prism_rows[] = {{"open", prism_open, 0}, {NULL, NULL, 0}};
POV_SHAPE_BLOCK(prism_block, prism_rows);

static vbnl_result prism_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    prism_shape *ps = (prism_shape *)mods;
    prism_data *d = ps->d;
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    if (!ps->degenerate) {
        cap lo = {d, d->h1}, hi = {d, d->h2};
        double nlo[3] = {0, -1, 0}, nhi[3] = {0, 1, 0};
        if (d->conic && d->h1 < 0)
            nlo[1] = 1; /* the outline mirrored below the apex */
        if (d->conic && d->h2 < 0)
            nhi[1] = -1;
        if (!ps->open) {
            if (!(d->conic && d->h1 == 0))
                pov_outline_fill(&d->o, &sm, cap_pos, &lo, nlo);
            if (!(d->conic && d->h2 == 0))
                pov_outline_fill(&d->o, &sm, cap_pos, &hi, nhi);
        }
        pov_outline_walls(&d->o, &sm, wall, d);
    }
    double blo[3] = {INFINITY, d->h1, INFINITY}, bhi[3] = {-INFINITY, d->h2, -INFINITY};
    for (uint32_t i = 0; i < d->o.n; ++i)
        for (int k = 0; k < 2; ++k)
            for (int e = 0; e < 2; ++e) {
                double v = d->o.xy[2 * i + k] * (d->conic ? (e ? d->h2 : d->h1) : 1);
                blo[2 * k] = fmin(blo[2 * k], v);
                bhi[2 * k] = fmax(bhi[2 * k], v);
            }
    if (d->o.n == 0 || ps->degenerate)
        blo[0] = blo[2] = bhi[0] = bhi[2] = 0;
    pov_solid *solid = ps->degenerate ? NULL : pov_solid_custom(&prism_fn, d, blo, bhi);
    if (!ps->degenerate) {
        ps->d = NULL;
        if (!solid) {
            pov_smesh_free(&sm);
            return pov_oom(s->L);
        }
    }
    return pov_shape_set_mesh(s, pr, &sm, 0, solid);
}

static int same(const double a[2], const double b[2]) { return fabs(a[0] - b[0]) < 1e-10 && fabs(a[1] - b[1]) < 1e-10; }

/* The segment at point i in power form (A t3 + B t2 + C t + D per coordinate) as Bezier points
 * appended to the outline. */
static void add_segment(pov_outline *o, int type, const double (*P)[2], int i, double tol)
{
    double c[2][4];
    for (int k = 0; k < 2; ++k) {
        double p0 = P[i][k], p1 = P[i + 1][k], p2 = type >= SPL_QUADRATIC ? P[i + 2][k] : 0,
               p3 = type >= SPL_CUBIC ? P[i + 3][k] : 0;
        switch (type) {
        case SPL_QUADRATIC:
            c[k][0] = 0, c[k][1] = 0.5 * p0 - p1 + 0.5 * p2, c[k][2] = -0.5 * p0 + 0.5 * p2, c[k][3] = p1;
            break;
        case SPL_CUBIC:
            c[k][0] = -0.5 * p0 + 1.5 * p1 - 1.5 * p2 + 0.5 * p3;
            c[k][1] = p0 - 2.5 * p1 + 2 * p2 - 0.5 * p3;
            c[k][2] = -0.5 * p0 + 0.5 * p2;
            c[k][3] = p1;
            break;
        default:
            break;
        }
    }
    if (type == SPL_LINEAR) {
        pov_outline_line(o, P[i], P[i + 1]);
    } else if (type == SPL_BEZIER) {
        pov_outline_cubic(o, P[i], P[i + 1], P[i + 2], P[i + 3], tol);
    } else if (type == SPL_QUADRATIC) {
        double b0[2] = {c[0][3], c[1][3]}, b1[2] = {c[0][3] + c[0][2] / 2, c[1][3] + c[1][2] / 2},
               b2[2] = {c[0][1] + c[0][2] + c[0][3], c[1][1] + c[1][2] + c[1][3]};
        pov_outline_quad(o, b0, b1, b2, tol);
    } else {
        double b0[2], b1[2], b2[2], b3[2];
        for (int k = 0; k < 2; ++k) {
            b0[k] = c[k][3];
            b1[k] = c[k][3] + c[k][2] / 3;
            b2[k] = c[k][3] + 2 * c[k][2] / 3 + c[k][1] / 3;
            b3[k] = c[k][0] + c[k][1] + c[k][2] + c[k][3];
        }
        pov_outline_cubic(o, b0, b1, b2, b3, tol);
    }
}

/* The sub-outlines, as POV-Ray's Compute_Prism walks the points. 0: too few points. */
static int build_outline(pov_outline *o, int type, const double (*P)[2], int n, double tol)
{
    static const int need[] = {1, 2, 3, 3}; /* the highest index a segment uses, from i */
    double first[2];
    memcpy(first, type == SPL_QUADRATIC || type == SPL_CUBIC ? P[1] : P[0], sizeof first);
    int start = 1;
    for (int i = 0; i < n - 1; ++i) {
        if (i + need[type] >= n)
            return 0;
        if (start) {
            pov_outline_begin(o);
            start = 0;
        }
        add_segment(o, type, P, i, tol);
        switch (type) {
        case SPL_LINEAR:
            if (same(P[i + 1], first)) {
                i++;
                if (i + 1 < n)
                    memcpy(first, P[i + 1], sizeof first);
                start = 1;
            }
            break;
        case SPL_QUADRATIC:
        case SPL_CUBIC:
            if (same(P[i + 2], first)) {
                i += type == SPL_QUADRATIC ? 2 : 3;
                if (i + 2 < n)
                    memcpy(first, P[i + 2], sizeof first);
                start = 1;
            }
            break;
        default:
            i += 3;
            if (same(P[i], o->xy + 2 * o->start[o->ncont - 1]))
                start = 1;
        }
    }
    return 1;
}

/* POV-Ray's check that every sub-outline closes. */
static int outline_closed(int type, const double (*P)[2], int n)
{
    if (type == SPL_BEZIER) {
        int loop = 0;
        for (int i = 4; i < n; i += 4)
            if (!same(P[i], P[i - 1])) {
                if (!same(P[i - 1], P[loop]))
                    return 0;
                loop = i;
            }
        return same(P[n - 1], P[loop]);
    }
    int i = type == SPL_LINEAR ? 1 : 2, closed = 0;
    double first[2];
    memcpy(first, P[i - 1], sizeof first);
    for (; i < n; ++i) {
        closed = 0;
        if (same(first, P[i])) {
            i += type == SPL_LINEAR ? 1 : type == SPL_QUADRATIC ? 2 : 3;
            if (i < n)
                memcpy(first, P[i], sizeof first);
            closed = 1;
        }
    }
    return closed;
}

vbnl_result pov_shape_prism(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    int type = SPL_LINEAR, conic = 0;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (pov_is_word(t, "linear_spline"))
            type = SPL_LINEAR;
        else if (pov_is_word(t, "quadratic_spline"))
            type = SPL_QUADRATIC;
        else if (pov_is_word(t, "cubic_spline"))
            type = SPL_CUBIC;
        else if (pov_is_word(t, "bezier_spline"))
            type = SPL_BEZIER;
        else if (pov_is_word(t, "linear_sweep"))
            conic = 0;
        else if (pov_is_word(t, "conic_sweep"))
            conic = 1;
        else
            break;
        vbnl_sdl_next(p);
    }
    double h1, h2, count;
    if (pov_float(L, &h1) != VBNL_OK || (pov_comma(L), pov_float(L, &h2)) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    vbnl_sdl_loc at = vbnl_sdl_peek(p)->loc;
    if (pov_list_count(L, &count) != VBNL_OK)
        return VBNL_ERR_PARSE;
    static const int least[] = {3, 5, 6, 4};
    if (!(count >= least[type] && count <= 1e6) || count != floor(count))
        return vbnl_sdl_error(p, &at, "prism: the number of points must be a whole number of at least %d, got %g",
                              least[type], count);
    if (type == SPL_BEZIER && (int)count % 4)
        return vbnl_sdl_error(p, &at, "prism: a bezier_spline needs four points per segment, got %g", count);
    int n = (int)count;
    double(*P)[2] = malloc(sizeof *P * (size_t)(n + 1));
    prism_shape ps;
    memset(&ps, 0, sizeof ps);
    ps.d = calloc(1, sizeof *ps.d);
    vbnl_result r = VBNL_OK;
    if (!P || !ps.d) {
        r = pov_oom(L);
        goto done;
    }
    for (int i = 0; i < n && r == VBNL_OK; ++i) {
        pov_comma(L);
        r = vbnl_sdl_parse_vector(p, 2, P[i]);
    }
    if (r != VBNL_OK)
        goto done;
    ps.d->h1 = fmin(h1, h2);
    ps.d->h2 = fmax(h1, h2);
    ps.d->conic = conic;
    if (!outline_closed(type, (const double(*)[2])P, n)) {
        if (type == SPL_LINEAR) {
            memcpy(P[n], P[0], sizeof P[0]);
            /* POV-Ray closes the last sub-outline with its first point */
            int last = 0;
            for (int i = 1; i < n; ++i)
                if (same(P[i], P[last]) && i + 1 < n)
                    last = i + 1;
            memcpy(P[n], P[last], sizeof P[0]);
            n++;
            vbnl_sdl_warning(p, &s->loc, "prism: the linear outline is not closed; it is closed");
        } else {
            vbnl_sdl_warning(p, &s->loc, "prism: the outline is not closed; the prism is empty (as in POV-Ray)");
            ps.degenerate = 1;
        }
    }
    /* the flattening tolerance: of the prism's size (conic: of the outline at the larger height) */
    double ext = 0;
    for (int i = 0; i < n; ++i)
        ext = fmax(ext, fmax(fabs(P[i][0]), fabs(P[i][1])));
    double hmax = conic ? fmax(fabs(ps.d->h1), fabs(ps.d->h2)) : 1;
    double tol = POV_TESS_TOL * fmax(ext * (hmax > 0 ? hmax : 1), 0.5 * (ps.d->h2 - ps.d->h1)) / (hmax > 0 ? hmax : 1);
    if (!ps.degenerate) {
        if (!build_outline(&ps.d->o, type, (const double(*)[2])P, n, tol)) {
            vbnl_sdl_warning(p, &s->loc, "prism: too few points for the last segment; the prism is empty");
            ps.degenerate = 1;
        } else if (!pov_outline_finish(&ps.d->o)) {
            r = pov_oom(L);
            goto done;
        }
    }
    r = pov_shape_deferred(s, &prism_block, &ps.mods, prism_make);
done:
    free(P);
    if (ps.d)
        prism_destroy(ps.d);
    return r;
}
