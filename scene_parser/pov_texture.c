/* vbnl: the texture part of the POV-Ray scene language: texture, pigment, finish, normal,
 * interior, material, colour maps, #default, and the mapping of an appearance onto a core
 * material and texture (the table is in scene_parser/README.md). */
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_internal.h"
#include "pov_texture.h"

#define MAP_MAX 256
#define PATH_MAX_LEN 1024

enum { PIG_SOLID = 0, PIG_CHECKER, PIG_GRADIENT, PIG_BRICK, PIG_IMAGE };

typedef struct pov_map_entry {
    double value;
    double color[5];
} pov_map_entry;

typedef struct pov_color_map {
    uint32_t count;
    pov_map_entry e[MAP_MAX];
} pov_color_map;

typedef struct pov_pigment {
    int kind;
    double color[5];       /* PIG_SOLID (also the fallback average of unsupported patterns) */
    pov_color_map map;     /* patterns: colour map, or the two colours of checker / brick */
    double gradient[3], brick_size[3], mortar, frequency, phase;
    int wave;
    int image;             /* PIG_IMAGE: index in the state's image list */
    int map_type, once, interpolate, uv_mapping;
    double xf[16];         /* pattern space -> POV world: the transforms applied so far */
} pov_pigment;

typedef struct pov_finish {
    double diffuse, emission[3], reflection[3], specular, roughness, phong, phong_size;
    int metallic;
} pov_finish;

typedef struct pov_ext_bsdf {
    int set, has_color;
    vbnl_material_desc desc;
} pov_ext_bsdf;

typedef struct pov_texture {
    pov_pigment pig;
    pov_finish fin;
    pov_ext_bsdf ext;
} pov_texture;

typedef struct pov_interior {
    double ior;
} pov_interior;

struct pov_appearance {
    pov_texture tex;
    pov_interior interior;
    vbnl_sdl_loc loc;     /* where the object's appearance was first given (warnings) */
    int own_texture;      /* a texture { } was given on this object: another one is a layer */
};

typedef struct pov_normal {
    int unused;
} pov_normal;

typedef struct image_entry {
    char path[PATH_MAX_LEN];
    uint32_t width, height;
    float *texels;
} image_entry;

typedef struct cache_entry {
    unsigned char key[sizeof(vbnl_material_desc) + sizeof(pov_pigment) + 8];
    uint32_t material;
    vbnl_material_desc desc;
    int has_texture;
    vbnl_texture_desc tdesc;
    vbnl_color_map_entry map[MAP_MAX];
} cache_entry;

struct pov_texture_state {
    pov_appearance deflt;
    image_entry *images;
    uint32_t image_count;
    cache_entry **cache;
    uint32_t cache_count, cache_cap;
    int normal_warned;
    int depth; /* nested pigments (pigment lists) */
};

/* ---- opaque values ------------------------------------------------------------------------- */

enum { TAG_TEXTURE = 1, TAG_PIGMENT, TAG_FINISH, TAG_NORMAL, TAG_INTERIOR, TAG_MATERIAL, TAG_COLOR_MAP };

static void *blob_copy(const void *ptr, void *user)
{
    size_t n = (size_t)(uintptr_t)user;
    void *q = malloc(n);
    if (q)
        memcpy(q, ptr, n);
    return q;
}
static void blob_free(void *ptr, void *user)
{
    (void)user;
    free(ptr);
}

#define OPAQUE(var, nm, T) \
    static const vbnl_sdl_opaque_type var = {nm, blob_free, blob_copy, (void *)(uintptr_t)sizeof(T), NULL}
static void *texture_layer(void *below, void *above, void *user);
static const vbnl_sdl_opaque_type type_texture = {"texture", blob_free, blob_copy,
                                                  (void *)(uintptr_t)sizeof(pov_texture), texture_layer};
OPAQUE(type_pigment, "pigment", pov_pigment);
OPAQUE(type_finish, "finish", pov_finish);
OPAQUE(type_normal, "normal", pov_normal);
OPAQUE(type_interior, "interior", pov_interior);
OPAQUE(type_material, "material", pov_appearance);
OPAQUE(type_color_map, "color_map", pov_color_map);

/* Takes the value of an identifier, or of an array element `Arr[i]...`, holding an object-layer
 * value of this type into dst. Returns 1 when taken (tokens consumed), 0 when the next token is
 * not such a value, -1 on a parse error. */
static int take_ident(pov_ctx *c, const vbnl_sdl_opaque_type *type, void *dst, size_t size)
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *tok = vbnl_sdl_peek(p);
    if (tok->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    const vbnl_sdl_value *v = vbnl_sdl_lookup(p, tok->text);
    if (!v)
        return 0;
    if (v->kind == VBNL_SDL_OBJECT && v->u.obj.type == type) {
        vbnl_sdl_loc use = tok->loc;
        memcpy(dst, v->u.obj.ptr, size);
        vbnl_sdl_defer_use(p, v->u.obj.deferred, &use);
        vbnl_sdl_next(p);
        return 1;
    }
    if (v->kind != VBNL_SDL_ARRAY)
        return 0;
    vbnl_sdl_loc loc = tok->loc;
    vbnl_sdl_value e;
    if (vbnl_sdl_parse_expression(p, &e) != VBNL_OK)
        return -1;
    if (e.kind != VBNL_SDL_OBJECT || e.u.obj.type != type) {
        const char *kind = e.kind == VBNL_SDL_OBJECT ? e.u.obj.type->name : vbnl_sdl_kind_name(e.kind);
        vbnl_sdl_value_clear(p, &e);
        vbnl_sdl_error(p, &loc, "array element is a %s, not a %s", kind, type->name);
        return -1;
    }
    memcpy(dst, e.u.obj.ptr, size);
    vbnl_sdl_defer_use(p, e.u.obj.deferred, &loc);
    vbnl_sdl_value_clear(p, &e);
    return 1;
}

static int is_kw(const vbnl_sdl_token *t, const char *kw)
{
    return t->kind == VBNL_SDL_TOK_IDENT && strcmp(t->text, kw) == 0;
}

/* ---- matrices ------------------------------------------------------------------------------ */

static void m_identity(double m[16])
{
    memset(m, 0, 16 * sizeof(double));
    m[0] = m[5] = m[10] = m[15] = 1.0;
}

/* r = a * b */
static void m_mul(const double a[16], const double b[16], double r[16])
{
    double t[16];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            double s = 0.0;
            for (int k = 0; k < 4; ++k)
                s += a[4 * i + k] * b[4 * k + j];
            t[4 * i + j] = s;
        }
    memcpy(r, t, sizeof(t));
}

/* Inverse of an affine matrix; 0 when singular. */
static int m_inverse(const double m[16], double r[16])
{
    double a = m[0], b = m[1], cc = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9], i = m[10];
    double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
    double det = a * A + b * B + cc * C;
    if (!(fabs(det) > 1e-300) || !isfinite(det))
        return 0;
    double inv[9] = {A / det, -(b * i - cc * h) / det, (b * f - cc * e) / det,
                     B / det, (a * i - cc * g) / det,  -(a * f - cc * d) / det,
                     C / det, -(a * h - b * g) / det,  (a * e - b * d) / det};
    m_identity(r);
    for (int row = 0; row < 3; ++row) {
        for (int col = 0; col < 3; ++col)
            r[4 * row + col] = inv[3 * row + col];
        r[4 * row + 3] = -(inv[3 * row] * m[3] + inv[3 * row + 1] * m[7] + inv[3 * row + 2] * m[11]);
    }
    return 1;
}

static void rotation(double axis, double deg, double m[16])
{
    m_identity(m);
    double s = sin(deg * M_PI / 180.0), co = cos(deg * M_PI / 180.0);
    int a = (int)axis, i = (a + 1) % 3, j = (a + 2) % 3;
    m[4 * i + i] = co;
    m[4 * i + j] = -s;
    m[4 * j + i] = s;
    m[4 * j + j] = co;
}

/* One transform item (translate rotate scale matrix transform [inverse]) into *m (p' = m p);
 * returns 1 when `t` started one, 0 when not, -1 on error. */
static int parse_transform_item(pov_ctx *c, double m[16]);

static int parse_transform_block(pov_ctx *c, double m[16])
{
    if (vbnl_sdl_expect(c->parser, '{', "after 'transform'") != VBNL_OK)
        return -1;
    double acc[16];
    m_identity(acc);
    int inverse = 0;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(c->parser);
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(c->parser);
            break;
        }
        if (is_kw(t, "inverse")) {
            vbnl_sdl_next(c->parser);
            inverse = !inverse;
            continue;
        }
        double one[16];
        int r = parse_transform_item(c, one);
        if (r < 0)
            return -1;
        if (r == 0) {
            vbnl_sdl_error(c->parser, &t->loc, "unexpected '%s' in transform", t->text);
            return -1;
        }
        m_mul(one, acc, acc);
    }
    if (inverse && !m_inverse(acc, acc)) {
        vbnl_sdl_error(c->parser, NULL, "cannot invert a singular transform");
        return -1;
    }
    memcpy(m, acc, sizeof(acc));
    return 1;
}

static int parse_transform_item(pov_ctx *c, double m[16])
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(c->parser);
    if (t->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    vbnl_sdl_loc loc = t->loc;
    double v[12];
    m_identity(m);
    if (is_kw(t, "translate")) {
        vbnl_sdl_next(c->parser);
        if (vbnl_sdl_parse_vector(c->parser, 3, v) != VBNL_OK)
            return -1;
        m[3] = v[0];
        m[7] = v[1];
        m[11] = v[2];
        return 1;
    }
    if (is_kw(t, "scale")) {
        vbnl_sdl_next(c->parser);
        if (vbnl_sdl_parse_vector(c->parser, 3, v) != VBNL_OK)
            return -1;
        if (v[0] == 0.0 || v[1] == 0.0 || v[2] == 0.0) {
            vbnl_sdl_error(c->parser, &loc, "scale by zero");
            return -1;
        }
        m[0] = v[0];
        m[5] = v[1];
        m[10] = v[2];
        return 1;
    }
    if (is_kw(t, "rotate")) {
        vbnl_sdl_next(c->parser);
        if (vbnl_sdl_parse_vector(c->parser, 3, v) != VBNL_OK)
            return -1;
        /* POV-Ray rotates about x, then y, then z */
        double r[16];
        for (int a = 0; a < 3; ++a) {
            rotation(a, v[a], r);
            m_mul(r, m, m);
        }
        return 1;
    }
    if (is_kw(t, "matrix")) {
        vbnl_sdl_next(c->parser);
        if (vbnl_sdl_expect(c->parser, '<', "after 'matrix'") != VBNL_OK)
            return -1;
        for (int i = 0; i < 12; ++i) {
            if (i > 0 && vbnl_sdl_expect(c->parser, ',', "between matrix values") != VBNL_OK)
                return -1;
            if (vbnl_sdl_parse_float(c->parser, &v[i]) != VBNL_OK)
                return -1;
        }
        if (vbnl_sdl_expect(c->parser, '>', "after the 12 matrix values") != VBNL_OK)
            return -1;
        /* POV-Ray's row-vector form p' = p M: x' = x v0 + y v3 + z v6 + v9 */
        for (int row = 0; row < 3; ++row) {
            for (int col = 0; col < 3; ++col)
                m[4 * row + col] = v[3 * col + row];
            m[4 * row + 3] = v[9 + row];
        }
        return 1;
    }
    if (is_kw(t, "transform")) {
        vbnl_sdl_next(c->parser);
        const vbnl_sdl_token *n = vbnl_sdl_peek(c->parser);
        if (n->kind == VBNL_SDL_TOK_PUNCT && n->op == '{')
            return parse_transform_block(c, m);
        vbnl_sdl_error(c->parser, &n->loc, "'transform' in an appearance takes a { } block here");
        return -1;
    }
    return 0;
}

