/* Photon splitting, the photon paths: eight paths in flight per thread, their rays traced as one
 * packet and the common hits set up and bounced eight at a time (part of splitting.c, included
 * once by it; see there). */
#ifndef VBI_SPLITTING_LANES_H
#define VBI_SPLITTING_LANES_H

typedef struct split_visit {
    const split_job *job;
    split_thread *t;
} split_visit;

static void split_visit_fn(void *user, const vbi_photon_vertex *v)
{
    split_visit *sv = user;
    record_hit(sv->job, sv->t, v->hit->p, v->ng, v->wo, v->beta, v->hit->material);
}

/* No VL at all: no hit can deposit. */
static void skip_visit_fn(void *user, const vbi_photon_vertex *v)
{
    (void)user;
    (void)v;
}

/* Paths in flight per thread. One walk alone is a chain of dependent steps (trace, set up the
 * hit, visit, bounce, trace again). With several paths in flight their rays go to Embree
 * together as one 8-wide packet (rtcIntersect8; independent directions, so Embree's hybrid
 * traversal), and the hits that are the common case (below) are set up, recorded and bounced
 * eight at a time in SIMD; the others one after another by the general walk. The packet is what
 * gains (eight paths in flight traced with rtcIntersect1 one ray after another are no faster
 * than one path at a time), and 16 or 24 paths in flight are no faster than 8; in the SIMD step the walk's own
 * work is ~170 instructions per hit (callgrind, Cornell box). Paths keep their
 * own streams, a ray's answer does not depend on its packet mates, the SIMD step computes the
 * general walk's values bit for bit (same operations in the same order; splitting.c is compiled
 * without contracted multiply-adds), and the deposits are integer sums, so neither the order
 * of hits nor the grouping changes a bit of the result (test_splitting: chunks of 7 paths,
 * ranges merged, 1 to 3 threads; SIMD step against the general walk; test_splitting_oracle:
 * against the plain reference). */
#define SPLIT_LANES 8u

/* The paths in flight, a structure of arrays (the SIMD step reads each field as a vector);
 * lane i's vbi_photon_state is (o, d, b, depth, max_depth)[i]. */
typedef struct photon_lanes {
    _Alignas(32) float ox[SPLIT_LANES], oy[SPLIT_LANES], oz[SPLIT_LANES];
    _Alignas(32) float dx[SPLIT_LANES], dy[SPLIT_LANES], dz[SPLIT_LANES];
    _Alignas(32) float bx[SPLIT_LANES], by[SPLIT_LANES], bz[SPLIT_LANES];
    _Alignas(32) int32_t depth[SPLIT_LANES], max_depth[SPLIT_LANES];
    vbi_rng rng[SPLIT_LANES];
} photon_lanes;

static inline __attribute__((always_inline)) void lane_get(const photon_lanes *L, uint32_t i, vbi_photon_state *ps)
{
    ps->o = v3(L->ox[i], L->oy[i], L->oz[i]);
    ps->dir = v3(L->dx[i], L->dy[i], L->dz[i]);
    ps->beta = v3(L->bx[i], L->by[i], L->bz[i]);
    ps->depth = L->depth[i];
    ps->max_depth = L->max_depth[i];
}

static inline __attribute__((always_inline)) void lane_put(photon_lanes *L, uint32_t i, const vbi_photon_state *ps)
{
    L->ox[i] = ps->o.x, L->oy[i] = ps->o.y, L->oz[i] = ps->o.z;
    L->dx[i] = ps->dir.x, L->dy[i] = ps->dir.y, L->dz[i] = ps->dir.z;
    L->bx[i] = ps->beta.x, L->by[i] = ps->beta.y, L->bz[i] = ps->beta.z;
    L->depth[i] = ps->depth;
    L->max_depth[i] = ps->max_depth;
}

static inline __attribute__((always_inline)) void lane_move(photon_lanes *L, uint32_t to, uint32_t from)
{
    L->ox[to] = L->ox[from], L->oy[to] = L->oy[from], L->oz[to] = L->oz[from];
    L->dx[to] = L->dx[from], L->dy[to] = L->dy[from], L->dz[to] = L->dz[from];
    L->bx[to] = L->bx[from], L->by[to] = L->by[from], L->bz[to] = L->bz[from];
    L->depth[to] = L->depth[from];
    L->max_depth[to] = L->max_depth[from];
    L->rng[to] = L->rng[from];
}

