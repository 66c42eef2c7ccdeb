/* Loading scenes for the host: POV-Ray scene files through the scene parser, mesh files through
 * assimp. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "host.h"
#include "vbnl/mesh_import.h"
#include "vbnl/pov_scene.h"

int host_parse_camera(const char *text, host_camera *cam)
{
    float v[7];
    char extra;
    if (sscanf(text, "%f,%f,%f,%f,%f,%f,%f%c", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6], &extra) != 7)
        return -1;
    for (int i = 0; i < 7; ++i)
        if (!isfinite(v[i]))
            return -1;
    memcpy(cam->position, v, sizeof(float) * 3);
    memcpy(cam->target, v + 3, sizeof(float) * 3);
    cam->fov_y = v[6];
    cam->given = 1;
    return 0;
}

static int has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

int host_is_pov(const char *path) { return has_extension(path, ".pov") || has_extension(path, ".inc"); }

static void print_diag(const vbnl_sdl_diag *d, void *user)
{
    (void)user;
    fputs(d->text, stderr);
}

vbnl_result host_load_pov(vbnl_context *ctx, const char *path, uint32_t width, uint32_t height,
                          vbnl_scene **out, char *integrator, size_t size, vbnl_params **params,
                          vbnl_error *err)
{
    *out = NULL;
    if (params)
        *params = NULL;
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    o.width = (int)width;
    o.height = (int)height;
    o.diag = print_diag;
    vbnl_pov_scene *ps = NULL;
    vbnl_result r = vbnl_pov_load_file(ctx, path, &o, &ps, err);
    if (r != VBNL_OK)
        return r;
    if (integrator && size)
        snprintf(integrator, size, "%s", vbnl_pov_scene_integrator(ps));
    if (params) {
        if ((r = vbnl_params_create(params, err)) != VBNL_OK ||
            (r = vbnl_params_append(*params, vbnl_pov_scene_params(ps), err)) != VBNL_OK) {
            vbnl_params_destroy(*params);
            *params = NULL;
            vbnl_pov_scene_destroy(ps);
            return r;
        }
    }
    *out = vbnl_pov_scene_take_scene(ps);
    vbnl_pov_scene_destroy(ps);
    return VBNL_OK;
}

vbnl_result host_load_scene(vbnl_context *ctx, const char *path, const host_camera *cam, float aspect,
                            vbnl_scene **out, vbnl_error *err)
{
    *out = NULL;
    if (host_is_pov(path)) {
        uint32_t h = 480, w = (uint32_t)lroundf(480.0f * (aspect > 0 ? aspect : 1.0f));
        return host_load_pov(ctx, path, w ? w : 1, h, out, NULL, 0, NULL, err);
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