/* ---- defaults ------------------------------------------------------------------------------ */

static void pigment_init(pov_pigment *p)
{
    memset(p, 0, sizeof(*p));
    p->kind = PIG_SOLID; /* POV-Ray's default pigment: black */
    p->gradient[0] = 1.0;
    p->brick_size[0] = 8.0;
    p->brick_size[1] = 3.0;
    p->brick_size[2] = 4.5;
    p->mortar = 0.5;
    p->frequency = 1.0;
    p->image = -1;
    m_identity(p->xf);
}

static void finish_init(pov_finish *f)
{
    memset(f, 0, sizeof(*f));
    f->diffuse = 0.6;
    f->roughness = 0.05;
    f->phong_size = 40.0;
}

static void texture_init(pov_texture *t)
{
    memset(t, 0, sizeof(*t));
    pigment_init(&t->pig);
    finish_init(&t->fin);
}

static void appearance_init(pov_appearance *a)
{
    memset(a, 0, sizeof(*a));
    texture_init(&a->tex);
    a->interior.ior = 1.0;
}

/* ---- colour maps ------------------------------------------------------------------------- */

static vbnl_result parse_color_map_body(pov_ctx *c, pov_color_map *m)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'color_map'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    m->count = 0;
    int unsorted = 0;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    int taken_m = take_ident(c, &type_color_map, m, sizeof *m);
    if (taken_m < 0)
        return VBNL_ERR_PARSE;
    for (;;) {
        t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            break;
        }
        if (vbnl_sdl_expect(p, '[', "to start a color_map entry") != VBNL_OK)
            return VBNL_ERR_PARSE;
        double v0, v1 = 0.0;
        if (vbnl_sdl_parse_float(p, &v0) != VBNL_OK)
            return VBNL_ERR_PARSE;
        /* [v1, v2 colour1 colour2] (the comma is optional) */
        /* ([v colour] may also be written [v, colour]) */
        vbnl_sdl_accept(p, ',');
        int two;
        {
            const vbnl_sdl_token *n = vbnl_sdl_peek(p);
            const vbnl_sdl_value *nv = n->kind == VBNL_SDL_TOK_IDENT ? vbnl_sdl_lookup(p, n->text) : NULL;
            two = n->kind == VBNL_SDL_TOK_NUMBER || (nv && nv->kind == VBNL_SDL_FLOAT) ||
                  (n->kind == VBNL_SDL_TOK_PUNCT && (n->op == '(' || n->op == '-' || n->op == '+'));
        }
        if (two && vbnl_sdl_parse_float(p, &v1) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (m->count + (two ? 2u : 1u) > MAP_MAX)
            return vbnl_sdl_error(p, &loc, "color_map has more than %d entries", MAP_MAX);
        pov_map_entry *e = &m->e[m->count];
        e->value = v0;
        if (vbnl_sdl_parse_color(p, e->color) != VBNL_OK)
            return VBNL_ERR_PARSE;
        m->count++;
        if (two) {
            vbnl_sdl_accept(p, ',');
            e[1].value = v1;
            if (vbnl_sdl_parse_color(p, e[1].color) != VBNL_OK)
                return VBNL_ERR_PARSE;
            m->count++;
        }
        if (vbnl_sdl_expect(p, ']', "to end a color_map entry") != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!isfinite(v0) || !isfinite(v1))
            return vbnl_sdl_error(p, &loc, "color_map values must be finite");
        if (m->count > 1 && m->e[m->count - 1].value < m->e[m->count - 2].value && !unsorted) {
            unsorted = 1;
            vbnl_sdl_warning(p, &loc, "color_map values decrease (%g after %g): entries sorted by value",
                             m->e[m->count - 1].value, m->e[m->count - 2].value);
        }
    }
    if (m->count == 0)
        return vbnl_sdl_error(p, NULL, "empty color_map");
    /* stable insertion sort: equal values keep their order (a sharp step) */
    for (uint32_t i = 1; i < m->count; ++i) {
        pov_map_entry e = m->e[i];
        uint32_t j = i;
        while (j > 0 && m->e[j - 1].value > e.value) {
            m->e[j] = m->e[j - 1];
            --j;
        }
        m->e[j] = e;
    }
    return VBNL_OK;
}

/* Interval-weighted average colour of a map over [0, 1] (entries held outside their range). */
static void color_map_average(const pov_color_map *m, double out[5])
{
    memset(out, 0, 5 * sizeof(double));
    if (m->count == 0) {
        for (int k = 0; k < 3; ++k)
            out[k] = 0.5;
        return;
    }
    double prev_v = 0.0;
    const double *prev_c = m->e[0].color;
    for (uint32_t i = 0; i <= m->count; ++i) {
        double v = i < m->count ? m->e[i].value : 1.0;
        const double *col = i < m->count ? m->e[i].color : m->e[m->count - 1].color;
        double w = v - prev_v;
        for (int k = 0; k < 5; ++k)
            out[k] += w * 0.5 * (prev_c[k] + col[k]);
        prev_v = v;
        prev_c = col;
    }
}

/* Mean filter + transmit of a pigment (its colour map's average for patterns; images count as
 * opaque). */
static double pigment_transparency(const pov_pigment *g)
{
    double col[5];
    if (g->kind == PIG_IMAGE)
        return 0.0;
    if (g->kind == PIG_SOLID)
        memcpy(col, g->color, sizeof col);
    else
        color_map_average(&g->map, col);
    return col[3] + col[4];
}

/* Layered textures (POV-Ray shows lower layers through the transparent parts of upper ones) are
 * rendered as one layer: the next layer replaces the one below unless its pigment is mostly
 * transparent (filter + transmit >= 0.5 on average), as the top layers of stones.inc are. */
static void texture_put_layer(pov_texture *below, const pov_texture *above)
{
    if (pigment_transparency(&above->pig) < 0.5)
        *below = *above;
}

static void *texture_layer(void *below, void *above, void *user)
{
    (void)user;
    texture_put_layer(below, above);
    free(above);
    return below;
}

/* ---- images -------------------------------------------------------------------------------- */

static float srgb_to_linear(float v)
{
    return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f);
}

/* Finds `name` next to the file that names it, else as given; loads it once. */
static int load_image(pov_ctx *c, const char *name, const vbnl_sdl_loc *loc)
{
    pov_texture_state *s = c->tex;
    char path[PATH_MAX_LEN];
    path[0] = '\0';
    if (name[0] != '/' && loc->file) {
        const char *slash = strrchr(loc->file, '/');
        if (slash) {
            int n = snprintf(path, sizeof(path), "%.*s/%s", (int)(slash - loc->file), loc->file, name);
            FILE *f = n > 0 && (size_t)n < sizeof(path) ? fopen(path, "rb") : NULL;
            if (f)
                fclose(f);
            else
                path[0] = '\0';
        }
    }
    /* then the standard POV-Ray include folders (POV-Ray's library path) */
    static const char *const libs[] = {"/usr/share/povray-3.7/include", "/usr/share/povray/include",
                                       "/usr/local/share/povray-3.7/include"};
    for (size_t i = 0; !path[0] && name[0] != '/' && i < sizeof(libs) / sizeof(libs[0]); ++i) {
        int n = snprintf(path, sizeof(path), "%s/%s", libs[i], name);
        FILE *f = n > 0 && (size_t)n < sizeof(path) ? fopen(path, "rb") : NULL;
        if (f)
            fclose(f);
        else
            path[0] = '\0';
    }
    if (!path[0]) {
        if (strlen(name) >= sizeof(path)) {
            vbnl_sdl_error(c->parser, loc, "image file name too long");
            return -1;
        }
        strcpy(path, name);
    }
    for (uint32_t i = 0; i < s->image_count; ++i)
        if (!strcmp(s->images[i].path, path))
            return (int)i;
    png_image img;
    memset(&img, 0, sizeof(img));
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path)) {
        vbnl_sdl_error(c->parser, loc, "cannot read PNG image '%s': %s", path, img.message);
        return -1;
    }
    img.format = PNG_FORMAT_RGB;
    if (img.width == 0 || img.height == 0 || img.width > 65536 || img.height > 65536) {
        png_image_free(&img);
        vbnl_sdl_error(c->parser, loc, "PNG image '%s' has an unsupported size", path);
        return -1;
    }
    size_t n = (size_t)img.width * img.height * 3;
    unsigned char *buf = malloc(n);
    float *texels = malloc(n * sizeof(float));
    image_entry *grown = realloc(s->images, sizeof(*grown) * (s->image_count + 1));
    if (grown)
        s->images = grown;
    if (!buf || !texels || !grown) {
        png_image_free(&img);
        free(buf);
        free(texels);
        vbnl_sdl_error(c->parser, loc, "out of memory reading '%s'", path);
        return -1;
    }
    if (!png_image_finish_read(&img, NULL, buf, 0, NULL)) {
        free(buf);
        free(texels);
        vbnl_sdl_error(c->parser, loc, "cannot decode PNG image '%s': %s", path, img.message);
        return -1;
    }
    /* POV-Ray 3.7 treats PNG data as sRGB-encoded (unless the file says otherwise): linearise */
    for (size_t i = 0; i < n; ++i)
        texels[i] = srgb_to_linear((float)buf[i] / 255.0f);
    free(buf);
    image_entry *e = &s->images[s->image_count];
    memset(e, 0, sizeof(*e));
    strcpy(e->path, path);
    e->width = img.width;
    e->height = img.height;
    e->texels = texels;
    return (int)s->image_count++;
}

