/* vbnl core: POV-Ray 3.7's mesh camera (scene.h, VBNL_CAMERA_MESH; reference section "Mesh
 * Camera"): the scene's own copy of the meshes, a uv index for distribution 3, and the rays. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera_mesh.h"
#include "vbnl/result.h"

/* The scene's copy: the meshes and their arrays in one allocation each and, for distribution 3, a grid of g x g cells over uv [0, 1]^2 listing, in face
 * order, the faces of mesh 0 whose uv bounds touch each cell. */
typedef struct cam_mesh_store {
    vbnl_camera_mesh *meshes;
    float *floats;
    uint32_t grid;
    uint32_t *cell_start; /* grid * grid + 1 */
    uint32_t *cell_faces;
} cam_mesh_store;

static int finite_n(const float *v, size_t n)
{
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* The mesh's transform as the core's matrix; 0 when its linear part cannot be inverted. */
static int mesh_matrix(const float t[16], mat4 *m, float *det)
{
    memcpy(m->m, t, sizeof m->m);
    *det = mat4_det3(m);
    return fabsf(*det) > 0.0f && isfinite(*det);
}

static int build_uv_grid(cam_mesh_store *st)
{
    const vbnl_camera_mesh *m = &st->meshes[0];
    const uint32_t n = m->triangle_count;
    uint32_t g = (uint32_t)sqrt((double)n / 2.0);
    g = g < 1 ? 1 : g > 512 ? 512 : g;
    st->grid = g;
    st->cell_start = calloc((size_t)g * g + 1, sizeof *st->cell_start);
    if (!st->cell_start)
        return 0;
    /* two passes over the faces' cell ranges: count, then fill in face order */
    uint32_t *range = malloc((size_t)n * 4 * sizeof *range);
    if (!range)
        return 0;
    size_t total = 0;
    for (uint32_t t = 0; t < n; ++t) {
        const float *uv = m->uvs + 6 * (size_t)t;
        float lo[2] = {fminf(uv[0], fminf(uv[2], uv[4])), fminf(uv[1], fminf(uv[3], uv[5]))};
        float hi[2] = {fmaxf(uv[0], fmaxf(uv[2], uv[4])), fmaxf(uv[1], fmaxf(uv[3], uv[5]))};
        uint32_t *r = range + 4 * (size_t)t;
        if (hi[0] < 0.0f || hi[1] < 0.0f || lo[0] > 1.0f || lo[1] > 1.0f) {
            r[0] = r[2] = 1; /* empty: outside the image */
            r[1] = r[3] = 0;
            continue;
        }
        for (int k = 0; k < 2; ++k) {
            r[2 * k] = (uint32_t)fminf(fmaxf(lo[k], 0.0f) * (float)g, (float)(g - 1));
            r[2 * k + 1] = (uint32_t)fminf(fmaxf(hi[k], 0.0f) * (float)g, (float)(g - 1));
        }
        for (uint32_t y = r[2]; y <= r[3]; ++y)
            for (uint32_t x = r[0]; x <= r[1]; ++x)
                st->cell_start[y * g + x + 1]++;
        total += (size_t)(r[1] - r[0] + 1) * (r[3] - r[2] + 1);
    }
    for (size_t c = 0; c < (size_t)g * g; ++c)
        st->cell_start[c + 1] += st->cell_start[c];
    st->cell_faces = malloc((total ? total : 1) * sizeof *st->cell_faces);
    uint32_t *fill = malloc((size_t)g * g * sizeof *fill);
    if (!st->cell_faces || !fill) {
        free(fill);
        free(range);
        return 0;
    }
    memcpy(fill, st->cell_start, (size_t)g * g * sizeof *fill);
    for (uint32_t t = 0; t < n; ++t) {
        const uint32_t *r = range + 4 * (size_t)t;
        if (r[0] > r[1])
            continue;
        for (uint32_t y = r[2]; y <= r[3]; ++y)
            for (uint32_t x = r[0]; x <= r[1]; ++x)
                st->cell_faces[fill[y * g + x]++] = t;
    }
    free(fill);
    free(range);
    return 1;
}

void vbi_camera_mesh_free(void *store)
{
    cam_mesh_store *st = store;
    if (!st)
        return;
    free(st->meshes);
    free(st->floats);
    free(st->cell_start);
    free(st->cell_faces);
    free(st);
}

vbnl_result vbi_camera_mesh_copy(vbnl_camera_desc *c, vbnl_error *err)
{
    if (!c->meshes || c->mesh_count == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "a mesh camera needs at least one mesh");
    if (c->mesh_distribution > 3)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mesh camera distribution %u is unknown (0 to 3)",
                              c->mesh_distribution);
    if (c->mesh_rays_per_pixel < 1 || (c->mesh_distribution >= 2 && c->mesh_rays_per_pixel != 1) ||
        (c->mesh_distribution == 0 && c->mesh_rays_per_pixel > c->mesh_count))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "mesh camera rays per pixel %u: at least 1, 1 for distributions 2 and 3, at most "
                              "the number of meshes (%u) for distribution 0",
                              c->mesh_rays_per_pixel, c->mesh_count);
    if (!isfinite(c->mesh_offset))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mesh camera offset must be finite");
    size_t nf = 0;
    for (uint32_t k = 0; k < c->mesh_count; ++k) {
        const vbnl_camera_mesh *m = &c->meshes[k];
        if (m->triangle_count && !m->positions)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mesh camera mesh %u has no positions", k);
        nf += 9 * (size_t)m->triangle_count + (m->normals ? 9 * (size_t)m->triangle_count : 0) +
              (m->uvs ? 6 * (size_t)m->triangle_count : 0);
    }
    const vbnl_camera_mesh *m0 = &c->meshes[0];
    if (c->mesh_distribution == 3 && !m0->uvs)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mesh camera distribution 3 needs uvs on its first mesh");
    if (c->mesh_smooth && (c->mesh_distribution != 3 || !m0->normals))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "a smooth mesh camera needs distribution 3 and normals on its first mesh");
    cam_mesh_store *st = calloc(1, sizeof *st);
    if (!st || !(st->meshes = calloc(c->mesh_count, sizeof *st->meshes)) ||
        !(st->floats = malloc((nf ? nf : 1) * sizeof *st->floats))) {
        vbi_camera_mesh_free(st);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory copying the mesh camera");
    }
    float *f = st->floats;
    for (uint32_t k = 0; k < c->mesh_count; ++k) {
        const vbnl_camera_mesh *m = &c->meshes[k];
        vbnl_camera_mesh *d = &st->meshes[k];
        *d = *m;
        const size_t n = m->triangle_count;
        const float *src[3] = {m->positions, m->normals, m->uvs};
        const float **dst[3] = {&d->positions, &d->normals, &d->uvs};
        const size_t per[3] = {9, 9, 6};
        for (int a = 0; a < 3; ++a) {
            if (!src[a])
                continue;
            if (!finite_n(src[a], per[a] * n)) {
                vbi_camera_mesh_free(st);
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mesh camera mesh %u has values that are not finite",
                                      k);
            }
            memcpy(f, src[a], per[a] * n * sizeof *f);
            *dst[a] = f;
            f += per[a] * n;
        }
        mat4 mm;
        float det;
        if (!finite_n(m->transform, 16) || !mesh_matrix(m->transform, &mm, &det)) {
            vbi_camera_mesh_free(st);
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "mesh camera mesh %u: its transform cannot be inverted",
                                  k);
        }
    }
    if (c->mesh_distribution == 3 && !build_uv_grid(st)) {
        vbi_camera_mesh_free(st);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory indexing the mesh camera's uvs");
    }
    c->meshes = st->meshes;
    c->mesh_index = st;
    return VBNL_OK;
}

