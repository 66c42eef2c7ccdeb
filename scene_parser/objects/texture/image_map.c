/* vbnl object layer, texture part: image_map { [png] "file.png" [map_type 0|1|2] [once]
 * [interpolate n] }. The PNG is read with libpng (next to the file that names it, then in the
 * POV-Ray include folders), once per file, and its sRGB values made linear. */
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pov_files.h"
#include "pov_texture.h"

static float srgb_to_linear(float v)
{
    return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f);
}

/* Finds `name` next to the file that names it (pov_files.h: never outside that folder), then in
 * the POV-Ray include folders; loads it once. Returns its index in the state's images, -1 after
 * an error. */
static int load_image(pov_ctx *c, const char *name, const vbnl_sdl_loc *loc)
{
    pov_texture_state *s = c->tex;
    char path[POV_PATH_MAX];
    path[0] = '\0';
    if (pov_file_name_escapes(name)) {
        /* allowed only into a folder the user opened to the scene */
        const char *why = NULL;
        char *opened = pov_file_resolve(c->parser, loc, name, POV_FILE_READ, &why);
        if (!opened) {
            vbnl_sdl_error(c->parser, loc, "image_map: '%s' is %s", name, why ? why : "outside the scene's folder");
            return -1;
        }
        free(opened);
    }
    const char *why = NULL;
    char *near = pov_file_resolve(c->parser, loc, name, POV_FILE_READ, &why);
    if (near) {
        int n = snprintf(path, sizeof(path), "%s", near);
        free(near);
        if (n < 0 || (size_t)n >= sizeof(path)) {
            vbnl_sdl_error(c->parser, loc, "image file name too long");
            return -1;
        }
    }
    /* then the standard POV-Ray include folders (POV-Ray's library path, readable by any scene) */
    static const char *const libs[] = {"/usr/share/povray-3.7/include", "/usr/share/povray/include",
                                       "/usr/local/share/povray-3.7/include"};
    for (size_t i = 0; !path[0] && i < sizeof(libs) / sizeof(libs[0]); ++i) {
        int n = snprintf(path, sizeof(path), "%s/%s", libs[i], name);
        FILE *f = n > 0 && (size_t)n < sizeof(path) ? fopen(path, "rb") : NULL;
        if (f)
            fclose(f);
        else
            path[0] = '\0';
    }
    if (!path[0]) {
        vbnl_sdl_error(c->parser, loc, "image_map: '%s' is %s", name, why ? why : "a file that does not exist");
        return -1;
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
    pov_image *grown = realloc(s->images, sizeof(*grown) * (s->image_count + 1));
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
    pov_image *e = &s->images[s->image_count];
    memset(e, 0, sizeof(*e));
    strcpy(e->path, path);
    e->width = img.width;
    e->height = img.height;
    e->texels = texels;
    return (int)s->image_count++;
}

/* ---- image_map { } ----------------------------------------------------------------------------- */

static vbnl_result map_type(const pov_item *it)
{
    pov_pigment *pg = it->target;
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (v != 0.0 && v != 1.0 && v != 2.0)
        return vbnl_sdl_error(it->p, &it->loc, "image_map: map_type %g is not supported (0 planar, 1 spherical, 2 cylindrical)", v);
    pg->map_type = (int)v;
    return VBNL_OK;
}

static vbnl_result once(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    ((pov_pigment *)it->target)->once = 1;
    return VBNL_OK;
}

static vbnl_result interpolate(const pov_item *it)
{
    double v;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    ((pov_pigment *)it->target)->interpolate = v != 0.0;
    return VBNL_OK;
}

/* `word` or a float, read and dropped. */
static vbnl_result word_or_float(vbnl_sdl_parser *p, const char *word)
{
    double v;
    if (pov_is_word(vbnl_sdl_peek(p), word)) {
        vbnl_sdl_next(p);
        return VBNL_OK;
    }
    return vbnl_sdl_parse_float(p, &v);
}

/* filter|transmit all|index, amount */
static vbnl_result filter(const pov_item *it)
{
    vbnl_sdl_parser *p = it->p;
    double v;
    vbnl_sdl_next(p);
    if (word_or_float(p, "all") != VBNL_OK) /* all, or a palette index */
        return VBNL_ERR_PARSE;
    vbnl_sdl_accept(p, ',');
    if (vbnl_sdl_parse_float(p, &v) != VBNL_OK)
        return VBNL_ERR_PARSE;
    /* it->tok is the parser's look-ahead slot: it now holds the token after the amount, and the
     * message names that token */
    vbnl_sdl_warning(p, &it->loc, "image_map: '%s' is ignored (image maps are opaque here)", it->tok->text);
    return VBNL_OK;
}

static vbnl_result gamma_item(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    if (word_or_float(it->p, "srgb") != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_warning(it->p, &it->loc, "image_map: 'gamma' is ignored (PNG data are read as sRGB)");
    return VBNL_OK;
}

static const pov_row image_map_rows[] = {
    {"map_type", map_type, 0},
    {"once", once, 0},
    {"interpolate", interpolate, 0},
    {"filter", filter, 0},
    {"transmit", filter, 0},
    {"gamma", gamma_item, 0},
    {"use_color", pov_item_word, 0},
    {"use_colour", pov_item_word, 0},
    {"use_index", pov_item_word, 0},
    {"premultiplied", pov_item_word, 0},
    {NULL, NULL, 0},
};
static const pov_row *const image_map_tables[] = {image_map_rows, NULL};
static const pov_block image_map_items = {.name = "image_map",
                                          .tables = image_map_tables,
                                          .unknown = pov_block_unexpected_word};

vbnl_result pov_image_map_parse(pov_ctx *c, pov_pigment *pg)
{
    vbnl_sdl_parser *p = c->parser;
    if (vbnl_sdl_expect(p, '{', "after 'image_map'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    static const char *const other[] = {"gif", "tga", "iff", "ppm", "pgm", "sys", "jpeg", "tiff", "bmp", "exr", "hdr", "ttf"};
    for (size_t i = 0; i < sizeof(other) / sizeof(other[0]); ++i)
        if (pov_is_word(t, other[i]))
            return vbnl_sdl_error(p, &t->loc, "image_map: only png images are supported (found '%s')", t->text);
    if (pov_is_word(t, "png"))
        vbnl_sdl_next(p);
    vbnl_sdl_loc loc = vbnl_sdl_peek(p)->loc;
    char *name = NULL;
    if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
        return VBNL_ERR_PARSE;
    pg->image = load_image(c, name, &loc);
    free(name);
    if (pg->image < 0)
        return VBNL_ERR_PARSE;
    pg->kind = POV_PIG_IMAGE;
    pg->map_type = 0;
    return pov_block_parse(&image_map_items, p, c, pg, NULL);
}
