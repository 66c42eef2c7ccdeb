/* Virtual point lights of the many-light baselines: generation by light random walks with the
 * optional Georgiev-Slusallek acceptance, the clamped VPL term, and the camera side shared by
 * `vpl` and `vsl`. Design and rules: vpl_set.h. */
#include "vpl_set.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "photon_walk.h"

#define VPL_CHUNK 256u

/* ---- the VPL term ---------------------------------------------------------------------------- */

vec3 vbi_vpl_contribution(const vbi_vpl *v, const vbi_bsdf *bsdf, vec3 x, const vbi_shading_frame *sf,
                           float clamp, vec3 *w_out, float *dist_out)
{
    vec3 to = v3_sub(v->p, x);
    float d2 = v3_len2(to);
    if (!(d2 > 0.0f))
        return v3s(0.0f);
    float dist = sqrtf(d2);
    vec3 w = v3_scale(to, 1.0f / dist);
    if (v3_dot(w, sf->ng) <= 0.0f || v3_dot(w, v->ng) >= 0.0f)
        return v3s(0.0f); /* x sees the back of the VPL's surface, or the VPL is behind x */
    vec3 wx = frame_to_local(&sf->fr, w);
    vec3 fx = vbi_bsdf_eval(bsdf, sf->wo, wx); /* f_x cos_x */
    if (v3_is_black(fx))
        return v3s(0.0f);
    vec3 wy = frame_to_local(&v->fr, v3_neg(w));
    vec3 fy = vbi_bsdf_eval(&v->bsdf, v->wi, wy); /* f_y cos_y (reciprocity) */
    if (v3_is_black(fy))
        return v3s(0.0f);
    float s = 1.0f / d2;
    if (clamp > 0.0f) {
        /* G_b = min(G, b) with G = cos_x cos_y / d^2: only the geometry term is bounded */
        float G = fabsf(wx.z) * fabsf(wy.z) / d2;
        if (G > clamp)
            s *= clamp / G;
    }
    *w_out = w;
    *dist_out = dist;
    return v3_scale(v3_mul(v3_mul(fx, fy), v->flux), s);
}

int vbi_vpl_visible(const vbnl_scene *sc, vec3 x, vec3 ng, const vbi_vpl *v, vec3 w, float dist)
{
    (void)dist;
    vec3 o = vbi_offset_ray_origin(x, ng, w);
    vec3 t = vbi_offset_ray_origin(v->p, v->ng, v3_neg(w));
    vec3 to = v3_sub(t, o);
    float len = v3_len(to);
    if (!(len > 0.0f))
        return 1;
    return !vbi_scene_occluded(sc, o, v3_scale(to, 1.0f / len), len * (1.0f - 1e-4f));
}

int vbi_vpl_camera_vertex(const vbnl_scene *sc, vbi_sampler *sp, int hit_ok, vbi_hit *hit, vec3 *d, vec3 *beta,
                           vec3 *direct, vbi_thread_stats *stats)
{
    *beta = v3s(1.0f);
    *direct = v3s(0.0f);
    for (int k = 0;; ++k) {
        if (!hit_ok)
            return 0;
        vbi_bsdf store;
        const vbi_bsdf *bsdf = vbi_surface_bsdf(sc, hit, &store);
        if (!vbi_bsdf_is_delta(bsdf))
            return 1;
        if (k >= VBI_VPL_MAX_SPECULAR)
            return 0;
        vbi_shading_frame sf;
        vbi_shading_frame_make(bsdf, hit, *d, &sf);
        vbi_bsdf_sample_rec bs;
        vec2 ub = vbi_sampler_next2(sp);
        if (!vbi_bsdf_sample(bsdf, sf.wo, ub, &bs) || v3_is_black(bs.weight))
            return 0;
        vec3 w = frame_to_world(&sf.fr, bs.wi);
        if (!(bs.lobe & VBI_LOBE_TRANSMISSION) && v3_dot(w, sf.ng) <= 0.0f)
            return 0;
        *beta = v3_mul(*beta, bs.weight);
        vec3 x = hit->p;
        vec3 o = vbi_offset_ray_origin(x, hit->ng, w);
        *d = w;
        stats->rays++;
        hit_ok = vbi_scene_intersect(sc, o, w, INFINITY, hit);
        vec3 Le;
        float mw = vbi_arriving_light(sc, hit_ok, hit, x, w, bs.pdf, 1, &Le);
        if (mw > 0.0f)
            *direct = v3_add(*direct, v3_scale(v3_mul(*beta, Le), mw));
    }
}

