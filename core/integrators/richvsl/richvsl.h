/* `richvsl`: Rich-VPLs with the spherical variant (Simon, Hanika, Dachsbacher 2015), internal
 * interface shared by its stages and the tests (private header).
 *
 * Stages (one file each):
 *   maps.c       importon map (camera paths, §4.1) and photon map (light paths, the photon walk
 *                of photon_walk.h), k-d trees over both (kdtree.h, whose k-nearest query the
 *                other stages use);
 *   placement.c  importance at every photon (Epanechnikov K-NN estimate of the importons,
 *                §4.1), one Bernoulli trial per photon with P_RS = min(1, W / (q W_mean)), and
 *                the relaxation of §4.2 (K = 6, snap to the nearest photon after every step);
 *   emission.c   the emission profile of every light (§5): normalised-kernel gathering of the
 *                photons within the distance to the second-closest other light, reflected with
 *                the BSDF at the light into a 32 x 32 hemi-octahedral intensity table
 *                (octahedral.h) by binned convolution, or for near-mirror conductors by BSDF
 *                sampling per photon and splatting; Lambertian lights keep only their flux;
 *   richvsl.c    the integrator: parameters, stages, sphere radii and shading (§6 Rich-VSL).
 *
 * Units: a light's intensity I(w) is reflected power per steradian leaving along w (W/sr,
 * without the outgoing cosine), I(w) = (1 / P_RS) sum_j w_j f_r(p, w_j -> w) Phi_j with sum w_j
 * = 1, so the power it emits is the integral of I(w) cos(theta) dw. */
#ifndef VBI_RICHVSL_H
#define VBI_RICHVSL_H

#include <stdint.h>

#include "bsdf.h"
#include "kdtree.h"
#include "octahedral.h"
#include "pool.h"
#include "render_internal.h"
#include "scene_internal.h"

/* ---- maps.c ---------------------------------------------------------------------------------- */

/* A stored photon: the surface hit (for the BSDF there), the normals facing the arriving photon,
 * the direction it came from and its flux (already divided by the number of photon paths). */
typedef struct rv_photon {
    vbi_hit hit;
    vec3 ng, ns;  /* unit, facing the side the photon arrived from */
    vec3 wi;      /* unit, toward where the photon came from */
    vec3 flux;
} rv_photon;

typedef struct rv_maps {
    /* importons: positions in pts (id = index), importance in w */
    vbi_kd_pt *imp_pts;
    float *imp_w;
    uint32_t imp_count;
    uint64_t imp_paths;
    vbi_kd_tree imp_tree;
    /* photons: records in ph, positions in ph_pts (id = index into ph) */
    rv_photon *ph;
    vbi_kd_pt *ph_pts;
    uint32_t ph_count;
    uint64_t ph_paths;
    vbi_kd_tree ph_tree;
} rv_maps;

void rv_maps_free(rv_maps *m);

/* Traces paths_per_pixel camera paths per pixel; an importon is stored at the vertex after the
 * first non-delta vertex (delta vertices before it are passed through, at most
 * RV_MAX_SPECULAR_CHAIN), with importance = mean of the path throughput there / paths. Builds
 * the importon tree. Path k draws from vbi_rng_for(seed ^ stream, k, 0): any thread count
 * gives the same map. */
#define RV_MAX_SPECULAR_CHAIN 8
vbnl_result rv_trace_importons(const vbnl_scene *sc, uint32_t width, uint32_t height, uint32_t paths_per_pixel,
                               uint64_t seed, vbnl_stage_ctx *stage, vbi_pool *pool, rv_maps *m,
                               vbnl_error *err);

/* Traces photon paths (vbi_photon_walk, plain Russian roulette) in batches of a fixed size
 * until at least target_photons photons are stored at non-delta hits; the flux is divided by the
 * number of paths traced (every path counts, also those that stored nothing). Builds the photon
 * tree. Deterministic for any thread count. */
vbnl_result rv_trace_photons(const vbnl_scene *sc, uint64_t target_photons, uint64_t seed, vbnl_stage_ctx *stage,
                             vbi_pool *pool, rv_maps *m, vbnl_error *err);

/* The most neighbours a placement query asks vbi_kd_knn for (its arrays are on the stack). */
#define RV_KNN_MAX 1024u

/* ---- placement.c ----------------------------------------------------------------------------- */

/* P_RS of §4.1: min(1, W / (q W_mean)); 0 when W_mean is 0. */
static inline double rv_p_rs(double W, double q, double W_mean)
{
    if (!(W_mean > 0.0) || !(W > 0.0))
        return 0.0;
    double p = W / (q * W_mean);
    return p < 1.0 ? p : 1.0;
}

/* W(x) = 2 / (pi d_K^2) sum_{i<K} Psi_i (1 - d_i^2 / d_K^2) at every photon (K-NN Epanechnikov
 * estimate of the importons, §4.1); W_mean = the mean over the photons. */
vbnl_result rv_importance_at_photons(const rv_maps *m, uint32_t K, vbnl_stage_ctx *stage, vbi_pool *pool,
                                     float *W, double *W_mean, vbnl_error *err);