/* Starts path k, or the next ones whose emission succeeds, in lane i; 0 when [*k, e) has none. */
static inline __attribute__((always_inline)) int lane_start(const split_job *job, split_thread *t,
                                                            const vbi_photon_walk_desc *w, photon_lanes *L,
                                                            uint32_t i, uint64_t *k, uint64_t e)
{
    while (*k < e) {
        vbi_rng rng = vbi_rng_for(job->d->seed, *k, 0);
        ++*k;
        t->s.paths++;
        vbi_photon_state ps;
        if (vbi_photon_emit(w, &rng, &ps)) {
            L->rng[i] = rng;
            lane_put(L, i, &ps);
            return 1;
        }
    }
    return 0;
}

/* The current rays of lanes [0, n) as one packet, answered in r8. */
static inline __attribute__((always_inline)) void trace_packet(const vbnl_scene *sc, struct RTCIntersectContext *ictx,
                                                              const photon_lanes *L, uint32_t n,
                                                              struct RTCRayHit8 *r8)
{
    _Static_assert(SPLIT_LANES == 8, "one rtcIntersect8 packet per step");
    _Alignas(32) int valid[8];
    for (uint32_t i = 0; i < 8; ++i) {
        valid[i] = i < n ? -1 : 0;
        vbi_rayhit8_set(r8, i, v3(L->ox[i], L->oy[i], L->oz[i]), v3(L->dx[i], L->dy[i], L->dz[i]), INFINITY);
    }
    rtcIntersect8(valid, sc->world, ictx, r8);
}

/* Lane i's answer as vbi_photon_hit_from reads it. */
static inline __attribute__((always_inline)) void packet_lane(const struct RTCRayHit8 *r8, uint32_t i,
                                                             struct RTCRayHit *rh)
{
    rh->ray.tfar = r8->ray.tfar[i];
    rh->hit.Ng_x = r8->hit.Ng_x[i];
    rh->hit.Ng_y = r8->hit.Ng_y[i];
    rh->hit.Ng_z = r8->hit.Ng_z[i];
    rh->hit.u = r8->hit.u[i];
    rh->hit.v = r8->hit.v[i];
    rh->hit.primID = r8->hit.primID[i];
    rh->hit.geomID = r8->hit.geomID[i];
    rh->hit.instID[0] = r8->hit.instID[0][i];
}

#if defined(__AVX2__)
/* What step_fast needs of the lanes' surfaces beyond Embree's answer: the Lambertian colour
 * and, for lanes in `shaded`, the vertex normals of the triangle hit (vertex k's in n[k]); for
 * lanes in `other` (an opaque, non-delta, non-Lambertian BSDF: plastic, conductor), the BSDF
 * the bounce samples instead. */
typedef struct fast_surf {
    _Alignas(32) float cr[8], cg[8], cb[8];
    _Alignas(32) float n[3][3][8]; /* [vertex][axis][lane] */
    const vbi_bsdf *bsdf[8];
    uint32_t material[8];
    unsigned shaded, other;
} fast_surf;

/* The lanes of `fast` (hits on a non-instanced triangle mesh whose material is untextured and
 * either a Lambertian with a non-black colour or, in sf->other, an opaque non-delta BSDF),
 * eight at once: vbi_photon_hit_from, vbi_photon_scatter with its visit (record_hit when
 * `rec`) and bounce, operation for operation (hence the same bits): the hit point o + d t; the
 * unit normals (vbi_fill_mesh_hit: the interpolated shading normal where the mesh has normals,
 * the geometric one turned to its side) turned to face the photon; the frame of the shading
 * normal (frame_from_normal); the direction: cosine-weighted for the Lambertian lanes
 * (sample_cosine_hemisphere), vbi_bsdf_sample of wo in the frame (frame_to_local) for the
 * others, one lane at a time; frame_to_world; the adjoint shading-normal correction; Russian
 * roulette; the offset origin of the next ray. Each lane draws from its own stream in the
 * general walk's order (the bounce's two numbers, then the roulette's). Returns the lanes of
 * `fast` that go on. */
