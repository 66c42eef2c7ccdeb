/* vbnl: render context, renderers, films and progress.
 *
 * A vbnl_context owns what several renders may share: the worker threads and the Embree device.
 * Create it first, build a vbnl_scene with it, then create a vbnl_renderer for a scene, an
 * integrator and settings. The renderer owns the film it writes.
 *
 *   vbnl_context_create -> vbnl_scene_create ... vbnl_scene_commit
 *     -> vbnl_renderer_create -> vbnl_renderer_prepare -> vbnl_renderer_render -> vbnl_film_read
 *
 * Determinism: the same scene, settings and seed give bit-identical films for any thread count.
 *
 * Thread-safety: a context may create many scenes and renderers; one renderer must be driven by
 * one thread at a time (the work inside prepare/render is spread over the context's workers).
 * The progress callback is called on the thread that called vbnl_renderer_prepare or
 * vbnl_renderer_render, never on a worker thread, at most every `progress_interval` seconds and
 * once at the end of each stage. */
#ifndef VBNL_RENDER_H
#define VBNL_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "vbnl/params.h"
#include "vbnl/result.h"
#include "vbnl/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vbnl_renderer vbnl_renderer;
typedef struct vbnl_film vbnl_film;

/* Test hooks (vbnl_context_desc.test_hooks): for the project's own tests, never set otherwise. */
typedef enum vbnl_test_hook {
    /* Every file the library writes (EXR, PNG, virtual-light files) waits 30 s with its temporary
     * file complete and not yet renamed, after saying so on stderr ("vbnl: test pause (write):
     * '<temporary>' written, not yet renamed to '<path>'"), so that a test can interrupt a write
     * at a known point. Writes are process-wide (one table of temporaries, which a signal handler
     * empties), so the pause is too: once a context asked for it, every write of the process
     * pauses. */
    VBNL_TEST_HOOK_PAUSE_WRITES = 1u << 0,
} vbnl_test_hook;

typedef struct vbnl_context_desc {
    uint32_t size;              /* sizeof(vbnl_context_desc): set by vbnl_context_desc_init */
    unsigned threads;           /* worker threads; 0 = one per core */
    uint32_t test_hooks;        /* vbnl_test_hook bits; 0 */
} vbnl_context_desc;

/* Fills `d` with its size and the defaults (one thread per core, no test hook). */
void vbnl_context_desc_init(vbnl_context_desc *d);
/* Creates a context (its worker threads and Embree device) into *out; desc may be NULL (the
 * defaults). Errors: VBNL_ERR_INVALID_ARGUMENT (NULL out, a descriptor of an unknown size, more
 * than 1024 threads), VBNL_ERR_UNSUPPORTED (a descriptor from a newer vbnl), VBNL_ERR_BACKEND
 * (Embree), VBNL_ERR_OUT_OF_MEMORY (also when a thread cannot start). */
vbnl_result vbnl_context_create(const vbnl_context_desc *desc, vbnl_context **out, vbnl_error *err);
/* Stops the workers and frees the context (accepts NULL). Every scene and renderer made with it
 * must be destroyed first. */
void vbnl_context_destroy(vbnl_context *ctx);
/* Worker threads of the context (0 for NULL). Any thread. */
unsigned vbnl_context_thread_count(const vbnl_context *ctx);

/* Where the random numbers of a camera sample come from (core/src/sampler.h). Chosen by name
 * with vbnl_sampler_find; every integrator renders with either. */
typedef enum vbnl_sampler_kind {
    VBNL_SAMPLER_SOBOL = 0,  /* "sobol" (default): the first draws of a sample (pixel position,
                                next-event estimation, the first bounces) from Owen-scrambled
                                Sobol' points, stratified per pixel; the rest as "random" */
    VBNL_SAMPLER_RANDOM = 1  /* "random": independent uniform numbers (PCG) for every draw */
} vbnl_sampler_kind;

/* The sampler's name ("sobol", "random"), or NULL for a value that is none. Pure: any thread. */
const char *vbnl_sampler_name(vbnl_sampler_kind kind);
/* Looks a sampler up by name; unknown names are refused with the list of valid ones
 * (VBNL_ERR_UNKNOWN_NAME); NULL arguments: VBNL_ERR_INVALID_ARGUMENT. Pure: any thread. */