static vbnl_result parse_image_map(pov_ctx *c, pov_pigment *pg)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'image_map'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_IDENT) {
        static const char *const other[] = {"gif", "tga", "iff", "ppm", "pgm", "sys", "jpeg", "tiff",
                                            "bmp", "exr", "hdr", "ttf"};
        for (size_t i = 0; i < sizeof(other) / sizeof(other[0]); ++i)
            if (is_kw(t, other[i]))
                return vbnl_sdl_error(p, &t->loc, "image_map: only png images are supported (found '%s')",
                                      t->text);
        if (is_kw(t, "png"))
            vbnl_sdl_next(p);
    }
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    char *name = NULL;
    if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pg->image = load_image(c, name, &loc);
    free(name);
    if (pg->image < 0)
        return VBNL_ERR_PARSE;
    pg->kind = PIG_IMAGE;
    pg->map_type = 0;
    for (;;) {
        t = vbnl_sdl_peek(p);
        loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        double v;
        if (is_kw(t, "map_type")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (v != 0.0 && v != 1.0 && v != 2.0)
                return vbnl_sdl_error(p, &loc, "image_map: map_type %g is not supported (0 planar, 1 spherical, 2 cylindrical)", v);
            pg->map_type = (int)v;
        } else if (is_kw(t, "once")) {
            vbnl_sdl_next(p);
            pg->once = 1;
        } else if (is_kw(t, "interpolate")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            pg->interpolate = v != 0.0;
        } else if (is_kw(t, "filter") || is_kw(t, "transmit")) {
            vbnl_sdl_next(p);
            if (is_kw(vbnl_sdl_peek(p), "all"))
                vbnl_sdl_next(p);
            else if (vbnl_sdl_parse_float(p, &v) != VBNL_OK) /* palette index */
                return VBNL_ERR_PARSE;
            vbnl_sdl_accept(p, ',');
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            vbnl_sdl_warning(p, &loc, "image_map: '%s' is ignored (image maps are opaque here)", t->text);
        } else if (is_kw(t, "gamma")) {
            vbnl_sdl_next(p);
            if (is_kw(vbnl_sdl_peek(p), "srgb"))
                vbnl_sdl_next(p);
            else if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            vbnl_sdl_warning(p, &loc, "image_map: 'gamma' is ignored (PNG data are read as sRGB)");
        } else if (is_kw(t, "use_color") || is_kw(t, "use_colour") || is_kw(t, "use_index") ||
                   is_kw(t, "premultiplied")) {
            vbnl_sdl_next(p);
        } else {
            return vbnl_sdl_error(p, &loc, "unexpected '%s' in image_map", t->text);
        }
    }
}

/* ---- pigment ------------------------------------------------------------------------------- */

static const char *const fallback_patterns[] = {
    "agate", "bozo", "granite", "marble", "wood", "leopard", "onion", "spotted", "wrinkles", "ripples",
    "waves", "crackle", "dents", "bumps", "radial", "spherical", "cylindrical", "boxed", "planar",
    "quilted", "cells", "mandel", "julia", "facets", "average", "aoi", "slope", "tiling", "pavement",
    "object", "function", "density_file", "spiral1", "spiral2", "hexagon", "square", "triangular",
    "cubic", "pigment_pattern", "magnet", "image_pattern", NULL};

static vbnl_result parse_pigment_body(pov_ctx *c, pov_pigment *pg);

/* Block patterns and their number of colours (0: a continuous pattern). */
static int discrete_pattern(const char *name)
{
    if (!strcmp(name, "hexagon"))
        return 3;
    if (!strcmp(name, "square"))
        return 4;
    if (!strcmp(name, "triangular") || !strcmp(name, "cubic"))
        return 6;
    if (!strcmp(name, "object"))
        return 2;
    return 0;
}

/* POV-Ray 3.7's default colour maps of the patterns (pattern.cpp); black to white otherwise. */
static void default_color_map(const char *name, pov_color_map *m)
{
    typedef struct { double v, r, g, b; } E;
    static const E agate[] = {{0.0, 1, 1, 1}, {0.5, 0.95, 0.75, 0.5}, {0.5, 0.9, 0.7, 0.5},
                              {0.6, 0.9, 0.7, 0.4}, {0.6, 1, 0.7, 0.4}, {1.0, 0.6, 0.3, 0}};
    static const E bozo[] = {{0.4, 1, 1, 1}, {0.4, 0, 1, 0}, {0.6, 0, 1, 0},
                             {0.6, 0, 0, 1}, {0.8, 0, 0, 1}, {0.8, 1, 0, 0}};
    static const E marble[] = {{0.0, 0.9, 0.8, 0.8}, {0.9, 0.9, 0.08, 0.08}, {0.9, 0, 0, 0}};
    static const E radial[] = {{0.0, 0, 1, 1}, {0.333, 1, 1, 0}, {0.666, 1, 0, 1}, {1.0, 0, 1, 1}};
    static const E wood[] = {{0.6, 0.666, 0.312, 0.2}, {0.6, 0.4, 0.1333, 0.066}};
    static const E mandel[] = {{0.001, 0, 0, 0}, {0.001, 0, 1, 1}, {0.012, 1, 1, 0}, {0.015, 1, 0, 1}, {0.1, 0, 1, 1}};
    static const E hexagon[] = {{0, 0, 0, 1}, {1, 0, 1, 0}, {2, 1, 0, 0}};
    static const E six[] = {{0, 1, 0, 0}, {1, 0, 1, 0}, {2, 0, 0, 1}, {3, 1, 1, 0}, {4, 0, 1, 1}, {5, 1, 0, 1}};
    static const E checker[] = {{0, 0, 0, 1}, {1, 0, 1, 0}};
    static const E gray[] = {{0, 0, 0, 0}, {1, 1, 1, 1}};
    const E *e = gray;
    uint32_t n = 2;
#define PICK(kw, arr)                                                                              \
    else if (!strcmp(name, kw)) { e = arr; n = (uint32_t)(sizeof(arr) / sizeof(arr[0])); }
    if (0) {
    }
    PICK("agate", agate) PICK("bozo", bozo) PICK("marble", marble)
    PICK("radial", radial) PICK("wood", wood) PICK("mandel", mandel) PICK("hexagon", hexagon)
    PICK("object", checker)
    else if (!strcmp(name, "square")) { e = six; n = 4; }
    PICK("triangular", six) PICK("cubic", six)
#undef PICK
    m->count = n;
    for (uint32_t i = 0; i < n; ++i) {
        m->e[i].value = e[i].v;
        m->e[i].color[0] = e[i].r;
        m->e[i].color[1] = e[i].g;
        m->e[i].color[2] = e[i].b;
        m->e[i].color[3] = m->e[i].color[4] = 0.0;
    }
}

/* Two optional colours after checker / brick / hexagon: entries at 0 and 1 (and more). */
static vbnl_result parse_block_colors(pov_ctx *c, pov_pigment *pg, int max)
{
    vbnl_sdl_parser *p = c->parser;
    int n = 0;
    for (; n < max; ++n) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        int starts = is_kw(t, "color") || is_kw(t, "colour") || is_kw(t, "rgb") || is_kw(t, "rgbf") ||
                     is_kw(t, "rgbt") || is_kw(t, "rgbft") || is_kw(t, "srgb") || is_kw(t, "srgbf") ||
                     is_kw(t, "srgbt") || is_kw(t, "srgbft") || is_kw(t, "red") || is_kw(t, "green") ||
                     is_kw(t, "blue") || (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '<');
        if (!starts && t->kind == VBNL_SDL_TOK_IDENT) {
            const vbnl_sdl_value *v = vbnl_sdl_lookup(p, t->text);
            starts = v && (v->kind == VBNL_SDL_COLOR || v->kind == VBNL_SDL_VECTOR);
        }
        if (is_kw(t, "pigment")) {
            /* a pigment list entry: its representative colour */
            vbnl_sdl_loc loc = t->loc;
            vbnl_sdl_next(p);
            if (c->tex->depth >= 64)
                return vbnl_sdl_error(p, &loc, "pigments nested more than 64 deep");
            pov_pigment *sub = malloc(sizeof(*sub));
            if (!sub)
                return vbnl_sdl_error(p, &loc, "out of memory");
            pigment_init(sub);
            c->tex->depth++;
            vbnl_result r = parse_pigment_body(c, sub);
            c->tex->depth--;
            if (r == VBNL_OK) {
                if (sub->kind == PIG_SOLID)
                    memcpy(pg->map.e[n].color, sub->color, sizeof(sub->color));
                else
                    color_map_average(&sub->map, pg->map.e[n].color);
                if (sub->kind != PIG_SOLID)
                    vbnl_sdl_warning(p, &loc, "a patterned pigment inside a pattern's list is replaced by its average colour");
            }
            free(sub);
            if (r != VBNL_OK)
                return r;
            pg->map.e[n].value = (double)n;
            vbnl_sdl_accept(p, ',');
            continue;
        }
        if (!starts)
            break;
        if (vbnl_sdl_parse_color(p, pg->map.e[n].color) != VBNL_OK)
            return VBNL_ERR_PARSE;
        pg->map.e[n].value = (double)n;
        vbnl_sdl_accept(p, ',');
    }
    if (n > 0)
        pg->map.count = (uint32_t)n;
    return VBNL_OK;
}

/* Pattern modifiers shared by pigments and texture patterns (waves, turbulence and the
 * parameters of the patterns rendered as averages). 1 handled, 0 not a modifier, -1 error. */
