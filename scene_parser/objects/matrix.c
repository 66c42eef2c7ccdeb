/* vbnl object layer: 4x4 row-major affine matrices (pov_matrix.h). */
#include <math.h>
#include <string.h>

#include "pov_matrix.h"

#define PI 3.14159265358979323846

void pov_m4_identity(double m[16])
{
    memset(m, 0, 16 * sizeof *m);
    m[0] = m[5] = m[10] = m[15] = 1.0;
}

void pov_m4_mul(const double a[16], const double b[16], double out[16])
{
    double r[16];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            double s = 0;
            for (int k = 0; k < 4; ++k)
                s += a[4 * i + k] * b[4 * k + j];
            r[4 * i + j] = s;
        }
    memcpy(out, r, sizeof r);
}

void pov_m4_translate(const double v[3], double m[16])
{
    pov_m4_identity(m);
    m[3] = v[0];
    m[7] = v[1];
    m[11] = v[2];
}

void pov_m4_scale(const double v[3], double m[16])
{
    pov_m4_identity(m);
    m[0] = v[0];
    m[5] = v[1];
    m[10] = v[2];
}

void pov_m4_rotate(const double deg[3], double m[16])
{
    double rx[16], ry[16], rz[16], t[16];
    double a = deg[0] * PI / 180, b = deg[1] * PI / 180, c = deg[2] * PI / 180;
    pov_m4_identity(rx);
    pov_m4_identity(ry);
    pov_m4_identity(rz);
    rx[5] = cos(a); rx[6] = -sin(a); rx[9] = sin(a); rx[10] = cos(a);
    ry[0] = cos(b); ry[2] = sin(b); ry[8] = -sin(b); ry[10] = cos(b);
    rz[0] = cos(c); rz[1] = -sin(c); rz[4] = sin(c); rz[5] = cos(c);
    pov_m4_mul(ry, rx, t);
    pov_m4_mul(rz, t, m);
}

void pov_m4_from_pov(const double v[12], double m[16])
{
    pov_m4_identity(m);
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            m[4 * r + c] = v[3 * c + r];
        m[4 * r + 3] = v[9 + r];
    }
}

int pov_m4_invert(const double m[16], double out[16])
{
    double a = m[0], b = m[1], c = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9], i = m[10];
    double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
    double det = a * A + b * B + c * C;
    if (!(fabs(det) > 1e-300) || !isfinite(det))
        return 0;
    double r[16];
    r[0] = A / det;
    r[1] = -(b * i - c * h) / det;
    r[2] = (b * f - c * e) / det;
    r[4] = B / det;
    r[5] = (a * i - c * g) / det;
    r[6] = -(a * f - c * d) / det;
    r[8] = C / det;
    r[9] = -(a * h - b * g) / det;
    r[10] = (a * e - b * d) / det;
    for (int k = 0; k < 3; ++k)
        r[4 * k + 3] = -(r[4 * k] * m[3] + r[4 * k + 1] * m[7] + r[4 * k + 2] * m[11]);
    r[12] = r[13] = r[14] = 0;
    r[15] = 1;
    memcpy(out, r, sizeof r);
    return 1;
}

void pov_m4_point(const double m[16], const double p[3], double out[3])
{
    double r[3];
    for (int i = 0; i < 3; ++i)
        r[i] = m[4 * i] * p[0] + m[4 * i + 1] * p[1] + m[4 * i + 2] * p[2] + m[4 * i + 3];
    memcpy(out, r, sizeof r);
}

void pov_m4_dir(const double m[16], const double d[3], double out[3])
{
    double r[3];
    for (int i = 0; i < 3; ++i)
        r[i] = m[4 * i] * d[0] + m[4 * i + 1] * d[1] + m[4 * i + 2] * d[2];
    memcpy(out, r, sizeof r);
}

int pov_m4_is_similarity(const double m[16], double *s)
{
    double col[3][3], len[3];
    for (int c = 0; c < 3; ++c) {
        for (int r = 0; r < 3; ++r)
            col[c][r] = m[4 * r + c];
        len[c] = sqrt(col[c][0] * col[c][0] + col[c][1] * col[c][1] + col[c][2] * col[c][2]);
    }
    if (!(len[0] > 0))
        return 0;
    for (int c = 1; c < 3; ++c)
        if (fabs(len[c] - len[0]) > 1e-9 * len[0])
            return 0;
    for (int a = 0; a < 3; ++a)
        for (int b = a + 1; b < 3; ++b) {
            double d = col[a][0] * col[b][0] + col[a][1] * col[b][1] + col[a][2] * col[b][2];
            if (fabs(d) > 1e-9 * len[0] * len[0])
                return 0;
        }
    *s = len[0];
    return 1;
}
