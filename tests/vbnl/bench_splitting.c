/* Benchmark of photon splitting (Li et al. 2022, Section 3.3); built, not run by `meson test`.
 *
 * Scene: McGuire's CornellBox-Original.obj (through vbnl_mesh_import), camera in front of the
 * open side. VLs: the paper's placement without elimination (Section 3.1, Fig. 6a): a camera
 * ray, a cosine bounce at its hit, a VL at the secondary hit with its normal facing the
 * incoming ray; radius alpha_r r_max of Eq. 1 (alpha_r = 2, A = the total triangle area).
 * Reports, median of the runs per index variant: time, photon paths/s, rays/s, deposits/s, the
 * memory of the index and the profile set, and the raw Embree incoherent ray rate of the same
 * scene: the faster of one ray at a time (rtcIntersect1) and eight to a packet (rtcIntersect8),
 * since splitting traces eight paths as one packet (vbnl_scene_measure_ray_rates: closest,
 * closest_packet). Also photon tracing with an empty VL set
 * (no splitting) to separate the cost of the splitting itself; with both rows and the raw rate,
 * a last line splits a ray's CPU time into Embree's (at the ceiling), the walk's and the deposit's.
 *
 * Shared machines: the raw rate is measured again before every run (same rays) and the ratio
 * splitting rays/s : raw rays/s is reported per run (median), once per wall second and once per
 * CPU second of the process; the latter does not count time the threads spent descheduled and
 * is the steadiest figure under load.
 *
 * Usage: bench_splitting [photon_paths (2e6)] [vl_count (1e5)] [threads (0 = all)] [variants (bit mask
 * of the rows below, 0 = all)] [runs (3)] [scene file in examples/mcguire of $VBNL_SOURCE_DIR,
 * else of the working directory (CornellBox-Original.obj; CornellBox-Glossy-Floor.obj has glossy
 * VLs), or a path with a '/' (tools/gen_dense_box.py writes a 320K-triangle variant)] [lights: "camera" (the
 * placement above, one radius) or "pipeline" (vbnl's own stages 1 and 2 with its defaults:
 * M = 10 N candidates, adaptive elimination, r_i = 2 r_i,max: radii over a few powers of two)];
 * a reduced case for callgrind: 20000 100000 1 2 1 (VBNL_BENCH_NO_RAW=1 skips the raw-rate runs).
 * VBNL_BENCH_LAMBERT_VLS=1 gives every VL a Lambertian profile (one sum, no incident map), so
 * that the glossy box's rows against a normal run show what its glossy maps cost; the photon
 * walk is unchanged. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "context.h"
#include "octahedral.h"
#include "pool.h"
#include "prepare.h"
#include "profiles.h"
#include "rng.h"
#include "sampling.h"
#include "scene_internal.h"
#include "splitting.h"
#include "vbnl/mesh_import.h"
#include "vbnl/vbnl.h"
#include "vl_index.h"

/* CPU seconds of the whole process (all threads): on a shared machine, rates per CPU second
 * do not count the time the threads were descheduled. */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The raw Embree incoherent ray rate as vbnl_scene_measure_ray_rate measures it (the same
 * rays: a camera ray, a cosine bounce, the bounce ray traced), per wall second and per CPU
 * second; the rays are made once. */
typedef struct raw_rays {
    const vbnl_scene *s;
    vec3 *o, *d;
    uint32_t n;
    int packet; /* 1: eight rays to a packet (rtcIntersect8), else one at a time (rtcIntersect1) */
} raw_rays;

static void make_raw_rays(raw_rays *rr, uint32_t count)
{
    rr->o = malloc(sizeof(vec3) * count);
    rr->d = malloc(sizeof(vec3) * count);
    vbi_rng rng = vbi_rng_make(0x5eed, 7);
    for (uint64_t attempt = 0; rr->n < count && attempt < (uint64_t)count * 16; ++attempt) {
        vec3 o, d;
        vbi_camera_ray(&rr->s->camera, 512, 512, vbi_rng_next(&rng) * 512, vbi_rng_next(&rng) * 512, &o, &d);
        vbi_hit h;
        if (!vbi_scene_intersect(rr->s, o, d, INFINITY, &h))
            continue;
        vec3 nrm = v3_dot(h.ng, d) < 0.0f ? h.ng : v3_neg(h.ng);
        frame f = frame_from_normal(nrm);
        vec3 w = frame_to_world(&f, sample_cosine_hemisphere(vbi_rng_next2(&rng)));
        rr->o[rr->n] = vbi_offset_ray_origin(h.p, nrm, w);
        rr->d[rr->n] = w;
        rr->n++;
    }
}