static inline __attribute__((always_inline)) unsigned step_fast(const split_job *job, split_thread *t,
                                                               const vbi_photon_walk_desc *w, photon_lanes *L,
                                                               const struct RTCRayHit8 *r8, unsigned fast,
                                                               const fast_surf *sf, int rec,
                                                               vbi_photon_walk_stats *ws)
{
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    const __m256 ox = _mm256_load_ps(L->ox), oy = _mm256_load_ps(L->oy), oz = _mm256_load_ps(L->oz);
    const __m256 dx = _mm256_load_ps(L->dx), dy = _mm256_load_ps(L->dy), dz = _mm256_load_ps(L->dz);
    const __m256 tf = _mm256_loadu_ps(r8->ray.tfar);
    /* p = o + d t (v3_fma) */
    const __m256 px = _mm256_add_ps(ox, _mm256_mul_ps(dx, tf)), py = _mm256_add_ps(oy, _mm256_mul_ps(dy, tf)),
                 pz = _mm256_add_ps(oz, _mm256_mul_ps(dz, tf));
    /* ng = v3_norm(Embree's Ng) */
    __m256 nx = _mm256_loadu_ps(r8->hit.Ng_x), ny = _mm256_loadu_ps(r8->hit.Ng_y), nz = _mm256_loadu_ps(r8->hit.Ng_z);
    {
        __m256 l = _mm256_sqrt_ps(dot8(nx, ny, nz, nx, ny, nz));
        __m256 pos = _mm256_cmp_ps(l, zero, _CMP_GT_OQ), inv = _mm256_div_ps(one, l);
        nx = sel8(pos, _mm256_mul_ps(nx, inv), nx);
        ny = sel8(pos, _mm256_mul_ps(ny, inv), ny);
        nz = sel8(pos, _mm256_mul_ps(nz, inv), nz);
    }
    /* the shading normal: b0 n0 + u n1 + v n2, normalised; ng = ns where that is degenerate;
     * then ng on the side of ns */
    __m256 sx = nx, sy = ny, sz = nz;
    if (sf->shaded) {
        const __m256 bu = _mm256_loadu_ps(r8->hit.u), bv = _mm256_loadu_ps(r8->hit.v);
        const __m256 b0 = _mm256_sub_ps(_mm256_sub_ps(one, bu), bv);
        __m256 ix_[3];
        for (int a = 0; a < 3; ++a)
            ix_[a] = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_load_ps(sf->n[0][a]), b0),
                                                 _mm256_mul_ps(_mm256_load_ps(sf->n[1][a]), bu)),
                                   _mm256_mul_ps(_mm256_load_ps(sf->n[2][a]), bv));
        __m256 l = _mm256_sqrt_ps(dot8(ix_[0], ix_[1], ix_[2], ix_[0], ix_[1], ix_[2]));
        __m256 pos = _mm256_cmp_ps(l, zero, _CMP_GT_OQ), inv = _mm256_div_ps(one, l);
        for (int a = 0; a < 3; ++a)
            ix_[a] = sel8(pos, _mm256_mul_ps(ix_[a], inv), ix_[a]);
        __m256 use = _mm256_and_ps(mask8(sf->shaded),
                                   _mm256_cmp_ps(dot8(ix_[0], ix_[1], ix_[2], ix_[0], ix_[1], ix_[2]),
                                                 _mm256_set1_ps(0.5f), _CMP_GT_OQ));
        sx = sel8(use, ix_[0], nx);
        sy = sel8(use, ix_[1], ny);
        sz = sel8(use, ix_[2], nz);
        __m256 flip = _mm256_and_ps(mask8(sf->shaded), _mm256_cmp_ps(dot8(nx, ny, nz, sx, sy, sz), zero, _CMP_LT_OQ));
        nx = sel8(flip, neg8(nx), nx);
        ny = sel8(flip, neg8(ny), ny);
        nz = sel8(flip, neg8(nz), nz);
    }
    /* wo = -d; both normals face the photon, ns = ng where ns does not */
    const __m256 wox = neg8(dx), woy = neg8(dy), woz = neg8(dz);
    {
        __m256 flip = _mm256_cmp_ps(dot8(nx, ny, nz, wox, woy, woz), zero, _CMP_LT_OQ);
        nx = sel8(flip, neg8(nx), nx);
        ny = sel8(flip, neg8(ny), ny);
        nz = sel8(flip, neg8(nz), nz);
        sx = sel8(flip, neg8(sx), sx);
        sy = sel8(flip, neg8(sy), sy);
        sz = sel8(flip, neg8(sz), sz);
        __m256 back = _mm256_cmp_ps(dot8(sx, sy, sz, wox, woy, woz), zero, _CMP_LE_OQ);
        sx = sel8(back, nx, sx);
        sy = sel8(back, ny, sy);
        sz = sel8(back, nz, sz);
    }
    const __m256 bx = _mm256_load_ps(L->bx), by = _mm256_load_ps(L->by), bz = _mm256_load_ps(L->bz);
    ws->hits += (uint64_t)__builtin_popcount(fast);

    /* the visits, and the bounce's two numbers of each lane */
    _Alignas(32) float ux[8], uy[8];
    if (rec && job->cell_fast) {
        /* record_hit with the cell of each hit (fast_cell) and its point in the cell's frame
         * (cell_frame) computed for the eight lanes at once */
        const grid_level *g = &job->d->index->levels[0];
        _Alignas(32) float a[15][8];
        _Alignas(32) int32_t ci[3][8];
        _Alignas(32) uint32_t cl[8];
        const __m256 P[3] = {px, py, pz}, lo[3] = {_mm256_set1_ps(g->lo.x), _mm256_set1_ps(g->lo.y),
                                                   _mm256_set1_ps(g->lo.z)};
        const __m256 inv = _mm256_set1_ps(g->inv_cell), cellv = _mm256_set1_ps(g->cell);
        __m256 in = mask8(fast);
        __m256i c3[3];
        for (int ax = 0; ax < 3; ++ax) {
            const __m256 nf = _mm256_set1_ps((float)g->n[ax]);
            __m256 f = _mm256_mul_ps(_mm256_sub_ps(P[ax], lo[ax]), inv);
            in = _mm256_and_ps(in, _mm256_and_ps(_mm256_cmp_ps(f, _mm256_set1_ps(-1.0f), _CMP_GT_OQ),
                                                 _mm256_cmp_ps(f, _mm256_add_ps(nf, one), _CMP_LT_OQ)));
            __m256 fl = _mm256_min_ps(_mm256_max_ps(_mm256_floor_ps(f), zero), _mm256_sub_ps(nf, one));
            c3[ax] = _mm256_cvttps_epi32(fl);
            _mm256_store_si256((__m256i *)ci[ax], c3[ax]);
            /* cell_frame: (p - (lo + c cell) + q_off) q_scale */
            __m256 org = _mm256_add_ps(lo[ax], _mm256_mul_ps(_mm256_cvtepi32_ps(c3[ax]), cellv));
            _mm256_store_ps(a[12 + ax], _mm256_mul_ps(_mm256_add_ps(_mm256_sub_ps(P[ax], org), _mm256_set1_ps(g->q_off)),
                                                      _mm256_set1_ps(g->q_scale)));
        }
        _mm256_store_si256((__m256i *)cl,
                           _mm256_add_epi32(c3[0], _mm256_mullo_epi32(_mm256_set1_epi32(g->n[0]),
                                                                      _mm256_add_epi32(c3[1], _mm256_mullo_epi32(
                                                                          _mm256_set1_epi32(g->n[1]), c3[2])))));
        _mm256_store_ps(a[0], px), _mm256_store_ps(a[1], py), _mm256_store_ps(a[2], pz);
        _mm256_store_ps(a[3], nx), _mm256_store_ps(a[4], ny), _mm256_store_ps(a[5], nz);
        _mm256_store_ps(a[6], wox), _mm256_store_ps(a[7], woy), _mm256_store_ps(a[8], woz);
        _mm256_store_ps(a[9], bx), _mm256_store_ps(a[10], by), _mm256_store_ps(a[11], bz);
        const unsigned inside = (unsigned)_mm256_movemask_ps(in);
        const uint32_t sh = job->cell_shift, bb = VBI_SPLIT_BIN_BITS / 3u;
        for (unsigned m = fast; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            if (inside >> i & 1u) {
                if (t->n == t->cap)
                    flush_batch(job, t);
                split_rec *h = &t->hits[t->n];
                *h = (split_rec){v3(a[0][i], a[1][i], a[2][i]), v3(a[3][i], a[4][i], a[5][i]),
                                 v3(a[6][i], a[7][i], a[8][i]), v3(a[9][i], a[10][i], a[11][i]),
                                 {a[12][i], a[13][i], a[14][i]}, sf->material[i]};
                t->cell[t->n] = cl[i];
                t->bin[t->n] = vbi_vl_key_spread_bits((uint32_t)ci[0][i] >> sh, bb) |
                               vbi_vl_key_spread_bits((uint32_t)ci[1][i] >> sh, bb) << 1 |
                               vbi_vl_key_spread_bits((uint32_t)ci[2][i] >> sh, bb) << 2;
                t->n++;
            }
            ux[i] = vbi_rng_next(&L->rng[i]);
            uy[i] = vbi_rng_next(&L->rng[i]);
        }
    } else {
        _Alignas(32) float a[12][8];
        if (rec) {
            _mm256_store_ps(a[0], px), _mm256_store_ps(a[1], py), _mm256_store_ps(a[2], pz);
            _mm256_store_ps(a[3], nx), _mm256_store_ps(a[4], ny), _mm256_store_ps(a[5], nz);
            _mm256_store_ps(a[6], wox), _mm256_store_ps(a[7], woy), _mm256_store_ps(a[8], woz);
            _mm256_store_ps(a[9], bx), _mm256_store_ps(a[10], by), _mm256_store_ps(a[11], bz);
        }
        for (unsigned m = fast; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            if (rec)
                record_hit(job, t, v3(a[0][i], a[1][i], a[2][i]), v3(a[3][i], a[4][i], a[5][i]),
                           v3(a[6][i], a[7][i], a[8][i]), v3(a[9][i], a[10][i], a[11][i]), sf->material[i]);
            ux[i] = vbi_rng_next(&L->rng[i]);
            uy[i] = vbi_rng_next(&L->rng[i]);
        }
    }
    __m256 alive = _mm256_and_ps(mask8(fast), _mm256_cmp_ps(dot8(wox, woy, woz, sx, sy, sz), zero, _CMP_GT_OQ));
    /* frame_from_normal(ns) */
    __m256 fr[6];
    frame8(sx, sy, sz, fr);
    const __m256 fsx = fr[0], fsy = fr[1], fsz = fr[2], ftx = fr[3], fty = fr[4], ftz = fr[5];

    /* sample_cosine_hemisphere(u): the concentric disk with sincos_quarter, then z */
    __m256 wx, wy, wz;
    {
        const __m256 two = _mm256_set1_ps(2.0f), am = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
        __m256 ex = _mm256_sub_ps(_mm256_mul_ps(two, _mm256_load_ps(ux)), one);
        __m256 ey = _mm256_sub_ps(_mm256_mul_ps(two, _mm256_load_ps(uy)), one);
        __m256 centre = _mm256_and_ps(_mm256_cmp_ps(ex, zero, _CMP_EQ_OQ), _mm256_cmp_ps(ey, zero, _CMP_EQ_OQ));
        __m256 first = _mm256_cmp_ps(_mm256_and_ps(ex, am), _mm256_and_ps(ey, am), _CMP_GT_OQ);
        __m256 r = sel8(first, ex, ey), other = sel8(first, ey, ex);
        __m256 phi = _mm256_mul_ps(_mm256_set1_ps(VBI_PI / 4.0f), _mm256_div_ps(other, r));
        __m256 x2 = _mm256_mul_ps(phi, phi);
        /* sincos_quarter(phi): the same Horner steps, innermost first */
#define SPLIT_H(acc, cst) _mm256_add_ps(_mm256_set1_ps(cst), _mm256_mul_ps(x2, (acc)))
        __m256 s = _mm256_set1_ps(1.0f / 362880.0f);
        s = SPLIT_H(s, -1.0f / 5040.0f);
        s = SPLIT_H(s, 1.0f / 120.0f);
        s = SPLIT_H(s, -1.0f / 6.0f);
        s = _mm256_mul_ps(phi, _mm256_add_ps(one, _mm256_mul_ps(x2, s)));
        __m256 c = _mm256_set1_ps(-1.0f / 3628800.0f);
        c = SPLIT_H(c, 1.0f / 40320.0f);
        c = SPLIT_H(c, -1.0f / 720.0f);
        c = SPLIT_H(c, 1.0f / 24.0f);
        c = SPLIT_H(c, -0.5f);
        c = _mm256_add_ps(one, _mm256_mul_ps(x2, c));
#undef SPLIT_H
        __m256 rs = _mm256_mul_ps(r, s), rc = _mm256_mul_ps(r, c);
        __m256 ddx = _mm256_andnot_ps(centre, sel8(first, rc, rs));
        __m256 ddy = _mm256_andnot_ps(centre, sel8(first, rs, rc));
        wx = ddx;
        wy = ddy;
        wz = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(_mm256_sub_ps(one, _mm256_mul_ps(ddx, ddx)),
                                                        _mm256_mul_ps(ddy, ddy)),
                                          zero));
    }
    alive = _mm256_and_ps(alive, _mm256_cmp_ps(wz, zero, _CMP_GT_OQ));
    /* the other lanes: vbi_bsdf_sample of wo in the frame, then their direction and weight */
    _Alignas(32) float owx[8], owy[8], owz[8], ogr[8], ogg[8], ogb[8];
    if (sf->other) {
        _Alignas(32) float lx[8], ly[8], lz[8];
        _mm256_store_ps(lx, dot8(wox, woy, woz, fsx, fsy, fsz));
        _mm256_store_ps(ly, dot8(wox, woy, woz, ftx, fty, ftz));
        _mm256_store_ps(lz, dot8(wox, woy, woz, sx, sy, sz));
        unsigned ok = 0;
        for (unsigned m = sf->other; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            vbi_bsdf_sample_rec bs;
            owx[i] = owy[i] = owz[i] = ogr[i] = ogg[i] = ogb[i] = 0.0f;
            if (!vbi_bsdf_sample(sf->bsdf[i], v3(lx[i], ly[i], lz[i]), (vec2){ux[i], uy[i]}, &bs) ||
                v3_is_black(bs.weight))
                continue;
            ok |= 1u << i;
            owx[i] = bs.wi.x, owy[i] = bs.wi.y, owz[i] = bs.wi.z;
            ogr[i] = bs.weight.x, ogg[i] = bs.weight.y, ogb[i] = bs.weight.z;
        }
        const __m256 om = mask8(sf->other);
        wx = sel8(om, _mm256_load_ps(owx), wx);
        wy = sel8(om, _mm256_load_ps(owy), wy);
        wz = sel8(om, _mm256_load_ps(owz), wz);
        alive = sel8(om, mask8(ok), alive);
    }
    /* frame_to_world */
    __m256 ix, iy, iz;
    {
        ix = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(fsx, wx), _mm256_mul_ps(ftx, wy)), _mm256_mul_ps(sx, wz));
        iy = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(fsy, wx), _mm256_mul_ps(fty, wy)), _mm256_mul_ps(sy, wz));
        iz = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(fsz, wx), _mm256_mul_ps(ftz, wy)), _mm256_mul_ps(sz, wz));
    }
    /* a reflection must leave on the photon's side of the real surface */
    alive = _mm256_and_ps(alive, _mm256_cmp_ps(dot8(ix, iy, iz, nx, ny, nz), zero, _CMP_GT_OQ));
    /* wt = colour, with the adjoint shading-normal correction (Veach 1997, Eq. 5.17) where ns
     * differs from ng; nb = beta wt; Russian roulette */
    __m256 wtx = _mm256_load_ps(sf->cr), wty = _mm256_load_ps(sf->cg), wtz = _mm256_load_ps(sf->cb);
    if (sf->other) { /* the sampled weight f cos / pdf */
        const __m256 om = mask8(sf->other);
        wtx = sel8(om, _mm256_load_ps(ogr), wtx);
        wty = sel8(om, _mm256_load_ps(ogg), wty);
        wtz = sel8(om, _mm256_load_ps(ogb), wtz);
    }
    if (sf->shaded) {
        __m256 differ = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(sx, nx, _CMP_NEQ_UQ), _mm256_cmp_ps(sy, ny, _CMP_NEQ_UQ)),
                                     _mm256_cmp_ps(sz, nz, _CMP_NEQ_UQ));
        const __m256 am = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
        __m256 den = _mm256_mul_ps(_mm256_and_ps(dot8(wox, woy, woz, nx, ny, nz), am),
                                   _mm256_and_ps(dot8(ix, iy, iz, sx, sy, sz), am));
        __m256 fac = _mm256_div_ps(_mm256_mul_ps(_mm256_and_ps(dot8(wox, woy, woz, sx, sy, sz), am),
                                                 _mm256_and_ps(dot8(ix, iy, iz, nx, ny, nz), am)),
                                   den);
        __m256 corr = _mm256_and_ps(differ, _mm256_cmp_ps(den, zero, _CMP_GT_OQ));
        wtx = sel8(corr, _mm256_mul_ps(wtx, fac), wtx);
        wty = sel8(corr, _mm256_mul_ps(wty, fac), wty);
        wtz = sel8(corr, _mm256_mul_ps(wtz, fac), wtz);
    }
    __m256 nbx = _mm256_mul_ps(bx, wtx), nby = _mm256_mul_ps(by, wty), nbz = _mm256_mul_ps(bz, wtz);
    const __m256i depth = _mm256_load_si256((const __m256i *)L->depth);
    const __m256i depth1 = _mm256_add_epi32(depth, _mm256_set1_epi32(1));
    __m256 rr = _mm256_castsi256_ps(_mm256_cmpgt_epi32(depth1, _mm256_set1_epi32(w->rr_depth - 1)));
    unsigned rr_bits = (unsigned)_mm256_movemask_ps(_mm256_and_ps(rr, alive));
    if (rr_bits) {
        __m256 ratio = _mm256_div_ps(maxf8(nbx, maxf8(nby, nbz)), maxf8(bx, maxf8(by, bz)));
        __m256 q = minf8(one, w->rr_sqrt ? _mm256_sqrt_ps(ratio) : ratio);
        unsigned draw = rr_bits & (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(q, zero, _CMP_GT_OQ));
        _Alignas(32) float qa[8], ua[8] = {0};
        _mm256_store_ps(qa, q);
        for (unsigned m = draw; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            ua[i] = vbi_rng_next(&L->rng[i]);
        }
        /* survivors: drawn and below q; lanes without roulette stay */
        __m256 survive = _mm256_and_ps(mask8(draw), _mm256_cmp_ps(_mm256_load_ps(ua), q, _CMP_LT_OQ));
        alive = _mm256_and_ps(alive, _mm256_or_ps(_mm256_andnot_ps(rr, alive), survive));
        __m256 inv = _mm256_div_ps(one, q);
        nbx = sel8(rr, _mm256_mul_ps(nbx, inv), nbx);
        nby = sel8(rr, _mm256_mul_ps(nby, inv), nby);
        nbz = sel8(rr, _mm256_mul_ps(nbz, inv), nbz);
    }
    const __m256 absm = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    {
        const __m256 inf = _mm256_set1_ps(INFINITY);
        __m256 finite = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(_mm256_and_ps(nbx, absm), inf, _CMP_LT_OQ),
                                                    _mm256_cmp_ps(_mm256_and_ps(nby, absm), inf, _CMP_LT_OQ)),
                                      _mm256_cmp_ps(_mm256_and_ps(nbz, absm), inf, _CMP_LT_OQ));
        __m256 black = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(nbx, zero, _CMP_EQ_OQ),
                                                   _mm256_cmp_ps(nby, zero, _CMP_EQ_OQ)),
                                     _mm256_cmp_ps(nbz, zero, _CMP_EQ_OQ));
        alive = _mm256_and_ps(alive, _mm256_andnot_ps(black, finite));
    }
    /* ++depth < max_depth */
    const __m256i maxd = _mm256_load_si256((const __m256i *)L->max_depth);
    alive = _mm256_and_ps(alive, _mm256_castsi256_ps(_mm256_cmpgt_epi32(maxd, depth1)));
    /* the next ray: vbi_offset_ray_origin(p, ng, wi), whose normal faces wi already (ng . wi > 0
     * above, and the hit's unflipped normal is turned to the same side), then wi */
    __m256 nox, noy, noz;
    {
        const __m256 int_scale = _mm256_set1_ps(256.0f), float_scale = _mm256_set1_ps(1.0f / 65536.0f);
        const __m256 origin = _mm256_set1_ps(1.0f / 32.0f);
#define SPLIT_OFFSET(P, N, OUT)                                                                            \
    do {                                                                                                   \
        __m256i of_ = _mm256_cvttps_epi32(_mm256_mul_ps(int_scale, (N)));                                  \
        __m256i neg_ = _mm256_castps_si256(_mm256_cmp_ps((P), zero, _CMP_LT_OQ));                          \
        of_ = _mm256_sub_epi32(_mm256_xor_si256(of_, neg_), neg_);                                         \
        __m256 pi_ = _mm256_castsi256_ps(_mm256_add_epi32(_mm256_castps_si256(P), of_));                   \
        __m256 pf_ = _mm256_add_ps((P), _mm256_mul_ps(float_scale, (N)));                                  \
        (OUT) = sel8(_mm256_cmp_ps(_mm256_and_ps((P), absm), origin, _CMP_LT_OQ), pf_, pi_);               \
    } while (0)
        SPLIT_OFFSET(px, nx, nox);
        SPLIT_OFFSET(py, ny, noy);
        SPLIT_OFFSET(pz, nz, noz);
#undef SPLIT_OFFSET
    }
    /* the lanes of `fast` take their new state (dead ones are replaced by the caller) */
    const __m256 fm = mask8(fast);
    _mm256_store_ps(L->ox, sel8(fm, nox, ox)), _mm256_store_ps(L->oy, sel8(fm, noy, oy));
    _mm256_store_ps(L->oz, sel8(fm, noz, oz));
    _mm256_store_ps(L->dx, sel8(fm, ix, dx)), _mm256_store_ps(L->dy, sel8(fm, iy, dy));
    _mm256_store_ps(L->dz, sel8(fm, iz, dz));
    _mm256_store_ps(L->bx, sel8(fm, nbx, bx)), _mm256_store_ps(L->by, sel8(fm, nby, by));
    _mm256_store_ps(L->bz, sel8(fm, nbz, bz));
    _mm256_store_si256((__m256i *)L->depth,
                       _mm256_castps_si256(sel8(fm, _mm256_castsi256_ps(depth1), _mm256_castsi256_ps(depth))));
    return (unsigned)_mm256_movemask_ps(alive) & fast;
}
#endif

