/* vbnl object layer, texture part: files named by textures: image_map, bump_map, image_pattern
 * and material_map images, and density_file voxel grids (reference manual, "Image Map", "Bump
 * Map", "Image Pattern", "Material Map", "Density File"). A file is read once, found next to the
 * scene file that names it (pov_files.h: never outside that folder) or in POV-Ray's include
 * folders. Images are decoded by the image reader (image_read.c); image_map colours are decoded
 * from the file's encoding to linear values (sRGB unless the file or a `gamma` says otherwise),
 * bump_map and image_pattern data are read as stored (POV-Ray 3.7 does not gamma-adjust them). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "pov_files.h"
#include "pov_image.h"
#include "pov_texture.h"
#include "read_file.h"

/* The path of `name` for the file at loc, or NULL after an error naming `what`. */
static char *locate(pov_ctx *c, const char *name, const vbnl_sdl_loc *loc, const char *what)
{
    if (pov_file_name_escapes(name)) {
        /* allowed only into a folder the user opened to the scene */
        const char *why = NULL;
        char *opened = pov_file_resolve(c->parser, loc, name, POV_FILE_READ, &why);
        if (!opened) {
            vbnl_sdl_error(c->parser, loc, "%s: '%s' is %s", what, name, why ? why : "outside the scene's folder");
            return NULL;
        }
        return opened;
    }
    const char *why = NULL;
    char *near = pov_file_resolve(c->parser, loc, name, POV_FILE_READ, &why);
    if (near)
        return near;
    /* then the standard POV-Ray include folders (POV-Ray's library path, readable by any scene) */
    static const char *const libs[] = {"/usr/share/povray-3.7/include", "/usr/share/povray/include",
                                       "/usr/local/share/povray-3.7/include"};
    for (size_t i = 0; i < sizeof(libs) / sizeof(libs[0]); ++i) {
        char path[POV_PATH_MAX];
        int n = snprintf(path, sizeof(path), "%s/%s", libs[i], name);
        struct stat st; /* found: a special file is refused with the reason where it is read */
        if (n > 0 && (size_t)n < sizeof(path) && stat(path, &st) == 0 && !S_ISDIR(st.st_mode))
            return strdup(path);
    }
    vbnl_sdl_error(c->parser, loc, "%s: '%s' is %s", what, name, why ? why : "a file that does not exist");
    return NULL;
}

/* ---- images ------------------------------------------------------------------------------------- */

/* The file type keywords POV-Ray reads. */
static const char *const file_types[] = {"gif", "tga", "iff", "ppm", "pgm", "png", "jpeg", "tiff", "sys", "exr", "hdr",
                                         "bmp", NULL};

/* Loads an image (once per file and decoding), returns its index in the state's images, -1
 * after an error. `gamma` > 0 overrides the file's decoding (1: the stored values). */
static int load_image(pov_ctx *c, const char *name, const vbnl_sdl_loc *loc, int raw, double gamma, const char *what)
{
    pov_texture_state *s = c->tex;
    char *path = locate(c, name, loc, what);
    if (!path)
        return -1;
    if (strlen(path) >= POV_PATH_MAX) {
        free(path);
        vbnl_sdl_error(c->parser, loc, "image file name too long");
        return -1;
    }
    int mode = gamma > 0.0 ? 2 : raw; /* the decodings differ per use: each is its own image */
    for (uint32_t i = 0; i < s->image_count; ++i)
        if (!strcmp(s->images[i].path, path) && s->images[i].raw == mode) {
            free(path);
            return (int)i;
        }
    pov_image_data img;
    char why[256];
    if (pov_image_read(path, &img, why, sizeof why) != 0) {
        vbnl_sdl_error(c->parser, loc, "%s: cannot read image '%s': %s", what, path, why);
        free(path);
        return -1;
    }
    /* to linear values: the file's transfer function for colours, nothing for data */
    size_t n = (size_t)img.width * img.height * img.channels;
    const int colour_channels = img.channels == 2 || img.channels == 4 ? img.channels - 1 : img.channels;
    for (size_t i = 0; i < n; ++i) {
        if ((int)(i % img.channels) >= colour_channels) {
            img.texels[i] = isfinite(img.texels[i]) ? img.texels[i] : 1.0f; /* alpha stays as stored */
            continue;
        }
        float v = img.texels[i];
        if (!isfinite(v))
            v = 0.0f; /* a float format's NaN or infinity: no light */
        if (img.grey8_png)
            v = (float)lrintf(v * 255.0f) / 255.0f; /* POV-Ray's float(v) / 255 */
        if (gamma > 0.0)
            v = v > 0.0f ? (float)pow(v, gamma) : 0.0f;
        else if (!raw && img.encoding == POV_IMAGE_SRGB)
            v = v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f);
        else if (!raw && img.encoding == POV_IMAGE_GAMMA && img.gamma > 0.0)
            v = v > 0.0f ? (float)pow(v, img.gamma) : 0.0f;
        if (img.grey8_png) {
            /* POV-Ray 3.7 stores a greyscale PNG of up to 8 bits as 8-bit grey after decoding:
             * its grey (0.297 r + 0.589 g + 0.114 b of the decoded value, in single precision)
             * truncated to an integer out of 255 */
            volatile float r = v * 0.297f, gr = v * 0.589f, b = v * 0.114f; /* rounded: no fused multiply-add */
            volatile float g = r + gr + b;
            v = (float)(unsigned char)(g * 255.0f) / 255.0f;
        }
        img.texels[i] = v;
    }
    pov_image *grown = realloc(s->images, sizeof(*grown) * (s->image_count + 1));
    if (!grown) {
        pov_image_data_free(&img);
        free(path);
        vbnl_sdl_error(c->parser, loc, "out of memory reading '%s'", name);
        return -1;
    }
    s->images = grown;
    pov_image *e = &s->images[s->image_count];
    memset(e, 0, sizeof(*e));
    strcpy(e->path, path);
    free(path);
    e->raw = mode;
    e->width = img.width;
    e->height = img.height;
    e->channels = img.channels;
    e->texels = img.texels;
    e->indices = img.indices;
    return (int)s->image_count++;
}

