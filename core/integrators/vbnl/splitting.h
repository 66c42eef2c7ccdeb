/* Photon splitting: the incident radiance field of every VBNL virtual light (private header).
 *
 * Li et al. 2022, Section 3.3. Photon paths are traced from the lights and never stored; at
 * every photon hit (the first one included) the photon's power is split among the virtual
 * lights (VLs) whose sphere contains the hit, with weights proportional to 1 - (d_i / r_i)^2
 * normalised to sum to one (a partition of unity: energy is preserved, and a hit with no VL
 * nearby deposits nothing). Each share is deposited into the VL's incident map
 * (profiles.h: vbnl_profile_deposit_fixed) in the VL's local frame frame_from_normal(n_j), with
 * wi pointing toward where the photon came from. Conversion to emission profiles is later
 * (profiles.h).
 *
 * Photon paths (importance transport, Veach 1997 ch. 5):
 *   - light j picked by power (the scene's alias table, pmf p_j), point and direction by
 *     vbnl_light_sample_le; flux Phi = Le |cos| / (p_j pdf_pos pdf_dir) / photon_paths;
 *   - at a hit, an opaque BSDF uses a frame facing the arriving photon (two-sided surfaces, as
 *     the path tracer); the dielectric keeps its orientation;
 *   - bounce by BSDF sampling with the photon arriving along wo: the sample weight
 *     f |cos theta_i| / pdf times eta^2 for a refraction (bsdf.h weights are for radiance,
 *     which carries 1 / eta^2; flux does not) times the shading-normal correction
 *     |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|) of the adjoint BSDF (Veach 1997, Eq. 5.17);
 *   - Russian roulette from bounce rr_depth on (authors' code: 5) with continuation probability
 *     q = min(1, sqrt(max(beta_new) / max(beta_old))), beta_new /= q (the authors' rule; its
 *     square root keeps photon powers from dropping as fast as the albedo). No depth limit
 *     (max_depth = 0), but a safety cap of VBNL_SPLIT_SAFETY_DEPTH bounces for lossless traps
 *     (mirror boxes, where q stays 1).
 *   - no deposits on delta surfaces (mirror, glass): VLs never stand for them.
 *
 * Which VLs share a hit at p with unit normal n (facing the arriving photon) arriving from wi:
 * the index (vl_index.h) gives every VL with d(p, y_j) < r_j; the authors' code then keeps those
 * with n_j . n > normal_cos (0.7) and, when require_facing, n_j . wi > 0; then, with `support`,
 * the VLs that pass the support test (vl_support.h: no occluder between the hit and the VL at
 * half its radius, which keeps the light trapped under a ceiling lamp or behind a thin wall out
 * of the VLs beyond it); of those the max_vls (8) with the largest weights 1 - (d/r)^2 (ties:
 * smaller id) share the photon.
 *
 * Determinism: photon k (a global index in [0, photon_paths)) draws only from
 * vbnl_rng_for(seed, k, 0); deposits are 64-bit fixed-point integer adds (profiles.h), so the
 * incident data are bit-identical for any thread count and chunking, and a run over paths
 * [0, a) merged (vbnl_profile_set_merge) with a run over [a, N) equals the run over [0, N).
 *
 * Energy bookkeeping (exact): the photon power at a hit is quantised once (Q, fixed point);
 * the VLs' shares are an exact integer partition of Q (vbnl_profile_split_fixed). The stats
 * count sum Q over the hits that deposited (covered_power), which therefore equals the sum of
 * all VLs' incident power sums exactly.
 *
 * How it runs (the work per hit is a handful of scattered memory accesses, so the order of the
 * work matters more than the arithmetic):
 *   - A work item traces `chunk` photon paths and records every non-delta hit (position,
 *     facing normal, wi, flux; 64 bytes, one cache line) in its thread's batch
 *     (vbnl_split_batch_hits), which it deposits when full. A batch spans work items (a larger
 *     batch deposits more hits into each VL and glossy map while they are in cache); the last
 *     `threads` work items deposit their thread's batch before they return, and what a thread still holds
 *     after the run (its last item came earlier) is deposited by the caller.
 *   - Bins: when the index is one dense grid level (uniform radii, the common case) the hit's
 *     cell and its point in the cell's quantisation frame are computed when the hit is recorded
 *     (hits outside the grid, which no sphere contains, are not recorded), and the bin is the
 *     Morton code of the cell coordinates' top 4 bits per axis; otherwise the bin is the top 12
 *     bits of the index's Morton key (vl_index.h, vbnl_vl_key_bin: 2^12 cubes of the VLs'
 *     bounding cube).
 *   - Deposit: the batch is counting-sorted by bin, then queried in that order through a
 *     software pipeline that prefetches each query's cell header, listings, hit record and
 *     candidate records a few queries ahead (splitting.c, run_fast_pipe, for hits that carry
 *     their cell; the index's own pipeline, vl_index_pipe.h, otherwise), with the last stage
 *     (exact test, filters, weights of eight candidates at a time in AVX2) fused with the
 *     deposit. Consecutive queries then read the same cells and records, which stay in cache.
 *   - The split: the photon power is quantised, the weights normalised and the exact partition
 *     added into the sums for the three channels at once (AVX2, same bits as
 *     vbnl_profile_split_fixed); the max_vls cap drops the smallest weights (or picks the
 *     largest, whichever takes fewer passes).
 *   - The walk's hit set-up for triangle meshes (the shared vbnl_fill_mesh_hit) and its
 *     Lambertian bounce in the world frame are inline (photon_fast.h, same values).
 *   - Phi_in goes into per-thread fixed-point sums indexed by the VLs' rank in the index's
 *     spatial order (nearby VLs, nearby sums; prefetched with the records), added to the
 *     profile set once at the end (integer adds: any order gives the same bits). Glossy VLs'
 *     direction maps: every worker splats with plain adds into its own 32-bit maps, which keep
 *     the low halves of its sums (a sum passing 2^32 adds its high part into the set's texel
 *     atomically, a rare event) and are added into the set at the end (profiles.h,
 *     vbnl_profile_splat_prepare_lo32): half the memory of copies of the set's 64-bit maps,
 *     so fewer cache lines per splat; while the maps of all threads fit in
 *     VBNL_SPLIT_MAX_MAP_COPY_BYTES and an eighth of the machine's memory, else atomic adds
 *     into the set's maps, the same bits; vbnl_split_map_copy_bytes). A glossy VL's map slot
 *     rides in the zero lane of its sums and its normal comes from the record copy, so a splat
 *     reads nothing at random before its texels. Each splat is
 *     prepared and its texels prefetched, then applied 16 splats later, since the maps are large
 *     (3 KB per glossy VL and thread at 16 x 16) and the texels random. With AVX2 a splat is
 *     two rows (splitting.c, splat_rows), and splats are prepared eight at a time
 *     (splat_queue_run): the frame, the footprint of vbnl_hemioct_footprint and the exact
 *     integer parts of vbnl_profile_splat_prepare_lo32 across the eight, then per row one 8-lane
 *     32-bit add over texels x0 and x0 + 1 (a row whose lane wraps past 2^32 is redone lane by
 *     lane with the carry; parts of 2^31 or more take the general form): the same bits as one
 *     splat at a time.
 *   The VLs that share a hit and their weights are exactly those of the rules above; only the
 *   order in which a hit's VLs are summed follows the index's rank order (so rounding of the
 *   normalised weights may differ in the last bit from an id-ordered sum; either is a
 *   deterministic function of the hit).
 *   Memory beyond the profile set (stats.scratch_bytes): per thread 64 bytes per VL (a record
 *   copy and the sums: RGB and a zero lane, one AVX2 vector) and 80 bytes per batch entry (the
 *   record, its order, bin, cell and sorted cell: 21 MB for the 262,144 entries of a batch);
 *   for 100K VLs and 2 threads, ~55 MB in all. When the sums of all threads would exceed
 *   VBNL_SPLIT_MAX_SUM_BYTES, the deposits are atomic adds into the profile set instead
 *   (slower, same bits); the 32-bit glossy maps add threads x half the set's incident maps
 *   (2 x 60 MB on the glossy-floor box with 2 threads).
 *   Each thread keeps eight paths in flight and traces their current rays as one rtcIntersect8
 *   packet (splitting.c, SPLIT_LANES). Packets of eight independent paths are faster than
 *   rtcIntersect1 one ray at a time (packets of consecutive rays of one path are not), with
 *   the same answers bit for bit.
 *   Loops whose trip counts vary from hit to hit cost more than their arithmetic (presumably
 *   their mispredicted exits; the VM the benchmarks run on has no branch counters), so the
 *   cell pipeline prefetches four listing blocks and eight candidates at once, whatever their
 *   counts, and stores every pre-test block packed.
 * Half the raw Embree rate needs the walk and the deposit together below Embree's own cost
 * (tests/vbnl/bench_splitting.c; figures in docs/performance.md). */