static int parse_pattern_modifier(pov_ctx *c, pov_pigment *pg)
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    vbnl_sdl_loc loc = t->loc;
    double v;
    if (0) {
    } else if (is_kw(t, "frequency") || is_kw(t, "phase")) {
        int freq = is_kw(t, "frequency");
        vbnl_sdl_next(p);
        if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return -1;
        *(freq ? &pg->frequency : &pg->phase) = v;
    } else if (is_kw(t, "ramp_wave") || is_kw(t, "triangle_wave") || is_kw(t, "sine_wave") ||
               is_kw(t, "scallop_wave")) {
        pg->wave = is_kw(t, "ramp_wave") ? VBNL_WAVE_RAMP
                   : is_kw(t, "triangle_wave") ? VBNL_WAVE_TRIANGLE
                   : is_kw(t, "sine_wave") ? VBNL_WAVE_SINE : VBNL_WAVE_SCALLOP;
        vbnl_sdl_next(p);
    } else if (is_kw(t, "cubic_wave") || is_kw(t, "poly_wave")) {
        int poly = is_kw(t, "poly_wave");
        vbnl_sdl_next(p);
        const vbnl_sdl_token *n = vbnl_sdl_peek(p);
        if (poly && (n->kind == VBNL_SDL_TOK_NUMBER || (n->kind == VBNL_SDL_TOK_PUNCT && n->op == '(')) &&
            vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return -1;
        vbnl_sdl_warning(p, &loc, "'%s' is not supported: using ramp_wave", poly ? "poly_wave" : "cubic_wave");
    } else if (is_kw(t, "turbulence") || is_kw(t, "octaves") || is_kw(t, "omega") || is_kw(t, "lambda")) {
        int turb = is_kw(t, "turbulence");
        vbnl_sdl_next(p);
        double vv[3];
        if ((turb ? vbnl_sdl_parse_vector(p, 3, vv) : vbnl_sdl_parse_float(p, &v)) != VBNL_OK)
            return -1;
        if (turb)
            vbnl_sdl_warning(p, &loc, "'turbulence' is not supported: the pattern is rendered without it");
    } else if (is_kw(t, "agate_turb") || is_kw(t, "control0") || is_kw(t, "control1") ||
               is_kw(t, "noise_generator") || is_kw(t, "offset") || is_kw(t, "metric") ||
               is_kw(t, "max_iteration") || is_kw(t, "exponent") || is_kw(t, "precision") ||
               is_kw(t, "coords") || is_kw(t, "form") || is_kw(t, "orientation") ||
               is_kw(t, "dist_exp")) {
        /* parameters of the fallback patterns (their look is replaced by an average) */
        int vec = is_kw(t, "form") || is_kw(t, "orientation");
        vbnl_sdl_next(p);
        double vv[3];
        if ((vec ? vbnl_sdl_parse_vector(p, 3, vv) : vbnl_sdl_parse_float(p, &v)) != VBNL_OK)
            return -1;
    } else if (is_kw(t, "interior") || is_kw(t, "exterior")) {
        /* fractal patterns: interior / exterior type, factor */
        vbnl_sdl_next(p);
        if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return -1;
        vbnl_sdl_accept(p, ',');
        if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return -1;
    } else if (is_kw(t, "interpolate")) {
        vbnl_sdl_next(p);
        if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return -1;
    } else if (is_kw(t, "solid")) {
        vbnl_sdl_next(p);
    } else if (is_kw(t, "warp")) {
        vbnl_sdl_next(p);
        if (vbnl_sdl_skip_block(p) != VBNL_OK)
            return -1;
        vbnl_sdl_warning(p, &loc, "'warp' is not supported: the pattern is rendered without it");
    } else if (is_kw(t, "quick_color") || is_kw(t, "quick_colour")) {
        vbnl_sdl_next(p);
        double q[5];
        if (vbnl_sdl_parse_color(p, q) != VBNL_OK)
            return -1;
    } else {
        return 0;
    }
    return 1;
}

/* The arguments after a pattern keyword rendered as an average (or a texture pattern). */
static vbnl_result parse_pattern_args(pov_ctx *c, pov_pigment *pg, const char *name)
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *n = vbnl_sdl_peek(p);
    double v, vv[3];
    if (!strcmp(name, "spiral1") || !strcmp(name, "spiral2") || !strcmp(name, "mandel") ||
        !strcmp(name, "tiling") || !strcmp(name, "pavement")) {
        if ((!strcmp(name, "tiling") || !strcmp(name, "pavement")) && !(n->kind == VBNL_SDL_TOK_NUMBER))
            return VBNL_OK;
        return vbnl_sdl_parse_float(p, &v);
    }
    if (!strcmp(name, "julia")) {
        if (vbnl_sdl_parse_vector(p, 2, vv) != VBNL_OK)
            return VBNL_ERR_PARSE;
        vbnl_sdl_accept(p, ',');
        return vbnl_sdl_parse_float(p, &v);
    }
    if (!strcmp(name, "magnet")) {
        if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return VBNL_ERR_PARSE;
        n = vbnl_sdl_peek(p);
        if (is_kw(n, "julia")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_vector(p, 2, vv) != VBNL_OK)
                return VBNL_ERR_PARSE;
            vbnl_sdl_accept(p, ',');
        } else if (is_kw(n, "mandel")) {
            vbnl_sdl_next(p);
        } else {
            return vbnl_sdl_error(p, &n->loc, "expected 'mandel' or 'julia' after 'magnet %g'", v);
        }
        return vbnl_sdl_parse_float(p, &v);
    }
    if (!strcmp(name, "density_file")) {
        if (is_kw(n, "df3"))
            vbnl_sdl_next(p);
        char *file = NULL;
        vbnl_result r = vbnl_sdl_parse_string(p, &file);
        free(file);
        return r;
    }
    if (!strcmp(name, "slope")) {
        if (n->kind == VBNL_SDL_TOK_PUNCT && n->op == '{')
            return vbnl_sdl_skip_block(p);
        return vbnl_sdl_parse_vector(p, 3, vv);
    }
    if (!strcmp(name, "gradient"))
        return vbnl_sdl_parse_vector(p, 3, vv);
    if (!strcmp(name, "object") || !strcmp(name, "function") || !strcmp(name, "pigment_pattern") ||
        !strcmp(name, "image_pattern")) {
        if (n->kind == VBNL_SDL_TOK_PUNCT && n->op == '{' && vbnl_sdl_skip_block(p) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (strcmp(name, "object"))
            return VBNL_OK;
    }
    if (discrete_pattern(name) && pg) {
        pg->map.count = 0;
        return parse_block_colors(c, pg, discrete_pattern(name));
    }
    return VBNL_OK;
}

static vbnl_result parse_pigment_body(pov_ctx *c, pov_pigment *pg)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'pigment'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    int taken_pg = take_ident(c, &type_pigment, pg, sizeof *pg);
    if (taken_pg < 0)
        return VBNL_ERR_PARSE;
    const char *fallback = NULL;
    vbnl_sdl_loc fallback_loc = {0};
    for (;;) {
        t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            break;
        }
        if (t->kind == VBNL_SDL_TOK_EOF)
            return vbnl_sdl_error(p, &loc, "unexpected end of file in pigment");
        double m[16];
        int tr = parse_transform_item(c, m);
        if (tr < 0)
            return VBNL_ERR_PARSE;
        if (tr > 0) {
            m_mul(m, pg->xf, pg->xf);
            continue;
        }
        int pm = parse_pattern_modifier(c, pg);
        if (pm < 0)
            return VBNL_ERR_PARSE;
        if (pm > 0)
            continue;
        if (is_kw(t, "checker") || is_kw(t, "brick")) {
            int brick = is_kw(t, "brick");
            vbnl_sdl_next(p);
            pg->kind = brick ? PIG_BRICK : PIG_CHECKER;
            /* POV-Ray's defaults: checker blue / green, brick grey mortar / red bricks */
            pov_map_entry d0 = {0.0, {0, 0, 1, 0, 0}}, d1 = {1.0, {0, 1, 0, 0, 0}};
            if (brick) {
                d0 = (pov_map_entry){0.0, {0.5, 0.5, 0.5, 0, 0}};
                d1 = (pov_map_entry){1.0, {0.6, 0.15, 0.15, 0, 0}};
            }
            pg->map.count = 2;
            pg->map.e[0] = d0;
            pg->map.e[1] = d1;
            if (parse_block_colors(c, pg, 2) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (pg->map.count == 1) {
                pg->map.e[1] = d1;
                pg->map.count = 2;
            }
        } else if (is_kw(t, "gradient")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_vector(p, 3, pg->gradient) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (pg->gradient[0] == 0.0 && pg->gradient[1] == 0.0 && pg->gradient[2] == 0.0)
                return vbnl_sdl_error(p, &loc, "gradient needs a non-zero vector");
            pg->kind = PIG_GRADIENT;
        } else if (is_kw(t, "image_map")) {
            vbnl_sdl_next(p);
            if (parse_image_map(c, pg) != VBNL_OK)
                return VBNL_ERR_PARSE;
        } else if (is_kw(t, "color_map") || is_kw(t, "colour_map")) {
            vbnl_sdl_next(p);
            if (parse_color_map_body(c, &pg->map) != VBNL_OK)
                return VBNL_ERR_PARSE;
        } else if (is_kw(t, "mortar")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &pg->mortar) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (!(pg->mortar >= 0.0))
                return vbnl_sdl_error(p, &loc, "mortar must be >= 0");
        } else if (is_kw(t, "brick_size")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_vector(p, 3, pg->brick_size) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (!(pg->brick_size[0] > 0 && pg->brick_size[1] > 0 && pg->brick_size[2] > 0))
                return vbnl_sdl_error(p, &loc, "brick_size components must be > 0");
        } else if (is_kw(t, "uv_mapping")) {
            vbnl_sdl_next(p);
            pg->uv_mapping = 1;
        } else if (is_kw(t, "pigment_map") || is_kw(t, "color_map_bump")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_skip_block(p) != VBNL_OK)
                return VBNL_ERR_PARSE;
            vbnl_sdl_warning(p, &loc, "'pigment_map' is not supported: using the colour map's average (grey without one)");
            fallback = "pigment_map";
            fallback_loc = loc;
        } else {
            int known = 0;
            for (int i = 0; fallback_patterns[i]; ++i)
                if (is_kw(t, fallback_patterns[i]))
                    known = 1;
            if (known) {
                fallback = t->text;
                fallback_loc = loc;
                vbnl_sdl_next(p);
                if (parse_pattern_args(c, pg, fallback) != VBNL_OK)
                    return VBNL_ERR_PARSE;
                pg->kind = PIG_SOLID;
                continue;
            }
            /* a solid colour: color / rgb... / a colour expression */
            if (vbnl_sdl_parse_color(p, pg->color) != VBNL_OK)
                return VBNL_ERR_PARSE;
            pg->kind = PIG_SOLID;
            fallback = NULL;
        }
    }
    if (fallback) {
        if (pg->map.count == 0)
            default_color_map(fallback, &pg->map);
        if (discrete_pattern(fallback)) {
            /* block patterns: every colour covers the same share of space */
            memset(pg->color, 0, sizeof(pg->color));
            for (uint32_t i = 0; i < pg->map.count; ++i)
                for (int k = 0; k < 5; ++k)
                    pg->color[k] += pg->map.e[i].color[k] / pg->map.count;
        } else {
            color_map_average(&pg->map, pg->color);
        }
        pg->kind = PIG_SOLID;
        vbnl_sdl_warning(p, &fallback_loc,
                         "pattern '%s' is not supported: using the average colour of its colour map (%.3g %.3g %.3g)",
                         fallback, pg->color[0], pg->color[1], pg->color[2]);
    }
    if ((pg->kind == PIG_GRADIENT) && pg->map.count == 0) {
        /* POV-Ray's default map for a pattern without one: black to white is the plain ramp */
        pg->map.count = 2;
        pg->map.e[0] = (pov_map_entry){0.0, {0, 0, 0, 0, 0}};
        pg->map.e[1] = (pov_map_entry){1.0, {1, 1, 1, 0, 0}};
    }
    return VBNL_OK;
}

