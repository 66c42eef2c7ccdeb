/* vbnl object layer: blob { [threshold t]
 *                          sphere { <c>, r, [strength] s  transforms appearance }
 *                          cylinder { <a>, <b>, r, [strength] s  transforms appearance }
 *                          component s, r, <c>
 *                          [sturm] [hierarchy b] modifiers }
 *
 * POV-Ray 3.7's blob (blob.cpp): each component adds s (1 - d^2 / r^2)^2 within its radius r,
 * where d is the distance to a sphere's centre, or to a cylinder's axis between its ends with a
 * half sphere on each end; a component's transforms move and stretch its field. The surface is
 * where the sum reaches the threshold (default 1), the inside where it exceeds it. It is made by
 * dual contouring (implicit.c) over the positive components' reach, with cells of at most half
 * the smallest radius (at most 256 along the longest side), refined to POV_TESS_TOL of the
 * blob's radius; the field's gradient bound skips the cells far from the surface. A component's
 * own texture is blended by density in POV-Ray; here the blob takes the first component's texture
 * when it has none of its own (with a warning). */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

enum { COMP_SPHERE = 0, COMP_CYLINDER };

typedef struct blob_comp {
    int type;
    int plain;           /* a sphere only moved: its centre is c */
    double c[3];
    double inv[16];     /* object space -> the component's (sphere: centred; cylinder: axis along z) */
    double r2, len, s;  /* radius^2, cylinder length, strength */
    double lo[3], hi[3]; /* its reach in object space */
} blob_comp;

typedef struct blob_data {
    blob_comp *c;
    size_t n, cap;
    double threshold;
} blob_data;

static double comp_density(const blob_comp *c, const double p[3])
{
    if (p[0] < c->lo[0] || p[0] > c->hi[0] || p[1] < c->lo[1] || p[1] > c->hi[1] || p[2] < c->lo[2] || p[2] > c->hi[2])
        return 0;
    double q[3], d2;
    pov_m4_point(c->inv, p, q);
    if (c->type == COMP_SPHERE) {
        d2 = pov_dot3(q, q);
    } else if (q[2] < 0) {
        d2 = pov_dot3(q, q);
    } else if (q[2] > c->len) {
        double e[3] = {q[0], q[1], q[2] - c->len};
        d2 = pov_dot3(e, e);
    } else {
        d2 = q[0] * q[0] + q[1] * q[1];
    }
    if (!(d2 < c->r2))
        return 0;
    double t = 1 - d2 / c->r2;
    return c->s * t * t;
}

static double blob_field(void *user, const double p[3])
{
    const blob_data *d = user;
    double sum = 0;
    for (size_t i = 0; i < d->n; ++i)
        sum += comp_density(&d->c[i], p);
    return d->threshold - sum; /* < 0 inside */
}

static int blob_inside(const void *data, const double q[3]) { return blob_field((void *)data, q) < 0; }

static double density_at(const blob_comp *c, double d2)
{
    if (!(d2 < c->r2))
        return 0;
    double t = 1 - d2 / c->r2;
    return c->s * t * t;
}

/* 1 when the field cannot reach the threshold anywhere in the box, or exceeds it everywhere
 * there: the range of each component's density over the box (exact for a moved sphere, whose
 * density falls with the distance; 0 to its strength for the others it reaches) summed. */
static int blob_excludes(void *user, const double lo[3], const double hi[3])
{
    const blob_data *d = user;
    double smin = 0, smax = 0;
    for (size_t i = 0; i < d->n; ++i) {
        const blob_comp *c = &d->c[i];
        if (hi[0] < c->lo[0] || lo[0] > c->hi[0] || hi[1] < c->lo[1] || lo[1] > c->hi[1] || hi[2] < c->lo[2] ||
            lo[2] > c->hi[2])
            continue;
        double a, b;
        if (c->plain) {
            double near2 = 0, far2 = 0;
            for (int k = 0; k < 3; ++k) {
                double e = fmax(0, fmax(lo[k] - c->c[k], c->c[k] - hi[k])), f = fmax(fabs(lo[k] - c->c[k]), fabs(hi[k] - c->c[k]));
                near2 += e * e;
                far2 += f * f;
            }
            a = density_at(c, far2);
            b = density_at(c, near2);
        } else {
            a = 0;
            b = c->s;
        }
        smin += fmin(a, b);
        smax += fmax(a, b);
    }
    return smax < d->threshold || smin > d->threshold;
}

static void blob_destroy(void *data)
{
    blob_data *d = data;
    free(d->c);
    free(d);
}

static const pov_solid_fn blob_fn = {blob_inside, blob_destroy, NULL};

/* ---- components ---------------------------------------------------------------------------------- */

typedef struct comp_build {
    pov_loader *L;
    double m[16];         /* the component's transforms so far */
    pov_appearance *app;  /* its texture, if any */
} comp_build;

