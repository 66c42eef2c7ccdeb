/* `vbnl compare REFERENCE.exr CANDIDATE.exr ... [--labels a,b,...] [--out DIR] [--layer NAME]
 * [--ref-layer NAME]`: error metrics of renders against a reference, false-colour error maps and
 * a labelled montage. --layer compares the candidates' layer NAME (channels NAME.R, NAME.G,
 * NAME.B, e.g. `path`'s split_direct layers "direct" and "indirect") instead of their beauty
 * image; --ref-layer does the same for the reference (default: its beauty image), so a layer can
 * be measured against a render of that part alone (e.g. indirect_only).
 *
 * Metrics (over every pixel and the R, G, B channels; eps = 0.01 mean(I_ref), the VBNL paper's
 * rMAE offset):
 *   rMAE      mean |I - I_ref| / (I_ref + eps)                     (the VBNL paper, §5)
 *   MSE       mean (I - I_ref)^2
 *   relMSE    mean (I - I_ref)^2 / (I_ref + eps)^2
 *   outliers  fraction of pixels whose relative error e = sum_c |I - I_ref| / sum_c (I_ref + eps)
 *             exceeds 1 (the pixel is off by more than the reference value itself: the spikes
 *             and splotches of many-light methods, the baseline notes §5).
 *   mean/ref  sum of I over sum of I_ref (R, G, B): the energy kept, e.g. what clamping removes
 *             or what spherical lights redistribute (notes §5, "energy loss").
 * A reference whose mean is 0 (black) is refused: every metric but MSE divides by it. So is an
 * image with a pixel that is NaN or infinite. The error map of a candidate shows e per pixel through a magma-like colour ramp from 0 to 1
 * (values above 1 saturate), with a colour bar underneath. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "commands.h"
#include "image_io.h"

/* ---- metrics --------------------------------------------------------------------------------- */

double cmd_rmae_eps(const float *ref, size_t n)
{
    double mean = 0.0;
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            mean += ref[4 * i + c];
    return n ? 0.01 * mean / (3.0 * (double)n) : 0.0;
}

double cmd_rmae(const float *img, const float *ref, size_t n)
{
    cmd_metrics m;
    cmd_image_metrics(img, ref, n, &m);
    return m.rmae;
}

void cmd_image_metrics(const float *img, const float *ref, size_t n, cmd_metrics *m)
{
    memset(m, 0, sizeof(*m));
    if (!n)
        return;
    const double eps = cmd_rmae_eps(ref, n);
    double rmae = 0.0, mse = 0.0, rel = 0.0, si = 0.0, sr = 0.0;
    size_t outliers = 0;
    for (size_t i = 0; i < n; ++i) {
        double num = 0.0, den = 0.0;
        for (int c = 0; c < 3; ++c) {
            double r = ref[4 * i + c], d = (double)img[4 * i + c] - r;
            double a = fabs(d);
            rmae += a / (r + eps);
            mse += d * d;
            rel += d * d / ((r + eps) * (r + eps));
            num += a;
            den += r + eps;
            si += img[4 * i + c];
            sr += r;
        }
        if (num > den)
            outliers++;
    }
    m->rmae = rmae / (3.0 * (double)n);
    m->mse = mse / (3.0 * (double)n);
    m->rel_mse = rel / (3.0 * (double)n);
    m->outliers = (double)outliers / (double)n;
    m->energy = sr > 0.0 ? si / sr : 0.0;
}

/* ---- drawing --------------------------------------------------------------------------------- */

/* 5x7 bitmap font: rows top to bottom, bit 4 = leftmost column. Letters are upper case only
 * (lower case is drawn in upper case); characters without a glyph are drawn as blanks. */
static const char font_chars[] = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ.-_:+/%=()<>";
static const uint8_t font_rows[][7] = {
    {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}, {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E},
    {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}, {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E},
    {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}, {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E},
    {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}, {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08},
    {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}, {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C},
    {0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11}, {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E},
    {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E}, {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C},
    {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F}, {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10},
    {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F}, {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11},
    {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}, {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C},
    {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}, {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F},
    {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11}, {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11},
    {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}, {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10},
    {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D}, {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11},
    {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E}, {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04},
    {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}, {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04},
    {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A}, {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11},
    {0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04}, {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F},
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}, {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00},
    {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F}, {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00},
    {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00}, {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00},
    {0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03}, {0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00},
    {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}, {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08},
    {0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02}, {0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08},
};

typedef struct canvas {
    uint8_t *px; /* RGB */
    uint32_t w, h;
} canvas;

