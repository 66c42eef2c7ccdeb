/* Warps: how a pattern maps the point it receives (reference manual, "Warps"; conventions of
 * POV-Ray 3.7's warps.cpp). A pattern applies its transform, its warps in order, then its classic
 * turbulence; coordinates are then clamped to +-1e17 as POV-Ray does. */
#include "texture.h"

#define VBI_COORD_LIMIT 1.0e17

/* The angle of (x, z) from +x towards +z in [0, 2 pi), POV-Ray's acos form. */
static double angle_xz(double x, double z, double len)
{
    if (z == 0.0)
        return x > 0.0 ? 0.0 : M_PI;
    double theta = acos(x / len);
    return z < 0.0 ? 2.0 * M_PI - theta : theta;
}

/* The mapped coordinates (x, y, z) of the spherical, cylindrical, toroidal and planar warps put
 * in place for the orientation o (POV-Ray's rotation of the default <0, 0, 1>). */
static dvec3 orient(dvec3 o, double x, double y, double z)
{
    if (o.x == 0.0 && o.y == 0.0 && o.z == 1.0)
        return d3(x, y, z);
    return d3(o.x * z + o.y * x + o.z * x, o.x * y - o.y * z + o.z * y, -o.x * x + o.y * y + o.z * z);
}

static dvec3 warp_spherical(const vbi_warp *w, dvec3 p)
{
    double dist = d3_len(p);
    if (dist == 0.0)
        return p;
    double x = p.x / dist, y = p.y / dist, z = p.z / dist;
    double phi = 0.5 + asin(y) / M_PI;
    double len = sqrt(x * x + z * z);
    double theta = len == 0.0 ? 0.0 : angle_xz(x, z, len) / (2.0 * M_PI);
    if (w->dist_exp == 1.0) {
        theta *= dist;
        phi *= dist;
    } else if (w->dist_exp != 0.0) {
        double f = pow(dist, w->dist_exp);
        theta *= f;
        phi *= f;
    }
    return orient(w->orient, theta, phi, dist);
}

static dvec3 warp_cylindrical(const vbi_warp *w, dvec3 p)
{
    double len = sqrt(p.x * p.x + p.z * p.z);
    if (len == 0.0)
        return p;
    double theta = angle_xz(p.x, p.z, len) / (2.0 * M_PI);
    if (w->dist_exp == 1.0)
        theta *= len;
    else if (w->dist_exp != 0.0)
        theta *= pow(len, w->dist_exp);
    return orient(w->orient, theta, p.y, len);
}

static dvec3 warp_toroidal(const vbi_warp *w, dvec3 p)
{
    double len = sqrt(p.x * p.x + p.z * p.z);
    if (len == 0.0)
        return p;
    double theta = angle_xz(p.x, p.z, len) / (2.0 * M_PI);
    double x = len - w->major_radius;
    double rlen = sqrt(x * x + p.y * p.y);
    double phi = acos(-x / rlen);
    if (p.y > 0.0)
        phi = 2.0 * M_PI - phi;
    phi /= 2.0 * M_PI;
    if (w->dist_exp == 1.0) {
        theta *= rlen;
        phi *= rlen;
    } else if (w->dist_exp != 0.0) {
        double f = pow(rlen, w->dist_exp);
        theta *= f;
        phi *= f;
    }
    return orient(w->orient, theta, phi, rlen);
}

/* POV-Ray's cubic warp: the six faces of the cube unfolded onto a 4 x 3 cross in [0, 1]^2. */
static dvec3 warp_cubic(dvec3 p)
{
    double x = p.x, y = p.y, z = p.z, ax = fabs(x), ay = fabs(y), az = fabs(z);
    if (x >= 0 && x >= ay && x >= az)
        return d3(0.75 - 0.25 * (z / x + 1.0) / 2.0, 1.0 / 3.0 + (y / x + 1.0) / 6.0, x);
    if (y >= 0 && y >= ax && y >= az)
        return d3(0.25 + 0.25 * (x / y + 1.0) / 2.0, 1.0 - (z / y + 1.0) / 6.0, y);
    if (z >= 0 && z >= ax && z >= ay)
        return d3(0.25 + 0.25 * (x / z + 1.0) / 2.0, 1.0 / 3.0 + (y / z + 1.0) / 6.0, z);
    if (x < 0 && x <= -ay && x <= -az)
        return d3(0.25 * (z / -x + 1.0) / 2.0, 1.0 / 3.0 + (y / -x + 1.0) / 6.0, -x);
    if (y < 0 && y <= -ax && y <= -az)
        return d3(0.25 + 0.25 * (x / -y + 1.0) / 2.0, (z / -y + 1.0) / 6.0, -y);
    return d3(1.0 - 0.25 * (x / -z + 1.0) / 2.0, 1.0 / 3.0 + (y / -z + 1.0) / 6.0, -z);
}