/* ---- finish -------------------------------------------------------------------------------- */

/* An optional float after a flag keyword (`metallic [amount]`, `fresnel [on]`): a value starts
 * unless the next token ends the block or is another finish / reflection keyword. */
static int optional_value_follows(const vbnl_sdl_token *n)
{
    static const char *const kws[] = {
        "ambient", "diffuse", "specular", "emission", "roughness", "phong", "phong_size", "brilliance",
        "crand", "reflection_exponent", "metallic", "reflection", "irid", "subsurface", "conserve_energy",
        "fresnel", "falloff", "exponent", "color", "colour", "rgb", "rgbf", "rgbt", "rgbft", "srgb",
        "srgbf", "srgbt", "srgbft", "albedo", NULL};
    if (n->kind == VBNL_SDL_TOK_PUNCT)
        return n->op == '(' || n->op == '-' || n->op == '+';
    if (n->kind == VBNL_SDL_TOK_NUMBER)
        return 1;
    if (n->kind != VBNL_SDL_TOK_IDENT)
        return 0;
    for (int i = 0; kws[i]; ++i)
        if (is_kw(n, kws[i]))
            return 0;
    return 1;
}

static vbnl_result parse_color_or_float(pov_ctx *c, double out[3])
{
    double col[5];
    if (vbnl_sdl_parse_color(c->parser, col) != VBNL_OK)
        return VBNL_ERR_PARSE;
    out[0] = col[0];
    out[1] = col[1];
    out[2] = col[2];
    return VBNL_OK;
}

static vbnl_result parse_finish_body(pov_ctx *c, pov_finish *f)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'finish'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    int taken_f = take_ident(c, &type_finish, f, sizeof *f);
    if (taken_f < 0)
        return VBNL_ERR_PARSE;
    for (;;) {
        t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        double v, col[3];
        if (is_kw(t, "ambient")) {
            vbnl_sdl_next(p);
            if (parse_color_or_float(c, col) != VBNL_OK)
                return VBNL_ERR_PARSE; /* ignored under global illumination */
        } else if (is_kw(t, "diffuse") || is_kw(t, "specular")) {
            int diff = is_kw(t, "diffuse");
            vbnl_sdl_next(p);
            if (is_kw(vbnl_sdl_peek(p), "albedo"))
                vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (diff && vbnl_sdl_accept(p, ',')) { /* diffuse front, back */
                double back;
                if (vbnl_sdl_parse_float(p, &back) != VBNL_OK)
                    return VBNL_ERR_PARSE;
            }
            if (!(v >= 0.0))
                return vbnl_sdl_error(p, &loc, "'%s' must be >= 0", diff ? "diffuse" : "specular");
            *(diff ? &f->diffuse : &f->specular) = v;
        } else if (is_kw(t, "emission")) {
            vbnl_sdl_next(p);
            if (parse_color_or_float(c, f->emission) != VBNL_OK)
                return VBNL_ERR_PARSE;
        } else if (is_kw(t, "roughness") || is_kw(t, "phong") || is_kw(t, "phong_size") ||
                   is_kw(t, "brilliance") || is_kw(t, "crand") || is_kw(t, "reflection_exponent") ||
                   is_kw(t, "metallic")) {
            const char *kw = t->text;
            vbnl_sdl_next(p);
            int is_metal = !strcmp(kw, "metallic");
            const vbnl_sdl_token *n = vbnl_sdl_peek(p);
            int has_value = !is_metal || optional_value_follows(n);
            v = 1.0;
            if (has_value && vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (!strcmp(kw, "roughness")) {
                if (!(v > 0.0))
                    return vbnl_sdl_error(p, &loc, "roughness must be > 0");
                f->roughness = v;
            } else if (!strcmp(kw, "phong")) {
                if (vbnl_sdl_peek(p)->kind == VBNL_SDL_TOK_IDENT && is_kw(vbnl_sdl_peek(p), "albedo"))
                    vbnl_sdl_next(p);
                f->phong = v;
            } else if (!strcmp(kw, "phong_size")) {
                if (!(v >= 0.0))
                    return vbnl_sdl_error(p, &loc, "phong_size must be >= 0");
                f->phong_size = v;
            } else if (is_metal) {
                f->metallic = v > 0.0;
            } else if (!strcmp(kw, "brilliance") && v != 1.0) {
                vbnl_sdl_warning(p, &loc, "'brilliance' is ignored (the diffuse lobe is Lambertian)");
            }
        } else if (is_kw(t, "reflection")) {
            vbnl_sdl_next(p);
            const vbnl_sdl_token *n = vbnl_sdl_peek(p);
            if (n->kind == VBNL_SDL_TOK_PUNCT && n->op == '{') {
                vbnl_sdl_next(p);
                int have = 0;
                for (;;) {
                    n = vbnl_sdl_peek(p);
                    vbnl_sdl_loc l2 = n->loc;
                    if (n->kind == VBNL_SDL_TOK_PUNCT && n->op == '}') {
                        vbnl_sdl_next(p);
                        break;
                    }
                    if (n->kind == VBNL_SDL_TOK_EOF)
                        return vbnl_sdl_error(p, &l2, "unexpected end of file in reflection");
                    if (is_kw(n, "metallic")) {
                        vbnl_sdl_next(p);
                        f->metallic = 1;
                        if (optional_value_follows(vbnl_sdl_peek(p)) && vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                            return VBNL_ERR_PARSE;
                    } else if (is_kw(n, "fresnel") || is_kw(n, "falloff") || is_kw(n, "exponent")) {
                        const char *kw = n->text;
                        vbnl_sdl_next(p);
                        if ((strcmp(kw, "fresnel") || optional_value_follows(vbnl_sdl_peek(p))) &&
                            vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                            return VBNL_ERR_PARSE;
                        vbnl_sdl_warning(p, &l2, "reflection '%s' is ignored (the lobe's own Fresnel term applies)", kw);
                    } else {
                        /* [min colour,] max colour: the strongest is used */
                        if (parse_color_or_float(c, col) != VBNL_OK)
                            return VBNL_ERR_PARSE;
                        vbnl_sdl_accept(p, ',');
                        if (!have || col[0] + col[1] + col[2] > f->reflection[0] + f->reflection[1] + f->reflection[2])
                            memcpy(f->reflection, col, sizeof(col));
                        have = 1;
                    }
                }
            } else {
                if (parse_color_or_float(c, f->reflection) != VBNL_OK)
                    return VBNL_ERR_PARSE;
            }
        } else if (is_kw(t, "irid") || is_kw(t, "subsurface")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_skip_block(p) != VBNL_OK)
                return VBNL_ERR_PARSE;
            vbnl_sdl_warning(p, &loc, "finish '%s' is not supported: ignored", t->text);
        } else if (is_kw(t, "conserve_energy")) {
            vbnl_sdl_next(p);
        } else {
            return vbnl_sdl_error(p, &loc, "unexpected '%s' in finish", t->text);
        }
    }
}

/* ---- normal, interior ------------------------------------------------------------------ */

static vbnl_result parse_normal(pov_ctx *c, const vbnl_sdl_loc *loc)
{
    if (vbnl_sdl_skip_block(c->parser) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!c->tex->normal_warned) {
        c->tex->normal_warned = 1;
        vbnl_sdl_warning(c->parser, loc, "'normal' (bump perturbation) is not rendered: ignored (reported once)");
    }
    return VBNL_OK;
}

static vbnl_result parse_interior_body(pov_ctx *c, pov_interior *in)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'interior'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    int taken_in = take_ident(c, &type_interior, in, sizeof *in);
    if (taken_in < 0)
        return VBNL_ERR_PARSE;
    for (;;) {
        t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        double v;
        if (is_kw(t, "ior")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (!(v >= 1.0 && v < 10.0))
                return vbnl_sdl_error(p, &loc, "ior must lie in [1, 10) (got %g)", v);
            in->ior = v;
        } else if (is_kw(t, "caustics") || is_kw(t, "dispersion") || is_kw(t, "dispersion_samples") ||
                   is_kw(t, "fade_distance") || is_kw(t, "fade_power")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
                return VBNL_ERR_PARSE;
        } else if (is_kw(t, "fade_color") || is_kw(t, "fade_colour")) {
            vbnl_sdl_next(p);
            double col[3];
            if (parse_color_or_float(c, col) != VBNL_OK)
                return VBNL_ERR_PARSE;
            vbnl_sdl_warning(p, &loc, "interior fade (absorption) is not supported: ignored");
        } else if (is_kw(t, "media")) {
            vbnl_sdl_next(p);
            if (vbnl_sdl_skip_block(p) != VBNL_OK)
                return VBNL_ERR_PARSE;
            vbnl_sdl_warning(p, &loc, "'media' is not supported: ignored");
        } else {
            return vbnl_sdl_error(p, &loc, "unexpected '%s' in interior", t->text);
        }
    }
}

/* ---- vbnl_bsdf extension ------------------------------------------------------------------- */

