/* vbnl object layer: triangle meshes and the tessellation of POV-Ray shapes.
 *
 * Counts: spheres (when not analytic), cylinders, cones, discs and tori use 64 segments around
 * their axis; spheres use 32 rings pole to pole and tori 32 segments around the tube. Curved
 * surfaces carry exact vertex normals, so shading is smooth; the silhouette error of a 64-gon is
 * 0.12% of the radius. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_object.h"

#define PI 3.14159265358979323846

/* ---- meshes --------------------------------------------------------------------------------- */

pov_mesh *pov_mesh_new(void)
{
    pov_mesh *m = calloc(1, sizeof *m);
    if (m)
        m->refs = 1;
    return m;
}

void pov_mesh_unref(pov_mesh *m)
{
    if (!m || --m->refs > 0)
        return;
    free(m->pos);
    free(m->nrm);
    free(m->uv);
    free(m->idx);
    free(m->ftex);
    for (uint32_t i = 0; i < m->ntex; ++i)
        pov_appearance_free(m->texs[i]);
    free(m->texs);
    free(m);
}

uint32_t pov_mesh_vertex(pov_mesh *m, const double p[3], const double n[3], const double uv[2])
{
    if (m->nv == m->capv) {
        uint32_t cap = m->capv ? 2 * m->capv : 64;
        float *np = realloc(m->pos, (size_t)cap * 3 * sizeof *np);
        if (!np)
            return UINT32_MAX;
        m->pos = np;
        if (n || m->nrm) {
            float *nn = realloc(m->nrm, (size_t)cap * 3 * sizeof *nn);
            if (!nn)
                return UINT32_MAX;
            m->nrm = nn;
        }
        if (uv || m->uv) {
            float *nu = realloc(m->uv, (size_t)cap * 2 * sizeof *nu);
            if (!nu)
                return UINT32_MAX;
            m->uv = nu;
        }
        m->capv = cap;
    }
    uint32_t i = m->nv++;
    for (int k = 0; k < 3; ++k) {
        m->pos[3 * i + k] = (float)p[k];
        if (m->nrm)
            m->nrm[3 * i + k] = n ? (float)n[k] : 0.0f;
    }
    if (m->uv)
        for (int k = 0; k < 2; ++k)
            m->uv[2 * i + k] = uv ? (float)uv[k] : 0.0f;
    return i;
}

int pov_mesh_tri(pov_mesh *m, uint32_t a, uint32_t b, uint32_t c, int32_t tex)
{
    if (a == UINT32_MAX || b == UINT32_MAX || c == UINT32_MAX)
        return 0;
    if (m->nt == m->capt) {
        uint32_t cap = m->capt ? 2 * m->capt : 64;
        uint32_t *ni = realloc(m->idx, (size_t)cap * 3 * sizeof *ni);
        if (!ni)
            return 0;
        m->idx = ni;
        if (tex >= 0 || m->ftex) {
            int32_t *nf = realloc(m->ftex, (size_t)cap * sizeof *nf);
            if (!nf)
                return 0;
            if (!m->ftex)
                for (uint32_t k = 0; k < m->nt; ++k)
                    nf[k] = -1;
            m->ftex = nf;
        }
        m->capt = cap;
    } else if (tex >= 0 && !m->ftex) {
        m->ftex = malloc((size_t)m->capt * sizeof *m->ftex);
        if (!m->ftex)
            return 0;
        for (uint32_t k = 0; k < m->nt; ++k)
            m->ftex[k] = -1;
    }
    m->idx[3 * m->nt] = a;
    m->idx[3 * m->nt + 1] = b;
    m->idx[3 * m->nt + 2] = c;
    if (m->ftex)
        m->ftex[m->nt] = tex;
    m->nt++;
    return 1;
}

static void normalize3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0)
        for (int i = 0; i < 3; ++i)
            v[i] /= l;
}