vbnl_result vbnl_sampler_find(const char *name, vbnl_sampler_kind *out, vbnl_error *err);

typedef struct vbnl_render_settings {
    uint32_t size;              /* sizeof(vbnl_render_settings): set by vbnl_render_settings_init */
    uint32_t width, height;     /* image size in pixels, 1 .. 65536 */
    uint32_t spp;               /* samples per pixel to reach; 0 = until the time budget ends */
    double time_budget;         /* seconds for prepare + render; 0 = no limit (spp must be > 0).
                                   The integrator sizes its work to it (docs/time-budget.md);
                                   rendering stops at it, the tiles in flight finishing */
    uint64_t seed;
    const char *integrator;     /* registered name; NULL means "path" */
    const vbnl_params *params;  /* integrator parameters, or NULL for every default */
    uint32_t crop[4];           /* x0, y0, x1, y1 (exclusive); all zero = whole image */
    float progress_interval;    /* seconds between progress calls; 0 = 0.25 */
    vbnl_sampler_kind sampler;  /* VBNL_SAMPLER_SOBOL unless changed */
} vbnl_render_settings;

/* Fills `s` with its size and the defaults: 512 x 512, 16 samples per pixel, no time budget,
 * seed 1, the `path` integrator with default parameters, no crop, the "sobol" sampler. */
void vbnl_render_settings_init(vbnl_render_settings *s);

/* Progress of one stage ("prepare: photons", "render", ...). */
typedef struct vbnl_progress {
    const char *stage;
    double done, total;         /* work units (total may be 0 when unknown) */
    const char *unit;           /* "samples/pixel", "photons", ... */
    double elapsed;             /* seconds in this stage so far */
    double rate;                /* units per second */
    double eta;                 /* seconds left in this stage, < 0 when unknown */
} vbnl_progress;

/* Returns non-zero to cancel: the stage stops after the work items in flight. */
typedef int (*vbnl_progress_fn)(void *user, const vbnl_progress *progress);

/* Validates the settings, the integrator name and its parameters, creates the integrator and
 * allocates the film. The settings and parameters are copied; ctx and scene (committed) must
 * outlive the renderer. Errors: VBNL_ERR_INVALID_ARGUMENT (NULL arguments, settings of an unknown
 * size, neither spp nor a time budget, a bad size, crop, sampler or parameter value),
 * VBNL_ERR_UNSUPPORTED (settings from a newer vbnl), VBNL_ERR_UNKNOWN_NAME (an unknown integrator,
 * with the list of registered names, or parameter), VBNL_ERR_STATE (the scene is not committed),
 * VBNL_ERR_OUT_OF_MEMORY, and what the integrator's create() refuses. */
vbnl_result vbnl_renderer_create(vbnl_context *ctx, const vbnl_scene *scene,
                                 const vbnl_render_settings *settings, vbnl_renderer **out,
                                 vbnl_error *err);
/* Frees the renderer, its integrator and its film (accepts NULL). */
void vbnl_renderer_destroy(vbnl_renderer *r);

/* Scene-dependent preparation of the integrator (a no-op for `path`), its stages reported to
 * `progress` (may be NULL), which may cancel. Errors: VBNL_ERR_CANCELLED, VBNL_ERR_INVALID_ARGUMENT
 * (NULL renderer), and the integrator's (e.g. VBNL_ERR_OUT_OF_MEMORY, a budget it cannot keep). */
vbnl_result vbnl_renderer_prepare(vbnl_renderer *r, vbnl_progress_fn progress, void *user,
                                  vbnl_error *err);
/* Renders progressive passes until `spp` or the time budget is reached (prepares first if
 * vbnl_renderer_prepare was not called). Returns VBNL_ERR_CANCELLED when the callback cancelled;
 * the film then holds every finished sample; once spp is reached a further call renders nothing.
 * Errors: VBNL_ERR_INVALID_ARGUMENT (NULL renderer), those of prepare. */
vbnl_result vbnl_renderer_render(vbnl_renderer *r, vbnl_progress_fn progress, void *user,
                                 vbnl_error *err);