#ifndef VBNL_SPLITTING_H
#define VBNL_SPLITTING_H

#include <stdint.h>

#include "pool.h"
#include "profiles.h"
#include "render_internal.h"
#include "scene_internal.h"
#include "vl_index.h"
#include "vl_support.h"
#include "photon_fast.h"

#define VBNL_SPLIT_DEFAULT_CHUNK 16384u /* photon paths per work item (about 4 hits each here) */
#define VBNL_SPLIT_BATCH_HITS 262144u   /* photon hits a thread buffers before depositing them, */
#define VBNL_SPLIT_BATCH_HITS_MIN 65536u /* down to this many when the batches of all threads */
#define VBNL_SPLIT_MAX_BATCH_BYTES (256u << 20) /* would take more than this */
#define VBNL_SPLIT_BIN_BITS 12u         /* spatial bins of the batch sort: 2^12 (16 per axis) */
#define VBNL_SPLIT_MAX_SUM_BYTES (256u << 20) /* per-thread sums of all threads, at most */
#define VBNL_SPLIT_MAX_MAP_COPY_BYTES (512u << 20) /* the 32-bit incident maps of all threads */
#define VBNL_SPLIT_SAFETY_DEPTH 4096
#define VBNL_SPLIT_QUERY_MAX 64u   /* candidates read from the index per hit */
#define VBNL_SPLIT_MAX_VLS 64u     /* upper bound for max_vls */