/* Barycentric coordinates of uv point (u, v) in face t's uvs; 1 when they are all >= 0. */
static int uv_inside(const float *uv, float u, float v, float b[3])
{
    const float scale = (uv[2] - uv[0]) * (uv[5] - uv[1]) - (uv[4] - uv[0]) * (uv[3] - uv[1]);
    if (scale == 0.0f)
        return 0;
    b[0] = ((uv[2] - u) * (uv[5] - v) - (uv[4] - u) * (uv[3] - v)) / scale;
    b[1] = ((uv[4] - u) * (uv[1] - v) - (uv[0] - u) * (uv[5] - v)) / scale;
    b[2] = ((uv[0] - u) * (uv[3] - v) - (uv[2] - u) * (uv[1] - v)) / scale;
    return b[0] >= 0.0f && b[1] >= 0.0f && b[2] >= 0.0f;
}

/* The first face of mesh m whose uvs hold (u, v), through the store's grid when there is one. */
static int64_t face_at_uv(const cam_mesh_store *st, const vbnl_camera_mesh *m, float u, float v, float b[3])
{
    if (st && st->grid) {
        if (u < 0.0f || v < 0.0f || u > 1.0f || v > 1.0f)
            return -1;
        const uint32_t g = st->grid;
        uint32_t x = (uint32_t)fminf(u * (float)g, (float)(g - 1)), y = (uint32_t)fminf(v * (float)g, (float)(g - 1));
        for (uint32_t i = st->cell_start[y * g + x]; i < st->cell_start[y * g + x + 1]; ++i)
            if (uv_inside(m->uvs + 6 * (size_t)st->cell_faces[i], u, v, b))
                return st->cell_faces[i];
        return -1;
    }
    for (uint32_t t = 0; t < m->triangle_count; ++t)
        if (uv_inside(m->uvs + 6 * (size_t)t, u, v, b))
            return t;
    return -1;
}