static vbnl_result parse_ext_bsdf(pov_ctx *c, pov_ext_bsdf *e)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'vbnl_bsdf'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_material_desc_init(&e->desc);
    e->set = 1;
    e->has_color = 0;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    static const char *const types[] = {"lambert", "conductor", "plastic", "mirror", "dielectric"};
    int found = -1;
    for (int i = 0; i < 5; ++i)
        if (is_kw(t, types[i]))
            found = i;
    if (found < 0)
        return vbnl_sdl_error(p, &t->loc,
                              "vbnl_bsdf must start with lambert, conductor, plastic, mirror or dielectric (found '%s')",
                              t->text);
    vbnl_sdl_next(p);
    e->desc.type = (vbnl_material_type)found;
    for (;;) {
        t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        double v[3];
        if (is_kw(t, "color") || is_kw(t, "colour")) {
            if (parse_color_or_float(c, v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            for (int k = 0; k < 3; ++k) {
                if (!(v[k] >= 0.0 && v[k] <= 1.0))
                    return vbnl_sdl_error(p, &loc, "vbnl_bsdf color components must lie in [0, 1]");
                e->desc.base_color[k] = (float)v[k];
            }
            e->has_color = 1;
        } else if (is_kw(t, "alpha") || is_kw(t, "ior")) {
            int alpha = is_kw(t, "alpha");
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (alpha && !(v[0] >= 0.001 && v[0] <= 1.0))
                return vbnl_sdl_error(p, &loc, "vbnl_bsdf alpha must lie in [0.001, 1] (got %g)", v[0]);
            if (!alpha && !(v[0] > 1.0 && v[0] < 10.0))
                return vbnl_sdl_error(p, &loc, "vbnl_bsdf ior must lie in (1, 10) (got %g)", v[0]);
            *(alpha ? &e->desc.alpha : &e->desc.ior) = (float)v[0];
        } else if (is_kw(t, "eta") || is_kw(t, "k") || is_kw(t, "emission")) {
            const char *kw = t->text;
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_vector(p, 3, v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            float *dst = !strcmp(kw, "eta") ? e->desc.eta : !strcmp(kw, "k") ? e->desc.k : e->desc.emission;
            for (int k = 0; k < 3; ++k) {
                if (!(v[k] >= 0.0) || !isfinite(v[k]) || (!strcmp(kw, "eta") && !(v[k] > 0.0)))
                    return vbnl_sdl_error(p, &loc, "vbnl_bsdf %s components must be %s", kw,
                                          strcmp(kw, "eta") ? ">= 0" : "> 0");
                dst[k] = (float)v[k];
            }
            if (strcmp(kw, "emission"))
                e->desc.conductor_use_ior = 1;
        } else if (is_kw(t, "two_sided")) {
            vbnl_sdl_next(p);
            e->desc.two_sided = 1;
        } else {
            return vbnl_sdl_error(p, &loc, "unexpected '%s' in vbnl_bsdf (color alpha ior eta k emission two_sided)",
                                  t->text);
        }
    }
}

/* ---- texture, material --------------------------------------------------------------------- */

static vbnl_result parse_texture_item(pov_ctx *c, pov_texture *tx, int *handled);
static vbnl_result parse_texture_body(pov_ctx *c, pov_texture *tx);

static int is_pattern_keyword(const vbnl_sdl_token *t)
{
    if (is_kw(t, "checker") || is_kw(t, "brick") || is_kw(t, "gradient"))
        return 1;
    for (int i = 0; fallback_patterns[i]; ++i)
        if (is_kw(t, fallback_patterns[i]))
            return 1;
    return 0;
}

/* One texture_map entry: [value texture-identifier | texture { } | pigment/finish/normal items]. */
static vbnl_result parse_texture_map_entry(pov_ctx *c, pov_texture *out)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '[', "to start a texture_map entry") != VBNL_OK)
        return VBNL_ERR_PARSE;
    double v;
    if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (vbnl_sdl_accept(p, ',')) {
        const vbnl_sdl_token *n = vbnl_sdl_peek(p);
        const vbnl_sdl_value *nv = n->kind == VBNL_SDL_TOK_IDENT ? vbnl_sdl_lookup(p, n->text) : NULL;
        if ((n->kind == VBNL_SDL_TOK_NUMBER || (nv && nv->kind == VBNL_SDL_FLOAT)) &&
            vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return VBNL_ERR_PARSE;
    }
    texture_init(out);
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == ']') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        if (t->kind == VBNL_SDL_TOK_EOF)
            return vbnl_sdl_error(p, &loc, "unexpected end of file in texture_map");
        int taken_out = take_ident(c, &type_texture, out, sizeof *out);
        if (taken_out < 0)
            return VBNL_ERR_PARSE;
        if (taken_out)
            continue;
        if (is_kw(t, "texture")) {
            vbnl_sdl_next(p);
            if (parse_texture_body(c, out) != VBNL_OK)
                return VBNL_ERR_PARSE;
            continue;
        }
        int handled = 0;
        if (parse_texture_item(c, out, &handled) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!handled)
            return vbnl_sdl_error(p, &loc, "unexpected '%s' in a texture_map entry", t->text);
    }
}

/* Texture patterns (`texture { checker texture {A} texture {B} }`, `texture { gradient y
 * texture_map { ... } }`): parsed in full; the first texture of the list or map is used, with a
 * warning, as the scene's texture layers are not blended per point here. Positioned after the
 * pattern keyword. */
static vbnl_result parse_texture_pattern(pov_ctx *c, pov_texture *tx, const char *name, const vbnl_sdl_loc *ploc)
{
    vbnl_sdl_parser *p = c->parser;
    pov_pigment *scratch = malloc(sizeof(*scratch));
    pov_texture *entry = malloc(sizeof(*entry));
    vbnl_result r = scratch && entry ? VBNL_OK : vbnl_sdl_error(p, ploc, "out of memory");
    int have = 0;
    double xf[16];
    m_identity(xf);
    if (r == VBNL_OK) {
        pigment_init(scratch);
        r = parse_pattern_args(c, NULL, name);
    }
    while (r == VBNL_OK) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}')
            break; /* the caller closes the texture */
        if (t->kind == VBNL_SDL_TOK_EOF) {
            r = vbnl_sdl_error(p, &loc, "unexpected end of file in texture");
            break;
        }
        if (is_kw(t, "texture")) {
            vbnl_sdl_next(p);
            texture_init(entry);
            if ((r = parse_texture_body(c, entry)) == VBNL_OK && !have) {
                *tx = *entry;
                have = 1;
            }
            vbnl_sdl_accept(p, ',');
            continue;
        }
        if (is_kw(t, "texture_map")) {
            vbnl_sdl_next(p);
            if ((r = vbnl_sdl_expect(p, '{', "after 'texture_map'")) != VBNL_OK)
                break;
            for (;;) {
                const vbnl_sdl_token *n = vbnl_sdl_peek(p);
                if (n->kind == VBNL_SDL_TOK_PUNCT && n->op == '}') {
                    vbnl_sdl_next(p);
                    break;
                }
                if ((r = parse_texture_map_entry(c, entry)) != VBNL_OK)
                    break;
                if (!have) {
                    *tx = *entry;
                    have = 1;
                }
            }
            continue;
        }
        if (is_kw(t, "brick_size") || is_kw(t, "mortar")) {
            int vec = is_kw(t, "brick_size");
            vbnl_sdl_next(p);
            double v[3];
            r = vec ? vbnl_sdl_parse_vector(p, 3, v) : vbnl_sdl_parse_float(p, v);
            continue;
        }
        double m[16];
        int tr = parse_transform_item(c, m);
        if (tr < 0) {
            r = VBNL_ERR_PARSE;
            break;
        }
        if (tr > 0) {
            m_mul(m, xf, xf);
            continue;
        }
        int pm = parse_pattern_modifier(c, scratch);
        if (pm < 0) {
            r = VBNL_ERR_PARSE;
            break;
        }
        if (pm == 0)
            r = vbnl_sdl_error(p, &loc, "unexpected '%s' in a patterned texture", t->text);
    }
    if (r == VBNL_OK) {
        m_mul(xf, tx->pig.xf, tx->pig.xf);
        vbnl_sdl_warning(p, ploc,
                         have ? "texture pattern '%s' is not supported: its first texture is used everywhere"
                              : "texture pattern '%s' is not supported and lists no texture: ignored",
                         name);
    }
    free(scratch);
    free(entry);
    return r;
}

static vbnl_result parse_texture_body(pov_ctx *c, pov_texture *tx)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'texture'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    int taken_tx = take_ident(c, &type_texture, tx, sizeof *tx);
    if (taken_tx < 0)
        return VBNL_ERR_PARSE;
    for (;;) {
        t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        if (t->kind == VBNL_SDL_TOK_EOF)
            return vbnl_sdl_error(p, &loc, "unexpected end of file in texture");
        int handled = 0;
        if (parse_texture_item(c, tx, &handled) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (handled)
            continue;
        double m[16];
        int tr = parse_transform_item(c, m);
        if (tr < 0)
            return VBNL_ERR_PARSE;
        if (tr > 0) {
            m_mul(m, tx->pig.xf, tx->pig.xf);
            continue;
        }
        if (is_pattern_keyword(t)) {
            const char *name = t->text;
            vbnl_sdl_next(p);
            if (c->tex->depth >= 64)
                return vbnl_sdl_error(p, &loc, "textures nested more than 64 deep");
            c->tex->depth++;
            vbnl_result r = parse_texture_pattern(c, tx, name, &loc);
            c->tex->depth--;
            if (r != VBNL_OK)
                return r;
            continue;
        }
        if (is_kw(t, "material_map") || is_kw(t, "tiles"))
            return vbnl_sdl_error(p, &loc, "'%s' is not supported", t->text);
        return vbnl_sdl_error(p, &loc, "unexpected '%s' in texture", t->text);
    }
}

/* pigment / finish / normal / vbnl_bsdf / uv_mapping inside a texture (or directly in an object). */
static vbnl_result parse_texture_item(pov_ctx *c, pov_texture *tx, int *handled)
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    vbnl_sdl_loc loc = t->loc;
    *handled = 1;
    if (is_kw(t, "pigment")) {
        vbnl_sdl_next(p);
        return parse_pigment_body(c, &tx->pig);
    }
    if (is_kw(t, "finish")) {
        vbnl_sdl_next(p);
        return parse_finish_body(c, &tx->fin);
    }
    if (is_kw(t, "normal")) {
        vbnl_sdl_next(p);
        return parse_normal(c, &loc);
    }
    if (is_kw(t, "vbnl_bsdf")) {
        vbnl_sdl_next(p);
        return parse_ext_bsdf(c, &tx->ext);
    }
    if (is_kw(t, "uv_mapping")) {
        vbnl_sdl_next(p);
        tx->pig.uv_mapping = 1;
        return VBNL_OK;
    }
    *handled = 0;
    return VBNL_OK;
}

static vbnl_result parse_material_body(pov_ctx *c, pov_appearance *a)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'material'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    int taken_a = take_ident(c, &type_material, a, sizeof *a);
    if (taken_a < 0)
        return VBNL_ERR_PARSE;
    for (;;) {
        t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return VBNL_OK;
        }
        if (is_kw(t, "texture")) {
            vbnl_sdl_next(p);
            if (parse_texture_body(c, &a->tex) != VBNL_OK)
                return VBNL_ERR_PARSE;
            continue;
        }
        if (is_kw(t, "interior")) {
            vbnl_sdl_next(p);
            if (parse_interior_body(c, &a->interior) != VBNL_OK)
                return VBNL_ERR_PARSE;
            continue;
        }
        if (is_kw(t, "vbnl_bsdf")) {
            vbnl_sdl_next(p);
            if (parse_ext_bsdf(c, &a->tex.ext) != VBNL_OK)
                return VBNL_ERR_PARSE;
            continue;
        }
        double m[16];
        int tr = parse_transform_item(c, m);
        if (tr < 0)
            return VBNL_ERR_PARSE;
        if (tr > 0) {
            pov_appearance_transform(a, m);
            continue;
        }
        return vbnl_sdl_error(p, &loc, "unexpected '%s' in material", t->text);
    }
}

/* ---- the interface ------------------------------------------------------------------------- */

vbnl_result pov_texture_state_create(pov_ctx *c, vbnl_error *err)
{
    c->tex = calloc(1, sizeof(*c->tex));
    if (!c->tex)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    appearance_init(&c->tex->deflt);
    return VBNL_OK;
}

