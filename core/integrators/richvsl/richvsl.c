/* `richvsl`: Rich-VPLs with importon-driven placement, relaxation and the spherical variant
 * (Simon, Hanika, Dachsbacher 2015, "Rich-VPLs for Improving the Versatility of Many-Light
 * Methods").
 *
 * prepare: importon map (importons per pixel, §4.1) -> photon map (q photons per light) ->
 *          importance W at every photon (Epanechnikov K-NN estimate) -> one Bernoulli trial per
 *          photon with P_RS = min(1, W / (q W_mean)) -> relaxation (K = 6, 20 iterations, snap
 *          to the nearest photon, §4.2) -> emission tables (maps.c, placement.c, emission.c)
 *          -> sphere radii r_i = M x the distance to the 10th nearest light (§7, HKWB09).
 * render:  camera paths pass through delta surfaces to the first non-delta vertex x, which gets
 *          the direct light of the real lights (the estimator of `path` and `vbnl`: next-event
 *          estimation with MIS against a BSDF sample) and, from every light i, the Rich-VSL term
 *            L_i = V(x, y_i) / (pi r_i^2) Int_cone f_x(w) cos_x I_i(-w) cos_i dw
 *          over the cone of directions toward the light's sphere (all directions inside it),
 *          visibility to the centre only (§6), and only when x is in front of the light's surface
 *          and the centre in front of x's (as `vsl`; against light leaking through thin walls).
 *          The integral is estimated by sampling the BSDF at x and, so that far lights whose
 *          cones BSDF samples rarely hit are not noisy, a uniform direction in the cone (VBNL
 *          Eq. 4), combined by the power heuristic; the emission is not importance-sampled (§6). As r -> 0 the term is the Rich-VPL term
 *          f_x I_i(-w) cos_x cos_i / d^2; radius_scale = 0 renders that point form.
 *
 * Clamping (`clamp` = b > 0, as for every VPL-type method; BSDFs never clamped): the point form
 * bounds G = cos_x cos_i / d^2 by b. The sphere form bounds the same quantity for each direction
 * of the cone, with 1 / d^2 replaced by the cone's solid angle over pi r^2 (which tends to
 * 1 / d^2 as r -> 0), so both agree in the limit and clamping never adds light. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "richvsl.h"
#include "vpl_set.h"
#include "shading.h"

static const vbnl_param_spec rv_params[] = {
    {"virtual_lights", VBNL_PARAM_INT, 1000, NULL, 1, 5e7, NULL,
     "N: the photon map holds q N photons, so about N lights (at most) are placed (the VBNL paper "
     "compares at 12K); under --time sized to the budget unless set"},
    {"importon_paths", VBNL_PARAM_INT, 32, NULL, 1, 4096, NULL, "camera (importon) paths per pixel (§7: 32); under --time lowered to fit the preparation bound unless set"},
    {"photons_per_light", VBNL_PARAM_FLOAT, 100, NULL, 1, 1e6, NULL, "q: photons per light (§7: 100)"},
    {"importance_neighbours", VBNL_PARAM_INT, 16, NULL, 2, 1024, NULL,
     "K of the importance estimate at the photons (not given in the paper)"},
    {"relax_neighbours", VBNL_PARAM_INT, 6, NULL, 1, 1000, NULL, "K of the relaxation (§4.2: 6)"},
    {"relax_iterations", VBNL_PARAM_INT, 20, NULL, 0, 1000, NULL, "relaxation steps (§4.2: 20; 0 = off)"},
    {"profile_resolution", VBNL_PARAM_INT, 32, NULL, 8, 32, NULL,
     "side of the hemi-octahedral emission table: 8, 16 or 32 (§7: 32)"},
    {"sampled_alpha", VBNL_PARAM_FLOAT, 0.1, NULL, 0, 1, NULL,
     "conductors smoother than this GGX alpha tabulate by sampling the BSDF per photon and splatting "
     "(the paper's highly glossy path, threshold not given); others by binned convolution"},
    {"emission_samples", VBNL_PARAM_INT, 16, NULL, 1, 4096, NULL,
     "BSDF samples per gathered photon for sampled_alpha lights (not given in the paper)"},
    {"radius_scale", VBNL_PARAM_FLOAT, 4, NULL, 0, 1e3, NULL,
     "M: sphere radius = M x distance to the radius_neighbour-th nearest light (HKWB09: 4 to 10); "
     "0 = point lights (Rich-VPL)"},
    {"radius_neighbour", VBNL_PARAM_INT, 10, NULL, 1, 1000, NULL, "k of the radius rule (10)"},
    {"clamp", VBNL_PARAM_FLOAT, 0, NULL, 0, 1e30, NULL,
     "bound b of the geometry term cos cos / d^2 (1/scene unit^2), as for vpl; 0 = unclamped"},
    {"indirect_only", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "leave out emission and single scattering (the 'direct' part of `path`), to compare indirect light"},
};
#define N_PARAMS (sizeof(rv_params) / sizeof(rv_params[0]))

typedef struct rv_state {
    const vbnl_scene *scene;
    uint32_t width, height;
    uint64_t seed;
    uint32_t virtual_lights, importon_paths, k_importance, k_relax, relax_iterations, res, radius_k;
    double q;
    float radius_scale, clamp, sampled_alpha;
    uint32_t emission_samples;
    int indirect_only;
    uint32_t stride;
    vec3 cam_forward;
    /* the prepared set */
    vbi_hemioct *map;
    rv_lights l;
    frame *fr;        /* local frame of each light (z = n) */
    float *inv_area;  /* 1 / (pi r^2), 0 for point lights */
    /* statistics of the last prepare (tests, README) */
    uint32_t importons, photons;
    uint64_t photon_paths;
    int prepared;
    vbnl_budget *budget;
    int lights_set, importons_set; /* virtual_lights / importon_paths set by the user */
} rv_state;