static void put(canvas *cv, int x, int y, const uint8_t rgb[3])
{
    if (x < 0 || y < 0 || (uint32_t)x >= cv->w || (uint32_t)y >= cv->h)
        return;
    memcpy(cv->px + 3 * ((size_t)y * cv->w + (uint32_t)x), rgb, 3);
}

#define GLYPH_W 6 /* 5 columns and a space */

/* Draws `text` with its top-left corner at (x, y), each font pixel `scale` pixels wide; clipped. */
static void draw_text(canvas *cv, int x, int y, int scale, const char *text, const uint8_t rgb[3])
{
    for (const char *t = text; *t; ++t, x += GLYPH_W * scale) {
        char ch = *t >= 'a' && *t <= 'z' ? (char)(*t - 'a' + 'A') : *t;
        const char *f = strchr(font_chars, ch);
        if (!f || !ch)
            continue;
        const uint8_t *rows = font_rows[f - font_chars];
        for (int r = 0; r < 7; ++r)
            for (int c = 0; c < 5; ++c)
                if (rows[r] & (0x10 >> c))
                    for (int sy = 0; sy < scale; ++sy)
                        for (int sx = 0; sx < scale; ++sx)
                            put(cv, x + c * scale + sx, y + r * scale + sy, rgb);
    }
}

static int text_width(const char *text, int scale) { return (int)strlen(text) * GLYPH_W * scale; }

/* Magma-like ramp (sRGB): black, purple, red, orange, pale yellow. */
static void ramp(double t, uint8_t out[3])
{
    static const double stops[5][3] = {
        {0, 0, 4}, {81, 18, 124}, {183, 55, 121}, {252, 137, 97}, {252, 253, 191}};
    if (!(t > 0.0))
        t = 0.0;
    if (t > 1.0)
        t = 1.0;
    double x = t * 4.0;
    int i = (int)x;
    if (i > 3)
        i = 3;
    double f = x - i;
    for (int c = 0; c < 3; ++c)
        out[c] = (uint8_t)lround(stops[i][c] + (stops[i + 1][c] - stops[i][c]) * f);
}

/* How many of the n pixels have an R, G or B value that is NaN or infinite. */
static size_t count_nonfinite(const float *img, size_t n)
{
    size_t bad = 0;
    for (size_t i = 0; i < n; ++i)
        bad += !isfinite(img[4 * i]) || !isfinite(img[4 * i + 1]) || !isfinite(img[4 * i + 2]);
    return bad;
}

/* Per-pixel relative error e = sum_c |I - I_ref| / sum_c (I_ref + eps). */
static double pixel_error(const float *img, const float *ref, size_t i, double eps)
{
    double num = 0.0, den = 0.0;
    for (int c = 0; c < 3; ++c) {
        num += fabs((double)img[4 * i + c] - ref[4 * i + c]);
        den += ref[4 * i + c] + eps;
    }
    return den > 0.0 ? num / den : 0.0;
}

static void blit_error(canvas *cv, int x0, int y0, const float *img, const float *ref, uint32_t w, uint32_t h)
{
    double eps = cmd_rmae_eps(ref, (size_t)w * h);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            uint8_t c[3];
            ramp(pixel_error(img, ref, (size_t)y * w + x, eps), c);
            put(cv, x0 + (int)x, y0 + (int)y, c);
        }
}

static void blit_image(canvas *cv, int x0, int y0, const uint8_t *rgb, uint32_t w, uint32_t h)
{
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x)
            put(cv, x0 + (int)x, y0 + (int)y, rgb + 3 * ((size_t)y * w + x));
}

/* A colour bar from 0 to 1 across [x0, x0 + len) with its labels underneath. */
static void draw_colour_bar(canvas *cv, int x0, int y0, int len, int scale)
{
    static const uint8_t white[3] = {255, 255, 255};
    int bar_h = 6 * scale;
    for (int x = 0; x < len; ++x) {
        uint8_t c[3];
        ramp(len > 1 ? (double)x / (len - 1) : 0.0, c);
        for (int y = 0; y < bar_h; ++y)
            put(cv, x0 + x, y0 + y, c);
    }
    int ty = y0 + bar_h + 2 * scale;
    draw_text(cv, x0, ty, scale, "0", white);
    draw_text(cv, x0 + len - text_width(">=1", scale), ty, scale, ">=1", white);
    const char *mid = "REL. ERROR";
    if (text_width(mid, scale) + 2 * text_width(">=1", scale) < len)
        draw_text(cv, x0 + (len - text_width(mid, scale)) / 2, ty, scale, mid, white);
}

