/* Joining the parts of a frame rendered apart (docs/farm.md):
 *
 *   vbnl merge-lights A.vls B.vls ... -o LIGHTS.vls [--partial]
 *       sums the photon ranges of light files of one preparation (vl_file_tools.h): exactly the
 *       file one process tracing every path would have written;
 *   vbnl merge-tiles T1.exr T2.exr ... -o OUT.exr [--png OUT.png] [--half] [view options]
 *       joins the EXRs of crop renders (each holds its window as the data window) into the whole
 *       image, pixel for pixel, with the header a single render writes.
 *
 * Neither needs the scene. Both refuse parts that do not belong together (another scene, camera,
 * light set, seed or option set, by the fingerprints and settings each part records) and a part
 * that is missing, naming the files and what differs. */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "farm_args.h"
#include "image_io.h"
#include "module.h"
#include "vl_file_tools.h"

#define MAX_PARTS 65536

/* ---- merge-lights ------------------------------------------------------------------------------ */

enum { ML_OUTPUT, ML_PARTIAL, ML_QUIET, ML_HELP };

typedef struct ml_opts {
    const char *out;
    int partial, quiet, help;
} ml_opts;

int cmd_merge_lights(int argc, char **argv)
{
    static const char usage[] =
        "usage: vbnl merge-lights A.vls B.vls ... -o LIGHTS.vls [--partial] [-q]\n"
        "\n"
        "Sums the photon ranges of light files of one preparation (`vbnl photons` parts of one\n"
        "`vbnl prepare` placement) into one file, equal bit for bit to one run over every path.\n"
        "The ranges must cover all the photon paths exactly once; with --partial, one contiguous part\n"
        "(for merging in steps).";
    ml_opts o = {0};
    const char **in = malloc(sizeof(*in) * (size_t)(argc > 1 ? argc : 1));
    uint32_t n = 0;
    int rc = in ? 0 : VBI_EXIT_FAILURE;
    for (int i = 1; i < argc && !rc; ++i) {
        const char *a = argv[i];
        if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
            if (i + 1 >= argc) {
                fprintf(stderr, "vbnl merge-lights: %s takes a file\n", a);
                rc = VBI_EXIT_USAGE;
            } else
                o.out = argv[++i];
        } else if (!strncmp(a, "--output=", 9))
            o.out = a + 9;
        else if (!strcmp(a, "--partial"))
            o.partial = 1;
        else if (!strcmp(a, "-q") || !strcmp(a, "--quiet"))
            o.quiet = 1;
        else if (!strcmp(a, "-h") || !strcmp(a, "--help"))
            o.help = 1;
        else if (a[0] == '-' && a[1]) {
            fprintf(stderr, "vbnl merge-lights: unknown option '%s'\n", a);
            rc = VBI_EXIT_USAGE;
        } else
            in[n++] = a;
    }
    if (!rc && o.help) {
        printf("%s\n", usage);
        free(in);
        return VBI_EXIT_OK;
    }
    if (!rc && (!o.out || n == 0)) {
        fprintf(stderr, "vbnl merge-lights: give the light files and -o LIGHTS.vls\n%s\n", usage);
        rc = VBI_EXIT_USAGE;
    }
    for (uint32_t i = 0; !rc && i < n; ++i)
        if (cli_same_file(o.out, in[i])) {
            fprintf(stderr, "vbnl merge-lights: -o '%s' is the input '%s'; an output never replaces an input\n",
                    o.out, in[i]);
            rc = VBI_EXIT_USAGE;
        }
    if (rc) {
        free(in);
        return rc;
    }
    farm_on_signals();
    vbi_vl_file_header h;
    vbnl_error err = {0};
    double t0 = farm_now();
    vbnl_result r = vbi_vl_file_merge(in, n, o.out, o.partial, &h, &err);
    free(in);
    if (r != VBNL_OK) {
        fprintf(stderr, "vbnl merge-lights: %s\n", err.message);
        return VBI_EXIT_FAILURE;
    }
    if (!o.quiet)
        fprintf(stderr,
                "vbnl merge-lights: %u files, %u virtual lights, photon paths [%" PRIu64 ", %" PRIu64 ") of %" PRIu64
                " -> %s (%.2f s)\n",
                n, h.count, h.photon_first, h.photon_first + h.photon_count, h.photon_paths, o.out,
                farm_now() - t0);
    return VBI_EXIT_OK;
}