/* Under a time budget the light count is sized by vbnl_budget_size_lights (docs/time-budget.md):
 * two samples per pixel in the budget's rendering share, a light evaluation costing about 3
 * shadow rays (measured on the Cornell box: docs/time-budget.md). */
#define RV_LIGHT_COST 3.0

static double param(const vbnl_integrator_env *env, const char *name)
{
    return vbnl_params_number(env->params, rv_params, N_PARAMS, name);
}

static vbnl_result rv_create(const vbnl_integrator_env *env, void **out, vbnl_error *err)
{
    rv_state *s = calloc(1, sizeof(*s));
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    s->scene = env->scene;
    s->width = env->settings->width;
    s->height = env->settings->height;
    s->seed = env->settings->seed;
    s->virtual_lights = (uint32_t)param(env, "virtual_lights");
    s->budget = env->budget;
    s->lights_set = vbnl_params_has(env->params, "virtual_lights");
    s->importons_set = vbnl_params_has(env->params, "importon_paths");
    s->importon_paths = (uint32_t)param(env, "importon_paths");
    s->q = param(env, "photons_per_light");
    s->k_importance = (uint32_t)param(env, "importance_neighbours");
    s->k_relax = (uint32_t)param(env, "relax_neighbours");
    s->relax_iterations = (uint32_t)param(env, "relax_iterations");
    s->res = (uint32_t)param(env, "profile_resolution");
    s->sampled_alpha = (float)param(env, "sampled_alpha");
    s->emission_samples = (uint32_t)param(env, "emission_samples");
    s->radius_scale = (float)param(env, "radius_scale");
    s->radius_k = (uint32_t)param(env, "radius_neighbour");
    s->clamp = (float)param(env, "clamp");
    s->indirect_only = param(env, "indirect_only") != 0.0;
    s->stride = env->film->stride;
    s->cam_forward = v3_norm(v3_load(env->scene->camera.forward));

    vbnl_result r = VBNL_OK;
    double photons = s->q * s->virtual_lights;
    double importons = (double)s->width * s->height * s->importon_paths;
    if (s->res != 8 && s->res != 16 && s->res != 32)
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'richvsl': profile_resolution must be 8, 16 or 32, got %u", s->res);
    else if (photons >= 2.0e9)
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'richvsl': photons_per_light x virtual_lights = %.3g photons, more than "
                           "the 2e9 the photon map holds",
                           photons);
    else if (importons >= 4.0e9)
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'richvsl': %ux%u pixels x %u importon_paths = %.3g importons, more than "
                           "4e9",
                           s->width, s->height, s->importon_paths, importons);
    if (r == VBNL_OK) {
        /* peak memory: importon tracing (~37 B each), photons (~130 B with tree), tables */
        double bytes = importons * 37.0 + photons * 130.0 +
                       (double)s->virtual_lights * (12.0 * s->res * s->res + 96.0);
        double phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
        if (phys > 0.0 && bytes > 0.8 * phys)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY,
                               "integrator 'richvsl': this request needs about %.1f GB (%.3g importons, %.3g "
                               "photons, %u tables of %ux%u) but the machine has %.1f GB",
                               bytes / 1e9, importons, photons, s->virtual_lights, s->res, s->res, phys / 1e9);
    }
    if (r != VBNL_OK) {
        free(s);
        return r;
    }
    *out = s;
    return VBNL_OK;
}

