/* vbnl object layer: camera { } and POV-Ray 3.7's camera set-up onto the core camera: the camera
 * types of the reference's "Camera Types" (omnimax excepted), mesh_camera among them, and focal
 * blur as a thin lens. */
#include <math.h>
#include <stdlib.h>
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
    pov_set3(c->look_at, 0, 0, 1);
    c->angle = 90;  /* what the fisheye, ultra_wide_angle and cylinder cameras see without `angle` */
    c->angle_v = 0; /* spherical: half the horizontal angle unless given */
    c->focal_distance = -1;
    c->projection = VBNL_CAMERA_PERSPECTIVE;
    pov_m4_identity(c->m);
}

static void camera_transform(const pov_item *it, const double m[16])
{
    pov_cam *c = it->target;
    pov_m4_mul(m, c->m, c->m);
}

static const struct {
    const char *kw;
    vbnl_camera_projection projection;
} projections[] = {
    {"perspective", VBNL_CAMERA_PERSPECTIVE}, {"orthographic", VBNL_CAMERA_ORTHOGRAPHIC},
    {"fisheye", VBNL_CAMERA_FISHEYE},         {"ultra_wide_angle", VBNL_CAMERA_ULTRA_WIDE_ANGLE},
    {"panoramic", VBNL_CAMERA_PANORAMIC},     {"spherical", VBNL_CAMERA_SPHERICAL},
};

static vbnl_result camera_type(const pov_item *it)
{
    pov_cam *c = it->target;
    vbnl_sdl_next(it->p);
    pov_camera_release(c);
    for (size_t i = 0; i < sizeof projections / sizeof projections[0]; ++i)
        if (!strcmp(it->kw, projections[i].kw)) {
            c->projection = projections[i].projection;
            return VBNL_OK;
        }
    if (!strcmp(it->kw, "cylinder")) {
        double f;
        if (vbnl_sdl_parse_float(it->p, &f) != VBNL_OK)
            return VBNL_ERR_PARSE;
        if (!(f == 1 || f == 2 || f == 3 || f == 4))
            return vbnl_sdl_error(it->p, &it->loc, "cylinder camera type %g: valid types are 1 to 4", f);
        c->projection = (vbnl_camera_projection)(VBNL_CAMERA_CYLINDER_1 + (int)f - 1);
        return VBNL_OK;
    }
    /* omnimax */
    vbnl_sdl_warning(it->p, &it->loc, "camera type '%s' is not supported; rendering with a perspective camera", it->kw);
    c->projection = VBNL_CAMERA_PERSPECTIVE;
    return VBNL_OK;
}

/* ---- mesh_camera --------------------------------------------------------------------------------- */

/* The meshes of a mesh_camera, one primitive each, shared by the copies of the camera. */
typedef struct pov_cam_meshes {
    int refs;
    pov_obj obj;
} pov_cam_meshes;

void pov_camera_copy(pov_cam *dst, const pov_cam *src)
{
    *dst = *src;
    if (dst->meshes)
        dst->meshes->refs++;
}

void pov_camera_release(pov_cam *c)
{
    if (c->meshes && --c->meshes->refs == 0) {
        pov_obj_clear(&c->meshes->obj);
        free(c->meshes);
    }
    c->meshes = NULL;
}

/* 1 when a number follows (an optional float), not a keyword such as mesh. */
static int float_follows(vbnl_sdl_parser *p)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_IDENT) {
        const vbnl_sdl_value *v = t->keyword ? NULL : vbnl_sdl_lookup(p, t->text);
        return v && v->kind == VBNL_SDL_FLOAT;
    }
    return t->kind == VBNL_SDL_TOK_NUMBER || (t->kind == VBNL_SDL_TOK_PUNCT && (t->op == '-' || t->op == '('));
}

/* mesh_camera { RAYS_PER_PIXEL, DISTRIBUTION [, MAX_DISTANCE] mesh { } | mesh2 { } ... [smooth] }
 * with POV-Ray's checks (Parse_Mesh_Camera). */
