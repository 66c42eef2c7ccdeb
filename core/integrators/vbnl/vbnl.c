/* `vbnl`: Virtual Blue Noise Lighting (Li, Wang, Lin, Yuksel 2022).
 *
 * prepare: placement (§3.1) -> adaptive sample elimination (§3.2) -> photon splitting (§3.3)
 *          -> emission profiles and the power table (§3.3, §5);
 * render:  at every diffuse or glossy vertex x of a camera path, direct light from the real
 *          lights by next-event estimation with MIS (as `path`), and the light reflected by the
 *          surfaces x sees from the virtual lights, treated as photon lights (Eq. 3): power-based
 *          sampling with uniform cone directions (Eq. 4) and BSDF sampling that gathers every
 *          light containing the hit, combined by the power heuristic (Eq. 5); the BSDF sample
 *          also continues the camera path with weight 1 - w_v (adaptive camera-path extension,
 *          Eqs. 6-9), so nearby light is path traced and distant light comes from the virtual
 *          lights.
 *
 * Radiance of a virtual light (Eq. 3): a point y within r_j of y_j leaving toward w emits
 * L_j(y, w) = J_j(w) / (pi r_j^2), J the profile of profiles.h (reflected power per steradian,
 * without the outgoing cosine). Dividing by the disk area makes the sum over the ~3.6 lights that
 * cover a point of a hexagonal set with alpha_r = 2 reproduce the reflected radiance of a
 * uniformly lit surface (README: "VBNL radiance normalisation").
 *
 * Saved sets (vl_file.h): save_lights writes the set and its photon data after stage 3;
 * load_lights replaces stages 1-3 by reading one file, or several of disjoint photon ranges
 * (photon_first / photon_count of the same photon_paths) whose fixed-point data are summed, which
 * equals one run bit for bit. The file's preparation parameters then replace the given ones; its
 * image size, camera and seed, and the counts the user set, must be this render's (unless
 * reuse_lights). placement_only stops after stage 2 and saves a placement, a set without photons;
 * loading a placement traces this process's photon range on it (stage 3), so that a farm
 * prepares once and splits only the photons (docs/farm.md).
 * view=lights renders the set itself instead of the image (paper Figs. 7 and 13). */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "context.h"
#include "placement.h"
#include "prepare.h"
#include "profiles.h"
#include "render_internal.h"
#include "shading.h"
#include "sizing.h"
#include "splitting.h"
#include "vl_file.h"
#include "vl_index.h"
#include "vl_shade.h"
#include "vl_support.h"

static const char *const elim_modes[] = {"adaptive", "uniform", "none", NULL};
static const char *const sampling_modes[] = {"mis", "power", "bsdf", NULL};
static const char *const view_modes[] = {"shaded", "lights", NULL};

static const vbnl_param_spec vbi_params_spec[] = {
    {"virtual_lights", VBNL_PARAM_INT, 20000, NULL, 1, 5e7, NULL,
     "N, the number of virtual lights (paper, on a GPU: 130K-140K); under --time sized to the budget "
     "unless set"},
    {"candidates", VBNL_PARAM_FLOAT, 0.1, NULL, 1e-6, 5e8, NULL,
     "M, camera sub-paths placing candidates; a value <= 1 is the ratio N/M (paper: 0.1)"},
    {"tile_size", VBNL_PARAM_INT, 4, NULL, 1, 256, NULL, "screen tile side (pixels) stratifying placement"},
    {"specular_roughness", VBNL_PARAM_FLOAT, 0.15, NULL, 0, 1, NULL,
     "GGX alpha below which a glossy lobe counts as near-specular (camera paths continue)"},
    {"elimination", VBNL_PARAM_ENUM, 0, "adaptive", 0, 0, elim_modes,
     "sample elimination: adaptive (Eq. 2), uniform (Eq. 1) or none (random subset)"},
    {"parallel_elimination", VBNL_PARAM_BOOL, 1, NULL, 0, 1, NULL, "k-d tree parallel elimination (§3.2)"},
    {"neighbours", VBNL_PARAM_INT, 32, NULL, 1, 1024, NULL, "m of Eq. 2 (local density from the m-th neighbour)"},
    {"early_stop", VBNL_PARAM_FLOAT, 0.8, NULL, 0.01, 1, NULL,
     "fraction of each box's excess eliminated before joining boxes (§3.2)"},
    {"radius_scale", VBNL_PARAM_FLOAT, 2, NULL, 0.1, 16, NULL, "alpha: r_i = alpha r_i,max (§3.2)"},
    {"photon_paths", VBNL_PARAM_FLOAT, 1e6, NULL, 1, 1e11, NULL,
     "photon paths traced for splitting (paper, on a GPU: 20M); under --time sized to the budget unless set"},
    {"profile_resolution", VBNL_PARAM_INT, 16, NULL, 8, 32, NULL,
     "hemi-octahedral emission map side for glossy lights: 8, 16 or 32"},
    {"lazy_profiles", VBNL_PARAM_BOOL, 1, NULL, 0, 1, NULL,
     "convert a light's emission map when rendering first reads it instead of every map before rendering"},
    {"sampling", VBNL_PARAM_ENUM, 0, "mis", 0, 0, sampling_modes,
     "virtual-light sampling: mis (power + BSDF, Eq. 5), power or bsdf only"},
    {"path_extension", VBNL_PARAM_BOOL, 1, NULL, 0, 1, NULL, "adaptive camera-path extension (§4.2)"},
    {"n_min", VBNL_PARAM_FLOAT, 40, NULL, 0, 1e9, NULL, "Eq. 9: below this many lights per footprint, path trace"},
    {"n_max", VBNL_PARAM_FLOAT, 80, NULL, 0, 1e9, NULL, "Eq. 9: above this many lights per footprint, use lights only"},
    {"disk_test", VBNL_PARAM_BOOL, 1, NULL, 0, 1, NULL,
     "skip power samples whose ray misses the light's disk without tracing (§5)"},
    {"support_test", VBNL_PARAM_BOOL, 1, NULL, 0, 1, NULL,
     "a light takes photons from, and lights, only the points of its sphere that share its air up to its "
     "radius (vl_support.h); off: every point of the sphere, as Eq. 3. A loaded light set keeps its own"},
    {"max_depth", VBNL_PARAM_INT, -1, NULL, -1, 1e6, NULL, "longest camera path in bounces; -1 = unlimited"},
    {"rr_depth", VBNL_PARAM_INT, 3, NULL, 0, 1e6, NULL, "bounces before Russian roulette starts"},
    {"save_lights", VBNL_PARAM_STRING, 0, "", 0, 0, NULL,
     "write the prepared virtual-light set (lights and photon data) to this file (vl_file.h)"},
    {"load_lights", VBNL_PARAM_STRING, 0, "", 0, 0, NULL,
     "skip placement, elimination and splitting: read the set from this file, or sum the photons of "
     "several files of disjoint photon ranges separated by ':'; a placement (placement_only) loads alone "
     "and has its photon range traced"},
    {"reuse_lights", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "load_lights: accept a set prepared for another image size, camera or seed, or with other counts "
     "than the ones set (refused otherwise: the image would not be this render's)"},
    {"placement_only", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "stop after placement and elimination: trace no photon and save the set to save_lights as a "
     "placement, on which processes trace photon ranges (load_lights with photon_first/photon_count)"},
    {"photon_first", VBNL_PARAM_INT, 0, NULL, 0, 1e15, NULL,
     "first photon path this process traces (of photon_paths), to split photons across processes"},
    {"photon_count", VBNL_PARAM_INT, 0, NULL, 0, 1e15, NULL,
     "photon paths this process traces from photon_first; 0 = all the rest"},
    {"view", VBNL_PARAM_ENUM, 0, "shaded", 0, 0, view_modes,
     "shaded (the image) or lights: grey surfaces with every virtual light as a dot coloured by its "
     "radius (viridis over log radius; paper Figs. 7, 13)"},
    {"indirect_only", VBNL_PARAM_BOOL, 0, NULL, 0, 1, NULL,
     "leave out emission and single scattering (the 'direct' part of `path`), to compare indirect light"},
    {"dot_scale", VBNL_PARAM_FLOAT, 0.2, NULL, 0.01, 1, NULL,
     "view=lights: dot radius as a fraction of the light's radius r_j"},
};
#define N_PARAMS (sizeof(vbi_params_spec) / sizeof(vbi_params_spec[0]))

enum { SAMPLE_MIS = 0, SAMPLE_POWER = 1, SAMPLE_BSDF = 2 };
enum { VIEW_SHADED = 0, VIEW_LIGHTS = 1 };

