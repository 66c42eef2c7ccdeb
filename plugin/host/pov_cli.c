/* POV-Ray 3.7's command line in the `vbnl` executable (pov_cli.h): the settings of .ini files and
 * switches (pov_ini.c) and vbnl's own options become one render per frame (host_render_run),
 * with POV-Ray's animation clock, output file names, console lines and All_File, so that a host
 * that runs POV-Ray (Blender's POV-Ray add-on) runs vbnl in its place. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "host.h"
#include "pov_cli.h"
#include "pov_options.h"

/* vbnl's own options that POV-Ray's command line sets in its own way. */
static const char *const pov_owned[][2] = {
    {"output", "+O or Output_File_Name with +FE or Output_File_Type=E"},
    {"png", "+O or Output_File_Name"},
    {"png-bits", "+FN16 or Bits_Per_Color=16"},
    {"png-alpha", "+UA or Output_Alpha=on"},
    {"width", "+W or Width"},
    {"height", "+H or Height"},
    {"crop", "+SC +EC +SR +ER or Start_Column, End_Column, Start_Row, End_Row"},
    {"camera", "the scene's camera"},
    {"builtin", "+K, +KFI, +KFF, +KI, +KF, +KC, +SF, +EF (the animation options)"},
};

enum { MAX_VBNL_OPTIONS = 256 };

/* One run of POV-Ray's command line. */
typedef struct pov_run {
    const plugin *pl;
    pov_settings set;
    int codes[MAX_VBNL_OPTIONS];      /* vbnl's options, in order */
    const char *args[MAX_VBNL_OPTIONS];
    int nvbnl;
    FILE *all;                        /* All_File, or NULL */
    /* the console of the frame being rendered */
    int rendering, line_open, last_pct, announced;
    char last_stage[64];
} pov_run;

int pov_cli_applies(int argc, char **argv)
{
    for (int i = 0; i < argc; ++i)
        if (pov_settings_is_pov(argv[i]))
            return 1;
    return 0;
}

/* ---- the console and All_File ------------------------------------------------------------------ */

/* A line (or a progress line ending in '\r') on `console` (NULL: none) and in All_File, where a
 * progress line ends in '\n'. */