/* [type] "file" [gamma g] [premultiplied b]: the file, decoded for its use, into pat (an IMAGE
 * pattern). */
static vbnl_result image_file(pov_ctx *c, pov_pattern *pat, int raw, const char *what)
{
    vbnl_sdl_parser *p = c->parser;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    for (int i = 0; file_types[i]; ++i)
        if (pov_is_word(t, file_types[i])) {
            vbnl_sdl_next(p);
            break;
        }
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    char *name = NULL;
    if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
        return VBNL_ERR_PARSE;
    double gamma = 0.0;
    for (;;) {
        t = vbnl_sdl_peek(p);
        if (pov_is_word(t, "gamma")) {
            vbnl_sdl_loc gl = t->loc;
            vbnl_sdl_next(p);
            if (pov_is_word(vbnl_sdl_peek(p), "srgb")) {
                vbnl_sdl_next(p);
                gamma = -1.0; /* decode as sRGB */
                raw = 0;
                continue;
            }
            if (vbnl_sdl_parse_float(p, &gamma) != VBNL_OK) {
                free(name);
                return VBNL_ERR_PARSE;
            }
            if (!(gamma > 0.0)) {
                free(name);
                return vbnl_sdl_error(p, &gl, "gamma must be > 0 (got %g)", gamma);
            }
        } else if (pov_is_word(t, "premultiplied")) {
            double b;
            vbnl_sdl_next(p);
            if (vbnl_sdl_parse_float(p, &b) != VBNL_OK) {
                free(name);
                return VBNL_ERR_PARSE;
            }
        } else {
            break;
        }
    }
    int idx = load_image(c, name, &loc, raw, gamma > 0.0 ? gamma : 0.0, what);
    free(name);
    if (idx < 0)
        return VBNL_ERR_PARSE;
    pat->d.kind = VBNL_PATTERN_IMAGE;
    pat->name = "image";
    pat->image = idx;
    pat->d.frequency = 0.0f;
    pat->d.image.map_type = 0;
    pat->d.image.interpolate = 0;
    pat->d.image.use = 1;
    return VBNL_OK;
}

/* ---- the image attributes ------------------------------------------------------------------------ */

typedef struct image_block {
    pov_pattern *pat;
    double *amount;    /* bump_map: bump_size */
    const char *what;
} image_block;

