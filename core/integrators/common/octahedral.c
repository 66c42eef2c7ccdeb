/* Hemispherical octahedral maps (see octahedral.h for the mapping, its Jacobian and the edge
 * rule). Tables are built once per map in double precision and stored as float. */
#include "octahedral.h"

#include <math.h>
#include <stdlib.h>

struct vbi_hemioct {
    uint32_t res;
    uint32_t count;        /* res * res */
    vec3 *dir;             /* texel centre directions */
    float *solid_angle;    /* Omega_t, exact */
    float *bil_solid;      /* B_t */
    float *bil_proj;       /* C_t */
};

struct vbi_hemioct_dist {
    const vbi_hemioct *map;
    float *pmf;            /* count entries */
    float *cdf;            /* count + 1 entries, cdf[count] = 1 */
};

/* ---- mapping ------------------------------------------------------------------------------- */

vec2 vbi_hemioct_encode(vec3 w) { return vbi_hemioct_encode_inline(w); }

vec3 vbi_hemioct_decode(vec2 u)
{
    float ex = 2.0f * clampf(u.x, 0.0f, 1.0f) - 1.0f, ey = 2.0f * clampf(u.y, 0.0f, 1.0f) - 1.0f;
    float tx = 0.5f * (ex + ey), ty = 0.5f * (ex - ey);
    vec3 p = v3(tx, ty, fmaxf(1.0f - fabsf(tx) - fabsf(ty), 0.0f));
    return v3_norm(p);
}

/* Double-precision decode for the tables (unnormalised point on the octahedron). */
static void decode_point_d(double ux, double uy, double p[3])
{
    double ex = 2.0 * ux - 1.0, ey = 2.0 * uy - 1.0;
    double tx = 0.5 * (ex + ey), ty = 0.5 * (ex - ey);
    p[0] = tx;
    p[1] = ty;
    p[2] = fmax(1.0 - fabs(tx) - fabs(ty), 0.0);
}

static void decode_unit_d(double ux, double uy, double v[3])
{
    decode_point_d(ux, uy, v);
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v[0] /= l;
    v[1] /= l;
    v[2] /= l;
}

/* d(omega) = dA cos / |p|^2 on the face plane; with dA = sqrt(3) dt, the plane's distance
 * 1 / sqrt(3) and |dt/du| = 2 (e = 2u - 1 scales areas by 4, the 45-degree rotation by 1/2),
 * the Jacobian is 2 / |p|^3. */
float vbi_hemioct_jacobian(vec2 u)
{
    float ex = 2.0f * clampf(u.x, 0.0f, 1.0f) - 1.0f, ey = 2.0f * clampf(u.y, 0.0f, 1.0f) - 1.0f;
    float tx = 0.5f * (ex + ey), ty = 0.5f * (ex - ey);
    float pz = fmaxf(1.0f - fabsf(tx) - fabsf(ty), 0.0f);
    float l2 = tx * tx + ty * ty + pz * pz;
    return 2.0f / (l2 * sqrtf(l2));
}

/* ---- tables -------------------------------------------------------------------------------- */

/* Solid angle of the spherical triangle (a, b, c) of unit vectors (Van Oosterom & Strackee
 * 1983): tan(Omega / 2) = |a . (b x c)| / (1 + a.b + b.c + c.a). */
static double spherical_triangle_d(const double a[3], const double b[3], const double c[3])
{
    double bxc[3] = {b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2], b[0] * c[1] - b[1] * c[0]};
    double num = fabs(a[0] * bxc[0] + a[1] * bxc[1] + a[2] * bxc[2]);
    double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    double bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
    double ca = c[0] * a[0] + c[1] * a[1] + c[2] * a[2];
    return 2.0 * atan2(num, 1.0 + ab + bc + ca);
}

/* Texel = 4 triangles (centre + one edge each), each inside one octahedron face (octahedral.h),
 * hence each an exact spherical triangle. */
