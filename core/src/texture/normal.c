/* Normal perturbation (reference manual, "Normal", "Normal Maps", "Slope Maps", "Bump Map"),
 * following POV-Ray 3.7's Perturb_Normal (normal.cpp): the unit normal is carried into the
 * pattern's space by its transforms, perturbed there, carried back and normalised. bumps, dents,
 * ripples, waves, wrinkles, quilted and facets have their own perturbations; every other pattern
 * perturbs by its gradient, estimated from four values on a tetrahedron `accuracy` wide. */
#include <stdlib.h>

#include "texture.h"

/* POV-Ray's tetrahedron of gradient samples (unit vectors). */
static const dvec3 pyramid[4] = {{0.942809041, -0.333333333, 0.0},
                                 {-0.471404521, -0.333333333, 0.816496581},
                                 {-0.471404521, -0.333333333, -0.816496581},
                                 {0.0, 1.0, 0.0}};

/* Hermite interpolation of slope-map entries (height, slope) at t in [0, 1]. */
static double hermite(double t, const vbnl_slope_map_entry *a, const vbnl_slope_map_entry *b)
{
    double tt = t * t, ttt = tt * t;
    return ttt * (a->slope + b->slope + 2.0 * (a->height - b->height)) -
           tt * (2.0 * a->slope + b->slope + 3.0 * (a->height - b->height)) + t * a->slope + a->height;
}

static double slope_map(const vbi_texture_set *ts, const vbi_normal *nm, double v)
{
    if (!nm->slope_count)
        return v;
    const vbnl_slope_map_entry *m = ts->slope_entries + nm->slope_begin;
    uint32_t a, b;
    double f;
    vbi_map_search(&m[0].value, sizeof(*m), nm->slope_count, v, &a, &b, &f);
    return a == b ? m[b].height : hermite(f, &m[a], &m[b]);
}

/* The normal of the random-point Voronoi cell of `facets` (POV-Ray's facets()). */
static dvec3 facets(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 p, dvec3 n)
{
    const double metric = pt->u.facets.metric, coords = pt->u.facets.coords;
    const int square = metric == 2.0, unity = metric == 1.0;
    n = d3_norm(n);
    double scale = pt->u.facets.size < 1e-6 ? 1e6 : 1.0 / pt->u.facets.size;
    dvec3 tv = d3_scale(coords != 0.0 ? p : n, scale);
    double best = INFINITY;
    dvec3 nearest = tv;
    for (int ax = -2; ax <= 2; ++ax)
        for (int ay = -2; ay <= 2; ++ay)
            for (int az = -2; az <= 2; ++az) {
                if ((abs(ax) == 2) + (abs(ay) == 2) + (abs(az) == 2) > 1)
                    continue;
                dvec3 s = d3_add(tv, d3(ax, ay, az));
                int fx = (int)floor(s.x - 1e-10), fy = (int)floor(s.y - 1e-10), fz = (int)floor(s.z - 1e-10);
                unsigned seed = vbi_noise_hash3(ts->noise, fx, fy, fz);
                dvec3 c = d3(fx + vbi_pattern_rand(ts->noise, seed), fy + vbi_pattern_rand(ts->noise, seed + 1),
                             fz + vbi_pattern_rand(ts->noise, seed + 2));
                dvec3 dv = d3_sub(c, tv);
                /* POV-Ray's metric 1 sums the signed offsets */
                double sum = square  ? d3_dot(dv, dv)
                             : unity ? dv.x + dv.y + dv.z
                                     : pow(fabs(dv.x), metric) + pow(fabs(dv.y), metric) + pow(fabs(dv.z), metric);
                if (sum < best) {
                    best = sum;
                    nearest = c;
                }
            }
    if (coords == 0.0)
        return nearest;
    dvec3 pert = vbi_dnoise(ts->noise, nearest);
    pert = d3_sub(pert, d3_scale(n, d3_dot(pert, n)));
    return d3_fma(n, pert, coords);
}

/* bump_map: the image as a height field; the heights of the texel and of its neighbours one
 * pixel down-left and down-right give the normal in the frame of n. */
static dvec3 bump_map(const vbi_texture_set *ts, const vbi_normal *nm, const vbi_pattern *pt, dvec3 p,
                      const vbi_shade_point *sp, dvec3 n)
{
    const vbi_image *im = &ts->images[pt->u.image.image];
    double x, y;
    if (!vbi_image_pixel(ts, pt, p, sp, &x, &y))
        return n;
    const double w = im->width, h = im->height;
    double hs[3];
    const double xs[3] = {x, x - 1.0, x + 1.0};
    double y2 = y + 1.0;
    if (y2 >= h)
        y2 -= h;
    for (int i = 0; i < 3; ++i) {
        double xi = xs[i];
        if (xi < 0.0)
            xi += w;
        else if (xi >= w)
            xi -= w;
        float c[5];
        int index;
        vbi_image_lookup(ts, pt, xi, i == 0 ? y : y2, c, &index);
        int by_index = pt->u.image.use == 0 && index >= 0;
        hs[i] = nm->amount * (by_index ? (double)index : vbi_greyscale(c));
    }
    dvec3 p1 = d3(0.0, hs[0], 0.0), p2 = d3(-1.0, hs[1], 1.0), p3 = d3(1.0, hs[2], 1.0);
    dvec3 bn = d3_norm(d3_cross(d3_sub(p3, p2), d3_sub(p1, p2)));
    dvec3 yp = n, xp = d3_cross(n, d3(0.0, 1.0, 0.0));
    double len = d3_len(xp);
    if (len < 1e-10) {
        yp = fabs(n.y - 1.0) < 1e-10 ? d3(0.0, 1.0, 0.0) : d3(0.0, -1.0, 0.0);
        xp = d3(1.0, 0.0, 0.0);
        len = 1.0;
    }
    xp = d3_scale(xp, 1.0 / len);
    dvec3 zp = d3_norm(d3_cross(xp, yp));
    return d3_sub(d3_add(d3_scale(xp, bn.x), d3_scale(yp, bn.y)), d3_scale(zp, bn.z));
}