/* ---- merge-tiles ------------------------------------------------------------------------------- */

/* Attributes every tile of one image must agree on (the rest are summed or are the tile's own). */
static const char *const same_attrs[] = {
    "vbnl/version",          "vbnl/integrator",         "vbnl/seed",
    "vbnl/sampler",          "vbnl/spp",                "vbnl/time_budget",
    "vbnl/scene/fingerprint", "vbnl/camera/fingerprint", "vbnl/lights/fingerprint",
    "vbnl/lights/preparation", "vbnl/lights/photons",   "vbnl/parameters",
};
#define N_SAME (sizeof(same_attrs) / sizeof(same_attrs[0]))

static int attr_equal(const vbi_image_attr *a, const vbi_image_attr *b)
{
    if (!a || !b)
        return !a && !b;
    if (a->type != b->type)
        return 0;
    switch (a->type) {
    case VBI_IMAGE_ATTR_STRING: return !strcmp(a->value.s, b->value.s);
    case VBI_IMAGE_ATTR_INT: return a->value.i == b->value.i;
    case VBI_IMAGE_ATTR_FLOAT: return memcmp(&a->value.f, &b->value.f, sizeof(float)) == 0;
    case VBI_IMAGE_ATTR_DOUBLE: return memcmp(&a->value.d, &b->value.d, sizeof(double)) == 0;
    }
    return 0;
}

static void attr_text(const vbi_image_attr *a, char *buf, size_t n)
{
    if (!a)
        snprintf(buf, n, "(none)");
    else if (a->type == VBI_IMAGE_ATTR_STRING)
        snprintf(buf, n, "'%.200s'", a->value.s);
    else if (a->type == VBI_IMAGE_ATTR_INT)
        snprintf(buf, n, "%d", (int)a->value.i);
    else
        snprintf(buf, n, "%.17g", a->type == VBI_IMAGE_ATTR_FLOAT ? (double)a->value.f : a->value.d);
}

static double attr_number(const vbi_exr_image *img, const char *name)
{
    const vbi_image_attr *a = vbi_exr_image_attr(img, name);
    if (!a)
        return 0.0;
    return a->type == VBI_IMAGE_ATTR_DOUBLE ? a->value.d
           : a->type == VBI_IMAGE_ATTR_FLOAT ? (double)a->value.f
           : a->type == VBI_IMAGE_ATTR_INT   ? (double)a->value.i
                                              : 0.0;
}

/* The seconds (or counts) a header attribute sums to over the tiles. */
typedef struct summed {
    char name[96];
    double value;
} summed;

typedef struct tile_set {
    uint32_t w, h, channels, tiles;
    char **channel;          /* names, in the first tile's (file) order */
    float **plane;           /* w x h each */
    uint32_t *owner;         /* w x h: 1 + the tile holding the pixel, 0 when none */
    vbi_exr_image first;    /* the first tile, kept for its attributes */
    summed sums[64];
    uint32_t nsums;
    double rays;
    int passes;
} tile_set;

static void tile_set_free(tile_set *t)
{
    for (uint32_t c = 0; c < t->channels; ++c) {
        free(t->channel ? t->channel[c] : NULL);
        free(t->plane ? t->plane[c] : NULL);
    }
    free(t->channel);
    free(t->plane);
    free(t->owner);
    vbi_exr_image_free(&t->first);
}

static void add_sum(tile_set *t, const char *name, double v)
{
    for (uint32_t i = 0; i < t->nsums; ++i)
        if (!strcmp(t->sums[i].name, name)) {
            t->sums[i].value += v;
            return;
        }
    if (t->nsums < sizeof(t->sums) / sizeof(t->sums[0])) {
        snprintf(t->sums[t->nsums].name, sizeof(t->sums[0].name), "%s", name);
        t->sums[t->nsums++].value = v;
    }
}