static vbnl_result mesh_camera(const pov_item *it)
{
    pov_cam *c = it->target;
    pov_loader *L = it->ctx;
    vbnl_sdl_parser *p = it->p;
    vbnl_sdl_next(p);
    double rays, dist, max_distance = 0;
    if (vbnl_sdl_expect(p, '{', "after 'mesh_camera'") != VBNL_OK || vbnl_sdl_parse_float(p, &rays) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_accept(p, ',');
    if (vbnl_sdl_parse_float(p, &dist) != VBNL_OK)
        return VBNL_ERR_PARSE;
    vbnl_sdl_accept(p, ',');
    if (float_follows(p) && vbnl_sdl_parse_float(p, &max_distance) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(rays >= 1 && rays < 1e6))
        return vbnl_sdl_error(p, &it->loc, "mesh_camera: rays per pixel must be at least 1, got %g", rays);
    if (!(dist >= 0 && dist < 4))
        return vbnl_sdl_error(p, &it->loc, "mesh_camera: distribution %g is not one of 0, 1, 2, 3", dist);
    c->mesh_rays = (unsigned)rays;
    c->mesh_distribution = (unsigned)dist;
    if (c->mesh_distribution >= 2 && c->mesh_rays != 1)
        return vbnl_sdl_error(p, &it->loc, "mesh_camera: rays per pixel must be 1 for distributions 2 and 3");
    if (max_distance > 0)
        vbnl_sdl_warning(p, &it->loc, "mesh_camera: the maximum distance %g is ignored (rays are not shortened)",
                         max_distance);
    pov_camera_release(c);
    if (!(c->meshes = calloc(1, sizeof *c->meshes)))
        return pov_oom(L);
    c->meshes->refs = 1;
    c->projection = VBNL_CAMERA_MESH;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (!pov_is_word(t, "mesh") && !pov_is_word(t, "mesh2"))
            break;
        vbnl_sdl_loc ml = t->loc;
        pov_obj one = {0};
        vbnl_result r = pov_parse_member(L, &one);
        if (r == VBNL_OK && (one.n != 1 || one.v[0].kind != POV_PRIM_MESH))
            r = vbnl_sdl_error(p, &ml, "mesh_camera: a mesh must be made of triangles only");
        if (r == VBNL_OK && !pov_obj_move(&c->meshes->obj, &one))
            r = pov_oom(L);
        pov_obj_clear(&one);
        if (r != VBNL_OK)
            return r;
    }
    c->mesh_smooth = 0;
    if (pov_is_word(vbnl_sdl_peek(p), "smooth")) {
        vbnl_sdl_next(p);
        if (c->mesh_distribution != 3)
            return vbnl_sdl_error(p, &it->loc, "mesh_camera: smooth needs distribution 3");
        c->mesh_smooth = 1;
    }
    const size_t n = c->meshes->obj.n;
    if (n == 0)
        return vbnl_sdl_error(p, &it->loc, "mesh_camera needs a mesh or mesh2");
    if (c->mesh_distribution == 0 && c->mesh_rays > n)
        return vbnl_sdl_error(p, &it->loc, "mesh_camera: rays per pixel (%u) must not exceed the number of meshes (%zu) "
                                           "for distribution 0", c->mesh_rays, n);
    if (c->mesh_distribution == 3 && n > 1)
        vbnl_sdl_warning(p, &it->loc, "mesh_camera: distribution 3 uses the first mesh; the other %zu are ignored", n - 1);
    const pov_mesh *m0 = c->meshes->obj.v[0].mesh;
    if (c->mesh_distribution == 3 && !m0->uv)
        return vbnl_sdl_error(p, &it->loc, "mesh_camera: distribution 3 needs a mesh with uv_vectors");
    if (c->mesh_smooth && !m0->nrm)
        return vbnl_sdl_error(p, &it->loc, "mesh_camera: smooth needs a mesh with normals");
    return vbnl_sdl_expect(p, '}', "to close the mesh_camera");
}

