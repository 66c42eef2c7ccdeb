/* vbnl object layer: bicubic_patch { type 0|1 [flatness f] [u_steps n] [v_steps n] [accuracy a]
 *                                    [uv_vectors <a>, <b>, <c>, <d>]  16 control points  modifiers }
 *
 * POV-Ray 3.7's Bezier patch (bezier.cpp): the 4 x 4 control points P[i][j] as given (row i the
 * u index, column j the v index), S(u, v) = sum B_i(u) B_j(v) P[i][j] over [0, 1]^2. It is made
 * as an 8 x 8 grid refined to POV_TESS_TOL of the control points' radius, normals from the exact
 * partial derivatives. uv_mapping: the bilinear map of the uv_vectors (default <0,0> <1,0> <1,1>
 * <0,1>) at (u, v), as POV-Ray's. A patch has no inside. type, flatness, u_steps, v_steps and
 * accuracy choose POV-Ray's own subdivision and change nothing here. */
#include <string.h>

#include "pov_surface.h"

typedef struct bicubic {
    pov_mods mods;
    double P[4][4][3];
    double st[4][2];
    double dummy;
} bicubic;

static void bernstein(double t, double b[4], double db[4])
{
    double s = 1 - t;
    b[0] = s * s * s;
    b[1] = 3 * t * s * s;
    b[2] = 3 * t * t * s;
    b[3] = t * t * t;
    db[0] = -3 * s * s;
    db[1] = 3 * s * s - 6 * t * s;
    db[2] = 6 * t * s - 3 * t * t;
    db[3] = 3 * t * t;
}

static void patch_eval(void *user, pov_svert *v)
{
    const bicubic *bp = user;
    double bu[4], dbu[4], bv[4], dbv[4], du[3] = {0, 0, 0}, dv[3] = {0, 0, 0};
    bernstein(v->s[0], bu, dbu);
    bernstein(v->s[1], bv, dbv);
    pov_set3(v->p, 0, 0, 0);
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int k = 0; k < 3; ++k) {
                v->p[k] += bu[i] * bv[j] * bp->P[i][j][k];
                du[k] += dbu[i] * bv[j] * bp->P[i][j][k];
                dv[k] += bu[i] * dbv[j] * bp->P[i][j][k];
            }
    pov_cross3(du, dv, v->n);
    double l = pov_len3(v->n);
    if (!(l > 1e-12)) { /* a degenerate corner: the normal just inside it */
        pov_svert w = *v;
        w.s[0] = v->s[0] + (v->s[0] < 0.5 ? 1e-4 : -1e-4);
        w.s[1] = v->s[1] + (v->s[1] < 0.5 ? 1e-4 : -1e-4);
        patch_eval(user, &w);
        memcpy(v->n, w.n, sizeof v->n);
    } else {
        pov_scale3(v->n, 1 / l);
    }
    double u = v->s[0], t = v->s[1];
    for (int k = 0; k < 2; ++k)
        v->uv[k] = (1 - u) * (1 - t) * bp->st[0][k] + u * (1 - t) * bp->st[1][k] + u * t * bp->st[2][k] +
                   (1 - u) * t * bp->st[3][k];
}

static vbnl_result uv_vectors(const pov_item *it)
{
    bicubic *bp = it->target;
    vbnl_sdl_next(it->p);
    for (int k = 0; k < 4; ++k) {
        if (k)
            pov_comma(it->ctx);
        if (vbnl_sdl_parse_vector(it->p, 2, bp->st[k]) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
    return VBNL_OK;
}

/* `v_steps 3 <0, 0, 0>, ...`: the '<' after the value starts the first control point */
static vbnl_result lead_value(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    return pov_list_count(it->ctx, &((bicubic *)it->target)->dummy);
}

static const pov_row lead_rows[] = {
    {"type", lead_value, 0},
    {"flatness", lead_value, 0},
    {"u_steps", lead_value, 0},
    {"v_steps", lead_value, 0},
    {"accuracy", lead_value, 0},
    {"uv_vectors", uv_vectors, 0},
    {NULL, NULL, 0},
};
static const pov_row *const lead_tables[] = {lead_rows, NULL};
static const pov_block lead_block = {.tables = lead_tables};

static const pov_row patch_rows[] = {{NULL, NULL, 0}};
POV_SHAPE_BLOCK(patch_block, patch_rows);

static vbnl_result patch_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    bicubic *bp = (bicubic *)mods;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int k = 0; k < 3; ++k) {
                lo[k] = fmin(lo[k], bp->P[i][j][k]);
                hi[k] = fmax(hi[k], bp->P[i][j][k]);
            }
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    double a[2] = {0, 0}, b[2] = {1, 1};
    pov_smesh_grid(&sm, patch_eval, bp, a, b, 8, 8);
    pov_param pp = {patch_eval, bp};
    pov_smesh_refine(&sm, 0, pov_param_mid, &pp, POV_TESS_TOL * pov_box_radius(lo, hi), 10);
    return pov_shape_set_mesh(s, pr, &sm, 1, NULL);
}

vbnl_result pov_shape_bicubic(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    bicubic bp;
    memset(&bp, 0, sizeof bp);
    static const double st[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    memcpy(bp.st, st, sizeof st);
    /* the leading values: keywords, or POV-Ray 1's bare numbers (type [flatness] u_steps v_steps) */
    if (vbnl_sdl_peek(p)->kind == VBNL_SDL_TOK_NUMBER) {
        double type;
        if (pov_list_count(L, &type) != VBNL_OK)
            return VBNL_ERR_PARSE;
        int n = type == 2 || type == 3 ? 3 : 2;
        for (int k = 0; k < n; ++k)
            if ((pov_comma(L), pov_list_count(L, &bp.dummy)) != VBNL_OK)
                return VBNL_ERR_PARSE;
    }
    if (pov_block_prefix(&lead_block, p, L, &bp) != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            pov_comma(L);
            if (pov_vec3(L, bp.P[i][j]) != VBNL_OK)
                return VBNL_ERR_PARSE;
        }
    return pov_shape_deferred(s, &patch_block, &bp.mods, patch_make);
}