/* Filter of §3.3 (authors' code), used for splitting and for gathering alike. */
#define VL_NORMAL_COS 0.7f
#define VL_GATHER_MAX 64u
#define VL_CAND_MAX 128u /* candidates of one gather before it falls back to the index's query */

typedef struct vbi_state {
    const vbnl_scene *scene;
    vbnl_context *ctx;
    vbi_prepare_params pp;
    uint64_t photon_paths;
    uint64_t photon_first, photon_count; /* the range this process traces (count 0: the rest) */
    char *save_path, *load_path;         /* NULL when not given */
    int placement_only, reuse_lights;
    double placement_seconds, elimination_seconds; /* of stages 1-2, for the saved file */
    int view;
    float dot_scale;
    float log_rmin, log_rmax;            /* view=lights: the colour ramp's range */
    uint32_t profile_res;
    int lazy, sampling, extension, disk_test, support_test, max_depth, rr_depth, indirect_only;
    float n_min, n_max;
    uint32_t off_vl, off_wv, off_depth, stride;
    vec3 cam_forward;
    /* the prepared set */
    vbi_vl_set vls;
    vbi_vl_index *index;
    vbi_hemioct *map;
    vbi_profile_set *profiles;
    vbi_profile_kernel **kernels;   /* per scene material (NULL where no light sits) */
    vbi_vl_shade shade;             /* what rendering reads per light, by rank (vl_shade.h) */
    vbi_vl_support *support;        /* by rank: the support test's data (vl_support.h), or NULL */
    int prepared;
    /* time budget (sizing.h) */
    vbnl_budget *budget;             /* NULL for the calibration's own state */
    int lights_set, paths_set;       /* virtual_lights / photon_paths set by the user */
    /* what the calibration measures (size_to_budget): seconds of the work that grows with the
     * light count, and of photon splitting, whose first cal_split paths are timed apart */
    double t_lights, t_photons, t_photons_first;
    double t_kernels;                /* of the fixed seconds: the conversion kernels */
    uint64_t cal_split;
} vbi_state;

static double param(const vbnl_integrator_env *env, const char *name)
{
    return vbnl_params_number(env->params, vbi_params_spec, N_PARAMS, name);
}

static vbnl_result vbi_create(const vbnl_integrator_env *env, void **out, vbnl_error *err)
{
    vbi_state *s = calloc(1, sizeof(*s));
    if (!s)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    s->scene = env->scene;
    s->ctx = env->ctx;
    vbi_prepare_params *pp = &s->pp;
    pp->virtual_lights = (uint32_t)param(env, "virtual_lights");
    s->budget = env->budget;
    s->lights_set = vbnl_params_has(env->params, "virtual_lights");
    s->paths_set = vbnl_params_has(env->params, "photon_paths");
    const int sized = vbnl_budget_seconds(env->budget) > 0.0 && !vbnl_params_has(env->params, "load_lights");
    /* under a budget the count is chosen in prepare (sizing.h), at most the rule's wish: that
     * bound is what the checks below see */
    if (sized && !s->lights_set)
        pp->virtual_lights = (uint32_t)vbi_sizing_lights_wanted(vbnl_budget_seconds(env->budget),
                                                                 vbnl_budget_pixels(env->budget));
    double cand = param(env, "candidates");
    double m = cand <= 1.0 ? pp->virtual_lights / cand : cand;
    pp->tile_size = (uint32_t)param(env, "tile_size");
    pp->specular_roughness = (float)param(env, "specular_roughness");
    pp->max_specular_chain = 4;
    const char *em = vbnl_params_string(env->params, vbi_params_spec, N_PARAMS, "elimination");
    pp->elimination = !strcmp(em, "uniform") ? VBI_ELIM_UNIFORM : !strcmp(em, "none") ? VBI_ELIM_NONE
                                                                                       : VBI_ELIM_ADAPTIVE;
    pp->parallel_elimination = param(env, "parallel_elimination") != 0.0;
    pp->neighbours = (uint32_t)param(env, "neighbours");
    pp->early_stop = (float)param(env, "early_stop");
    pp->radius_scale = (float)param(env, "radius_scale");
    pp->width = env->settings->width;
    pp->height = env->settings->height;
    pp->seed = env->settings->seed;
    s->photon_paths = (uint64_t)param(env, "photon_paths");
    s->profile_res = (uint32_t)param(env, "profile_resolution");
    s->lazy = param(env, "lazy_profiles") != 0.0;
    const char *sm = vbnl_params_string(env->params, vbi_params_spec, N_PARAMS, "sampling");
    s->sampling = !strcmp(sm, "power") ? SAMPLE_POWER : !strcmp(sm, "bsdf") ? SAMPLE_BSDF : SAMPLE_MIS;
    s->extension = param(env, "path_extension") != 0.0;
    s->n_min = (float)param(env, "n_min");
    s->n_max = (float)param(env, "n_max");
    s->disk_test = param(env, "disk_test") != 0.0;
    s->support_test = param(env, "support_test") != 0.0;
    s->max_depth = (int)param(env, "max_depth");
    s->rr_depth = (int)param(env, "rr_depth");
    s->indirect_only = param(env, "indirect_only") != 0.0;
    s->photon_first = (uint64_t)param(env, "photon_first");
    s->photon_count = (uint64_t)param(env, "photon_count");
    s->placement_only = param(env, "placement_only") != 0.0;
    s->reuse_lights = param(env, "reuse_lights") != 0.0;
    s->view = !strcmp(vbnl_params_string(env->params, vbi_params_spec, N_PARAMS, "view"), "lights") ? VIEW_LIGHTS
                                                                                                     : VIEW_SHADED;
    s->dot_scale = (float)param(env, "dot_scale");
    const char *save = vbnl_params_string(env->params, vbi_params_spec, N_PARAMS, "save_lights");
    const char *load = vbnl_params_string(env->params, vbi_params_spec, N_PARAMS, "load_lights");
    /* copies: the parameter list need not outlive the integrator */
    s->save_path = save && *save ? strdup(save) : NULL;
    s->load_path = load && *load ? strdup(load) : NULL;

    /* Impossible requests are refused here, before any work. */
    vbnl_result r = VBNL_OK;
    if (m > 4.0e9 || m < pp->virtual_lights)
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'vbnl': candidates (M = %.0f) must be at least virtual_lights "
                           "(N = %u) and below 4e9",
                           m, pp->virtual_lights);
    else if (s->profile_res != 8 && s->profile_res != 16 && s->profile_res != 32)
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'vbnl': profile_resolution must be 8, 16 or 32, got %u", s->profile_res);
    else if (!(s->n_max > s->n_min))
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'vbnl': n_max (%g) must be greater than n_min (%g)", s->n_max, s->n_min);
    else if ((save && *save && !s->save_path) || (load && *load && !s->load_path))
        r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    else if (!s->load_path && (s->photon_first >= s->photon_paths ||
                               s->photon_count > s->photon_paths - s->photon_first))
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'vbnl': the photon range [photon_first = %llu, + photon_count = %llu) must "
                           "lie inside the %llu photon_paths",
                           (unsigned long long)s->photon_first, (unsigned long long)s->photon_count,
                           (unsigned long long)s->photon_paths);
    else if (sized && !s->paths_set && (s->photon_first || s->photon_count))
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'vbnl': photon_first/photon_count split a photon_paths that is the same in "
                           "every process: set photon_paths explicitly under a time budget");
    else if (s->placement_only && (!s->save_path || s->load_path || s->photon_first || s->photon_count || sized))
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'vbnl': placement_only saves a placement for other processes: it needs "
                           "save_lights and takes no load_lights, photon range or time budget (%s)",
                           !s->save_path ? "save_lights is not set"
                           : s->load_path ? "load_lights is set"
                           : sized        ? "a time budget is set"
                                          : "a photon range is set");
    if (r == VBNL_OK && s->load_path) {
        pp->candidates = (uint32_t)m; /* unused: the file holds the set */
    } else if (r == VBNL_OK) {
        pp->candidates = (uint32_t)m;
        /* Peak memory: candidates and the elimination's working set (~96 B each), the lights
         * with a glossy incident map each in the worst case (R^2 x 28 B) and the index, and
         * photon splitting's private 32-bit maps (vbi_split_map_copy_bytes of maps of
         * R^2 x 24 B per light) and hit batches (vbi_split_batch_bytes per thread). */
        double res2 = (double)s->profile_res * s->profile_res;
        double bytes = (double)pp->candidates * 96.0 + (double)pp->virtual_lights * (64.0 + res2 * 28.0 + 64.0);
        bytes += (double)vbi_split_map_copy_bytes((uint64_t)pp->virtual_lights * (uint64_t)res2 * 24u,
                                                   env->ctx->threads);
        bytes += (double)env->ctx->threads * (double)vbi_split_batch_bytes(vbi_split_batch_hits(env->ctx->threads));
        double phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
        if (phys > 0.0 && bytes > 0.8 * phys)
            r = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY,
                               "integrator 'vbnl': this request needs about %.1f GB (M = %u candidates, "
                               "N = %u lights with %ux%u profiles) but the machine has %.1f GB",
                               bytes / 1e9, pp->candidates, pp->virtual_lights, s->profile_res,
                               s->profile_res, phys / 1e9);
    }
    if (r == VBNL_OK) {
        static const char *const rgb[] = {"R", "G", "B"};
        static const char *const one[] = {"Y"};
        if ((r = vbnl_film_add_layer(env->film, "vl", 3, rgb, &s->off_vl, err)) == VBNL_OK &&
            (r = vbnl_film_add_layer(env->film, "wv", 1, one, &s->off_wv, err)) == VBNL_OK)
            r = vbnl_film_add_layer(env->film, "path_depth", 1, one, &s->off_depth, err);
    }
    if (r != VBNL_OK) {
        free(s->save_path);
        free(s->load_path);
        free(s);
        return r;
    }
    s->stride = env->film->stride;
    s->cam_forward = v3_norm(v3_load(env->scene->camera.forward));
    *out = s;
    return VBNL_OK;
}