vbnl_result pov_camera_meshes(pov_loader *L, const pov_cam *c, vbnl_camera_desc *out, void **storage, vbnl_error *err)
{
    (void)L;
    *storage = NULL;
    const pov_obj *o = &c->meshes->obj;
    size_t nf = 0;
    for (size_t k = 0; k < o->n; ++k)
        nf += 24 * (size_t)o->v[k].mesh->nt;
    /* one block: the meshes, then their arrays */
    const size_t head = o->n * sizeof(vbnl_camera_mesh);
    char *block = malloc(head + (nf ? nf : 1) * sizeof(float));
    if (!block)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory making the mesh camera");
    vbnl_camera_mesh *meshes = (vbnl_camera_mesh *)(void *)block;
    memset(meshes, 0, head);
    float *next = (float *)(void *)(block + head);
    for (size_t k = 0; k < o->n; ++k) {
        const pov_mesh *m = o->v[k].mesh;
        vbnl_camera_mesh *d = &meshes[k];
        d->triangle_count = m->nt;
        float *pos = next, *nrm = m->nrm ? pos + 9 * (size_t)m->nt : NULL;
        float *uv = m->uv ? (nrm ? nrm : pos) + 9 * (size_t)m->nt : NULL;
        for (uint32_t t = 0; t < m->nt; ++t)
            for (int j = 0; j < 3; ++j) {
                const uint32_t v = m->idx[3 * (size_t)t + (size_t)j];
                for (int a = 0; a < 3; ++a) {
                    pos[9 * (size_t)t + 3 * (size_t)j + (size_t)a] = m->pos[3 * (size_t)v + (size_t)a];
                    if (nrm)
                        nrm[9 * (size_t)t + 3 * (size_t)j + (size_t)a] = m->nrm[3 * (size_t)v + (size_t)a];
                }
                if (uv)
                    for (int a = 0; a < 2; ++a)
                        uv[6 * (size_t)t + 2 * (size_t)j + (size_t)a] = m->uv[2 * (size_t)v + (size_t)a];
            }
        next = (uv ? uv + 6 * (size_t)m->nt : nrm ? nrm + 9 * (size_t)m->nt : pos + 9 * (size_t)m->nt);
        d->positions = pos;
        d->normals = nrm;
        d->uvs = uv;
        for (int i = 0; i < 16; ++i)
            d->transform[i] = (float)o->v[k].m[i];
    }
    /* POV-Ray's offset and reversal: the z of the camera's location and direction */
    double loc[3], dir[3];
    pov_m4_point(c->m, c->loc, loc);
    pov_m4_dir(c->m, c->dir, dir);
    out->projection = VBNL_CAMERA_MESH;
    out->meshes = meshes;
    out->mesh_count = (uint32_t)o->n;
    out->mesh_distribution = c->mesh_distribution;
    out->mesh_rays_per_pixel = c->mesh_rays;
    out->mesh_smooth = (uint32_t)c->mesh_smooth;
    out->mesh_offset = (float)loc[2];
    out->mesh_reverse = dir[2] < -1e-10;
    out->lens_radius = 0;
    *storage = block;
    return VBNL_OK;
}

static vbnl_result look_at(const pov_item *it)
{
    pov_cam *c = it->target;
    vbnl_sdl_next(it->p);
    c->have_look_at = 1;
    return vbnl_sdl_parse_vector(it->p, 3, c->look_at);
}

static vbnl_result up_right(const pov_item *it)
{
    pov_cam *c = it->target;
    vbnl_sdl_next(it->p);
    int up = !strcmp(it->kw, "up");
    *(up ? &c->have_up : &c->have_right) = 1;
    return vbnl_sdl_parse_vector(it->p, 3, up ? c->up : c->right);
}

