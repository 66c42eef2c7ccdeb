/* vbnl object layer: height_field { [png] "file.png" | function W, H { F }
 *                                   [smooth] [water_level w] [hierarchy b] modifiers }
 *
 * POV-Ray 3.7's height field (hfield.cpp) is itself made of triangles, so it is reproduced
 * exactly: an image of W x H pixels spans x and z in [0, 1], pixel (i, row) at
 * x = i / (W - 1), z = (H - 1 - row) / (H - 1) (the image's top row at z = 1), height
 * y = value / 65536, and each cell is cut along its diagonal from (i + 1, z) to (i, z + 1).
 * Values as POV-Ray's image_height_at: a palette image's index * 256, a grey image's value *
 * 65535, an 8-bit colour image's red * 256 + green, a 16-bit colour one's grey * 65535. A
 * function image is F(i / (W - 1), row / (H - 1), 0) clamped to [0, 1] on 16 bits. `smooth`
 * averages the normals of the four quadrants around each point (POV-Ray's normals);
 * `water_level w` cuts the surface away below the height w (POV-Ray's rays do not look below
 * it). Inside (for CSG): below the surface over the unit square, or below the water level. Images are read as
 * texture images are (PNG through libpng, the other formats through OpenImageIO: pov_image.h); POV-Ray's `pot`
 * and `sys` files are skipped with a warning. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "pov_image.h"

#include "pov_surface.h"
#include "sdl_internal.h"

typedef struct hf_data {
    uint32_t w, h; /* points along x and z */
    float *y;      /* heights (scaled to [0, 1)), row z-major: y[z * w + x] */
    double water;
} hf_data;

static double hf_at(const hf_data *d, uint32_t x, uint32_t z) { return d->y[(size_t)z * d->w + x]; }

static int hf_inside(const void *data, const double q[3])
{
    const hf_data *d = data;
    double gx = q[0] * (d->w - 1), gz = q[2] * (d->h - 1);
    if (!(gx >= 0 && gx < d->w - 1 && gz >= 0 && gz < d->h - 1) || q[1] >= 1.0)
        return 0;
    if (q[1] < d->water)
        return 1;
    uint32_t px = (uint32_t)gx, pz = (uint32_t)gz;
    double fx = gx - px, fz = gz - pz, y;
    if (fx + fz < 1) /* the triangle (px, pz) (px + 1, pz) (px, pz + 1) */
        y = hf_at(d, px, pz) + fx * (hf_at(d, px + 1, pz) - hf_at(d, px, pz)) + fz * (hf_at(d, px, pz + 1) - hf_at(d, px, pz));
    else
        y = hf_at(d, px + 1, pz + 1) + (1 - fx) * (hf_at(d, px, pz + 1) - hf_at(d, px + 1, pz + 1)) +
            (1 - fz) * (hf_at(d, px + 1, pz) - hf_at(d, px + 1, pz + 1));
    return q[1] < y;
}

static void hf_destroy(void *data)
{
    hf_data *d = data;
    free(d->y);
    free(d);
}

static const pov_solid_fn hf_fn = {hf_inside, hf_destroy, NULL};

/* ---- the heights ----------------------------------------------------------------------------- */

/* A PNG's heights, or NULL with *why set. */
/* The heights of an image as POV-Ray's image_height_at gives them, on 16 bits (value / 65536):
 * a palette image's index * 256, a grey image's value * 65535, a colour image of at most 8 bits
 * (or a float one, which POV-Ray also counts as 8-bit) red * 256 + green, a deeper colour one's
 * grey (0.297 r + 0.589 g + 0.114 b) * 65535. The stored values are used as they are, without
 * the file's transfer function. Returns NULL with the reason in *why. */