static double texel_solid_angle_d(uint32_t res, uint32_t i, uint32_t j)
{
    double h = 1.0 / res;
    double corner[4][3], centre[3];
    decode_unit_d(i * h, j * h, corner[0]);
    decode_unit_d((i + 1) * h, j * h, corner[1]);
    decode_unit_d((i + 1) * h, (j + 1) * h, corner[2]);
    decode_unit_d(i * h, (j + 1) * h, corner[3]);
    decode_unit_d((i + 0.5) * h, (j + 0.5) * h, centre);
    double sum = 0.0;
    for (int k = 0; k < 4; ++k)
        sum += spherical_triangle_d(centre, corner[k], corner[(k + 1) & 3]);
    return sum;
}

/* B_t and C_t by the midpoint rule on an N x N grid, N = res * sub >= 512 with `sub` even: the
 * sub-cell boundaries then contain the texel-centre lines (the kinks of the bilinear basis) and
 * the diagonals cross sub-cells only along their own diagonals (the Jacobian's kinks). Measured:
 * sum(B) = 2 pi and sum(C) = pi to 2e-8 relative for R = 8, 16, 32. */
static void bilinear_tables(vbi_hemioct *m)
{
    uint32_t sub = 2;
    while (m->res * sub < 512)
        sub += 2;
    uint32_t n = m->res * sub;
    double du = 1.0 / n;
    double *b = calloc(2 * (size_t)m->count, sizeof(double));
    double *c = b ? b + m->count : NULL;
    if (!b) {
        /* Fall back to the texel solid angles (only reached when out of memory for a few KB). */
        for (uint32_t t = 0; t < m->count; ++t) {
            m->bil_solid[t] = m->solid_angle[t];
            m->bil_proj[t] = m->solid_angle[t] * m->dir[t].z;
        }
        return;
    }
    for (uint32_t y = 0; y < n; ++y) {
        for (uint32_t x = 0; x < n; ++x) {
            double ux = (x + 0.5) * du, uy = (y + 0.5) * du;
            double p[3];
            decode_point_d(ux, uy, p);
            double l2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
            double l = sqrt(l2);
            double dw = 2.0 / (l2 * l) * du * du; /* Jacobian 2 / |p|^3 */
            double cosv = p[2] / l;
            /* Bilinear weights in double, same footprint rule as vbi_hemioct_footprint (octahedral.h). */
            double fxp = ux * m->res - 0.5, fyp = uy * m->res - 0.5;
            double x0f = floor(fxp), y0f = floor(fyp);
            double fx = fxp - x0f, fy = fyp - y0f;
            int last = (int)m->res - 1;
            int ix[2] = {(int)x0f, (int)x0f + 1}, iy[2] = {(int)y0f, (int)y0f + 1};
            for (int k = 0; k < 2; ++k) {
                ix[k] = ix[k] < 0 ? 0 : (ix[k] > last ? last : ix[k]);
                iy[k] = iy[k] < 0 ? 0 : (iy[k] > last ? last : iy[k]);
            }
            double wx[2] = {1.0 - fx, fx}, wy[2] = {1.0 - fy, fy};
            for (int a = 0; a < 2; ++a)
                for (int bb = 0; bb < 2; ++bb) {
                    size_t t = (size_t)iy[a] * m->res + (size_t)ix[bb];
                    double w = wy[a] * wx[bb] * dw;
                    b[t] += w;
                    c[t] += w * cosv;
                }
        }
    }
    for (uint32_t t = 0; t < m->count; ++t) {
        m->bil_solid[t] = (float)b[t];
        m->bil_proj[t] = (float)c[t];
    }
    free(b);
}