static void cross3(const double a[3], const double b[3], double o[3])
{
    double r[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    memcpy(o, r, sizeof r);
}

/* Orthonormal u, v perpendicular to the unit vector w. */
static void basis(const double w[3], double u[3], double v[3])
{
    double t[3] = {0, 0, 0};
    t[fabs(w[0]) < 0.6 ? 0 : fabs(w[1]) < 0.6 ? 1 : 2] = 1;
    cross3(w, t, u);
    normalize3(u);
    cross3(w, u, v);
}

static pov_mesh *fail(pov_mesh *m)
{
    pov_mesh_unref(m);
    return NULL;
}

pov_mesh *pov_tess_sphere(const double c[3], double r)
{
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return NULL;
    for (int i = 0; i <= POV_RINGS; ++i) {
        double th = PI * i / POV_RINGS;
        /* the poles exactly on the axis: their triangles share one point (watertight) */
        double st = i == 0 || i == POV_RINGS ? 0.0 : sin(th), ct = i == 0 ? 1.0 : i == POV_RINGS ? -1.0 : cos(th);
        for (int j = 0; j <= POV_SEGMENTS; ++j) {
            double ph = 2 * PI * j / POV_SEGMENTS;
            double n[3] = {st * cos(ph), ct, st * sin(ph)};
            double p[3] = {c[0] + r * n[0], c[1] + r * n[1], c[2] + r * n[2]};
            if (pov_mesh_vertex(m, p, n, NULL) == UINT32_MAX)
                return fail(m);
        }
    }
    const uint32_t w = POV_SEGMENTS + 1;
    for (uint32_t i = 0; i < POV_RINGS; ++i)
        for (uint32_t j = 0; j < POV_SEGMENTS; ++j) {
            uint32_t a = i * w + j, b = a + 1, cc = a + w, d = cc + 1;
            if (i > 0 && !pov_mesh_tri(m, a, b, cc, -1))
                return fail(m);
            if (i + 1 < POV_RINGS && !pov_mesh_tri(m, b, d, cc, -1))
                return fail(m);
        }
    return m;
}

pov_mesh *pov_tess_box(const double a[3], const double b[3])
{
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return NULL;
    double lo[3], hi[3];
    for (int i = 0; i < 3; ++i) {
        lo[i] = fmin(a[i], b[i]);
        hi[i] = fmax(a[i], b[i]);
    }
    for (int k = 0; k < 8; ++k) {
        double p[3] = {k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]};
        if (pov_mesh_vertex(m, p, NULL, NULL) == UINT32_MAX)
            return fail(m);
    }
    static const uint32_t f[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1},
                                      {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
    /* counter-clockwise seen from outside: the geometric normal (p1 - p0) x (p2 - p0) points out,
     * which a flat mesh's shading (and a glass box's inside) follows */
    for (int i = 0; i < 6; ++i)
        if (!pov_mesh_tri(m, f[i][0], f[i][2], f[i][1], -1) ||
            !pov_mesh_tri(m, f[i][0], f[i][3], f[i][2], -1))
            return fail(m);
    return m;
}

pov_mesh *pov_tess_cone(const double b[3], double rb, const double t[3], double rt, int open)
{
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return NULL;
    double w[3] = {t[0] - b[0], t[1] - b[1], t[2] - b[2]};
    double h = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    normalize3(w);
    double u[3], v[3];
    basis(w, u, v);
    double slope = h > 0 ? (rb - rt) / h : 0;
    for (int j = 0; j <= POV_SEGMENTS; ++j) {
        double ph = 2 * PI * j / POV_SEGMENTS, cs = cos(ph), sn = sin(ph);
        double radial[3], n[3], p0[3], p1[3];
        for (int k = 0; k < 3; ++k) {
            radial[k] = cs * u[k] + sn * v[k];
            n[k] = radial[k] + slope * w[k];
            p0[k] = b[k] + rb * radial[k];
            p1[k] = t[k] + rt * radial[k];
        }
        normalize3(n);
        if (pov_mesh_vertex(m, p0, n, NULL) == UINT32_MAX || pov_mesh_vertex(m, p1, n, NULL) == UINT32_MAX)
            return fail(m);
    }
    for (uint32_t j = 0; j < POV_SEGMENTS; ++j) {
        uint32_t a = 2 * j;
        if ((rb > 0 && !pov_mesh_tri(m, a, a + 2, a + 1, -1)) ||
            (rt > 0 && !pov_mesh_tri(m, a + 1, a + 2, a + 3, -1)))
            return fail(m);
    }
    if (!open)
        for (int cap = 0; cap < 2; ++cap) {
            double r = cap ? rt : rb;
            const double *c = cap ? t : b;
            if (!(r > 0))
                continue;
            double n[3] = {cap ? w[0] : -w[0], cap ? w[1] : -w[1], cap ? w[2] : -w[2]};
            uint32_t centre = pov_mesh_vertex(m, c, n, NULL), first = m->nv;
            for (int j = 0; j < POV_SEGMENTS; ++j) {
                double ph = 2 * PI * j / POV_SEGMENTS, p[3];
                for (int k = 0; k < 3; ++k)
                    p[k] = c[k] + r * (cos(ph) * u[k] + sin(ph) * v[k]);
                if (pov_mesh_vertex(m, p, n, NULL) == UINT32_MAX)
                    return fail(m);
            }
            for (uint32_t j = 0; j < POV_SEGMENTS; ++j)
                if (!pov_mesh_tri(m, centre, first + j, first + (j + 1) % POV_SEGMENTS, -1))
                    return fail(m);
        }
    return m;
}

pov_mesh *pov_tess_disc(const double c[3], const double n_in[3], double r, double hole)
{
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return NULL;
    double n[3] = {n_in[0], n_in[1], n_in[2]}, u[3], v[3];
    normalize3(n);
    basis(n, u, v);
    for (int j = 0; j < POV_SEGMENTS; ++j) {
        double ph = 2 * PI * j / POV_SEGMENTS, po[3], pi[3];
        for (int k = 0; k < 3; ++k) {
            double d = cos(ph) * u[k] + sin(ph) * v[k];
            po[k] = c[k] + r * d;
            pi[k] = c[k] + hole * d;
        }
        if (pov_mesh_vertex(m, po, n, NULL) == UINT32_MAX || pov_mesh_vertex(m, pi, n, NULL) == UINT32_MAX)
            return fail(m);
    }
    for (uint32_t j = 0; j < POV_SEGMENTS; ++j) {
        uint32_t a = 2 * j, b = 2 * ((j + 1) % POV_SEGMENTS);
        if (!pov_mesh_tri(m, a, b, a + 1, -1) || (hole > 0 && !pov_mesh_tri(m, b, b + 1, a + 1, -1)))
            return fail(m);
    }
    return m;
}

pov_mesh *pov_tess_torus(double major, double minor)
{
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return NULL;
    for (int i = 0; i <= POV_SEGMENTS; ++i) {
        double th = 2 * PI * i / POV_SEGMENTS;
        for (int j = 0; j <= POV_RINGS; ++j) {
            double ph = 2 * PI * j / POV_RINGS;
            double n[3] = {cos(ph) * cos(th), sin(ph), cos(ph) * sin(th)};
            double p[3] = {(major + minor * cos(ph)) * cos(th), minor * sin(ph),
                           (major + minor * cos(ph)) * sin(th)};
            if (pov_mesh_vertex(m, p, n, NULL) == UINT32_MAX)
                return fail(m);
        }
    }
    const uint32_t w = POV_RINGS + 1;
    for (uint32_t i = 0; i < POV_SEGMENTS; ++i)
        for (uint32_t j = 0; j < POV_RINGS; ++j) {
            uint32_t a = i * w + j, b = a + 1, c = a + w, d = c + 1;
            if (!pov_mesh_tri(m, a, c, b, -1) || !pov_mesh_tri(m, b, c, d, -1))
                return fail(m);
        }
    return m;
}

pov_mesh *pov_tess_plane(const double n_in[3], double d, const double centre[3], double half)
{
    double n[3] = {n_in[0], n_in[1], n_in[2]};
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; ++k)
        n[k] /= len;
    d /= len;
    double off = n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2] - d, p0[3], u[3], v[3];
    for (int k = 0; k < 3; ++k)
        p0[k] = centre[k] - off * n[k];
    basis(n, u, v);
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return NULL;
    for (int c = 0; c < 4; ++c) {
        double su = (c == 1 || c == 2) ? half : -half, sv = c >= 2 ? half : -half, p[3];
        for (int k = 0; k < 3; ++k)
            p[k] = p0[k] + su * u[k] + sv * v[k];
        if (pov_mesh_vertex(m, p, NULL, NULL) == UINT32_MAX)
            return fail(m);
    }
    if (!pov_mesh_tri(m, 0, 1, 2, -1) || !pov_mesh_tri(m, 0, 2, 3, -1))
        return fail(m);
    return m;
}

