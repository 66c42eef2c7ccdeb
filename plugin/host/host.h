/* Helpers of the `vbnl` command that run inside the plugin module (scene loading, EXR writing,
 * the bench commands): they use the core's public API, which the host executable never links. */
#ifndef VBNL_HOST_H
#define VBNL_HOST_H

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

/* Loads FILE (a mesh file through assimp for now) into a committed scene. Without a camera the
 * scene is framed from +z with a 40 degree vertical field of view. */
vbnl_result host_load_scene(vbnl_context *ctx, const char *path, const host_camera *cam, float aspect,
                            vbnl_scene **out, vbnl_error *err);

/* Writes the film as EXR (all layers, settings as attributes) and, if png_path, an sRGB PNG. */
vbnl_result host_write_outputs(const vbnl_renderer *r, const vbnl_render_settings *s,
                               const char *exr_path, const char *png_path, float exposure, int half,
                               int partial, vbnl_error *err);

/* Checks that a file can be created at `path` (so a render does not fail at the very end). */
vbnl_result host_check_writable(const char *path, vbnl_error *err);

int host_bench_main(int argc, char **argv);
/* The equal-time comparison of `vbnl bench --equal-time` (bench_equal.c). */
int host_bench_equal_time(const char *out_dir, uint32_t size, const double *budgets, int nb, double ref_time,
                          const char *shared_dir, const char *only_scene);

#endif