vbnl_result vbi_hemioct_create(uint32_t res, vbi_hemioct **out)
{
    if (!out)
        return VBNL_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (res < VBI_HEMIOCT_MIN_RES || res > VBI_HEMIOCT_MAX_RES)
        return VBNL_ERR_INVALID_ARGUMENT;
    vbi_hemioct *m = calloc(1, sizeof(*m));
    if (!m)
        return VBNL_ERR_OUT_OF_MEMORY;
    m->res = res;
    m->count = res * res;
    m->dir = malloc(m->count * sizeof(vec3));
    m->solid_angle = malloc(3 * (size_t)m->count * sizeof(float));
    if (!m->dir || !m->solid_angle) {
        vbi_hemioct_destroy(m);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    m->bil_solid = m->solid_angle + m->count;
    m->bil_proj = m->bil_solid + m->count;
    for (uint32_t j = 0; j < res; ++j) {
        for (uint32_t i = 0; i < res; ++i) {
            uint32_t t = j * res + i;
            double v[3];
            decode_unit_d((i + 0.5) / res, (j + 0.5) / res, v);
            m->dir[t] = v3((float)v[0], (float)v[1], (float)v[2]);
            m->solid_angle[t] = (float)texel_solid_angle_d(res, i, j);
        }
    }
    bilinear_tables(m);
    *out = m;
    return VBNL_OK;
}

void vbi_hemioct_destroy(vbi_hemioct *map)
{
    if (!map)
        return;
    free(map->dir);
    free(map->solid_angle);
    free(map);
}

uint32_t vbi_hemioct_res(const vbi_hemioct *map) { return map->res; }
uint32_t vbi_hemioct_texel_count(const vbi_hemioct *map) { return map->count; }

uint32_t vbi_hemioct_texel(const vbi_hemioct *map, vec3 w)
{
    vec2 u = vbi_hemioct_encode(w);
    uint32_t i = (uint32_t)(u.x * (float)map->res), j = (uint32_t)(u.y * (float)map->res);
    if (i >= map->res)
        i = map->res - 1;
    if (j >= map->res)
        j = map->res - 1;
    return j * map->res + i;
}

vec3 vbi_hemioct_texel_dir(const vbi_hemioct *map, uint32_t t) { return map->dir[t]; }
float vbi_hemioct_texel_solid_angle(const vbi_hemioct *map, uint32_t t) { return map->solid_angle[t]; }
float vbi_hemioct_texel_bilinear_solid_angle(const vbi_hemioct *map, uint32_t t) { return map->bil_solid[t]; }
float vbi_hemioct_texel_bilinear_projected(const vbi_hemioct *map, uint32_t t) { return map->bil_proj[t]; }
const float *vbi_hemioct_solid_angles(const vbi_hemioct *map) { return map->solid_angle; }
const float *vbi_hemioct_bilinear_projected(const vbi_hemioct *map) { return map->bil_proj; }
const vec3 *vbi_hemioct_texel_dirs(const vbi_hemioct *map) { return map->dir; }

/* ---- splat and lookup ---------------------------------------------------------------------- */

void vbi_hemioct_bilinear(const vbi_hemioct *map, vec3 w, uint32_t idx[4], float wgt[4])
{
    vbi_hemioct_footprint(map->res, w, idx, wgt);
}

void vbi_hemioct_splat(const vbi_hemioct *map, float *rgb, vec3 w, vec3 value)
{
    uint32_t idx[4];
    float wgt[4];
    vbi_hemioct_bilinear(map, w, idx, wgt);
    for (int k = 0; k < 4; ++k) {
        float *p = rgb + 3 * (size_t)idx[k];
        p[0] += value.x * wgt[k];
        p[1] += value.y * wgt[k];
        p[2] += value.z * wgt[k];
    }
}

/* Lock-free float addition (GCC's generic __atomic builtins compare the 4 bytes). */
static void atomic_add_float(float *p, float v)
{
    if (v == 0.0f)
        return;
    float old, sum;
    __atomic_load(p, &old, __ATOMIC_RELAXED);
    do {
        sum = old + v;
    } while (!__atomic_compare_exchange(p, &old, &sum, 1, __ATOMIC_RELAXED, __ATOMIC_RELAXED));
}

void vbi_hemioct_splat_atomic(const vbi_hemioct *map, float *rgb, vec3 w, vec3 value)
{
    uint32_t idx[4];
    float wgt[4];
    vbi_hemioct_bilinear(map, w, idx, wgt);
    for (int k = 0; k < 4; ++k) {
        float *p = rgb + 3 * (size_t)idx[k];
        atomic_add_float(p + 0, value.x * wgt[k]);
        atomic_add_float(p + 1, value.y * wgt[k]);
        atomic_add_float(p + 2, value.z * wgt[k]);
    }
}

vec3 vbi_hemioct_lookup(const vbi_hemioct *map, const float *rgb, vec3 w)
{
    uint32_t idx[4];
    float wgt[4];
    vbi_hemioct_bilinear(map, w, idx, wgt);
    vec3 r = v3s(0.0f);
    for (int k = 0; k < 4; ++k)
        r = v3_fma(r, v3_load(rgb + 3 * (size_t)idx[k]), wgt[k]);
    return r;
}

/* ---- sampling ------------------------------------------------------------------------------ */

vbnl_result vbi_hemioct_dist_create(const vbi_hemioct *map, const float *weights, vbi_hemioct_dist **out)
{
    if (!out)
        return VBNL_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!map || !weights)
        return VBNL_ERR_INVALID_ARGUMENT;
    double total = 0.0;
    for (uint32_t t = 0; t < map->count; ++t) {
        if (!(weights[t] >= 0.0f) || !isfinite(weights[t]))
            return VBNL_ERR_INVALID_ARGUMENT;
        total += weights[t];
    }
    if (!(total > 0.0))
        return VBNL_ERR_INVALID_ARGUMENT;
    vbi_hemioct_dist *d = calloc(1, sizeof(*d));
    float *buf = malloc((2 * (size_t)map->count + 1) * sizeof(float));
    if (!d || !buf) {
        free(d);
        free(buf);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    d->map = map;
    d->pmf = buf;
    d->cdf = buf + map->count;
    double run = 0.0;
    for (uint32_t t = 0; t < map->count; ++t) {
        d->cdf[t] = (float)(run / total);
        d->pmf[t] = (float)(weights[t] / total);
        run += weights[t];
    }
    d->cdf[map->count] = 1.0f;
    *out = d;
    return VBNL_OK;
}

void vbi_hemioct_dist_destroy(vbi_hemioct_dist *d)
{
    if (!d)
        return;
    free(d->pmf);
    free(d);
}

vec3 vbi_hemioct_dist_sample(const vbi_hemioct_dist *d, float u_texel, vec2 u, float *pdf)
{
    const vbi_hemioct *m = d->map;
    /* Largest t with cdf[t] <= u_texel and pmf[t] > 0 (zero-weight texels have empty intervals,
     * except when rounding makes cdf[t] == cdf[t + 1] for a tiny positive pmf: skip those). */
    uint32_t lo = 0, hi = m->count; /* invariant: cdf[lo] <= u < cdf[hi] */
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (d->cdf[mid] <= u_texel)
            lo = mid;
        else
            hi = mid;
    }
    uint32_t t = lo;
    while (d->pmf[t] == 0.0f && t > 0)
        --t;
    while (d->pmf[t] == 0.0f && t + 1 < m->count)
        ++t;
    uint32_t i = t % m->res, j = t / m->res;
    vec2 us = {((float)i + u.x) / (float)m->res, ((float)j + u.y) / (float)m->res};
    vec3 w = vbi_hemioct_decode(us);
    if (pdf)
        *pdf = d->pmf[t] * (float)m->count / vbi_hemioct_jacobian(us);
    return w;
}

float vbi_hemioct_dist_pdf(const vbi_hemioct_dist *d, vec3 w)
{
    if (!(w.z >= 0.0f))
        return 0.0f;
    vec2 u = vbi_hemioct_encode(w);
    uint32_t t = vbi_hemioct_texel(d->map, w);
    return d->pmf[t] * (float)d->map->count / vbi_hemioct_jacobian(u);
}

float vbi_hemioct_dist_pmf(const vbi_hemioct_dist *d, uint32_t t) { return d->pmf[t]; }