static void vbi_destroy(void *state)
{
    vbi_state *s = state;
    if (!s)
        return;
    if (s->kernels) {
        for (uint32_t i = 0; i < s->scene->material_count; ++i)
            vbi_profile_kernel_destroy(s->kernels[i]);
        free(s->kernels);
    }
    vbi_profile_set_destroy(s->profiles);
    vbi_hemioct_destroy(s->map);
    vbi_vl_index_destroy(s->index);
    vbi_vl_shade_free(&s->shade);
    vbi_vl_set_free(&s->vls);
    free(s->support);
    free(s->save_path);
    free(s->load_path);
    free(s);
}

typedef struct convert_job {
    vbi_state *s;
    float *power;
} convert_job;

#define CONVERT_CHUNK 1024u

/* Stage 4 per chunk of lights: power for the selection table, and the eager conversion. */
static void convert_chunk(void *user, uint64_t item, unsigned thread)
{
    (void)thread;
    convert_job *job = user;
    vbi_state *s = job->s;
    uint32_t begin = (uint32_t)item * CONVERT_CHUNK;
    uint32_t end = begin + CONVERT_CHUNK < s->vls.count ? begin + CONVERT_CHUNK : s->vls.count;
    for (uint32_t j = begin; j < end; ++j) {
        const vbi_profile_kernel *k = s->kernels[s->vls.material[j]];
        job->power[j] = v3_max_comp(v3_mul(vbi_profile_power(s->profiles, j, k), s->vls.tint[j]));
        if (!s->lazy)
            vbi_profile_convert(s->profiles, j, k);
    }
}

/* The index over the set and one conversion kernel per material carrying lights; s->vls and
 * s->profiles exist. */
static vbnl_result setup_lights(vbi_state *s, vbnl_error *err)
{
    const vbnl_scene *sc = s->scene;
    uint32_t n = s->vls.count;
    vbi_vl_index_desc id;
    memset(&id, 0, sizeof(id));
    id.centers = s->vls.position;
    id.radii = s->vls.radius;
    id.normals = s->vls.normal;
    id.count = n;
    id.kind = VBI_VL_INDEX_GRID;
    double t0 = vbi_now();
    vbnl_result r = vbi_vl_index_create(&id, &s->index);
    s->t_lights += vbi_now() - t0;
    if (r != VBNL_OK)
        return vbnl_error_set(err, r, "cannot build the virtual-light index (%s)", vbnl_result_name(r));
    if (!s->kernels) /* else the calibration's, kept (size_to_budget) */
        s->kernels = calloc(sc->material_count, sizeof(*s->kernels));
    if (!s->kernels)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u virtual lights", n);
    s->log_rmin = INFINITY;
    s->log_rmax = -INFINITY;
    for (uint32_t j = 0; j < n; ++j) {
        s->log_rmin = fminf(s->log_rmin, logf(s->vls.radius[j]));
        s->log_rmax = fmaxf(s->log_rmax, logf(s->vls.radius[j]));
    }
    double t_k = vbi_now();
    for (uint32_t j = 0; j < n && r == VBNL_OK; ++j) {
        uint32_t m = s->vls.material[j];
        if (!s->kernels[m])
            r = vbi_profile_kernel_create(s->map, &sc->materials[m].bsdf, 1, &s->kernels[m]);
    }
    s->t_kernels += vbi_now() - t_k;
    if (r != VBNL_OK)
        return vbnl_error_set(err, r, "cannot build the profile conversion kernels");
    return VBNL_OK;
}

/* Which lights take the support test (vl_support.h), a stage of its own after the set exists. */
static vbnl_result build_support(vbi_state *s, vbnl_stage_ctx *stage, vbnl_error *err)
{
    if (!s->support_test || s->vls.count == 0)
        return VBNL_OK;
    uint32_t n = s->vls.count;
    if (!(s->support = malloc(sizeof(*s->support) * n)))
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u virtual lights", n);
    double t0 = vbi_now();
    if (stage)
        vbnl_stage_begin(stage, "support", n, "lights");
    vbi_vl_support_stats st;
    vbnl_result r = vbi_vl_support_build(s->scene, &s->vls, s->index, stage, NULL, s->support, &st);
    if (stage) {
        vbnl_stage_set_work(stage, (double)st.rays, "rays");
        vbnl_stage_end(stage);
    }
    s->t_lights += vbi_now() - t0;
    if (r != VBNL_OK)
        return vbnl_error_set(err, r, r == VBNL_ERR_CANCELLED ? "the support probes were cancelled"
                                                              : "out of memory for the support probes");
    return VBNL_OK;
}

static vbnl_result vbi_prepare(void *state, vbnl_stage_ctx *stage, vbnl_error *err);

/* The light count and photon paths for the time budget (sizing.h): a calibration (a whole
 * preparation of a small set, recorded as the stage "calibrate" and thrown away) measures the
 * seconds per light and per photon path on this scene, then the rule sizes what the user did
 * not set. Counts set by the user that cannot fit the preparation's bound are refused here,
 * before any of the sized work. */
