/* The commands that run inside the module (`vbnl bench`, `vbnl compare`, the farm's), reached
 * through the plugin ABI's command_at / run_command: they need the core's API beyond that ABI.
 * Each takes its arguments with argv[0] the command's name and returns a `vbnl` exit code
 * (common/cli.h). Internal to the module: nothing here is exported. */
#ifndef VBI_COMMANDS_H
#define VBI_COMMANDS_H

#include <stddef.h>
#include <stdint.h>

#include "cli.h"
#include "vbnl/vbnl.h"

/* `vbnl bench` (bench.c). */
int cmd_bench(int argc, char **argv);

/* The equal-time and equal-count comparisons of `vbnl bench --equal-time` (bench_equal.c). Scene
 * files are read from examples/ relative to the working directory (the repository's root). */
typedef struct cmd_bench_equal_opts {
    const char *out_dir;
    uint32_t size;
    const double *budgets;
    int nb;                 /* 0: no equal-time runs */
    double ref_time;
    uint32_t ref_spp;       /* > 0: references by sample count instead of ref_time */
    const char *only_scene; /* NULL: every scene */
    const char *methods;    /* comma-separated method labels, NULL: all */
    uint32_t count;         /* equal-count run with this many virtual lights, 0: none */
    uint32_t count_spp;
    vbnl_sampler_kind sampler; /* of the methods' renders (references: the default) */
    uint32_t runs;          /* equal-time runs per cell (seeds 7, 8, ...): the median is reported */
} cmd_bench_equal_opts;
int cmd_bench_equal_time(const cmd_bench_equal_opts *o);

/* Error metrics of an image against a reference (compare.c), both RGBA floats, n pixels; the
 * definitions are in compare.c's header comment. */
typedef struct cmd_metrics {
    double rmae, mse, rel_mse, outliers, energy;
} cmd_metrics;
void cmd_image_metrics(const float *img, const float *ref, size_t n, cmd_metrics *m);
/* rMAE as the VBNL paper defines it: mean |I - I_ref| / (I_ref + eps), eps = cmd_rmae_eps. */
double cmd_rmae(const float *img, const float *ref, size_t n);
/* eps = 0.01 x the mean of the reference's R, G, B values. */
double cmd_rmae_eps(const float *ref, size_t n);

/* `vbnl compare` (compare.c). */
int cmd_compare(int argc, char **argv);

/* A frame over many machines (docs/farm.md): `vbnl farm` (farm.c) submits the job graph to
 * Slurm; its stages are `vbnl prepare` and `vbnl photons` (stages.c), `vbnl render --crop` and
 * `vbnl merge-lights`, `vbnl merge-tiles` (merge.c), each usable on its own. */
int cmd_farm(int argc, char **argv);
int cmd_prepare(int argc, char **argv);
int cmd_photons(int argc, char **argv);
int cmd_merge_lights(int argc, char **argv);
int cmd_merge_tiles(int argc, char **argv);

#endif