static inline void add_rgb(float *out, vec3 c)
{
    out[0] += c.x;
    out[1] += c.y;
    out[2] += c.z;
}

void vbi_vpl_trace(const vbnl_scene *sc, int indirect_only, vec3 cam_forward, vbi_vpl_gather_fn gather,
                    const void *gstate, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first,
                    float *out, vbi_thread_stats *stats)
{
    out[3] = 1.0f;
    if (!hit_ok) {
        if (sc->env_light != VBI_NO_LIGHT && !indirect_only)
            add_rgb(out, vbi_light_Le(&sc->lights[sc->env_light], v3s(0.0f), v3_neg(d)));
        return;
    }
    vbi_hit hit = *first;
    {
        vbi_bsdf tmp;
        v3_store(out + VBNL_FILM_ALBEDO, vbi_bsdf_albedo(vbi_surface_bsdf(sc, &hit, &tmp)));
    }
    v3_store(out + VBNL_FILM_NORMAL, hit.ns);
    out[VBNL_FILM_DEPTH] = v3_dot(v3_sub(hit.p, o), cam_forward);
    if (hit.light != VBI_NO_LIGHT && !indirect_only)
        add_rgb(out, vbi_light_Le(&sc->lights[hit.light], hit.ng, v3_neg(d)));
    vec3 beta, direct;
    int ok = vbi_vpl_camera_vertex(sc, sp, 1, &hit, &d, &beta, &direct, stats);
    if (!indirect_only)
        add_rgb(out, direct);
    if (!ok)
        return;
    vbi_bsdf store;
    const vbi_bsdf *bsdf = vbi_surface_bsdf(sc, &hit, &store);
    vbi_shading_frame sf;
    vbi_shading_frame_make(bsdf, &hit, d, &sf);
    const vec3 x = hit.p;
    if (!indirect_only) {
        add_rgb(out, v3_mul(beta, vbi_estimate_direct(sc, bsdf, x, &sf, sp, stats)));
        /* the BSDF half of the direct estimator's MIS */
        vbi_bsdf_sample_rec bs;
        vec2 ub = vbi_sampler_next2(sp);
        if (vbi_bsdf_sample(bsdf, sf.wo, ub, &bs) && !v3_is_black(bs.weight)) {
            vec3 w = frame_to_world(&sf.fr, bs.wi);
            if ((bs.lobe & VBI_LOBE_TRANSMISSION) || v3_dot(w, sf.ng) > 0.0f) {
                vbi_hit y;
                stats->rays++;
                int y_ok = vbi_scene_intersect(sc, vbi_offset_ray_origin(x, hit.ng, w), w, INFINITY, &y);
                vec3 Le;
                float mw = vbi_arriving_light(sc, y_ok, &y, x, w, bs.pdf, (bs.lobe & VBI_LOBE_SPECULAR) != 0, &Le);
                if (mw > 0.0f)
                    add_rgb(out, v3_scale(v3_mul(v3_mul(beta, bs.weight), Le), mw));
            }
        }
    }
    add_rgb(out, v3_mul(beta, gather(gstate, bsdf, x, &sf, sp, stats)));
}

/* ---- camera points of the acceptance test ---------------------------------------------------- */

typedef struct cam_point {
    vbi_bsdf bsdf;
    vbi_shading_frame sf;
    vec3 x, beta;
    int ok;
} cam_point;