static vbnl_result size_to_budget(vbi_state *s, vbnl_stage_ctx *stage, vbnl_error *err)
{
    vbi_state *cal = malloc(sizeof(*cal));
    if (!cal)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    *cal = *s;
    memset(&cal->vls, 0, sizeof(cal->vls));
    memset(&cal->shade, 0, sizeof(cal->shade));
    cal->index = NULL;
    cal->map = NULL;
    cal->profiles = NULL;
    cal->kernels = NULL;
    cal->support = NULL;
    cal->prepared = 0;
    cal->save_path = cal->load_path = NULL;
    cal->budget = NULL;
    const double ratio = (double)s->pp.candidates / (double)s->pp.virtual_lights; /* M / N */
    uint32_t n_cal = s->pp.virtual_lights < VBI_SIZING_CAL_LIGHTS ? s->pp.virtual_lights : VBI_SIZING_CAL_LIGHTS;
    cal->pp.virtual_lights = n_cal;
    cal->pp.candidates = (uint32_t)ceil(ratio * n_cal);
    cal->photon_paths = VBI_SIZING_CAL_PATHS_FIRST + VBI_SIZING_CAL_PATHS;
    cal->cal_split = VBI_SIZING_CAL_PATHS_FIRST;
    cal->photon_first = cal->photon_count = 0;
    cal->t_lights = cal->t_photons = cal->t_photons_first = cal->t_kernels = 0.0;
    const char *record_as = stage ? stage->record_as : NULL;
    if (stage)
        stage->record_as = "calibrate";
    double t0 = vbi_now();
    vbnl_result r = vbi_prepare(cal, stage, err);
    /* Fixed costs (the conversion kernels of each material, the maps, the splitting's set-up)
     * are paid again by the real preparation whatever its counts: apart from the costs per light
     * and per path. Splitting's: from its two runs of VBI_SIZING_CAL_PATHS_FIRST and
     * VBI_SIZING_CAL_PATHS paths. */
    const double total = vbi_now() - t0, t_a = cal->t_photons_first, t_b = cal->t_photons;
    const double na = VBI_SIZING_CAL_PATHS_FIRST, nb = VBI_SIZING_CAL_PATHS;
    double per_path = (t_b - t_a) / (nb - na);
    if (!(per_path > 0.0))
        per_path = t_b / nb;
    const double fixed_paths = fmax(0.0, t_b - per_path * nb);
    const double per_light = cal->t_lights / n_cal;
    /* the conversion kernels depend on the materials and the profile resolution only: the real
     * preparation keeps the calibration's (and the map they refer to) and builds only those of
     * materials the calibration's lights did not sit on, so their seconds are not paid again */
    const double fixed = fmax(0.0, total - cal->t_lights - t_a - t_b - cal->t_kernels) + fixed_paths;
    if (stage)
        stage->record_as = record_as;
    if (r == VBNL_OK) {
        s->map = cal->map;
        s->kernels = cal->kernels;
        cal->map = NULL;
        cal->kernels = NULL;
    }
    vbi_destroy(cal);
    if (r != VBNL_OK)
        return r;

    vbi_sizing_in in;
    memset(&in, 0, sizeof(in));
    in.budget = vbnl_budget_seconds(s->budget);
    in.prepare_limit = vbnl_budget_prepare_limit(s->budget);
    in.pixels = vbnl_budget_pixels(s->budget);
    in.elapsed = vbnl_budget_elapsed(s->budget);
    in.seconds_per_light = per_light;
    in.seconds_per_path = per_path;
    in.fixed_seconds = fixed;
    in.lights_set = s->lights_set;
    in.lights = s->pp.virtual_lights;
    in.paths_set = s->paths_set;
    in.paths = (double)s->photon_paths;
    vbi_sizing_out out;
    vbi_size_to_budget(&in, &out);
    if (!out.fits)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "integrator 'vbnl': with %s set explicitly (virtual_lights=%.0f, photon_paths=%.0f) "
                              "preparation needs about %.1f s (calibrated on this scene: %.3g us per light, %.3g us "
                              "per photon path, %.3g s fixed), more than its bound of %.2f s (%g%% of the %g s time budget); "
                              "lower them, raise --time, or leave them unset so that the budget sizes them",
                              s->lights_set && s->paths_set ? "virtual_lights and photon_paths"
                              : s->lights_set              ? "virtual_lights"
                                                           : "photon_paths",
                              out.lights, out.paths, out.estimate, in.seconds_per_light * 1e6,
                              in.seconds_per_path * 1e6, in.fixed_seconds, in.prepare_limit, 100.0 * VBNL_BUDGET_PREPARE_SHARE,
                              in.budget);
    s->pp.virtual_lights = (uint32_t)out.lights;
    if (!s->lights_set)
        s->pp.candidates = (uint32_t)ceil(ratio * out.lights);
    s->photon_paths = (uint64_t)out.paths;
    vbnl_budget_choose(s->budget, "virtual_lights", out.lights, "%s", out.lights_why);
    vbnl_budget_choose(s->budget, "photon_paths", out.paths, "%s", out.paths_why);
    vbnl_budget_choose(s->budget, "prepare_estimate", out.estimate,
                       "seconds of preparation estimated (calibration %.3f s and %.3f s fixed included) against the "
                       "bound of %.2f s (%g%% of %g s)",
                       in.elapsed, in.fixed_seconds, in.prepare_limit, 100.0 * VBNL_BUDGET_PREPARE_SHARE, in.budget);
    return VBNL_OK;
}

/* FNV-1a of every parameter that shaped a set prepared here and its photons (the file's
 * preparation fingerprint, vl_file.h): files to sum must agree on it. */
static uint64_t preparation_fingerprint(const vbi_state *s)
{
    const vbi_prepare_params *p = &s->pp;
    uint32_t bits[3];
    memcpy(&bits[0], &p->specular_roughness, 4);
    memcpy(&bits[1], &p->early_stop, 4);
    memcpy(&bits[2], &p->radius_scale, 4);
    const uint64_t v[] = {p->virtual_lights, p->candidates, p->tile_size, bits[0], p->max_specular_chain,
                          (uint64_t)p->elimination, (uint64_t)(p->parallel_elimination != 0), p->neighbours,
                          bits[1], bits[2], p->width, p->height, p->seed, s->photon_paths, s->profile_res,
                          (uint64_t)(s->support_test != 0)};
    return vbi_vl_file_hash(VBI_VL_FILE_HASH_INIT, v, sizeof(v));
}

/* The file header of a set prepared here from the scene (stages 1-2), before its photons. */
static void header_of_state(const vbi_state *s, vbi_vl_file_header *h)
{
    const vbnl_scene *sc = s->scene;
    memset(h, 0, sizeof(*h));
    h->fingerprint = vbi_scene_fingerprint(sc);
    h->virtual_lights = s->pp.virtual_lights;
    h->profile_resolution = s->profile_res;
    h->photon_paths = s->photon_paths;
    h->unit = vbi_profile_set_unit(s->profiles);
    h->seed = s->pp.seed;
    h->elimination = (uint32_t)s->pp.elimination;
    h->radius_scale = s->pp.radius_scale;
    h->material_count = sc->material_count;
    h->flags = s->support_test ? VBI_VL_FILE_SUPPORT_TEST : 0u;
    h->width = s->pp.width;
    h->height = s->pp.height;
    h->camera = vbi_vl_file_camera_fingerprint(sc);
    h->preparation = preparation_fingerprint(s);
    h->placement_seconds = s->placement_seconds;
    h->elimination_seconds = s->elimination_seconds;
}

/* Stage 3: photon splitting of paths [photon_first, photon_first + count) of the photon_paths
 * that normalise the flux, so that the files of disjoint ranges sum to one run (splitting.h);
 * then save_lights with header `h` (its range and photon figures filled here). The set, its
 * index and support data exist. */
static vbnl_result split_and_save(vbi_state *s, vbnl_stage_ctx *stage, vbi_vl_file_header *h, vbnl_error *err)
{
    uint64_t count = s->photon_count ? s->photon_count : s->photon_paths - s->photon_first;
    if (stage)
        vbnl_stage_begin(stage, "photons", (double)count, "paths");
    vbi_split_desc sd;
    vbi_split_desc_init(&sd);
    sd.scene = s->scene;
    sd.index = s->index;
    sd.vl_normals = s->vls.normal;
    sd.profiles = s->profiles;
    sd.photon_paths = s->photon_paths;
    sd.first_path = s->photon_first;
    sd.path_count = count;
    sd.seed = s->pp.seed;
    sd.normal_cos = VL_NORMAL_COS;
    sd.support = s->support;
    vbi_split_stats sst;
    double t_split = vbi_now();
    vbnl_result r = VBNL_OK;
    if (s->cal_split > 0 && s->cal_split < count) { /* the calibration: two runs, see size_to_budget */
        sd.path_count = s->cal_split;
        r = vbi_split_photons(&sd, NULL, stage, &sst);
        s->t_photons_first = vbi_now() - t_split;
        t_split = vbi_now();
        sd.first_path += s->cal_split;
        sd.path_count = count - s->cal_split;
    }
    if (r == VBNL_OK)
        r = vbi_split_photons(&sd, NULL, stage, &sst);
    s->t_photons = vbi_now() - t_split;
    if (stage) {
        vbnl_stage_set_work(stage, (double)sst.rays, "rays");
        vbnl_stage_end(stage);
    }
    if (r != VBNL_OK)
        return vbnl_error_set(err, r, r == VBNL_ERR_CANCELLED ? "photon splitting was cancelled"
                                                              : "photon splitting failed (%s)",
                              vbnl_result_name(r));
    h->photon_first = s->photon_first;
    h->photon_count = count;
    h->photon_seconds = s->t_photons;
    h->photon_rays = (double)sst.rays;
    return s->save_path ? vbi_vl_file_save(s->save_path, h, &s->vls, s->profiles, err) : VBNL_OK;
}

/* Stages 1-3: placement, elimination, photon splitting of this process's photon range; with
 * placement_only, stages 1-2 saved as a placement. */
