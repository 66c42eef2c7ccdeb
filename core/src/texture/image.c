/* Image lookups of IMAGE patterns (reference manual, "Image Map", "Bump Map", "Image Pattern",
 * "Material Map"): POV-Ray 3.7's projections (planar, spherical, cylindrical, torus), its pixel
 * coordinates (imageutil.cpp's map_pos: x across, y down from the top, 1e-10 added, wrapped into
 * the image unless `once`) and its interpolations (none, bilinear from the four nearest texel
 * centres, normalised distance, bicubic). */
#include "texture.h"

#define VBI_POV_EPSILON 1e-10

static double wrapd(double v, double n)
{
    double r = fmod(v, n);
    return r < 0.0 ? r + n : r;
}

static double angle_xz(double x, double z, double len)
{
    if (z == 0.0)
        return x > 0.0 ? 0.0 : M_PI;
    double theta = acos(x / len);
    return z < 0.0 ? 2.0 * M_PI - theta : theta;
}

/* Pixel coordinates (x across, y_up up from the bottom) of point p; 0 where the projection has
 * no value there (the axis of a spherical or cylindrical map, outside a `once` image). */
static int project(const vbi_pattern *pt, const vbi_image *im, dvec3 p, const vbi_shade_point *sp, double *x,
                   double *y_up)
{
    const double w = im->width, h = im->height;
    const int once = pt->u.image.wrap == VBI_IMAGE_ONCE;
    if (pt->u.image.uv) {
        *x = sp ? sp->u * w : 0.0;
        *y_up = sp ? sp->v * h : 0.0;
        return 1;
    }
    switch (pt->u.image.map_type) {
    case 1: { /* spherical */
        double len = d3_len(p);
        if (len == 0.0)
            return 0;
        dvec3 n = d3_scale(p, 1.0 / len);
        double phi = 0.5 + asin(n.y) / M_PI, r = sqrt(n.x * n.x + n.z * n.z);
        double theta = r == 0.0 ? 0.0 : angle_xz(n.x, n.z, r) / (2.0 * M_PI);
        *x = theta * w;
        *y_up = phi * h;
        return 1;
    }
    case 2: { /* cylindrical */
        if (once && (p.y < 0.0 || p.y > 1.0))
            return 0;
        *y_up = fmod(p.y * h, h);
        double len = d3_len(p);
        if (len == 0.0)
            return 0;
        double nx = p.x / len, nz = p.z / len, r = sqrt(nx * nx + nz * nz);
        if (r == 0.0)
            return 0;
        *x = angle_xz(nx, nz, r) / (2.0 * M_PI) * w;
        return 1;
    }
    case 5: { /* torus around y, major radius r0 */
        double len = sqrt(p.x * p.x + p.z * p.z);
        if (len == 0.0)
            return 0;
        double theta = angle_xz(p.x, p.z, len) / (2.0 * M_PI);
        double xr = len - pt->u.image.major_radius, rl = sqrt(xr * xr + p.y * p.y);
        double phi = rl == 0.0 ? 0.0 : acos(-xr / rl);
        if (p.y > 0.0)
            phi = 2.0 * M_PI - phi;
        *x = theta * w;
        *y_up = phi / (2.0 * M_PI) * h;
        return 1;
    }
    default: /* planar: x across, y up, the unit square */
        if (once && (p.x < 0.0 || p.x > 1.0 || p.y < 0.0 || p.y > 1.0))
            return 0;
        *x = fmod(p.x * w, w);
        *y_up = fmod(p.y * h, h);
        return 1;
    }
}

/* The texel (ix, iy) (iy from the top) as r g b filter transmit, indices wrapped or clamped. */
static void texel(const vbi_pattern *pt, const vbi_image *im, long ix, long iy, double c[5], int *index)
{
    const long w = im->width, h = im->height;
    if (pt->u.image.wrap == VBI_IMAGE_REPEAT) {
        ix %= w;
        iy %= h;
        ix += ix < 0 ? w : 0;
        iy += iy < 0 ? h : 0;
    } else {
        ix = ix < 0 ? 0 : (ix >= w ? w - 1 : ix);
        iy = iy < 0 ? 0 : (iy >= h ? h - 1 : iy);
    }
    size_t i = (size_t)iy * (size_t)w + (size_t)ix;
    const float *t = im->texels + i * im->channels;
    switch (im->channels) {
    case 1:
        c[0] = c[1] = c[2] = t[0];
        c[4] = 0.0;
        break;
    case 2:
        c[0] = c[1] = c[2] = t[0];
        c[4] = 1.0 - t[1];
        break;
    case 3:
        c[0] = t[0], c[1] = t[1], c[2] = t[2];
        c[4] = 0.0;
        break;
    default:
        c[0] = t[0], c[1] = t[1], c[2] = t[2];
        c[4] = 1.0 - t[3];
        break;
    }
    c[3] = pt->u.image.filter_all;
    c[4] += pt->u.image.transmit_all;
    *index = im->indices ? im->indices[i] : -1;
}

/* POV-Ray's cubic interpolation weights for the four texels around x. */
static void cubic_weights(double x, double f[4])
{
    double p = x - (double)(long)x, q = 1.0 - p;
    f[0] = -0.5 * p * q * q;
    f[1] = 0.5 * q * (q * (3.0 * p + 1.0) + 1.0);
    f[2] = 0.5 * p * (p * (3.0 * q + 1.0) + 1.0);
    f[3] = -0.5 * q * p * p;
}

