/* Double-precision vectors and affine maps for pattern evaluation (private header). POV-Ray
 * evaluates its patterns in double precision; the lattice noise and the cell patterns differ from
 * its values in single precision, so the texture code works in doubles. */
#ifndef VBI_TEXTURE_DVEC_H
#define VBI_TEXTURE_DVEC_H

#include <math.h>

typedef struct dvec3 {
    double x, y, z;
} dvec3;

static inline dvec3 d3(double x, double y, double z) { return (dvec3){x, y, z}; }
static inline dvec3 d3_add(dvec3 a, dvec3 b) { return d3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline dvec3 d3_sub(dvec3 a, dvec3 b) { return d3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline dvec3 d3_mul(dvec3 a, dvec3 b) { return d3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline dvec3 d3_scale(dvec3 a, double s) { return d3(a.x * s, a.y * s, a.z * s); }
static inline dvec3 d3_fma(dvec3 a, dvec3 b, double s) { return d3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
static inline double d3_dot(dvec3 a, dvec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline double d3_len(dvec3 a) { return sqrt(d3_dot(a, a)); }
static inline dvec3 d3_cross(dvec3 a, dvec3 b)
{
    return d3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline dvec3 d3_norm(dvec3 a)
{
    double l = d3_len(a);
    return l > 0.0 ? d3_scale(a, 1.0 / l) : a;
}
static inline double d3_comp(dvec3 a, int i) { return i == 0 ? a.x : (i == 1 ? a.y : a.z); }
static inline void d3_set(dvec3 *a, int i, double v)
{
    if (i == 0)
        a->x = v;
    else if (i == 1)
        a->y = v;
    else
        a->z = v;
}

/* Affine map p' = A p + t, row-major (m[r][0..2] the linear part, m[r][3] the translation). */
typedef struct dmat {
    double m[3][4];
} dmat;

static inline dvec3 dmat_point(const dmat *a, dvec3 p)
{
    return d3(a->m[0][0] * p.x + a->m[0][1] * p.y + a->m[0][2] * p.z + a->m[0][3],
              a->m[1][0] * p.x + a->m[1][1] * p.y + a->m[1][2] * p.z + a->m[1][3],
              a->m[2][0] * p.x + a->m[2][1] * p.y + a->m[2][2] * p.z + a->m[2][3]);
}
/* A^T v: how a map's inverse carries normals (a normal n of the input space goes to A^-T n; for
 * A = the map into pattern space given as its inverse, this is the direction it needs). */
static inline dvec3 dmat_transpose_vector(const dmat *a, dvec3 v)
{
    return d3(a->m[0][0] * v.x + a->m[1][0] * v.y + a->m[2][0] * v.z,
              a->m[0][1] * v.x + a->m[1][1] * v.y + a->m[2][1] * v.z,
              a->m[0][2] * v.x + a->m[1][2] * v.y + a->m[2][2] * v.z);
}
/* The cofactor matrix of the linear part applied to v: det(A) A^-T v. */
static inline dvec3 dmat_cofactor_vector(const dmat *a, dvec3 v)
{
    const double(*m)[4] = a->m;
    dvec3 c0 = d3(m[1][1] * m[2][2] - m[1][2] * m[2][1], m[1][2] * m[2][0] - m[1][0] * m[2][2],
                  m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    dvec3 c1 = d3(m[0][2] * m[2][1] - m[0][1] * m[2][2], m[0][0] * m[2][2] - m[0][2] * m[2][0],
                  m[0][1] * m[2][0] - m[0][0] * m[2][1]);
    dvec3 c2 = d3(m[0][1] * m[1][2] - m[0][2] * m[1][1], m[0][2] * m[1][0] - m[0][0] * m[1][2],
                  m[0][0] * m[1][1] - m[0][1] * m[1][0]);
    return d3(d3_dot(c0, v), d3_dot(c1, v), d3_dot(c2, v));
}

#endif