static vbnl_result attr(const pov_item *it)
{
    image_block *b = it->target;
    vbnl_sdl_parser *p = it->p;
    const char *kw = it->kw;
    vbnl_sdl_next(p);
    if (!strcmp(kw, "once")) {
        b->pat->d.image.once = 1;
        return VBNL_OK;
    }
    if (!strcmp(kw, "use_color") || !strcmp(kw, "use_colour") || !strcmp(kw, "use_index") || !strcmp(kw, "use_alpha")) {
        /* POV-Ray: use_index means "the palette index" (its USE_NONE) except in image_pattern */
        int image_pattern = !strcmp(b->what, "image_pattern");
        b->pat->d.image.use = !strcmp(kw, "use_alpha") ? 3 : !strcmp(kw, "use_index") ? (image_pattern ? 2 : 0) : 1;
        return VBNL_OK;
    }
    if (!strcmp(kw, "repeat") || !strcmp(kw, "offset")) {
        double v[2];
        if (vbnl_sdl_parse_vector(p, 2, v) != VBNL_OK)
            return VBNL_ERR_PARSE;
        vbnl_sdl_warning(p, &it->loc, "%s: '%s' is ignored (the image covers the unit square once)", b->what, kw);
        return VBNL_OK;
    }
    double v;
    if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!strcmp(kw, "map_type")) {
        if (v != 0.0 && v != 1.0 && v != 2.0 && v != 5.0)
            return vbnl_sdl_error(p, &it->loc, "%s: map_type %g is not supported (0 planar, 1 spherical, 2 cylindrical, 5 torus)",
                                  b->what, v);
        b->pat->d.image.map_type = (int)v;
    } else if (!strcmp(kw, "interpolate")) {
        /* 2 bilinear, 3 bicubic, 4 normalised distance (POV-Ray's numbers) */
        b->pat->d.image.interpolate = v == 2.0 ? 2 : v == 3.0 ? 3 : v == 4.0 ? 4 : 0;
    } else if (!strcmp(kw, "bump_size") && b->amount) {
        *b->amount = v;
    }
    return VBNL_OK;
}