/* ---- polygons -------------------------------------------------------------------------------- */

static double area2(const double *a, const double *b, const double *c)
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

static int point_in_poly(const double *q, const double *xy, int n)
{
    int in = 0;
    for (int i = 0, j = n - 1; i < n; j = i++) {
        const double *a = xy + 2 * i, *b = xy + 2 * j;
        if ((a[1] > q[1]) != (b[1] > q[1]) && q[0] < (b[0] - a[0]) * (q[1] - a[1]) / (b[1] - a[1]) + a[0])
            in = !in;
    }
    return in;
}

/* Ear clipping of one simple polygon (2D coordinates xy, mesh vertex ids ids). */
static int ear_clip(pov_mesh *m, const double *xy, const uint32_t *ids, int n)
{
    int *idx = malloc(sizeof(int) * (size_t)n);
    if (!idx)
        return 0;
    double area = 0;
    for (int i = 0; i < n; ++i) {
        const double *a = xy + 2 * i, *b = xy + 2 * ((i + 1) % n);
        area += a[0] * b[1] - b[0] * a[1];
    }
    for (int i = 0; i < n; ++i)
        idx[i] = area >= 0 ? i : n - 1 - i;
    int left = n, guard = 0;
    while (left > 3 && guard < left) {
        int found = 0;
        for (int i = 0; i < left; ++i) {
            int ia = idx[(i + left - 1) % left], ib = idx[i], ic = idx[(i + 1) % left];
            const double *a = xy + 2 * ia, *b = xy + 2 * ib, *c = xy + 2 * ic;
            if (area2(a, b, c) <= 0)
                continue;
            int ear = 1;
            for (int k = 0; k < left && ear; ++k) {
                int iq = idx[k];
                if (iq == ia || iq == ib || iq == ic)
                    continue;
                const double *q = xy + 2 * iq;
                if (area2(a, b, q) >= 0 && area2(b, c, q) >= 0 && area2(c, a, q) >= 0)
                    ear = 0;
            }
            if (!ear)
                continue;
            if (!pov_mesh_tri(m, ids[ia], ids[ib], ids[ic], -1)) {
                free(idx);
                return 0;
            }
            memmove(idx + i, idx + i + 1, sizeof(int) * (size_t)(left - i - 1));
            left--;
            found = 1;
            break;
        }
        guard = found ? 0 : guard + 1;
        if (!found)
            break; /* degenerate remainder (collinear points): nothing more to fill */
    }
    if (left == 3 && area2(xy + 2 * idx[0], xy + 2 * idx[1], xy + 2 * idx[2]) != 0 &&
        !pov_mesh_tri(m, ids[idx[0]], ids[idx[1]], ids[idx[2]], -1)) {
        free(idx);
        return 0;
    }
    free(idx);
    return 1;
}