/* Frees what a preparation made (the lights, their tables and frames). */
static void rv_release(rv_state *s)
{
    rv_lights_free(&s->l);
    vbi_hemioct_destroy(s->map);
    free(s->fr);
    free(s->inv_area);
    s->map = NULL;
    s->fr = NULL;
    s->inv_area = NULL;
    s->prepared = 0;
}

static void rv_destroy(void *state)
{
    rv_state *s = state;
    if (!s)
        return;
    rv_release(s);
    free(s);
}

/* Sphere radii: M x the distance to the k-th nearest other light (0: a point light). */
static vbnl_result set_radii(rv_state *s, vbnl_error *err)
{
    rv_lights *l = &s->l;
    uint32_t n = l->count;
    l->radius = calloc(n, sizeof(float));
    s->inv_area = calloc(n, sizeof(float));
    s->fr = malloc(sizeof(frame) * n);
    vbi_kd_pt *pts = malloc(sizeof(vbi_kd_pt) * n);
    uint32_t *idx = malloc(sizeof(uint32_t) * (s->radius_k + 1));
    float *d2 = malloc(sizeof(float) * (s->radius_k + 1));
    vbi_kd_tree t;
    memset(&t, 0, sizeof(t));
    vbnl_result r = VBNL_OK;
    if (!l->radius || !s->inv_area || !s->fr || !pts || !idx || !d2)
        r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u lights", n);
    for (uint32_t i = 0; r == VBNL_OK && i < n; ++i) {
        s->fr[i] = frame_from_normal(l->n[i]);
        pts[i].p[0] = l->p[i].x;
        pts[i].p[1] = l->p[i].y;
        pts[i].p[2] = l->p[i].z;
        pts[i].id = i;
    }
    if (r == VBNL_OK && s->radius_scale > 0.0f && n > s->radius_k) {
        if (vbi_kd_build(&t, pts, n) != 0)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u lights", n);
        for (uint32_t i = 0; r == VBNL_OK && i < n; ++i) {
            const float q[3] = {l->p[i].x, l->p[i].y, l->p[i].z};
            uint32_t c = vbi_kd_knn(&t, q, s->radius_k + 1, UINT32_MAX, idx, d2);
            uint32_t seen = 0;
            for (uint32_t k = 0; k < c; ++k) {
                if (t.pts[idx[k]].id == i)
                    continue;
                if (++seen == s->radius_k) {
                    l->radius[i] = s->radius_scale * sqrtf(d2[k]);
                    break;
                }
            }
            if (l->radius[i] > 0.0f)
                s->inv_area[i] = 1.0f / (VBI_PI * l->radius[i] * l->radius[i]);
        }
    }
    vbi_kd_free(&t);
    free(pts);
    free(idx);
    free(d2);
    return r;
}

