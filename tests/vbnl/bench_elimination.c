/* Benchmark of VBNL sample elimination: the paper's Fig. 8 case (1.3M candidates -> 0.13M) on a
 * bumpy height-field surface, serial vs box-parallel.
 *
 *   bench_elimination [M [N [threads [mode]]]]    mode: adaptive (default) | uniform
 *
 * Prints the median of 3 runs of each variant, the speed-up, and the blue-noise quality of each
 * result: mean and minimum of (nearest-neighbour distance / 2 r_max) over the kept points
 * (vbi_elim_measure). "serial" runs everything on the calling thread; "serial+pool" runs only the
 * m-NN radius estimate on the pool (the elimination itself is sequential); "parallel" is the
 * paper's box-parallel elimination on the pool. Wall and process CPU times are printed: on a
 * shared machine, compare the CPU times too. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "elimination.h"
#include "pool.h"
#include "rng.h"

static vec3 *make_surface(uint32_t M, uint64_t seed)
{
    vec3 *pts = malloc((size_t)M * sizeof(vec3));
    if (!pts)
        return NULL;
    vbi_rng rng = vbi_rng_make(seed, 7);
    for (uint32_t i = 0; i < M; ++i) {
        float x = vbi_rng_next(&rng), y = vbi_rng_next(&rng);
        float z = 0.08f * sinf(6.0f * VBI_PI * x) * sinf(4.0f * VBI_PI * y);
        pts[i] = v3(x, y, z);
    }
    return pts;
}

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

typedef struct variant {
    const char *name;
    int parallel;
    int use_pool;
    double t[3], cpu[3];
    double median;
    double mean_rel, min_rel;
    vbi_elim_stats stats;
} variant;

int main(int argc, char **argv)
{
    uint32_t M = argc > 1 ? (uint32_t)strtoul(argv[1], NULL, 10) : 1300000u;
    uint32_t N = argc > 2 ? (uint32_t)strtoul(argv[2], NULL, 10) : M / 10u;
    unsigned threads = argc > 3 ? (unsigned)strtoul(argv[3], NULL, 10) : 2u;
    vbi_elim_mode mode = (argc > 4 && strcmp(argv[4], "uniform") == 0) ? VBI_ELIM_UNIFORM : VBI_ELIM_ADAPTIVE;
    vec3 *pts = make_surface(M, 1234);
    uint32_t *kept = malloc((size_t)N * sizeof(uint32_t));
    float *rmax = malloc((size_t)N * sizeof(float));
    vbi_pool *pool = vbi_pool_create(threads);
    if (!pts || !kept || !rmax || !pool) {
        fprintf(stderr, "bench_elimination: out of memory\n");
        return 1;
    }
    printf("sample elimination: M = %u -> N = %u, %s mode, bumpy surface, %u pool threads\n", M, N,
           mode == VBI_ELIM_ADAPTIVE ? "adaptive" : "uniform", threads);
    variant vs[3] = {{.name = "serial", .parallel = 0, .use_pool = 0},
                     {.name = "serial+pool", .parallel = 0, .use_pool = 1},
                     {.name = "parallel", .parallel = 1, .use_pool = 1}};
    for (int v = 0; v < 3; ++v) {
        vbi_elim_params p;
        vbi_elim_params_default(&p, N);
        p.mode = mode;
        p.parallel = vs[v].parallel;
        vbi_elim_exec ex = vbi_elim_exec_pool(vs[v].use_pool ? pool : NULL);
        for (int r = 0; r < 3; ++r) {
            vbnl_error err = {0};
            double t0 = vbi_now(), c0 = cpu_now();
            if (vbi_eliminate(pts, M, &p, &ex, kept, rmax, &vs[v].stats, &err) != VBNL_OK) {
                fprintf(stderr, "bench_elimination: %s\n", err.message);
                return 1;
            }
            vs[v].t[r] = vbi_now() - t0;
            vs[v].cpu[r] = cpu_now() - c0;
        }
        double s[3];
        memcpy(s, vs[v].t, sizeof(s));
        qsort(s, 3, sizeof(double), cmp_double);
        vs[v].median = s[1];
        vbnl_error err = {0};
        if (vbi_elim_measure(pts, kept, rmax, N, &vs[v].mean_rel, &vs[v].min_rel, &err) != VBNL_OK) {
            fprintf(stderr, "bench_elimination: %s\n", err.message);
            return 1;
        }
        const vbi_elim_stats *st = &vs[v].stats;
        printf("%-12s median %.3f s (runs %.3f %.3f %.3f; cpu %.3f %.3f %.3f; last: radius %.3f s, "
               "eliminate %.3f s)  mean NN/2r_max %.4f  min %.4f\n",
               vs[v].name, vs[v].median, vs[v].t[0], vs[v].t[1], vs[v].t[2], vs[v].cpu[0], vs[v].cpu[1],
               vs[v].cpu[2], st->time_radius, st->time_eliminate, vs[v].mean_rel, vs[v].min_rel);
        printf("             (last run) tree %.3f s; levels %u: boxes %u/%u/%u removed %llu/%llu/%llu "
               "in %.3f/%.3f/%.3f s\n",
               st->time_tree, st->levels, st->boxes[0], st->boxes[1], st->boxes[2],
               (unsigned long long)st->removed[0], (unsigned long long)st->removed[1],
               (unsigned long long)st->removed[2], st->time_level[0], st->time_level[1], st->time_level[2]);
    }
    printf("speed-up parallel vs serial: %.2fx; vs serial+pool: %.2fx\n", vs[0].median / vs[2].median,
           vs[1].median / vs[2].median);
    printf("quality parallel / serial: mean %.4f, min %.4f\n", vs[2].mean_rel / vs[0].mean_rel,
           vs[2].min_rel / vs[0].min_rel);
    vbi_pool_destroy(pool);
    free(rmax);
    free(kept);
    free(pts);
    return 0;
}
