/* vbnl object layer: text { ttf "font" "string" thickness, offset  modifiers }
 *                    text { internal N "string" thickness, offset  modifiers }
 *
 * Glyph outlines come from FreeType (TrueType and OpenType fonts), in font units scaled by
 * 1 / units_per_EM, so a line of text is about one unit high. Each glyph is one primitive (a
 * union, as POV-Ray builds it), extruded from z = 0 (its front, facing -z) to z = thickness;
 * glyphs that repeat share their mesh. Placement is POV-Ray 3.7's (truetype.cpp):
 *   the first glyph is moved so that its left edge (the glyph's xMin) is at x = 0, and the pen
 *   goes on by (advance - left side bearing);
 *   every other glyph is placed at pen + (left side bearing - xMin + kerning) and the pen goes on
 *   by (advance + kerning), kerning from the font's 'kern' table as FreeType reads it;
 *   after each glyph the pen moves by `offset` (its x and y; POV-Ray drops its z).
 * Inside is the even-odd rule over the glyph's contours between the two faces, as POV-Ray's
 * glyph test. `internal N` names POV-Ray's built-in fonts, which its include folder ships as
 * files: 1 timrom.ttf, 2 cyrvetic.ttf, 3 crystal.ttf, any other povlogo.ttf. */
#include <ft2build.h>
#include FT_FREETYPE_H
#include FT_OUTLINE_H
#include FT_TRUETYPE_TABLES_H
#include FT_TRUETYPE_TAGS_H

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pov_surface.h"
#include "read_file.h"

/* Flattening tolerance of the glyph outlines, in em: 1/2000 of the line height. */
#define TEXT_TOL 5e-4

/* ---- the font file: read through a descriptor of a regular file (read_file.h) ------------------- */

static unsigned long font_read(FT_Stream st, unsigned long off, unsigned char *buf, unsigned long n)
{
    if (n == 0) /* a seek: 0 when the offset lies within the file */
        return off > st->size;
    ssize_t got = pread((int)st->descriptor.value, buf, n, (off_t)off);
    return got > 0 ? (unsigned long)got : 0;
}

/* Called by FreeType when the face is done, and when FT_Open_Face fails. */
static void font_close(FT_Stream st)
{
    if (st->descriptor.value >= 0)
        close((int)st->descriptor.value);
    st->descriptor.value = -1;
}

/* The face of the font file `path` (*why set when it is not a regular file that can be opened);
 * `stream` must outlive the face. */
static FT_Error font_open(FT_Library lib, const char *path, FT_StreamRec *stream, FT_Face *face, const char **why)
{
    struct stat st;
    memset(stream, 0, sizeof *stream);
    stream->descriptor.value = vbi_read_open(path, &st, why);
    if (stream->descriptor.value < 0)
        return FT_Err_Cannot_Open_Resource;
    stream->size = (unsigned long)st.st_size;
    stream->read = font_read;
    stream->close = font_close;
    FT_Open_Args args = {.flags = FT_OPEN_STREAM, .stream = stream};
    return FT_Open_Face(lib, &args, 0, face);
}

/* ---- one glyph: outline, mesh, solid ------------------------------------------------------------ */

typedef struct glyph_solid {
    pov_outline o;
    double depth;
} glyph_solid;

static int glyph_inside(const void *data, const double q[3])
{
    const glyph_solid *g = data;
    double z0 = fmin(0, g->depth), z1 = fmax(0, g->depth);
    return q[2] > z0 && q[2] < z1 && pov_outline_inside(&g->o, q[0], q[1]);
}

static void glyph_destroy(void *data)
{
    glyph_solid *g = data;
    pov_outline_free(&g->o);
    free(g);
}

static const pov_solid_fn glyph_fn = {glyph_inside, glyph_destroy, NULL};

typedef struct decompose {
    pov_outline *o;
    double scale, last[2];
    int open;
} decompose;

static void ft_point(const decompose *d, const FT_Vector *v, double p[2])
{
    p[0] = v->x * d->scale;
    p[1] = v->y * d->scale;
}

static int ft_move(const FT_Vector *to, void *user)
{
    decompose *d = user;
    pov_outline_begin(d->o);
    ft_point(d, to, d->last);
    pov_outline_point(d->o, d->last[0], d->last[1], 0, 0);
    return d->o->oom;
}

static int ft_line(const FT_Vector *to, void *user)
{
    decompose *d = user;
    double p[2];
    ft_point(d, to, p);
    pov_outline_line(d->o, d->last, p);
    memcpy(d->last, p, sizeof p);
    return d->o->oom;
}

static int ft_conic(const FT_Vector *control, const FT_Vector *to, void *user)
{
    decompose *d = user;
    double c[2], p[2];
    ft_point(d, control, c);
    ft_point(d, to, p);
    pov_outline_quad(d->o, d->last, c, p, TEXT_TOL);
    memcpy(d->last, p, sizeof p);
    return d->o->oom;
}