static void raw_chunk(void *user, uint64_t item, unsigned thread)
{
    const raw_rays *rr = user;
    (void)thread;
    uint32_t b = (uint32_t)item * 4096u, e = b + 4096u < rr->n ? b + 4096u : rr->n;
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    if (!rr->packet) {
        for (uint32_t i = b; i < e; ++i) {
            struct RTCRayHit rh;
            vbi_rayhit_init(&rh, rr->o[i], rr->d[i], INFINITY);
            rtcIntersect1(rr->s->world, &ictx, &rh);
        }
        return;
    }
    for (uint32_t i0 = b; i0 < e; i0 += 8) {
        _Alignas(32) struct RTCRayHit8 rh;
        _Alignas(32) int valid[8];
        vbi_rayhit8_fill(&rh, valid, rr->o, rr->d, i0, e);
        rtcIntersect8(valid, rr->s->world, &ictx, &rh);
    }
}

/* The ceiling: the faster of one ray at a time and eight-ray packets, each the median of 3 runs,
 * per wall second and per CPU second. */
static void raw_rate(vbnl_context *ctx, raw_rays *rr, double *wall, double *cpu)
{
    *wall = *cpu = 0.0;
    for (int packet = 0; packet < 2; ++packet) {
        rr->packet = packet;
        double w[3], c[3];
        for (int k = 0; k < 3; ++k) {
            double t0 = vbi_now(), c0 = cpu_now();
            vbi_pool_run(ctx->pool, (rr->n + 4095u) / 4096u, raw_chunk, (void *)rr, NULL, NULL, 1.0);
            w[k] = rr->n / (vbi_now() - t0);
            c[k] = rr->n / (cpu_now() - c0);
        }
        for (int a = 0; a < 3; ++a)
            for (int b = a + 1; b < 3; ++b) {
                if (w[b] < w[a]) { double t = w[a]; w[a] = w[b]; w[b] = t; }
                if (c[b] < c[a]) { double t = c[a]; c[a] = c[b]; c[b] = t; }
            }
        *wall = w[1] > *wall ? w[1] : *wall;
        *cpu = c[1] > *cpu ? c[1] : *cpu;
    }
}

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
    unsigned mask = argc > 4 ? (unsigned)strtoul(argv[4], NULL, 0) : 0;
    int runs = argc > 5 ? atoi(argv[5]) : 3;
    if (runs < 1 || runs > 15)
        runs = 3;
    const char *src = getenv("VBNL_SOURCE_DIR");
    char path[1024];
    const char *scene_file = argc > 6 ? argv[6] : "CornellBox-Original.obj";
    if (strchr(scene_file, '/')) /* a path of its own */
        snprintf(path, sizeof(path), "%s", scene_file);
    else
        snprintf(path, sizeof(path), "%s/examples/mcguire/%s", src ? src : ".", scene_file);

    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = threads;
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

    /* VL placement (Section 3.1, Fig. 6a), or the pipeline's lights. */
    const int pipeline = argc > 7 && !strcmp(argv[7], "pipeline");
    if (argc > 7 && !pipeline && strcmp(argv[7], "camera")) {
        fprintf(stderr, "bench_splitting: lights must be 'camera' or 'pipeline', got '%s'\n", argv[7]);
        return 2;
    }
    vbi_vl_set vls;
    memset(&vls, 0, sizeof(vls));
    if (pipeline) {
        vbi_prepare_params pp = {nvl, 10u * nvl, 4, 0.15f, 4, VBI_ELIM_ADAPTIVE, 1, 32, 0.8f, 2.0f, 512, 512, 1};
        if (vbi_prepare_lights(s, &pp, NULL, ctx->pool, &vls, NULL, &err) != VBNL_OK) {
            fprintf(stderr, "%s\n", err.message);
            return 1;
        }
        nvl = vls.count;
    }
    vec3 *c = malloc(sizeof(vec3) * nvl), *n = malloc(sizeof(vec3) * nvl);
    float *r = malloc(sizeof(float) * nvl);
    uint8_t *glossy = malloc(nvl);
    float rad = 2.0f * sqrtf((float)(area / (2.0 * sqrt(3.0) * nvl)));
    vbi_rng rng = vbi_rng_make(3, 3);
    uint32_t k = 0;
    for (; pipeline && k < nvl; ++k) {
        c[k] = vls.position[k];
        n[k] = vls.normal[k];
        r[k] = vls.radius[k];
        glossy[k] = s->materials[vls.material[k]].bsdf.type != VBNL_MATERIAL_LAMBERT;
    }
    uint64_t tries = 0;
    while (k < nvl) {
        if (++tries > 100ull * nvl + 1000000ull) { /* the fixed camera sees (almost) nothing of this scene */
            fprintf(stderr,
                    "bench_splitting: camera lights: the camera at (0, 1, 3.4) looking at (0, 1, 0) found %u of %u "
                    "light positions in %llu rays in %s; use 'pipeline' lights\n",
                    k, nvl, (unsigned long long)tries, path);
            return 1;
        }
        vec3 o, d;
        vbi_camera_ray(&s->camera, 512, 512, vbi_rng_next(&rng) * 512, vbi_rng_next(&rng) * 512, &o, &d);
        vbi_hit h;
        if (!vbi_scene_intersect(s, o, d, INFINITY, &h))
            continue;
        vec3 ng = v3_dot(h.ng, d) > 0.0f ? v3_neg(h.ng) : h.ng;
        frame f = frame_from_normal(ng);
        vec3 d2 = frame_to_world(&f, sample_cosine_hemisphere(vbi_rng_next2(&rng)));
        vbi_hit h2;
        if (!vbi_scene_intersect(s, vbi_offset_ray_origin(h.p, ng, d2), d2, INFINITY, &h2) ||
            vbi_bsdf_is_delta(&s->materials[h2.material].bsdf))
            continue;
        c[k] = h2.p;
        n[k] = v3_dot(h2.ng, d2) > 0.0f ? v3_neg(h2.ng) : h2.ng;
        r[k] = rad;
        glossy[k] = s->materials[h2.material].bsdf.type != VBNL_MATERIAL_LAMBERT;
        ++k;
    }
    /* VBNL_BENCH_NO_RAW=1 skips the ray-rate measurements (under callgrind). */
    int want_raw = !getenv("VBNL_BENCH_NO_RAW");
    double raw = 0.0, raw_single = 0.0, raw_packet = 0.0;
    raw_rays rr = {s, NULL, NULL, 0, 0};
    if (want_raw) {
        vbnl_ray_rates rates;
        if (vbnl_scene_measure_ray_rates(ctx, s, 1000000, 512, 512, &rates, NULL) == VBNL_OK) {
            raw_single = rates.closest;
            raw_packet = rates.closest_packet;
            raw = raw_single > raw_packet ? raw_single : raw_packet;
        }
        make_raw_rays(&rr, 1000000);
    }
    const int lambert_vls = getenv("VBNL_BENCH_LAMBERT_VLS") != NULL;
    if (lambert_vls)
        memset(glossy, 0, nvl);
    uint32_t nglossy = 0;
    for (uint32_t j = 0; j < nvl; ++j)
        nglossy += glossy[j];
    float r_lo = INFINITY, r_hi = 0.0f;
    for (uint32_t j = 0; j < nvl; ++j) {
        r_lo = fminf(r_lo, r[j]);
        r_hi = fmaxf(r_hi, r[j]);
    }
    printf("scene: %s, %llu triangles, area %.3f; %u VLs (%s lights, %u glossy%s), r = %.4f .. %.4f; %llu photon "
           "paths; %u threads\n",
           path, (unsigned long long)s->triangle_count, area, nvl, pipeline ? "pipeline" : "camera", nglossy,
           lambert_vls ? ", all kept as Lambertian: VBNL_BENCH_LAMBERT_VLS" : "", r_lo,
           r_hi, (unsigned long long)paths, nthreads);
    printf("raw Embree incoherent ray rate: %.2f Mrays/s (one ray at a time %.2f, 8-ray packets %.2f; the faster "
           "is the ceiling)\n",
           raw * 1e-6, raw_single * 1e-6, raw_packet * 1e-6);

    vbi_hemioct *map = NULL;
    vbi_hemioct_create(16, &map);
    double unit = vbi_split_photon_unit(s, paths);
    struct {
        const char *name;
        vbi_vl_index_kind kind;
        float cell_scale;
        uint32_t count;
    } variants[] = {
        {"tracing only (no VLs)", VBI_VL_INDEX_GRID, 2.0f, 0},
        {"grid, cell = 2 r", VBI_VL_INDEX_GRID, 2.0f, nvl},
        {"grid, cell = 1 r", VBI_VL_INDEX_GRID, 1.0f, nvl},
        {"embree point query", VBI_VL_INDEX_EMBREE, 0.0f, nvl},
    };
    /* Per variant that ran: CPU nanoseconds per traced ray (threads x median seconds / rays). */
    double ns_per_ray[sizeof(variants) / sizeof(variants[0])] = {0};
    for (size_t v = 0; v < sizeof(variants) / sizeof(variants[0]); ++v) {
        if (mask && !(mask >> v & 1u))
            continue;
        vbi_vl_index_desc xd = {c, r, n, variants[v].count, variants[v].kind, variants[v].cell_scale, ctx->device,
                                 VBI_VL_INDEX_LEVELS_AUTO};
        vbi_vl_index *idx = NULL;
        double tb = vbi_now();
        if (vbi_vl_index_create(&xd, &idx) != VBNL_OK)
            return 1;
        tb = vbi_now() - tb;
        double times[15], ratios[15], cpu_ratios[15];
        vbi_split_stats st;
        size_t pbytes = 0;
        for (int run = 0; run < runs; ++run) {
            vbi_profile_set *ps = NULL;
            vbi_profile_set_create_fixed(map, variants[v].count, glossy, unit, &ps);
            vbi_split_desc d;
            vbi_split_desc_init(&d);
            d.scene = s;
            d.index = idx;
            d.vl_normals = n;
            d.profiles = ps;
            d.photon_paths = paths;
            d.seed = 1;
            /* The raw rate again right before every run: on a shared machine the ratio of the two
             * is much steadier than either figure. */
            double raw_run = raw, raw_cpu = 0.0;
            if (want_raw)
                raw_rate(ctx, &rr, &raw_run, &raw_cpu);
            double c0 = cpu_now();
            vbi_split_photons(&d, ctx->pool, NULL, &st);
            double split_cpu = cpu_now() - c0;
            times[run] = st.seconds;
            ratios[run] = raw_run > 0.0 ? st.rays / st.seconds / raw_run : 0.0;
            cpu_ratios[run] = raw_cpu > 0.0 ? st.rays / split_cpu / raw_cpu : 0.0;
            pbytes = vbi_profile_set_bytes(ps);
            vbi_profile_set_destroy(ps);
        }
        qsort(times, (size_t)runs, sizeof(double), cmp_double);
        qsort(ratios, (size_t)runs, sizeof(double), cmp_double);
        qsort(cpu_ratios, (size_t)runs, sizeof(double), cmp_double);
        double t = times[runs / 2], ratio = ratios[runs / 2], cpu_ratio = cpu_ratios[runs / 2];
        printf("%-24s %.3f s (min %.3f max %.3f, %d runs) | %.3f Mpaths/s | %.2f Mrays/s (%.0f%% of raw; median per-run ratio %.0f%%, per CPU second %.0f%%) | %.2f Mdeposits/s | "
               "%.2f hits/path (%.0f%% in the SIMD step), %.1f%% covered, %.2f VLs/covered hit, %llu overflow | index %.2f MB, %u levels (build %.3f s), "
               "profiles %.2f MB, splitting scratch %.2f MB\n",
               variants[v].name, t, times[0], times[runs - 1], runs, st.paths / t * 1e-6, st.rays / t * 1e-6,
               raw > 0.0 ? 100.0 * st.rays / t / raw : 0.0, 100.0 * ratio, 100.0 * cpu_ratio, st.deposits / t * 1e-6, (double)st.hits / st.paths,
               100.0 * st.simd_hits / (st.hits ? st.hits : 1), 100.0 * st.covered_hits / (st.hits ? st.hits : 1),
               (double)st.deposits / (st.covered_hits ? st.covered_hits : 1), (unsigned long long)st.overflow,
               vbi_vl_index_bytes(idx) / 1048576.0, vbi_vl_index_level_count(idx), tb, pbytes / 1048576.0, st.scratch_bytes / 1048576.0);
        ns_per_ray[v] = st.rays ? 1e9 * nthreads * t / (double)st.rays : 0.0;
        vbi_vl_index_destroy(idx);
    }
    /* Where a ray's time goes, against the target: at half the ceiling a ray may take twice what
     * Embree alone needs, so the walk (emission, hit set-up, bounce) and the deposit together must
     * fit in one ceiling ray's time. */
    if (raw > 0.0 && ns_per_ray[0] > 0.0) {
        const double embree = 1e9 * nthreads / raw;
        printf("per ray and thread: Embree at the ceiling %.0f ns; tracing alone %.0f ns (walk and emission %.0f ns)",
               embree, ns_per_ray[0], ns_per_ray[0] - embree);
        for (size_t v = 1; v < sizeof(variants) / sizeof(variants[0]); ++v)
            if (ns_per_ray[v] > 0.0)
                printf("; %s %.0f ns (deposit %.0f ns)", variants[v].name, ns_per_ray[v], ns_per_ray[v] - ns_per_ray[0]);
        printf(". Half the ceiling leaves %.0f ns for walk and deposit together\n", embree);
    }
    vbi_hemioct_destroy(map);
    free(c);
    free(n);
    free(r);
    free(glossy);
    vbi_vl_set_free(&vls);
    free(rr.o);
    free(rr.d);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
    return 0;
}
