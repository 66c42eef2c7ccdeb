/* The preparation of a frame split into jobs (docs/farm.md):
 *
 *   vbnl prepare SCENE [scene options] -o PLACEMENT.vls
 *       placement and elimination once (the `vbnl` integrator's placement_only): the set without
 *       photons, and no image;
 *   vbnl photons SCENE [scene options] --placement PLACEMENT.vls (--part K/N | --range FIRST,COUNT)
 *                -o PART.vls
 *       one range of the photon paths traced on that set (load_lights with photon_first and
 *       photon_count); `vbnl merge-lights` sums the parts.
 *
 * The scene options are `vbnl render`'s that the scene and its preparation depend on (farm_args.h):
 * every job of a frame must get the same ones, which the files check (image size, camera, seed,
 * preparation parameters). */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "farm_args.h"
#include "module.h"
#include "vl_file_tools.h"

enum { STAGE_OUTPUT, STAGE_PLACEMENT, STAGE_PART, STAGE_RANGE, STAGE_HELP };

typedef struct stage_opts {
    const char *cmd;
    const char *out, *placement, *part, *range;
    int help;
} stage_opts;

static int on_stage_option(void *user, int id, const char *v)
{
    stage_opts *s = user;
    switch (id) {
    case STAGE_OUTPUT: s->out = v; break;
    case STAGE_PLACEMENT: s->placement = v; break;
    case STAGE_PART: s->part = v; break;
    case STAGE_RANGE: s->range = v; break;
    case STAGE_HELP: s->help = 1; break;
    }
    return 0;
}

static const farm_option stage_options[] = {
    {"-o", 1, STAGE_OUTPUT},   {"--output", 1, STAGE_OUTPUT}, {"--placement", 1, STAGE_PLACEMENT},
    {"--part", 1, STAGE_PART}, {"--range", 1, STAGE_RANGE},   {"--help", 0, STAGE_HELP},
    {"-h", 0, STAGE_HELP},     {NULL, 0, 0}};

static const char scene_options_help[] =
    "scene options, as `vbnl render` takes them (every job of a frame must get the same ones):\n"
    "  --integrator NAME  --set KEY=VALUE  --width W  --height H  --seed S  --threads N\n"
    "  --camera px,py,pz,tx,ty,tz,fov  --declare NAME=VALUE  --include-dir DIR  --read-dir DIR\n"
    "  --write-dir DIR  --builtin NAME=VALUE (POV-Ray's animation identifiers)  -q, --quiet\n"
    "  (--spp and --sampler are taken too, and change nothing here)\n";

/* Runs the preparation of a configured renderer, which it destroys; prints what it took. */
static int run_prepare(vbnl_plugin_renderer *r, const char *cmd, int quiet)
{
    const vbnl_plugin_api *api = module_api();
    char msg[2048];
    int rc = VBI_EXIT_OK;
    farm_on_signals(); /* a cancelled job leaves no half-written light file */
    vbnl_plugin_result res = api->prepare(r, NULL, NULL, msg, sizeof(msg));
    vbnl_plugin_stats st = {.size = sizeof(st)};
    if (res != VBNL_PLUGIN_OK) {
        fprintf(stderr, "%s: %s\n", cmd, msg);
        rc = VBI_EXIT_FAILURE;
    } else if (!quiet && api->get_stats(r, &st, msg, sizeof(msg)) == VBNL_PLUGIN_OK) {
        fprintf(stderr, "%s: prepared in %.2f s on %u threads\n", cmd, st.prepare_seconds, st.threads);
    }
    api->renderer_destroy(r);
    return rc;
}