pov_mesh *pov_tess_polygon(const double *pts, int n, int *nested, int *open_last, int *huge)
{
    *nested = 0;
    *huge = 0;
    *open_last = 0;
    /* Newell normal of the whole point list picks the projection plane. */
    double nrm[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i) {
        const double *a = pts + 3 * i, *b = pts + 3 * ((i + 1) % n);
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    int ax = fabs(nrm[0]) > fabs(nrm[1]) ? (fabs(nrm[0]) > fabs(nrm[2]) ? 0 : 2)
                                         : (fabs(nrm[1]) > fabs(nrm[2]) ? 1 : 2);
    int u = (ax + 1) % 3, v = (ax + 2) % 3;
    pov_mesh *m = pov_mesh_new();
    double *xy = malloc(sizeof(double) * 2 * (size_t)(n + 1));
    uint32_t *ids = malloc(sizeof(uint32_t) * (size_t)(n + 1));
    int *starts = malloc(sizeof(int) * 2 * (size_t)(n + 2)), *ends = starts ? starts + n + 2 : NULL;
    if (!m || !xy || !ids || !starts)
        goto oom;
    for (int i = 0; i < n; ++i) {
        xy[2 * i] = pts[3 * i + u];
        xy[2 * i + 1] = pts[3 * i + v];
    }
    int nsub = 0, start = 0, i = 1;
    while (start < n) {
        while (i < n && memcmp(pts + 3 * i, pts + 3 * start, 3 * sizeof(double)) != 0)
            ++i;
        int end = i; /* exclusive */
        if (i >= n)
            *open_last = 1;
        starts[nsub] = start;
        ends[nsub++] = end;
        if (end - start >= 3) {
            for (int k = start; k < end; ++k)
                if ((ids[k] = pov_mesh_vertex(m, pts + 3 * k, NULL, NULL)) == UINT32_MAX)
                    goto oom;
            if (end - start > POV_EAR_CLIP_MAX) { /* bounded work: a fan from the first point */
                *huge = 1;
                for (int k = start + 1; k + 1 < end; ++k)
                    if (!pov_mesh_tri(m, ids[start], ids[k], ids[k + 1], -1))
                        goto oom;
            } else if (!ear_clip(m, xy + 2 * start, ids + start, end - start)) {
                goto oom;
            }
        }
        start = end + 1;
        i = start + 1;
    }
    for (int a = 0; a < nsub; ++a)
        for (int b = 0; b < nsub; ++b) {
            int sa = starts[a], sb = starts[b], eb = ends[b];
            if (a != b && eb - sb >= 3 && point_in_poly(xy + 2 * sa, xy + 2 * sb, eb - sb))
                *nested = 1;
        }
    free(xy);
    free(ids);
    free(starts);
    return m;
oom:
    free(xy);
    free(ids);
    free(starts);
    return fail(m);
}
