/* vbnl object layer: mesh2 { vertex_vectors normal_vectors uv_vectors texture_list face_indices
 *                            normal_indices uv_indices [inside_vector V] modifiers }. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_shape.h"

/* The vector lists, in the order of mesh2_rows. */
enum { VERTEX_VECTORS = 0, NORMAL_VECTORS, UV_VECTORS, NORMAL_INDICES, UV_INDICES, LISTS };

/* The lists read so far (each may come again: the last one counts). */
typedef struct mesh2 {
    pov_loader *L;
    double *list[LISTS];
    size_t count[LISTS];
    double *fi; /* face_indices */
    size_t nfi;
    int32_t *ftex; /* per face: first texture index or -1 */
    pov_appearance **texs;
    size_t ntex;
} mesh2;

/* The count that opens a list (after its '{'): a whole number in [0, max], max_text in the
 * message, reported at loc (NULL: where the count ends). Before vectors a '<' ends the count. */
static vbnl_result read_count(pov_loader *L, const char *what, int vectors, double max, const char *max_text,
                              const vbnl_sdl_loc *loc, double *n)
{
    if ((vectors ? pov_list_count(L, n) : pov_float(L, n)) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_loc at = loc ? *loc : vbnl_sdl_peek(L->c.parser)->loc;
    if (!(*n >= 0 && *n <= max) || *n != floor(*n))
        return vbnl_sdl_error(L->c.parser, &at, "%s: the count must be a whole number in [0, %s], got %g", what, max_text, *n);
    return VBNL_OK;
}

/* A counted list "{ n, item, item ... }" of vectors (dim 2 or 3). */
static vbnl_result counted_vectors(pov_loader *L, const char *what, int dim, double **out, size_t *count)
{
    vbnl_sdl_parser *p = L->c.parser;
    double n;
    *out = NULL;
    *count = 0;
    if (vbnl_sdl_expect(p, '{', "after the list keyword") != VBNL_OK || read_count(L, what, 1, 1e8, "1e8", NULL, &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    double *v = malloc(sizeof(double) * (size_t)dim * ((size_t)n + 1));
    if (!v)
        return pov_oom(L);
    for (size_t i = 0; i < (size_t)n; ++i) {
        pov_comma(L);
        if (pov_is_punct(vbnl_sdl_peek(p), '}')) {
            free(v);
            return vbnl_sdl_error(p, NULL, "%s: %zu items given, %g declared", what, i, n);
        }
        if (vbnl_sdl_parse_vector(p, dim, v + (size_t)dim * i) != VBNL_OK) {
            free(v);
            return VBNL_ERR_PARSE;
        }
    }
    pov_comma(L);
    if (vbnl_sdl_expect(p, '}', "after the declared number of items") != VBNL_OK) {
        free(v);
        return VBNL_ERR_PARSE;
    }
    *out = v;
    *count = (size_t)n;
    return VBNL_OK;
}

/* `keyword { n` of texture_list and face_indices. */
static vbnl_result list_head(const pov_item *it, int vectors, double max, const char *max_text, double *n)
{
    char ctx[64];
    snprintf(ctx, sizeof ctx, "after '%s'", it->kw);
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_expect(it->p, '{', ctx) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return read_count(((mesh2 *)it->target)->L, it->kw, vectors, max, max_text, &it->loc, n);
}

/* vertex_vectors normal_vectors uv_vectors normal_indices uv_indices (`arg`: which list). */
static vbnl_result list_item(const pov_item *it)
{
    mesh2 *m2 = it->target;
    vbnl_sdl_next(it->p);
    free(m2->list[it->arg]);
    return counted_vectors(m2->L, it->kw, it->arg == UV_VECTORS ? 2 : 3, &m2->list[it->arg], &m2->count[it->arg]);
}

static vbnl_result texture_list(const pov_item *it)
{
    mesh2 *m2 = it->target;
    pov_loader *L = m2->L;
    vbnl_sdl_parser *p = it->p;
    double n;
    if (list_head(it, 0, 1e6, "1e6", &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    for (size_t i = 0; i < m2->ntex; ++i)
        pov_appearance_free(m2->texs[i]);
    free(m2->texs);
    m2->ntex = 0;
    m2->texs = calloc((size_t)n + 1, sizeof *m2->texs);
    if (!m2->texs)
        return pov_oom(L);
    for (size_t i = 0; i < (size_t)n; ++i) {
        pov_comma(L);
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (!pov_is_word(t, "texture"))
            return vbnl_sdl_error(p, NULL, "texture_list: expected 'texture' (%zu of %g)", i + 1, n);
        if (pov_appearance_parse_modifier(&L->c, &m2->texs[m2->ntex]) != VBNL_OK)
            return VBNL_ERR_PARSE;
        m2->ntex++;
    }
    pov_comma(L);
    return vbnl_sdl_expect(p, '}', "after the textures of 'texture_list'");
}

static vbnl_result face_indices(const pov_item *it)
{
    mesh2 *m2 = it->target;
    pov_loader *L = m2->L;
    vbnl_sdl_parser *p = it->p;
    double n;
    if (list_head(it, 1, 1e8, "1e8", &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    free(m2->fi);
    free(m2->ftex);
    m2->nfi = (size_t)n;
    m2->fi = malloc(sizeof(double) * 3 * (m2->nfi + 1));
    m2->ftex = malloc(sizeof(int32_t) * (m2->nfi + 1));
    if (!m2->fi || !m2->ftex)
        return pov_oom(L);
    for (size_t i = 0; i < m2->nfi; ++i) {
        pov_comma(L);
        if (vbnl_sdl_parse_vector(p, 3, m2->fi + 3 * i) != VBNL_OK)
            return VBNL_ERR_PARSE;
        m2->ftex[i] = -1;
        /* texture indices, only after a texture_list (as POV-Ray reads them): one, or
         * three (per vertex; the first is used) */
        for (int k = 0; k < (m2->ntex > 0 ? 3 : 0); ++k) {
            const vbnl_sdl_token *a = vbnl_sdl_peek(p);
            if (!pov_is_punct(a, ','))
                break;
            vbnl_sdl_next(p);
            a = vbnl_sdl_peek(p);
            if (pov_is_punct(a, '<') || pov_is_punct(a, '}'))
                break;
            double ti;
            if (pov_float(L, &ti) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (k == 0)
                m2->ftex[i] = (int32_t)fmax(-1, fmin(ti, 2e9));
        }
    }
    pov_comma(L);
    return vbnl_sdl_expect(p, '}', "after the declared number of faces");
}

static const pov_row mesh2_rows[] = {
    {"vertex_vectors", list_item, VERTEX_VECTORS},
    {"normal_vectors", list_item, NORMAL_VECTORS},
    {"uv_vectors", list_item, UV_VECTORS},
    {"normal_indices", list_item, NORMAL_INDICES},
    {"uv_indices", list_item, UV_INDICES},
    {"texture_list", texture_list, 0},
    {"face_indices", face_indices, 0},
    {NULL, NULL, 0},
};
static const pov_row *const mesh2_tables[] = {mesh2_rows, NULL};
static const pov_block mesh2_block = {.tables = mesh2_tables};

/* The triangles of the lists, checked against each other. */
static vbnl_result mesh2_make(const pov_shape *s, mesh2 *m2)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    const double *vv = m2->list[VERTEX_VECTORS], *nv = m2->list[NORMAL_VECTORS], *uv = m2->list[UV_VECTORS],
                 *ni = m2->list[NORMAL_INDICES], *ui = m2->list[UV_INDICES], *fi = m2->fi;
    size_t nvv = m2->count[VERTEX_VECTORS], nnv = m2->count[NORMAL_VECTORS], nuv = m2->count[UV_VECTORS],
           nni = m2->count[NORMAL_INDICES], nui = m2->count[UV_INDICES], nfi = m2->nfi, ntex = m2->ntex;
    const int32_t *ftex = m2->ftex;
    vbnl_sdl_loc loc = s->loc;
    vbnl_result r;
    if (!vv || !fi)
        return vbnl_sdl_error(p, &loc, "mesh2 needs vertex_vectors and face_indices");
    if (ni && nni != nfi)
        return vbnl_sdl_error(p, &loc, "mesh2: normal_indices has %zu entries, face_indices %zu", nni, nfi);
    if (ui && nui != nfi)
        return vbnl_sdl_error(p, &loc, "mesh2: uv_indices has %zu entries, face_indices %zu", nui, nfi);
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return pov_oom(L);
    int use_n = nv && (ni || nnv == nvv), use_uv = uv && (ui || nuv == nvv);
    for (size_t f = 0; f < nfi; ++f) {
        uint32_t id[3];
        double tv[3][3], tn[3][3];
        for (int k = 0; k < 3; ++k) {
            double iv = fi[3 * f + k];
            if (!(iv >= 0 && iv < (double)nvv) || iv != floor(iv)) {
                r = vbnl_sdl_error(p, &loc, "mesh2: face %zu uses vertex index %g; vertex_vectors has %zu", f, iv, nvv);
                goto fail;
            }
            memcpy(tv[k], vv + 3 * (size_t)iv, sizeof tv[k]);
            pov_set3(tn[k], 0, 0, 0);
            if (use_n) {
                double in = ni ? ni[3 * f + k] : iv;
                if (!(in >= 0 && in < (double)nnv) || in != floor(in)) {
                    r = vbnl_sdl_error(p, &loc, "mesh2: face %zu uses normal index %g; normal_vectors has %zu", f, in, nnv);
                    goto fail;
                }
                memcpy(tn[k], nv + 3 * (size_t)in, sizeof tn[k]);
            }
        }
        pov_triangle_normals(tv, tn, use_n);
        for (int k = 0; k < 3; ++k) {
            double tuv[2] = {0, 0};
            if (use_uv) {
                double iu = ui ? ui[3 * f + k] : fi[3 * f + k];
                if (!(iu >= 0 && iu < (double)nuv) || iu != floor(iu)) {
                    r = vbnl_sdl_error(p, &loc, "mesh2: face %zu uses uv index %g; uv_vectors has %zu", f, iu, nuv);
                    goto fail;
                }
                memcpy(tuv, uv + 2 * (size_t)iu, sizeof tuv);
            }
            id[k] = pov_mesh_vertex(m, tv[k], use_n ? tn[k] : NULL, use_uv ? tuv : NULL);
        }
        int32_t tx = ftex[f];
        if (tx >= (int32_t)ntex) {
            r = vbnl_sdl_error(p, &loc, "mesh2: face %zu uses texture %d; texture_list has %zu", f, (int)tx, ntex);
            goto fail;
        }
        if (!pov_mesh_tri(m, id[0], id[1], id[2], tx)) {
            r = pov_oom(L);
            goto fail;
        }
    }
    m->texs = m2->texs;
    m->ntex = (uint32_t)ntex;
    m2->texs = NULL;
    m2->ntex = 0;
    return pov_shape_add_mesh(s, m);
fail:
    pov_mesh_unref(m);
    return r;
}

vbnl_result pov_shape_mesh2(const pov_shape *s)
{
    vbnl_sdl_parser *p = s->L->c.parser;
    mesh2 m2;
    memset(&m2, 0, sizeof m2);
    m2.L = s->L;
    vbnl_result r = pov_block_prefix(&mesh2_block, p, s->L, &m2);
    if (r == VBNL_OK)
        r = mesh2_make(s, &m2);
    for (int i = 0; i < LISTS; ++i)
        free(m2.list[i]);
    free(m2.fi);
    free(m2.ftex);
    for (size_t i = 0; i < m2.ntex; ++i)
        pov_appearance_free(m2.texs[i]);
    free(m2.texs);
    if (r != VBNL_OK || pov_block_prefix(&pov_inside_vector_block, p, s->L, NULL) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_shape_modifiers(s);
}