/* ---- files ----------------------------------------------------------------------------------- */

/* Reads R, G, B (or Y) of an EXR as RGBA floats. */
/* The beauty image (layer NULL) or layer `layer` of an EXR file as RGBA floats. */
static float *read_rgb(const char *path, const char *layer, uint32_t *w, uint32_t *h)
{
    vbi_exr_image ex;
    vbnl_error err = {0};
    if (vbi_exr_read(path, &ex, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl compare: %s\n", err.message);
        return NULL;
    }
    const vbi_exr_channel *ch[3];
    for (int c = 0; c < 3; ++c) {
        char name[160];
        snprintf(name, sizeof(name), "%s%s%c", layer ? layer : "", layer ? "." : "", "RGB"[c]);
        ch[c] = vbi_exr_image_channel(&ex, name);
    }
    if (layer && (!ch[0] || !ch[1] || !ch[2])) {
        fprintf(stderr, "vbnl compare: '%s' has no layer '%s' (channels %s.R, %s.G, %s.B); its channels:", path,
                layer, layer, layer, layer);
        for (uint32_t i = 0; i < ex.channel_count; ++i)
            fprintf(stderr, " %s", ex.channels[i].name);
        fprintf(stderr, "\n");
        vbi_exr_image_free(&ex);
        return NULL;
    }
    if (!ch[0] || !ch[1] || !ch[2]) {
        const vbi_exr_channel *y = vbi_exr_image_channel(&ex, "Y");
        if (!y) {
            fprintf(stderr, "vbnl compare: '%s' has neither R, G, B nor Y channels\n", path);
            vbi_exr_image_free(&ex);
            return NULL;
        }
        ch[0] = ch[1] = ch[2] = y;
    }
    size_t n = (size_t)ex.width * ex.height;
    float *px = malloc(sizeof(float) * 4 * (n ? n : 1));
    if (px)
        for (size_t i = 0; i < n; ++i) {
            for (int c = 0; c < 3; ++c)
                px[4 * i + c] = ch[c]->data[i];
            px[4 * i + 3] = 1.0f;
        }
    else
        fprintf(stderr, "vbnl compare: out of memory\n");
    *w = ex.width;
    *h = ex.height;
    vbi_exr_image_free(&ex);
    return px;
}

static void compare_usage(FILE *f)
{
    fprintf(f, "usage: vbnl compare REFERENCE.exr CANDIDATE.exr ... [--labels a,b,...] [--out DIR]\n"
               "                    [--layer NAME] [--ref-layer NAME]\n\n"
               "  Prints rMAE, MSE, relative MSE and the fraction of outlier pixels of every candidate\n"
               "  against the reference (all images of the same size). With --out, writes\n"
               "  DIR/error-LABEL.png (false-colour relative error with a colour bar) and\n"
               "  DIR/montage.png (reference, candidates and error maps side by side, labelled).\n"
               "  --labels names the candidates (default: their file names).\n"
               "  --layer compares the candidates' EXR layer NAME (NAME.R, NAME.G, NAME.B, e.g. path's\n"
               "  split_direct layers direct and indirect) instead of their beauty image; --ref-layer\n"
               "  picks the reference's layer the same way (default: its beauty image).\n");
}

static int write_png(const char *path, const canvas *cv)
{
    vbnl_error err = {0};
    if (vbi_png_write(path, cv->w, cv->h, 3, 8, cv->px, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl compare: %s\n", err.message);
        return -1;
    }
    return 0;
}

/* A label usable in a file name: letters, digits, '-' and '_' kept, the rest '_'. */
static void file_label(const char *label, char *out, size_t size)
{
    size_t k = 0;
    for (const char *c = label; *c && k + 1 < size; ++c)
        out[k++] = ((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') || *c == '-' ||
                    *c == '_')
                       ? *c
                       : '_';
    out[k] = '\0';
}

#define MAX_CANDIDATES 32

int cmd_compare(int argc, char **argv)
{
    const char *files[MAX_CANDIDATES + 1];
    int nfiles = 0;
    const char *labels_arg = NULL, *out_dir = NULL, *layer = NULL, *ref_layer = NULL;
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
            compare_usage(stdout);
            return VBI_EXIT_OK;
        } else if (!strcmp(argv[i], "--labels") || !strcmp(argv[i], "--out") || !strcmp(argv[i], "--layer") ||
                   !strcmp(argv[i], "--ref-layer")) {
            if (i + 1 >= argc || !argv[i + 1][0]) {
                fprintf(stderr, "vbnl compare: %s needs a value\n", argv[i]);
                return VBI_EXIT_USAGE;
            }
            if (!strcmp(argv[i], "--labels"))
                labels_arg = argv[++i];
            else if (!strcmp(argv[i], "--out"))
                out_dir = argv[++i];
            else if (!strcmp(argv[i], "--layer"))
                layer = argv[++i];
            else
                ref_layer = argv[++i];
        } else if (argv[i][0] == '-' && argv[i][1]) {
            fprintf(stderr, "vbnl compare: unknown option '%s'\n", argv[i]);
            compare_usage(stderr);
            return VBI_EXIT_USAGE;
        } else {
            if (nfiles > MAX_CANDIDATES) {
                fprintf(stderr, "vbnl compare: at most %d candidates\n", MAX_CANDIDATES);
                return VBI_EXIT_USAGE;
            }
            files[nfiles++] = argv[i];
        }
    }
    if (nfiles < 2) {
        fprintf(stderr, "vbnl compare: give a reference and at least one candidate\n");
        compare_usage(stderr);
        return VBI_EXIT_USAGE;
    }
    const int nc = nfiles - 1;
    /* labels */
    char label_store[MAX_CANDIDATES][64];
    const char *labels[MAX_CANDIDATES];
    int nl = 0;
    if (labels_arg) {
        const char *p = labels_arg;
        while (nl < MAX_CANDIDATES) {
            const char *comma = strchr(p, ',');
            size_t len = comma ? (size_t)(comma - p) : strlen(p);
            if (len >= sizeof(label_store[0]))
                len = sizeof(label_store[0]) - 1;
            memcpy(label_store[nl], p, len);
            label_store[nl][len] = '\0';
            labels[nl] = label_store[nl];
            nl++;
            if (!comma)
                break;
            p = comma + 1;
        }
        if (nl != nc) {
            fprintf(stderr, "vbnl compare: %d labels for %d candidates\n", nl, nc);
            return VBI_EXIT_USAGE;
        }
    } else {
        for (int i = 0; i < nc; ++i) {
            const char *base = strrchr(files[i + 1], '/');
            snprintf(label_store[i], sizeof(label_store[i]), "%s", base ? base + 1 : files[i + 1]);
            char *dot = strrchr(label_store[i], '.');
            if (dot && dot != label_store[i])
                *dot = '\0';
            labels[i] = label_store[i];
        }
    }
    /* images */
    float *img[MAX_CANDIDATES + 1] = {0};
    uint32_t w = 0, h = 0;
    int rc = VBI_EXIT_OK;
    for (int i = 0; i < nfiles && rc == VBI_EXIT_OK; ++i) {
        uint32_t iw, ih;
        img[i] = read_rgb(files[i], i == 0 ? ref_layer : layer, &iw, &ih);
        if (!img[i]) {
            rc = VBI_EXIT_FAILURE;
        } else if (i == 0) {
            w = iw;
            h = ih;
        } else if (iw != w || ih != h) {
            fprintf(stderr, "vbnl compare: '%s' is %ux%u but the reference '%s' is %ux%u: images must have "
                            "the same size\n",
                    files[i], iw, ih, files[0], w, h);
            rc = VBI_EXIT_FAILURE;
        }
    }
    if (rc == VBI_EXIT_OK && (size_t)w * h == 0) {
        fprintf(stderr, "vbnl compare: '%s' has no pixels\n", files[0]);
        rc = VBI_EXIT_FAILURE;
    }
    /* every metric but MSE is relative to the reference: against a black one (eps = 0) it divides 0
     * by 0, and a pixel that is not a finite number makes every mean NaN */
    for (int i = 0; i < nfiles && rc == VBI_EXIT_OK; ++i) {
        size_t bad = count_nonfinite(img[i], (size_t)w * h);
        if (bad) {
            fprintf(stderr, "vbnl compare: '%s' has %zu pixel%s that %s not finite numbers (NaN or infinite): no "
                            "error is defined against it\n",
                    files[i], bad, bad == 1 ? "" : "s", bad == 1 ? "is" : "are");
            rc = VBI_EXIT_FAILURE;
        }
    }
    if (rc == VBI_EXIT_OK && !(cmd_rmae_eps(img[0], (size_t)w * h) > 0.0)) {
        fprintf(stderr, "vbnl compare: the reference '%s' is black (its mean is %s): relative errors (rMAE, relMSE, "
                        "outliers, mean/ref) are undefined against it\n",
                files[0], cmd_rmae_eps(img[0], (size_t)w * h) < 0.0 ? "negative" : "0");
        rc = VBI_EXIT_FAILURE;
    }
    if (rc == VBI_EXIT_OK) {
        const size_t n = (size_t)w * h;
        printf("reference %s (%ux%u); eps = 0.01 mean(reference) = %.4g; outlier: relative error > 1\n", files[0],
               w, h, cmd_rmae_eps(img[0], n));
        if (layer || ref_layer)
            printf("layers: reference %s, candidates %s\n", ref_layer ? ref_layer : "beauty",
                   layer ? layer : "beauty");
        printf("%-24s %12s %12s %12s %10s %9s\n", "candidate", "rMAE", "MSE", "relMSE", "outliers", "mean/ref");
        for (int i = 0; i < nc; ++i) {
            cmd_metrics m;
            cmd_image_metrics(img[i + 1], img[0], n, &m);
            printf("%-24s %12.5f %12.5g %12.5g %9.3f%% %9.4f\n", labels[i], m.rmae, m.mse, m.rel_mse,
                   100.0 * m.outliers, m.energy);
        }
    }
    if (rc == VBI_EXIT_OK && out_dir) {
        if (mkdir(out_dir, 0777) != 0 && errno != EEXIST) {
            fprintf(stderr, "vbnl compare: cannot create '%s': %s\n", out_dir, strerror(errno));
            rc = VBI_EXIT_FAILURE;
        }
        const int scale = w >= 512 ? 2 : 1;
        const int label_h = 11 * scale, bar_h = 6 * scale + 2 * scale + 7 * scale + 4 * scale;
        const int gap = 4;
        char path[4096], fl[64];
        /* error maps */
        for (int i = 0; i < nc && rc == VBI_EXIT_OK; ++i) {
            canvas cv = {calloc((size_t)w * (h + bar_h + gap) * 3, 1), w, h + (uint32_t)(bar_h + gap)};
            if (!cv.px) {
                fprintf(stderr, "vbnl compare: out of memory\n");
                rc = VBI_EXIT_FAILURE;
                break;
            }
            blit_error(&cv, 0, 0, img[i + 1], img[0], w, h);
            draw_colour_bar(&cv, 0, (int)h + gap, (int)w, scale);
            file_label(labels[i], fl, sizeof(fl));
            snprintf(path, sizeof(path), "%s/error-%s.png", out_dir, fl);
            if (write_png(path, &cv) != 0)
                rc = VBI_EXIT_FAILURE;
            else
                printf("error map: %s\n", path);
            free(cv.px);
        }
        /* montage: row 1 the images (reference first), row 2 the error maps, labels on top */
        if (rc == VBI_EXIT_OK) {
            const uint32_t cols = (uint32_t)nfiles;
            const uint32_t cw = w + gap, mw = cols * cw - gap;
            const uint32_t mh = (uint32_t)label_h + h + gap + h + gap + (uint32_t)bar_h;
            canvas cv = {calloc((size_t)mw * mh * 3, 1), mw, mh};
            uint8_t *srgb = malloc((size_t)w * h * 3);
            static const uint8_t white[3] = {255, 255, 255};
            if (!cv.px || !srgb) {
                fprintf(stderr, "vbnl compare: out of memory\n");
                rc = VBI_EXIT_FAILURE;
            }
            for (uint32_t c = 0; c < cols && rc == VBI_EXIT_OK; ++c) {
                int x0 = (int)(c * cw);
                const char *lab = c == 0 ? "reference" : labels[c - 1];
                draw_text(&cv, x0 + 2, 2 * scale, scale, lab, white);
                vbi_linear_to_srgb8(img[c], w, h, 4, 0.0f, 0, srgb, 3, NULL);
                blit_image(&cv, x0, label_h, srgb, w, h);
                if (c > 0)
                    blit_error(&cv, x0, label_h + (int)h + gap, img[c], img[0], w, h);
            }
            if (rc == VBI_EXIT_OK) {
                draw_colour_bar(&cv, (int)cw, label_h + 2 * ((int)h + gap), (int)(mw - cw), scale);
                snprintf(path, sizeof(path), "%s/montage.png", out_dir);
                if (write_png(path, &cv) != 0)
                    rc = VBI_EXIT_FAILURE;
                else
                    printf("montage: %s\n", path);
            }
            free(srgb);
            free(cv.px);
        }
    }
    for (int i = 0; i < nfiles; ++i)
        free(img[i]);
    return rc;
}