static int ft_cubic(const FT_Vector *c1, const FT_Vector *c2, const FT_Vector *to, void *user)
{
    decompose *d = user;
    double a[2], b[2], p[2];
    ft_point(d, c1, a);
    ft_point(d, c2, b);
    ft_point(d, to, p);
    pov_outline_cubic(d->o, d->last, a, b, p, TEXT_TOL);
    memcpy(d->last, p, sizeof p);
    return d->o->oom;
}

typedef struct glyph_geom {
    double depth;
    double nz; /* the back face's normal (+z for a positive depth) */
} glyph_geom;

static void front_pos(void *user, double x, double y, double p[3])
{
    (void)user;
    p[0] = x;
    p[1] = y;
    p[2] = 0;
}

static void back_pos(void *user, double x, double y, double p[3])
{
    p[0] = x;
    p[1] = y;
    p[2] = ((const glyph_geom *)user)->depth;
}

static void wall(void *user, const double xy[2], const double nrm[2], int h, double p[3], double n[3])
{
    p[0] = xy[0];
    p[1] = xy[1];
    p[2] = h ? ((const glyph_geom *)user)->depth : 0;
    n[0] = nrm[0];
    n[1] = nrm[1];
    n[2] = 0;
}

/* The glyph's mesh and solid in font space scaled to em (NULL mesh: out of memory or a font
 * error, *why set). An empty glyph (a space) gives an empty mesh. */
static pov_mesh *glyph_mesh(FT_Face face, double scale, double depth, pov_solid **solid, const char **why)
{
    *solid = NULL;
    *why = NULL;
    glyph_solid *gs = calloc(1, sizeof *gs);
    if (!gs) {
        *why = "out of memory";
        return NULL;
    }
    gs->depth = depth;
    decompose d = {&gs->o, scale, {0, 0}, 0};
    FT_Outline_Funcs funcs = {ft_move, ft_line, ft_conic, ft_cubic, 0, 0};
    if (FT_Outline_Decompose(&face->glyph->outline, &funcs, &d) != 0 || !pov_outline_finish(&gs->o)) {
        *why = gs->o.oom ? "out of memory" : "the font's glyph outline cannot be read";
        glyph_destroy(gs);
        return NULL;
    }
    pov_smesh sm;
    memset(&sm, 0, sizeof sm);
    glyph_geom gg = {depth, depth >= 0 ? 1 : -1};
    double nf[3] = {0, 0, -gg.nz}, nb[3] = {0, 0, gg.nz};
    pov_outline_fill(&gs->o, &sm, front_pos, &gg, nf);
    pov_outline_fill(&gs->o, &sm, back_pos, &gg, nb);
    pov_outline_walls(&gs->o, &sm, wall, &gg);
    pov_mesh *m = sm.oom ? NULL : pov_smesh_to_mesh(&sm, 0);
    pov_smesh_free(&sm);
    double lo[3] = {INFINITY, INFINITY, fmin(0, depth)}, hi[3] = {-INFINITY, -INFINITY, fmax(0, depth)};
    for (uint32_t i = 0; i < gs->o.n; ++i)
        for (int k = 0; k < 2; ++k) {
            lo[k] = fmin(lo[k], gs->o.xy[2 * i + k]);
            hi[k] = fmax(hi[k], gs->o.xy[2 * i + k]);
        }
    if (gs->o.n == 0)
        lo[0] = lo[1] = hi[0] = hi[1] = 0;
    if (!m || !(*solid = pov_solid_custom(&glyph_fn, gs, lo, hi))) {
        if (!m)
            glyph_destroy(gs);
        pov_mesh_unref(m);
        *why = "out of memory";
        return NULL;
    }
    return m;
}

/* ---- the string ------------------------------------------------------------------------------ */

/* The next code point of a UTF-8 string (bytes that are not UTF-8 count as Latin-1). */
static uint32_t next_char(const unsigned char **s)
{
    const unsigned char *p = *s;
    uint32_t c = *p;
    int n = c >= 0xf0 && c < 0xf8 ? 3 : c >= 0xe0 ? 2 : c >= 0xc0 ? 1 : 0;
    if (c >= 0x80 && n) {
        uint32_t v = c & (0x3f >> n);
        int i = 1;
        for (; i <= n && (p[i] & 0xc0) == 0x80; ++i)
            v = v << 6 | (p[i] & 0x3f);
        if (i > n) {
            *s = p + n + 1;
            return v;
        }
    }
    *s = p + 1;
    return c;
}