static void lookup(const vbi_pattern *pt, const vbi_image *im, double x, double y, double c[5], int *index)
{
    const int interp = pt->u.image.interpolate;
    if (interp != 2 && interp != 3 && interp != 4) {
        texel(pt, im, (long)floor(x), (long)floor(y), c, index);
        return;
    }
    double acc[5] = {0, 0, 0, 0, 0}, idx = 0.0, t[5];
    int ti;
    x += 0.5;
    y += 0.5;
    const long ix = (long)floor(x), iy = (long)floor(y);
    if (interp == 3) {
        double fx[4], fy[4];
        cubic_weights(x, fx);
        cubic_weights(y, fy);
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) {
                texel(pt, im, ix + i - 2, iy + j - 2, t, &ti);
                double f = fx[i] * fy[j];
                for (int k = 0; k < 5; ++k)
                    acc[k] += t[k] * f;
                idx += ti * f;
            }
    } else {
        /* the four texels whose centres surround the point: (ix, iy), (ix-1, iy), (ix, iy-1),
         * (ix-1, iy-1) */
        double p = x - (double)ix, q = y - (double)iy, f[4];
        if (interp == 2) {
            f[0] = p * q;
            f[1] = (1.0 - p) * q;
            f[2] = p * (1.0 - q);
            f[3] = (1.0 - p) * (1.0 - q);
        } else { /* normalised inverse squared distances */
            double d[4] = {(1 - p) * (1 - p) + (1 - q) * (1 - q), p * p + (1 - q) * (1 - q), (1 - p) * (1 - p) + q * q,
                           p * p + q * q};
            double sum = 0.0;
            int exact = -1;
            for (int i = 0; i < 4; ++i) {
                if (d[i] == 0.0)
                    exact = i;
                f[i] = d[i] > 0.0 ? 1.0 / d[i] : 0.0;
                sum += f[i];
            }
            for (int i = 0; i < 4; ++i)
                f[i] = exact >= 0 ? (i == exact) : f[i] / sum;
        }
        const long dx[4] = {0, -1, 0, -1}, dy[4] = {0, 0, -1, -1};
        for (int i = 0; i < 4; ++i) {
            texel(pt, im, ix + dx[i], iy + dy[i], t, &ti);
            for (int k = 0; k < 5; ++k)
                acc[k] += t[k] * f[i];
            idx += ti * f[i];
        }
    }
    for (int k = 0; k < 5; ++k)
        c[k] = acc[k];
    *index = im->indices ? (int)idx : -1;
}

int vbi_image_pixel(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 w, const vbi_shade_point *sp,
                     double *x, double *y)
{
    const vbi_image *im = &ts->images[pt->u.image.image];
    double px, py_up;
    if (!project(pt, im, w, sp, &px, &py_up))
        return 0;
    const double iw = im->width, ih = im->height;
    double x0 = px + VBI_POV_EPSILON, y0 = py_up + VBI_POV_EPSILON;
    switch (pt->u.image.wrap) {
    case VBI_IMAGE_ONCE:
        if (x0 >= iw || y0 >= ih || x0 < 0.0 || y0 < 0.0)
            return 0;
        *x = wrapd(x0, iw);
        *y = wrapd(-y0, ih);
        return 1;
    case VBI_IMAGE_CLAMP:
        *x = x0 < 0.0 ? 0.0 : (x0 > iw ? iw : x0);
        *y = ih - (y0 < 0.0 ? 0.0 : (y0 > ih ? ih : y0));
        return 1;
    default:
        *x = wrapd(x0, iw);
        *y = wrapd(-y0, ih); /* rows count down from the top */
        return 1;
    }
}

void vbi_image_lookup(const vbi_texture_set *ts, const vbi_pattern *pt, double x, double y, float out[5], int *index)
{
    double c[5];
    lookup(pt, &ts->images[pt->u.image.image], x, y, c, index);
    for (int k = 0; k < 5; ++k)
        out[k] = (float)c[k];
}

int vbi_image_color(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 w, const vbi_shade_point *sp,
                     float out[5], int *index)
{
    double x, y;
    *index = -1;
    if (!vbi_image_pixel(ts, pt, w, sp, &x, &y)) {
        out[0] = out[1] = out[2] = 1.0f;
        out[3] = 0.0f;
        out[4] = 1.0f;
        return 0;
    }
    vbi_image_lookup(ts, pt, x, y, out, index);
    return 1;
}

double vbi_image_value(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 w, const vbi_shade_point *sp)
{
    float c[5];
    int index;
    const int use = pt->u.image.use;
    if (!vbi_image_color(ts, pt, w, sp, c, &index))
        return 0.0;
    double v;
    if (use == 4) /* material_map: the palette index, or the red channel as one */
        return index >= 0 ? (double)index : (double)(int)(c[0] * 255.0);
    if (index < 0 || use != 0) {
        if (use == 3)
            v = ts->images[pt->u.image.image].opaque ? c[0] : c[4];
        else
            v = vbi_greyscale(c);
    } else {
        v = index / 255.0;
    }
    return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
}