typedef struct vbnl_split_desc {
    const vbnl_scene *scene;        /* committed */
    const vbnl_vl_index *index;     /* the VL spheres (ids = VL ids of `profiles`), with the same
                                     * normals when a filter is on (vl_index.h) */
    const vec3 *vl_normals;         /* unit normals n_j, index count of them */
    vbnl_profile_set *profiles;     /* receives the deposits; VL count = index count */
    uint64_t photon_paths;          /* N of the flux normalisation (all runs together) */
    uint64_t first_path;            /* this call traces paths [first_path, first_path + path_count) */
    uint64_t path_count;            /* 0 = photon_paths - first_path */
    uint64_t seed;
    float normal_cos;               /* keep VLs with n_j . n > normal_cos; <= -1 disables */
    int require_facing;             /* keep VLs with n_j . wi > 0 */
    uint32_t max_vls;               /* VLs sharing one hit (1 .. VBNL_SPLIT_MAX_VLS) */
    int rr_depth;                   /* bounces before Russian roulette */
    int max_depth;                  /* 0 = unlimited (up to VBNL_SPLIT_SAFETY_DEPTH) */
    uint32_t chunk;                 /* photon paths per work item, 0 = default (results do not
                                     * depend on it) */
    int atomic_deposits;            /* 1: no per-thread sums, atomic adds into `profiles` (what
                                     * happens beyond VBNL_SPLIT_MAX_SUM_BYTES; same bits) */
    int general_walk;               /* 1: every hit through the general walk, none through the SIMD
                                     * step (splitting.c, step_fast; same bits: tests compare) */
    const vbnl_vl_support *support; /* by index rank: the support test's data (vl_support.h);
                                     * NULL: no test (the paper's rule) */
} vbnl_split_desc;

/* Bytes of the private 32-bit incident maps photon splitting allocates for a set whose maps take
 * `map_bytes` (vbnl_profile_incident_bytes), run on `threads` workers: threads x map_bytes / 2
 * (a 32-bit map per thread) when that fits in VBNL_SPLIT_MAX_MAP_COPY_BYTES and an eighth of
 * physical memory, else 0 (the atomic path). The one rule for the splitting and for vbnl's
 * memory check before any work. */