static float *image_heights(const pov_image_data *img, const char **why)
{
    const uint32_t W = img->width, H = img->height, ch = img->channels;
    if (W < 2 || H < 2 || W > 16384 || H > 16384) {
        *why = "a size a height field cannot use (2 to 16384 pixels a side)";
        return NULL;
    }
    float *heights = malloc(sizeof *heights * (size_t)W * H);
    if (!heights) {
        *why = "out of memory";
        return NULL;
    }
    for (uint32_t r = 0; r < H; ++r)
        for (uint32_t x = 0; x < W; ++x) {
            const size_t i = (size_t)r * W + x;
            const float *px = img->texels + i * ch;
            double v[3];
            for (int c = 0; c < 3; ++c) {
                const float t = px[ch >= 3 ? c : 0];
                v[c] = isfinite(t) ? t : 0.0;
            }
            /* an integer format's stored integers, exactly (the texels are their floats scaled to [0, 1]) */
            const double q = img->bits >= 1 && img->bits <= 16 ? (double)((1u << img->bits) - 1u) : 0.0;
            double n[3];
            for (int c = 0; c < 3; ++c)
                n[c] = q > 0.0 ? (double)lrint(v[c] * q) : v[c];
            double hv;
            if (img->indices)
                hv = img->indices[i] * 256.0;
            else if (ch < 3)
                hv = q > 0.0 ? floor(n[0] * 65535.0 / q) : floor(v[0] * 65535.0);
            else if (img->bits > 8)
                hv = floor((0.297 * n[0] + 0.589 * n[1] + 0.114 * n[2]) * 65535.0 / q);
            else if (q > 0.0)
                hv = n[0] * 256.0 + n[1]; /* red the high byte, green the low one */
            else
                hv = floor((v[0] * 256.0 + v[1]) * 255.0);
            hv = hv < 0.0 ? 0.0 : hv > 65535.0 ? 65535.0 : hv;
            heights[(size_t)(H - 1 - r) * W + x] = (float)(hv / 65536.0);
        }
    return heights;
}

typedef struct hf_shape {
    pov_mods mods;
    hf_data *d;
    int smooth, skip;
    double water;
} hf_shape;

static vbnl_result hf_smooth(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((hf_shape *)it->target)->smooth = 1;
    return VBNL_OK;
}

static const pov_row hf_rows[] = {
    {"smooth", hf_smooth, 0},
    {"water_level", pov_item_float, offsetof(hf_shape, water)},
    {NULL, NULL, 0},
};
POV_SHAPE_BLOCK(hf_block, hf_rows);

/* The normal of the triangle (a, b, c) of grid points, in grid units (x, z cells; y in 1/65536). */
static int quadrant(const hf_data *d, int ax, int az, int bx, int bz, int cx, int cz, double n[3])
{
    if (bx < 0 || bz < 0 || cx < 0 || cz < 0 || bx >= (int)d->w || cx >= (int)d->w || bz >= (int)d->h || cz >= (int)d->h)
        return 0;
    double ya = d->y[(size_t)az * d->w + ax] * 65536.0, yb = d->y[(size_t)bz * d->w + bx] * 65536.0,
           yc = d->y[(size_t)cz * d->w + cx] * 65536.0;
    double u[3] = {bx - ax, yb - ya, bz - az}, v[3] = {cx - ax, yc - ya, cz - az}, c[3];
    pov_cross3(v, u, c); /* upwards for a flat field */
    double l = pov_len3(c);
    if (!(l > 0))
        return 0;
    for (int k = 0; k < 3; ++k)
        n[k] += c[k] / l;
    return 1;
}

/* The triangle's part at or above the water level (all of it without water). */
static void water_tri(pov_smesh *m, uint32_t a, uint32_t b, uint32_t c, double water)
{
    uint32_t id[3] = {a, b, c}, out[4];
    int n = 0, above = 0;
    for (int k = 0; k < 3; ++k)
        above += m->v[id[k]].p[1] >= water;
    if (above == 3 || water <= 0) {
        pov_smesh_tri(m, a, b, c);
        return;
    }
    if (above == 0)
        return;
    for (int k = 0; k < 3 && !m->oom; ++k) { /* Sutherland-Hodgman against y = water */
        pov_svert p = m->v[id[k]], q = m->v[id[(k + 1) % 3]];
        int pin = p.p[1] >= water, qin = q.p[1] >= water;
        if (pin)
            out[n++] = id[k];
        if (pin != qin) {
            double t = (water - p.p[1]) / (q.p[1] - p.p[1]);
            pov_svert v;
            for (int j = 0; j < 3; ++j) {
                v.p[j] = p.p[j] + t * (q.p[j] - p.p[j]);
                v.n[j] = p.n[j] + t * (q.n[j] - p.n[j]);
            }
            for (int j = 0; j < 2; ++j) {
                v.uv[j] = p.uv[j] + t * (q.uv[j] - p.uv[j]);
                v.s[j] = 0;
            }
            v.p[1] = water;
            double l = pov_len3(v.n);
            if (l > 0)
                pov_scale3(v.n, 1 / l);
            out[n++] = pov_smesh_vert(m, &v);
        }
    }
    for (int k = 1; k + 1 < n; ++k)
        pov_smesh_tri(m, out[0], out[k], out[k + 1]);
}