static vbnl_result prepare_from_scene(vbi_state *s, vbnl_stage_ctx *stage, vbnl_error *err)
{
    const vbnl_scene *sc = s->scene;
    vbnl_result r = VBNL_OK;
    if (s->budget && vbnl_budget_seconds(s->budget) > 0.0 && (r = size_to_budget(s, stage, err)) != VBNL_OK)
        return r;
    double t_prep = vbi_now();
    vbi_prepare_stats ps;
    r = vbi_prepare_lights(sc, &s->pp, stage, NULL, &s->vls, &ps, err);
    s->t_lights += vbi_now() - t_prep;
    s->placement_seconds = ps.seconds[0];
    s->elimination_seconds = ps.seconds[1];
    if (r != VBNL_OK)
        return r;
    uint32_t n = s->vls.count;
    uint8_t *glossy = malloc(n);
    if (!glossy)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u virtual lights", n);
    for (uint32_t j = 0; j < n; ++j)
        glossy[j] = sc->materials[s->vls.material[j]].desc.type != VBNL_MATERIAL_LAMBERT;
    if ((r = s->map ? VBNL_OK : vbi_hemioct_create(s->profile_res, &s->map)) == VBNL_OK)
        r = vbi_profile_set_create_fixed(s->map, n, glossy, vbi_split_photon_unit(sc, s->photon_paths),
                                          &s->profiles);
    free(glossy);
    if (r != VBNL_OK)
        return vbnl_error_set(err, r, "cannot allocate the emission profiles of %u lights", n);
    vbi_vl_file_header h; /* only a saved set needs it (the scene's fingerprint reads all its geometry) */
    memset(&h, 0, sizeof(h));
    if (s->save_path)
        header_of_state(s, &h);
    if (s->placement_only) /* photon range [0, 0): other processes trace the photons */
        return vbi_vl_file_save(s->save_path, &h, &s->vls, s->profiles, err);
    if ((r = setup_lights(s, err)) != VBNL_OK || (r = build_support(s, stage, err)) != VBNL_OK)
        return r;
    return split_and_save(s, stage, &h, err);
}

/* A loaded set must have been prepared for this render: the same image size, camera and seed,
 * and the counts the user set (unless reuse_lights). The file's other preparation parameters
 * replace the given ones. */
static vbnl_result check_loaded(const vbi_state *s, const vbi_vl_file_header *h, vbnl_error *err)
{
    const char *fix = "prepare the lights for this render, or set reuse_lights=on to render them anyway";
    if (h->width != s->pp.width || h->height != s->pp.height)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "load_lights: '%s' was prepared for a %ux%u image, this render is %ux%u: %s",
                              s->load_path, h->width, h->height, s->pp.width, s->pp.height, fix);
    if (h->camera != vbi_vl_file_camera_fingerprint(s->scene))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "load_lights: '%s' was prepared for another camera (fingerprint %016llx, this "
                              "render's %016llx): %s",
                              s->load_path, (unsigned long long)h->camera,
                              (unsigned long long)vbi_vl_file_camera_fingerprint(s->scene), fix);
    if (h->seed != s->pp.seed)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "load_lights: '%s' was prepared with seed %llu, this render has seed %llu: %s",
                              s->load_path, (unsigned long long)h->seed, (unsigned long long)s->pp.seed, fix);
    if (s->lights_set && h->virtual_lights != s->pp.virtual_lights)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "load_lights: '%s' was prepared with virtual_lights=%u, this render sets %u: %s",
                              s->load_path, h->virtual_lights, s->pp.virtual_lights, fix);
    if (s->paths_set && h->photon_paths != s->photon_paths)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "load_lights: '%s' was prepared with photon_paths=%llu, this render sets %llu: %s",
                              s->load_path, (unsigned long long)h->photon_paths,
                              (unsigned long long)s->photon_paths, fix);
    return VBNL_OK;
}

/* Instead of stages 1-3: the set and its photon data from load_lights (vl_file.h). A placement
 * has the photon range [photon_first, + photon_count) traced on it (stage 3), and is saved with
 * it when save_lights is set. */
static vbnl_result prepare_from_file(vbi_state *s, vbnl_stage_ctx *stage, vbnl_error *err)
{
    if (s->budget && vbnl_budget_seconds(s->budget) > 0.0)
        vbnl_budget_choose(s->budget, "virtual_lights", 0, "load_lights: the counts of the file, not sized");
    if (stage)
        vbnl_stage_begin(stage, "load", 0, "files");
    vbi_vl_file_data d;
    vbnl_result r = vbi_vl_file_load(s->load_path, s->scene, &d, err);
    if (stage)
        vbnl_stage_end(stage);
    if (r != VBNL_OK)
        return r;
    const int placement = d.header.photon_count == 0;
    if (r == VBNL_OK && !s->reuse_lights)
        r = check_loaded(s, &d.header, err);
    if (r == VBNL_OK && !placement && (s->photon_first || s->photon_count))
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'vbnl': photon_first/photon_count trace photons on a placement "
                           "(placement_only), but '%s' holds photon paths [%llu, %llu) already",
                           s->load_path, (unsigned long long)d.header.photon_first,
                           (unsigned long long)(d.header.photon_first + d.header.photon_count));
    if (r == VBNL_OK && placement &&
        (s->photon_first >= d.header.photon_paths || s->photon_count > d.header.photon_paths - s->photon_first))
        r = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                           "integrator 'vbnl': the photon range [photon_first = %llu, + photon_count = %llu) must "
                           "lie inside the %llu photon_paths of the placement '%s'",
                           (unsigned long long)s->photon_first, (unsigned long long)s->photon_count,
                           (unsigned long long)d.header.photon_paths, s->load_path);
    if (r != VBNL_OK) {
        vbi_vl_file_data_free(&d);
        return r;
    }
    /* the file's preparation parameters replace the ones given */
    s->vls = d.vls;
    s->map = d.map;
    s->profiles = d.profiles;
    s->photon_paths = d.header.photon_paths;
    s->profile_res = d.header.profile_resolution;
    s->pp.virtual_lights = d.header.virtual_lights;
    s->pp.seed = d.header.seed;
    s->pp.elimination = (vbi_elim_mode)d.header.elimination;
    s->pp.radius_scale = d.header.radius_scale;
    s->support_test = (d.header.flags & VBI_VL_FILE_SUPPORT_TEST) != 0; /* as the photons were split */
    if ((r = setup_lights(s, err)) != VBNL_OK || (r = build_support(s, stage, err)) != VBNL_OK)
        return r;
    if (placement)
        return split_and_save(s, stage, &d.header, err);
    if (s->save_path) { /* e.g. several photon ranges summed into one file */
        d.header.fingerprint = vbi_scene_fingerprint(s->scene);
        r = vbi_vl_file_save(s->save_path, &d.header, &s->vls, s->profiles, err);
    }
    return r;
}

static vbnl_result vbi_prepare(void *state, vbnl_stage_ctx *stage, vbnl_error *err)
{
    vbi_state *s = state;
    /* a scene with media is path traced (trace): no virtual lights to prepare */
    if (s->scene->has_media)
        return VBNL_OK;
    vbnl_result r = s->load_path ? prepare_from_file(s, stage, err) : prepare_from_scene(s, stage, err);
    if (r != VBNL_OK || s->placement_only)
        return r; /* a placement is saved, not rendered: no light has any power yet */
    uint32_t n = s->vls.count;

    /* 4. profiles: power table (and the eager conversion) */
    double t4 = vbi_now();
    if (stage)
        vbnl_stage_begin(stage, "profiles", n, "lights");
    convert_job cj = {s, malloc(sizeof(float) * n)};
    if (!cj.power)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    int rc = vbi_run_items(stage, NULL, (n + CONVERT_CHUNK - 1) / CONVERT_CHUNK, convert_chunk, &cj);
    if (stage)
        vbnl_stage_end(stage);
    /* the render records with the power alias table; when no light received any photon, only
     * path extension remains (shade.n = 0) */
    r = rc == 0 ? vbi_vl_shade_build(&s->shade, &s->vls, s->index, s->profiles, s->kernels, cj.power,
                                            s->support) : VBNL_OK;
    free(cj.power);
    s->t_lights += vbi_now() - t4;
    if (rc != 0)
        return vbnl_error_set(err, VBNL_ERR_CANCELLED, "profile conversion was cancelled");
    if (r != VBNL_OK)
        return vbnl_error_set(err, r, "out of memory for the render records of %u virtual lights", n);
    /* the set, profiles, index and render records */
    vbnl_stage_set_storage(stage, vbi_vl_set_bytes(&s->vls) + vbi_profile_set_bytes(s->profiles) +
                                      vbi_vl_index_bytes(s->index) + vbi_vl_shade_bytes(&s->shade));
    s->prepared = 1;
    return VBNL_OK;
}

/* ---- rendering ------------------------------------------------------------------------------ */

/* Eq. 4: solid-angle pdf of power-based sampling reaching light j along a direction in its cone. */
static inline float vl_pdf(const vbi_state *s, uint32_t j, vec3 x)
{
    const vbi_vl_shade_rec *e = &s->shade.rec[j];
    return e->pmf * pdf_uniform_cone(vbi_vl_shade_cone_cos(e, x));
}

/* Which lobes of the BSDF at x gather virtual lights (the rest continue the camera path, §3.1):
 * all of them, only the diffuse one (a near-specular coat or microfacet lobe), or none. */