/* Traces s's importons into m (stage "importons"). */
static vbnl_result rv_importons(const rv_state *s, vbnl_stage_ctx *stage, rv_maps *m, vbnl_error *err)
{
    if (stage)
        vbnl_stage_begin(stage, "importons", 0, "chunks");
    vbnl_result r = rv_trace_importons(s->scene, s->width, s->height, s->importon_paths, s->seed, stage, NULL, m, err);
    if (stage)
        vbnl_stage_end(stage);
    return r;
}

/* Frees the photon part of m, keeping its importons. */
static void free_photons(rv_maps *m)
{
    vbi_kd_free(&m->ph_tree);
    free(m->ph);
    free(m->ph_pts);
    memset(&m->ph_tree, 0, sizeof(m->ph_tree));
    m->ph = NULL;
    m->ph_pts = NULL;
    m->ph_count = 0;
    m->ph_paths = 0;
}

/* The rest of the preparation at s's light count, on the importons of m (whose photon part it
 * fills and frees again): photons, importance, placement, relaxation, emission tables, radii. */
static vbnl_result rv_build(rv_state *s, vbnl_stage_ctx *stage, rv_maps *mp, vbnl_error *err)
{
    const vbnl_scene *sc = s->scene;
    rv_maps m = *mp;
    float *W = NULL, *p_rs = NULL;
    uint32_t *ids = NULL, count = 0;
    vec3 *pos = NULL;
    vbnl_result r = VBNL_OK;

    if (r == VBNL_OK) {
        if (stage)
            vbnl_stage_begin(stage, "photons", 0, "batches");
        r = rv_trace_photons(sc, (uint64_t)(s->q * s->virtual_lights + 0.5), s->seed, stage, NULL, &m, err);
        if (stage)
            vbnl_stage_end(stage);
    }
    if (r == VBNL_OK) {
        s->importons = m.imp_count;
        s->photons = m.ph_count;
        s->photon_paths = m.ph_paths;
        if (stage)
            vbnl_stage_begin(stage, "importance", m.ph_count, "photons");
        double W_mean = 0.0;
        W = malloc(sizeof(float) * m.ph_count);
        r = W ? rv_importance_at_photons(&m, s->k_importance, stage, NULL, W, &W_mean, err)
              : vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        /* The photon map holds whole paths, so slightly more than q N photons: the ratio q in P_RS
         * is the actual photons per wanted light, which keeps the expected count sum P_RS <= N. */
        double q_eff = (double)m.ph_count / s->virtual_lights;
        if (r == VBNL_OK)
            r = rv_place(W, m.ph_count, q_eff, W_mean, s->seed, &ids, &p_rs, &count, err);
        if (stage)
            vbnl_stage_end(stage);
        if (r == VBNL_OK && count == 0)
            r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                               "integrator 'richvsl': no light was placed (no photon lies where the camera's "
                               "importons are: nothing in view is lit indirectly)");
    }
    free(W);
    if (r == VBNL_OK) {
        if (stage)
            vbnl_stage_begin(stage, "relaxation", s->relax_iterations, "iterations");
        pos = malloc(sizeof(vec3) * m.ph_count);
        if (!pos)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        for (uint32_t i = 0; pos && i < m.ph_count; ++i)
            pos[i] = m.ph[i].hit.p;
        if (r == VBNL_OK)
            r = rv_relax(&m.ph_tree, pos, ids, count, s->k_relax, s->relax_iterations, stage, NULL, err);
        if (stage)
            vbnl_stage_end(stage);
    }
    free(pos);
    if (r == VBNL_OK) {
        rv_lights *l = &s->l;
        l->count = count;
        l->photon = ids;
        l->p_rs = p_rs; /* the probability of the photon each light was placed on */
        ids = NULL;
        p_rs = NULL;
        l->p = malloc(sizeof(vec3) * count);
        l->n = malloc(sizeof(vec3) * count);
        l->ng = malloc(sizeof(vec3) * count);
        l->lambert = malloc(count);
        if (!l->p || !l->n || !l->ng || !l->lambert)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u lights", count);
        for (uint32_t i = 0; r == VBNL_OK && i < count; ++i) {
            const rv_photon *ph = &m.ph[l->photon[i]];
            l->p[i] = ph->hit.p;
            l->n[i] = ph->ns;
            l->ng[i] = ph->ng;
            vbi_bsdf store;
            l->lambert[i] = vbi_surface_bsdf(sc, &ph->hit, &store)->type == VBNL_MATERIAL_LAMBERT;
        }
        if (r == VBNL_OK && vbi_hemioct_create(s->res, &s->map) != VBNL_OK)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        if (r == VBNL_OK) {
            if (stage)
                vbnl_stage_begin(stage, "emission", count, "lights");
            rv_emission_params ep = {s->sampled_alpha, s->emission_samples, s->seed};
            r = rv_build_emission(sc, &m, s->map, &ep, l, stage, NULL, err);
            if (r == VBNL_OK)
                r = set_radii(s, err);
            if (stage)
                vbnl_stage_end(stage);
        }
    }
    free(ids);
    free(p_rs);
    free_photons(&m); /* rendering needs only the lights */
    *mp = m;
    if (r == VBNL_OK) {
        s->prepared = 1;
        if (stage) { /* the lights and their emission tables */
            const rv_lights *l = &s->l;
            uint64_t per_light = sizeof(uint32_t) * 2 + sizeof(vec3) * 4 + sizeof(float) * 4 + 2 + sizeof(frame);
            uint64_t bytes = (uint64_t)l->count * per_light;
            if (l->table)
                bytes += (uint64_t)l->count * 3 * vbi_hemioct_texel_count(s->map) * sizeof(float);
            vbnl_stage_set_storage(stage, bytes);
        }
    }
    return r;
}