/* 1 when the next token may start a number (an optional float follows). */
static int number_follows(vbnl_sdl_parser *p)
{
    const vbnl_sdl_token *t = vbnl_sdl_peek(p);
    if (t->kind == VBNL_SDL_TOK_IDENT && !t->keyword) {
        const vbnl_sdl_value *v = vbnl_sdl_lookup(p, t->text);
        return v && v->kind == VBNL_SDL_FLOAT;
    }
    return t->kind == VBNL_SDL_TOK_NUMBER || (t->kind == VBNL_SDL_TOK_PUNCT && (t->op == '-' || t->op == '(')) ||
           t->kind == VBNL_SDL_TOK_IDENT;
}

/* angle: the perspective camera's horizontal field of view in (0, 180) (an optional second number
 * is ignored, as POV-Ray does); optional for the orthographic camera, where 0 leaves the vectors
 * alone; "angle H [, V]" for the spherical camera; the field of the other types. */
static vbnl_result angle(const pov_item *it)
{
    pov_cam *c = it->target;
    vbnl_sdl_next(it->p);
    double a = 0, f;
    int given = c->projection != VBNL_CAMERA_ORTHOGRAPHIC || number_follows(it->p);
    if (given && vbnl_sdl_parse_float(it->p, &a) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (a < 0)
        return vbnl_sdl_error(it->p, &it->loc, "negative camera angle %g", a);
    c->angle = a;
    c->have_angle = 1;
    if (c->projection == VBNL_CAMERA_SPHERICAL) {
        int comma = vbnl_sdl_accept(it->p, ',');
        if (comma || number_follows(it->p)) {
            if (vbnl_sdl_parse_float(it->p, &c->angle_v) != VBNL_OK)
                return VBNL_ERR_PARSE;
            if (c->angle_v < 0)
                return vbnl_sdl_error(it->p, &it->loc, "negative vertical camera angle %g", c->angle_v);
            c->have_angle_v = 1;
        }
        return VBNL_OK;
    }
    if ((c->projection == VBNL_CAMERA_PERSPECTIVE || c->projection == VBNL_CAMERA_ORTHOGRAPHIC) && a >= 180)
        return vbnl_sdl_error(it->p, &it->loc, "camera angle must be smaller than 180 degrees, got %g", a);
    if (c->projection == VBNL_CAMERA_PERSPECTIVE && vbnl_sdl_peek(it->p)->kind == VBNL_SDL_TOK_NUMBER)
        return vbnl_sdl_parse_float(it->p, &f);
    if (a > 360)
        return vbnl_sdl_error(it->p, &it->loc, "camera angle must not exceed 360 degrees, got %g", a);
    return VBNL_OK;
}

static vbnl_result aperture(const pov_item *it)
{
    pov_cam *c = it->target;
    vbnl_sdl_next(it->p);
    return vbnl_sdl_parse_float(it->p, &c->aperture);
}

/* blur_samples [MIN ,] MAX: the comma is optional, as in POV-Ray. The count only enables focal
 * blur: vbnl samples the lens with every camera sample. */
static vbnl_result blur_samples(const pov_item *it)
{
    pov_cam *c = it->target;
    vbnl_sdl_next(it->p);
    double n, m = 0;
    if (vbnl_sdl_parse_float(it->p, &n) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (!(n > 0))
        return vbnl_sdl_error(it->p, &it->loc, "blur_samples must be > 0, got %g", n);
    if ((vbnl_sdl_accept(it->p, ',') || vbnl_sdl_peek(it->p)->kind == VBNL_SDL_TOK_NUMBER) &&
        vbnl_sdl_parse_float(it->p, &m) != VBNL_OK)
        return VBNL_ERR_PARSE;
    if (m > 0 && n > m)
        return vbnl_sdl_error(it->p, &it->loc, "blur_samples: the minimum %g exceeds the maximum %g", n, m);
    c->blur_samples = m > 0 ? m : n;
    return VBNL_OK;
}

static vbnl_result focal_point(const pov_item *it)
{
    pov_cam *c = it->target;
    double fp[3];
    vbnl_sdl_next(it->p);
    if (vbnl_sdl_parse_vector(it->p, 3, fp) != VBNL_OK)
        return VBNL_ERR_PARSE;
    double d[3] = {fp[0] - c->loc[0], fp[1] - c->loc[1], fp[2] - c->loc[2]};
    c->focal_distance = pov_len3(d);
    return VBNL_OK;
}

static vbnl_result camera_normal(const pov_item *it)
{
    vbnl_sdl_next(it->p);
    vbnl_sdl_warning(it->p, &it->loc, "camera normal perturbation is ignored");
    return vbnl_sdl_skip_block(it->p);
}

static const pov_row camera_rows[] = {
    {"perspective", camera_type, 0},
    {"orthographic", camera_type, 0},
    {"fisheye", camera_type, 0},
    {"ultra_wide_angle", camera_type, 0},
    {"omnimax", camera_type, 0},
    {"panoramic", camera_type, 0},
    {"spherical", camera_type, 0},
    {"cylinder", camera_type, 0},
    {"mesh_camera", mesh_camera, 0},
    {"location", pov_item_vec3, CAM_FIELD(loc)},
    {"look_at", look_at, 0},
    {"right", up_right, 0},
    {"up", up_right, 0},
    {"direction", pov_item_vec3, CAM_FIELD(dir)},
    {"sky", pov_item_vec3, CAM_FIELD(sky)},
    {"angle", angle, 0},
    {"focal_point", focal_point, 0},
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
        pov_camera_release(c);
        pov_camera_copy(c, d);
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
    const int flat = c->projection == VBNL_CAMERA_PERSPECTIVE || c->projection == VBNL_CAMERA_ORTHOGRAPHIC;
    if (c->have_angle && flat && c->angle > 0) {
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
    if (c->projection == VBNL_CAMERA_ORTHOGRAPHIC && ((!c->have_up && !c->have_right) || c->have_angle)) {
        /* right and up grow to the area the perspective camera sees at the look_at distance */
        double to[3] = {c->look_at[0] - loc_[0], c->look_at[1] - loc_[1], c->look_at[2] - loc_[2]};
        double k1 = pov_len3(to), k2 = pov_len3(dir);
        if (k1 > 1e-10 && k2 > 1e-10) {
            pov_scale3(right, k1 / k2);
            pov_scale3(up, k1 / k2);
        }
    }
    double focal = c->focal_distance < 0 ? pov_len3(dir) : c->focal_distance;
    pov_m4_point(c->m, loc_, loc_);
    pov_m4_dir(c->m, dir, dir);
    pov_m4_dir(c->m, right, right);
    pov_m4_dir(c->m, up, up);
    if (!(pov_len3(dir) > 0) || !(pov_len3(right) > 0) || !(pov_len3(up) > 0))
        return vbnl_sdl_error(L->c.parser, &loc, "camera direction, right and up must not be zero");
    vbnl_camera_desc_init(out);
    for (int i = 0; i < 3; ++i) {
        out->position[i] = (float)loc_[i];
        out->forward[i] = (float)dir[i];
        out->right[i] = (float)right[i];
        out->up[i] = (float)up[i];
    }
    out->projection = c->projection;
    out->angle[0] = (float)c->angle;
    if (c->projection == VBNL_CAMERA_SPHERICAL) {
        out->angle[0] = c->have_angle ? (float)c->angle : 360.0f;
        out->angle[1] = c->have_angle_v ? (float)c->angle_v : out->angle[0] * 0.5f;
    }
    if (c->aperture != 0 && c->blur_samples > 0) {
        /* POV-Ray spreads its eye points over a disc of radius 0.5 scaled by half the aperture
         * (the measurement against povray is in docs/scene-language.md, "Focal blur") */
        out->lens_radius = (float)(0.25 * fabs(c->aperture));
        out->focal_distance = (float)(focal > 0 ? focal : 1.0);
    }
    return VBNL_OK;
}