static void out(pov_run *r, FILE *console, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void out(pov_run *r, FILE *console, const char *fmt, ...)
{
    char line[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof(line), fmt, ap);
    va_end(ap);
    if (console) {
        if (r->line_open && console == stderr) {
            fputc('\n', stdout);
            fflush(stdout);
            r->line_open = 0;
        }
        fputs(line, console);
        fflush(console);
    }
    if (r->all) {
        size_t n = strlen(line);
        if (n && line[n - 1] == '\r')
            line[n - 1] = '\n';
        fputs(line, r->all);
        fflush(r->all);
    }
}

/* The render's progress as POV-Ray prints it ("==== [Rendering...] ====", "(NN%)"), which hosts
 * such as Blender's POV-Ray add-on read; cancels after the first signal. */
static int pov_progress(void *user, const vbnl_plugin_progress *p)
{
    pov_run *r = user;
    int interrupted = host_interrupted() > 0;
    if (interrupted && !r->announced) {
        r->announced = 1;
        out(r, stderr, "vbnl: interrupted, finishing the current tiles (a second signal quits without writing)\n");
        host_test_pause();
    }
    if (!r->rendering) {
        r->rendering = 1;
        out(r, stdout, "==== [Rendering...] ========================================================\n");
    }
    if (!r->set.render_console)
        return interrupted;
    int pct = p->total > 0.0 ? (int)floor(100.0 * p->done / p->total) : -1;
    int new_stage = strcmp(r->last_stage, p->stage) != 0;
    if (!new_stage && pct == r->last_pct)
        return interrupted;
    if (new_stage && r->line_open) {
        out(r, stdout, "\n");
        r->line_open = 0;
    }
    snprintf(r->last_stage, sizeof(r->last_stage), "%s", p->stage);
    r->last_pct = pct;
    char rate[64] = "", counts[160];
    if (r->set.verbose)
        snprintf(rate, sizeof(rate), ", %.3g %s/s", p->rate, p->unit);
    if (pct >= 0)
        snprintf(counts, sizeof(counts), "%.0f of %.0f %s (%d%%)%s", p->done, p->total, p->unit, pct, rate);
    else
        snprintf(counts, sizeof(counts), "%.0f %s%s", p->done, p->unit, rate);
    if (!strcmp(p->stage, "render"))
        out(r, stdout, "Rendered %s\r", counts);
    else
        out(r, stdout, "Preparing %s: %s\r", p->stage, counts);
    r->line_open = 1;
    return interrupted;
}

static void pov_progress_end(void *user)
{
    pov_run *r = user;
    if (r->line_open) {
        out(r, stdout, "\n");
        r->line_open = 0;
    }
}

/* The scene's notes, warnings and errors in full. */
static void pov_message(void *user, vbnl_plugin_severity severity, const char *text)
{
    (void)severity;
    size_t n = strlen(text);
    out(user, stderr, "%s%s", text, n && text[n - 1] == '\n' ? "" : "\n");
}

/* Errors on stderr, the result line on stdout; both in All_File. */
static void pov_say(void *user, int error, const char *line)
{
    out(user, error ? stderr : stdout, "%s\n", line);
}

/* ---- frames and file names ------------------------------------------------------------------------ */

typedef struct pov_frames {
    int animation;
    long initial, final, step, start, end; /* POV-Ray's frame numbers; start..end is rendered */
    double initial_clock, final_clock, delta;
    int digits;
} pov_frames;

/* POV-Ray 3.7's animation (reference "Animation Options"): an animation unless the frames are
 * left unset, or 1 to 1; Cyclic_Animation counts one frame more for the clock and renders one
 * less; a subset given as a fraction below 1 is that share of the frames; the file names carry as
 * many digits as the last frame number. */
static void pov_frames_compute(const pov_settings *s, pov_frames *f)
{
    memset(f, 0, sizeof(*f));
    long i0 = s->have_initial_frame ? s->initial_frame : 0, f0 = s->have_final_frame ? s->final_frame : 0;
    f->animation = !((i0 == 0 && f0 == 0) || (i0 == 1 && f0 == 1));
    if (!f->animation) {
        f->start = f->end = 0;
        f->step = 1;
        return;
    }
    f->initial = s->have_initial_frame ? s->initial_frame : 1;
    f->final = s->have_final_frame ? s->final_frame : 1;
    if (f->final < f->initial)
        f->final = f->initial;
    f->initial_clock = s->initial_clock;
    f->final_clock = s->final_clock;
    f->step = s->frame_step < 1 ? 1 : s->frame_step;
    if (s->cyclic)
        f->final++;
    long n = f->final - f->initial + 1;
    if (s->have_subset_start)
        f->start = s->subset_start == 0.0 || s->subset_start >= 1.0 ? (long)s->subset_start : (long)(n * s->subset_start);
    if (!s->have_subset_start || f->start < f->initial)
        f->start = f->initial;
    if (s->have_subset_end) {
        f->end = s->subset_end == 0.0 || s->subset_end >= 1.0 ? (long)s->subset_end : (long)(n * s->subset_end);
        if (f->end < f->start)
            f->end = f->start;
    } else {
        f->end = s->cyclic ? f->final - 1 : f->final;
    }
    /* one frame from initial to final: no step of the clock (POV-Ray divides by zero there) */
    f->delta = f->final > f->initial ? (f->final_clock - f->initial_clock) / (double)(f->final - f->initial) : 0.0;
    f->digits = 1;
    for (long v = f->final; v >= 10; v /= 10)
        f->digits++;
}

/* The image file of `frame` as POV-Ray 3.7 names it: Output_File_Name, or the input's name in
 * the input's folder; a trailing '.' or the type's own extension (".png", ".exr", as written)
 * is dropped, then the frame number (animations) and the extension are appended. */
static int pov_output_name(const pov_settings *s, const pov_frames *f, long frame, char *out_path, size_t n)
{
    const char *ext = s->file_type == 'E' ? ".exr" : ".png";
    char folder[4096] = "", file[4096] = "";
    const char *o = s->output ? s->output : "";
    const char *slash = strrchr(o, '/');
    snprintf(folder, sizeof(folder), "%.*s", slash ? (int)(slash - o + 1) : 0, o);
    snprintf(file, sizeof(file), "%s", slash ? slash + 1 : o);
    if (!file[0] || !strcmp(file, ext)) {
        const char *in = s->input ? s->input : "object.pov";
        const char *is = strrchr(in, '/');
        if (!o[0])
            snprintf(folder, sizeof(folder), "%.*s", is ? (int)(is - in + 1) : 0, in);
        snprintf(file, sizeof(file), "%s", is ? is + 1 : in);
        char *dot = strrchr(file, '.');
        if (dot)
            *dot = '\0';
    } else {
        size_t fl = strlen(file), el = strlen(ext);
        if (file[fl - 1] == '.')
            file[fl - 1] = '\0';
        else if (fl > el && !strcmp(file + fl - el, ext))
            file[fl - el] = '\0';
    }
    char number[32] = "";
    if (f->animation)
        snprintf(number, sizeof(number), "%0*ld", f->digits, frame);
    int len = snprintf(out_path, n, "%s%s%s%s", folder, file, number, ext);
    return len > 0 && (size_t)len < n ? 0 : -1;
}

/* The render window in pixels from Start/End_Column/Row (reference "Output Options"): a start
 * below 1 is a fraction of the size, else a pixel number from 1; an end up to 1 is a fraction,
 * else the last pixel number. All zero: the whole image. */
static int pov_window(const pov_settings *s, uint32_t w, uint32_t h, uint32_t crop[4])
{
    memset(crop, 0, 4 * sizeof(uint32_t));
    if (!s->have_region[0] && !s->have_region[1] && !s->have_region[2] && !s->have_region[3])
        return 0;
    const double size[4] = {w, h, w, h};
    long v[4];
    for (int i = 0; i < 2; ++i) {
        double x = s->have_region[i] ? s->region[i] : 1.0;
        v[i] = x < 1.0 ? (long)(size[i] * x) : (long)x - 1;
    }
    for (int i = 2; i < 4; ++i) {
        double x = s->have_region[i] ? s->region[i] : size[i];
        v[i] = (x <= 1.0 ? (long)(size[i] * x) - 1 : (long)x - 1) + 1; /* exclusive */
    }
    if (v[0] < 0 || v[1] < 0 || v[0] >= (long)w || v[1] >= (long)h || v[2] > (long)w || v[3] > (long)h ||
        v[2] <= v[0] || v[3] <= v[1]) {
        fprintf(stderr,
                "vbnl: the render window (Start_Column %g, End_Column %g, Start_Row %g, End_Row %g) does not fit "
                "the %ux%u image\n",
                s->have_region[0] ? s->region[0] : 1.0, s->have_region[2] ? s->region[2] : (double)w,
                s->have_region[1] ? s->region[1] : 1.0, s->have_region[3] ? s->region[3] : (double)h, w, h);
        return -1;
    }
    if (v[0] == 0 && v[1] == 0 && v[2] == (long)w && v[3] == (long)h)
        return 0;
    for (int i = 0; i < 4; ++i)
        crop[i] = (uint32_t)v[i];
    return 0;
}

/* ---- the command line ------------------------------------------------------------------------------ */

static void pov_usage(FILE *f)
{
    fprintf(f,
            "usage: vbnl [FILE.ini ...] [+/-SWITCHES ...] [KEY=VALUE ...] [--vbnl-option ...] [FILE.pov]\n"
            "\n"
            "POV-Ray 3.7's command line and .ini files, read from left to right (the later setting wins),\n"
            "e.g. vbnl +Iscene.pov +W640 +H480 +Oout.png, vbnl scene.ini +KFF20. vbnl's own options of\n"
            "`vbnl render` may stand among them (--spp, --time, --integrator, --set, --read-dir, ...).\n"
            "The mapping of every key and switch: docs/povray-command-line.md.\n");
}

/* One of vbnl's --options at argv[*i]: its code and argument into r. */
static int vbi_option(pov_run *r, int argc, char **argv, int *i)
{
    const char *a = argv[*i] + 2;
    size_t nl = strcspn(a, "=");
    if (!strcmp(a, "help")) {
        pov_usage(stdout);
        return -2;
    }
    for (size_t k = 0; k < sizeof(pov_owned) / sizeof(pov_owned[0]); ++k)
        if (strlen(pov_owned[k][0]) == nl && !strncmp(a, pov_owned[k][0], nl)) {
            fprintf(stderr, "vbnl: --%s: on POV-Ray's command line give %s\n", pov_owned[k][0], pov_owned[k][1]);
            return -1;
        }
    for (const struct option *o = host_render_options; o->name; ++o) {
        if (strlen(o->name) != nl || strncmp(a, o->name, nl))
            continue;
        const char *arg = NULL;
        if (o->has_arg == required_argument) {
            if (a[nl] == '=')
                arg = a + nl + 1;
            else if (*i + 1 < argc)
                arg = argv[++*i];
            else {
                fprintf(stderr, "vbnl: --%s takes a value\n", o->name);
                return -1;
            }
        } else if (a[nl] == '=') {
            fprintf(stderr, "vbnl: --%s takes no value\n", o->name);
            return -1;
        }
        if (r->nvbnl == MAX_VBNL_OPTIONS) {
            fprintf(stderr, "vbnl: more than %d options\n", MAX_VBNL_OPTIONS);
            return -1;
        }
        r->codes[r->nvbnl] = o->val;
        r->args[r->nvbnl++] = arg;
        return 0;
    }
    fprintf(stderr, "vbnl: unknown option '%s' (`vbnl render --help` lists vbnl's options)\n", argv[*i]);
    return -1;
}

/* What the console shows before the first frame (and All_File keeps). */
static void pov_banner(pov_run *r, const pov_frames *f, const char *first_output)
{
    const vbnl_plugin_api *api = r->pl->api;
    const pov_settings *s = &r->set;
    out(r, stdout, "vbnl %s (plugin %s, ABI %u.%u) reading POV-Ray 3.7's command line\n", api->version(), r->pl->path,
        api->abi_major, api->abi_minor);
    out(r, stdout, "  Input file: %s\n", s->input);
    if (!s->output_to_file)
        out(r, stdout, "  Output file: none (Output_To_File off)\n");
    else
        out(r, stdout, "  Output file: %s%s, %s\n", first_output, f->animation ? " (the first frame)" : "",
            s->file_type == 'E' ? "OpenEXR, scene-linear" : s->alpha ? (s->bits == 16 ? "PNG, 16 bits RGBA" : "PNG, 8 bits RGBA")
                                                           : (s->bits == 16 ? "PNG, 16 bits RGB" : "PNG, 8 bits RGB"));
    out(r, stdout, "  Image resolution: %ld by %ld\n", s->width, s->height);
    for (size_t i = 0; i < s->library.n; ++i)
        out(r, stdout, "  Library path: %s\n", s->library.v[i]);
    if (f->animation)
        out(r, stdout, "  Animation: frames %ld to %ld of %ld to %ld, clock %g to %g (step %g per frame)\n", f->start,
            f->end, f->initial, f->final, f->initial_clock, f->final_clock, f->delta);
    else
        out(r, stdout, "  Clock value: %.3f (animation off)\n", s->have_clock ? s->clock : 0.0);
    /* one note per reason, naming every key it answers */
    for (size_t i = 0; i < s->notes.n; ++i) {
        const char *why = strstr(s->notes.v[i], ": does not apply: ");
        int first = 1;
        for (size_t j = 0; j < i && first; ++j)
            first = strcmp(why, strstr(s->notes.v[j], ": does not apply: ")) != 0;
        if (!first)
            continue;
        char keys[1024] = "";
        size_t len = 0;
        int count = 0;
        for (size_t j = i; j < s->notes.n; ++j)
            if (!strcmp(why, strstr(s->notes.v[j], ": does not apply: ")) && len < sizeof(keys)) {
                len += (size_t)snprintf(keys + len, sizeof(keys) - len, "%s%.*s", len ? ", " : "",
                                        (int)(strstr(s->notes.v[j], ": does not apply: ") - s->notes.v[j]),
                                        s->notes.v[j]);
                ++count;
            }
        out(r, stderr, "vbnl: note: %s: %s: %s\n", keys, count > 1 ? "do not apply" : "does not apply",
            why + strlen(": does not apply: "));
    }
}

/* Fills the job of one frame. Returns 0 or an exit status. */
static int pov_job(pov_run *r, host_render_job *job, const pov_frames *f, long frame, char *image, size_t n,
                   char numbers[8][48])
{
    const pov_settings *s = &r->set;
    host_render_job_init(job, r->pl->api, "vbnl");
    job->opt.width = (uint32_t)s->width;
    job->opt.height = (uint32_t)s->height;
    if (pov_window(s, job->opt.width, job->opt.height, job->opt.crop) != 0)
        return VBI_EXIT_USAGE;
    if (s->threads > 0)
        job->opt.threads = (uint32_t)s->threads;
    job->view.png_bits = (uint32_t)s->bits;
    job->view.alpha = s->alpha;
    if (s->output_to_file) {
        if (pov_output_name(s, f, frame, image, n) != 0) {
            fprintf(stderr, "vbnl: the output file name is too long\n");
            return VBI_EXIT_USAGE;
        }
        if (s->file_type == 'E')
            job->exr = image;
        else
            job->png = image;
    }
    /* the identifiers POV-Ray's front end declares: all 0 in a still image, where clock_on says
     * whether Clock was given */
    double clock = f->animation ? f->initial_clock + f->delta * (double)(frame - f->initial) : s->have_clock ? s->clock : 0;
    const double values[8] = {clock,
                              f->animation ? f->delta : 0,
                              f->animation ? f->initial_clock : 0,
                              f->animation ? f->final_clock : 0,
                              f->animation ? (double)frame : 0,
                              f->animation ? (double)f->initial : 0,
                              f->animation ? (double)f->final : 0,
                              f->animation || s->have_clock};
    static const char *const names[8] = {"clock",        "clock_delta",   "initial_clock", "final_clock",
                                         "frame_number", "initial_frame", "final_frame",   "clock_on"};
    int rc;
    for (int i = 0; i < 8; ++i) {
        snprintf(numbers[i], 48, "%.17g", values[i]);
        if ((rc = host_render_scene_option(job, names[i], numbers[i])) != 0)
            return rc;
    }
    for (size_t i = 0; i < s->declares.n; ++i)
        if ((rc = host_render_scene_option(job, "declare", s->declares.v[i])) != 0)
            return rc;
    for (size_t i = 0; i < s->library.n; ++i)
        if ((rc = host_render_scene_option(job, "include_dir", s->library.v[i])) != 0)
            return rc;
    /* vbnl's own options come last: they win */
    for (int i = 0; i < r->nvbnl; ++i)
        if ((rc = host_render_option(job, r->codes[i], r->args[i])) != 0)
            return rc;
    job->scene = s->input;
    job->quiet = job->quiet || !s->render_console;
    job->progress = pov_progress;
    job->progress_user = r;
    job->progress_end = pov_progress_end;
    job->message = pov_message;
    job->message_user = r;
    job->say = pov_say;
    job->say_user = r;
    return 0;
}

/* The All_File: beside the image (POV-Ray's rule), else in the current folder; never an input or
 * the image. */
static int pov_open_all_file(pov_run *r, const char *first_output)
{
    const pov_settings *s = &r->set;
    if (!s->all_file)
        return 0;
    char path[4096];
    const char *slash = s->output_to_file ? strrchr(first_output, '/') : NULL;
    snprintf(path, sizeof(path), "%.*s%s", slash ? (int)(slash - first_output + 1) : 0, first_output, s->all_file);
    int clash = cli_same_file(path, s->input) || (s->output_to_file && cli_same_file(path, first_output));
    for (size_t i = 0; !clash && i < s->ini_files.n; ++i)
        clash = cli_same_file(path, s->ini_files.v[i]);
    if (clash) {
        fprintf(stderr, "vbnl: All_File '%s' is an input or the image; an output never replaces either\n", path);
        return -1;
    }
    r->all = fopen(path, s->append_file ? "a" : "w");
    if (!r->all) {
        fprintf(stderr, "vbnl: cannot write All_File '%s': %s\n", path, strerror(errno));
        return -1;
    }
    return 0;
}

int pov_cli_main(const plugin *pl, int argc, char **argv)
{
    pov_run *r = calloc(1, sizeof(*r));
    if (!r) {
        fprintf(stderr, "vbnl: out of memory\n");
        return VBI_EXIT_FAILURE;
    }
    r->pl = pl;
    pov_settings_init(&r->set);
    int rc = VBI_EXIT_USAGE;
    for (int i = 0; i < argc; ++i) {
        int e = argv[i][0] == '-' && argv[i][1] == '-' ? vbi_option(r, argc, argv, &i)
                                                       : pov_settings_argument(&r->set, argv[i]);
        if (e == -2) {
            rc = VBI_EXIT_OK;
            goto done;
        }
        if (e != 0)
            goto done;
    }
    pov_settings *s = &r->set;
    if (!s->input) {
        fprintf(stderr, "vbnl: no scene: give a .pov file, +IFILE or Input_File_Name\n");
        goto done;
    }
    pov_frames f;
    pov_frames_compute(s, &f);
    char first[4096] = "";
    if (s->output_to_file && pov_output_name(s, &f, f.start, first, sizeof(first)) != 0) {
        fprintf(stderr, "vbnl: the output file name is too long\n");
        goto done;
    }
    for (size_t i = 0; s->output_to_file && i < s->ini_files.n; ++i)
        if (cli_same_file(first, s->ini_files.v[i])) {
            fprintf(stderr, "vbnl: the image '%s' is the INI file '%s'; an output never replaces an input\n", first,
                    s->ini_files.v[i]);
            goto done;
        }
    if (pov_open_all_file(r, first) != 0)
        goto done;
    pov_banner(r, &f, first);
    long total = f.animation ? (f.end - f.start) / f.step + 1 : 1;
    long index = 0;
    rc = VBI_EXIT_OK;
    for (long frame = f.start; rc == VBI_EXIT_OK && frame <= f.end; frame += f.step, ++index) {
        host_render_job job;
        char image[4096] = "", numbers[8][48];
        if ((rc = pov_job(r, &job, &f, frame, image, sizeof(image), numbers)) != 0)
            break;
        if (f.animation)
            out(r, stdout, "Rendering frame %ld of %ld (#%ld), clock %g: %s\n", index + 1, total, frame,
                f.initial_clock + f.delta * (double)(frame - f.initial), image[0] ? image : "no image file");
        out(r, stdout, "==== [Parsing...] ==========================================================\n");
        r->rendering = 0;
        r->last_stage[0] = '\0';
        r->last_pct = -2;
        rc = host_render_run(pl->api, &job, NULL);
        if (rc == VBI_EXIT_OK && image[0])
            out(r, stdout, "Wrote %s\n", image);
    }
done:
    if (r->all)
        fclose(r->all);
    pov_settings_free(&r->set);
    free(r);
    return rc;
}