/* Under a time budget (docs/time-budget.md) the light count is first chosen from the rendering
 * rate (vbnl_budget_size_lights), then the preparation is kept within its bound in two steps,
 * each measured on the scene by a calibration recorded as the stage "calibrate" and thrown away:
 * importon_paths is lowered (not below 1) until the importons take at most RV_IMPORTON_SHARE of
 * what is left of RV_AIM of the bound (calibration: RV_CAL_IMPORTONS importon paths per pixel), then, on the
 * importons traced, the light count until the rest fits (calibration: the rest of the
 * preparation with at most RV_CAL_LIGHTS lights on the same importons, whose number sets the
 * cost of the importance estimate). Counts set by the user are kept; when they cannot fit the
 * bound they are refused before their work. */
#define RV_CAL_IMPORTONS 1u
#define RV_CAL_LIGHTS 16u
#define RV_AIM 0.8
#define RV_MARGIN 1.25
#define RV_IMPORTON_SHARE (1.0 / 3.0)

static void refuse_if(const rv_state *s, double estimate, const char *what, double per_unit, const char *unit,
                      int *refused, vbnl_error *err)
{
    const double limit = vbnl_budget_prepare_limit(s->budget);
    if (estimate <= limit)
        return;
    *refused = 1;
    vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                   "integrator 'richvsl': with %s set explicitly (virtual_lights=%u, importon_paths=%u) preparation "
                   "needs about %.1f s (calibrated on this scene: %.3g us per %s), more than its bound of %.2f s "
                   "(%g%% of the %g s time budget); lower it, raise --time, or leave it unset so that the budget "
                   "sizes it",
                   what, s->virtual_lights, s->importon_paths, estimate, per_unit * 1e6, unit, limit,
                   100.0 * VBNL_BUDGET_PREPARE_SHARE, vbnl_budget_seconds(s->budget));
}

