/* `vbnl farm`: one frame, or an animation, over a Slurm cluster (docs/farm.md).
 *
 * The front end loads and checks the scene with the render options given (nothing is submitted
 * when it cannot), writes one job script per stage into the work folder and submits them with
 * sbatch as a chain of job arrays, each element of a stage waiting for the whole previous stage
 * (--dependency=afterok, with --kill-on-invalid-dep so that a failed stage cancels the rest):
 *
 *   prepare       vbnl prepare       placement and elimination, once per frame        F jobs
 *   photons       vbnl photons       photon part k of P on that placement             F x P
 *   merge-lights  vbnl merge-lights  the parts summed into one light file             F
 *   tiles         vbnl render --crop the tile's window, loading the light file        F x T
 *   merge         vbnl merge-tiles   the tiles joined into OUT.exr and OUT.png        F
 *
 * Integrators other than `vbnl` prepare nothing to share: their graph is tiles and merge only.
 * Every array element runs its command again, up to --retries times, when it fails (not for a bad
 * command line, exit status 2, nor after a cancel, 130); Slurm requeues elements of a failed node
 * (--requeue). The merged image is the single-machine render's, bit for bit: every part is a
 * deterministic function of the scene, the options and the seed (docs/farm.md, "Exactness").
 *
 * Animations follow POV-Ray 3.7's frame options (Initial_Frame, Final_Frame, Initial_Clock,
 * Final_Clock, Cyclic_Animation, Subset_Start_Frame, Subset_End_Frame) as `vbnl`'s POV-Ray
 * command line reads them (plugin/host/pov_cli.c), so that a frame is the one
 * `vbnl scene.pov +KFI.. +KFF..` renders: frame f has
 *   clock = initial_clock + clock_delta (f - initial_frame),
 *   clock_delta = (final_clock - initial_clock) / (final_frame - initial_frame),
 * a cyclic animation counts one frame more (final_frame + 1) and renders up to final_frame, the
 * outputs carry the frame number before their extension, zero-padded to the digits of the last
 * counted frame (out.exr -> out07.exr), and the frames are elements of the same arrays. Every
 * stage of a frame gets POV-Ray's eight animation identifiers as `--builtin NAME=VALUE`. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <dlfcn.h>
#include <errno.h>
#include <inttypes.h>
#include <libgen.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cli.h"
#include "commands.h"
#include "farm_args.h"
#include "module.h"

#define MAX_FRAMES 100000
#define MAX_JOBS 16

enum {
    F_PHOTON_JOBS, F_TILES, F_WORK, F_NAME, F_PARTITION, F_CPUS, F_RETRIES, F_SBATCH_ARG, F_INITIAL_FRAME,
    F_FINAL_FRAME, F_INITIAL_CLOCK, F_FINAL_CLOCK, F_CYCLIC, F_SUBSET_START, F_SUBSET_END, F_DRY_RUN, F_LOCAL,
    F_WAIT, F_VBNL, F_SBATCH, F_SQUEUE, F_SCONTROL, F_CLOCK, F_HELP
};

static const farm_option farm_options[] = {
    {"--photon-jobs", 1, F_PHOTON_JOBS},  {"--tiles", 1, F_TILES},
    {"--work", 1, F_WORK},                {"--name", 1, F_NAME},
    {"--partition", 1, F_PARTITION},      {"--cpus-per-task", 1, F_CPUS},
    {"--retries", 1, F_RETRIES},          {"--sbatch-arg", 1, F_SBATCH_ARG},
    {"--initial-frame", 1, F_INITIAL_FRAME}, {"--final-frame", 1, F_FINAL_FRAME},
    {"--initial-clock", 1, F_INITIAL_CLOCK}, {"--final-clock", 1, F_FINAL_CLOCK},
    {"--cyclic", 0, F_CYCLIC},            {"--subset-start", 1, F_SUBSET_START},
    {"--subset-end", 1, F_SUBSET_END},    {"--dry-run", 0, F_DRY_RUN},
    {"--local", 0, F_LOCAL},              {"--wait", 0, F_WAIT},
    {"--vbnl", 1, F_VBNL},                {"--sbatch", 1, F_SBATCH},
    {"--squeue", 1, F_SQUEUE},            {"--scontrol", 1, F_SCONTROL},
    {"--clock", 1, F_CLOCK},
    {"--help", 0, F_HELP},                {"-h", 0, F_HELP},
    {NULL, 0, 0}};

static const char farm_usage[] =
    "usage: vbnl farm SCENE -o OUT.exr [--png OUT.png] [render options] [farm options]\n"
    "\n"
    "Renders SCENE over a Slurm cluster: the render options are `vbnl render`'s (not --crop, --time,\n"
    "--save-lights, --load-lights), and the image equals `vbnl render` with them, bit for bit.\n"
    "The scene is loaded and checked first: nothing is submitted when it cannot be rendered.\n"
    "\n"
    "  --photon-jobs N        photon jobs per frame (vbnl; default 4)\n"
    "  --tiles N | CxR        tiles per frame (default 4: 2x2)\n"
    "  --work DIR             job scripts, logs and parts (default OUT.farm beside OUT.exr);\n"
    "                         on a folder every node sees, as the scene and the outputs\n"
    "  --name NAME            job names vbnl-NAME-<stage> (default: OUT's name)\n"
    "  --partition P, --cpus-per-task N, --sbatch-arg ARG (repeatable): passed to sbatch\n"
    "  --retries N            runs again a failed job element up to N times (default 2)\n"
    "  --initial-frame N --final-frame N --initial-clock C --final-clock C --cyclic\n"
    "  --subset-start N --subset-end N    an animation, as POV-Ray's frame options\n"
    "  --clock C              the clock of a still image (POV-Ray's +K)\n"
    "  --wait                 wait for the jobs, reporting progress; exit 0 when the image is written\n"
    "  --dry-run              write the job scripts and print the sbatch commands, submit nothing\n"
    "  --local                run the job scripts here, one after another, without Slurm\n"
    "  --vbnl PATH            the vbnl program the jobs run (default: this one)\n"
    "  --sbatch, --squeue, --scontrol PATH   Slurm's programs (default: from PATH)\n";

typedef struct farm {
    farm_args a;
    uint32_t photon_jobs, tiles_x, tiles_y, cpus, retries;
    const char *work_arg, *name_arg, *partition;
    const char *sbatch_args[64];
    uint32_t n_sbatch_args;
    int64_t initial_frame, final_frame, subset_start, subset_end;
    double initial_clock, final_clock, still_clock;
    int frames_given, subset_end_given, cyclic, animated, still_clock_given, dry_run, local, wait, help;
    const char *vbnl_arg, *sbatch, *squeue, *scontrol;
    /* resolved */
    char vbnl[PATH_MAX], plugin[PATH_MAX], scene[PATH_MAX], exr[PATH_MAX], png[PATH_MAX], work[PATH_MAX];
    char name[128];
    int lights; /* the vbnl integrator: prepare, photons, merge-lights */
    uint64_t photon_paths;
    uint32_t frames;
    int64_t *frame;       /* frame numbers */
    double *clock;
    int64_t counted_final; /* final_frame as the identifiers say it (+ 1 when cyclic) */
    double clock_delta;
    int digits;
} farm;

