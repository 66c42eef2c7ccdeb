/* Benchmark of photon splitting (Li et al. 2022, Section 3.3); built, not run by `meson test`.
 *
 * Scene: McGuire's CornellBox-Original.obj (through vbnl_mesh_import), camera in front of the
 * open side. VLs: the paper's placement without elimination (Section 3.1, Fig. 6a): a camera
 * ray, a cosine bounce at its hit, a VL at the secondary hit with its normal facing the
 * incoming ray; radius alpha_r r_max of Eq. 1 (alpha_r = 2, A = the total triangle area).
 * Reports, median of 3 runs per index variant: time, photon paths/s, rays/s, deposits/s, the
 * memory of the index and the profile set, and the raw Embree incoherent ray rate
 * (vbnl_scene_measure_ray_rate) of the same scene. Also photon tracing with an empty VL set
 * (no splitting) to separate the cost of the splitting itself.
 *
 * Usage: bench_splitting [photon_paths (2e6)] [vl_count (1e5)] [threads (0 = all)] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "context.h"
#include "octahedral.h"
#include "profiles.h"
#include "rng.h"
#include "sampling.h"
#include "scene_internal.h"
#include "splitting.h"
#include "vbnl/mesh_import.h"
#include "vbnl/vbnl.h"
#include "vl_index.h"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double world_area(const vbnl_scene *s)
{
    double a = 0.0;
    for (uint32_t g = 0; g < s->geom_count; ++g) {
        const scene_geom *ge = &s->geoms[g];
        if (ge->kind != SCENE_GEOM_MESH || ge->group != VBNL_GROUP_WORLD)
            continue;
        const scene_mesh *m = &ge->u.mesh;
        for (uint32_t t = 0; t < m->triangle_count; ++t) {
            vec3 p[3];
            for (int k = 0; k < 3; ++k)
                p[k] = v3_load(m->positions + 3 * (size_t)m->indices[3 * t + k]);
            a += 0.5 * v3_len(v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0])));
        }
    }
    return a;
}

int main(int argc, char **argv)
{
    uint64_t paths = argc > 1 ? (uint64_t)atof(argv[1]) : 2000000;
    uint32_t nvl = argc > 2 ? (uint32_t)atof(argv[2]) : 100000;
    unsigned threads = argc > 3 ? (unsigned)atoi(argv[3]) : 0;
    const char *shared = getenv("VBNL_SHARED_DIR");
    char path[1024];
    snprintf(path, sizeof(path), "%s/scenes/cornell-box-mcguire/CornellBox-Original.obj", shared ? shared : "/work/shared");

    vbnl_context_desc cd = {threads};
    vbnl_context *ctx = NULL;
    vbnl_error err;
    if (vbnl_context_create(&cd, &ctx, &err) != VBNL_OK)
        return 1;
    vbnl_scene *s = NULL;
    vbnl_scene_create(ctx, &s, NULL);
    vbnl_mesh_import_stats ms;
    if (vbnl_mesh_import(s, path, NULL, &ms, &err) != VBNL_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 77;
    }
    float pos[3] = {0, 1, 3.4f}, target[3] = {0, 1, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, target, up, 40.0f, 1.0f, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
    if (vbnl_scene_commit(s, &err) != VBNL_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    unsigned nthreads = vbnl_context_thread_count(ctx);
    double area = world_area(s);

    /* VL placement (Section 3.1, Fig. 6a). */
    vec3 *c = malloc(sizeof(vec3) * nvl), *n = malloc(sizeof(vec3) * nvl);
    float *r = malloc(sizeof(float) * nvl);
    uint8_t *glossy = malloc(nvl);
    float rad = 2.0f * sqrtf((float)(area / (2.0 * sqrt(3.0) * nvl)));
    vbnl_rng rng = vbnl_rng_make(3, 3);
    uint32_t k = 0;
    while (k < nvl) {
        vec3 o, d;
        vbnl_camera_ray(&s->camera, 512, 512, vbnl_rng_next(&rng) * 512, vbnl_rng_next(&rng) * 512, &o, &d);
        vbnl_hit h;
        if (!vbnl_scene_intersect(s, o, d, INFINITY, &h))
            continue;
        vec3 ng = v3_dot(h.ng, d) > 0.0f ? v3_neg(h.ng) : h.ng;
        frame f = frame_from_normal(ng);
        vec3 d2 = frame_to_world(&f, sample_cosine_hemisphere(vbnl_rng_next2(&rng)));
        vbnl_hit h2;
        if (!vbnl_scene_intersect(s, vbnl_offset_ray_origin(h.p, ng, d2), d2, INFINITY, &h2) ||
            vbnl_bsdf_is_delta(&s->materials[h2.material].bsdf))
            continue;
        c[k] = h2.p;
        n[k] = v3_dot(h2.ng, d2) > 0.0f ? v3_neg(h2.ng) : h2.ng;
        r[k] = rad;
        glossy[k] = s->materials[h2.material].bsdf.type != VBNL_MATERIAL_LAMBERT;
        ++k;
    }
    double raw = 0.0;
    vbnl_scene_measure_ray_rate(ctx, s, 1000000, 512, 512, &raw, NULL);
    printf("scene: %s, %llu triangles, area %.3f; %u VLs, r = %.4f; %llu photon paths; %u threads\n", path,
           (unsigned long long)s->triangle_count, area, nvl, rad, (unsigned long long)paths, nthreads);
    printf("raw Embree incoherent ray rate: %.2f Mrays/s\n", raw * 1e-6);

    vbnl_hemioct *map = NULL;
    vbnl_hemioct_create(16, &map);
    double unit = vbnl_split_photon_unit(s, paths);
    struct {
        const char *name;
        vbnl_vl_index_kind kind;
        float cell_scale;
        uint32_t count;
    } variants[] = {
        {"tracing only (no VLs)", VBNL_VL_INDEX_GRID, 2.0f, 0},
        {"grid, cell = 2 r", VBNL_VL_INDEX_GRID, 2.0f, nvl},
        {"grid, cell = 1 r", VBNL_VL_INDEX_GRID, 1.0f, nvl},
        {"embree point query", VBNL_VL_INDEX_EMBREE, 0.0f, nvl},
    };
    for (size_t v = 0; v < sizeof(variants) / sizeof(variants[0]); ++v) {
        vbnl_vl_index_desc xd = {c, r, n, variants[v].count, variants[v].kind, variants[v].cell_scale, ctx->device};
        vbnl_vl_index *idx = NULL;
        double tb = vbnl_now();
        if (vbnl_vl_index_create(&xd, &idx) != VBNL_OK)
            return 1;
        tb = vbnl_now() - tb;
        double times[3];
        vbnl_split_stats st;
        size_t pbytes = 0;
        for (int run = 0; run < 3; ++run) {
            vbnl_profile_set *ps = NULL;
            vbnl_profile_set_create_fixed(map, variants[v].count, glossy, unit, &ps);
            vbnl_split_desc d;
            vbnl_split_desc_init(&d);
            d.scene = s;
            d.index = idx;
            d.vl_normals = n;
            d.profiles = ps;
            d.photon_paths = paths;
            d.seed = 1;
            vbnl_split_photons(&d, ctx->pool, NULL, &st);
            times[run] = st.seconds;
            pbytes = vbnl_profile_set_bytes(ps);
            vbnl_profile_set_destroy(ps);
        }
        qsort(times, 3, sizeof(double), cmp_double);
        double t = times[1];
        printf("%-24s %.3f s (runs %.3f %.3f %.3f) | %.3f Mpaths/s | %.2f Mrays/s (%.0f%% of raw) | %.2f Mdeposits/s | "
               "%.2f hits/path, %.1f%% covered, %.2f VLs/covered hit, %llu overflow | index %.2f MB (build %.3f s), "
               "profiles %.2f MB\n",
               variants[v].name, t, times[0], times[1], times[2], st.paths / t * 1e-6, st.rays / t * 1e-6,
               100.0 * st.rays / t / raw, st.deposits / t * 1e-6, (double)st.hits / st.paths,
               100.0 * st.covered_hits / (st.hits ? st.hits : 1),
               (double)st.deposits / (st.covered_hits ? st.covered_hits : 1), (unsigned long long)st.overflow,
               vbnl_vl_index_bytes(idx) / 1048576.0, tb, pbytes / 1048576.0);
        vbnl_vl_index_destroy(idx);
    }
    vbnl_hemioct_destroy(map);
    free(c);
    free(n);
    free(r);
    free(glossy);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
    return 0;
}