static vbnl_result hf_make(const pov_shape *s, pov_mods *mods, pov_prim *pr)
{
    hf_shape *hs = (hf_shape *)mods;
    hf_data *d = hs->d;
    if (hs->skip)
        return VBNL_OK; /* an empty mesh */
    d->water = hs->water;
    uint32_t W = d->w, H = d->h;
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    double sx = 1.0 / (W - 1), sz = 1.0 / (H - 1);
    for (uint32_t z = 0; z < H && !sm.oom; ++z)
        for (uint32_t x = 0; x < W; ++x) {
            pov_svert v;
            memset(&v, 0, sizeof v);
            pov_set3(v.p, x * sx, hf_at(d, x, z), z * sz);
            if (hs->smooth) {
                double n[3] = {0, 0, 0};
                int k = quadrant(d, (int)x, (int)z, (int)x + 1, (int)z, (int)x, (int)z + 1, n) +
                        quadrant(d, (int)x, (int)z, (int)x, (int)z + 1, (int)x - 1, (int)z, n) +
                        quadrant(d, (int)x, (int)z, (int)x - 1, (int)z, (int)x, (int)z - 1, n) +
                        quadrant(d, (int)x, (int)z, (int)x, (int)z - 1, (int)x + 1, (int)z, n);
                /* from grid units to the unit square: the inverse transpose of the scale */
                pov_set3(v.n, n[0] * (W - 1), n[1] * 65536.0, n[2] * (H - 1));
                double l = pov_len3(v.n);
                if (k && l > 0)
                    pov_scale3(v.n, 1 / l);
                else
                    pov_set3(v.n, 0, 1, 0);
            }
            v.uv[0] = x * sx;
            v.uv[1] = z * sz;
            pov_smesh_vert(&sm, &v);
        }
    for (uint32_t z = 0; z + 1 < H && !sm.oom; ++z)
        for (uint32_t x = 0; x + 1 < W; ++x) {
            uint32_t a = z * W + x, b = a + 1, c = a + W, e = c + 1;
            /* (x, z) (x, z + 1) (x + 1, z) and (x + 1, z + 1) (x + 1, z) (x, z + 1): upward faces */
            water_tri(&sm, a, c, b, d->water);
            water_tri(&sm, e, b, c, d->water);
        }
    if (!hs->smooth && !sm.oom) { /* flat: the faces' own normals (one vertex per corner) */
        pov_smesh flat;
        memset(&flat, 0, sizeof flat);
        for (uint32_t t = 0; t < sm.nt && !flat.oom; ++t) {
            pov_svert v[3];
            for (int k = 0; k < 3; ++k)
                v[k] = sm.v[sm.t[3 * t + k]];
            double e1[3], e2[3], n[3];
            for (int k = 0; k < 3; ++k) {
                e1[k] = v[1].p[k] - v[0].p[k];
                e2[k] = v[2].p[k] - v[0].p[k];
            }
            pov_cross3(e1, e2, n);
            double l = pov_len3(n);
            for (int k = 0; k < 3; ++k) {
                memcpy(v[k].n, n, sizeof n);
                pov_scale3(v[k].n, l > 0 ? 1 / l : 0);
            }
            uint32_t i0 = pov_smesh_vert(&flat, &v[0]), i1 = pov_smesh_vert(&flat, &v[1]), i2 = pov_smesh_vert(&flat, &v[2]);
            pov_smesh_tri(&flat, i0, i1, i2);
        }
        pov_smesh_free(&sm);
        sm = flat;
    }
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    pov_solid *solid = pov_solid_custom(&hf_fn, d, lo, hi);
    hs->d = NULL;
    if (!solid) {
        pov_smesh_free(&sm);
        return pov_oom(s->L);
    }
    return pov_shape_set_mesh(s, pr, &sm, 1, solid);
}