uint64_t vbnl_split_map_copy_bytes(uint64_t map_bytes, unsigned threads);
/* Hits a thread's batch holds on `threads` workers: VBNL_SPLIT_BATCH_HITS, fewer (down to
 * VBNL_SPLIT_BATCH_HITS_MIN) when the batches would exceed VBNL_SPLIT_MAX_BATCH_BYTES;
 * vbnl_split_batch_bytes: the memory of one (records and sort keys). */
uint32_t vbnl_split_batch_hits(unsigned threads);
uint64_t vbnl_split_batch_bytes(uint32_t hits);

/* Defaults of the authors' code: normal_cos 0.7, facing on, 8 VLs, RR after bounce 5, unlimited
 * depth, chunks of 16384 paths. Scene, index, normals, profiles, counts and seed to be filled. */
void vbnl_split_desc_init(vbnl_split_desc *d);

typedef struct vbnl_split_stats {
    uint64_t paths;         /* photon paths traced (emission samples; failed ones included) */
    uint64_t rays;          /* rays traced */
    uint64_t hits;          /* photon hits (surface interactions) */
    uint64_t delta_hits;    /* hits on delta surfaces (no deposit) */
    uint64_t simd_hits;     /* hits set up and bounced eight at a time (the SIMD step) */
    uint64_t covered_hits;  /* hits that deposited into at least one VL */
    uint64_t deposits;      /* VL deposits (<= max_vls per covered hit) */
    uint64_t overflow;      /* hits with more than VBNL_SPLIT_QUERY_MAX containing spheres */
    uint64_t support_tests; /* hits whose VLs took the support test's rays (vl_support.h) */
    uint64_t support_rejects; /* VLs that a hit's support test removed */
    uint64_t covered_power[3]; /* sum of the quantised photon power of covered hits (fixed point) */
    uint64_t scratch_bytes; /* memory of the run beyond index and profiles: per-thread sums, batches */
    double seconds;
} vbnl_split_stats;

/* The fixed-point unit for `photon_paths` photons of this scene: vbnl_profile_unit_for_power of
 * the total light power (max channel) / photon_paths, the power of an emitted photon. */
double vbnl_split_photon_unit(const vbnl_scene *scene, uint64_t photon_paths);

/* One photon path (light random walk), shared with the many-light baselines (vpl, vsl): the
 * rules above (light by power, importance transport, Russian roulette, safety cap). `visit` is
 * called at every non-delta hit, before the bounce, with the flux arriving there. Draws from
 * `rng` only, in a fixed order, so a path is a function of its stream. (Its floating-point
 * results depend on the compiler's inlining at the last bit: GCC contracts a * b + c into FMAs
 * across inlined statements; a given build is deterministic.) */
typedef struct vbnl_photon_vertex {
    const vbnl_hit *hit;
    const vbnl_bsdf *bsdf;  /* vbnl_surface_bsdf at the hit */
    vec3 ng, ns;            /* unit normals facing the arriving photon (opaque surfaces) */
    vec3 wo;                /* unit, toward where the photon came from */
    vec3 beta;              /* flux arriving (already divided by the path count) */
    int depth;              /* 0 at the first hit */
} vbnl_photon_vertex;
typedef void (*vbnl_photon_visit_fn)(void *user, const vbnl_photon_vertex *v);
typedef struct vbnl_photon_walk_desc {
    const vbnl_scene *scene;
    float inv_paths;        /* 1 / N, the flux normalisation by the number of paths */
    int rr_depth;           /* bounces before Russian roulette */
    int max_depth;          /* 0 = unlimited (up to VBNL_SPLIT_SAFETY_DEPTH) */
    int rr_sqrt;            /* 1: VBNL authors' sqrt rule; 0: survival = sampled albedo ratio */
    int visit_delta_nodes;  /* 1: also visit the delta hits of material nodes (photon splitting:
                             * a VBNL light stands for its own leaf over its whole disk, so the
                             * irradiance of the node's mirror-chosen points is its too) */
} vbnl_photon_walk_desc;
typedef struct vbnl_photon_walk_stats {
    uint64_t rays, hits, delta_hits;
} vbnl_photon_walk_stats;
void vbnl_photon_walk(const vbnl_photon_walk_desc *w, vbnl_rng *rng, vbnl_photon_visit_fn visit, void *user,
                      vbnl_photon_walk_stats *stats);
