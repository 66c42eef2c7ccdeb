/* `vbnl`: the command-line host. It links no renderer code: it loads the plugin module with
 * dlopen and drives it through the table of vbnl_plugin.h.
 *
 *   vbnl [--plugin PATH] render FILE -o out.exr [--png out.png] [options]
 *   vbnl [--plugin PATH] info
 *   vbnl [--plugin PATH] bench ...      (commands that run inside the module)
 *
 * The module is looked for in this order: --plugin, $VBNL_PLUGIN, beside this executable, in
 * <executable>/../<libdir>/vbnl (an installed tree, wherever it was moved), in the configured
 * install directory.
 *
 * Ctrl-C (or SIGTERM, SIGHUP) during a render: the first stops it after the tiles in flight and
 * the partial image is written (exit 130); the second ends the process at once from the signal
 * handler (exit 130), after the module's abandon_writes has removed the temporary file of a write
 * under way. An output never names the scene, a --load-lights file or another output. */
#include <dlfcn.h>
#include <errno.h>
#include <getopt.h>
#include <libgen.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "vbnl/vbnl_plugin.h"

#ifndef VBNL_PLUGIN_FILE
#define VBNL_PLUGIN_FILE "vbnl_plugin.so"
#endif
#ifndef VBNL_PLUGIN_LIBDIR
#define VBNL_PLUGIN_LIBDIR "lib/vbnl"
#endif
#ifndef VBNL_PLUGIN_INSTALL_DIR
#define VBNL_PLUGIN_INSTALL_DIR "/usr/local/lib/vbnl"
#endif

#define MSG_SIZE 2048

/* The signal handler's state. Lock-free atomics: the handler may run on any thread, the module's
 * workers included, while the main thread reads the count. g_abandon_writes is the module's
 * abandon_writes (NULL for a 1.0 module), set before the handler is installed. */
_Static_assert(ATOMIC_INT_LOCK_FREE == 2 && ATOMIC_POINTER_LOCK_FREE == 2, "the handler needs lock-free atomics");
static atomic_int g_interrupts;
static void (*_Atomic g_abandon_writes)(void);

/* First Ctrl-C: the progress callback cancels, the partial image is written. Second: leave at
 * once, writing nothing; the module removes the temporary file of a write under way (only
 * async-signal-safe calls here). */
static void on_sigint(int sig)
{
    (void)sig;
    if (atomic_fetch_add(&g_interrupts, 1) + 1 >= 2) {
        void (*abandon)(void) = atomic_load(&g_abandon_writes);
        if (abandon)
            abandon();
        _exit(VBNL_EXIT_INTERRUPTED);
    }
}

/* ---- outputs that never replace an input or each other ----------------------------------------- */

/* The file `p` names: its canonical path when it exists, else its folder's canonical path and its
 * name (a file about to be created). -1 when the folder does not exist either. */
static int canonical_path(const char *p, char *out, size_t n)
{
    char buf[PATH_MAX], a[PATH_MAX], b[PATH_MAX];
    if (realpath(p, buf)) {
        snprintf(out, n, "%s", buf);
        return 0;
    }
    snprintf(a, sizeof(a), "%s", p);
    snprintf(b, sizeof(b), "%s", p);
    if (!realpath(dirname(a), buf))
        return -1;
    const char *base = basename(b);
    size_t lb = strlen(buf), ln = strlen(base);
    if (lb + 1 + ln >= n)
        return -1;
    memcpy(out, buf, lb);
    out[lb] = '/';
    memcpy(out + lb + 1, base, ln + 1);
    return 0;
}

/* True when `a` and `b` name one file: the same inode when both exist (links and hard links
 * included), else the same canonical path. */
static int same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char ca[PATH_MAX], cb[PATH_MAX];
    return canonical_path(a, ca, sizeof(ca)) == 0 && canonical_path(b, cb, sizeof(cb)) == 0 && !strcmp(ca, cb);
}

/* 0 when no output (name[i], path[i], NULL paths skipped) names the scene, one of the ':'-separated
 * --load-lights files, or another output; else prints why and returns -1. */