/* Perturbs n (in the space of the point q this normal receives) and returns it, not normalised
 * when `raw` (the caller normalises). */
static dvec3 perturb(const vbi_texture_set *ts, uint32_t id, dvec3 q, dvec3 n, const vbi_shade_point *sp)
{
    const vbi_normal *nm = &ts->normals[id];
    const vbi_pattern *pt = nm->pattern ? &ts->patterns[nm->pattern - 1] : NULL;
    const int scale = !nm->no_bump_scale;
    dvec3 w = pt ? vbi_pattern_point(ts, pt, q) : q;
    dvec3 m = pt ? vbi_pattern_normal_in(ts, pt, n) : n;
    if (scale)
        m = d3_norm(m);
    const vbnl_normal_map_entry *map = ts->normal_entries + nm->entry_begin;
    switch (nm->kind) {
    case VBNL_NORMAL_MAP: {
        double v = vbi_pattern_shape(pt, vbi_pattern_raw(ts, pt, w, sp));
        uint32_t a, b;
        double f;
        vbi_map_search(&map[0].value, sizeof(*map), nm->entry_count, v, &a, &b, &f);
        dvec3 r = perturb(ts, map[b].normal, w, m, sp);
        if (a != b)
            r = d3_add(d3_scale(perturb(ts, map[a].normal, w, m, sp), 1.0 - f), d3_scale(r, f));
        m = r;
        break;
    }
    case VBNL_NORMAL_AVERAGE: {
        dvec3 acc = d3(0.0, 0.0, 0.0);
        double total = 0.0;
        for (uint32_t i = 0; i < nm->entry_count; ++i) {
            acc = d3_fma(acc, perturb(ts, map[i].normal, w, m, sp), map[i].value);
            total += map[i].value;
        }
        m = total != 0.0 ? d3_scale(acc, 1.0 / total) : m;
        break;
    }
    case VBNL_NORMAL_IMAGE:
        m = bump_map(ts, nm, pt, w, sp, m);
        break;
    case VBNL_NORMAL_PATTERN: {
        const double amount = nm->amount;
        switch (pt->kind) {
        case VBNL_PATTERN_BUMPS:
            m = d3_fma(m, vbi_dnoise(ts->noise, w), amount);
            break;
        case VBNL_PATTERN_DENTS: {
            double v = vbi_noise(ts->noise, w, pt->generator);
            m = d3_fma(m, vbi_dnoise(ts->noise, w), v * v * v * amount);
            break;
        }
        case VBNL_PATTERN_RIPPLES:
        case VBNL_PATTERN_WAVES: {
            const int count = pt->u.waves, waves = pt->kind == VBNL_PATTERN_WAVES;
            for (int i = 0; i < count; ++i) {
                dvec3 d = d3_sub(w, ts->noise->wave_source[i]);
                double len = d3_len(d);
                if (len == 0.0)
                    len = 1.0;
                double f = waves ? ts->noise->wave_frequency[i] : 1.0;
                double s = vbi_cycloidal(len * pt->frequency * f + pt->phase) * amount / f;
                m = d3_fma(m, d, s / (len * count));
            }
            break;
        }
        case VBNL_PATTERN_WRINKLES: {
            dvec3 r = d3(0.0, 0.0, 0.0);
            double s = 1.0;
            for (int i = 0; i < 10; ++i, s *= 2.0) {
                dvec3 v = vbi_dnoise(ts->noise, d3_scale(w, s));
                r = d3_add(r, d3(fabs(v.x / s), fabs(v.y / s), fabs(v.z / s)));
            }
            m = d3_fma(m, r, amount);
            break;
        }
        case VBNL_PATTERN_QUILTED:
            m = d3_fma(m, vbi_pattern_quilted_offset(pt, w), amount);
            break;
        case VBNL_PATTERN_FACETS:
            m = facets(ts, pt, w, m);
            break;
        default: {
            /* POV-Ray's finite-difference gradient and its scale (-5 amount, per 0.02 of accuracy) */
            const double k = amount * -5.0 * 0.02 / nm->accuracy;
            for (int i = 0; i < 4; ++i) {
                dvec3 s = d3_fma(w, pyramid[i], nm->accuracy);
                double v = slope_map(ts, nm, vbi_pattern_shape(pt, vbi_pattern_raw(ts, pt, s, sp)));
                m = d3_fma(m, pyramid[i], v * k);
            }
            break;
        }
        }
        break;
    }
    }
    if (pt)
        m = vbi_pattern_normal_out(ts, pt, m);
    return scale ? d3_norm(m) : m;
}

dvec3 vbi_normal_perturb_at(const vbi_texture_set *ts, uint32_t id, dvec3 q, const vbi_shade_point *sp)
{
    dvec3 n = d3_norm(perturb(ts, id, q, sp->n, sp));
    /* a degenerate perturbation keeps the surface's own normal */
    return d3_dot(n, n) > 0.5 && isfinite(n.x + n.y + n.z) ? n : sp->n;
}

dvec3 vbi_normal_perturb(const vbi_texture_set *ts, uint32_t id, const vbi_shade_point *sp)
{
    dvec3 q = ts->normals[id].uv ? d3(sp->u, sp->v, 0.0) : sp->p;
    return vbi_normal_perturb_at(ts, id, q, sp);
}