enum { GATHER_ALL = 0, GATHER_DIFFUSE = 1, GATHER_NONE = 2 };
static inline int gather_lobes(const vbi_state *s, const vbi_bsdf *b)
{
    if (vbi_bsdf_is_delta(b))
        return GATHER_NONE;
    if (!vbi_lobe_is_near_specular(b, VBI_LOBE_GLOSSY, s->pp.specular_roughness) ||
        !(vbi_bsdf_lobes(b) & VBI_LOBE_GLOSSY))
        return GATHER_ALL;
    return b->type == VBNL_MATERIAL_PLASTIC ? GATHER_DIFFUSE : GATHER_NONE;
}

/* The density with which x's BSDF sampling gathers at direction wi: the BSDF pdf p_b, or the
 * diffuse lobe's share of it when the other lobe continues the path. The virtual-light part of
 * x's estimate is then the integral of f L_vl w_v (p_g / p_b): power samples carry the factor
 * p_g / p_b and both strategies weigh each other with p_g (Eq. 5), so that the light a
 * near-specular lobe's continued path brings is not counted by power samples a second time. */
static inline float gather_pdf(int lobes, const vbi_bsdf *b, vec3 wo, vec3 wi, float p_b)
{
    return lobes == GATHER_ALL ? p_b : lobes == GATHER_DIFFUSE ? vbi_bsdf_pdf_diffuse(b, wo, wi) : 0.0f;
}

/* Eq. 9 with the footprint of Eq. 7. */
static inline float blend_weight(const vbi_state *s, vec3 x, const vbi_hit *y, vec3 w, float pdf_bsdf,
                                 float density)
{
    if (!s->extension)
        return 1.0f;
    float cos_y = fabsf(v3_dot(y->ng, w));
    if (!(pdf_bsdf > 0.0f) || cos_y <= 0.0f)
        return 1.0f; /* an infinite footprint: virtual lights suffice */
    float a = v3_len2(v3_sub(y->p, x)) / (pdf_bsdf * cos_y);
    return clampf((a * density - s->n_min) / (s->n_max - s->n_min), 0.0f, 1.0f);
}

/* The lights containing y that may shine toward x (the filter of splitting, so both see the
 * same set), in two steps: gather_candidates lists the index's candidates for y (its lookup begun
 * and fetched) and starts loading their render records; gather_filter tests containment and the
 * filter on these records (which the shading reads next anyway) and writes the ranks of the
 * lights that pass. More than VL_GATHER_MAX lights (rare): the VL_GATHER_MAX smallest ids, as the
 * index's own query keeps. */
static uint32_t gather_candidates(const vbi_state *s, const vbi_vl_lookup *lk, uint32_t *cand)
{
    uint32_t nc = vbi_vl_index_lookup_candidates(s->index, lk, VL_CAND_MAX, cand);
    if (nc <= VL_CAND_MAX)
        for (uint32_t k = 0; k < nc; ++k)
            __builtin_prefetch(&s->shade.rec[cand[k]]);
    return nc;
}

static uint32_t gather_filter(const vbi_state *s, const vbi_hit *y, vec3 w, const uint32_t *cand, uint32_t nc,
                              uint32_t *ranks)
{
    vbi_vl_filter f;
    f.n = v3_dot(y->ng, w) < 0.0f ? y->ng : v3_neg(y->ng); /* facing x */
    f.wi = v3_neg(w);
    f.normal_cos = VL_NORMAL_COS;
    f.facing = 1;
    uint32_t m = 0;
    float tmax = 0.0f; /* the largest support test height among them */
    int overflow = nc > VL_CAND_MAX;
    for (uint32_t k = 0; k < nc && !overflow; ++k) {
        const vbi_vl_shade_rec *e = &s->shade.rec[cand[k]];
        double d2;
        if (vbi_vl_contains(e->position, e->radius, y->p, &d2) && vbi_vl_filter_passes(&f, e->normal) &&
            (!s->support || vbi_material_surface(s->scene, e->material) == y->material)) {
            overflow = m == VL_GATHER_MAX;
            if (!overflow) {
                ranks[m++] = cand[k];
                tmax = e->support > tmax ? e->support : tmax;
            }
        }
    }
    if (overflow) {
        vbi_vl_found found[VL_GATHER_MAX];
        uint32_t n = vbi_vl_index_query_found(s->index, y->p, &f, VL_GATHER_MAX, found);
        n = n < VL_GATHER_MAX ? n : VL_GATHER_MAX;
        m = 0;
        tmax = 0.0f;
        for (uint32_t k = 0; k < n; ++k) {
            const vbi_vl_shade_rec *e = &s->shade.rec[found[k].rank];
            if (s->support && vbi_material_surface(s->scene, e->material) != y->material)
                continue;
            ranks[m++] = found[k].rank;
            tmax = e->support > tmax ? e->support : tmax;
        }
    }
    if (!(tmax > 0.0f))
        return m;
    /* the support test (vl_support.h) of the lights that need it, one open height for all */
    const float hy = vbi_vl_support_height(s->scene, y->p, f.n, tmax);
    uint32_t kept = 0;
    for (uint32_t k = 0; k < m; ++k) {
        const vbi_vl_shade_rec *e = &s->shade.rec[ranks[k]];
        if (e->support > 0.0f &&
            !vbi_vl_support_passes(s->scene, y->p, f.n, hy, e->position, e->normal, e->support))
            continue;
        ranks[kept++] = ranks[k];
    }
    return kept;
}

/* True when light e may shine at y toward x (the filter and support test of gather). */
static int accepts(const vbi_state *s, const vbi_vl_shade_rec *e, const vbi_hit *y, vec3 w)
{
    if (v3_len2(v3_sub(y->p, e->position)) >= e->radius * e->radius)
        return 0;
    vec3 n = v3_dot(y->ng, w) < 0.0f ? y->ng : v3_neg(y->ng);
    if (!(v3_dot(e->normal, n) > VL_NORMAL_COS && v3_dot(e->normal, w) < 0.0f) ||
        (s->support && vbi_material_surface(s->scene, e->material) != y->material))
        return 0;
    return !(e->support > 0.0f) ||
           vbi_vl_support_passes(s->scene, y->p, n, vbi_vl_support_height(s->scene, y->p, n, e->support),
                                  e->position, e->normal, e->support);
}

static inline void add_vl(float *out, const vbi_state *s, vec3 c)
{
    out[0] += c.x;
    out[1] += c.y;
    out[2] += c.z;
    out[s->off_vl] += c.x;
    out[s->off_vl + 1] += c.y;
    out[s->off_vl + 2] += c.z;
}

static inline void add_L(float *out, vec3 c)
{
    out[0] += c.x;
    out[1] += c.y;
    out[2] += c.z;
}

/* Virtual lights, strategy 1, at x: power-based selection (light `pick`), a uniform direction in
 * the cone of the light's sphere (Eq. 4); counts only if the ray's hit lies in the sphere (Eq. 3).
 * In two halves, so that the caller can start loads between the direction and the ray:
 * power_draw samples the direction and runs the cheap tests, power_trace traces the ray and adds
 * the contribution when the draw is usable. */
typedef struct power_sample {
    const vbi_vl_shade_rec *e;
    vec3 w, wl, f;
    float p_j;
    int usable, lobes;
} power_sample;

static void power_draw(const vbi_state *s, const vbi_bsdf *bsdf, const vbi_shading_frame *sf, vec3 x,
                       uint32_t pick, int lobes, vbi_sampler *sp, power_sample *ps)
{
    const vbi_vl_shade_rec *e = &s->shade.rec[pick];
    vec2 uc = vbi_sampler_next2(sp);
    vec3 to = v3_sub(e->position, x);
    ps->e = e;
    ps->usable = 0;
    ps->lobes = lobes;
    /* Picks that cannot contribute, rejected before the cone is sampled (17% and 11% of them on
     * the glossy Cornell box): with the disk pre-test, x behind the light's plane (any ray
     * meeting the disk then arrives at its back, which emits nothing); at an opaque surface, a
     * sphere wholly below x's tangent plane (every direction of the cone fails the side test). */
    if ((s->disk_test && v3_dot(to, e->normal) >= 0.0f) ||
        (!vbi_bsdf_is_transmissive(bsdf) && v3_dot(to, sf->ng) <= -e->radius))
        return;
    float dist = v3_len(to);
    float cos_max = vbi_vl_shade_cone_cos(e, x);
    frame cf = frame_from_normal(dist > 0.0f ? v3_scale(to, 1.0f / dist) : sf->fr.n);
    vec3 w = frame_to_world(&cf, sample_uniform_cone(uc, cos_max));
    float p_j = e->pmf * pdf_uniform_cone(cos_max);
    /* the cheap tests first: the BSDF is evaluated, and the ray traced, only for a direction
     * that leaves on the right side and, with the §5 disk pre-test, meets the light's disk (a
     * ray that misses it is taken as occluded, untraced) */
    int usable = p_j > 0.0f && (vbi_bsdf_is_transmissive(bsdf) || v3_dot(w, sf->ng) > 0.0f);
    if (usable && s->disk_test) {
        vec3 n = e->normal;
        float denom = v3_dot(w, n);
        usable = 0;
        if (fabsf(denom) > 1e-6f) {
            float t = v3_dot(v3_sub(e->position, x), n) / denom;
            if (t > 0.0f) {
                vec3 q = v3_fma(x, w, t);
                usable = v3_len2(v3_sub(q, e->position)) < e->radius * e->radius;
            }
        }
    }
    if (!usable)
        return;
    ps->wl = frame_to_local(&sf->fr, w);
    ps->f = vbi_bsdf_eval(bsdf, sf->wo, ps->wl);
    ps->w = w;
    ps->p_j = p_j;
    ps->usable = !v3_is_black(ps->f);
}