/* The walk in two steps, so that a caller can keep several paths in flight and trace their rays
 * together (photon splitting): vbnl_photon_emit draws the path's emission, vbnl_photon_scatter
 * takes the hit of the path's current ray (o, dir), visits it and bounces. Each returns 1 when
 * the path has a next ray to trace, 0 when it has ended. */
typedef struct vbnl_photon_state {
    vec3 o, dir;   /* the ray to trace next */
    vec3 beta;     /* flux it carries (already divided by the path count) */
    int depth;     /* 0 for the emitted ray */
    int max_depth;
} vbnl_photon_state;

static inline __attribute__((always_inline)) int vbnl_photon_emit(const vbnl_photon_walk_desc *w, vbnl_rng *rng,
                                                                  vbnl_photon_state *ps)
{
    const vbnl_scene *sc = w->scene;
    float pmf;
    uint32_t li = vbnl_scene_pick_light(sc, vbnl_rng_next(rng), &pmf);
    vec2 u_pos = vbnl_rng_next2(rng), u_dir = vbnl_rng_next2(rng);
    vbnl_light_le_sample les;
    if (!(pmf > 0.0f) || !vbnl_light_sample_le(&sc->lights[li], u_pos, u_dir, &les))
        return 0;
    float den = pmf * les.pdf_pos * les.pdf_dir;
    if (!(den > 0.0f))
        return 0;
    /* Flux of the photon: Le |cos| / (p_j pdf_pos pdf_dir) / N (lights.h). */
    ps->beta = v3_scale(les.Le, les.cos_at_light / den * w->inv_paths);
    if (!v3_is_finite(ps->beta) || v3_is_black(ps->beta))
        return 0;
    ps->o = vbnl_offset_ray_origin(les.p, les.n, les.dir);
    ps->dir = les.dir;
    ps->depth = 0;
    ps->max_depth = w->max_depth > 0 && w->max_depth < VBNL_SPLIT_SAFETY_DEPTH ? w->max_depth
                                                                              : VBNL_SPLIT_SAFETY_DEPTH;
    return 1;
}