static int parse_i64(const char *s, int64_t *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || *end || end == s)
        return -1;
    *out = v;
    return 0;
}

static int parse_count(const char *s, uint32_t *out, uint32_t min, uint32_t max)
{
    int64_t v;
    if (parse_i64(s, &v) || v < min || v > max)
        return -1;
    *out = (uint32_t)v;
    return 0;
}

static int on_farm_option(void *user, int id, const char *v)
{
    farm *f = user;
    char *end;
    switch (id) {
    case F_PHOTON_JOBS:
        if (parse_count(v, &f->photon_jobs, 1, 100000)) {
            fprintf(stderr, "vbnl farm: --photon-jobs takes 1..100000, got '%s'\n", v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case F_TILES: {
        unsigned c, r;
        char extra;
        if (sscanf(v, "%ux%u%c", &c, &r, &extra) == 2 && c >= 1 && r >= 1 && c <= 65536 && r <= 65536) {
            f->tiles_x = c;
            f->tiles_y = r;
            return 0;
        }
        uint32_t n;
        if (parse_count(v, &n, 1, 1u << 20)) {
            fprintf(stderr, "vbnl farm: --tiles takes N or CxR (columns x rows), got '%s'\n", v);
            return VBI_EXIT_USAGE;
        }
        /* the grid closest to square: rows the largest divisor of n not above its square root */
        uint32_t rows = 1;
        for (uint32_t d = 1; (uint64_t)d * d <= n; ++d)
            if (n % d == 0)
                rows = d;
        f->tiles_x = n / rows;
        f->tiles_y = rows;
        return 0;
    }
    case F_WORK: f->work_arg = v; return 0;
    case F_NAME: f->name_arg = v; return 0;
    case F_PARTITION: f->partition = v; return 0;
    case F_CPUS:
        if (parse_count(v, &f->cpus, 1, 4096)) {
            fprintf(stderr, "vbnl farm: --cpus-per-task takes 1..4096, got '%s'\n", v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case F_RETRIES:
        if (parse_count(v, &f->retries, 0, 100)) {
            fprintf(stderr, "vbnl farm: --retries takes 0..100, got '%s'\n", v);
            return VBI_EXIT_USAGE;
        }
        return 0;
    case F_SBATCH_ARG:
        if (f->n_sbatch_args == sizeof(f->sbatch_args) / sizeof(f->sbatch_args[0])) {
            fprintf(stderr, "vbnl farm: too many --sbatch-arg\n");
            return VBI_EXIT_USAGE;
        }
        f->sbatch_args[f->n_sbatch_args++] = v;
        return 0;
    case F_INITIAL_FRAME:
    case F_FINAL_FRAME:
    case F_SUBSET_START:
    case F_SUBSET_END: {
        int64_t *dst = id == F_INITIAL_FRAME ? &f->initial_frame
                       : id == F_FINAL_FRAME ? &f->final_frame
                       : id == F_SUBSET_START ? &f->subset_start
                                              : &f->subset_end;
        if (parse_i64(v, dst) || *dst < 0 || *dst > 1000000000) {
            fprintf(stderr,
                    "vbnl farm: frame numbers are whole numbers >= 0 (POV-Ray's fractional subsets are not taken), "
                    "got '%s'\n",
                    v);
            return VBI_EXIT_USAGE;
        }
        f->frames_given |= id == F_INITIAL_FRAME || id == F_FINAL_FRAME;
        f->subset_end_given |= id == F_SUBSET_END;
        return 0;
    }
    case F_INITIAL_CLOCK:
    case F_FINAL_CLOCK: {
        double c = strtod(v, &end);
        if (*end || end == v || !isfinite(c)) {
            fprintf(stderr, "vbnl farm: a clock takes a number, got '%s'\n", v);
            return VBI_EXIT_USAGE;
        }
        *(id == F_INITIAL_CLOCK ? &f->initial_clock : &f->final_clock) = c;
        return 0;
    }
    case F_CLOCK:
        f->still_clock = strtod(v, &end);
        if (*end || end == v || !isfinite(f->still_clock)) {
            fprintf(stderr, "vbnl farm: --clock takes a number, got '%s'\n", v);
            return VBI_EXIT_USAGE;
        }
        f->still_clock_given = 1;
        return 0;
    case F_CYCLIC: f->cyclic = 1; return 0;
    case F_DRY_RUN: f->dry_run = 1; return 0;
    case F_LOCAL: f->local = 1; return 0;
    case F_WAIT: f->wait = 1; return 0;
    case F_VBNL: f->vbnl_arg = v; return 0;
    case F_SBATCH: f->sbatch = v; return 0;
    case F_SQUEUE: f->squeue = v; return 0;
    case F_SCONTROL: f->scontrol = v; return 0;
    case F_HELP: f->help = 1; return 0;
    }
    return 0;
}

/* `p` made absolute (its folder canonical, the name kept). 0, or -1 when its folder does not exist. */
static int absolute(const char *p, char *out, size_t n)
{
    char a[PATH_MAX], b[PATH_MAX], dir[PATH_MAX];
    snprintf(a, sizeof(a), "%s", p);
    snprintf(b, sizeof(b), "%s", p);
    if (!realpath(dirname(a), dir))
        return -1;
    int len = snprintf(out, n, "%s/%s", dir, basename(b));
    return len < 0 || (size_t)len >= n ? -1 : 0;
}

/* `path` with the frame number inserted before its extension (POV-Ray's numbering). */
static void frame_path(const farm *f, const char *path, uint32_t i, char *out, size_t n)
{
    if (!f->animated) {
        snprintf(out, n, "%s", path);
        return;
    }
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    if (!dot || (slash && dot < slash))
        dot = path + strlen(path);
    snprintf(out, n, "%.*s%0*" PRId64 "%s", (int)(dot - path), path, f->digits, f->frame[i], dot);
}

/* The frames to render and their clocks, as `vbnl`'s POV-Ray command line plans them (see the file
 * comment): an animation unless the frames are left unset or 1 to 1. */
static int plan_frames(farm *f)
{
    const int64_t i0 = f->frames_given ? f->initial_frame : 0, f0 = f->frames_given ? f->final_frame : 0;
    f->animated = !((i0 == 0 && f0 == 0) || (i0 == 1 && f0 == 1));
    if (!f->animated) {
        f->frames = 1;
        f->frame = malloc(sizeof(int64_t));
        f->clock = malloc(sizeof(double));
        if (!f->frame || !f->clock)
            return VBI_EXIT_FAILURE;
        f->frame[0] = 1;
        f->clock[0] = f->still_clock;
        f->digits = 1;
        return 0;
    }
    if (f->still_clock_given || f->a.clock_given) {
        fprintf(stderr, "vbnl farm: --clock sets a still image's clock; an animation's come from --initial-clock and "
                        "--final-clock\n");
        return VBI_EXIT_USAGE;
    }
    const int64_t initial = f->initial_frame;
    int64_t final = f->final_frame < initial ? initial : f->final_frame;
    if (f->cyclic)
        final++; /* one frame more for the clock, one less rendered */
    int64_t first = f->subset_start >= initial ? f->subset_start : initial;
    int64_t last = f->subset_end_given ? f->subset_end : f->cyclic ? final - 1 : final;
    if (last < first)
        last = first;
    if (last - first + 1 > MAX_FRAMES) {
        fprintf(stderr, "vbnl farm: %" PRId64 " frames; at most %d per submission (use --subset-start/--subset-end)\n",
                last - first + 1, MAX_FRAMES);
        return VBI_EXIT_USAGE;
    }
    f->frames = (uint32_t)(last - first + 1);
    f->frame = malloc(sizeof(int64_t) * f->frames);
    f->clock = malloc(sizeof(double) * f->frames);
    if (!f->frame || !f->clock)
        return VBI_EXIT_FAILURE;
    f->counted_final = final;
    /* one frame from initial to final: no step of the clock */
    f->clock_delta = final > initial ? (f->final_clock - f->initial_clock) / (double)(final - initial) : 0.0;
    for (uint32_t i = 0; i < f->frames; ++i) {
        f->frame[i] = first + i;
        f->clock[i] = f->initial_clock + f->clock_delta * (double)(f->frame[i] - initial);
    }
    f->digits = 1;
    for (int64_t v = final; v >= 10; v /= 10)
        f->digits++;
    return 0;
}

/* POV-Ray's eight animation identifiers of frame i, "NAME=VALUE" (farm_builtins' order); the
 * number of them set (0 for a still image without a clock: all stay 0). */
static int frame_builtins(const farm *f, uint32_t i, char out[8][64])
{
    if (!f->animated && !f->still_clock_given)
        return 0;
    double v[8] = {0};
    v[0] = f->clock[i];
    v[2] = 1.0; /* clock_on */
    if (f->animated) {
        v[1] = f->clock_delta;
        v[3] = (double)f->frame[i];
        v[4] = f->initial_clock;
        v[5] = f->final_clock;
        v[6] = (double)f->initial_frame;
        v[7] = (double)f->counted_final;
    }
    for (int k = 0; k < 8; ++k)
        snprintf(out[k], 64, "%s=%.17g", farm_builtins[k], v[k]);
    return 8;
}

/* 1 when `vbnl render --help` lists --builtin (the tiles of an animation need it). */
static int render_takes_builtins(const farm *f)
{
    char *cmd = NULL;
    size_t len = 0;
    FILE *m = open_memstream(&cmd, &len);
    if (!m)
        return 0;
    farm_shell_word(m, f->vbnl);
    fputs(" --plugin ", m);
    farm_shell_word(m, f->plugin);
    fputs(" render --help 2>&1", m);
    fclose(m);
    FILE *p = popen(cmd, "r");
    free(cmd);
    if (!p)
        return 0;
    char line[512];
    int found = 0;
    while (fgets(line, sizeof(line), p))
        found |= strstr(line, "--builtin") != NULL;
    pclose(p);
    return found;
}

/* ---- checks before anything is written or submitted ----------------------------------------------- */

static int check_and_resolve(farm *f)
{
    const farm_args *a = &f->a;
    if (a->single) {
        fprintf(stderr,
                "vbnl farm: %s is an option of one render: the farm chooses the tiles, prepares and loads the "
                "lights itself, and a time budget would size each job apart (give --spp)\n",
                a->single);
        return VBI_EXIT_USAGE;
    }
    if (!a->scene || !a->exr) {
        fprintf(stderr, "vbnl farm: give a scene FILE and -o OUT.exr\n%s", farm_usage);
        return VBI_EXIT_USAGE;
    }
    if (f->local + f->dry_run + f->wait > 1) {
        fprintf(stderr, "vbnl farm: --dry-run, --local and --wait exclude each other\n");
        return VBI_EXIT_USAGE;
    }
    if (!realpath(a->scene, f->scene)) {
        fprintf(stderr, "vbnl farm: cannot read the scene '%s': %s\n", a->scene, strerror(errno));
        return VBI_EXIT_SCENE;
    }
    const char *outs[2] = {a->exr, a->png};
    char *abs_out[2] = {f->exr, f->png};
    for (int i = 0; i < 2; ++i)
        if (outs[i] && absolute(outs[i], abs_out[i], PATH_MAX)) {
            fprintf(stderr, "vbnl farm: cannot write '%s': its folder does not exist\n", outs[i]);
            return VBI_EXIT_FAILURE;
        }
    int rc = plan_frames(f);
    if (rc)
        return rc;
    /* the programs the jobs run: this vbnl (or --vbnl) and this module */
    Dl_info di;
    if (!dladdr((void *)module_api, &di) || !di.dli_fname || !realpath(di.dli_fname, f->plugin)) {
        fprintf(stderr, "vbnl farm: cannot find the plugin module's own path\n");
        return VBI_EXIT_FAILURE;
    }
    if (f->vbnl_arg ? !realpath(f->vbnl_arg, f->vbnl) : !realpath("/proc/self/exe", f->vbnl)) {
        fprintf(stderr, "vbnl farm: cannot find the vbnl program '%s': %s\n", f->vbnl_arg ? f->vbnl_arg : "/proc/self/exe",
                strerror(errno));
        return VBI_EXIT_USAGE;
    }
    /* outputs: never an input, never each other, writable (every frame's) */
    char msg[2048], p1[PATH_MAX + 32], p2[PATH_MAX + 32];
    for (uint32_t i = 0; i < f->frames; ++i) {
        frame_path(f, f->exr, i, p1, sizeof(p1));
        if (a->png)
            frame_path(f, f->png, i, p2, sizeof(p2));
        if (cli_same_file(p1, f->scene) || (a->png && cli_same_file(p2, f->scene))) {
            fprintf(stderr, "vbnl farm: an output is the scene file; an output never replaces an input\n");
            return VBI_EXIT_USAGE;
        }
        if (a->png && cli_same_file(p1, p2)) {
            fprintf(stderr, "vbnl farm: -o and --png name the same file '%s'; give each output its own\n", p1);
            return VBI_EXIT_USAGE;
        }
        if (module_api()->check_writable(p1, msg, sizeof(msg)) != VBNL_PLUGIN_OK ||
            (a->png && module_api()->check_writable(p2, msg, sizeof(msg)) != VBNL_PLUGIN_OK)) {
            fprintf(stderr, "vbnl farm: %s\n", msg);
            return VBI_EXIT_FAILURE;
        }
    }
    /* the scene, with the first frame's identifiers, and the options: what every job will load */
    farm_args first = *a;
    char builtins[8][64];
    for (int k = 0, nb = frame_builtins(f, 0, builtins); k < nb && first.nscene < FARM_MAX_SETS; ++k) {
        const char *eq = strchr(builtins[k], '=');
        first.scene_key[first.nscene] = farm_builtins[k];
        first.scene_value[first.nscene++] = eq + 1;
    }
    vbnl_plugin_renderer *r;
    if ((rc = farm_args_renderer(&first, "vbnl farm", NULL, 0, NULL, &r)) != 0)
        return rc;
    const vbnl_render_settings *s = module_renderer_settings(r);
    f->lights = s->integrator && !strcmp(s->integrator, "vbnl");
    static const char *const farm_params[] = {"save_lights", "load_lights", "placement_only", "photon_first",
                                              "photon_count", "reuse_lights"};
    for (size_t k = 0; k < sizeof(farm_params) / sizeof(farm_params[0]); ++k)
        if (f->lights && vbnl_params_has(s->params, farm_params[k])) {
            fprintf(stderr, "vbnl farm: the parameter %s is set (by --set or the scene); the farm sets it itself\n",
                    farm_params[k]);
            module_api()->renderer_destroy(r);
            return VBI_EXIT_USAGE;
        }
    if (f->lights) {
        const vbnl_integrator_class *c = vbnl_integrator_find("vbnl");
        f->photon_paths = (uint64_t)vbnl_params_number(s->params, c->params, c->param_count, "photon_paths");
    }
    module_api()->renderer_destroy(r);
    if (a->png) {
        float probe[4] = {0.5f, 0.5f, 0.5f, 1.0f};
        if (module_write_png(NULL, probe, 1, 1, &a->view, msg, sizeof(msg)) != VBNL_OK) {
            fprintf(stderr, "vbnl farm: %s\n", msg);
            return VBI_EXIT_USAGE;
        }
    }
    if (f->lights && f->photon_jobs > f->photon_paths) {
        fprintf(stderr, "vbnl farm: %u photon jobs for %" PRIu64 " photon paths would leave jobs empty\n",
                f->photon_jobs, f->photon_paths);
        return VBI_EXIT_USAGE;
    }
    if (f->tiles_x > a->o.width || f->tiles_y > a->o.height) {
        fprintf(stderr, "vbnl farm: a %ux%u grid of tiles does not fit the %ux%u image\n", f->tiles_x, f->tiles_y,
                a->o.width, a->o.height);
        return VBI_EXIT_USAGE;
    }
    if ((f->animated || f->still_clock_given) && !f->dry_run && !render_takes_builtins(f)) {
        fprintf(stderr, "vbnl farm: the program '%s' takes no --builtin, which the tiles of an animation need\n",
                f->vbnl);
        return VBI_EXIT_USAGE;
    }
    /* names and the work folder */
    char base[PATH_MAX];
    snprintf(base, sizeof(base), "%s", f->exr);
    char *dot = strrchr(base, '.');
    if (dot && dot > strrchr(base, '/'))
        *dot = '\0';
    if (f->work_arg) {
        if (mkdir(f->work_arg, 0777) != 0 && errno != EEXIST) {
            fprintf(stderr, "vbnl farm: cannot create the work folder '%s': %s\n", f->work_arg, strerror(errno));
            return VBI_EXIT_FAILURE;
        }
        if (!realpath(f->work_arg, f->work)) {
            fprintf(stderr, "vbnl farm: work folder '%s': %s\n", f->work_arg, strerror(errno));
            return VBI_EXIT_FAILURE;
        }
    } else if (snprintf(f->work, sizeof(f->work), "%s.farm", base) >= (int)sizeof(f->work)) {
        fprintf(stderr, "vbnl farm: path too long\n");
        return VBI_EXIT_FAILURE;
    }
    const char *nm = f->name_arg ? f->name_arg : strrchr(base, '/') + 1;
    size_t k = 0;
    for (const char *c = nm; *c && k + 1 < sizeof(f->name); ++c) /* job names: no spaces or shell words */
        f->name[k++] = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') || *c == '-' ||
                               *c == '_' || *c == '.'
                           ? *c
                           : '_';
    f->name[k] = '\0';
    return 0;
}

/* ---- the work folder and the job scripts --------------------------------------------------------- */

static int make_dir(const char *path)
{
    if (mkdir(path, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "vbnl farm: cannot create '%s': %s\n", path, strerror(errno));
        return -1;
    }
    return 0;
}

/* The per-frame folder: the work folder itself for one frame, frame<N> in it for an animation. */
static void frame_dir(const farm *f, uint32_t i, char *out, size_t n)
{
    if (f->animated)
        snprintf(out, n, "%s/frame%0*" PRId64, f->work, f->digits, f->frame[i]);
    else
        snprintf(out, n, "%s", f->work);
}

typedef struct stage {
    const char *name;   /* prepare, photons, merge-lights, tiles, merge */
    uint32_t per_frame; /* array elements per frame */
} stage;

/* Writes the lines every script starts with: the frame tables and the retry loop. */
static void script_head(const farm *f, FILE *s, const stage *st)
{
    fprintf(s, "#!/bin/bash\n# vbnl farm: stage '%s' of ", st->name);
    farm_shell_word(s, f->scene);
    fprintf(s, ",\n# written by `vbnl farm` (docs/farm.md); Slurm runs it as the elements of a job array.\n");
    fprintf(s, "set -u\nvbnl=");
    farm_shell_word(s, f->vbnl);
    fprintf(s, "\nplugin=");
    farm_shell_word(s, f->plugin);
    fprintf(s, "\nscene=");
    farm_shell_word(s, f->scene);
    fprintf(s, "\ni=${SLURM_ARRAY_TASK_ID:-0}\nper_frame=%u\nf=$((i / per_frame))\nk=$((i %% per_frame))\n",
            st->per_frame);
    fprintf(s, "frames=(");
    for (uint32_t i = 0; i < f->frames; ++i)
        fprintf(s, "%s%" PRId64, i ? " " : "", f->frame[i]);
    fprintf(s, ")\ndirs=(");
    char dir[PATH_MAX + 64];
    for (uint32_t i = 0; i < f->frames; ++i) {
        frame_dir(f, i, dir, sizeof(dir));
        fputs(i ? " " : "", s);
        farm_shell_word(s, dir);
    }
    fprintf(s, ")\ndir=${dirs[f]}\n");
    /* POV-Ray's animation identifiers reach every stage of a frame */
    fprintf(s, "builtins=(");
    for (uint32_t i = 0; i < f->frames; ++i) {
        char b[8][64];
        int nb = frame_builtins(f, i, b);
        fputs(i ? " '" : "'", s);
        for (int k = 0; k < nb; ++k)
            fprintf(s, "%s%s", k ? " " : "", b[k]);
        fputc('\'', s);
    }
    fprintf(s, ")\nclock=()\nfor kv in ${builtins[f]}; do clock+=(--builtin \"$kv\"); done\n");
    /* the threads Slurm gave this element, unless the options chose */
    fprintf(s, "threads=()\n");
    if (!f->a.threads_given)
        fprintf(s, "threads=(--threads \"${SLURM_CPUS_ON_NODE:-0}\")\n");
    fprintf(s,
            "# runs the command again after a failure, up to %u more times; not after a bad command line\n"
            "# (exit status 2) or a cancel (130)\n"
            "run() {\n"
            "    local attempt rc=1\n"
            "    for attempt in $(seq 1 %u); do\n"
            "        echo \"vbnl farm: %s element $i (frame ${frames[f]}, part $k): attempt $attempt of %u on "
            "$(hostname)\" >&2\n"
            "        \"$@\"\n"
            "        rc=$?\n"
            "        if [ $rc -eq 0 ] || [ $rc -eq 2 ] || [ $rc -eq 130 ]; then return $rc; fi\n"
            "        echo \"vbnl farm: exit status $rc\" >&2\n"
            "    done\n"
            "    return $rc\n"
            "}\n",
            f->retries, f->retries + 1, st->name, f->retries + 1);
}

/* A shell array `name` of `path` numbered for each frame. */
static void frame_paths(const farm *f, FILE *s, const char *name, const char *path)
{
    char out[PATH_MAX + 32];
    fprintf(s, "%s=(", name);
    for (uint32_t i = 0; i < f->frames; ++i) {
        frame_path(f, path, i, out, sizeof(out));
        fputs(i ? " " : "", s);
        farm_shell_word(s, out);
    }
    fprintf(s, ")\n");
}

static int write_script(const farm *f, const stage *st, char *path, size_t n)
{
    snprintf(path, n, "%s/jobs/%s.sh", f->work, st->name);
    FILE *s = fopen(path, "w");
    if (!s) {
        fprintf(stderr, "vbnl farm: cannot write '%s': %s\n", path, strerror(errno));
        return -1;
    }
    script_head(f, s, st);
    const farm_args *a = &f->a;
    if (!strcmp(st->name, "prepare")) {
        fprintf(s, "run \"$vbnl\" --plugin \"$plugin\" prepare \"$scene\"");
        farm_args_write(a, FARM_OPT_SCENE | FARM_OPT_QUIET, s);
        fprintf(s, " \"${threads[@]}\" \"${clock[@]}\" -o \"$dir/lights/placement.vls\"\n");
    } else if (!strcmp(st->name, "photons")) {
        fprintf(s, "run \"$vbnl\" --plugin \"$plugin\" photons \"$scene\"");
        farm_args_write(a, FARM_OPT_SCENE | FARM_OPT_QUIET, s);
        fprintf(s, " \"${threads[@]}\" \"${clock[@]}\" --placement \"$dir/lights/placement.vls\" --part \"$k/%u\" "
                   "-o \"$dir/lights/photons-$k.vls\"\n",
                f->photon_jobs);
    } else if (!strcmp(st->name, "merge-lights")) {
        fprintf(s, "parts=()\nfor ((p = 0; p < %u; ++p)); do parts+=(\"$dir/lights/photons-$p.vls\"); done\n",
                f->photon_jobs);
        fprintf(s, "run \"$vbnl\" --plugin \"$plugin\" merge-lights \"${parts[@]}\" -o \"$dir/lights/lights.vls\"%s\n",
                a->quiet ? " -q" : "");
    } else if (!strcmp(st->name, "tiles")) {
        fprintf(s, "crops=(");
        const uint32_t W = a->o.width, H = a->o.height;
        for (uint32_t ty = 0; ty < f->tiles_y; ++ty)
            for (uint32_t tx = 0; tx < f->tiles_x; ++tx)
                fprintf(s, "%s%u,%u,%u,%u", tx || ty ? " " : "", (uint32_t)((uint64_t)tx * W / f->tiles_x),
                        (uint32_t)((uint64_t)ty * H / f->tiles_y), (uint32_t)((uint64_t)(tx + 1) * W / f->tiles_x),
                        (uint32_t)((uint64_t)(ty + 1) * H / f->tiles_y));
        fprintf(s, ")\nlights=()\n");
        if (f->lights)
            fprintf(s, "lights=(--load-lights \"$dir/lights/lights.vls\")\n");
        fprintf(s, "run \"$vbnl\" --plugin \"$plugin\" render \"$scene\"");
        farm_args_write(a, FARM_OPT_SCENE | FARM_OPT_RENDER | FARM_OPT_QUIET, s);
        fprintf(s, " \"${threads[@]}\" \"${clock[@]}\" \"${lights[@]}\" --crop \"${crops[k]}\" "
                   "-o \"$dir/tiles/tile-$k.exr\"\n");
    } else { /* merge */
        frame_paths(f, s, "exrs", f->exr);
        if (a->png)
            frame_paths(f, s, "pngs", f->png);
        fprintf(s, "png=()\n");
        if (a->png)
            fprintf(s, "png=(--png \"${pngs[f]}\")\n");
        fprintf(s, "tiles=()\nfor ((t = 0; t < %u; ++t)); do tiles+=(\"$dir/tiles/tile-$t.exr\"); done\n",
                f->tiles_x * f->tiles_y);
        fprintf(s, "run \"$vbnl\" --plugin \"$plugin\" merge-tiles \"${tiles[@]}\" -o \"${exrs[f]}\" \"${png[@]}\"");
        farm_args_write(a, FARM_OPT_VIEW | FARM_OPT_QUIET, s);
        fputc('\n', s);
    }
    if (fclose(s) != 0 || chmod(path, 0755) != 0) {
        fprintf(stderr, "vbnl farm: cannot write '%s': %s\n", path, strerror(errno));
        return -1;
    }
    return 0;
}

/* ---- submitting ------------------------------------------------------------------------------------ */

typedef struct job {
    const stage *st;
    char script[PATH_MAX + 64];
    char id[64];
    uint32_t elements;
} job;

/* The sbatch command line of a job, depending on `after` (NULL: none). */
static char *sbatch_command(const farm *f, const job *j, const job *after)
{
    char *cmd = NULL;
    size_t len = 0;
    FILE *m = open_memstream(&cmd, &len);
    if (!m)
        return NULL;
    farm_shell_word(m, f->sbatch ? f->sbatch : "sbatch");
    char arg[PATH_MAX + 256];
    fputs(" --parsable --requeue", m);
    snprintf(arg, sizeof(arg), "--job-name=vbnl-%s-%s", f->name, j->st->name);
    fputc(' ', m);
    farm_shell_word(m, arg);
    snprintf(arg, sizeof(arg), "--output=%s/logs/%s-%%A_%%a.log", f->work, j->st->name);
    fputc(' ', m);
    farm_shell_word(m, arg);
    fprintf(m, " --array=0-%u", j->elements - 1);
    if (after)
        fprintf(m, " --dependency=afterok:%s --kill-on-invalid-dep=yes", after->id);
    if (f->partition) {
        snprintf(arg, sizeof(arg), "--partition=%s", f->partition);
        fputc(' ', m);
        farm_shell_word(m, arg);
    }
    if (f->cpus)
        fprintf(m, " --cpus-per-task=%u", f->cpus);
    for (uint32_t i = 0; i < f->n_sbatch_args; ++i) {
        fputc(' ', m);
        farm_shell_word(m, f->sbatch_args[i]);
    }
    fputc(' ', m);
    farm_shell_word(m, j->script);
    fclose(m);
    return cmd;
}

/* Runs `cmd` with the shell; its first output line (trimmed) into out. 0 on exit status 0. */
static int run_capture(const char *cmd, char *out, size_t n)
{
    FILE *p = popen(cmd, "r");
    if (!p)
        return -1;
    out[0] = '\0';
    char line[512];
    while (fgets(line, sizeof(line), p))
        if (!out[0]) {
            size_t l = strlen(line) < n ? strlen(line) : n - 1;
            memcpy(out, line, l);
            out[l] = '\0';
        }
    int st = pclose(p);
    out[strcspn(out, "\r\n")] = '\0';
    return st == 0 ? 0 : -1;
}

static void cancel_jobs(const farm *f, const job *jobs, uint32_t n)
{
    for (uint32_t i = 0; i < n; ++i) {
        if (!jobs[i].id[0])
            continue;
        char cmd[96];
        snprintf(cmd, sizeof(cmd), "scancel %.63s", jobs[i].id);
        if (system(cmd) != 0)
            fprintf(stderr, "vbnl farm: could not cancel job %s (%s)\n", jobs[i].id, cmd);
    }
    (void)f;
}

/* --local: every element of every stage, in order, here. */
static int run_local(const farm *f, const job *jobs, uint32_t n)
{
    for (uint32_t j = 0; j < n; ++j)
        for (uint32_t e = 0; e < jobs[j].elements; ++e) {
            char log[PATH_MAX + 64];
            snprintf(log, sizeof(log), "%s/logs/%s-local_%u.log", f->work, jobs[j].st->name, e);
            pid_t pid = fork();
            if (pid < 0)
                return VBI_EXIT_FAILURE;
            if (pid == 0) {
                char id[32];
                snprintf(id, sizeof(id), "%u", e);
                setenv("SLURM_ARRAY_TASK_ID", id, 1);
                FILE *l = freopen(log, "w", stdout);
                if (!l || dup2(fileno(stdout), STDERR_FILENO) < 0)
                    _exit(127);
                execl("/bin/bash", "bash", jobs[j].script, (char *)NULL);
                _exit(127);
            }
            int status = 0;
            while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
            }
            if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
                fprintf(stderr, "vbnl farm: %s element %u failed (log: %s)\n", jobs[j].st->name, e, log);
                return VBI_EXIT_FAILURE;
            }
            if (!f->a.quiet)
                fprintf(stderr, "vbnl farm: %s %u of %u done\n", jobs[j].st->name, e + 1, jobs[j].elements);
        }
    return VBI_EXIT_OK;
}

/* --wait: until squeue lists none of the jobs, then the outcome from scontrol and the outputs. */
static int wait_jobs(const farm *f, const job *jobs, uint32_t n)
{
    char *ids = NULL;
    size_t len = 0;
    FILE *m = open_memstream(&ids, &len);
    for (uint32_t i = 0; i < n; ++i)
        fprintf(m, "%s%s", i ? "," : "", jobs[i].id);
    fclose(m);
    char cmd[8192], last[4096] = "";
    /* one line per array element (-r), so that the counts are of elements */
    snprintf(cmd, sizeof(cmd), "%s -h -r -j %s -o '%%j %%T' 2>/dev/null", f->squeue ? f->squeue : "squeue", ids);
    for (;;) {
        FILE *p = popen(cmd, "r");
        if (!p)
            break;
        /* counts of elements per stage and state */
        char now[4096] = "", line[512];
        uint32_t count[MAX_JOBS][2] = {{0}};
        int any = 0;
        while (fgets(line, sizeof(line), p)) {
            any = 1;
            for (uint32_t i = 0; i < n; ++i) {
                char nm[256];
                snprintf(nm, sizeof(nm), "vbnl-%s-%s ", f->name, jobs[i].st->name);
                if (!strncmp(line, nm, strlen(nm)))
                    count[i][strstr(line, "RUNNING") ? 1 : 0]++;
            }
        }
        pclose(p);
        if (!any)
            break;
        size_t l = 0;
        for (uint32_t i = 0; i < n && l < sizeof(now); ++i) {
            uint32_t left = count[i][0] + count[i][1];
            l += (size_t)snprintf(now + l, sizeof(now) - l, "%s%s %u/%u", l ? ", " : "", jobs[i].st->name,
                                  jobs[i].elements > left ? jobs[i].elements - left : 0, jobs[i].elements);
            if (count[i][1] && l < sizeof(now))
                l += (size_t)snprintf(now + l, sizeof(now) - l, " (%u running)", count[i][1]);
        }
        if (strcmp(now, last) && !f->a.quiet)
            fprintf(stderr, "vbnl farm: done %s\n", now);
        snprintf(last, sizeof(last), "%s", now);
        usleep(250000);
    }
    free(ids);
    /* every element of every job: COMPLETED */
    int failed = 0;
    for (uint32_t i = 0; i < n; ++i) {
        snprintf(cmd, sizeof(cmd), "%s -o show job %s 2>/dev/null", f->scontrol ? f->scontrol : "scontrol", jobs[i].id);
        FILE *p = popen(cmd, "r");
        char line[8192];
        while (p && fgets(line, sizeof(line), p)) {
            const char *st = strstr(line, "JobState="), *id = strstr(line, "JobId=");
            if (st && strncmp(st + 9, "COMPLETED", 9)) {
                const char *task = strstr(line, "ArrayTaskId=");
                char element[32], log[PATH_MAX + 128];
                snprintf(element, sizeof(element), "%.*s", task ? (int)strcspn(task + 12, " ") : 1,
                         task ? task + 12 : "0");
                snprintf(log, sizeof(log), "%s/logs/%s-%s_%s.log", f->work, jobs[i].st->name, jobs[i].id, element);
                fprintf(stderr, "vbnl farm: %s element %s: %.*s (%s%s)\n", jobs[i].st->name, element,
                        (int)strcspn(st, " \n"), st, access(log, F_OK) == 0 ? "log: " : "never ran",
                        access(log, F_OK) == 0 ? log : "");
                failed = 1;
            }
            (void)id;
        }
        if (p)
            pclose(p);
    }
    char out[PATH_MAX + 32];
    for (uint32_t i = 0; i < f->frames; ++i) {
        frame_path(f, f->exr, i, out, sizeof(out));
        if (access(out, F_OK) != 0) {
            fprintf(stderr, "vbnl farm: '%s' was not written\n", out);
            failed = 1;
        }
    }
    if (!failed && !f->a.quiet)
        fprintf(stderr, "vbnl farm: done: %s%s\n", f->exr, f->frames > 1 ? " (every frame)" : "");
    return failed ? VBI_EXIT_FAILURE : VBI_EXIT_OK;
}

int cmd_farm(int argc, char **argv)
{
    farm *f = calloc(1, sizeof(*f));
    if (!f)
        return VBI_EXIT_FAILURE;
    f->photon_jobs = 4;
    f->tiles_x = f->tiles_y = 2;
    f->retries = 2;
    f->initial_frame = f->final_frame = 1;
    f->final_clock = 1.0;
    int rc = farm_args_parse(&f->a, argc, argv, "vbnl farm", ~0u, farm_options, on_farm_option, f);
    if (!rc && f->help) {
        printf("%s", farm_usage);
        goto out;
    }
    if (rc || (rc = check_and_resolve(f)) != 0)
        goto out;

    /* the work folder: one farm per folder */
    char path[PATH_MAX + 64];
    rc = VBI_EXIT_FAILURE;
    if (make_dir(f->work))
        goto out;
    snprintf(path, sizeof(path), "%s/farm.txt", f->work);
    if (access(path, F_OK) == 0) {
        fprintf(stderr, "vbnl farm: '%s' holds the farm of an earlier submission (%s); remove it or give another "
                        "--work\n", f->work, path);
        rc = VBI_EXIT_USAGE;
        goto out;
    }
    static const char *const sub[] = {"jobs", "logs"};
    for (size_t i = 0; i < 2; ++i) {
        snprintf(path, sizeof(path), "%s/%s", f->work, sub[i]);
        if (make_dir(path))
            goto out;
    }
    for (uint32_t i = 0; i < f->frames; ++i) {
        char dir[PATH_MAX + 32];
        frame_dir(f, i, dir, sizeof(dir));
        snprintf(path, sizeof(path), "%s/lights", dir);
        if (make_dir(dir) || (f->lights && make_dir(path)))
            goto out;
        snprintf(path, sizeof(path), "%s/tiles", dir);
        if (make_dir(path))
            goto out;
    }
    /* the graph */
    const uint32_t tiles = f->tiles_x * f->tiles_y;
    const stage stages[] = {{"prepare", 1}, {"photons", f->photon_jobs}, {"merge-lights", 1}, {"tiles", tiles},
                            {"merge", 1}};
    job jobs[MAX_JOBS];
    uint32_t nj = 0;
    for (size_t i = f->lights ? 0 : 3; i < sizeof(stages) / sizeof(stages[0]); ++i) {
        memset(&jobs[nj], 0, sizeof(jobs[nj]));
        jobs[nj].st = &stages[i];
        jobs[nj].elements = stages[i].per_frame * f->frames;
        if (write_script(f, &stages[i], jobs[nj].script, sizeof(jobs[nj].script)))
            goto out;
        ++nj;
    }
    if (f->local) {
        rc = run_local(f, jobs, nj);
        goto out;
    }
    snprintf(path, sizeof(path), "%s/farm.txt", f->work);
    FILE *log = fopen(path, "w");
    if (!log) {
        fprintf(stderr, "vbnl farm: cannot write '%s': %s\n", path, strerror(errno));
        goto out;
    }
    fprintf(log, "vbnl farm: %s, %u frame%s, %u photon jobs, %ux%u tiles\n", f->scene, f->frames,
            f->frames > 1 ? "s" : "", f->lights ? f->photon_jobs : 0, f->tiles_x, f->tiles_y);
    rc = VBI_EXIT_OK;
    for (uint32_t i = 0; i < nj; ++i) {
        char *cmd = sbatch_command(f, &jobs[i], i ? &jobs[i - 1] : NULL);
        if (!cmd) {
            rc = VBI_EXIT_FAILURE;
            break;
        }
        if (f->dry_run) {
            /* the dependency is on the previous stage's job id, unknown until submitted */
            snprintf(jobs[i].id, sizeof(jobs[i].id), "$%s", jobs[i].st->name);
            printf("%s\n", cmd);
            fprintf(log, "%s\n", cmd);
            free(cmd);
            continue;
        }
        char id[256];
        int ok = run_capture(cmd, id, sizeof(id)) == 0 && id[0];
        fprintf(log, "%s\n  -> %s\n", cmd, ok ? id : "failed");
        free(cmd);
        if (!ok) {
            fprintf(stderr, "vbnl farm: sbatch failed for stage '%s'%s%s\n", jobs[i].st->name, id[0] ? ": " : "", id);
            fprintf(log, "cancelled the stages submitted before\n");
            cancel_jobs(f, jobs, i);
            rc = VBI_EXIT_FAILURE;
            break;
        }
        id[strcspn(id, ";")] = '\0'; /* "id;cluster" */
        snprintf(jobs[i].id, sizeof(jobs[i].id), "%s", id);
    }
    fclose(log);
    if (rc || f->dry_run)
        goto out;
    if (!f->a.quiet) {
        fprintf(stderr, "vbnl farm: submitted %u frame%s of %s:", f->frames, f->frames > 1 ? "s" : "", f->scene);
        for (uint32_t i = 0; i < nj; ++i)
            fprintf(stderr, "%s %s %s (%u)", i ? "," : "", jobs[i].st->name, jobs[i].id, jobs[i].elements);
        fprintf(stderr, "\nvbnl farm: progress: squeue --name=vbnl-%s-prepare,vbnl-%s-photons,vbnl-%s-merge-lights,"
                        "vbnl-%s-tiles,vbnl-%s-merge; logs in %s/logs\n",
                f->name, f->name, f->name, f->name, f->name, f->work);
    }
    if (f->wait)
        rc = wait_jobs(f, jobs, nj);
out:
    free(f->frame);
    free(f->clock);
    free(f);
    return rc;
}
