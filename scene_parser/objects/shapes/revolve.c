/* vbnl object layer: surfaces of revolution around the y axis (pov_surface.h), for lathe, sor,
 * ovus and lemon. The surface point at angle a (from +x towards +z, POV-Ray's uv convention) and
 * profile parameter (seg, t) is (r cos a, y, r sin a); its normal is the profile's normal
 * (dy, -dr) turned by the same angle. */
#include <math.h>
#include <string.h>

#include "pov_surface.h"

#define TAU 6.28318530717958647692

typedef struct revolve {
    pov_profile_fn eval;
    void *user;
    int nseg, flip;
} revolve;

static void revolve_eval(void *user, pov_svert *v)
{
    const revolve *rv = user;
    double u = v->s[0], w = v->s[1];
    int seg = (int)floor(w);
    if (seg >= rv->nseg)
        seg = rv->nseg - 1;
    if (seg < 0)
        seg = 0;
    double t = w - seg, r, y, dr, dy;
    rv->eval(rv->user, seg, t, &r, &y, &dr, &dy);
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
        rv->eval(rv->user, seg, t2, &r2, &y2, &dr2, &dy2);
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
    v->uv[1] = w / rv->nseg;
}

int pov_revolve(pov_smesh *m, pov_profile_fn eval, void *user, int nseg, double tol, int flip)
{
    if (nseg <= 0)
        return 1;
    revolve rv = {eval, user, nseg, flip};
    /* 32 steps around and 4 per segment to start (enough to see every bump of a cubic), then
     * refined to the tolerance */
    double lo[2] = {0, 0}, hi[2] = {1, nseg};
    uint32_t first = m->nt;
    pov_smesh_grid(m, revolve_eval, &rv, lo, hi, 32, 4 * nseg);
    /* the grid runs counter-clockwise in (angle, profile): outward for a profile whose right side
     * is outside, when the angle turns from +x to +z (which is clockwise seen from +y) */
    for (uint32_t t = first; t < m->nt; ++t) {
        uint32_t a = m->t[3 * t + 1];
        m->t[3 * t + 1] = m->t[3 * t + 2];
        m->t[3 * t + 2] = a;
    }
    pov_param pp = {revolve_eval, &rv};
    pov_smesh_refine(m, first, pov_param_mid, &pp, tol, 12);
    return !m->oom;
}