vbnl_result pov_shape_height_field(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    hf_shape hs;
    memset(&hs, 0, sizeof hs);
    if (!(hs.d = calloc(1, sizeof *hs.d)))
        return pov_oom(L);
    vbnl_result r = VBNL_OK;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    vbnl_sdl_loc at = t->loc;
    if (pov_is_word(t, "function")) {
        double w, h;
        vbnl_sdl_next(p);
        if (pov_float(L, &w) != VBNL_OK || (pov_comma(L), pov_float(L, &h)) != VBNL_OK) {
            r = VBNL_ERR_PARSE;
            goto done;
        }
        w = floor(w + 0.5);
        h = floor(h + 0.5);
        if (!(w >= 2 && h >= 2 && w <= 16384 && h <= 16384)) {
            r = vbnl_sdl_error(p, &at, "height_field: the function's size must be 2 to 16384 a side, got %g x %g", w, h);
            goto done;
        }
        vbnl_sdl_value fv;
        vbnl_sdl_loc floc = vbnl_sdl_peek(p)->loc;
        if (!sdl_parse_function_body(p, &fv, &floc)) {
            r = VBNL_ERR_PARSE;
            goto done;
        }
        hs.d->w = (uint32_t)w;
        hs.d->h = (uint32_t)h;
        hs.d->y = malloc(sizeof *hs.d->y * hs.d->w * hs.d->h);
        for (uint32_t row = 0; hs.d->y && row < hs.d->h && r == VBNL_OK; ++row)
            for (uint32_t i = 0; i < hs.d->w; ++i) {
                double a[3] = {(double)i / (w - 1), (double)row / (h - 1), 0}, v = 0;
                if (vbnl_sdl_function_call(p, fv.u.fn, a, 3, &v) != VBNL_OK) {
                    r = VBNL_ERR_PARSE;
                    break;
                }
                v = floor(fmin(fmax(isfinite(v) ? v : 0, 0), 1) * 65535.0); /* a 16-bit grey image */
                hs.d->y[(size_t)(hs.d->h - 1 - row) * hs.d->w + i] = (float)(v / 65536.0);
            }
        sdl_function_release(p, fv.u.fn);
        if (r == VBNL_OK && !hs.d->y)
            r = pov_oom(L);
    } else {
        static const char *const types[] = {"png", "gif", "tga", "pgm", "ppm", "sys", "pot", "iff", "jpeg", "tiff",
                                            "exr", "hdr", "bmp"};
        const char *type = NULL;
        for (size_t i = 0; i < sizeof types / sizeof types[0]; ++i)
            if (pov_is_word(t, types[i]))
                type = types[i];
        if (type)
            vbnl_sdl_next(p);
        char *name = NULL, *path = NULL;
        vbnl_sdl_loc nloc = vbnl_sdl_peek(p)->loc;
        if (vbnl_sdl_parse_string(p, &name) != VBNL_OK) {
            r = VBNL_ERR_PARSE;
            goto done;
        }
        const char *dot = strrchr(name, '.');
        const int pot = type ? !strcmp(type, "pot") : dot && !strcasecmp(dot + 1, "pot");
        if (pot || (type && !strcmp(type, "sys"))) {
            /* Fractint's continuous-potential files and a platform's own format: no image library
             * reads them */
            vbnl_sdl_warning(p, &at, "height_field: '%s' images are not read (convert '%s' to PNG); the object is skipped",
                             pot ? "pot" : "sys", name);
            hs.skip = 1;
        } else if (!(path = pov_shape_find_file(L, name, NULL, &nloc, "height_field: image"))) {
            r = VBNL_ERR_PARSE;
        } else {
            /* every other format through the texture images' reader (libpng, else OpenImageIO) */
            pov_image_data img;
            char msg[256];
            const char *why = NULL;
            if (pov_image_read(path, &img, msg, sizeof msg) != 0) {
                r = vbnl_sdl_error(p, &nloc, "height_field: cannot read '%s': %s", path, msg);
            } else {
                if ((hs.d->y = image_heights(&img, &why)) != NULL) {
                    hs.d->w = img.width;
                    hs.d->h = img.height;
                } else {
                    r = strcmp(why, "out of memory") ? vbnl_sdl_error(p, &nloc, "height_field: cannot read '%s': %s", path, why)
                                                     : pov_oom(L);
                }
                pov_image_data_free(&img);
            }
        }
        free(name);
        free(path);
    }
    if (r == VBNL_OK)
        r = pov_shape_deferred(s, &hf_block, &hs.mods, hf_make);
done:
    if (hs.d)
        hf_destroy(hs.d);
    return r;
}