static void comp_transform(const pov_item *it, const double m[16])
{
    comp_build *cb = it->target;
    pov_m4_mul(m, cb->m, cb->m);
}

static int comp_appearance(const pov_item *it)
{
    if (it->tok->kind != VBNL_SDL_TOK_IDENT || !pov_appearance_is_modifier(it->tok))
        return 0;
    comp_build *cb = it->target;
    return pov_appearance_parse_modifier(&cb->L->c, &cb->app) == VBNL_OK ? 1 : -1;
}

static const pov_row *const comp_tables[] = {pov_transform_rows, NULL};
static const pov_block comp_block = {.tables = comp_tables, .before = comp_appearance, .transform = comp_transform};

typedef struct blob_shape {
    pov_mods mods;
    blob_data *d;
    pov_appearance *first_app;
    vbnl_sdl_loc app_loc;
} blob_shape;

/* The component's reach: its local bounds through its transform. */
static void comp_bounds(blob_comp *c, const double m[16])
{
    double r = sqrt(c->r2), l[3] = {-r, -r, -r}, h[3] = {r, r, r + (c->type == COMP_CYLINDER ? c->len : 0)};
    for (int k = 0; k < 3; ++k) {
        c->lo[k] = INFINITY;
        c->hi[k] = -INFINITY;
    }
    for (int k = 0; k < 8; ++k) {
        double p[3] = {k & 1 ? h[0] : l[0], k & 2 ? h[1] : l[1], k & 4 ? h[2] : l[2]}, q[3];
        pov_m4_point(m, p, q);
        for (int j = 0; j < 3; ++j) {
            c->lo[j] = fmin(c->lo[j], q[j]);
            c->hi[j] = fmax(c->hi[j], q[j]);
        }
    }
}