/* The stage seconds and work counts of a tile, summed: vbnl/time/<stage>, vbnl/<unit>/<stage>. */
static void add_stage_figures(tile_set *t, const vbi_exr_image *img)
{
    for (uint32_t i = 0; i < img->attr_count; ++i) {
        const vbi_image_attr *a = &img->attrs[i];
        if (strncmp(a->name, "vbnl/", 5) || strchr(a->name + 5, '/') == NULL || a->type != VBI_IMAGE_ATTR_DOUBLE)
            continue;
        if (!strncmp(a->name, "vbnl/lights/", 12) || !strncmp(a->name, "vbnl/budget/", 12) ||
            strstr(a->name, "_per_second/"))
            continue;
        add_sum(t, a->name, a->value.d);
    }
}

/* The parameters text of a tile without the light file it loaded (vbnl/lights/files): what the
 * same render on one machine writes. */
static void single_parameters(const vbi_exr_image *first, char *out, size_t n)
{
    const vbi_image_attr *p = vbi_exr_image_attr(first, "vbnl/parameters");
    const vbi_image_attr *f = vbi_exr_image_attr(first, "vbnl/lights/files");
    snprintf(out, n, "%s", p && p->type == VBI_IMAGE_ATTR_STRING ? p->value.s : "");
    if (!f || f->type != VBI_IMAGE_ATTR_STRING)
        return;
    char token[4200];
    snprintf(token, sizeof(token), "load_lights=%s", f->value.s);
    size_t len = strlen(token);
    char *at = out;
    while ((at = strstr(at, token))) {
        int starts = at == out || at[-1] == ' ', ends = at[len] == ' ' || at[len] == '\0';
        if (!starts || !ends) {
            at += len;
            continue;
        }
        char *rest = at + len + (at[len] == ' ');
        memmove(at, rest, strlen(rest) + 1);
    }
    size_t l = strlen(out);
    while (l && out[l - 1] == ' ')
        out[--l] = '\0';
}