static void make_camera_points(const vbnl_scene *sc, const vbi_vpl_params *p, uint64_t seed, cam_point *pts)
{
    vbi_thread_stats st;
    memset(&st, 0, sizeof(st));
    for (uint32_t c = 0; c < p->camera_points; ++c) {
        cam_point *cp = &pts[c];
        cp->ok = 0;
        vbi_rng rng = vbi_rng_for(seed, c, 2);
        float px = vbi_rng_next(&rng) * (float)p->width, py = vbi_rng_next(&rng) * (float)p->height;
        vec3 o, d;
        vbi_camera_ray(&sc->camera, p->width, p->height, px, py, &o, &d);
        vbi_hit hit;
        int hit_ok = vbi_scene_intersect(sc, o, d, INFINITY, &hit);
        vec3 beta, direct;
        vbi_sampler sp = vbi_sampler_from_rng(rng);
        if (!vbi_vpl_camera_vertex(sc, &sp, hit_ok, &hit, &d, &beta, &direct, &st))
            continue;
        vbi_bsdf store;
        cp->bsdf = *vbi_surface_bsdf(sc, &hit, &store);
        vbi_shading_frame_make(&cp->bsdf, &hit, d, &cp->sf);
        cp->x = hit.p;
        cp->beta = beta;
        cp->ok = 1;
    }
}

/* Mean luminance contribution of v over the camera points (shadow rays included). */
static double camera_contribution(const vbnl_scene *sc, const cam_point *pts, uint32_t n, const vbi_vpl *v,
                                  float clamp)
{
    double sum = 0.0;
    for (uint32_t c = 0; c < n; ++c) {
        if (!pts[c].ok)
            continue;
        vec3 w;
        float dist;
        vec3 L = vbi_vpl_contribution(v, &pts[c].bsdf, pts[c].x, &pts[c].sf, clamp, &w, &dist);
        if (v3_is_black(L) || !vbi_vpl_visible(sc, pts[c].x, pts[c].sf.ng, v, w, dist))
            continue;
        sum += vbi_luminance(v3_mul(pts[c].beta, L));
    }
    return n ? sum / n : 0.0;
}

/* ---- generation ------------------------------------------------------------------------------ */

typedef struct cand {
    vbi_vpl v;
    uint64_t path;
    double phi;   /* mean camera-point luminance contribution with the raw (unnormalised) flux */
    float p;      /* acceptance probability */
    int accepted;
} cand;

typedef struct chunk_out {
    cand *c;
    uint32_t n, cap;
    int oom;
} chunk_out;

typedef struct frame_job {
    const vbnl_scene *scene;
    const vbi_vpl_params *p;
    uint64_t seed;          /* the frame's walk seed */
    uint64_t first;         /* first path of this round */
    uint64_t end;           /* one past the last path of this round */
    chunk_out *out;         /* one per chunk of the round */
    const cam_point *pts;   /* NULL: no contribution estimates */
    double inv_n_prev;      /* 1 / previous frame's N */
    double phi_v;           /* 0: accept everything */
} frame_job;

typedef struct walk_ctx {
    const frame_job *job;
    chunk_out *out;
    uint64_t path;
    vbi_rng acc;
} walk_ctx;

static void visit(void *user, const vbi_photon_vertex *pv)
{
    walk_ctx *wc = user;
    const frame_job *job = wc->job;
    chunk_out *o = wc->out;
    if (o->oom)
        return;
    if (o->n == o->cap) {
        uint32_t cap = o->cap ? 2 * o->cap : 64;
        cand *c = realloc(o->c, sizeof(cand) * cap);
        if (!c) {
            o->oom = 1;
            return;
        }
        o->c = c;
        o->cap = cap;
    }
    cand *c = &o->c[o->n];
    c->v.p = pv->hit->p;
    c->v.ng = pv->ng;
    c->v.fr = frame_from_normal(pv->ns);
    c->v.wi = frame_to_local(&c->v.fr, pv->wo);
    c->v.flux = pv->beta;
    c->v.bsdf = *pv->bsdf;
    c->path = wc->path;
    c->phi = 0.0;
    c->p = 1.0f;
    if (job->pts) {
        c->phi = camera_contribution(job->scene, job->pts, job->p->camera_points, &c->v, job->p->clamp);
        if (job->phi_v > 0.0)
            c->p = (float)fmin(c->phi * job->inv_n_prev / job->phi_v + job->p->epsilon, 1.0);
    }
    /* the acceptance draw comes from its own stream: the walk is the same whatever p is */
    float xi = vbi_rng_next(&wc->acc);
    c->accepted = xi < c->p;
    o->n++;
}

