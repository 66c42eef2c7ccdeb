/* Photon splitting (Li et al. 2022, Section 3.3): photon paths from the lights, every hit's
 * power shared among the virtual lights around it. Design and rules: splitting.h.
 *
 * One translation unit, compiled without contracted multiply-adds (meson.build), in parts that
 * each hold one concern and are included once, in this order:
 *   splitting_job.h    the working state: batch records, per-thread sums and splat queues, the job
 *   splitting_simd.h   AVX2 helpers (lane packing, frames, the exact integer split in lanes)
 *   splitting_splat.h  glossy VLs: splats into the incident maps, eight prepared at a time
 *   splitting_share.h  one hit: the VLs that contain it, their weights, the exact partition of
 *                      its power and the deposits
 *   splitting_batch.h  the batches: hits recorded with their cell and bin, sorted, then queried
 *                      through a pipeline of prefetches
 *   splitting_lanes.h  the photon paths: eight in flight, one packet per step, the common hits
 *                      set up and bounced eight at a time
 * and this file: the sizes, the run over work items and the final merges. Keeping one unit
 * lets the compiler inline across the parts, as the hot loops need. */
#include "bigalloc.h"
#include "splitting.h"
#include "vl_index_pipe.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "splitting_job.h"
#include "splitting_simd.h"
#include "splitting_splat.h"
#include "splitting_share.h"
#include "splitting_batch.h"
#include "splitting_lanes.h"

uint64_t vbi_split_map_copy_bytes(uint64_t map_bytes, unsigned threads)
{
    if (threads < 1 || map_bytes == 0)
        return 0;
    const uint64_t copy = map_bytes / 2u * threads; /* 32-bit maps, one per thread */
    const double phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
    if ((double)copy > (double)VBI_SPLIT_MAX_MAP_COPY_BYTES || (phys > 0.0 && (double)copy > phys / 8.0))
        return 0;
    return copy;
}

uint64_t vbi_split_batch_bytes(uint32_t hits)
{
    return (uint64_t)hits * (sizeof(split_rec) + 4u * sizeof(uint32_t)); /* hits, order, bin, cell, scell */
}

uint32_t vbi_split_batch_hits(unsigned threads)
{
    uint64_t fit = (uint64_t)VBI_SPLIT_MAX_BATCH_BYTES / vbi_split_batch_bytes(1) / (threads ? threads : 1u);
    fit &= ~(uint64_t)1023u;
    return fit >= VBI_SPLIT_BATCH_HITS ? VBI_SPLIT_BATCH_HITS
                                        : (fit <= VBI_SPLIT_BATCH_HITS_MIN ? VBI_SPLIT_BATCH_HITS_MIN : (uint32_t)fit);
}

void vbi_split_desc_init(vbi_split_desc *d)
{
    memset(d, 0, sizeof(*d));
    d->normal_cos = 0.7f;
    d->require_facing = 1;
    d->max_vls = 8;
    d->rr_depth = 5;
    d->max_depth = 0;
    d->chunk = VBI_SPLIT_DEFAULT_CHUNK;
}

double vbi_split_photon_unit(const vbnl_scene *scene, uint64_t photon_paths)
{
    double total = 0.0;
    for (uint32_t i = 0; i < scene->light_count; ++i)
        total += v3_max_comp(vbi_light_power(&scene->lights[i]));
    return vbi_profile_unit_for_power(photon_paths ? total / (double)photon_paths : 0.0);
}

/* A work item traces its paths into the thread's batch, deposited whenever it fills up; the
 * last thread_count items deposit what their thread holds before they return (the caller
 * deposits what is left after the run, splitting.h), so once the run is over every finished
 * item has made all its deposits. */
static void run_chunk(void *user, uint64_t item, unsigned thread)
{
    const split_job *job = user;
    /* Workers are numbered 0 .. thread_count - 1 (pool.h; the caller never runs items), so
     * each split_thread, whose sums are plain adds, has one writer. */
    split_thread *t = &job->threads[thread];
    uint64_t b = job->begin + item * job->chunk;
    uint64_t e = b + job->chunk < job->end ? b + job->chunk : job->end;
    trace_paths(job, t, b, e);
    if (item + job->thread_count >= job->items)
        flush_batch(job, t);
}

static void threads_free(split_job *job)
{
    if (!job->threads)
        return;
    for (unsigned i = 0; i < job->thread_count; ++i) {
        split_thread *t = &job->threads[i];
        free(t->vl);
        free(t->maps);
        free(t->hits);
        free(t->order);
        free(t->bin);
        free(t->cell);
        free(t->scell);
        free(t->start);
    }
    free(job->threads);
    job->threads = NULL;
}