void pov_texture_state_destroy(pov_ctx *c)
{
    if (!c || !c->tex)
        return;
    for (uint32_t i = 0; i < c->tex->image_count; ++i)
        free(c->tex->images[i].texels);
    free(c->tex->images);
    for (uint32_t i = 0; i < c->tex->cache_count; ++i)
        free(c->tex->cache[i]);
    free(c->tex->cache);
    free(c->tex);
    c->tex = NULL;
}

int pov_appearance_is_modifier(const vbnl_sdl_token *tok)
{
    static const char *const kws[] = {"texture", "pigment", "finish", "normal", "interior",
                                      "material", "interior_texture", "vbnl_bsdf", "uv_mapping", NULL};
    for (int i = 0; kws[i]; ++i)
        if (is_kw(tok, kws[i]))
            return 1;
    return 0;
}

vbnl_result pov_appearance_parse_modifier(pov_ctx *c, pov_appearance **app)
{
    vbnl_sdl_parser *p = c->parser;
    if (!*app) {
        *app = pov_appearance_default(c);
        if (!*app)
            return vbnl_sdl_error(p, NULL, "out of memory");
    }
    pov_appearance *a = *app;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    vbnl_sdl_loc loc = t->loc;
    if (!a->loc.file)
        a->loc = loc;
    if (is_kw(t, "texture")) {
        vbnl_sdl_next(p);
        if (!a->own_texture) {
            if (parse_texture_body(c, &a->tex) != VBNL_OK)
                return VBNL_ERR_PARSE;
            a->own_texture = 1;
            return VBNL_OK;
        }
        if (a->own_texture == 1)
            vbnl_sdl_warning(p, &loc, "layered textures are rendered as one layer (the top opaque one)");
        a->own_texture = 2;
        pov_texture layer = c->tex->deflt.tex;
        if (parse_texture_body(c, &layer) != VBNL_OK)
            return VBNL_ERR_PARSE;
        texture_put_layer(&a->tex, &layer);
        return VBNL_OK;
    }
    if (is_kw(t, "interior")) {
        vbnl_sdl_next(p);
        return parse_interior_body(c, &a->interior);
    }
    if (is_kw(t, "material")) {
        vbnl_sdl_next(p);
        return parse_material_body(c, a);
    }
    if (is_kw(t, "interior_texture")) {
        vbnl_sdl_next(p);
        vbnl_sdl_warning(p, &loc, "'interior_texture' is not supported: ignored");
        return vbnl_sdl_skip_block(p);
    }
    int handled = 0;
    if (parse_texture_item(c, &a->tex, &handled) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!handled)
        return vbnl_sdl_error(p, &loc, "'%s' is not an appearance modifier", t->text);
    return VBNL_OK;
}

static int appearance_rvalue(pov_ctx *c, const vbnl_sdl_token *tok, vbnl_sdl_value *out)
{
    vbnl_sdl_parser *p = c->parser;
    void *obj = NULL;
    const vbnl_sdl_opaque_type *type = NULL;
    int tag = 0;
    vbnl_result r = VBNL_OK;
    if (is_kw(tok, "texture")) {
        pov_texture *t = malloc(sizeof(*t));
        if (t) {
            texture_init(t);
            vbnl_sdl_next(p);
            r = parse_texture_body(c, t);
        }
        obj = t, type = &type_texture, tag = TAG_TEXTURE;
    } else if (is_kw(tok, "pigment")) {
        pov_pigment *g = malloc(sizeof(*g));
        if (g) {
            pigment_init(g);
            vbnl_sdl_next(p);
            r = parse_pigment_body(c, g);
        }
        obj = g, type = &type_pigment, tag = TAG_PIGMENT;
    } else if (is_kw(tok, "finish")) {
        pov_finish *f = malloc(sizeof(*f));
        if (f) {
            finish_init(f);
            vbnl_sdl_next(p);
            r = parse_finish_body(c, f);
        }
        obj = f, type = &type_finish, tag = TAG_FINISH;
    } else if (is_kw(tok, "normal")) {
        pov_normal *n = calloc(1, sizeof(*n));
        vbnl_sdl_loc loc = tok->loc;
        if (n) {
            vbnl_sdl_next(p);
            r = parse_normal(c, &loc);
        }
        obj = n, type = &type_normal, tag = TAG_NORMAL;
    } else if (is_kw(tok, "interior")) {
        pov_interior *in = malloc(sizeof(*in));
        if (in) {
            in->ior = 1.0;
            vbnl_sdl_next(p);
            r = parse_interior_body(c, in);
        }
        obj = in, type = &type_interior, tag = TAG_INTERIOR;
    } else if (is_kw(tok, "material")) {
        pov_appearance *a = malloc(sizeof(*a));
        if (a) {
            appearance_init(a);
            a->loc = tok->loc;
            vbnl_sdl_next(p);
            r = parse_material_body(c, a);
        }
        obj = a, type = &type_material, tag = TAG_MATERIAL;
    } else if (is_kw(tok, "color_map") || is_kw(tok, "colour_map")) {
        pov_color_map *m = calloc(1, sizeof(*m));
        if (m) {
            vbnl_sdl_next(p);
            r = parse_color_map_body(c, m);
        }
        obj = m, type = &type_color_map, tag = TAG_COLOR_MAP;
    } else if (is_kw(tok, "pigment_map") || is_kw(tok, "normal_map") || is_kw(tok, "texture_map") ||
               is_kw(tok, "slope_map") || is_kw(tok, "density") || is_kw(tok, "media") ||
               is_kw(tok, "interior_texture")) {
        /* parsed structurally: not rendered (the modifiers that use them warn) */
        return 0;
    } else {
        return 0;
    }
    if (!obj) {
        vbnl_sdl_error(p, &tok->loc, "out of memory");
        return -1;
    }
    if (r != VBNL_OK) {
        free(obj);
        return -1;
    }
    vbnl_sdl_value_object(out, obj, type, tag);
    return 1;
}

/* A declared texture (pigment, finish, ...) warns about what it cannot render where the scene
 * uses it, not where it is declared: POV-Ray's standard includes declare many. */
int pov_appearance_rvalue(pov_ctx *c, const vbnl_sdl_token *tok, vbnl_sdl_value *out)
{
    int group = vbnl_sdl_defer_begin(c->parser);
    int r = appearance_rvalue(c, tok, out);
    vbnl_sdl_defer_end(c->parser, group);
    if (r > 0)
        out->u.obj.deferred = group;
    return r;
}

void pov_appearance_average_color(pov_ctx *c, const pov_appearance *a, double rgb[3])
{
    const pov_pigment *g = &a->tex.pig;
    double col[5] = {0, 0, 0, 0, 0};
    if (g->kind == PIG_SOLID) {
        memcpy(col, g->color, sizeof col);
    } else if (g->kind == PIG_IMAGE) {
        const image_entry *im = g->image >= 0 && (uint32_t)g->image < c->tex->image_count ? &c->tex->images[g->image] : NULL;
        size_t n = im ? (size_t)im->width * im->height : 0;
        for (size_t i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k)
                col[k] += im->texels[3 * i + k] / (double)n;
    } else {
        color_map_average(&g->map, col);
    }
    for (int k = 0; k < 3; ++k)
        rgb[k] = col[k] > 0 ? col[k] : 0;
}

int pov_appearance_default_block(pov_ctx *c)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after '#default'") != VBNL_OK)
        return -1;
    pov_appearance *a = &c->tex->deflt;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        vbnl_sdl_loc loc = t->loc;
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            return 1;
        }
        if (is_kw(t, "texture")) {
            vbnl_sdl_next(p);
            if (parse_texture_body(c, &a->tex) != VBNL_OK)
                return -1;
            continue;
        }
        int handled = 0;
        if (parse_texture_item(c, &a->tex, &handled) != VBNL_OK)
            return -1;
        if (!handled) {
            vbnl_sdl_error(p, &loc, "unexpected '%s' in #default (texture pigment finish normal)", t->text);
            return -1;
        }
    }
}

pov_appearance *pov_appearance_copy(const pov_appearance *a)
{
    if (!a)
        return NULL;
    pov_appearance *b = malloc(sizeof(*b));
    if (b)
        *b = *a;
    return b;
}

void pov_appearance_free(pov_appearance *a) { free(a); }

pov_appearance *pov_appearance_default(pov_ctx *c)
{
    pov_appearance *a = pov_appearance_copy(&c->tex->deflt);
    if (a) {
        memset(&a->loc, 0, sizeof(a->loc));
        a->own_texture = 0;
    }
    return a;
}

void pov_appearance_transform(pov_appearance *a, const double m[16])
{
    if (a)
        m_mul(m, a->tex.pig.xf, a->tex.pig.xf);
}

int pov_appearance_is_emissive(const pov_appearance *a)
{
    if (!a)
        return 0;
    if (a->tex.ext.set)
        return a->tex.ext.desc.emission[0] > 0 || a->tex.ext.desc.emission[1] > 0 || a->tex.ext.desc.emission[2] > 0;
    const pov_pigment *g = &a->tex.pig;
    double col[5];
    if (g->kind == PIG_SOLID)
        memcpy(col, g->color, sizeof(col));
    else
        color_map_average(&g->map, col);
    for (int k = 0; k < 3; ++k)
        if (a->tex.fin.emission[k] * (g->kind == PIG_IMAGE ? 1.0 : col[k]) > 0.0)
            return 1;
    return 0;
}

/* ---- mapping onto the core ---------------------------------------------------------------- */

/* Warnings found while mapping an appearance: reported only when it makes a new core material,
 * so objects sharing an appearance warn once. */
typedef struct map_notes {
    const char *clamped_what;
    double clamped_value;
    int no_ior;
} map_notes;

static float clamp_albedo(map_notes *n, double v, const char *what)
{
    if (v > 1.0 || v < 0.0) {
        if (!n->clamped_what) {
            n->clamped_what = what;
            n->clamped_value = v;
        }
        v = v > 1.0 ? 1.0 : 0.0;
    }
    return (float)v;
}

static void report_notes(pov_ctx *c, const pov_appearance *a, const map_notes *n)
{
    const vbnl_sdl_loc *loc = a->loc.file ? &a->loc : NULL;
    if (n->clamped_what)
        vbnl_sdl_warning(c->parser, loc, "%s %.3g exceeds the energy-conserving range [0, 1]: clamped",
                         n->clamped_what, n->clamped_value);
    if (n->no_ior)
        vbnl_sdl_warning(c->parser, loc,
                         "transparent pigment without interior { ior > 1 }: rendered as glass of ior 1.5");
}

/* Blinn-Phong exponent n to GGX alpha (Walter et al. 2007): alpha = sqrt(2 / (n + 2)). */
static float alpha_from_exponent(double n)
{
    double a = sqrt(2.0 / (n + 2.0));
    return (float)(a < 0.001 ? 0.001 : (a > 1.0 ? 1.0 : a));
}