static void power_trace(const vbi_state *s, const vbi_bsdf *bsdf, const vbi_shading_frame *sf, vec3 x,
                        const power_sample *ps, vec3 beta, float *out, vbi_thread_stats *stats)
{
    if (!ps->usable)
        return;
    const vbi_vl_shade_rec *e = ps->e;
    const vec3 w = ps->w;
    /* Only a first hit inside the light's sphere counts, so the ray ends where it leaves the
     * sphere (with a margin for rounding; accepts() decides): the same answer as an unbounded
     * ray, for less traversal. */
    vec3 org = vbi_offset_ray_origin(x, sf->ng, w);
    vec3 oc = v3_sub(e->position, org);
    float b = v3_dot(oc, w), c = v3_len2(oc) - e->radius * e->radius;
    float disc = b * b - c;
    float t_exit = disc > 0.0f ? (b + sqrtf(disc)) * 1.001f + 1e-4f * e->radius : INFINITY;
    vbi_hit y;
    stats->rays++;
    if (vbi_scene_intersect_inline(s->scene, org, w, t_exit, &y) && accepts(s, e, &y, w)) {
        float p_b = vbi_bsdf_pdf(bsdf, sf->wo, ps->wl);
        float p_g = gather_pdf(ps->lobes, bsdf, sf->wo, ps->wl, p_b);
        float share = ps->lobes == GATHER_ALL ? 1.0f : p_b > 0.0f ? p_g / p_b : 0.0f;
        float mis = s->sampling == SAMPLE_MIS ? power_heuristic(ps->p_j, p_g) : 1.0f;
        float wv = blend_weight(s, x, &y, w, p_b, e->density);
        if (wv > 0.0f && share > 0.0f)
            add_vl(out, s,
                   v3_scale(v3_mul(v3_mul(beta, ps->f), vbi_vl_shade_radiance(e, s->profiles, s->kernels, w)),
                            mis * wv * share / ps->p_j));
    }
}

typedef struct vbi_media_add_ctx {
    float *out;
    int indirect_only;
} vbi_media_add_ctx;

static void vbi_media_add(void *user, vec3 c, int is_direct)
{
    const vbi_media_add_ctx *a = user;
    if (!(a->indirect_only && is_direct))
        add_L(a->out, c);
}

static void trace(void *state, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *first, float *out,
                  vbi_thread_stats *stats)
{
    vbi_state *s = state;
    const vbnl_scene *sc = s->scene;
    vbi_hit hit = *first;
    const int have_vls = s->prepared && s->shade.n > 0;
    vec3 beta = v3s(1.0f);
    uint32_t ranks[VL_GATHER_MAX];
    vbi_profile_lookup looks[VL_GATHER_MAX];
    uint8_t lit[VL_GATHER_MAX];
    int vertices = 0;
    out[3] = 1.0f;
    if (sc->has_media) {
        /* Media: path tracing with the walk between vertices (the virtual lights are placed for surfaces and do not light points in media;
         * docs/integrators.md, "Media"). */
        vbi_media_add_ctx a = {out, s->indirect_only};
        vbi_trace_path_walk(sc, sp, o, d, hit_ok, first, s->max_depth, s->rr_depth, vbi_media_add, &a, out, stats);
        return;
    }
    /* what the camera sees directly */
    /* indirect_only: emission seen directly or through delta bounces, and single scattering at
     * the first non-delta vertex, are left out (the split of path.c) */
    const int skip_direct = s->indirect_only;
    if (!hit_ok) {
        if (sc->env_light != VBI_NO_LIGHT && !skip_direct)
            add_L(out, vbi_light_Le(&sc->lights[sc->env_light], v3s(0.0f), v3_neg(d)));
        return;
    }
    {
        vbi_bsdf tmp;
        v3_store(out + VBNL_FILM_ALBEDO, vbi_bsdf_albedo(vbi_surface_bsdf(sc, &hit, &tmp)));
    }
    v3_store(out + VBNL_FILM_NORMAL, hit.ns);
    out[VBNL_FILM_DEPTH] = v3_dot(v3_sub(hit.p, o), s->cam_forward);
    if (hit.light != VBI_NO_LIGHT && !skip_direct)
        add_L(out, vbi_light_Le(&sc->lights[hit.light], hit.ng, v3_neg(d)));

    /* The power-based pick of each vertex is drawn ahead, so that its record (a cache miss:
     * lights are picked at random) loads while other work runs: at the camera's vertex during its
     * BSDF ray and next-event estimation, at later ones from before the ray to the vertex is
     * traced. The alias table is small and stays in cache, so the pick is resolved at once. A
     * vertex that turns out delta leaves its pick unused. */
    const int power_on = have_vls && s->sampling != SAMPLE_BSDF;
    vbi_vl_pick pick = {0, 0.0f};
    if (power_on)
        pick = vbi_vl_shade_pick_start(&s->shade, vbi_sampler_next(sp));
    int direct_phase = 1; /* no non-delta vertex yet */
    vbi_bsdf y_store; /* the BSDF at the next vertex, resolved when it was reached */
    const vbi_bsdf *y_bsdf = NULL;
    for (int depth = 0;; ++depth) {
        vertices++;
        if (s->max_depth >= 0 && depth >= s->max_depth)
            break;
        vbi_bsdf bsdf_store;
        const vbi_bsdf *bsdf = y_bsdf == &y_store ? (bsdf_store = y_store, &bsdf_store)
                                : y_bsdf           ? y_bsdf
                                                   : vbi_surface_bsdf(sc, &hit, &bsdf_store);
        vbi_shading_frame sf;
        vbi_shading_frame_make(bsdf, &hit, d, &sf);
        const int delta = vbi_bsdf_is_delta(bsdf);
        const vec3 x = hit.p;
        const int drop_direct = skip_direct && direct_phase;
        if (!delta)
            direct_phase = 0;

        const vbi_vl_pick pick_x = pick;

        /* BSDF sampling comes first: the ray to its hit y is traced and the index lookup of y's
         * gather started before x's next-event estimation and power sample, whose work then
         * covers the lookup's dependent loads (cell header, then the cell's listings). At y the
         * virtual lights are gathered (strategy 2) with weight w_v, and the camera path carries
         * on from y with weight 1 - w_v (Eq. 6). */
        vbi_bsdf_sample_rec bs = {0}; /* read only when go: {0} for the compiler's sake */
        vec2 ub = vbi_sampler_next2(sp);
        int go = vbi_bsdf_sample(bsdf, sf.wo, ub, &bs) && !v3_is_black(bs.weight);
        vec3 w = v3s(0.0f);
        if (go) {
            w = frame_to_world(&sf.fr, bs.wi);
            go = (bs.lobe & VBI_LOBE_TRANSMISSION) || v3_dot(w, sf.ng) > 0.0f;
        }
        vbi_hit y;
        int y_ok = 0, gather_y = 0;
        vbi_vl_lookup lk;
        if (go) {
            o = vbi_offset_ray_origin(x, hit.ng, w);
            d = w;
            if (power_on) /* the next vertex's pick (see above) */
                pick = vbi_vl_shade_pick_start(&s->shade, vbi_sampler_next(sp));
            stats->rays++;
            y_ok = vbi_scene_intersect_inline(sc, o, d, INFINITY, &y);
            /* The camera path goes on through near-specular lobes, as placement did (§3.1):
             * w_v = 0, no gather. */
            gather_y = y_ok && have_vls && !vbi_lobe_is_near_specular(bsdf, bs.lobe, s->pp.specular_roughness);
            if (gather_y)
                vbi_vl_index_lookup_begin(s->index, y.p, &lk);
        }

        const int lobes_x = gather_lobes(s, bsdf);
        const int power_x = lobes_x != GATHER_NONE && power_on;
        uint32_t rank_x = power_x ? vbi_vl_shade_pick_finish(&s->shade, pick_x) : 0;
        /* Direct light from the real lights: next-event estimation with MIS. */
        if (!delta && !drop_direct)
            add_L(out, v3_mul(beta, vbi_estimate_direct(sc, bsdf, x, &sf, sp, stats)));
        if (gather_y)
            vbi_vl_index_lookup_fetch(s->index, &lk);
        /* Virtual lights, strategy 1 (power-based selection), with y's candidates listed between
         * its direction and its ray. */
        power_sample ps = {0};
        if (power_x)
            power_draw(s, bsdf, &sf, x, rank_x, lobes_x, sp, &ps);
        uint32_t cand[VL_CAND_MAX], nc = 0;
        if (gather_y)
            nc = gather_candidates(s, &lk, cand);
        if (power_x)
            power_trace(s, bsdf, &sf, x, &ps, beta, out, stats);
        if (!go)
            break;

        const vec3 beta_in = v3_mul(beta, bs.weight);
        const int specular = (bs.lobe & VBI_LOBE_SPECULAR) != 0;
        /* light arriving directly (emitter or environment) belongs to x's direct estimate: it is
         * counted with the throughput before the split between lights and extension */
        vec3 Le;
        float mw = vbi_arriving_light(sc, y_ok, &y, x, w, bs.pdf, specular, &Le);
        if (mw > 0.0f && !drop_direct)
            add_L(out, v3_scale(v3_mul(beta_in, Le), mw));
        if (!y_ok)
            break;
        hit = y;
        /* No light containing y means w_v = 0 (§4.2). */
        float wv = 0.0f;
        /* A point whose BSDF is a delta (a mirror member of a material node) is not lit by the
         * lights: they stand for the diffuse and glossy points around them, and the path goes on
         * through it. */
        y_bsdf = vbi_surface_bsdf(sc, &hit, &y_store);
        if (gather_y && vbi_bsdf_is_delta(y_bsdf))
            gather_y = 0;
        if (gather_y) {
            uint32_t n = gather_filter(s, &hit, w, cand, nc, ranks);
            if (n > 0) {
                float density = 0.0f;
                for (uint32_t k = 0; k < n; ++k)
                    density += s->shade.rec[ranks[k]].density;
                wv = blend_weight(s, x, &hit, w, bs.pdf, density / (float)n); /* Eqs. 7-9 */
                if (wv > 0.0f && s->sampling != SAMPLE_POWER) {
                    /* every glossy light's texel loads start before the first is read */
                    for (uint32_t k = 0; k < n; ++k)
                        lit[k] = (uint8_t)vbi_vl_shade_radiance_begin(&s->shade.rec[ranks[k]], s->profiles, w,
                                                                       &looks[k]);
                    vec3 sum = v3s(0.0f);
                    const float p_g =
                        s->sampling == SAMPLE_MIS ? gather_pdf(lobes_x, bsdf, sf.wo, bs.wi, bs.pdf) : 0.0f;
                    for (uint32_t k = 0; k < n; ++k) {
                        if (!lit[k])
                            continue;
                        uint32_t j = ranks[k];
                        float mis = s->sampling == SAMPLE_MIS ? power_heuristic(p_g, vl_pdf(s, j, x)) : 1.0f;
                        vec3 L = vbi_vl_shade_radiance_end(&s->shade.rec[j], s->profiles, s->kernels, &looks[k]);
                        sum = v3_add(sum, v3_scale(L, mis));
                    }
                    add_vl(out, s, v3_scale(v3_mul(beta_in, sum), wv));
                }
            }
        }
        if (depth == 0)
            out[s->off_wv] = wv;
        if (wv >= 1.0f)
            break;
        beta = v3_scale(beta_in, 1.0f - wv);
        if (depth >= s->rr_depth) {
            float q = fmaxf(0.05f, 1.0f - v3_max_comp(beta));
            if (vbi_sampler_next(sp) < q)
                break;
            beta = v3_scale(beta, 1.0f / (1.0f - q));
        }
        if (!v3_is_finite(beta))
            break;
    }
    out[s->off_depth] = (float)vertices;
}