static vbnl_result size_importons(rv_state *s, vbnl_stage_ctx *stage, vbnl_error *err)
{
    vbnl_result r = vbnl_budget_size_lights(s->budget, "virtual_lights", s->virtual_lights, 2.0, RV_LIGHT_COST, 16,
                                            12000, &s->virtual_lights, err);
    if (r != VBNL_OK)
        return r;
    rv_state cal = *s;
    cal.importon_paths = s->importon_paths < RV_CAL_IMPORTONS ? s->importon_paths : RV_CAL_IMPORTONS;
    rv_maps m;
    memset(&m, 0, sizeof(m));
    const char *record_as = stage ? stage->record_as : NULL;
    if (stage)
        stage->record_as = "calibrate";
    double t0 = vbi_now();
    r = rv_importons(&cal, stage, &m, err);
    const double t = vbi_now() - t0;
    if (stage)
        stage->record_as = record_as;
    rv_maps_free(&m);
    if (r != VBNL_OK)
        return r;
    const double pixels = (double)s->width * s->height;
    const double per_importon = fmax(t, 1e-9) / (pixels * cal.importon_paths);
    const double limit = vbnl_budget_prepare_limit(s->budget), elapsed = vbnl_budget_elapsed(s->budget);
    if (s->importons_set) {
        int refused = 0;
        refuse_if(s, elapsed + s->importon_paths * pixels * per_importon, "importon_paths", per_importon,
                  "importon path", &refused, err);
        if (refused)
            return VBNL_ERR_INVALID_ARGUMENT;
        vbnl_budget_choose(s->budget, "importon_paths", s->importon_paths, "set explicitly, kept (%.3g s estimated)",
                           s->importon_paths * pixels * per_importon);
        return VBNL_OK;
    }
    const double left = fmax(0.0, RV_AIM * limit - elapsed);
    const double fit = floor(RV_IMPORTON_SHARE * left / (RV_MARGIN * per_importon * pixels));
    const uint32_t want = s->importon_paths;
    s->importon_paths = (uint32_t)fmax(1.0, fmin((double)want, fit));
    vbnl_budget_choose(s->budget, "importon_paths", s->importon_paths,
                       "sized: %u per pixel%s; %.3g us per importon path measured", want,
                       s->importon_paths < want ? ", lowered to fit a third of the preparation bound" : "",
                       per_importon * 1e6);
    return VBNL_OK;
}

static vbnl_result size_lights(rv_state *s, vbnl_stage_ctx *stage, rv_maps *m, vbnl_error *err)
{
    rv_state *cal = malloc(sizeof(*cal));
    if (!cal)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    *cal = *s;
    memset(&cal->l, 0, sizeof(cal->l));
    cal->map = NULL;
    cal->fr = NULL;
    cal->inv_area = NULL;
    cal->prepared = 0;
    cal->budget = NULL;
    cal->virtual_lights = s->virtual_lights < RV_CAL_LIGHTS ? s->virtual_lights : RV_CAL_LIGHTS;
    const char *record_as = stage ? stage->record_as : NULL;
    if (stage)
        stage->record_as = "calibrate";
    double t0 = vbi_now();
    vbnl_result r = rv_build(cal, stage, m, err);
    const double per_light = fmax(vbi_now() - t0, 1e-9) / cal->virtual_lights;
    if (stage)
        stage->record_as = record_as;
    rv_destroy(cal);
    if (r != VBNL_OK)
        return r;
    const double limit = vbnl_budget_prepare_limit(s->budget), elapsed = vbnl_budget_elapsed(s->budget);
    if (s->lights_set) {
        int refused = 0;
        refuse_if(s, elapsed + s->virtual_lights * per_light, "virtual_lights", per_light, "light", &refused, err);
        return refused ? VBNL_ERR_INVALID_ARGUMENT : VBNL_OK;
    }
    const double left = fmax(0.0, RV_AIM * limit - elapsed);
    const uint32_t want = s->virtual_lights;
    s->virtual_lights = (uint32_t)fmax(16.0, fmin((double)want, floor(left / (RV_MARGIN * per_light))));
    if (s->virtual_lights < want)
        vbnl_budget_choose(s->budget, "virtual_lights", s->virtual_lights,
                           "sized: %u from the rendering rate, lowered to fit the preparation bound; %.3g us per "
                           "light measured",
                           want, per_light * 1e6);
    vbnl_budget_choose(s->budget, "prepare_estimate", elapsed + s->virtual_lights * per_light,
                       "seconds of preparation estimated (calibrations and importons, %.3f s, included) against "
                       "the bound of %.2f s (%g%% of %g s)",
                       elapsed, limit, 100.0 * VBNL_BUDGET_PREPARE_SHARE, vbnl_budget_seconds(s->budget));
    return VBNL_OK;
}