/* Paths [b, e) of the walk (vbi_photon_walk_inline's steps), SPLIT_LANES at a time; `rec`:
 * hits are recorded (else there is no VL to deposit into). */
static inline __attribute__((always_inline)) void trace_lanes(const split_job *job, split_thread *t, uint64_t b,
                                                             uint64_t e, int rec)
{
    const vbi_split_desc *d = job->d;
    const vbnl_scene *sc = d->scene;
    vbi_photon_walk_desc w = {sc, job->inv_paths, d->rr_depth, d->max_depth, 1, 1};
    vbi_photon_walk_stats ws = {0, 0, 0};
    split_visit sv = {job, t};
    const vbi_photon_visit_fn visit = rec ? split_visit_fn : skip_visit_fn;
    photon_lanes L;
    memset(&L, 0, sizeof(L));
    _Alignas(32) struct RTCRayHit8 r8;
    uint32_t n = 0;
    uint64_t k = b;
    while (n < SPLIT_LANES && lane_start(job, t, &w, &L, n, &k, e))
        n++;
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    while (n > 0) {
        trace_packet(sc, &ictx, &L, n, &r8);
        ws.rays += n;
        unsigned alive = 0, general = 0;
#if defined(__AVX2__)
        /* the lanes the SIMD step takes (step_fast); misses end */
        fast_surf sf; /* lanes outside `fast` (and normals outside `shaded`) are computed on and
                       * discarded: zero, not indeterminate, values there */
        memset(&sf, 0, sizeof(sf));
        unsigned fast = 0;
        if (d->general_walk)
            general = (1u << n) - 1u;
        else
            for (uint32_t i = 0; i < n; ++i) {
            const uint32_t gid = r8.hit.geomID[i];
            if (gid == RTC_INVALID_GEOMETRY_ID)
                continue;
            const scene_geom *g = &sc->geoms[gid];
            if (r8.hit.instID[0][i] != RTC_INVALID_GEOMETRY_ID || g->kind != SCENE_GEOM_MESH) {
                general |= 1u << i;
                continue;
            }
            const scene_mesh *me = &g->u.mesh;
            const uint32_t mi = me->face_materials ? me->face_materials[r8.hit.primID[i]] : me->material;
            const scene_material *sm = &sc->materials[mi];
            if (sm->varies) {
                general |= 1u << i;
                continue;
            }
            if (sm->bsdf.type != VBNL_MATERIAL_LAMBERT) {
                if (vbi_bsdf_is_delta(&sm->bsdf) || vbi_bsdf_is_transmissive(&sm->bsdf)) {
                    general |= 1u << i;
                    continue;
                }
                sf.other |= 1u << i;
                sf.bsdf[i] = &sm->bsdf;
            } else if (v3_is_black(sm->bsdf.color)) {
                general |= 1u << i;
                continue;
            }
            fast |= 1u << i;
            sf.material[i] = mi;
            sf.cr[i] = sm->bsdf.color.x;
            sf.cg[i] = sm->bsdf.color.y;
            sf.cb[i] = sm->bsdf.color.z;
            if (me->normals) {
                const uint32_t *tri = me->indices + 3 * (size_t)r8.hit.primID[i];
                for (int vtx = 0; vtx < 3; ++vtx)
                    for (int a = 0; a < 3; ++a)
                        sf.n[vtx][a][i] = me->normals[3 * (size_t)tri[vtx] + (size_t)a];
                sf.shaded |= 1u << i;
            }
        }
        if (fast) {
            alive = step_fast(job, t, &w, &L, &r8, fast, &sf, rec, &ws);
            t->s.simd_hits += (uint64_t)__builtin_popcount(fast);
        }
#else
        general = (1u << n) - 1u;
#endif
        /* the others through the general walk */
        for (unsigned m = general; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            struct RTCRayHit rh;
            packet_lane(&r8, i, &rh);
            vbi_photon_state ps;
            lane_get(&L, i, &ps);
            vbi_hit hit;
            if (vbi_photon_hit_from(sc, ps.o, ps.dir, &rh, &hit) &&
                vbi_photon_scatter(&w, &L.rng[i], &ps, &hit, visit, &sv, &ws)) {
                lane_put(&L, i, &ps);
                alive |= 1u << i;
            }
        }
        uint32_t m = 0; /* lanes kept, compacted in place */
        for (uint32_t i = 0; i < n; ++i) {
            if ((alive >> i & 1u) || lane_start(job, t, &w, &L, i, &k, e)) {
                if (m != i)
                    lane_move(&L, m, i);
                m++;
            }
        }
        n = m;
    }
    t->s.rays += ws.rays;
    t->s.hits += ws.hits;
    t->s.delta_hits += ws.delta_hits;
}

static __attribute__((flatten)) void trace_paths(const split_job *job, split_thread *t, uint64_t b, uint64_t e)
{
    if (job->empty)
        trace_lanes(job, t, b, e, 0);
    else
        trace_lanes(job, t, b, e, 1);
}

#endif