int vbi_camera_mesh_ray(const vbnl_camera_desc *c, uint32_t width, uint32_t height, float px, float py, float pick,
                        vec3 *o, vec3 *d)
{
    const cam_mesh_store *st = c->mesh_index;
    if (!c->meshes || c->mesh_count == 0)
        return 0;
    const uint32_t rpp = c->mesh_rays_per_pixel ? c->mesh_rays_per_pixel : 1;
    const uint32_t k = (uint32_t)fminf(fmaxf(pick, 0.0f) * (float)rpp, (float)(rpp - 1));
    const float x = fminf(fmaxf(floorf(px), 0.0f), (float)width - 1.0f);
    const float y = fminf(fmaxf(floorf(py), 0.0f), (float)height - 1.0f);
    const uint64_t pixel = (uint64_t)y * width + (uint64_t)x;
    uint32_t mesh = 0;
    int64_t face = -1;
    float b[3] = {1.0f / 3.0f, 1.0f / 3.0f, 1.0f / 3.0f};
    switch (c->mesh_distribution) {
    case 0:
        mesh = k < c->mesh_count ? k : c->mesh_count - 1;
        face = pixel < c->meshes[mesh].triangle_count ? (int64_t)pixel : -1;
        break;
    case 1: {
        uint64_t f = pixel + (uint64_t)k * width * height;
        for (mesh = 0; mesh < c->mesh_count && f >= c->meshes[mesh].triangle_count; ++mesh)
            f -= c->meshes[mesh].triangle_count;
        face = mesh < c->mesh_count ? (int64_t)f : -1;
        break;
    }
    case 2: {
        const uint32_t cols = width / c->mesh_count ? width / c->mesh_count : 1;
        mesh = (uint32_t)x / cols;
        if (mesh >= c->mesh_count)
            return 0;
        const uint64_t f = (uint64_t)y * cols + ((uint32_t)x - mesh * cols);
        face = f < c->meshes[mesh].triangle_count ? (int64_t)f : -1;
        break;
    }
    default:
        face = face_at_uv(st, &c->meshes[0], px / (float)width, 1.0f - py / (float)height, b);
        break;
    }
    if (face < 0)
        return 0;
    const vbnl_camera_mesh *m = &c->meshes[mesh];
    const float *p = m->positions + 9 * (size_t)face;
    const vec3 a = v3(p[0], p[1], p[2]), bb = v3(p[3], p[4], p[5]), cc = v3(p[6], p[7], p[8]);
    vec3 org = v3_add(v3_add(v3_scale(a, b[0]), v3_scale(bb, b[1])), v3_scale(cc, b[2]));
    vec3 dir = v3_cross(v3_sub(cc, a), v3_sub(bb, a));
    if (c->mesh_smooth && m->normals) {
        const float *n = m->normals + 9 * (size_t)face;
        dir = v3_add(v3_add(v3_scale(v3(n[0], n[1], n[2]), b[0]), v3_scale(v3(n[3], n[4], n[5]), b[1])),
                     v3_scale(v3(n[6], n[7], n[8]), b[2]));
    }
    if (!(v3_len(dir) > 0.0f))
        return 0; /* a degenerate face has no normal */
    dir = v3_norm(dir);
    org = v3_add(org, v3_scale(dir, c->mesh_offset));
    if (c->mesh_reverse)
        dir = v3_neg(dir);
    mat4 mm;
    float det;
    if (!mesh_matrix(m->transform, &mm, &det))
        return 0;
    *o = mat4_point(&mm, org);
    /* the inverse transpose, up to a positive scale: the cofactors times the determinant's sign */
    *d = v3_scale(mat4_normal(&mm, dir), det > 0.0f ? 1.0f : -1.0f);
    return 1;
}

uint64_t vbi_camera_mesh_hash(const vbnl_camera_desc *c, uint64_t h, uint64_t (*hash)(uint64_t, const void *, size_t))
{
    const uint32_t head[5] = {c->mesh_count, c->mesh_distribution, c->mesh_rays_per_pixel, c->mesh_smooth,
                              c->mesh_reverse};
    h = hash(h, head, sizeof head);
    h = hash(h, &c->mesh_offset, sizeof c->mesh_offset);
    for (uint32_t k = 0; c->meshes && k < c->mesh_count; ++k) {
        const vbnl_camera_mesh *m = &c->meshes[k];
        const size_t n = m->triangle_count;
        h = hash(h, &m->triangle_count, sizeof m->triangle_count);
        h = hash(h, m->transform, sizeof m->transform);
        if (m->positions)
            h = hash(h, m->positions, 9 * n * sizeof(float));
        if (m->normals)
            h = hash(h, m->normals, 9 * n * sizeof(float));
        if (m->uvs)
            h = hash(h, m->uvs, 6 * n * sizeof(float));
    }
    return h;
}