/* The renderer's film (NULL for NULL), valid until the renderer is destroyed; read it between
 * calls of prepare and render, never during them. */
const vbnl_film *vbnl_renderer_film(const vbnl_renderer *r);

typedef struct vbnl_stage_time {
    const char *name;
    double seconds;
    double work;            /* what the stage counted, e.g. the photon stage's rays (0: nothing) */
    const char *work_unit;  /* its unit ("rays"), NULL when work is 0 */
} vbnl_stage_time;

/* A value an integrator chose for a time budget, or kept because the user set it. */
typedef struct vbnl_budget_choice {
    const char *name;   /* a parameter, e.g. "virtual_lights" */
    double value;
    const char *why;    /* one line: the rule and the figures it used */
} vbnl_budget_choice;

typedef struct vbnl_render_stats {
    uint32_t passes;
    uint32_t spp;                /* samples per pixel finished in every pixel of the crop */
    uint64_t samples;            /* camera samples taken */
    uint64_t rays;               /* every ray traced (closest hit and shadow) */
    double prepare_seconds, render_seconds;
    uint32_t stage_count;
    const vbnl_stage_time *stages;/* owned by the renderer; valid until it is destroyed */
    int cancelled;
    uint64_t storage_bytes;      /* memory held by the integrator's prepared data (virtual lights,
                                  * emission profiles, indices); 0 when it keeps none (`path`) */
    /* Among `rays`: the camera rays (8-wide coherent packets) and the shadow rays of the shared
     * next-event estimation (`path`, and wherever an integrator calls it); the rest are
     * counted as closest-hit rays by vbnl_ray_rates_mix, though an integrator's own occlusion
     * rays (virtual lights) are among them. */
    uint64_t camera_rays, shadow_rays;
    /* Under a time budget (docs/time-budget.md): what the integrator chose and why, owned by the
     * renderer (valid until it is destroyed); the preparation's bound in seconds; and whether the
     * last pass was cut at the budget (its tiles not yet started were left out, so some pixels
     * have spp + that pass's samples and the rest spp). */
    uint32_t choice_count;
    const vbnl_budget_choice *choices;
    double prepare_limit;
    int budget_cut;
} vbnl_render_stats;
/* The renderer's statistics so far into *out (pointers in it owned by the renderer). Errors:
 * VBNL_ERR_INVALID_ARGUMENT for NULL arguments. */
vbnl_result vbnl_renderer_get_stats(const vbnl_renderer *r, vbnl_render_stats *out, vbnl_error *err);

/* Diagnostics: raw Embree ray rates of this scene in rays per second, for each kind of ray a
 * path tracer traces, since their costs differ by up to three times:
 *   camera   primary rays through jittered pixel positions, pixel after pixel, as 8-wide
 *            coherent packets (rtcIntersect8), as the integrators trace them;
 *   closest  incoherent secondary rays (rtcIntersect1): from points the camera sees (image of
 *            width x height), directions cosine-distributed about the surface normal;
 *   closest_packet  the same rays eight to a packet in their random order (rtcIntersect8, no
 *            coherence flag): what a tracer that keeps eight independent paths in flight gets
 *            (photon splitting does); on small scenes faster than closest (Cornell box 36
 *            triangles: ~1.3x), on large or random ones about the same;
 *   shadow   occlusion rays (rtcOccluded1) from the same points to points on the lights, picked
 *            and sampled as next-event estimation does, ending just short of the light (0 when
 *            the scene has no lights).
 * Each set of ray_count rays at most is generated first, then traced by every worker with no
 * shading; each rate is the median of three timed runs. These are the ceiling the integrators'
 * ray rates are compared with (vbnl_ray_rates_mix). */
typedef struct vbnl_ray_rates {
    double camera, closest, shadow;
    double closest_packet; /* appended: the layout of the first three is unchanged */
} vbnl_ray_rates;
/* Measures the rates above on ctx's workers (the calling thread waits). Errors:
 * VBNL_ERR_INVALID_ARGUMENT (NULL arguments, zero counts or sizes), VBNL_ERR_STATE (the scene is
 * not committed), VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_scene_measure_ray_rates(vbnl_context *ctx, const vbnl_scene *scene, uint32_t ray_count,
                                         uint32_t width, uint32_t height, vbnl_ray_rates *out, vbnl_error *err);
/* The rate Embree alone would trace a given mixture of rays at: the total count over the sum of
 * each kind's count divided by its rate. 0 when a kind with rays has no measured rate. Pure. */
