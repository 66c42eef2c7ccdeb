/* The render options as the farm's commands take them (farm_args.c): `vbnl farm`, `vbnl prepare`
 * and `vbnl photons` accept the options of `vbnl render` with its names, ranges and messages, and
 * the farm hands each stage the ones it needs. Internal to the module.
 *
 * Every option has a class that says which stage of a farm it matters to; the parser keeps the
 * options as given, in order, with their class, so that they can be passed on verbatim. */
#ifndef VBI_FARM_ARGS_H
#define VBI_FARM_ARGS_H

#include <stdint.h>
#include <stdio.h>

#include "vbnl/vbnl_plugin.h"

/* Which stages an option matters to. */
enum {
    FARM_OPT_SCENE = 1,   /* the scene and its preparation: --integrator --set --width --height --seed
                             --threads --camera --declare --include-dir --read-dir --write-dir
                             --builtin; every stage that loads the scene */
    FARM_OPT_RENDER = 2,  /* shading only: --spp --sampler; the tiles */
    FARM_OPT_VIEW = 4,    /* how the image is written: --half --png-bits --png-alpha --display --view
                             --ocio --exposure; the final merge */
    FARM_OPT_OUTPUT = 8,  /* -o --png */
    FARM_OPT_SINGLE = 16, /* --crop --time --save-lights --load-lights: one render's own */
    FARM_OPT_QUIET = 32,  /* -q --quiet */
};

#define FARM_MAX_SETS 256
#define FARM_MAX_ARGS 1024

/* POV-Ray's animation identifiers, the names `--builtin NAME=VALUE` takes (set_scene_option's). */
extern const char *const farm_builtins[8];

typedef struct farm_args {
    const char *scene;           /* the one positional argument (NULL when none was given) */
    vbnl_plugin_options o;       /* size, seed, spp, threads, camera, integrator, sampler, crop, time */
    vbnl_plugin_view view;
    const char *exr, *png;
    const char *sets[FARM_MAX_SETS]; /* "key=value" of --set, --save-lights, --load-lights, in order */
    const char *set_where[FARM_MAX_SETS];
    uint32_t nsets;
    const char *scene_key[FARM_MAX_SETS]; /* settings of the .pov load (set_scene_option), in order */
    const char *scene_value[FARM_MAX_SETS];
    uint32_t nscene;
    int half, quiet, threads_given;
    int clock_given;             /* --builtin clock=... was given */
    const char *single;          /* the first FARM_OPT_SINGLE option given ("--crop"), or NULL */
    /* the options as given: name ("--width") and value (NULL for a flag), with their class */
    const char *name[FARM_MAX_ARGS], *value[FARM_MAX_ARGS];
    unsigned cls[FARM_MAX_ARGS];
    uint32_t count;
    char owned[2][4096 + 16];    /* "save_lights=...", "load_lights=..." */
} farm_args;

/* An option of the command itself (looked up before the render options). */
typedef struct farm_option {
    const char *name;            /* "--photon-jobs", or "-o" */
    int has_arg;
    int id;                      /* handed to the callback */
} farm_option;

/* Called for each of the command's own options; returns 0, or an exit code (VBI_EXIT_USAGE, after
 * printing why) to stop. */
typedef int (*farm_own_fn)(void *user, int id, const char *value);

/* Parses argv[1..argc-1] ("--name value", "--name=value", one positional scene file). `cmd` names
 * the command in messages ("vbnl farm"). Options of `accept` classes are taken; a render option of
 * another class is refused naming the command. Returns 0, or VBI_EXIT_USAGE after printing why.
 * argv must outlive `a` (its strings are kept). */
int farm_args_parse(farm_args *a, int argc, char **argv, const char *cmd, unsigned accept, const farm_option *own,
                    farm_own_fn on_own, void *user);

/* Creates a renderer with the options, scene settings and parameters of `a` (plus `extra`, n
 * "key=value" settings from `where`), loads the scene and configures it, printing scene messages to
 * stderr. Returns 0 with *out set, or an exit code after printing "<cmd>: <why>": the scene
 * (VBI_EXIT_SCENE), a bad option or parameter (VBI_EXIT_USAGE), anything else
 * (VBI_EXIT_FAILURE). */
int farm_args_renderer(const farm_args *a, const char *cmd, const char *const *extra, uint32_t n_extra,
                       const char *where, vbnl_plugin_renderer **out);

/* Writes the options of `classes` to `f` as shell words, each quoted, each preceded by a space. */
void farm_args_write(const farm_args *a, unsigned classes, FILE *f);

/* Writes `s` to `f` as one single-quoted shell word. */
void farm_shell_word(FILE *f, const char *s);


/* Seconds of a monotonic clock. */
double farm_now(void);

/* Installs the handler of SIGINT, SIGTERM and SIGHUP for a command that writes files: it removes
 * the temporary file of a write under way (the atomic files) and ends the process with exit status
 * 130, so that a cancelled job (Slurm's scancel sends SIGTERM) leaves no half-written file. */
void farm_on_signals(void);

#endif