/* The left side bearing of a glyph from the 'hmtx' table (as POV-Ray reads it), else xMin. */
static long glyph_lsb(FT_Face face, const FT_Byte *hmtx, FT_ULong hmtx_len, unsigned nmetrics, FT_UInt gi, long xmin)
{
    if (!hmtx || nmetrics == 0)
        return xmin;
    FT_ULong off = gi < nmetrics ? 4ul * gi + 2 : 4ul * nmetrics + 2ul * (gi - nmetrics);
    if (off + 2 > hmtx_len)
        return xmin;
    (void)face;
    return (int16_t)(hmtx[off] << 8 | hmtx[off + 1]);
}

typedef struct text_shape {
    pov_mods mods;
    char *font;      /* the path found */
    char *string;
    double depth, offset[3];
} text_shape;

static const pov_row text_rows[] = {{NULL, NULL, 0}};
POV_SHAPE_BLOCK(text_block, text_rows);

typedef struct cached {
    FT_UInt gi;
    pov_mesh *mesh;
    pov_solid *solid;
} cached;

static vbnl_result text_make(const pov_shape *s, pov_mods *mods, pov_prim *first)
{
    text_shape *ts = (text_shape *)mods;
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    FT_Library lib = NULL;
    FT_Face face = NULL;
    FT_StreamRec stream;
    FT_Byte *hmtx = NULL;
    FT_ULong hmtx_len = 0;
    cached *cache = NULL;
    size_t ncache = 0;
    vbnl_result r = VBNL_OK;
    /* the primitive already added is the first glyph's; its transform so far is every glyph's */
    double m0[16];
    memcpy(m0, first->m, sizeof m0);
    pov_appearance *app0 = first->app;
    size_t idx0 = (size_t)(first - s->o->v), placed = 0;
    first->mesh = pov_mesh_new();
    if (!first->mesh)
        return pov_oom(L);
    if (FT_Init_FreeType(&lib) != 0)
        return vbnl_sdl_error(p, &s->loc, "text: FreeType cannot start");
    const char *unread = NULL;
    if (font_open(lib, ts->font, &stream, &face, &unread) != 0) {
        face = NULL;
        r = unread ? vbnl_sdl_error(p, &s->loc, "text: cannot read '%s': %s", ts->font, unread)
                : vbnl_sdl_error(p, &s->loc, "text: '%s' is not a font FreeType can read", ts->font);
        goto done;
    }
    if (FT_Select_Charmap(face, FT_ENCODING_UNICODE) != 0 && face->num_charmaps > 0)
        FT_Set_Charmap(face, face->charmaps[0]); /* a symbol font: its own encoding */
    double upem = face->units_per_EM > 0 ? face->units_per_EM : 1000, sc = 1.0 / upem;
    unsigned nmetrics = 0;
    const TT_HoriHeader *hhea = FT_Get_Sfnt_Table(face, FT_SFNT_HHEA);
    if (hhea && FT_Load_Sfnt_Table(face, TTAG_hmtx, 0, NULL, &hmtx_len) == 0 && (hmtx = malloc(hmtx_len)) &&
        FT_Load_Sfnt_Table(face, TTAG_hmtx, 0, hmtx, &hmtx_len) == 0)
        nmetrics = hhea->number_Of_HMetrics;
    double pen[3] = {0, 0, 0};
    FT_UInt prev = 0;
    int i = 0;
    for (const unsigned char *c = (const unsigned char *)ts->string; *c; ++i) {
        uint32_t ch = next_char(&c);
        FT_UInt gi = FT_Get_Char_Index(face, ch);
        if (FT_Load_Glyph(face, gi, FT_LOAD_NO_SCALE | FT_LOAD_NO_HINTING | FT_LOAD_NO_BITMAP) != 0) {
            r = vbnl_sdl_error(p, &s->loc, "text: glyph %u of '%s' cannot be loaded", (unsigned)gi, ts->font);
            goto done;
        }
        FT_BBox box;
        FT_Outline_Get_CBox(&face->glyph->outline, &box);
        long xmin = face->glyph->outline.n_points ? box.xMin : 0;
        long adv = face->glyph->metrics.horiAdvance, lsb = glyph_lsb(face, hmtx, hmtx_len, nmetrics, gi, xmin);
        double at[3] = {0, 0, 0};
        if (i == 0) {
            at[0] = -xmin * sc;
            pen[0] = (adv - lsb) * sc;
        } else {
            FT_Vector k = {0, 0};
            if (FT_HAS_KERNING(face))
                FT_Get_Kerning(face, prev, gi, FT_KERNING_UNSCALED, &k);
            long kx = k.x < -(long)upem ? -(long)upem : k.x, ky = k.y < -(long)upem ? -(long)upem : k.y;
            at[0] = pen[0] + (lsb - xmin + kx) * sc;
            at[1] = pen[1] + ky * sc;
            pen[0] += (adv + kx) * sc;
        }
        for (int k = 0; k < 3; ++k)
            pen[k] += ts->offset[k];
        prev = gi;
        if (face->glyph->outline.n_contours == 0)
            continue; /* a space: it only moves the pen */
        size_t ci = 0;
        while (ci < ncache && cache[ci].gi != gi)
            ++ci;
        if (ci == ncache) {
            cached *nc = realloc(cache, (ncache + 1) * sizeof *nc);
            if (!nc) {
                r = pov_oom(L);
                goto done;
            }
            cache = nc;
            cache[ci].gi = gi;
            /* the glyph of this font and depth made before (by any text): shared */
            pov_key key = {0};
            pov_key_add(&key, "glyph", 6);
            pov_key_add(&key, ts->font, strlen(ts->font) + 1);
            pov_key_add(&key, &gi, sizeof gi);
            pov_key_add(&key, &ts->depth, sizeof ts->depth);
            if (key.failed || !pov_shape_cache_get(L, key.b, key.n, &cache[ci].mesh, &cache[ci].solid)) {
                const char *why = NULL;
                cache[ci].mesh = glyph_mesh(face, sc, ts->depth, &cache[ci].solid, &why);
                if (!cache[ci].mesh) {
                    pov_key_free(&key);
                    r = strcmp(why, "out of memory") ? vbnl_sdl_error(p, &s->loc, "text: %s", why) : pov_oom(L);
                    goto done;
                }
                if (!key.failed)
                    pov_shape_cache_put(L, key.b, key.n, cache[ci].mesh, cache[ci].solid);
            }
            pov_key_free(&key);
            ncache++;
        }
        /* the glyph's primitive: the first one reuses the primitive added for the shape */
        pov_prim *pr;
        if (placed == 0) {
            pr = &s->o->v[idx0];
        } else {
            if (!(pr = pov_obj_add(s->o, POV_PRIM_MESH, s->loc)) ||
                (app0 && !(pr->app = pov_appearance_copy(app0)))) {
                r = pov_oom(L);
                goto done;
            }
            pr->inverse = s->o->v[idx0].inverse;
        }
        double t[16];
        pov_m4_translate(at, t);
        pov_m4_mul(m0, t, pr->m);
        pov_mesh_unref(pr->mesh);
        pr->mesh = cache[ci].mesh;
        pr->mesh->refs++;
        pov_solid_unref(pr->solid);
        pr->solid = pov_solid_ref(cache[ci].solid);
        placed++;
    }
done:
    for (size_t k = 0; k < ncache; ++k) {
        pov_mesh_unref(cache[k].mesh);
        pov_solid_unref(cache[k].solid);
    }
    free(cache);
    free(hmtx);
    if (face)
        FT_Done_Face(face);
    FT_Done_FreeType(lib);
    return r;
}