vbnl_result pov_appearance_material(pov_ctx *c, const pov_appearance *a, const double world_from_pov[16],
                                    uint32_t *material, vbnl_error *err)
{
    pov_texture_state *s = c->tex;
    pov_appearance tmp;
    if (!a) {
        tmp = s->deflt;
        a = &tmp;
    }
    const pov_texture *tx = &a->tex;
    const pov_pigment *g = &tx->pig;
    const pov_finish *f = &tx->fin;
    map_notes notes = {NULL, 0.0, 0};

    /* the pigment's representative colour (solid colour, or 1 where a texture supplies it) */
    double pc[5] = {1, 1, 1, 0, 0};
    int textured = g->kind != PIG_SOLID;
    if (!textured)
        memcpy(pc, g->color, sizeof(pc));
    double filter = textured ? 0.0 : pc[3], transmit = textured ? 0.0 : pc[4];

    vbnl_material_desc md;
    vbnl_material_desc_init(&md);
    double scale[3] = {1, 1, 1}; /* multiplies the pigment colour into base_color */
    if (tx->ext.set) {
        md = tx->ext.desc;
        if (!tx->ext.has_color) {
            scale[0] = scale[1] = scale[2] = 1.0;
        } else {
            textured = 0; /* an explicit colour replaces the pigment */
            for (int k = 0; k < 3; ++k)
                pc[k] = md.base_color[k];
        }
    } else {
        double refl = (f->reflection[0] + f->reflection[1] + f->reflection[2]) / 3.0;
        if (filter + transmit > 0.0) {
            md.type = VBNL_MATERIAL_DIELECTRIC;
            md.ior = (float)(a->interior.ior > 1.0 ? a->interior.ior : 1.5);
            notes.no_ior = !(a->interior.ior > 1.0);
            /* filter tints by the colour, transmit passes light unchanged */
            double w = filter / (filter + transmit);
            for (int k = 0; k < 3; ++k)
                pc[k] = w * pc[k] + (1.0 - w);
        } else if (f->metallic && (refl > 0.0 || f->specular > 0.0 || f->phong > 0.0)) {
            md.type = VBNL_MATERIAL_CONDUCTOR;
            md.alpha = f->specular > 0.0   ? alpha_from_exponent(1.0 / f->roughness)
                       : f->phong > 0.0    ? alpha_from_exponent(4.0 * f->phong_size)
                                           : 0.001f;
        } else if (refl > 0.0 && f->diffuse <= 0.0 && f->specular <= 0.0 && f->phong <= 0.0) {
            md.type = VBNL_MATERIAL_MIRROR;
            for (int k = 0; k < 3; ++k)
                scale[k] = f->reflection[k];
            textured = 0;
            pc[0] = pc[1] = pc[2] = 1.0;
        } else if (refl > 0.0 || f->specular > 0.0 || f->phong > 0.0) {
            md.type = VBNL_MATERIAL_PLASTIC;
            md.alpha = f->specular > 0.0 ? alpha_from_exponent(1.0 / f->roughness)
                       : f->phong > 0.0  ? alpha_from_exponent(4.0 * f->phong_size)
                                         : 0.001f;
            md.ior = (float)(a->interior.ior > 1.0 ? a->interior.ior : 1.5);
            for (int k = 0; k < 3; ++k)
                scale[k] = f->diffuse;
        } else {
            md.type = VBNL_MATERIAL_LAMBERT;
            for (int k = 0; k < 3; ++k)
                scale[k] = f->diffuse;
        }
        for (int k = 0; k < 3; ++k)
            md.emission[k] = (float)(f->emission[k] * (textured ? 1.0 : pc[k]));
        md.two_sided = 1; /* POV-Ray's emission glows on both sides of a surface */
        if (textured && (f->emission[0] > 0 || f->emission[1] > 0 || f->emission[2] > 0)) {
            double avg[5];
            color_map_average(&g->map, avg);
            for (int k = 0; k < 3; ++k)
                md.emission[k] = (float)(f->emission[k] * (g->kind == PIG_IMAGE ? 1.0 : avg[k]));
        }
    }
    for (int k = 0; k < 3; ++k) {
        if (!(md.emission[k] >= 0.0f) || !isfinite(md.emission[k]))
            md.emission[k] = 0.0f;
        md.base_color[k] = clamp_albedo(&notes, scale[k] * (textured ? 1.0 : pc[k]), "albedo");
    }

    /* the texture */
    vbnl_texture_desc td;
    vbnl_texture_desc_init(&td);
    vbnl_color_map_entry map[MAP_MAX];
    int image = -1;
    if (textured) {
        double pov_from_world[16], world_from_pattern[16], pattern_from_world[16];
        if (!m_inverse(world_from_pov, pov_from_world))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "world_from_pov is singular");
        m_mul(world_from_pov, g->xf, world_from_pattern);
        if (!m_inverse(world_from_pattern, pattern_from_world))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "a pigment transform is singular");
        for (int i = 0; i < 16; ++i)
            td.pattern_from_world[i] = (float)pattern_from_world[i];
        switch (g->kind) {
        case PIG_CHECKER: td.kind = VBNL_TEXTURE_CHECKER; break;
        case PIG_GRADIENT: td.kind = VBNL_TEXTURE_GRADIENT; break;
        case PIG_BRICK: td.kind = VBNL_TEXTURE_BRICK; break;
        default: td.kind = VBNL_TEXTURE_IMAGE; break;
        }
        for (int k = 0; k < 3; ++k) {
            td.gradient[k] = (float)g->gradient[k];
            td.brick_size[k] = (float)g->brick_size[k];
        }
        td.mortar = (float)g->mortar;
        td.frequency = (float)g->frequency;
        td.phase = (float)g->phase;
        td.wave = (vbnl_texture_wave)g->wave;
        if (g->kind == PIG_IMAGE) {
            const image_entry *im = &s->images[g->image];
            image = g->image;
            td.texels = im->texels;
            td.width = im->width;
            td.height = im->height;
            td.projection = g->uv_mapping ? VBNL_PROJECTION_UV
                            : g->map_type == 1 ? VBNL_PROJECTION_SPHERICAL
                            : g->map_type == 2 ? VBNL_PROJECTION_CYLINDRICAL
                                               : VBNL_PROJECTION_PLANAR;
            td.wrap = g->once ? VBNL_WRAP_CLAMP : VBNL_WRAP_REPEAT;
            td.interpolate = g->interpolate;
        } else {
            td.color_map = map;
            td.color_map_count = g->map.count;
            for (uint32_t i = 0; i < g->map.count; ++i) {
                map[i].value = (float)g->map.e[i].value;
                for (int k = 0; k < 3; ++k)
                    map[i].color[k] = clamp_albedo(&notes, g->map.e[i].color[k], "pigment colour");
            }
        }
    }

    /* the cache: one core material per distinct content */
    cache_entry *ce = calloc(1, sizeof(*ce));
    if (!ce)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    ce->desc = md;
    ce->has_texture = textured;
    ce->tdesc = td;
    if (textured) {
        memcpy(ce->map, map, sizeof(vbnl_color_map_entry) * td.color_map_count);
        ce->tdesc.color_map = NULL;
        ce->tdesc.texels = NULL;
    }
    /* key: the material description, the texture inputs (with the image index in place of texels) */
    unsigned char *k = ce->key;
    memcpy(k, &md, sizeof(md));
    k += sizeof(md);
    if (textured) {
        pov_pigment key_pig;
        memset(&key_pig, 0, sizeof(key_pig));
        key_pig.kind = g->kind;
        memcpy(key_pig.xf, td.pattern_from_world, sizeof(td.pattern_from_world)); /* floats suffice */
        key_pig.map.count = g->map.count;
        for (uint32_t i = 0; i < g->map.count; ++i) {
            key_pig.map.e[i].value = map[i].value;
            for (int q = 0; q < 3; ++q)
                key_pig.map.e[i].color[q] = map[i].color[q];
        }
        memcpy(key_pig.gradient, g->gradient, sizeof(g->gradient));
        memcpy(key_pig.brick_size, g->brick_size, sizeof(g->brick_size));
        key_pig.mortar = g->mortar;
        key_pig.frequency = g->frequency;
        key_pig.phase = g->phase;
        key_pig.wave = g->wave;
        key_pig.image = image;
        key_pig.map_type = (int)td.projection;
        key_pig.once = g->once;
        key_pig.interpolate = g->interpolate;
        memcpy(k, &key_pig, sizeof(key_pig));
    }
    for (uint32_t i = 0; i < s->cache_count; ++i) {
        if (!memcmp(s->cache[i]->key, ce->key, sizeof(ce->key))) {
            *material = s->cache[i]->material;
            free(ce);
            return VBNL_OK;
        }
    }
    report_notes(c, a, &notes);
    if (textured) {
        uint32_t tid;
        vbnl_result r = vbnl_scene_add_texture(c->scene, &td, &tid, err);
        if (r != VBNL_OK) {
            free(ce);
            return r;
        }
        md.base_texture = tid + 1;
        ce->desc.base_texture = tid + 1;
    }
    vbnl_result r = vbnl_scene_add_material(c->scene, &md, &ce->material, err);
    if (r != VBNL_OK) {
        free(ce);
        return r;
    }
    if (s->cache_count == s->cache_cap) {
        uint32_t ncap = s->cache_cap ? 2 * s->cache_cap : 16;
        cache_entry **n = realloc(s->cache, sizeof(*n) * ncap);
        if (!n) {
            free(ce);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        s->cache = n;
        s->cache_cap = ncap;
    }
    s->cache[s->cache_count++] = ce;
    *material = ce->material;
    return VBNL_OK;
}

/* ---- test accessors (pov_texture.h) -------------------------------------------------------- */

static const cache_entry *find_entry(const pov_ctx *c, uint32_t material)
{
    for (uint32_t i = 0; i < c->tex->cache_count; ++i)
        if (c->tex->cache[i]->material == material)
            return c->tex->cache[i];
    return NULL;
}

const vbnl_material_desc *pov_texture_material_desc(const pov_ctx *c, uint32_t material)
{
    const cache_entry *e = find_entry(c, material);
    return e ? &e->desc : NULL;
}

const vbnl_texture_desc *pov_texture_texture_desc(const pov_ctx *c, uint32_t material)
{
    cache_entry *e = (cache_entry *)find_entry(c, material);
    if (!e || !e->has_texture)
        return NULL;
    e->tdesc.color_map = e->tdesc.kind == VBNL_TEXTURE_IMAGE ? NULL : e->map;
    return &e->tdesc;
}

uint32_t pov_texture_material_count(const pov_ctx *c) { return c->tex->cache_count; }