/* One Bernoulli trial per photon (stream: vbi_rng_for(seed ^ stream, photon, 0)) with
 * probability rv_p_rs(W[i], q, W_mean). Writes the accepted photon ids (ascending) and their
 * P_RS to malloc'ed arrays. */
vbnl_result rv_place(const float *W, uint32_t n, double q, double W_mean, uint64_t seed, uint32_t **ids,
                     float **p_rs, uint32_t *count, vbnl_error *err);

/* Relaxation of §4.2 (Spencer-Jones after Turk): `iterations` Jacobi steps of
 * dx = (1/K) sum_k (x - x_k) (d / (|x - x_k| + eps) - 1), d the distance to the (K+1)-th
 * neighbour, then each light snaps to the photon nearest its new position; ids (photon ids:
 * photon_pos[id] is the position, photon_tree's point ids) are updated in place. eps = 1e-4 d. Needs count > K + 1
 * (else nothing moves). */
vbnl_result rv_relax(const vbi_kd_tree *photon_tree, const vec3 *photon_pos, uint32_t *ids, uint32_t count,
                     uint32_t K, uint32_t iterations, vbnl_stage_ctx *stage, vbi_pool *pool, vbnl_error *err);

/* ---- emission.c ------------------------------------------------------------------------------ */

/* The gathered photons of one light: normalised kernel weights times 1 / P_RS. */
typedef struct rv_gathered {
    vec3 wi;      /* unit, world space, toward where the photon came from */
    vec3 flux;    /* w_j Phi_j / P_RS */
} rv_gathered;

/* The table of one light: texel t receives I(w_t) at its centre direction (hemi-octahedral map
 * of `map` in the frame around n), I(w) = sum_j f_r(w_j -> w) flux_j with f_r = eval(w, w_j) /
 * cos(theta_j). Incident directions are first binned (bilinear splat) into an incident map of
 * incident_res^2 texels, so the cost is at most incident_res^2 x R^2 BSDF evaluations. rgb
 * has R^2 x 3 floats. */
#define RV_INCIDENT_RES 8u
void rv_emission_table(const vbi_hemioct *map, const vbi_hemioct *incident_map, const vbi_bsdf *bsdf, vec3 n,
                       const rv_gathered *g, uint32_t count, float *rgb);

/* The table of a highly glossy light (§5, "highly glossy/specular"): for every photon,
 * `samples` outgoing directions drawn from the BSDF at the light given the photon's incident
 * direction (adjoint sampling, reciprocal BSDFs), each carrying flux_j f cos / (pdf samples) of
 * reflected power, splatted bilinearly; then I_t = E_t / C_t (the texel's bilinear projected
 * solid angle), so the table's power sum_t I_t C_t is exactly the power splatted and a lobe
 * narrower than a texel keeps its energy (the paper's built-in mollification). */
void rv_emission_table_sampled(const vbi_hemioct *map, const vbi_bsdf *bsdf, vec3 n, const rv_gathered *g,
                               uint32_t count, uint32_t samples, vbi_rng *rng, float *rgb);

/* Lambertian light: the constant intensity rho / pi sum_j flux_j (incident directions below the
 * light's horizon excluded). */
vec3 rv_lambert_intensity(const vbi_bsdf *bsdf, vec3 n, const rv_gathered *g, uint32_t count);

/* The lights of a placed set. */
typedef struct rv_lights {
    uint32_t count;
    uint32_t *photon;   /* the photon each light sits on */
    vec3 *p, *n, *ng;   /* position, unit shading and geometric normals (the photon's, facing where
                         * its light came from) */
    float *p_rs;        /* acceptance probability of the photon it was placed on */
    float *radius;      /* sphere radius (richvsl.c) */
    float *gather_r;    /* radius photons were gathered in */
    uint32_t *gathered; /* photons gathered */
    vec3 *intensity;    /* Lambertian lights: I; others: unused */
    float *table;       /* count x R^2 x 3 floats (rows of Lambertian lights stay unused); NULL
                         * when every light is Lambertian */
    uint8_t *lambert;
    uint8_t *sampled;   /* table made by rv_emission_table_sampled */
    uint32_t res;
} rv_lights;

void rv_lights_free(rv_lights *l);

/* Gathers and tabulates the emission of every light of l (positions and normals set, p_rs set):
 * photons within the distance to the second-closest light (the light itself excluded), whose
 * geometric normal agrees with the light's (n . n_j > RV_NORMAL_COS), weights
 * (1 - d^2 / r^2) normalised to one (at most RV_GATHER_MAX nearest photons). */
#define RV_NORMAL_COS 0.7f
#define RV_GATHER_MAX 1024u
typedef struct rv_emission_params {
    float sampled_alpha;  /* conductors with GGX alpha below this use rv_emission_table_sampled */
    uint32_t samples;     /* BSDF samples per photon there */
    uint64_t seed;        /* light i draws from vbi_rng_for(seed ^ stream, i, 0) */
} rv_emission_params;
vbnl_result rv_build_emission(const vbnl_scene *sc, const rv_maps *m, const vbi_hemioct *map,
                              const rv_emission_params *ep, rv_lights *l, vbnl_stage_ctx *stage, vbi_pool *pool,
                              vbnl_error *err);

#endif