static void run_chunk(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    const frame_job *job = user;
    chunk_out *o = &job->out[item];
    uint64_t b = job->first + item * VPL_CHUNK;
    uint64_t e = b + VPL_CHUNK < job->end ? b + VPL_CHUNK : job->end;
    vbi_photon_walk_desc wd = {job->scene, 1.0f, job->p->rr_depth, 0, 0, 0};
    vbi_photon_walk_stats ws = {0, 0, 0};
    for (uint64_t k = b; k < e; ++k) {
        vbi_rng rng = vbi_rng_for(job->seed, k, 0);
        walk_ctx wc = {job, o, k, vbi_rng_for(job->seed, k, 1)};
        vbi_photon_walk(&wd, &rng, visit, &wc, &ws);
    }
}

void vbi_vpl_set_free(vbi_vpl_set *s)
{
    if (!s)
        return;
    free(s->vpls);
    memset(s, 0, sizeof(*s));
}

/* One frame: candidates in path order until `target` are accepted (or light_paths paths). */
static vbnl_result build_frame(const vbnl_scene *sc, const vbi_vpl_params *p, vbnl_stage_ctx *stage,
                               uint64_t seed, const cam_point *pts, double inv_n_prev, double phi_v,
                               cand **out_c, uint32_t *out_n, uint64_t *out_paths, vbnl_error *err)
{
    cand *all = NULL;
    size_t n_all = 0, cap_all = 0;
    uint64_t accepted = 0, next = 0, paths = 0;
    int done = 0;
    const uint64_t max_paths = p->light_paths ? p->light_paths : (uint64_t)1 << 40;
    while (!done) {
        uint64_t batch;
        if (p->light_paths)
            batch = p->light_paths;
        else if (accepted == 0)
            batch = next == 0 ? (uint64_t)p->target / 2 + VPL_CHUNK : next * 4;
        else
            batch = (uint64_t)((double)(p->target - accepted) * (double)next / (double)accepted * 1.1) + VPL_CHUNK;
        if (batch > max_paths - next)
            batch = max_paths - next;
        if (batch == 0)
            break;
        uint64_t items = (batch + VPL_CHUNK - 1) / VPL_CHUNK;
        frame_job job = {sc, p, seed, next, next + batch, calloc(items, sizeof(chunk_out)), pts, inv_n_prev, phi_v};
        if (!job.out) {
            free(all);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        int rc = vbi_run_items(stage, NULL, items, run_chunk, &job);
        int oom = 0;
        for (uint64_t i = 0; i < items && rc == 0 && !done; ++i) {
            chunk_out *o = &job.out[i];
            oom |= o->oom;
            for (uint32_t k = 0; k < o->n && !done; ++k) {
                if (n_all == cap_all) {
                    size_t cap = cap_all ? 2 * cap_all : 1024;
                    cand *c = realloc(all, sizeof(cand) * cap);
                    if (!c) {
                        oom = 1;
                        break;
                    }
                    all = c;
                    cap_all = cap;
                }
                all[n_all++] = o->c[k];
                paths = o->c[k].path + 1;
                if (o->c[k].accepted && ++accepted >= p->target && !p->light_paths)
                    done = 1;
            }
        }
        for (uint64_t i = 0; i < items; ++i)
            free(job.out[i].c);
        free(job.out);
        if (rc != 0) {
            free(all);
            return vbnl_error_set(err, VBNL_ERR_CANCELLED, "virtual point light generation was cancelled");
        }
        if (oom) {
            free(all);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        next += batch;
        if (p->light_paths)
            done = 1;
        if (!done && next >= max_paths)
            break;
        if (!done && next > 1000000 && accepted == 0) {
            free(all);
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "no virtual point light after %llu light paths: no light reaches a "
                                  "non-specular surface",
                                  (unsigned long long)next);
        }
    }
    if (p->light_paths)
        paths = p->light_paths;
    *out_c = all;
    *out_n = (uint32_t)n_all;
    *out_paths = paths;
    return VBNL_OK;
}

vbnl_result vbi_vpl_params_check(const vbi_vpl_params *p, const char *owner, vbnl_error *err)
{
    /* a fixed path count stores about one VPL per bounce: assume 4 per path */
    double lights = p->light_paths ? 4.0 * (double)p->light_paths : (double)p->target;
    /* candidates (with the acceptance: assume a mean acceptance of 0.1) plus the kept set */
    double bytes = lights * (sizeof(vbi_vpl) + (p->acceptance ? 10.0 : 1.0) * sizeof(vbi_vpl) * 1.2);
    double phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
    if (phys > 0.0 && bytes > 0.8 * phys)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY,
                              "integrator '%s': %.0f virtual point lights need about %.1f GB but the machine has "
                              "%.1f GB",
                              owner, lights, bytes / 1e9, phys / 1e9);
    return VBNL_OK;
}