/* filter|transmit all amount | filter|transmit index, amount (palette entries: not kept here) */
static vbnl_result filter(const pov_item *it)
{
    image_block *b = it->target;
    vbnl_sdl_parser *p = it->p;
    const int transmit = !strcmp(it->kw, "transmit");
    double v;
    vbnl_sdl_next(p);
    if (pov_is_word(vbnl_sdl_peek(p), "all")) {
        vbnl_sdl_next(p);
        if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
            return VBNL_ERR_PARSE;
        *(transmit ? &b->pat->d.image.transmit_all : &b->pat->d.image.filter_all) = v;
        return VBNL_OK;
    }
    double index;
    if (vbnl_sdl_parse_float(p, &index) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_accept(p, ',');
    if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(p, &it->loc, "%s: '%s' of palette entry %g is ignored (palette images are read as colours)",
                     b->what, it->kw, index);
    return VBNL_OK;
}

static const pov_row image_rows[] = {
    {"once", attr, 0},        {"map_type", attr, 0},   {"interpolate", attr, 0}, {"use_color", attr, 0},
    {"use_colour", attr, 0},  {"use_index", attr, 0},  {"use_alpha", attr, 0},   {"repeat", attr, 0},
    {"offset", attr, 0},      {"bump_size", attr, 0},  {"filter", filter, 0},    {"transmit", filter, 0},
    {NULL, NULL, 0},
};
static const pov_row *const image_tables[] = {image_rows, NULL};
static const pov_block image_items = {.name = "image_map", .tables = image_tables, .unknown = pov_block_unexpected_word};

/* `what { file attributes }`, after its keyword. */
static vbnl_result image_block_parse(pov_ctx *c, pov_pattern *pat, double *amount, int raw, const char *what)
{
    vbnl_sdl_parser *p = c->parser;
    char ctx[48];
    snprintf(ctx, sizeof ctx, "after '%s'", what);
    if (vbnl_sdl_expect(p, '{', ctx) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (image_file(c, pat, raw, what) != VBNL_OK)
        return VBNL_ERR_PARSE;
    image_block b = {pat, amount, what};
    return pov_block_parse(&image_items, p, c, &b, what);
}

vbnl_result pov_image_map_parse(pov_ctx *c, pov_pigment *pg)
{
    if (image_block_parse(c, &pg->pat, NULL, 0, "image_map") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pg->kind = POV_PIG_IMAGE;
    return VBNL_OK;
}

vbnl_result pov_bump_map_parse(pov_ctx *c, pov_normal *n)
{
    if (image_block_parse(c, &n->pat, &n->amount, 1, "bump_map") != VBNL_OK)
        return VBNL_ERR_PARSE;
    n->kind = POV_NRM_IMAGE;
    return VBNL_OK;
}

vbnl_result pov_image_pattern_parse(pov_ctx *c, pov_pattern *pat)
{
    return image_block_parse(c, pat, NULL, 1, "image_pattern");
}

/* material_map { file attributes texture { } ... }: texture i where the image's index (palette
 * index, or red * 255) is i. */
vbnl_result pov_material_map_parse(pov_ctx *c, pov_texture *tx)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'material_map'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    pov_pattern_free(&tx->pat);
    pov_map_free(&tx->map);
    tx->map.kind = POV_MAP_TEXTURE;
    if (image_file(c, &tx->pat, 1, "material_map") != VBNL_OK)
        return VBNL_ERR_PARSE;
    tx->pat.d.image.use = 4;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (pov_is_word(t, "texture")) {
            vbnl_sdl_next(p);
            pov_map_entry *e = pov_map_add(&tx->map);
            if (!e)
                return vbnl_sdl_error(p, &t->loc, "material_map has more than %d textures", POV_MAP_MAX);
            e->value = tx->map.count - 1;
            pov_texture *sub = NULL;
            vbnl_result r = pov_texture_parse(c, &sub);
            e->sub = sub;
            if (r != VBNL_OK)
                return r;
            continue;
        }
        if (pov_is_punct(t, '}')) {
            vbnl_sdl_next(p);
            break;
        }
        image_block b = {&tx->pat, NULL, "material_map"};
        int r = pov_row_dispatch(image_rows, p, c, &b);
        if (r < 0)
            return VBNL_ERR_PARSE;
        if (r == 0)
            return vbnl_sdl_error(p, &t->loc, "unexpected '%s' in material_map", t->text ? t->text : "?");
    }
    if (tx->map.count == 0)
        return vbnl_sdl_error(p, NULL, "material_map needs at least one texture");
    return VBNL_OK;
}

/* ---- density_file df3 "file" ------------------------------------------------------------------ */

vbnl_result pov_density_read(pov_ctx *c, pov_pattern *pat, const vbnl_sdl_loc *kw_loc)
{
    vbnl_sdl_parser *p = c->parser;
    if (pov_is_word(vbnl_sdl_peek(p), "df3"))
        vbnl_sdl_next(p);
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    char *name = NULL;
    if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
        return VBNL_ERR_PARSE;
    char *path = locate(c, name, &loc, "density_file");
    free(name);
    if (!path)
        return VBNL_ERR_PARSE;
    struct stat st;
    const char *why = NULL;
    FILE *f = vbi_read_fopen(path, &st, &why);
    unsigned char h[6];
    long len = -1;
    if (f && fread(h, 1, 6, f) == 6)
        len = (long)st.st_size - 6;
    pov_density *d = calloc(1, sizeof(*d));
    vbnl_result r = VBNL_OK;
    if (!d) {
        r = vbnl_sdl_error(p, &loc, "out of memory reading '%s'", path);
    } else if (!f || len < 0) {
        r = vbnl_sdl_error(p, &loc, "density_file: cannot read '%s': %s", path, why ? why : "it is shorter than its header");
    } else {
        /* POV-Ray's df3: three 16-bit sizes, then 8, 16 or 32-bit values (big-endian), x fastest */
        d->n[0] = (uint32_t)(h[0] << 8 | h[1]);
        d->n[1] = (uint32_t)(h[2] << 8 | h[3]);
        d->n[2] = (uint32_t)(h[4] << 8 | h[5]);
        size_t count = (size_t)d->n[0] * d->n[1] * d->n[2];
        size_t bytes = count == 0 ? 0 : (size_t)len / count;
        if (count == 0 || (bytes != 1 && bytes != 2 && bytes != 4) || bytes * count != (size_t)len ||
            count > ((size_t)1 << 28)) {
            r = vbnl_sdl_error(p, &loc, "density_file: '%s' has an invalid size", path);
        } else if (!(d->v = malloc(count * sizeof(float)))) {
            r = vbnl_sdl_error(p, &loc, "out of memory reading '%s'", path);
        } else {
            fseek(f, 6, SEEK_SET);
            const double scale = bytes == 1 ? 255.0 : bytes == 2 ? 65535.0 : 4294967295.0;
            for (size_t i = 0; i < count && r == VBNL_OK; ++i) {
                unsigned char b[4];
                if (fread(b, 1, bytes, f) != bytes) {
                    r = vbnl_sdl_error(p, &loc, "density_file: '%s' is truncated", path);
                    break;
                }
                uint32_t v = 0;
                for (size_t k = 0; k < bytes; ++k)
                    v = v << 8 | b[k];
                d->v[i] = (float)(v / scale);
            }
        }
    }
    if (f)
        fclose(f);
    free(path);
    if (r != VBNL_OK) {
        if (d)
            free(d->v);
        free(d);
        return r;
    }
    (void)kw_loc;
    d->refs = 1;
    if (pat->density && --pat->density->refs <= 0) {
        free(pat->density->v);
        free(pat->density);
    }
    pat->density = d;
    pat->d.density.nx = d->n[0];
    pat->d.density.ny = d->n[1];
    pat->d.density.nz = d->n[2];
    return VBNL_OK;
}
