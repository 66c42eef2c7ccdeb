/* Loading scene files for the module: mesh files through assimp (the ABI's load_scene_file) and,
 * for the bench commands, POV-Ray scene files through the scene parser. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "module.h"
#include "vbnl/mesh_import.h"
#include "vbnl/pov_scene.h"

static int has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

int module_is_pov(const char *path) { return has_extension(path, ".pov") || has_extension(path, ".inc"); }

static void print_diag(const vbnl_sdl_diag *d, void *user)
{
    (void)user;
    fputs(d->text, stderr);
}

/* A POV-Ray scene file; the integrator and parameters it selects are not kept (the bench commands
 * choose their own). plugin.c loads the scenes of the ABI itself, keeping them. */
static vbnl_result load_pov(vbnl_context *ctx, const char *path, uint32_t width, uint32_t height, vbnl_scene **out,
                            vbnl_error *err)
{
    *out = NULL;
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    o.width = (int)width;
    o.height = (int)height;
    o.diag = print_diag;
    vbnl_pov_scene *ps = NULL;
    vbnl_result r = vbnl_pov_load_file(ctx, path, &o, &ps, err);
    if (r != VBNL_OK)
        return r;
    *out = vbnl_pov_scene_take_scene(ps);
    vbnl_pov_scene_destroy(ps);
    return VBNL_OK;
}

vbnl_result module_load_scene(vbnl_context *ctx, const char *path, const module_camera *cam, float aspect,
                              vbnl_scene **out, vbnl_error *err)
{
    *out = NULL;
    if (module_is_pov(path)) {
        uint32_t h = 480, w = (uint32_t)lroundf(480.0f * (aspect > 0 ? aspect : 1.0f));
        return load_pov(ctx, path, w ? w : 1, h, out, err);
    }
    vbnl_scene *scene;
    vbnl_result r = vbnl_scene_create(ctx, &scene, err);
    if (r != VBNL_OK)
        return r;
    vbnl_mesh_import_stats st;
    if ((r = vbnl_mesh_import(scene, path, NULL, &st, err)) != VBNL_OK)
        goto fail;
    if (st.emissive_materials == 0) {
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "%s: no emissive material (MTL Ke > 0): the image would be black", path);
        goto fail;
    }
    static const float up[3] = {0.0f, 1.0f, 0.0f};
    vbnl_camera_desc cd;
    if (cam && cam->given) {
        r = vbnl_camera_look_at(&cd, cam->position, cam->target, up, cam->fov_y, aspect, err);
    } else {
        /* Frame the bounding box from +z with a 40 degree vertical field of view. */
        vbnl_scene_info info;
        if ((r = vbnl_scene_get_info(scene, &info, err)) != VBNL_OK)
            goto fail;
        const float fov = 40.0f, t = tanf(fov * 0.5f * 3.14159265f / 180.0f);
        float c[3], half[3];
        for (int i = 0; i < 3; ++i) {
            c[i] = 0.5f * (info.bounds_min[i] + info.bounds_max[i]);
            half[i] = 0.5f * (info.bounds_max[i] - info.bounds_min[i]);
        }
        float fit = fmaxf(half[0] / aspect, half[1]);
        float pos[3] = {c[0], c[1], c[2] + half[2] + 1.05f * fit / t};
        r = vbnl_camera_look_at(&cd, pos, c, up, fov, aspect, err);
    }
    if (r != VBNL_OK || (r = vbnl_scene_set_camera(scene, &cd, err)) != VBNL_OK ||
        (r = vbnl_scene_commit(scene, err)) != VBNL_OK)
        goto fail;
    *out = scene;
    return VBNL_OK;
fail:
    vbnl_scene_destroy(scene);
    return r;
}