static int outputs_distinct(const char *const name[3], const char *const path[3], const char *scene,
                            const char *load_lights)
{
    for (int i = 0; i < 3; ++i) {
        if (!path[i])
            continue;
        if (same_file(path[i], scene)) {
            fprintf(stderr, "vbnl render: %s '%s' is the scene file; an output never replaces an input\n", name[i],
                    path[i]);
            return -1;
        }
        if (load_lights) {
            char list[PATH_MAX * 2];
            snprintf(list, sizeof(list), "%s", load_lights);
            for (char *save = NULL, *f = strtok_r(list, ":", &save); f; f = strtok_r(NULL, ":", &save))
                if (same_file(path[i], f)) {
                    fprintf(stderr,
                            "vbnl render: %s '%s' is the --load-lights file '%s'; an output never replaces an "
                            "input\n",
                            name[i], path[i], f);
                    return -1;
                }
        }
        for (int j = 0; j < i; ++j)
            if (path[j] && same_file(path[i], path[j])) {
                fprintf(stderr, "vbnl render: %s '%s' and %s '%s' name the same file; give each output its own\n",
                        name[j], path[j], name[i], path[i]);
                return -1;
            }
    }
    return 0;
}

/* ---- loading the plugin ------------------------------------------------------------------------ */

static int g_silent; /* `vbnl --help`: no message when the plugin cannot be loaded */

#define PLUGIN_ERROR(...) (g_silent ? 0 : fprintf(stderr, __VA_ARGS__))

typedef struct plugin {
    void *handle;
    const vbnl_plugin_api *api;
    char path[PATH_MAX];
} plugin;

/* Opens one candidate. Returns 0 on success, -1 when the file does not exist (try the next one),
 * 1 on a hard error (message printed). */
static int try_plugin(const char *path, plugin *pl, int must_exist)
{
    if (access(path, F_OK) != 0) {
        if (must_exist) {
            PLUGIN_ERROR("vbnl: plugin '%s': %s\n", path, strerror(errno));
            return 1;
        }
        return -1;
    }
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        PLUGIN_ERROR("vbnl: cannot load plugin '%s': %s\n", path, dlerror());
        return 1;
    }
    vbnl_plugin_entry_fn entry;
    *(void **)&entry = dlsym(h, VBNL_PLUGIN_ENTRY_NAME);
    if (!entry) {
        PLUGIN_ERROR("vbnl: '%s' is not a vbnl plugin (no %s symbol)\n", path, VBNL_PLUGIN_ENTRY_NAME);
        dlclose(h);
        return 1;
    }
    const char *why = NULL;
    const vbnl_plugin_api *api = entry(VBNL_PLUGIN_ABI_MAJOR, &why);
    if (!api || api->abi_major != VBNL_PLUGIN_ABI_MAJOR || api->size < offsetof(vbnl_plugin_api, run_command)) {
        char table[96];
        if (api)
            snprintf(table, sizeof(table), "its table has ABI %u.%u and %u bytes", api->abi_major,
                     api->abi_minor, api->size);
        PLUGIN_ERROR("vbnl: plugin '%s' has another ABI (this host needs ABI major %u): %s\n", path,
                     VBNL_PLUGIN_ABI_MAJOR, !api ? (why ? why : "the module refused") : table);
        dlclose(h);
        return 1;
    }
    pl->handle = h;
    pl->api = api;
    snprintf(pl->path, sizeof(pl->path), "%s", path);
    return 0;
}

static int load_plugin(const char *given, plugin *pl)
{
    if (given)
        return try_plugin(given, pl, 1) == 0 ? 0 : -1;
    const char *env = getenv("VBNL_PLUGIN");
    if (env && *env)
        return try_plugin(env, pl, 1) == 0 ? 0 : -1;
    char exe[PATH_MAX], cand[PATH_MAX + 256];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
    int rc;
    if (n > 0) {
        exe[n] = '\0';
        const char *dir = dirname(exe);
        snprintf(cand, sizeof(cand), "%s/%s", dir, VBNL_PLUGIN_FILE);
        if ((rc = try_plugin(cand, pl, 0)) >= 0)
            return rc == 0 ? 0 : -1;
        snprintf(cand, sizeof(cand), "%s/../%s/%s", dir, VBNL_PLUGIN_LIBDIR, VBNL_PLUGIN_FILE);
        if ((rc = try_plugin(cand, pl, 0)) >= 0)
            return rc == 0 ? 0 : -1;
    }
    snprintf(cand, sizeof(cand), "%s/%s", VBNL_PLUGIN_INSTALL_DIR, VBNL_PLUGIN_FILE);
    if ((rc = try_plugin(cand, pl, 0)) >= 0)
        return rc == 0 ? 0 : -1;
    PLUGIN_ERROR(
            "vbnl: plugin %s not found beside the executable or in %s; give --plugin PATH or set "
            "$VBNL_PLUGIN\n",
            VBNL_PLUGIN_FILE, VBNL_PLUGIN_INSTALL_DIR);
    return -1;
}

