/* Helpers of the `vbnl` command that run inside the plugin module (scene loading, EXR writing,
 * the bench commands): they use the core's public API, which the host executable never links. */
#ifndef VBNL_HOST_H
#define VBNL_HOST_H

#include <stddef.h>
#include <stdint.h>

#include "vbnl/vbnl.h"

#include "exit_codes.h"

typedef struct host_camera {
    int given;
    float position[3], target[3];
    float fov_y;
} host_camera;

/* Parses "px,py,pz,tx,ty,tz,fov_degrees". Returns 0 on success. */
int host_parse_camera(const char *text, host_camera *cam);

/* Loads FILE (a POV-Ray scene, or a mesh file through assimp) into a committed scene. Without a
 * camera a mesh file is framed from +z with a 40 degree vertical field of view. */
vbnl_result host_load_scene(vbnl_context *ctx, const char *path, const host_camera *cam, float aspect,
                            vbnl_scene **out, vbnl_error *err);

/* 1 when `path` is a POV-Ray scene file (.pov or .inc). */
int host_is_pov(const char *path);

/* Loads a POV-Ray scene (diagnostics to stderr) into a committed scene; the integrator the
 * scene selected goes to `integrator` (size bytes) and its parameters to *params (caller
 * destroys). The image size is what the scene sees as image_width / image_height. */
vbnl_result host_load_pov(vbnl_context *ctx, const char *path, uint32_t width, uint32_t height,
                          vbnl_scene **out, char *integrator, size_t size, vbnl_params **params,
                          vbnl_error *err);

/* Writes the film as EXR (all layers, settings as attributes) and, if png_path, an sRGB PNG. */
vbnl_result host_write_outputs(const vbnl_renderer *r, const vbnl_render_settings *s,
                               const char *exr_path, const char *png_path, float exposure, int half,
                               int partial, vbnl_error *err);

/* Checks that a file can be created at `path` (so a render does not fail at the very end). */
vbnl_result host_check_writable(const char *path, vbnl_error *err);

int host_bench_main(int argc, char **argv);
/* The equal-time and equal-count comparisons of `vbnl bench --equal-time` (bench_equal.c). */
typedef struct host_bench_equal_opts {
    const char *out_dir;
    uint32_t size;
    const double *budgets;
    int nb;                 /* 0: no equal-time runs */
    double ref_time;
    uint32_t ref_spp;       /* > 0: references by sample count instead of ref_time */
    const char *shared_dir;
    const char *only_scene; /* NULL: every scene */
    const char *methods;    /* comma-separated method labels, NULL: all */
    uint32_t count;         /* equal-count run with this many virtual lights, 0: none */
    uint32_t count_spp;
    vbnl_sampler_kind sampler; /* of the methods' renders (references: the default) */
    uint32_t runs;          /* equal-time runs per cell (seeds 7, 8, ...): the median is reported */
} host_bench_equal_opts;
int host_bench_equal_time(const host_bench_equal_opts *o);

/* Error metrics of an image against a reference (compare.c), both RGBA floats, n pixels; the
 * definitions are in compare.c's header comment. */
typedef struct host_metrics {
    double rmae, mse, rel_mse, outliers, energy;
} host_metrics;
void host_image_metrics(const float *img, const float *ref, size_t n, host_metrics *m);
/* rMAE as the VBNL paper defines it: mean |I - I_ref| / (I_ref + eps), eps = host_rmae_eps. */
double host_rmae(const float *img, const float *ref, size_t n);
/* eps = 0.01 x the mean of the reference's R, G, B values. */
double host_rmae_eps(const float *ref, size_t n);
/* `vbnl compare` (compare.c); argv[0] is "compare". */
int host_compare_main(int argc, char **argv);

#endif