vbnl_result vbi_split_photons(const vbi_split_desc *d, vbi_pool *pool, vbnl_stage_ctx *stage,
                               vbi_split_stats *stats)
{
    if (stats)
        memset(stats, 0, sizeof(*stats));
    if (!d || !d->scene || !d->scene->committed || !d->index || !d->vl_normals || !d->profiles ||
        (!vbi_vl_index_has_normals(d->index) && (d->normal_cos > -1.0f || d->require_facing)) ||
        (!pool && !stage) || d->photon_paths == 0 || d->first_path > d->photon_paths ||
        vbi_vl_index_count(d->index) != vbi_profile_set_count(d->profiles) || d->max_vls == 0 ||
        d->max_vls > VBI_SPLIT_MAX_VLS)
        return VBNL_ERR_INVALID_ARGUMENT;
    double t0 = vbi_now();
    split_job job;
    memset(&job, 0, sizeof(job));
    job.d = d;
    job.begin = d->first_path;
    job.end = d->path_count ? d->first_path + d->path_count : d->photon_paths;
    if (job.end < job.begin)
        return VBNL_ERR_INVALID_ARGUMENT;
    job.chunk = d->chunk ? d->chunk : VBI_SPLIT_DEFAULT_CHUNK;
    job.max_vls = d->max_vls;
    job.inv_paths = (float)(1.0 / (double)d->photon_paths);
    job.inv_unit = 1.0 / vbi_profile_set_unit(d->profiles);
    _Static_assert(VBI_SPLIT_BIN_BITS % 3u == 0 && VBI_SPLIT_BIN_BITS <= 24u, "bins: whole Morton triples");
    job.key_grid = vbi_vl_index_key_grid(d->index);
    job.bins = 1u << VBI_SPLIT_BIN_BITS;
    {
        const vbi_vl_index *x = d->index;
        job.cell_fast = x->kind == VBI_VL_INDEX_GRID && x->level_count == 1 && x->levels[0].dense;
        if (job.cell_fast) {
            const grid_level *g = &x->levels[0];
            int32_t nmax = g->n[0] > g->n[1] ? g->n[0] : g->n[1];
            nmax = nmax > g->n[2] ? nmax : g->n[2];
            while (((uint32_t)(nmax - 1) >> job.cell_shift) >= (1u << (VBI_SPLIT_BIN_BITS / 3u)))
                job.cell_shift++;
        }
    }
    job.thread_count = stage ? vbnl_stage_thread_count(stage) : vbi_pool_thread_count(pool);
    if (job.thread_count == 0)
        job.thread_count = 1;
    const uint32_t batch_hits = vbi_split_batch_hits(job.thread_count);
    uint32_t nvl = vbi_vl_index_count(d->index);
    job.empty = nvl == 0;
    uint8_t *glossy = NULL;
    vbnl_result res = VBNL_OK;
    for (uint32_t r = 0; r < nvl; ++r) {
        uint32_t id = vbi_vl_index_id(d->index, r);
        if (!vbi_profile_is_glossy(d->profiles, id))
            continue;
        if (!glossy && !(glossy = calloc(nvl, 1))) {
            res = VBNL_ERR_OUT_OF_MEMORY;
            goto done;
        }
        glossy[r] = 1;
    }
    job.glossy = glossy;
    if (glossy)
        job.maps_view = vbi_profile_maps_view_of(d->profiles);
    job.rec_normals = vbi_vl_index_has_normals(d->index);
    for (uint32_t r = 0; r < nvl && job.rec_normals; ++r) {
        const vl_rec *e = &d->index->rec[r];
        const vec3 nv = d->vl_normals[e->id];
        job.rec_normals = e->nx == nv.x && e->ny == nv.y && e->nz == nv.z;
    }
    job.threads = aligned_alloc(64, sizeof(split_thread) * job.thread_count);
    if (!job.threads) {
        res = VBNL_ERR_OUT_OF_MEMORY;
        goto done;
    }
    memset(job.threads, 0, sizeof(split_thread) * job.thread_count);
    /* Per-thread sums unless they would take more than VBI_SPLIT_MAX_SUM_BYTES (many threads
     * and millions of VLs): then atomic adds into the set, the same bits. */
    int own_sums = !d->atomic_deposits &&
                   (double)nvl * (double)sizeof(split_vl) * job.thread_count <= (double)VBI_SPLIT_MAX_SUM_BYTES;
    /* 32-bit private maps for every worker when they fit in VBI_SPLIT_MAX_MAP_COPY_BYTES and
     * an eighth of the machine's memory; else atomic splats into the set, the same bits. */
    const size_t map_bytes = vbi_profile_incident_bytes(d->profiles);
    const uint64_t copy_bytes = vbi_split_map_copy_bytes(map_bytes, job.thread_count);
    const int map_copies = own_sums && copy_bytes > 0;
    for (unsigned i = 0; i < job.thread_count && !job.empty; ++i) {
        split_thread *t = &job.threads[i];
        t->cap = batch_hits;
        if (own_sums && (t->vl = vbi_big_alloc(sizeof(split_vl) * ((size_t)nvl + 1)))) {
            memset(t->vl, 0, sizeof(split_vl) * ((size_t)nvl + 1));
            for (uint32_t r = 0; r < nvl; ++r) {
                t->vl[r].rec = d->index->rec[r];
                if (glossy && glossy[r]) /* slot + 1 in the zero lane (split_deposit) */
                    t->vl[r].acc[3] = (uint64_t)vbi_profile_slot(d->profiles, d->index->rec[r].id) + 1u;
            }
            t->acc = t->vl[0].acc;
        }
        if (t->acc && glossy && map_copies) {
            t->maps = vbi_big_calloc(map_bytes / 2u + SPLIT_MAP_SLACK, 1);
            if (!t->maps) {
                res = VBNL_ERR_OUT_OF_MEMORY;
                goto done;
            }
        }
        t->hits = vbi_big_alloc(t->cap * sizeof(split_rec));
        t->order = malloc(t->cap * sizeof(uint32_t));
        t->bin = malloc(t->cap * sizeof(uint32_t));
        if (job.cell_fast && (!(t->cell = malloc(t->cap * sizeof(uint32_t))) ||
                              !(t->scell = malloc(t->cap * sizeof(uint32_t))))) {
            res = VBNL_ERR_OUT_OF_MEMORY;
            goto done;
        }
        t->start = malloc(((size_t)job.bins + 1) * sizeof(uint32_t));
        if ((own_sums && !t->vl) || !t->hits || !t->order || !t->bin || !t->start) {
            res = VBNL_ERR_OUT_OF_MEMORY;
            goto done;
        }
    }
    uint64_t items = (job.end - job.begin + job.chunk - 1) / job.chunk;
    job.items = items;
    if (items) {
        if (vbi_run_items(stage, pool, items, run_chunk, &job) != 0)
            res = VBNL_ERR_CANCELLED;
        /* the batches of threads whose last item was not among the last thread_count (also
         * after a cancel: the items that ran have finished) */
        for (unsigned i = 0; i < job.thread_count && !job.empty; ++i)
            flush_batch(&job, &job.threads[i]);
    }
    /* The private maps' low halves into the set's maps (integer adds: the same bits as atomic
     * splats; deposits of finished work items stay after a cancel). */
    for (unsigned i = 0; i < job.thread_count && !job.empty; ++i)
        if (job.threads[i].maps)
            vbi_profile_add_incident_lo32(d->profiles, job.threads[i].maps);
    /* Phi_in: the threads' sums, added in rank order (integer adds: the same bits for any
     * thread count and order). */
    for (uint32_t r = 0; r < nvl && own_sums; ++r) {
        uint64_t q[3] = {0, 0, 0};
        for (unsigned i = 0; i < job.thread_count; ++i)
            for (int c = 0; c < 3; ++c)
                q[c] += job.threads[i].acc[ACC_STRIDE * (size_t)r + c];
        if (q[0] | q[1] | q[2])
            vbi_profile_add_power_fixed(d->profiles, vbi_vl_index_id(d->index, r), q);
    }
    if (stats) {
        for (unsigned i = 0; i < job.thread_count; ++i) {
            const vbi_split_stats *s = &job.threads[i].s;
            stats->paths += s->paths;
            stats->rays += s->rays;
            stats->hits += s->hits;
            stats->delta_hits += s->delta_hits;
            stats->simd_hits += s->simd_hits;
            stats->covered_hits += s->covered_hits;
            stats->deposits += s->deposits;
            stats->overflow += s->overflow;
            stats->support_tests += s->support_tests;
            stats->support_rejects += s->support_rejects;
            for (int c = 0; c < 3; ++c)
                stats->covered_power[c] += job.threads[i].cov[c];
        }
        stats->seconds = vbi_now() - t0;
        stats->scratch_bytes = job.empty ? 0u : (uint64_t)job.thread_count *
                               ((own_sums ? (uint64_t)sizeof(split_vl) * (nvl + 1) : 0ull) +
                                (uint64_t)batch_hits *
                                    (sizeof(split_rec) + (job.cell_fast ? 4 : 2) * sizeof(uint32_t)) +
                                4ull * (job.bins + 1)) +
                               (glossy ? nvl : 0u) +
                               (map_copies ? copy_bytes : 0ull);
    }
done:
    threads_free(&job);
    free(glossy);
    return res;
}
