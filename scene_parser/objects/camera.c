/* vbnl object layer: camera { } and POV-Ray 3.7's camera set-up onto the core camera. */
#include <string.h>

#include "pov_loader.h"

#define CAM_FIELD(f) offsetof(pov_cam, f)

void pov_camera_default(pov_cam *c)
{
    memset(c, 0, sizeof *c);
    pov_set3(c->dir, 0, 0, 1);
    pov_set3(c->up, 0, 1, 0);
    pov_set3(c->right, 1.33, 0, 0);
    pov_set3(c->sky, 0, 1, 0);
    pov_m4_identity(c->m);
}

static void camera_transform(const pov_item *it, const double m[16])
{
    pov_cam *c = it->target;
    pov_m4_mul(m, c->m, c->m);
}

/* orthographic fisheye ...: rendered with the perspective camera. */
static vbnl_result other_type(const pov_item *it)
{
    pov_cam *c = it->target;
    double f;
    vbnl_sdl_next(it->p);
    vbnl_sdl_warning(it->p, &it->loc, "camera type '%s' is not supported; rendering with a perspective camera", it->kw);
    c->other_type = 1;
    if (strcmp(it->kw, "cylinder") == 0)
        return vbnl_sdl_parse_float(it->p, &f);
    if (strcmp(it->kw, "mesh_camera") == 0)
        return vbnl_sdl_skip_block(it->p);
    return VBNL_OK;
}

static vbnl_result look_at(const pov_item *it)
{
    pov_cam *c = it->target;
    vbnl_sdl_next(it->p);
    c->have_look_at = 1;
    return vbnl_sdl_parse_vector(it->p, 3, c->look_at);
}

static vbnl_result angle(const pov_item *it)
{
    pov_cam *c = it->target;
    double f;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &c->angle) != VBNL_OK)
        return VBNL_ERR_PARSE;
    c->have_angle = 1;
    if (c->other_type && c->angle >= 170 && c->angle < 360.0001) {
        vbnl_sdl_warning(it->p, &it->loc, "camera angle %g does not fit a perspective camera; using 170", c->angle);
        c->angle = 170;
    }
    if (!(c->angle > 0 && c->angle < 180))
        return vbnl_sdl_error(it->p, &it->loc, "camera angle must lie in (0, 180) degrees, got %g", c->angle);
    if (vbnl_sdl_peek(it->p)->kind == VBNL_SDL_TOK_NUMBER) /* optional vertical angle: ignored, as in perspective */
        return vbnl_sdl_parse_float(it->p, &f);
    return VBNL_OK;
}

static vbnl_result aperture(const pov_item *it)
{
    double f;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &f) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (f > 0)
        vbnl_sdl_warning(it->p, &it->loc, "focal blur (aperture) is not supported; the camera is a pinhole");
    return VBNL_OK;
}

static vbnl_result blur_samples(const pov_item *it)
{
    double f;
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_float(it->p, &f) != VBNL_OK)
        return VBNL_ERR_PARSE;
    return vbnl_sdl_accept(it->p, ',') ? vbnl_sdl_parse_float(it->p, &f) : VBNL_OK;
}

static vbnl_result camera_normal(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    vbnl_sdl_warning(it->p, &it->loc, "camera normal perturbation is ignored");
    return vbnl_sdl_skip_block(it->p);
}