/* ---- view=lights: the distribution of the virtual lights (paper Figs. 7 and 13) ----------- */

/* Viridis as a degree-6 polynomial fit in sRGB (Matt Zucker's public-domain fit of the
 * matplotlib map), then to linear: the film is scene-linear and the PNG writer encodes sRGB. */
static vec3 viridis(float t)
{
    static const float c[7][3] = {
        {0.2777273272f, 0.0054073445f, 0.3340998053f},  {0.1050930431f, 1.4046135299f, 1.3845901626f},
        {-0.3308618287f, 0.2148475595f, 0.0950951630f}, {-4.6342304990f, -5.7991009734f, -19.3324409563f},
        {6.2282699363f, 14.1799333668f, 56.6905526007f}, {4.7763849977f, -13.7451453777f, -65.3530326334f},
        {-5.4354558559f, 4.6458526122f, 26.3124352496f}};
    t = clampf(t, 0.0f, 1.0f);
    float rgb[3];
    for (int k = 0; k < 3; ++k) {
        float v = c[6][k];
        for (int i = 5; i >= 0; --i)
            v = v * t + c[i][k];
        v = clampf(v, 0.0f, 1.0f);
        rgb[k] = v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f);
    }
    return v3(rgb[0], rgb[1], rgb[2]);
}

/* Grey |cos| x albedo shading of what the camera sees, and a dot of radius dot_scale r_j around
 * every virtual light whose normal agrees with the surface's, coloured by log r_j between the
 * set's smallest and largest radius. The lights are found by the index query at the hit. */
static void lights_view(const vbi_state *s, vec3 d, int hit_ok, const vbi_hit *hit, float *out)
{
    out[3] = 1.0f;
    if (!hit_ok)
        return;
    const vbnl_scene *sc = s->scene;
    vbi_bsdf tmp;
    vec3 albedo = vbi_bsdf_albedo(vbi_surface_bsdf(sc, hit, &tmp));
    v3_store(out + VBNL_FILM_ALBEDO, albedo);
    v3_store(out + VBNL_FILM_NORMAL, hit->ns);
    vec3 c = v3s(fabsf(v3_dot(hit->ns, d)) * (albedo.x + albedo.y + albedo.z) / 3.0f);
    if (s->prepared) {
        uint32_t ids[VL_GATHER_MAX];
        float d2[VL_GATHER_MAX];
        uint32_t n = vbi_vl_index_query(s->index, hit->p, VL_GATHER_MAX, ids, d2);
        n = n < VL_GATHER_MAX ? n : VL_GATHER_MAX;
        float best = INFINITY;
        for (uint32_t k = 0; k < n; ++k) {
            uint32_t j = ids[k];
            float rd = s->dot_scale * s->vls.radius[j];
            float rel = d2[k] / (rd * rd);
            if (rel < 1.0f && rel < best && fabsf(v3_dot(s->vls.normal[j], hit->ng)) > VL_NORMAL_COS) {
                float span = s->log_rmax - s->log_rmin;
                best = rel;
                c = viridis(span > 0.0f ? (logf(s->vls.radius[j]) - s->log_rmin) / span : 0.5f);
            }
        }
    }
    add_L(out, c);
}

static void trace_lights_view(void *state, vbi_sampler *sp, vec3 o, vec3 d, int hit_ok, const vbi_hit *hit,
                              float *out, vbi_thread_stats *stats)
{
    (void)sp;
    (void)o;
    (void)stats;
    lights_view(state, d, hit_ok, hit, out);
}

static void vbi_render_tile(void *state, vbnl_tile_job *job)
{
    vbi_state *s = state;
    vbi_render_camera_paths(job, s->stride, s->view == VIEW_LIGHTS ? trace_lights_view : trace, state);
}

const vbnl_integrator_class vbi_integrator_vbnl = {
    VBNL_INTEGRATOR_ABI_MAJOR,
    VBNL_INTEGRATOR_ABI_MINOR,
    sizeof(vbnl_integrator_class),
    "vbnl",
    "Virtual Blue Noise Lighting: camera-placed blue-noise photon lights with MIS and path extension",
    vbi_params_spec,
    N_PARAMS,
    vbi_create,
    vbi_prepare,
    vbi_render_tile,
    vbi_destroy,
};