static dvec3 warp_repeat(const vbi_warp *w, dvec3 p)
{
    /* POV-Ray keeps the repetition number in single precision */
    float blk = (float)floor(d3_comp(p, w->axis) / w->width);
    dvec3 r = p;
    d3_set(&r, w->axis, d3_comp(p, w->axis) - (double)blk * w->width);
    if (((int)blk) & 1) {
        r = d3_mul(r, w->flip);
        if (d3_comp(w->flip, w->axis) < 0.0)
            d3_set(&r, w->axis, w->width + d3_comp(r, w->axis));
    }
    return d3_fma(r, w->offset, (double)blk);
}

static dvec3 warp_black_hole(const vbi_texture_set *ts, const vbi_warp *w, dvec3 p)
{
    dvec3 c = w->center;
    if (w->repeat) {
        int b[3] = {0, 0, 0};
        for (int i = 0; i < 3; ++i)
            if (d3_comp(w->repeat_vec, i) >= 1e-10)
                b[i] = (int)floor(d3_comp(p, i) / d3_comp(w->repeat_vec, i));
        if (w->uncertain) {
            unsigned seed = vbi_noise_hash3(ts->noise, b[0], b[1], b[2]);
            c.x += vbi_pattern_rand(ts->noise, seed) * w->jitter.x;
            c.y += vbi_pattern_rand(ts->noise, seed + 1) * w->jitter.y;
            c.z += vbi_pattern_rand(ts->noise, seed + 2) * w->jitter.z;
        }
        c = d3_add(c, d3(w->repeat_vec.x * b[0], w->repeat_vec.y * b[1], w->repeat_vec.z * b[2]));
    }
    dvec3 delta = d3_sub(p, c);
    double len = d3_len(delta);
    if (len >= w->radius)
        return p;
    /* 0 on the rim, 1 at the centre, raised to the falloff and capped at 1 */
    double s = pow((w->radius - len) / w->radius, w->falloff) * w->strength;
    if (s > 1.0)
        s = 1.0;
    return d3_fma(p, delta, w->inverse ? -s : s);
}

static dvec3 apply_warp(const vbi_texture_set *ts, const vbi_warp *w, dvec3 p)
{
    switch (w->kind) {
    case VBNL_WARP_TRANSFORM:
        return dmat_point(&w->m, p);
    case VBNL_WARP_TURBULENCE:
        return d3_add(p, d3_mul(vbi_dturbulence(ts->noise, p, &w->turb), w->turb.amount));
    case VBNL_WARP_REPEAT:
        return warp_repeat(w, p);
    case VBNL_WARP_BLACK_HOLE:
        return warp_black_hole(ts, w, p);
    case VBNL_WARP_SPHERICAL:
        return warp_spherical(w, p);
    case VBNL_WARP_CYLINDRICAL:
        return warp_cylindrical(w, p);
    case VBNL_WARP_TOROIDAL:
        return warp_toroidal(w, p);
    case VBNL_WARP_PLANAR:
        return orient(w->orient, p.x, p.y, w->plane_offset);
    case VBNL_WARP_CUBIC:
        return warp_cubic(p);
    }
    return p;
}

static double clamp_coord(double v)
{
    return v > VBI_COORD_LIMIT ? VBI_COORD_LIMIT : (v < -VBI_COORD_LIMIT ? -VBI_COORD_LIMIT : v);
}

dvec3 vbi_pattern_point(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 q)
{
    dvec3 p = pt->has_xf ? dmat_point(&pt->xf, q) : q;
    for (uint32_t i = 0; i < pt->warp_count; ++i)
        p = apply_warp(ts, &ts->warps[pt->warp_begin + i], p);
    /* classic turbulence moves the point, except for marble and wood, whose formula uses it */
    if (pt->has_turb && pt->kind != VBNL_PATTERN_MARBLE && pt->kind != VBNL_PATTERN_WOOD &&
        (pt->turb.amount.x != 0.0 || pt->turb.amount.y != 0.0 || pt->turb.amount.z != 0.0))
        p = d3_add(p, d3_mul(vbi_dturbulence(ts->noise, p, &pt->turb), pt->turb.amount));
    return d3(clamp_coord(p.x), clamp_coord(p.y), clamp_coord(p.z));
}

dvec3 vbi_pattern_normal_in(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 n)
{
    /* a normal follows the inverse transpose of the point map A: A^-T = M^T for M = A^-1 */
    if (pt->has_xf)
        n = dmat_transpose_vector(&pt->xf_inv, n);
    for (uint32_t i = 0; i < pt->warp_count; ++i) {
        const vbi_warp *w = &ts->warps[pt->warp_begin + i];
        if (w->kind == VBNL_WARP_TRANSFORM)
            n = dmat_transpose_vector(&w->inv, n);
    }
    return n;
}

dvec3 vbi_pattern_normal_out(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 n)
{
    for (uint32_t i = pt->warp_count; i-- > 0;) {
        const vbi_warp *w = &ts->warps[pt->warp_begin + i];
        if (w->kind == VBNL_WARP_TRANSFORM)
            n = dmat_transpose_vector(&w->m, n);
    }
    if (pt->has_xf)
        n = dmat_transpose_vector(&pt->xf, n);
    return n;
}