/* ---- progress lines ---------------------------------------------------------------------------- */

typedef struct progress_state {
    int quiet, tty;
    double last_plain;
    char last_stage[64];
    int announced;        /* the first Ctrl-C has been reported */
    int pause_interrupt;  /* VBNL_TEST_PAUSE=interrupt (test_hooks below) */
} progress_state;

/* The program's test hooks, from VBNL_TEST_PAUSE in the environment (tests only, docs/tests.md;
 * the module reads no environment): "interrupt": once the first Ctrl-C is seen, wait 30 s before
 * the render is told to stop, after saying so on stderr, so that a test can send the second one
 * while the render is surely still running; "write": the module's VBNL_PLUGIN_TEST_PAUSE_WRITES
 * (every file it writes waits 30 s before its rename). */
static int test_hook_is(const char *which)
{
    const char *v = getenv("VBNL_TEST_PAUSE");
    return v && !strcmp(v, which);
}

static void test_pause_interrupt(void)
{
    fprintf(stderr, "vbnl: test pause (interrupt): the render has not been stopped yet\n");
    struct timespec left = {30, 0};
    while (nanosleep(&left, &left) != 0 && errno == EINTR) {
    }
}

static void format_eta(double s, char *buf, size_t n)
{
    if (s < 0.0)
        snprintf(buf, n, "--");
    else if (s < 60.0)
        snprintf(buf, n, "%.0fs", s);
    else
        snprintf(buf, n, "%.0fm%02.0fs", floor(s / 60.0), s - 60.0 * floor(s / 60.0));
}

/* Called on the thread that called prepare/render (this program's main thread). On a terminal:
 * one line per stage, rewritten in place; otherwise a plain line at a stage's start and end and
 * every 5 seconds. Returns non-zero after Ctrl-C, which cancels the render; the first call that
 * sees it says so on stderr (the point after which a second Ctrl-C counts as the second). */
static int on_progress(void *user, const vbnl_plugin_progress *p)
{
    progress_state *ps = user;
    int interrupted = atomic_load(&g_interrupts) > 0;
    if (interrupted && !ps->announced) {
        ps->announced = 1;
        if (!ps->quiet) {
            if (ps->tty && ps->last_stage[0])
                fputc('\n', stderr);
            fprintf(stderr, "vbnl: interrupted, finishing the current tiles (Ctrl-C again to quit without writing)\n");
        }
        if (ps->pause_interrupt)
            test_pause_interrupt();
    }
    if (!ps->quiet) {
        char eta[32];
        format_eta(p->eta, eta, sizeof(eta));
        int new_stage = strcmp(ps->last_stage, p->stage) != 0;
        char pct[16] = "";
        if (p->total > 0.0)
            snprintf(pct, sizeof(pct), "%5.1f%%", 100.0 * p->done / p->total);
        if (ps->tty) {
            if (ps->last_stage[0] && new_stage)
                fputc('\n', stderr);
            fprintf(stderr, "\r%-12s %6s  %.4g %s  %.3g/s  ETA %s\033[K", p->stage, pct, p->done, p->unit,
                    p->rate, eta);
            fflush(stderr);
        } else if (new_stage || p->elapsed - ps->last_plain >= 5.0 || (p->total > 0.0 && p->done >= p->total)) {
            fprintf(stderr, "%s: %s%s%.4g %s, %.3g/s, ETA %s)\n", p->stage, pct, pct[0] ? " (" : "(", p->done,
                    p->unit, p->rate, eta);
            ps->last_plain = p->elapsed;
        }
        if (new_stage)
            snprintf(ps->last_stage, sizeof(ps->last_stage), "%s", p->stage);
    }
    return interrupted;
}