vbnl_result vbi_vpl_set_build(const vbnl_scene *sc, const vbi_vpl_params *p, vbnl_stage_ctx *stage,
                               vbi_vpl_set *out, vbnl_error *err)
{
    memset(out, 0, sizeof(*out));
    const uint32_t frames = p->acceptance ? (p->frames ? p->frames : 1) : 1;
    const double P = (double)p->width * p->height;
    cam_point *pts = NULL;
    if (p->acceptance) {
        pts = malloc(sizeof(cam_point) * (p->camera_points ? p->camera_points : 1));
        if (!pts)
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    double phi_total = 0.0, inv_n_prev = 0.0;
    cand *c = NULL;
    uint32_t n = 0;
    uint64_t paths = 0;
    vbnl_result r = VBNL_OK;
    for (uint32_t f = 0; f < frames; ++f) {
        const int last = f + 1 == frames;
        /* pilot frames walk with their own seeds; the final frame walks as plain IR does */
        uint64_t seed = last ? vbi_hash3(p->seed, 0x5650u, 0) : vbi_hash3(p->seed, 0x5650u, f + 1);
        if (pts)
            make_camera_points(sc, p, vbi_hash3(p->seed, 0x4e43u, f), pts);
        double phi_v = phi_total > 0.0 && p->target > 0 ? phi_total / (P * (double)p->target) : 0.0;
        free(c);
        c = NULL;
        if (stage)
            vbnl_stage_begin(stage, last ? "light paths" : "light paths (pilot frames)", 0.0, "chunks");
        r = build_frame(sc, p, stage, seed, pts, inv_n_prev, phi_v, &c, &n, &paths, err);
        if (stage)
            vbnl_stage_end(stage);
        if (r != VBNL_OK)
            break;
        /* this frame's image total for the next: P times the camera-point mean of the kept set */
        double sum = 0.0;
        for (uint32_t i = 0; i < n; ++i)
            if (c[i].accepted)
                sum += c[i].phi / c[i].p;
        phi_total = paths ? P * sum / (double)paths : 0.0;
        inv_n_prev = paths ? 1.0 / (double)paths : 0.0;
        out->phi_total = phi_v * P * (double)p->target;
    }
    free(pts);
    if (r != VBNL_OK) {
        free(c);
        return r;
    }
    uint32_t kept = 0;
    double psum = 0.0;
    for (uint32_t i = 0; i < n; ++i) {
        kept += c[i].accepted != 0;
        psum += c[i].p;
    }
    out->vpls = malloc(sizeof(vbi_vpl) * (kept ? kept : 1));
    if (!out->vpls) {
        free(c);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    const float inv_n = paths ? (float)(1.0 / (double)paths) : 0.0f;
    for (uint32_t i = 0; i < n; ++i) {
        if (!c[i].accepted)
            continue;
        vbi_vpl *v = &out->vpls[out->count++];
        *v = c[i].v;
        v->flux = v3_scale(v->flux, inv_n / c[i].p);
    }
    out->paths = paths;
    out->candidates = n;
    out->mean_acceptance = n ? psum / n : 1.0;
    free(c);
    return VBNL_OK;
}