static vbnl_result rv_prepare(void *state, vbnl_stage_ctx *stage, vbnl_error *err)
{
    rv_state *s = state;
    const int budget = vbnl_budget_seconds(s->budget) > 0.0;
    vbnl_result r = budget ? size_importons(s, stage, err) : VBNL_OK;
    rv_maps m;
    memset(&m, 0, sizeof(m));
    if (r == VBNL_OK)
        r = rv_importons(s, stage, &m, err);
    if (r == VBNL_OK && budget)
        r = size_lights(s, stage, &m, err);
    if (r == VBNL_OK)
        r = rv_build(s, stage, &m, err);
    rv_maps_free(&m);
    return r;
}

/* ---- rendering ------------------------------------------------------------------------------ */

/* Intensity of light i toward the world direction w (leaving the light). */
static inline vec3 intensity(const rv_state *s, uint32_t i, vec3 w)
{
    vec3 wl = frame_to_local(&s->fr[i], w);
    if (wl.z <= 0.0f)
        return v3s(0.0f);
    if (s->l.lambert[i])
        return s->l.intensity[i];
    return vbi_hemioct_lookup(s->map, s->l.table + (size_t)i * 3 * vbi_hemioct_texel_count(s->map), wl);
}

/* f_x cos_x I(-w) cos_i along w (from x toward light i), times the clamp factor; *pdf_x the
 * BSDF's pdf of w. 0 outside the cone (axis, cos_max) or behind either surface. */
static vec3 integrand(const rv_state *s, uint32_t i, const vbi_bsdf *bsdf, const vbi_shading_frame *sf, vec3 w,
                      vec3 axis, float cos_max, float g_scale, float *pdf_x)
{
    *pdf_x = 0.0f;
    if (v3_dot(w, axis) < cos_max || v3_dot(w, sf->ng) <= 0.0f)
        return v3s(0.0f);
    float cos_i = -v3_dot(w, s->l.n[i]);
    if (cos_i <= 0.0f)
        return v3s(0.0f);
    vec3 wx = frame_to_local(&sf->fr, w);
    *pdf_x = vbi_bsdf_pdf(bsdf, sf->wo, wx);
    vec3 fx = vbi_bsdf_eval(bsdf, sf->wo, wx); /* includes cos_x */
    if (v3_is_black(fx))
        return v3s(0.0f);
    float c = cos_i;
    if (s->clamp > 0.0f) {
        float G = fabsf(wx.z) * cos_i * g_scale; /* g_scale: 1/d^2 or cone solid angle / (pi r^2) */
        if (G > s->clamp)
            c *= s->clamp / G;
    }
    return v3_scale(v3_mul(fx, intensity(s, i, v3_neg(w))), c);
}

static inline float sq(float x) { return x * x; }

