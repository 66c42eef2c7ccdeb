/* vbnl object layer: triangle { a, b, c } and smooth_triangle { a, na, b, nb, c, nc }. */
#include "pov_shape.h"

vbnl_result pov_triangle_values(pov_loader *L, int smooth, double v[3][3], double n[3][3])
{
    for (int k = 0; k < 3; ++k) {
        if (k)
            pov_comma(L);
        if (pov_vec3(L, v[k]) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (smooth) {
            pov_comma(L);
            if (pov_vec3(L, n[k]) != VBNL_OK)
                return VBNL_ERR_PARSE;
        }
    }
    return VBNL_OK;
}

void pov_triangle_normals(double v[3][3], double n[3][3], int smooth)
{
    double e1[3], e2[3], f[3];
    for (int i = 0; i < 3; ++i) {
        e1[i] = v[1][i] - v[0][i];
        e2[i] = v[2][i] - v[0][i];
    }
    pov_cross3(e1, e2, f);
    double lf = pov_len3(f);
    for (int k = 0; k < 3; ++k) {
        double l = smooth ? pov_len3(n[k]) : 0;
        if (l > 0)
            pov_scale3(n[k], 1 / l);
        else if (lf > 0)
            for (int i = 0; i < 3; ++i)
                n[k][i] = f[i] / lf;
        else
            pov_set3(n[k], 0, 1, 0);
    }
}

vbnl_result pov_shape_triangle(const pov_shape *s)
{
    int smooth = s->keyword[0] == 's';
    double v[3][3], n[3][3];
    if (pov_triangle_values(s->L, smooth, v, n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_triangle_normals(v, n, smooth);
    pov_mesh *m = pov_mesh_new();
    if (!m)
        return pov_oom(s->L);
    uint32_t id[3];
    for (int k = 0; k < 3; ++k)
        id[k] = pov_mesh_vertex(m, v[k], smooth ? n[k] : NULL, NULL);
    if (!pov_mesh_tri(m, id[0], id[1], id[2], -1)) {
        pov_mesh_unref(m);
        return pov_oom(s->L);
    }
    if (pov_shape_add_mesh(s, m) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return pov_shape_modifiers(s);
}