vbnl_result pov_shape_text(const pov_shape *s)
{
    pov_loader *L = s->L;
    vbnl_sdl_parser *p = L->c.parser;
    text_shape ts;
    memset(&ts, 0, sizeof ts);
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    vbnl_sdl_loc floc = t->loc;
    char *name = NULL;
    vbnl_result r = VBNL_OK;
    if (pov_is_word(t, "ttf")) {
        vbnl_sdl_next(p);
        floc = vbnl_sdl_peek(p)->loc;
        if (vbnl_sdl_parse_string(p, &name) != VBNL_OK)
            return VBNL_ERR_PARSE;
    } else if (pov_is_word(t, "internal")) {
        double id;
        vbnl_sdl_next(p);
        if (pov_float(L, &id) != VBNL_OK)
            return VBNL_ERR_PARSE;
        int n = (int)id;
        name = strdup(n == 1 ? "timrom.ttf" : n == 2 ? "cyrvetic.ttf" : n == 3 ? "crystal.ttf" : "povlogo.ttf");
        if (!name)
            return pov_oom(L);
    } else {
        return vbnl_sdl_error(p, &floc, "text: expected 'ttf' or 'internal'");
    }
    ts.font = pov_shape_find_file(L, name, ".ttf", &floc, "text: font");
    free(name);
    if (!ts.font)
        return VBNL_ERR_PARSE;
    pov_comma(L);
    if (vbnl_sdl_parse_string(p, &ts.string) != VBNL_OK)
        r = VBNL_ERR_PARSE;
    if (r == VBNL_OK) {
        pov_comma(L);
        r = pov_float(L, &ts.depth);
    }
    if (r == VBNL_OK) {
        pov_comma(L);
        r = pov_vec3(L, ts.offset);
    }
    if (r == VBNL_OK)
        r = pov_shape_deferred(s, &text_block, &ts.mods, text_make);
    free(ts.font);
    free(ts.string);
    return r;
}