/* Light reflected at x toward the viewer from every Rich-VSL. */
static vec3 gather(const rv_state *s, const vbi_bsdf *bsdf, vec3 x, const vbi_shading_frame *sf, vbi_sampler *sp,
                   vbi_thread_stats *stats)
{
    const vbnl_scene *sc = s->scene;
    vec3 sum = v3s(0.0f);
    const vec3 org_base = x;
    for (uint32_t i = 0; i < s->l.count; ++i) {
        /* fixed use of the stream per light, whether or not it contributes */
        vec2 uc = vbi_sampler_next2(sp);
        vec2 ub = vbi_sampler_next2(sp);
        vec3 to = v3_sub(s->l.p[i], x);
        float d2 = v3_len2(to);
        if (!(d2 > 0.0f))
            continue;
        float dist = sqrtf(d2);
        vec3 axis = v3_scale(to, 1.0f / dist);
        /* x in front of the light's plane and the centre in front of x's: the conditions of the
         * point term at the centre, as in `vsl`. Without them a point inside a sphere but behind
         * the light's surface receives light through directions that never meet the light's disk
         * (the cone is every direction there), and the visibility ray to the centre, offset to
         * the back of both surfaces, runs inside a thin wall: light leaks through walls and
         * around edges. */
        if (v3_dot(axis, s->l.ng[i]) >= 0.0f || v3_dot(axis, sf->ng) <= 0.0f)
            continue;
        float r = s->l.radius[i];
        vec3 L;
        float pdf;
        if (!(r > 0.0f)) {
            /* point form: f_x I cos_x cos_i / d^2, G clamped */
            L = v3_scale(integrand(s, i, bsdf, sf, axis, axis, -1.0f, 1.0f / d2, &pdf), 1.0f / d2);
        } else {
            float cos_max = d2 <= r * r ? -1.0f : sqrtf(1.0f - r * r / d2);
            float omega = 2.0f * VBI_PI * (1.0f - cos_max);
            float pc = 1.0f / omega;
            float g_scale = omega * s->inv_area[i];
            vec3 est = v3s(0.0f);
            /* 1: uniform direction in the cone */
            frame cf = frame_from_normal(axis);
            vec3 w = frame_to_world(&cf, sample_uniform_cone(uc, cos_max));
            vec3 h = integrand(s, i, bsdf, sf, w, axis, cos_max, g_scale, &pdf);
            if (!v3_is_black(h))
                est = v3_add(est, v3_scale(h, pc / (sq(pc) + sq(pdf))));
            /* 2: the BSDF at x */
            vbi_bsdf_sample_rec bs;
            if (vbi_bsdf_sample(bsdf, sf->wo, ub, &bs) && bs.pdf > 0.0f && !(bs.lobe & VBI_LOBE_SPECULAR)) {
                w = frame_to_world(&sf->fr, bs.wi);
                h = integrand(s, i, bsdf, sf, w, axis, cos_max, g_scale, &pdf);
                if (!v3_is_black(h) && pdf > 0.0f)
                    est = v3_add(est, v3_scale(h, pdf / (sq(pc) + sq(pdf))));
            }
            L = v3_scale(est, s->inv_area[i]);
        }
        if (v3_is_black(L) || !v3_is_finite(L))
            continue;
        /* visibility to the centre, both ends offset off their surfaces */
        vec3 o = vbi_offset_ray_origin(org_base, sf->ng, axis);
        vec3 t = vbi_offset_ray_origin(s->l.p[i], s->l.ng[i], v3_neg(axis));
        vec3 dv = v3_sub(t, o);
        float len = v3_len(dv);
        if (!(len > 0.0f))
            continue;
        stats->rays++;
        if (!vbi_scene_occluded(sc, o, v3_scale(dv, 1.0f / len), len))
            sum = v3_add(sum, L);
    }
    return sum;
}

/* The virtual lights' share at a camera path's first non-delta vertex (nothing before preparing). */
static vec3 gather_cb(const void *state, const vbi_bsdf *bsdf, vec3 x, const vbi_shading_frame *sf,
                      vbi_sampler *sp, vbi_thread_stats *stats)
{
    const rv_state *s = state;
    return s->prepared ? gather(s, bsdf, x, sf, sp, stats) : v3s(0.0f);
}

/* The camera path, direct light and film layers exactly as `vpl` and `vsl` (the same estimator for
 * every many-light method). */
static void trace(void *state, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first, float *out,
                  vbi_thread_stats *stats)
{
    const rv_state *s = state;
    vbi_vpl_trace(s->scene, s->indirect_only, s->cam_forward, gather_cb, s, sp, o, d, hit_ok, first, out, stats);
}

static void rv_render_tile(void *state, vbnl_tile_job *job)
{
    const rv_state *s = state;
    vbi_render_camera_paths(job, s->stride, trace, state);
}

const vbnl_integrator_class vbi_integrator_richvsl = {
    VBNL_INTEGRATOR_ABI_MAJOR,
    VBNL_INTEGRATOR_ABI_MINOR,
    sizeof(vbnl_integrator_class),
    "richvsl",
    "Rich-VSL: importance-placed, relaxed virtual lights with tabulated multi-photon emission, shaded as spheres",
    rv_params,
    N_PARAMS,
    rv_create,
    rv_prepare,
    rv_render_tile,
    rv_destroy,
};