/* Parses the options common to both stages; 0 or an exit code (-1: help printed, exit 0). */
static int stage_parse(farm_args *a, stage_opts *so, int argc, char **argv, const char *usage)
{
    /* the options that shade only (--spp, --sampler) are taken and change nothing here, so that
     * every stage of a frame can be given one list of options */
    int rc = farm_args_parse(a, argc, argv, so->cmd, FARM_OPT_SCENE | FARM_OPT_RENDER | FARM_OPT_QUIET, stage_options,
                             on_stage_option, so);
    if (rc)
        return rc;
    if (so->help) {
        printf("%s\n%s", usage, scene_options_help);
        return -1;
    }
    if (!a->scene || !so->out) {
        fprintf(stderr, "%s: give a scene FILE and -o OUT.vls\n%s\n", so->cmd, usage);
        return VBI_EXIT_USAGE;
    }
    if (cli_same_file(so->out, a->scene)) {
        fprintf(stderr, "%s: -o '%s' is the scene file; an output never replaces an input\n", so->cmd, so->out);
        return VBI_EXIT_USAGE;
    }
    char msg[2048];
    if (module_api()->check_writable(so->out, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        fprintf(stderr, "%s: %s\n", so->cmd, msg);
        return VBI_EXIT_FAILURE;
    }
    return 0;
}

/* The renderer of a stage: the scene loaded with the options, the integrator checked to be vbnl,
 * then configured again with the stage's own parameters `extra`. 0, or an exit code after
 * printing why. */
static int stage_renderer(const farm_args *a, const char *cmd, const char *const *extra, uint32_t n,
                          vbnl_plugin_renderer **out)
{
    int rc = farm_args_renderer(a, cmd, NULL, 0, NULL, out);
    if (rc)
        return rc;
    const vbnl_render_settings *s = module_renderer_settings(*out);
    if (!s || !s->integrator || strcmp(s->integrator, "vbnl")) {
        fprintf(stderr,
                "%s: the integrator is '%s': only 'vbnl' prepares virtual lights (choose it with --integrator vbnl; "
                "the tiles of the other integrators need no preparation)\n",
                cmd, s && s->integrator ? s->integrator : "?");
        rc = VBI_EXIT_USAGE;
    }
    char msg[2048];
    for (uint32_t i = 0; !rc && i < n; ++i)
        if (module_api()->set_param(*out, extra[i], cmd, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
            fprintf(stderr, "%s: %s\n", cmd, msg);
            rc = VBI_EXIT_USAGE;
        }
    if (!rc && module_api()->configure(*out, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        fprintf(stderr, "%s: %s\n", cmd, msg);
        rc = VBI_EXIT_USAGE;
    }
    if (rc) {
        module_api()->renderer_destroy(*out);
        *out = NULL;
    }
    return rc;
}

int cmd_prepare(int argc, char **argv)
{
    static const char usage[] = "usage: vbnl prepare SCENE [scene options] -o PLACEMENT.vls\n"
                                "\n"
                                "Placement and elimination of the `vbnl` integrator, once: the virtual lights without\n"
                                "photons (a placement), for `vbnl photons` jobs to trace their photon ranges on.";
    farm_args a;
    stage_opts so = {.cmd = "vbnl prepare"};
    int rc = stage_parse(&a, &so, argc, argv, usage);
    if (rc)
        return rc < 0 ? VBI_EXIT_OK : rc;
    if (so.placement || so.part || so.range) {
        fprintf(stderr, "vbnl prepare: --placement, --part and --range are options of `vbnl photons`\n");
        return VBI_EXIT_USAGE;
    }
    char save[4200];
    snprintf(save, sizeof(save), "save_lights=%s", so.out);
    const char *extra[] = {"placement_only=on", save};
    vbnl_plugin_renderer *r;
    if ((rc = stage_renderer(&a, so.cmd, extra, 2, &r)) != 0)
        return rc;
    rc = run_prepare(r, so.cmd, a.quiet);
    if (!rc && !a.quiet) {
        vbi_vl_file_header h;
        if (vbi_vl_file_read_header(so.out, 0, &h, NULL) == VBNL_OK)
            fprintf(stderr, "vbnl prepare: %u virtual lights (%u asked) for %" PRIu64 " photon paths -> %s\n", h.count,
                    h.virtual_lights, h.photon_paths, so.out);
    }
    return rc;
}

/* "K/N": part K (0-based) of N equal parts of `paths`; "FIRST,COUNT". 0, or prints why. */
static int photon_range(const stage_opts *so, uint64_t paths, uint64_t *first, uint64_t *count)
{
    char extra;
    if (so->part) {
        unsigned long long k, n;
        if (sscanf(so->part, "%llu/%llu%c", &k, &n, &extra) != 2 || strchr(so->part, '-') || n == 0 || k >= n) {
            fprintf(stderr, "vbnl photons: --part takes K/N with 0 <= K < N, got '%s'\n", so->part);
            return VBI_EXIT_USAGE;
        }
        if (n > paths) {
            fprintf(stderr, "vbnl photons: --part %s: %llu parts of %" PRIu64 " photon paths leave parts empty\n",
                    so->part, n, paths);
            return VBI_EXIT_USAGE;
        }
        /* floor(k P / N) .. floor((k+1) P / N): the parts tile [0, P) exactly (128-bit products) */
        *first = (uint64_t)((unsigned __int128)paths * k / n);
        *count = (uint64_t)((unsigned __int128)paths * (k + 1) / n) - *first;
        return 0;
    }
    unsigned long long f, c;
    if (sscanf(so->range, "%llu,%llu%c", &f, &c, &extra) != 2 || strchr(so->range, '-') || c == 0 || f >= paths ||
        c > paths - f) {
        fprintf(stderr,
                "vbnl photons: --range takes FIRST,COUNT with COUNT >= 1 inside the %" PRIu64
                " photon paths, got '%s'\n",
                paths, so->range);
        return VBI_EXIT_USAGE;
    }
    *first = f;
    *count = c;
    return 0;
}

int cmd_photons(int argc, char **argv)
{
    static const char usage[] =
        "usage: vbnl photons SCENE [scene options] --placement PLACEMENT.vls (--part K/N | --range FIRST,COUNT)\n"
        "                    -o PART.vls\n"
        "\n"
        "Traces one range of the photon paths on a placement of `vbnl prepare`: part K (0-based) of N\n"
        "equal parts, or the paths [FIRST, FIRST + COUNT). `vbnl merge-lights` sums the parts.";
    farm_args a;
    stage_opts so = {.cmd = "vbnl photons"};
    int rc = stage_parse(&a, &so, argc, argv, usage);
    if (rc)
        return rc < 0 ? VBI_EXIT_OK : rc;
    if (!so.placement || !so.part == !so.range) {
        fprintf(stderr, "vbnl photons: give --placement FILE and one of --part K/N or --range FIRST,COUNT\n%s\n", usage);
        return VBI_EXIT_USAGE;
    }
    if (cli_same_file(so.out, so.placement)) {
        fprintf(stderr, "vbnl photons: -o '%s' is the placement; an output never replaces an input\n", so.out);
        return VBI_EXIT_USAGE;
    }
    vbi_vl_file_header h;
    vbnl_error err = {0};
    if (vbi_vl_file_read_header(so.placement, 0, &h, &err) != VBNL_OK) {
        fprintf(stderr, "vbnl photons: %s\n", err.message);
        return VBI_EXIT_FAILURE;
    }
    uint64_t first, count;
    if ((rc = photon_range(&so, h.photon_paths, &first, &count)) != 0)
        return rc;
    char load[4200], save[4200], pf[64], pc[64];
    snprintf(load, sizeof(load), "load_lights=%s", so.placement);
    snprintf(save, sizeof(save), "save_lights=%s", so.out);
    snprintf(pf, sizeof(pf), "photon_first=%" PRIu64, first);
    snprintf(pc, sizeof(pc), "photon_count=%" PRIu64, count);
    const char *extra[] = {load, save, pf, pc};
    vbnl_plugin_renderer *r;
    if ((rc = stage_renderer(&a, so.cmd, extra, 4, &r)) != 0)
        return rc;
    rc = run_prepare(r, so.cmd, a.quiet);
    if (!rc && !a.quiet)
        fprintf(stderr, "vbnl photons: paths [%" PRIu64 ", %" PRIu64 ") of %" PRIu64 " -> %s\n", first, first + count,
                h.photon_paths, so.out);
    return rc;
}