static inline __attribute__((always_inline)) int
vbnl_photon_scatter(const vbnl_photon_walk_desc *w, vbnl_rng *rng, vbnl_photon_state *ps, const vbnl_hit *hitp,
                    vbnl_photon_visit_fn visit, void *user, vbnl_photon_walk_stats *st)
{
    const vbnl_scene *sc = w->scene;
    const vbnl_hit *hit = hitp; /* read in place: `visit` sees the caller's record */
    const vec3 beta = ps->beta;
    st->hits++;
    vbnl_bsdf bsdf_store;
    const vbnl_bsdf *bsdf = vbnl_surface_bsdf(sc, hit, &bsdf_store);
    vec3 wo_w = v3_neg(ps->dir); /* toward where the photon came from */
    vec3 ng = hit->ng, ns = vbnl_bsdf_shading_normal(bsdf, hit->ns);
    int transmissive = vbnl_bsdf_is_transmissive(bsdf);
    if (!transmissive) { /* two-sided opaque surface: frame facing the photon (path.c) */
        if (v3_dot(ng, wo_w) < 0.0f) {
            ng = v3_neg(ng);
            ns = v3_neg(ns);
        }
        if (v3_dot(ns, wo_w) <= 0.0f)
            ns = ng;
    }
    if (vbnl_bsdf_is_delta(bsdf)) {
        st->delta_hits++;
        if (w->visit_delta_nodes && sc->materials[hit->material].is_node) {
            vbnl_photon_vertex v = {hit, bsdf, ng, ns, wo_w, beta, ps->depth};
            visit(user, &v);
        }
    } else {
        vbnl_photon_vertex v = {hit, bsdf, ng, ns, wo_w, beta, ps->depth};
        visit(user, &v);
    }

    /* Bounce (importance transport, splitting.h). The same draws for every BSDF. */
    vec2 ub = vbnl_rng_next2(rng);
    vec3 wi_w, wt;
    if (bsdf->type == VBNL_MATERIAL_LAMBERT) {
        /* lambert_sample without the general dispatch (photon_fast.h) */
        if (!vbnl_photon_lambert_bounce(bsdf, ns, wo_w, ub, &wi_w) || v3_is_black(bsdf->color))
            return 0;
        if (v3_dot(wi_w, ng) <= 0.0f)
            return 0; /* a reflection must leave on the photon's side of the real surface */
        wt = bsdf->color;
    } else {
        frame fr = frame_from_normal(ns);
        vec3 wo = frame_to_local(&fr, wo_w);
        vbnl_bsdf_sample_rec bs;
        if (!vbnl_bsdf_sample(bsdf, wo, ub, &bs) || v3_is_black(bs.weight))
            return 0;
        wi_w = frame_to_world(&fr, bs.wi);
        if (!(bs.lobe & VBNL_LOBE_TRANSMISSION) && v3_dot(wi_w, ng) <= 0.0f)
            return 0; /* a reflection must leave on the photon's side of the real surface */
        wt = bs.weight;
        if (bs.lobe & VBNL_LOBE_TRANSMISSION)
            wt = v3_scale(wt, bs.eta * bs.eta); /* flux is not compressed by refraction */
    }
    /* Adjoint shading-normal correction (Veach 1997, Eq. 5.17); exactly 1 when ns == ng. */
    if (ns.x != ng.x || ns.y != ng.y || ns.z != ng.z) {
        float den_c = v3_absdot(wo_w, ng) * v3_absdot(wi_w, ns);
        if (den_c > 0.0f)
            wt = v3_scale(wt, v3_absdot(wo_w, ns) * v3_absdot(wi_w, ng) / den_c);
    }
    vec3 nb = v3_mul(beta, wt);
    if (ps->depth + 1 >= w->rr_depth) {
        /* VBNL authors' rule: continue with q = sqrt(max(new) / max(old)); the plain rule
         * (q = max(new) / max(old), the sampled albedo) otherwise; at most 1. */
        float ratio = v3_max_comp(nb) / v3_max_comp(beta);
        float q = minf(1.0f, w->rr_sqrt ? sqrtf(ratio) : ratio);
        if (!(q > 0.0f) || vbnl_rng_next(rng) >= q)
            return 0;
        nb = v3_scale(nb, 1.0f / q);
    }
    if (!v3_is_finite(nb) || v3_is_black(nb))
        return 0;
    if (++ps->depth >= ps->max_depth)
        return 0;
    ps->beta = nb;
    ps->o = vbnl_offset_ray_origin(hit->p, hit->ng, wi_w);
    ps->dir = wi_w;
    return 1;
}

/* The same walk, inline: called with a known `visit`, the compiler inlines the visit too
 * (vbnl_photon_walk is this function out of line). */
static inline __attribute__((always_inline)) void
vbnl_photon_walk_inline(const vbnl_photon_walk_desc *w, vbnl_rng *rng, vbnl_photon_visit_fn visit, void *user,
                        vbnl_photon_walk_stats *st)
{
    vbnl_photon_state ps;
    if (!vbnl_photon_emit(w, rng, &ps))
        return;
    for (;;) {
        vbnl_hit hit;
        st->rays++;
        if (!vbnl_photon_intersect(w->scene, ps.o, ps.dir, &hit)) /* photon_fast.h */
            return;
        if (!vbnl_photon_scatter(w, rng, &ps, &hit, visit, user, st))
            return;
    }
}


/* Traces the photon paths of `d` and deposits into d->profiles (adds to what it holds; the
 * call owns the set while it runs: nothing else may read or deposit into it meanwhile, since
 * the final merges use plain adds). Work items run on `stage`'s workers with
 * progress in photon paths when stage is not NULL (cancellation: VBNL_ERR_CANCELLED, deposits
 * of finished items stay), else on `pool` (which must then be given). With a stage, the caller
 * brackets the call with vbnl_stage_begin(stage, name, path count, "photons") and
 * vbnl_stage_end. Stats are summed from per-thread counters. Errors:
 * VBNL_ERR_INVALID_ARGUMENT, VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_split_photons(const vbnl_split_desc *d, vbnl_pool *pool, vbnl_stage_ctx *stage,
                               vbnl_split_stats *stats);

#endif