/* Adds one tile (read from `path`) to the set, checking it against the first. 0, or prints why. */
static int add_tile(tile_set *t, const char *path, const char *first_path, uint32_t index)
{
    vbi_exr_image img;
    vbnl_error err = {0};
    if (vbi_exr_read(path, &img, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl merge-tiles: %s\n", err.message);
        return VBI_EXIT_FAILURE;
    }
    int rc = VBI_EXIT_FAILURE;
    const int is_first = index == 0;
    const vbi_exr_image *ref = is_first ? &img : &t->first;
    if (!vbi_exr_image_attr(&img, "vbnl/version") || !vbi_exr_image_attr(&img, "vbnl/scene/fingerprint")) {
        fprintf(stderr, "vbnl merge-tiles: '%s' is not a part of a vbnl render (no vbnl/version or scene fingerprint)\n",
                path);
        goto done;
    }
    if (attr_number(&img, "vbnl/partial") != 0.0) {
        fprintf(stderr, "vbnl merge-tiles: '%s' is a partial render (interrupted: vbnl/partial = 1); render it again\n",
                path);
        goto done;
    }
    for (size_t k = 0; !is_first && k < N_SAME; ++k) {
        const vbi_image_attr *x = vbi_exr_image_attr(ref, same_attrs[k]), *y = vbi_exr_image_attr(&img, same_attrs[k]);
        /* the parameters without the light file's name: the lights are compared by fingerprint */
        vbi_image_attr px, py;
        char sx[4096], sy[4096];
        if (x && y && !strcmp(same_attrs[k], "vbnl/parameters")) {
            single_parameters(ref, sx, sizeof(sx));
            single_parameters(&img, sy, sizeof(sy));
            px = *x;
            py = *y;
            px.value.s = sx;
            py.value.s = sy;
            x = &px;
            y = &py;
        }
        if (!attr_equal(x, y)) {
            char tx[256], ty[256];
            attr_text(x, tx, sizeof(tx));
            attr_text(y, ty, sizeof(ty));
            fprintf(stderr,
                    "vbnl merge-tiles: '%s' has %s = %s, '%s' has %s: parts of one image come from one render "
                    "(the same scene, camera, lights, seed and options)\n",
                    path, same_attrs[k], ty, first_path, tx);
            goto done;
        }
    }
    if (img.display_width != ref->display_width || img.display_height != ref->display_height || img.display_x != 0 ||
        img.display_y != 0) {
        fprintf(stderr, "vbnl merge-tiles: '%s' is a part of a %ux%u image, '%s' of a %ux%u image\n", path,
                img.display_width, img.display_height, first_path, ref->display_width, ref->display_height);
        goto done;
    }
    if (img.data_x < 0 || img.data_y < 0 || (uint64_t)img.data_x + img.width > img.display_width ||
        (uint64_t)img.data_y + img.height > img.display_height) {
        fprintf(stderr, "vbnl merge-tiles: '%s': its data window reaches outside the image\n", path);
        goto done;
    }
    if (is_first) {
        t->w = img.display_width;
        t->h = img.display_height;
        t->channels = img.channel_count;
        t->channel = calloc(t->channels, sizeof(*t->channel));
        t->plane = calloc(t->channels, sizeof(*t->plane));
        t->owner = calloc((size_t)t->w * t->h, sizeof(*t->owner));
        if (!t->channel || !t->plane || !t->owner) {
            fprintf(stderr, "vbnl merge-tiles: out of memory for a %ux%u image\n", t->w, t->h);
            goto done;
        }
        for (uint32_t c = 0; c < t->channels; ++c) {
            t->channel[c] = strdup(img.channels[c].name);
            t->plane[c] = calloc((size_t)t->w * t->h, sizeof(float));
            if (!t->channel[c] || !t->plane[c]) {
                fprintf(stderr, "vbnl merge-tiles: out of memory for a %ux%u image\n", t->w, t->h);
                goto done;
            }
        }
    }
    if (img.channel_count != t->channels) {
        fprintf(stderr, "vbnl merge-tiles: '%s' has %u channels, '%s' %u\n", path, img.channel_count, first_path,
                t->channels);
        goto done;
    }
    for (uint32_t c = 0; c < t->channels; ++c)
        if (!vbi_exr_image_channel(&img, t->channel[c])) {
            fprintf(stderr, "vbnl merge-tiles: '%s' has no channel '%s' (which '%s' has)\n", path, t->channel[c],
                    first_path);
            goto done;
        }
    for (uint32_t y = 0; y < img.height; ++y)
        for (uint32_t x = 0; x < img.width; ++x) {
            size_t at = (size_t)(img.data_y + y) * t->w + (size_t)(img.data_x + x);
            if (t->owner[at]) {
                fprintf(stderr, "vbnl merge-tiles: tiles %u and %u ('%s') both hold pixel (%u, %u): tiles must not overlap\n",
                        t->owner[at], index + 1, path, (unsigned)(img.data_x + x), (unsigned)(img.data_y + y));
                goto done;
            }
            t->owner[at] = index + 1;
        }
    for (uint32_t c = 0; c < t->channels; ++c) {
        const vbi_exr_channel *ch = vbi_exr_image_channel(&img, t->channel[c]);
        for (uint32_t y = 0; y < img.height; ++y)
            memcpy(t->plane[c] + (size_t)(img.data_y + y) * t->w + img.data_x, ch->data + (size_t)y * img.width,
                   sizeof(float) * img.width);
    }
    t->rays += attr_number(&img, "vbnl/rays");
    t->passes = t->passes > (int)attr_number(&img, "vbnl/passes") ? t->passes : (int)attr_number(&img, "vbnl/passes");
    add_stage_figures(t, &img);
    t->tiles++;
    rc = 0;
done:
    if (is_first && rc == 0)
        t->first = img;
    else
        vbi_exr_image_free(&img);
    return rc;
}

/* The header of the joined image: a single render's attributes (deterministic ones from the
 * tiles, rays and stage figures summed over them, the preparation's from the light files), plus
 * the lights' own and vbnl/farm/tiles. */
typedef struct header_out {
    vbi_image_attr a[128];
    uint32_t n;
    char params[4096];
    char names[64][96];
} header_out;

static void build_header(const tile_set *t, header_out *ho)
{
    const vbi_exr_image *f = &t->first;
    ho->n = 0;
    single_parameters(f, ho->params, sizeof(ho->params));
    double prepare = 0.0, load = 0.0;
    for (uint32_t i = 0; i < t->nsums; ++i) {
        if (!strcmp(t->sums[i].name, "vbnl/time/prepare"))
            prepare = t->sums[i].value;
        if (!strcmp(t->sums[i].name, "vbnl/time/load"))
            load = t->sums[i].value;
    }
    const int has_lights = vbi_exr_image_attr(f, "vbnl/lights/fingerprint") != NULL;
    const double placement = attr_number(f, "vbnl/lights/time/placement");
    const double elimination = attr_number(f, "vbnl/lights/time/elimination");
    const double photons = attr_number(f, "vbnl/lights/time/photons");
    const double photon_rays = attr_number(f, "vbnl/lights/rays/photons");
    for (uint32_t i = 0; i < f->attr_count && ho->n < 100; ++i) {
        vbi_image_attr a = f->attrs[i];
        const char *name = a.name;
        if (strncmp(name, "vbnl/", 5) || !strcmp(name, "vbnl/crop") || !strcmp(name, "vbnl/time/load") || !strcmp(name, "vbnl/rays/load") ||
            !strncmp(name, "vbnl/rays_per_second/", 21))
            continue;
        if (!strcmp(name, "vbnl/parameters"))
            a.value.s = ho->params;
        else if (!strcmp(name, "vbnl/rays"))
            a.value.d = t->rays;
        else if (!strcmp(name, "vbnl/passes"))
            a.value.i = t->passes;
        else if (!strcmp(name, "vbnl/time/prepare"))
            a.value.d = prepare - load + (has_lights ? placement + elimination + photons : 0.0);
        else if (a.type == VBI_IMAGE_ATTR_DOUBLE && strncmp(name, "vbnl/lights/", 12))
            for (uint32_t k = 0; k < t->nsums; ++k)
                if (!strcmp(t->sums[k].name, name))
                    a.value.d = t->sums[k].value;
        if (a.type == VBI_IMAGE_ATTR_STRING || a.type == VBI_IMAGE_ATTR_INT || a.type == VBI_IMAGE_ATTR_FLOAT ||
            a.type == VBI_IMAGE_ATTR_DOUBLE)
            ho->a[ho->n++] = a;
    }
    /* the preparation's stages, as a single render reports them */
    uint32_t k = 0;
    if (has_lights) {
        const struct {
            const char *name;
            double v;
        } prep[] = {{"vbnl/time/placement", placement},
                    {"vbnl/time/elimination", elimination},
                    {"vbnl/time/photons", photons},
                    {"vbnl/rays/photons", photon_rays},
                    {"vbnl/rays_per_second/photons", photons > 0.0 ? photon_rays / photons : 0.0}};
        for (size_t i = 0; i < sizeof(prep) / sizeof(prep[0]); ++i) {
            snprintf(ho->names[k], sizeof(ho->names[k]), "%s", prep[i].name);
            ho->a[ho->n++] = (vbi_image_attr){ho->names[k++], VBI_IMAGE_ATTR_DOUBLE, {.d = prep[i].v}};
        }
    }
    /* rates of the summed stages (work over machine-seconds) */
    for (uint32_t i = 0; i < t->nsums && k + 1 < 64 && ho->n < 126; ++i) {
        const char *s = t->sums[i].name + 5, *slash = strchr(s, '/');
        if (!strncmp(s, "time/", 5) || !slash || !strcmp(slash + 1, "load"))
            continue;
        char seconds[96];
        snprintf(seconds, sizeof(seconds), "vbnl/time%s", slash);
        for (uint32_t j = 0; j < t->nsums; ++j)
            if (!strcmp(t->sums[j].name, seconds) && t->sums[j].value > 0.0) {
                snprintf(ho->names[k], sizeof(ho->names[k]), "vbnl/%.*s_per_second%s", (int)(slash - s), s, slash);
                ho->a[ho->n++] = (vbi_image_attr){ho->names[k++], VBI_IMAGE_ATTR_DOUBLE,
                                                   {.d = t->sums[i].value / t->sums[j].value}};
            }
    }
    ho->a[ho->n++] = (vbi_image_attr){"vbnl/farm/tiles", VBI_IMAGE_ATTR_INT, {.i = (int32_t)t->tiles}};
}

enum { MT_OUTPUT, MT_HELP };

static int on_mt_option(void *user, int id, const char *v)
{
    const char **out = user;
    if (id == MT_OUTPUT)
        out[0] = v;
    else
        out[1] = "help";
    return 0;
}

int cmd_merge_tiles(int argc, char **argv)
{
    static const char usage[] =
        "usage: vbnl merge-tiles T1.exr T2.exr ... -o OUT.exr [--png OUT.png] [--png-bits 8|16]\n"
        "                        [--display D --view V --ocio CONFIG --exposure STOPS] [--half] [-q]\n"
        "\n"
        "Joins the EXRs of crop renders of one image (`vbnl render --crop`: each holds its window) into\n"
        "the whole image, with the header a single render writes; the PNG as `vbnl render --png` writes\n"
        "it. Refuses tiles of another render (scene, camera, lights, seed, options), overlapping tiles\n"
        "and pixels no tile holds.";
    /* the tiles are the positional arguments: collect them apart from the options */
    char **opts = malloc(sizeof(char *) * (size_t)(argc + 1));
    const char **tiles = malloc(sizeof(char *) * (size_t)(argc + 1));
    if (!opts || !tiles) {
        free(opts);
        free(tiles);
        return VBI_EXIT_FAILURE;
    }
    int no = 1;
    uint32_t nt = 0;
    opts[0] = argv[0];
    static const char *const with_value[] = {"-o", "--output", "--png", "--png-bits", "--display",
                                             "--view", "--ocio", "--exposure", NULL};
    for (int i = 1; i < argc; ++i) {
        if (argv[i][0] != '-' || !argv[i][1]) {
            tiles[nt++] = argv[i];
            continue;
        }
        opts[no++] = argv[i];
        for (const char *const *w = with_value; *w; ++w)
            if (!strcmp(argv[i], *w) && i + 1 < argc)
                opts[no++] = argv[++i];
    }
    const char *own_out[2] = {NULL, NULL};
    static const farm_option own[] = {{"-o", 1, MT_OUTPUT}, {"--output", 1, MT_OUTPUT}, {"--help", 0, MT_HELP},
                                      {"-h", 0, MT_HELP},   {NULL, 0, 0}};
    farm_args a;
    int rc = farm_args_parse(&a, no, opts, "vbnl merge-tiles", FARM_OPT_VIEW | FARM_OPT_OUTPUT | FARM_OPT_QUIET, own,
                             on_mt_option, own_out);
    tile_set t;
    memset(&t, 0, sizeof(t));
    char msg[2048];
    if (rc)
        goto out;
    if (own_out[1]) {
        printf("%s\n", usage);
        goto out;
    }
    a.exr = own_out[0];
    rc = VBI_EXIT_USAGE;
    if (!a.exr || nt == 0) {
        fprintf(stderr, "vbnl merge-tiles: give the tiles and -o OUT.exr\n%s\n", usage);
        goto out;
    }
    if (nt > MAX_PARTS) {
        fprintf(stderr, "vbnl merge-tiles: more than %d tiles\n", MAX_PARTS);
        goto out;
    }
    const char *outs[2] = {a.exr, a.png};
    for (int o = 0; o < 2; ++o)
        for (uint32_t i = 0; outs[o] && i < nt; ++i)
            if (cli_same_file(outs[o], tiles[i])) {
                fprintf(stderr, "vbnl merge-tiles: '%s' is the tile '%s'; an output never replaces an input\n",
                        outs[o], tiles[i]);
                goto out;
            }
    if (a.png && cli_same_file(a.exr, a.png)) {
        fprintf(stderr, "vbnl merge-tiles: -o and --png name the same file '%s'\n", a.png);
        goto out;
    }
    rc = VBI_EXIT_FAILURE;
    for (int o = 0; o < 2; ++o)
        if (outs[o] && module_api()->check_writable(outs[o], msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
            fprintf(stderr, "vbnl merge-tiles: %s\n", msg);
            goto out;
        }
    if (a.png) { /* an unknown display or view is refused before the tiles are read */
        float probe[4] = {0.5f, 0.5f, 0.5f, 1.0f};
        if (module_write_png(NULL, probe, 1, 1, &a.view, msg, sizeof(msg)) != VBNL_OK) {
            fprintf(stderr, "vbnl merge-tiles: %s\n", msg);
            rc = VBI_EXIT_USAGE;
            goto out;
        }
    }
    farm_on_signals();
    double t0 = farm_now();
    for (uint32_t i = 0; i < nt; ++i)
        if ((rc = add_tile(&t, tiles[i], tiles[0], i)) != 0)
            goto out;
    /* every pixel in exactly one tile */
    uint64_t covered = 0, first_hole = UINT64_MAX;
    for (uint64_t p = 0; p < (uint64_t)t.w * t.h; ++p) {
        if (t.owner[p])
            ++covered;
        else if (first_hole == UINT64_MAX)
            first_hole = p;
    }
    if (covered != (uint64_t)t.w * t.h) {
        fprintf(stderr,
                "vbnl merge-tiles: the %u tiles hold %" PRIu64 " of the %ux%u pixels (pixel (%" PRIu64 ", %" PRIu64
                ") is in none): a tile is missing\n",
                nt, covered, t.w, t.h, first_hole % t.w, first_hole / t.w);
        rc = VBI_EXIT_FAILURE;
        goto out;
    }
    header_out ho;
    build_header(&t, &ho);
    /* one 1-channel layer per channel: "R" is the beauty's, "albedo.G" the albedo layer's */
    vbi_image_layer *layers = calloc(t.channels, sizeof(*layers));
    char (*prefix)[256] = calloc(t.channels, sizeof(*prefix));
    const char **suffix = calloc(t.channels, sizeof(*suffix));
    vbnl_error err = {0};
    vbnl_result res = layers && prefix && suffix ? VBNL_OK : VBNL_ERR_OUT_OF_MEMORY;
    for (uint32_t c = 0; res == VBNL_OK && c < t.channels; ++c) {
        const char *dot = strrchr(t.channel[c], '.');
        snprintf(prefix[c], sizeof(prefix[c]), "%.*s", dot ? (int)(dot - t.channel[c]) : 0, t.channel[c]);
        suffix[c] = dot ? dot + 1 : t.channel[c];
        layers[c] = (vbi_image_layer){prefix[c], 1, &suffix[c], t.plane[c]};
    }
    if (res == VBNL_OK)
        res = vbi_exr_write(a.exr, t.w, t.h, layers, t.channels, ho.a, ho.n, a.half, &err);
    else
        vbnl_error_set(&err, res, "out of memory");
    free(layers);
    free(prefix);
    free(suffix);
    if (res != VBNL_OK) {
        fprintf(stderr, "vbnl merge-tiles: %s\n", err.message);
        rc = VBI_EXIT_FAILURE;
        goto out;
    }
    if (a.png) {
        /* RGBA of the beauty channels, through the view: what `vbnl render --png` writes */
        float *rgba = calloc((size_t)t.w * t.h * 4, sizeof(float));
        static const char *const rgba_names[4] = {"R", "G", "B", "A"};
        res = rgba ? VBNL_OK : VBNL_ERR_OUT_OF_MEMORY;
        snprintf(msg, sizeof(msg), "out of memory");
        for (int k = 0; res == VBNL_OK && k < 4; ++k) {
            uint32_t c = 0;
            while (c < t.channels && strcmp(t.channel[c], rgba_names[k]))
                ++c;
            if (c == t.channels) {
                snprintf(msg, sizeof(msg), "the tiles have no channel '%s' for the PNG", rgba_names[k]);
                res = VBNL_ERR_INVALID_ARGUMENT;
                break;
            }
            for (size_t p = 0; p < (size_t)t.w * t.h; ++p)
                rgba[4 * p + k] = t.plane[c][p];
        }
        if (res == VBNL_OK)
            res = module_write_png(a.png, rgba, t.w, t.h, &a.view, msg, sizeof(msg));
        free(rgba);
        if (res != VBNL_OK) {
            fprintf(stderr, "vbnl merge-tiles: %s\n", msg);
            rc = VBI_EXIT_FAILURE;
            goto out;
        }
    }
    if (!a.quiet)
        fprintf(stderr, "vbnl merge-tiles: %u tiles, %ux%u pixels -> %s%s%s (%.2f s)\n", nt, t.w, t.h, a.exr,
                a.png ? ", " : "", a.png ? a.png : "", farm_now() - t0);
    rc = VBI_EXIT_OK;
out:
    tile_set_free(&t);
    free(opts);
    free(tiles);
    return rc;
}