static const pov_row camera_rows[] = {
    {"perspective", pov_item_word, 0},
    {"orthographic", other_type, 0},
    {"fisheye", other_type, 0},
    {"ultra_wide_angle", other_type, 0},
    {"omnimax", other_type, 0},
    {"panoramic", other_type, 0},
    {"spherical", other_type, 0},
    {"cylinder", other_type, 0},
    {"mesh_camera", other_type, 0},
    {"location", pov_item_vec3, CAM_FIELD(loc)},
    {"look_at", look_at, 0},
    {"right", pov_item_vec3, CAM_FIELD(right)},
    {"up", pov_item_vec3, CAM_FIELD(up)},
    {"direction", pov_item_vec3, CAM_FIELD(dir)},
    {"sky", pov_item_vec3, CAM_FIELD(sky)},
    {"angle", angle, 0},
    {"focal_point", pov_item_any_vec3, 0},
    {"aperture", aperture, 0},
    {"confidence", pov_item_any_float, 0},
    {"variance", pov_item_any_float, 0},
    {"blur_samples", blur_samples, 0},
    {"normal", camera_normal, 0},
    {NULL, NULL, 0},
};

static const pov_row *const camera_tables[] = {pov_transform_rows, camera_rows, NULL};
static const pov_block camera_block = {.name = "camera",
                                       .tables = camera_tables,
                                       .transform = camera_transform};

vbnl_result pov_camera_parse(pov_loader *L, pov_cam *c)
{
    vbnl_sdl_parser *p = L->c.parser;
    if (vbnl_sdl_expect(p, '{', "after 'camera'") != VBNL_OK)
        return VBNL_ERR_PARSE;
    const pov_cam *d = pov_declared(L, vbnl_sdl_peek(p), &pov_camera_type);
    if (d) {
        vbnl_sdl_next(p);
        *c = *d;
    }
    return pov_block_parse(&camera_block, p, L, c, NULL);
}

vbnl_result pov_camera_resolve(pov_loader *L, const pov_cam *c, vbnl_sdl_loc loc, vbnl_camera_desc *out)
{
    vbnl_camera_desc_init(out);
    double loc_[3], dir[3], right[3], up[3];
    memcpy(loc_, c->loc, sizeof loc_);
    memcpy(dir, c->dir, sizeof dir);
    memcpy(right, c->right, sizeof right);
    memcpy(up, c->up, sizeof up);
    if (c->have_angle) {
        double dl = pov_len3(dir);
        if (!(dl > 0))
            return vbnl_sdl_error(L->c.parser, &loc, "camera direction must not be zero");
        pov_scale3(dir, 0.5 * pov_len3(right) / tan(c->angle * POV_PI / 360.0) / dl);
    }
    if (c->have_look_at) {
        double dlen = pov_len3(dir), ulen = pov_len3(up), rlen = pov_len3(right), tmp[3];
        pov_cross3(up, dir, tmp);
        double handed = pov_dot3(tmp, right);
        for (int i = 0; i < 3; ++i)
            dir[i] = c->look_at[i] - loc_[i];
        double l = pov_len3(dir);
        if (!(l > 0))
            return vbnl_sdl_error(L->c.parser, &loc, "camera look_at equals location");
        pov_scale3(dir, 1 / l);
        double saved[3];
        memcpy(saved, right, sizeof saved);
        pov_cross3(c->sky, dir, right);
        if (pov_len3(right) < 1e-10)
            memcpy(right, saved, sizeof right);
        l = pov_len3(right);
        if (l > 0)
            pov_scale3(right, 1 / l);
        pov_cross3(dir, right, up);
        pov_scale3(dir, dlen);
        pov_scale3(right, handed > 0 ? rlen : -rlen);
        pov_scale3(up, ulen);
    }
    pov_m4_point(c->m, loc_, loc_);
    pov_m4_dir(c->m, dir, dir);
    pov_m4_dir(c->m, right, right);
    pov_m4_dir(c->m, up, up);
    if (!(pov_len3(dir) > 0) || !(pov_len3(right) > 0) || !(pov_len3(up) > 0))
        return vbnl_sdl_error(L->c.parser, &loc, "camera direction, right and up must not be zero");
    for (int i = 0; i < 3; ++i) {
        out->position[i] = (float)loc_[i];
        out->forward[i] = (float)dir[i];
        out->right[i] = (float)right[i];
        out->up[i] = (float)up[i];
    }
    return VBNL_OK;
}