/* Scene notes, warnings and errors in full (source line, caret, include chain). */
static void on_message(void *user, vbnl_plugin_severity severity, const char *text)
{
    (void)user;
    (void)severity;
    size_t n = strlen(text);
    fprintf(stderr, "%s%s", text, n && text[n - 1] == '\n' ? "" : "\n");
}

/* ---- usage --------------------------------------------------------------------------------------- */

static void usage(FILE *f, const plugin *pl)
{
    fprintf(f,
            "usage: vbnl [--plugin PATH] <command> [options]\n"
            "\n"
            "commands:\n"
            "  render FILE -o OUT.exr   render a scene (.pov scene file, or a mesh file: OBJ/MTL, PLY, glTF)\n"
            "  info                     list the integrators and their parameters\n");
    const char *summary;
    const char *name;
    for (uint32_t i = 0; pl && pl->api && (name = pl->api->command_at(i, &summary)); ++i)
        fprintf(f, "  %-24s %s\n", name, summary);
    fprintf(f,
            "\n"
            "  --plugin PATH            the plugin module (default: $VBNL_PLUGIN, else " VBNL_PLUGIN_FILE
            " beside\n"
            "                           this program or in " VBNL_PLUGIN_INSTALL_DIR ")\n"
            "  --version                versions of the program, the plugin and its ABI\n"
            "\n"
            "`vbnl render --help` and `vbnl bench --help` list their options.\n"
            "exit status: 0 success, 1 render or file error, 2 bad command line, 3 scene error,\n"
            "4 plugin missing or of another ABI, 130 interrupted (Ctrl-C; the partial image is written).\n");
}

static void render_usage(FILE *f)
{
    fprintf(f,
            "usage: vbnl render FILE [-o OUT.exr] [--png OUT.png] [options]\n"
            "\n"
            "FILE is a POV-Ray scene (.pov) or a mesh file (OBJ/MTL, PLY, glTF). A scene file may choose\n"
            "its integrator and parameters; --integrator and --set override them.\n"
            "\n"
            "  -o, --output PATH        EXR output (scene-linear Rec.709, every layer, settings in the header)\n"
            "      --png PATH           PNG of the beauty image through the colour view (display-referred)\n"
            "      --png-bits 8|16      PNG bit depth (default 8)\n"
            "      --integrator NAME    integrator (default: the scene's, else path); see `vbnl info`\n"
            "      --set KEY=VALUE      integrator parameter (repeatable)\n"
            "      --save-lights PATH   vbnl: save the prepared virtual lights and photons (--set save_lights=PATH)\n"
            "      --load-lights PATH   vbnl: load them instead of preparing; A:B:... sums the photon ranges of\n"
            "                           several files (--set load_lights=PATH; see photon_first, photon_count)\n"
            "      --spp N              samples per pixel (default 16)\n"
            "      --time SECONDS       time budget for preparation plus rendering, instead of --spp\n"
            "      --width W, --height H  image size (default 512x512)\n"
            "      --crop X0,Y0,X1,Y1   render only this window (pixels, X1 and Y1 exclusive)\n"
            "      --seed S             random seed (default 1); same seed, same image, any thread count\n"
            "      --sampler NAME       sobol (default: stratified low-discrepancy points for each sample's\n"
            "                           first draws) or random (independent numbers)\n"
            "      --threads N          worker threads (default 0 = one per core)\n"
            "      --camera px,py,pz,tx,ty,tz,fov   mesh files: camera position, target, vertical fov (degrees)\n"
            "      --display NAME       OpenColorIO display (default sRGB)\n"
            "      --view NAME          OpenColorIO view (default Standard; also 'ACES 1.0 SDR-video', Raw)\n"
            "      --ocio CONFIG        OpenColorIO config file (default $OCIO, else the embedded config)\n"
            "      --exposure STOPS     exposure applied before the view (PNG only)\n"
            "      --half               write half-float EXR channels\n"
            "  -q, --quiet              no progress output\n"
            "  -h, --help               this help\n");
}

/* ---- render -------------------------------------------------------------------------------------- */

static int parse_u32(const char *s, uint32_t *out, uint32_t min, uint32_t max)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end || end == s || v < min || v > max || s[0] == '-')
        return -1;
    *out = (uint32_t)v;
    return 0;
}

#define MAX_SETS 256