static vbnl_result add_comp(const pov_item *it, blob_shape *bs, int type, const double a[3], const double b[3],
                            double r, double s, const double m[16])
{
    blob_data *d = bs->d;
    if (!(r > 0))
        return vbnl_sdl_error(it->p, &it->loc, "blob: a component's radius must be positive, got %g", r);
    if (d->n == d->cap) {
        size_t cap = d->cap ? 2 * d->cap : 16;
        blob_comp *n = realloc(d->c, cap * sizeof *n);
        if (!n)
            return pov_oom(it->ctx);
        d->c = n;
        d->cap = cap;
    }
    blob_comp *c = &d->c[d->n];
    memset(c, 0, sizeof *c);
    c->type = type;
    c->r2 = r * r;
    c->s = s;
    double local[16]; /* the component's own frame: a sphere's centre, a cylinder's base and axis */
    pov_m4_identity(local);
    if (type == COMP_SPHERE) {
        local[3] = a[0], local[7] = a[1], local[11] = a[2];
    } else {
        double w[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, u[3], v[3], t[3] = {1, 0, 0};
        c->len = pov_len3(w);
        if (!(c->len > 1e-10))
            return vbnl_sdl_error(it->p, &it->loc, "blob: a cylinder component's ends coincide");
        pov_scale3(w, 1 / c->len);
        if (fabs(w[0]) > 0.6)
            pov_set3(t, 0, 1, 0);
        pov_cross3(w, t, u);
        pov_scale3(u, 1 / pov_len3(u));
        pov_cross3(w, u, v);
        for (int k = 0; k < 3; ++k) { /* columns: u, v, w; then the base */
            local[4 * k] = u[k];
            local[4 * k + 1] = v[k];
            local[4 * k + 2] = w[k];
            local[4 * k + 3] = a[k];
        }
    }
    double full[16];
    pov_m4_mul(m, local, full);
    c->plain = type == COMP_SPHERE && full[0] == 1 && full[1] == 0 && full[2] == 0 && full[4] == 0 && full[5] == 1 &&
               full[6] == 0 && full[8] == 0 && full[9] == 0 && full[10] == 1;
    pov_set3(c->c, full[3], full[7], full[11]);
    if (!pov_m4_invert(full, c->inv))
        return vbnl_sdl_error(it->p, &it->loc, "blob: a component is scaled flat");
    comp_bounds(c, full);
    d->n++;
    return VBNL_OK;
}

/* sphere { } and cylinder { } components */
static vbnl_result blob_component_block(const pov_item *it)
{
    blob_shape *bs = it->target;
    pov_loader *L = it->ctx;
    vbnl_sdl_parser *p = it->p;
    int cyl = it->kw[0] == 'c';
    double a[3], b[3] = {0, 0, 0}, r, s;
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '{', cyl ? "after 'cylinder'" : "after 'sphere'") != VBNL_OK || pov_vec3(L, a) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (cyl && (pov_vec3(L, b) != VBNL_OK || (pov_comma(L), 0)))
        return VBNL_ERR_PARSE;
    if (pov_float(L, &r) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (pov_is_word(vbnl_sdl_peek(p), "strength"))
        vbnl_sdl_next(p);
    if (pov_float(L, &s) != VBNL_OK)
        return VBNL_ERR_PARSE;
    comp_build cb = {L, {0}, NULL};
    pov_m4_identity(cb.m);
    vbnl_result res = pov_block_parse(&comp_block, p, L, &cb, it->kw);
    if (res == VBNL_OK)
        res = add_comp(it, bs, cyl ? COMP_CYLINDER : COMP_SPHERE, a, b, r, s, cb.m);
    if (res == VBNL_OK && cb.app && !bs->first_app) {
        bs->first_app = cb.app;
        bs->app_loc = it->loc;
        cb.app = NULL;
    }
    pov_appearance_free(cb.app);
    return res;
}

/* component s, r, <c> (POV-Ray 1's form) */
static vbnl_result blob_component(const pov_item *it)
{
    pov_loader *L = it->ctx;
    double s, r, c[3], m[16];
    vbnl_sdl_next(it->p);
    if (pov_float(L, &s) != VBNL_OK || (pov_comma(L), pov_float(L, &r)) != VBNL_OK ||
        (pov_comma(L), pov_vec3(L, c)) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_m4_identity(m);
    return add_comp(it, it->target, COMP_SPHERE, c, c, r, s, m);
}

static vbnl_result blob_threshold(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_float(it->ctx, &((blob_shape *)it->target)->d->threshold);
}

static const pov_row blob_rows[] = {
    {"threshold", blob_threshold, 0},
    {"sphere", blob_component_block, 0},
    {"cylinder", blob_component_block, 0},
    {"component", blob_component, 0},
    {NULL, NULL, 0},
};
POV_SHAPE_BLOCK(blob_block, blob_rows);

static vbnl_result blob_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    blob_shape *bs = (blob_shape *)mods;
    blob_data *d = bs->d;
    pov_loader *L = s->L;
    if (bs->first_app) {
        if (!s->o->app) {
            s->o->app = bs->first_app;
            bs->first_app = NULL;
        }
        vbnl_sdl_warning(L->c.parser, &bs->app_loc,
                         "blob: component textures are blended by POV-Ray; the blob is rendered with %s",
                         s->o->app && !bs->first_app ? "the first component's" : "its own");
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, rmin = INFINITY, lip = 0;
    for (size_t i = 0; i < d->n; ++i) {
        const blob_comp *c = &d->c[i];
        /* |d/dd s (1 - d^2/r^2)^2| <= 8 |s| / (3 sqrt 3 r), times the component's stretch */
        double stretch = 0;
        for (int k = 0; k < 3; ++k)
            stretch = fmax(stretch, sqrt(c->inv[k] * c->inv[k] + c->inv[4 + k] * c->inv[4 + k] + c->inv[8 + k] * c->inv[8 + k]));
        lip += 8 * fabs(c->s) / (3 * sqrt(3.0) * sqrt(c->r2)) * stretch;
        if (c->s <= 0)
            continue; /* a negative component adds no inside of its own */
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], c->lo[k]);
            hi[k] = fmax(hi[k], c->hi[k]);
        }
        rmin = fmin(rmin, sqrt(c->r2) / stretch);
    }
    if (!(lo[0] <= hi[0]) || !(d->threshold > 0 || d->n > 0)) {
        pr->mesh = pov_mesh_new();
        return pr->mesh ? VBNL_OK : pov_oom(L);
    }
    double ext = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    int depth = (int)ceil(log2(ext / (0.5 * rmin)));
    depth = depth < 5 ? 5 : depth > 8 ? 8 : depth;
    pov_implicit im;
    memset(&im, 0, sizeof im);
    im.f = blob_field;
    im.user = d;
    memcpy(im.lo, lo, sizeof lo);
    memcpy(im.hi, hi, sizeof hi);
    double r = pov_box_radius(lo, hi);
    im.depth = depth;
    im.lipschitz = lip;
    im.excludes = blob_excludes;
    im.tol = POV_TESS_TOL * r;
    im.grad_step = 1e-6 * r;
    im.max_evals = 60000000;
    return pov_shape_implicit(s, pr, &im, &blob_fn, (void **)&bs->d, lo, hi);
}

vbnl_result pov_shape_blob(const pov_shape *s)
{
    blob_shape bs;
    memset(&bs, 0, sizeof bs);
    if (!(bs.d = calloc(1, sizeof *bs.d)))
        return pov_oom(s->L);
    bs.d->threshold = 1.0;
    vbnl_result r = pov_shape_deferred(s, &blob_block, &bs.mods, blob_make);
    if (bs.d)
        blob_destroy(bs.d);
    pov_appearance_free(bs.first_app);
    return r;
}