double vbnl_ray_rates_mix(const vbnl_ray_rates *r, uint64_t camera_rays, uint64_t closest_rays,
                          uint64_t shadow_rays);
/* The closest-hit rate of vbnl_scene_measure_ray_rates alone (measures every kind; its errors). */
vbnl_result vbnl_scene_measure_ray_rate(vbnl_context *ctx, const vbnl_scene *scene, uint32_t ray_count,
                                        uint32_t width, uint32_t height, double *rays_per_second,
                                        vbnl_error *err);

/* ---- film --------------------------------------------------------------------------------- */

/* Offsets, in a sample record (integrator.h, vbnl_tile_job_add_sample), of the layers every
 * film has; an integrator's own layers follow (vbnl_film_add_layer). */
#define VBNL_FILM_BEAUTY 0u       /* R, G, B, A */
#define VBNL_FILM_ALBEDO 4u       /* R, G, B: the first surface's reflectance */
#define VBNL_FILM_NORMAL 7u       /* X, Y, Z: its unit shading normal */
#define VBNL_FILM_DEPTH 10u       /* Z: its distance along the camera's view axis */
#define VBNL_FILM_MAX_CHANNELS 64u /* channels of all layers together, at most */

typedef struct vbnl_layer_info {
    const char *name;              /* "" for the beauty image, else "albedo", "normal", ... */
    uint32_t channels;             /* 1 .. 4 */
    const char *const *channel_names; /* e.g. "R","G","B" or "Z" */
} vbnl_layer_info;

/* Reading a film: any thread, while no render runs on it. Image size in pixels (0 for NULL). */
uint32_t vbnl_film_width(const vbnl_film *f);
uint32_t vbnl_film_height(const vbnl_film *f);
/* Layers: the beauty image first, then albedo, normal, depth and the integrator's. */
uint32_t vbnl_film_layer_count(const vbnl_film *f);
/* Layer `index`'s name and channels (strings owned by the film). Errors:
 * VBNL_ERR_INVALID_ARGUMENT (NULL arguments, index >= the layer count). */
vbnl_result vbnl_film_layer(const vbnl_film *f, uint32_t index, vbnl_layer_info *out, vbnl_error *err);
/* Writes the resolved layer (mean of its samples; 0 where a pixel has none) as interleaved
 * floats, row 0 at the top: width*height*channels values into dst (the caller's, dst_count
 * floats). Errors: VBNL_ERR_UNKNOWN_NAME (no such layer), VBNL_ERR_INVALID_ARGUMENT (NULL
 * arguments, dst_count too small). */
vbnl_result vbnl_film_read(const vbnl_film *f, const char *layer, float *dst, size_t dst_count,
                           vbnl_error *err);
/* Samples taken in pixel (x, y) (0 outside a crop window). */
uint32_t vbnl_film_pixel_samples(const vbnl_film *f, uint32_t x, uint32_t y);

/* For integrators, from create() only (integrator.h): adds a layer `name` (not yet in the film,
 * at most 31 bytes) of 1 to 4 channels named channel_names[0 .. channels) (strings that outlive
 * the film) and writes its offset in a sample record to *offset (may be NULL). Errors:
 * VBNL_ERR_INVALID_ARGUMENT (bad arguments, a taken or too long name, more than 16 layers or
 * VBNL_FILM_MAX_CHANNELS channels), VBNL_ERR_STATE (after create()). */
vbnl_result vbnl_film_add_layer(vbnl_film *f, const char *name, uint32_t channels,
                                const char *const *channel_names, uint32_t *offset, vbnl_error *err);
/* Floats in a sample record: the channels of every layer (at most VBNL_FILM_MAX_CHANNELS). */
uint32_t vbnl_film_record_size(const vbnl_film *f);

#ifdef __cplusplus
}
#endif
#endif
