/* vbnl object layer: surfaces of revolution around the y axis (pov_surface.h), for lathe, sor,
 * ovus and lemon. The surface point at angle a (from +x towards +z, POV-Ray's uv convention) and
 * profile parameter t of segment seg is (r cos a, y, r sin a); its normal is the profile's
 * normal (dy, -dr) turned by the same angle. Each segment is its own grid, so the normal may
 * turn sharply where two segments meet (a linear spline's corners). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

#define TAU 6.28318530717958647692

typedef struct revolve {
    pov_profile_fn eval;
    void *user;
    int nseg, seg, flip;
} revolve;

static void revolve_eval(void *user, pov_svert *v)
{
    const revolve *rv = user;
    double u = v->s[0], t = v->s[1], r, y, dr, dy;
    rv->eval(rv->user, rv->seg, t, &r, &y, &dr, &dy);
    double a = TAU * u, c = cos(a), s = sin(a);
    if (u == 0 || u == 1)
        c = 1, s = 0;
    v->p[0] = r * c;
    v->p[1] = y;
    v->p[2] = r * s;
    /* the profile's normal: (dy, -dr) points to the right of the direction of travel */
    double nr = dy, ny = -dr, l = hypot(nr, ny);
    if (!(l > 0)) { /* a stationary point of the profile: its neighbours' direction */
        double r2, y2, dr2, dy2, t2 = t < 0.5 ? t + 1e-6 : t - 1e-6;
        rv->eval(rv->user, rv->seg, t2, &r2, &y2, &dr2, &dy2);
        nr = dy2;
        ny = -dr2;
        l = hypot(nr, ny);
        if (!(l > 0))
            nr = 0, ny = 1, l = 1;
    }
    if (rv->flip)
        l = -l;
    v->n[0] = nr / l * c;
    v->n[1] = ny / l;
    v->n[2] = nr / l * s;
    v->uv[0] = u;
    v->uv[1] = (rv->seg + t) / rv->nseg;
}

int pov_revolve(pov_smesh *m, pov_profile_fn eval, void *user, int nseg, double tol, int flip)
{
    for (int seg = 0; seg < nseg && !m->oom; ++seg) {
        revolve rv = {eval, user, nseg, seg, flip};
        /* 32 steps around and 4 along the segment to start (enough to see every bump of a
         * cubic), then refined to the tolerance */
        double lo[2] = {0, 0}, hi[2] = {1, 1};
        uint32_t first = m->nt;
        pov_smesh_grid(m, revolve_eval, &rv, lo, hi, 32, 4);
        /* the grid runs counter-clockwise in (angle, t): with the angle turning from +x to +z
         * (clockwise seen from +y) its face normal is the profile's left: turn it */
        for (uint32_t t = first; t < m->nt; ++t) {
            uint32_t a = m->t[3 * t + 1];
            m->t[3 * t + 1] = m->t[3 * t + 2];
            m->t[3 * t + 2] = a;
        }
        pov_param pp = {revolve_eval, &rv};
        pov_smesh_refine(m, first, pov_param_mid, &pp, tol, 12);
    }
    return !m->oom;
}

static int cmp_angle(const void *a, const void *b, void *user)
{
    const pov_svert *v = user;
    double x = v[*(const uint32_t *)a].uv[0], y = v[*(const uint32_t *)b].uv[0];
    return x < y ? -1 : x > y;
}

int pov_revolve_cap(pov_smesh *m, uint32_t first_vertex, int top, double y, double normal_y)
{
    uint32_t n = 0, *ring = malloc(sizeof *ring * (m->nv - first_vertex + 1));
    if (!ring) {
        m->oom = 1;
        return 0;
    }
    double want = top ? 1.0 : 0.0;
    for (uint32_t i = first_vertex; i < m->nv; ++i)
        if (m->v[i].uv[1] == want && m->v[i].uv[0] < 1)
            ring[n++] = i;
    qsort_r(ring, n, sizeof *ring, cmp_angle, m->v);
    pov_svert c;
    memset(&c, 0, sizeof c);
    c.p[1] = y;
    c.n[1] = normal_y;
    c.uv[1] = want;
    uint32_t ci = pov_smesh_vert(m, &c);
    /* the rim again with the cap's normal, fanned from the centre */
    uint32_t base = m->nv, kept = 0;
    double last = -1;
    for (uint32_t i = 0; i < n && !m->oom; ++i) {
        pov_svert v = m->v[ring[i]];
        if (v.uv[0] == last)
            continue;
        last = v.uv[0];
        v.n[0] = v.n[2] = 0;
        v.n[1] = normal_y;
        pov_smesh_vert(m, &v);
        kept++;
    }
    for (uint32_t i = 0; i < kept && !m->oom; ++i)
        pov_smesh_tri_facing(m, ci, base + i, base + (i + 1) % kept);
    free(ring);
    return !m->oom;
}