static int cmd_render(const plugin *pl, int argc, char **argv)
{
    static const struct option opts[] = {
        {"output", required_argument, 0, 'o'}, {"png", required_argument, 0, 'p'},
        {"integrator", required_argument, 0, 'i'}, {"set", required_argument, 0, 's'},
        {"spp", required_argument, 0, 'n'}, {"time", required_argument, 0, 't'},
        {"width", required_argument, 0, 'W'}, {"height", required_argument, 0, 'H'},
        {"seed", required_argument, 0, 'S'}, {"threads", required_argument, 0, 'T'},
        {"sampler", required_argument, 0, 'm'},
        {"camera", required_argument, 0, 'c'}, {"exposure", required_argument, 0, 'e'},
        {"half", no_argument, 0, 'f'}, {"quiet", no_argument, 0, 'q'},
        {"save-lights", required_argument, 0, 'L'}, {"load-lights", required_argument, 0, 'l'},
        {"display", required_argument, 0, 'd'}, {"view", required_argument, 0, 'v'},
        {"ocio", required_argument, 0, 'O'}, {"png-bits", required_argument, 0, 'b'},
        {"crop", required_argument, 0, 'C'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    const vbnl_plugin_api *api = pl->api;
    const char *exr = NULL, *png = NULL, *save_lights = NULL, *load_lights = NULL;
    char *sets[MAX_SETS], lights_buf[2][PATH_MAX + 16];
    const char *set_where[MAX_SETS];
    int nsets = 0, half = 0, quiet = 0, spp_given = 0, time_given = 0;
    vbnl_plugin_options o;
    api->options_init(&o);
    if (test_hook_is("write"))
        o.test_hooks |= VBNL_PLUGIN_TEST_PAUSE_WRITES;
    vbnl_plugin_view view;
    api->view_init(&view);
    char msg[MSG_SIZE];
    int c, rc = VBNL_EXIT_USAGE;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o': exr = optarg; break;
        case 'p': png = optarg; break;
        case 'i': o.integrator = optarg; break;
        case 'm': o.sampler = optarg; break;
        case 's':
        case 'L':
        case 'l':
            if (nsets == MAX_SETS) {
                fprintf(stderr, "vbnl render: more than %d parameters\n", MAX_SETS);
                return VBNL_EXIT_USAGE;
            }
            if (c == 's') {
                sets[nsets] = optarg;
                set_where[nsets++] = "--set";
                break;
            }
            if (!*optarg) {
                fprintf(stderr, "vbnl render: --%s takes a file path\n", c == 'L' ? "save-lights" : "load-lights");
                return VBNL_EXIT_USAGE;
            }
            snprintf(lights_buf[c == 'L'], sizeof(lights_buf[0]), "%s=%s", c == 'L' ? "save_lights" : "load_lights",
                     optarg);
            if (c == 'L')
                save_lights = optarg;
            else
                load_lights = optarg;
            sets[nsets] = lights_buf[c == 'L'];
            set_where[nsets++] = c == 'L' ? "--save-lights" : "--load-lights";
            break;
        case 'n':
            if (parse_u32(optarg, &o.spp, 1, 1u << 30)) {
                fprintf(stderr, "vbnl render: --spp takes a whole number >= 1, got '%s'\n", optarg);
                return VBNL_EXIT_USAGE;
            }
            spp_given = 1;
            break;
        case 't': {
            char *end;
            o.time_budget = strtod(optarg, &end);
            if (*end || !(o.time_budget > 0.0) || o.time_budget > 1e7) {
                fprintf(stderr, "vbnl render: --time takes seconds > 0, got '%s'\n", optarg);
                return VBNL_EXIT_USAGE;
            }
            time_given = 1;
            break;
        }
        case 'W':
        case 'H':
            if (parse_u32(optarg, c == 'W' ? &o.width : &o.height, 1, 65536)) {
                fprintf(stderr, "vbnl render: --%s takes 1..65536, got '%s'\n", c == 'W' ? "width" : "height", optarg);
                return VBNL_EXIT_USAGE;
            }
            break;
        case 'S': {
            char *end;
            errno = 0;
            o.seed = strtoull(optarg, &end, 10);
            if (errno || *end || end == optarg || optarg[0] == '-') {
                fprintf(stderr, "vbnl render: --seed takes a whole number >= 0, got '%s'\n", optarg);
                return VBNL_EXIT_USAGE;
            }
            break;
        }
        case 'T':
            if (parse_u32(optarg, &o.threads, 0, 1024)) {
                fprintf(stderr, "vbnl render: --threads takes 0..1024, got '%s'\n", optarg);
                return VBNL_EXIT_USAGE;
            }
            break;
        case 'c':
            if (cli_parse_camera(optarg, o.camera_position, o.camera_target, &o.camera_fov_y)) {
                fprintf(stderr, "vbnl render: --camera takes px,py,pz,tx,ty,tz,fov_degrees, got '%s'\n", optarg);
                return VBNL_EXIT_USAGE;
            }
            o.camera_given = 1;
            break;
        case 'C': {
            unsigned v[4];
            char extra;
            if (sscanf(optarg, "%u,%u,%u,%u%c", &v[0], &v[1], &v[2], &v[3], &extra) != 4 || strchr(optarg, '-') ||
                v[0] >= v[2] || v[1] >= v[3]) {
                fprintf(stderr, "vbnl render: --crop takes X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1, got '%s'\n", optarg);
                return VBNL_EXIT_USAGE;
            }
            memcpy(o.crop, v, sizeof(o.crop));
            break;
        }
        case 'e': {
            char *end;
            view.exposure = strtof(optarg, &end);
            if (*end || end == optarg || !(view.exposure > -64.0f && view.exposure < 64.0f)) {
                fprintf(stderr, "vbnl render: --exposure takes stops in (-64, 64), got '%s'\n", optarg);
                return VBNL_EXIT_USAGE;
            }
            break;
        }
        case 'd': view.display = optarg; break;
        case 'v': view.view = optarg; break;
        case 'O': view.config = optarg; break;
        case 'b':
            if (parse_u32(optarg, &view.png_bits, 8, 16) || (view.png_bits != 8 && view.png_bits != 16)) {
                fprintf(stderr, "vbnl render: --png-bits takes 8 or 16, got '%s'\n", optarg);
                return VBNL_EXIT_USAGE;
            }
            break;
        case 'f': half = 1; break;
        case 'q': quiet = 1; break;
        case 'h': render_usage(stdout); return VBNL_EXIT_OK;
        default: render_usage(stderr); return VBNL_EXIT_USAGE;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "vbnl render: expected exactly one scene FILE\n");
        render_usage(stderr);
        return VBNL_EXIT_USAGE;
    }
    if (!exr && !png) {
        fprintf(stderr, "vbnl render: give an output: -o OUT.exr and/or --png OUT.png\n");
        return VBNL_EXIT_USAGE;
    }
    if (time_given && !spp_given)
        o.spp = 0;
    if (o.crop[2] > o.width || o.crop[3] > o.height) {
        fprintf(stderr, "vbnl render: --crop window reaches outside the %ux%u image\n", o.width, o.height);
        return VBNL_EXIT_USAGE;
    }
    const char *scene_path = argv[optind];

    /* Refuse what cannot work before any heavy work: unwritable outputs first (within the first
     * second), then options, parameters, the scene, the colour view. */
    const char *outs[3] = {exr, png, save_lights};
    const char *const out_names[3] = {"-o", "--png", "--save-lights"};
    if (outputs_distinct(out_names, outs, scene_path, load_lights) != 0)
        return VBNL_EXIT_USAGE;
    for (int i = 0; i < 3; ++i)
        if (outs[i] && api->check_writable(outs[i], msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
            fprintf(stderr, "vbnl render: %s\n", msg);
            return VBNL_EXIT_FAILURE;
        }
    vbnl_plugin_renderer *r = NULL;
    vbnl_plugin_result res;
    if (api->renderer_create(&r, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        fprintf(stderr, "vbnl render: %s\n", msg);
        return VBNL_EXIT_FAILURE;
    }
    if (api->set_options(r, &o, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        fprintf(stderr, "vbnl render: %s\n", msg);
        goto cleanup;
    }
    api->set_message_callback(r, on_message, NULL, msg, sizeof(msg));
    for (int i = 0; i < nsets; ++i)
        if (api->set_param(r, sets[i], set_where[i], msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
            fprintf(stderr, "vbnl render: %s: %s\n", set_where[i], msg);
            goto cleanup;
        }
    if (api->load_scene_file(r, scene_path, msg, sizeof(msg)) != VBNL_PLUGIN_OK) {
        fprintf(stderr, "vbnl render: %s\n", msg);
        rc = VBNL_EXIT_SCENE;
        goto cleanup;
    }
    if ((res = api->configure(r, msg, sizeof(msg))) != VBNL_PLUGIN_OK) {
        fprintf(stderr, "vbnl render: %s\n", msg);
        rc = res == VBNL_PLUGIN_ERR_UNKNOWN_NAME || res == VBNL_PLUGIN_ERR_INVALID_ARGUMENT ? VBNL_EXIT_USAGE
                                                                                             : VBNL_EXIT_FAILURE;
        goto cleanup;
    }
    if (png) {
        /* the display and view are checked on the empty framebuffer, before rendering */
        size_t n = (size_t)o.width * o.height * 4;
        float *probe = malloc(sizeof(float) * n);
        res = probe ? api->apply_view(r, &view, probe, n, msg, sizeof(msg)) : VBNL_PLUGIN_ERR_OUT_OF_MEMORY;
        free(probe);
        if (res != VBNL_PLUGIN_OK) {
            fprintf(stderr, "vbnl render: %s\n", probe ? msg : "out of memory");
            rc = res == VBNL_PLUGIN_ERR_UNKNOWN_NAME ? VBNL_EXIT_USAGE : VBNL_EXIT_FAILURE;
            goto cleanup;
        }
    }

    rc = VBNL_EXIT_FAILURE;
    atomic_store(&g_abandon_writes, VBNL_PLUGIN_HAS(api, abandon_writes) ? api->abandon_writes : NULL);
    struct sigaction sa;
    memset(&sa, 0, sizeof(sa));
    sa.sa_handler = on_sigint;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL); /* a host's stop button (Blender sends SIGTERM) */
    sigaction(SIGHUP, &sa, NULL);  /* the terminal closed */
    progress_state ps = {quiet, isatty(STDERR_FILENO), -1e9, "", 0, test_hook_is("interrupt")};
    res = api->prepare(r, on_progress, &ps, msg, sizeof(msg));
    if (res == VBNL_PLUGIN_OK)
        res = api->render(r, on_progress, &ps, msg, sizeof(msg));
    if (!quiet && ps.tty && ps.last_stage[0])
        fputc('\n', stderr);
    int partial = res == VBNL_PLUGIN_ERR_CANCELLED;
    if (res != VBNL_PLUGIN_OK && !partial) {
        fprintf(stderr, "vbnl render: %s\n", msg);
        goto cleanup;
    }
    if ((exr && api->write_exr(r, exr, half, msg, sizeof(msg)) != VBNL_PLUGIN_OK) ||
        (png && api->write_png(r, png, &view, msg, sizeof(msg)) != VBNL_PLUGIN_OK)) {
        fprintf(stderr, "vbnl render: %s\n", msg);
        goto cleanup;
    }
    vbnl_plugin_stats st = {.size = sizeof(st)};
    if (!quiet && api->get_stats(r, &st, msg, sizeof(msg)) == VBNL_PLUGIN_OK)
        fprintf(stderr, "%s%u spp in %.2f s (prepare %.2f s), %.3g rays/s, %u threads%s\n",
                partial ? "interrupted: " : "", st.spp, st.render_seconds, st.prepare_seconds,
                st.render_seconds > 0 ? (double)st.rays / st.render_seconds : 0.0, st.threads,
                partial ? " (partial image written)" : "");
    rc = partial ? VBNL_EXIT_INTERRUPTED : VBNL_EXIT_OK;
cleanup:
    api->renderer_destroy(r);
    return rc;
}

/* ---- info ---------------------------------------------------------------------------------------- */

static const char *type_text(const vbnl_plugin_param_info *p, char *buf, size_t n)
{
    switch (p->type) {
    case VBNL_PLUGIN_PARAM_INT: snprintf(buf, n, "int [%g, %g], default %g", p->min, p->max, p->default_number); break;
    case VBNL_PLUGIN_PARAM_FLOAT: snprintf(buf, n, "float [%g, %g], default %g", p->min, p->max, p->default_number); break;
    case VBNL_PLUGIN_PARAM_BOOL: snprintf(buf, n, "bool, default %s", p->default_number != 0.0 ? "on" : "off"); break;
    case VBNL_PLUGIN_PARAM_ENUM: {
        size_t len = (size_t)snprintf(buf, n, "one of");
        for (const char *const *c = p->choices; c && *c && len < n; ++c)
            len += (size_t)snprintf(buf + len, n - len, " %s", *c);
        if (len < n)
            snprintf(buf + len, n - len, ", default %s", p->default_string);
        break;
    }
    case VBNL_PLUGIN_PARAM_STRING:
        snprintf(buf, n, "string, default '%s'", p->default_string ? p->default_string : "");
        break;
    default: snprintf(buf, n, "(type %d)", (int)p->type); break;
    }
    return buf;
}

static int cmd_info(const plugin *pl, int argc, char **argv)
{
    (void)argv;
    if (argc > 1) {
        fprintf(stderr, "vbnl info: takes no arguments\n");
        return VBNL_EXIT_USAGE;
    }
    const vbnl_plugin_api *api = pl->api;
    printf("vbnl %s, plugin %s (ABI %u.%u)\n\n", api->version(), pl->path, api->abi_major, api->abi_minor);
    char msg[MSG_SIZE];
    for (uint32_t i = 0; i < api->integrator_count(); ++i) {
        vbnl_plugin_integrator_info info;
        if (api->integrator_info(i, &info, msg, sizeof(msg)) != VBNL_PLUGIN_OK)
            continue;
        printf("%s: %s\n", info.name, info.summary);
        for (uint32_t k = 0; k < info.param_count; ++k) {
            vbnl_plugin_param_info p;
            char t[256];
            if (api->integrator_param(i, k, &p, msg, sizeof(msg)) == VBNL_PLUGIN_OK)
                printf("  %-16s %s\n  %-16s %s\n", p.name, type_text(&p, t, sizeof(t)), "", p.doc);
        }
        printf("\n");
    }
    return VBNL_EXIT_OK;
}

/* ---- dispatch ------------------------------------------------------------------------------------ */

typedef struct host_command {
    const char *name;
    int (*run)(const plugin *pl, int argc, char **argv);
} host_command;

/* Commands of this program; any other name is looked up among the module's commands. */
static const host_command host_commands[] = {
    {"render", cmd_render},
    {"info", cmd_info},
};

int main(int argc, char **argv)
{
    const char *plugin_path = NULL;
    int a = 1;
    while (a < argc && !strncmp(argv[a], "--plugin", 8)) {
        if (argv[a][8] == '=')
            plugin_path = argv[a] + 9;
        else if (!argv[a][8] && a + 1 < argc)
            plugin_path = argv[++a];
        else
            break;
        ++a;
    }
    plugin pl = {0};
    if (a >= argc) {
        usage(stderr, NULL);
        return VBNL_EXIT_USAGE;
    }
    const char *cmd = argv[a];
    if (!strcmp(cmd, "-h") || !strcmp(cmd, "--help") || !strcmp(cmd, "help")) {
        /* help works without a plugin; with one it also lists the module's commands */
        g_silent = 1;
        int ok = load_plugin(plugin_path, &pl) == 0;
        usage(stdout, ok ? &pl : NULL);
        return VBNL_EXIT_OK;
    }
    if (load_plugin(plugin_path, &pl) != 0)
        return VBNL_EXIT_PLUGIN;
    if (!strcmp(cmd, "--version")) {
        printf("vbnl %s (plugin %s, ABI %u.%u)\n", pl.api->version(), pl.path, pl.api->abi_major, pl.api->abi_minor);
        return VBNL_EXIT_OK;
    }
    for (size_t i = 0; i < sizeof(host_commands) / sizeof(host_commands[0]); ++i)
        if (!strcmp(cmd, host_commands[i].name))
            return host_commands[i].run(&pl, argc - a, argv + a);
    const char *name;
    for (uint32_t i = 0; (name = pl.api->command_at(i, NULL)); ++i)
        if (!strcmp(cmd, name))
            return pl.api->run_command(cmd, argc - a, argv + a);
    fprintf(stderr, "vbnl: unknown command '%s'\n", cmd);
    usage(stderr, &pl);
    return VBNL_EXIT_USAGE;
}
