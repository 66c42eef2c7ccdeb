/* Renderer: integrator life cycle, progressive passes over tiles, time budget, statistics. */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "context.h"
#include "desc.h"
#include "render_internal.h"

#define MAX_STAGES 32
#define MAX_CHOICES 8

struct vbnl_budget {
    vbnl_renderer *renderer;
    double seconds, pixels;
    uint32_t count;
    vbnl_budget_choice choices[MAX_CHOICES];
    char names[MAX_CHOICES][48];
    char why[MAX_CHOICES][320];
};

struct vbnl_renderer {
    vbnl_context *ctx;
    const vbnl_scene *scene;
    vbnl_render_settings settings;
    vbnl_params *params;              /* private copy */
    const vbnl_integrator_class *cls;
    void *state;
    vbnl_film *film;
    int prepared;
    uint32_t spp_done;
    uint32_t passes;
    double t_start;                   /* first prepare or render call, for the time budget */
    double prepare_seconds, render_seconds;
    vbnl_stage_time stages[MAX_STAGES];
    uint32_t stage_count;
    vbi_thread_stats *tstats;
    int cancelled;
    int budget_cut;
    uint64_t storage_bytes;
    vbnl_budget budget;
};

void vbnl_render_settings_init(vbnl_render_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->size = sizeof(*s);
    s->width = 512;
    s->height = 512;
    s->spp = 16;
    s->seed = 1;
}

static const char *const sampler_names[] = {"sobol", "random"};
#define SAMPLER_LIST "sobol, random" /* sampler_names, for messages */

const char *vbnl_sampler_name(vbnl_sampler_kind kind)
{
    return (unsigned)kind < sizeof(sampler_names) / sizeof(sampler_names[0]) ? sampler_names[kind] : NULL;
}

vbnl_result vbnl_sampler_find(const char *name, vbnl_sampler_kind *out, vbnl_error *err)
{
    if (!name || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_sampler_find: NULL argument");
    for (unsigned k = 0; k < sizeof(sampler_names) / sizeof(sampler_names[0]); ++k)
        if (!strcmp(name, sampler_names[k])) {
            *out = (vbnl_sampler_kind)k;
            return VBNL_OK;
        }
    return vbnl_error_set(err, VBNL_ERR_UNKNOWN_NAME, "unknown sampler '%s' (valid: " SAMPLER_LIST ")", name);
}

static void list_integrators(char *buf, size_t size)
{
    buf[0] = '\0';
    for (uint32_t i = 0; i < vbnl_integrator_count(); ++i) {
        size_t n = strlen(buf);
        snprintf(buf + n, size - n, "%s%s", i ? ", " : "", vbnl_integrator_at(i)->name);
    }
}

/* The renderer of settings for class cls (NULL: the registered one settings->integrator names). */
static vbnl_result renderer_create(vbnl_context *ctx, const vbnl_scene *scene, const vbnl_render_settings *settings,
                                   const vbnl_integrator_class *cls, vbnl_renderer **out, vbnl_error *err)
{
    if (!ctx || !scene || !settings || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_renderer_create: NULL argument");
    *out = NULL;
    vbnl_result r = VBI_DESC_CHECK(settings, vbnl_render_settings, err);
    if (r != VBNL_OK)
        return r;
    if (!scene->committed)
        return vbnl_error_set(err, VBNL_ERR_STATE, "vbnl_renderer_create: the scene is not committed");
    if (settings->spp == 0 && !(settings->time_budget > 0.0))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "give a sample count (spp > 0) or a time budget (> 0 seconds)");
    if (!(settings->time_budget >= 0.0) || !isfinite(settings->time_budget))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "the time budget must be >= 0 seconds");
    if (!vbnl_sampler_name(settings->sampler))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "unknown sampler %d (valid: " SAMPLER_LIST ")",
                              (int)settings->sampler);
    const char *name = cls ? cls->name : settings->integrator ? settings->integrator : "path";
    if (!cls && !(cls = vbnl_integrator_find(name))) {
        char list[512];
        list_integrators(list, sizeof(list));
        return vbnl_error_set(err, VBNL_ERR_UNKNOWN_NAME, "unknown integrator '%s' (registered: %s)",
                              name, list);
    }
    if (cls->abi_major != VBNL_INTEGRATOR_ABI_MAJOR)
        return vbnl_error_set(err, VBNL_ERR_UNSUPPORTED,
                              "integrator '%s' was built for ABI %u, this core has ABI %u", name,
                              cls->abi_major, VBNL_INTEGRATOR_ABI_MAJOR);
    char owner[96];
    snprintf(owner, sizeof(owner), "integrator '%s'", cls->name);
    r = vbnl_params_validate(settings->params, cls->params, cls->param_count, owner, err);
    if (r != VBNL_OK)
        return r;
    vbnl_renderer *rd = calloc(1, sizeof(*rd));
    if (!rd)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    rd->ctx = ctx;
    rd->scene = scene;
    rd->settings = *settings;
    rd->settings.integrator = cls->name;
    rd->cls = cls;
    if ((r = vbnl_params_create(&rd->params, err)) != VBNL_OK ||
        (settings->params && (r = vbnl_params_append(rd->params, settings->params, err)) != VBNL_OK)) {
        vbnl_renderer_destroy(rd);
        return r;
    }
    rd->settings.params = rd->params;
    rd->budget.renderer = rd;
    rd->budget.seconds = settings->time_budget;
    rd->tstats = calloc(ctx->threads, sizeof(vbi_thread_stats));
    if (!rd->tstats) {
        vbnl_renderer_destroy(rd);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    if ((r = vbi_film_create(settings->width, settings->height, settings->crop, &rd->film, err)) != VBNL_OK) {
        vbnl_renderer_destroy(rd);
        return r;
    }
    rd->budget.pixels = (double)(rd->film->crop[2] - rd->film->crop[0]) * (rd->film->crop[3] - rd->film->crop[1]);
    vbnl_integrator_env env = {ctx, scene, rd->params, &rd->settings, rd->film, &rd->budget};
    if ((r = cls->create(&env, &rd->state, err)) != VBNL_OK) {
        rd->state = NULL;
        vbnl_renderer_destroy(rd);
        return r;
    }
    if ((r = vbi_film_allocate(rd->film, err)) != VBNL_OK) {
        vbnl_renderer_destroy(rd);
        return r;
    }
    *out = rd;
    return VBNL_OK;
}

vbnl_result vbnl_renderer_create(vbnl_context *ctx, const vbnl_scene *scene,
                                 const vbnl_render_settings *settings, vbnl_renderer **out,
                                 vbnl_error *err)
{
    return renderer_create(ctx, scene, settings, NULL, out, err);
}

vbnl_result vbnl_renderer_create_with_class(vbnl_context *ctx, const vbnl_scene *scene,
                                            const vbnl_render_settings *settings,
                                            const vbnl_integrator_class *cls, vbnl_renderer **out,
                                            vbnl_error *err)
{
    if (out)
        *out = NULL;
    if (!cls)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_renderer_create_with_class: the class is NULL");
    if (cls->abi_major != VBNL_INTEGRATOR_ABI_MAJOR)
        return vbnl_error_set(err, VBNL_ERR_UNSUPPORTED, "integrator '%s' was built for ABI %u, this core has ABI %u",
                              cls->name ? cls->name : "(unnamed)", cls->abi_major, VBNL_INTEGRATOR_ABI_MAJOR);
    const size_t need = offsetof(vbnl_integrator_class, destroy) + sizeof(cls->destroy);
    if (cls->size < need)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "integrator class of %u bytes: its table needs at least %zu (set size to "
                              "sizeof(vbnl_integrator_class))",
                              cls->size, need);
    if (!cls->name || !cls->create || !cls->render_tile || (cls->param_count && !cls->params))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "integrator class '%s' lacks a name, create, render_tile or its parameter table",
                              cls->name ? cls->name : "(unnamed)");
    return renderer_create(ctx, scene, settings, cls, out, err);
}

void vbnl_renderer_destroy(vbnl_renderer *r)
{
    if (!r)
        return;
    if (r->state && r->cls->destroy)
        r->cls->destroy(r->state);
    vbi_film_destroy(r->film);
    vbnl_params_destroy(r->params);
    free(r->tstats);
    free(r);
}

const vbnl_film *vbnl_renderer_film(const vbnl_renderer *r) { return r ? r->film : NULL; }

static void record_stage(vbnl_renderer *r, const char *name, double seconds, double work, const char *unit)
{
    for (uint32_t i = 0; i < r->stage_count; ++i) {
        if (strcmp(r->stages[i].name, name) == 0) {
            r->stages[i].seconds += seconds;
            r->stages[i].work += work;
            if (unit)
                r->stages[i].work_unit = unit;
            return;
        }
    }
    if (r->stage_count < MAX_STAGES) {
        r->stages[r->stage_count] = (vbnl_stage_time){name, seconds, work, unit};
        r->stage_count++;
    }
}

/* ---- time budget -------------------------------------------------------------------------- */

double vbnl_budget_seconds(const vbnl_budget *b) { return b ? b->seconds : 0.0; }

double vbnl_budget_prepare_limit(const vbnl_budget *b)
{
    return b && b->seconds > 0.0 ? VBNL_BUDGET_PREPARE_SHARE * b->seconds : 0.0;
}

double vbnl_budget_elapsed(const vbnl_budget *b)
{
    return b && b->renderer->t_start > 0.0 ? vbi_now() - b->renderer->t_start : 0.0;
}

double vbnl_budget_pixels(const vbnl_budget *b) { return b ? b->pixels : 0.0; }

void vbnl_budget_choose(vbnl_budget *b, const char *name, double value, const char *why_fmt, ...)
{
    if (!b || !name)
        return;
    uint32_t i = 0;
    while (i < b->count && strcmp(b->names[i], name) != 0)
        ++i;
    if (i == MAX_CHOICES)
        return;
    if (i == b->count)
        b->count++;
    snprintf(b->names[i], sizeof(b->names[i]), "%s", name);
    b->why[i][0] = '\0';
    if (why_fmt) {
        va_list ap;
        va_start(ap, why_fmt);
        vsnprintf(b->why[i], sizeof(b->why[i]), why_fmt, ap);
        va_end(ap);
    }
    b->choices[i] = (vbnl_budget_choice){b->names[i], value, b->why[i]};
}

vbnl_result vbnl_budget_size_lights(vbnl_budget *b, const char *name, double fallback, double spp_target,
                                    double cost, double lo, double hi, uint32_t *out, vbnl_error *err)
{
    *out = (uint32_t)fallback;
    if (!b || !(b->seconds > 0.0))
        return VBNL_OK;
    vbnl_renderer *r = b->renderer;
    const int explicit_count = vbnl_params_has(r->params, name);
    /* the scene's shadow-ray rate on every worker: a short calibration (median of three runs of
     * 8192 rays of each kind, about 10 ms on the bench scenes) */
    double t0 = vbi_now();
    vbnl_ray_rates rates;
    uint32_t w = r->settings.width, h = r->settings.height;
    vbnl_result res = vbnl_scene_measure_ray_rates(r->ctx, r->scene, 8192, w, h, &rates, err);
    record_stage(r, "calibrate", vbi_now() - t0, 0.0, NULL);
    if (res != VBNL_OK)
        return res;
    double rate = rates.shadow > 0.0 ? rates.shadow : rates.closest;
    /* rendering's share: the budget less the preparation's bound */
    double render = b->seconds * (1.0 - VBNL_BUDGET_PREPARE_SHARE);
    double per_light_pass = b->pixels * cost / (rate > 0.0 ? rate : 1.0); /* seconds per light per spp */
    if (explicit_count) {
        double one_pass = fallback * per_light_pass;
        if (one_pass > b->seconds - vbnl_budget_elapsed(b))
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "integrator '%s': %s=%.0f set explicitly cannot fit the %g s time budget: one "
                                  "sample per pixel "
                                  "of %.0f pixels needs about %.1f s (%.3g shadow rays/s measured on this scene); "
                                  "lower %s, raise --time or leave %s unset so that the budget sizes it",
                                  r->cls->name, name, fallback, b->seconds, b->pixels, one_pass, rate, name, name);
        vbnl_budget_choose(b, name, fallback,
                           "set explicitly, kept: about %.1f s per sample per pixel (%.3g shadow rays/s)", one_pass,
                           rate);
        return VBNL_OK;
    }
    double n = floor(render / (spp_target * per_light_pass));
    n = fmax(lo, fmin(hi, n));
    *out = (uint32_t)n;
    vbnl_budget_choose(b, name, n,
                       "sized: %g spp x %.0f pixels x %g shadow-ray costs per light in %.2f s of rendering at "
                       "%.3g shadow rays/s (measured), clamped to [%g, %g]",
                       spp_target, b->pixels, cost, render, rate, lo, hi);
    return VBNL_OK;
}

/* ---- stages ------------------------------------------------------------------------------- */

void vbnl_stage_begin(vbnl_stage_ctx *st, const char *name, double total, const char *unit)
{
    st->name = name;
    st->unit = unit;
    st->total = total;
    st->start = vbi_now();
    st->work = 0.0;
    st->work_unit = NULL;
}

static int stage_poll(void *user, uint64_t finished, uint64_t count)
{
    vbnl_stage_ctx *st = user;
    (void)count;
    if (!st->progress)
        return 0;
    vbnl_progress p;
    p.stage = st->name;
    p.unit = st->unit;
    p.total = st->total;
    p.elapsed = vbi_now() - st->start;
    p.done = st->total > 0.0 && count > 0 ? st->total * (double)finished / (double)count : (double)finished;
    p.rate = p.elapsed > 0.0 ? p.done / p.elapsed : 0.0;
    p.eta = p.rate > 0.0 && p.total > 0.0 ? (p.total - p.done) / p.rate : -1.0;
    if (st->progress(st->user, &p)) {
        st->cancelled = 1;
        return 1;
    }
    return 0;
}

int vbnl_stage_run(vbnl_stage_ctx *st, uint64_t count, vbnl_work_fn fn, void *user)
{
    if (st->cancelled)
        return -1;
    uint64_t ran = vbi_pool_run(st->renderer->ctx->pool, count, fn, user, stage_poll, st, st->interval);
    return (ran < count || st->cancelled) ? -1 : 0;
}

void vbnl_stage_end(vbnl_stage_ctx *st)
{
    if (st->record_as)
        record_stage(st->renderer, st->record_as, vbi_now() - st->start, 0.0, NULL);
    else
        record_stage(st->renderer, st->name, vbi_now() - st->start, st->work, st->work_unit);
}

void vbnl_stage_set_work(vbnl_stage_ctx *st, double work, const char *unit)
{
    if (!st)
        return;
    st->work = work;
    st->work_unit = unit;
}

void vbnl_stage_set_storage(vbnl_stage_ctx *st, uint64_t bytes)
{
    if (st)
        st->renderer->storage_bytes = bytes;
}

unsigned vbnl_stage_thread_count(const vbnl_stage_ctx *st) { return st->renderer->ctx->threads; }

int vbi_run_items(vbnl_stage_ctx *st, vbi_pool *pool, uint64_t count, vbi_pool_fn fn, void *user)
{
    if (st)
        return vbnl_stage_run(st, count, fn, user);
    if (pool)
        return vbi_pool_run(pool, count, fn, user, NULL, NULL, 1.0) == count ? 0 : -1;
    for (uint64_t i = 0; i < count; ++i)
        fn(user, i, 0);
    return 0;
}

unsigned vbi_run_thread_count(const vbnl_stage_ctx *st, const vbi_pool *pool)
{
    if (st)
        return vbnl_stage_thread_count(st);
    return pool ? vbi_pool_thread_count(pool) : 1u;
}
uint64_t vbi_stage_seed(const vbnl_stage_ctx *st) { return st->renderer->settings.seed; }

vbnl_result vbnl_renderer_prepare(vbnl_renderer *r, vbnl_progress_fn progress, void *user,
                                  vbnl_error *err)
{
    if (!r)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_renderer_prepare: renderer is NULL");
    if (r->prepared)
        return VBNL_OK;
    double t0 = vbi_now();
    if (r->t_start == 0.0)
        r->t_start = t0;
    vbnl_result res = VBNL_OK;
    if (r->cls->prepare) {
        vbnl_stage_ctx st;
        memset(&st, 0, sizeof(st));
        st.renderer = r;
        st.progress = progress;
        st.user = user;
        st.interval = r->settings.progress_interval > 0.0f ? r->settings.progress_interval : 0.25;
        res = r->cls->prepare(r->state, &st, err);
        if (res == VBNL_OK && st.cancelled)
            res = vbnl_error_set(err, VBNL_ERR_CANCELLED, "preparation was cancelled");
        if (res == VBNL_ERR_CANCELLED)
            r->cancelled = 1;
    }
    r->prepare_seconds += vbi_now() - t0;
    if (res == VBNL_OK)
        r->prepared = 1;
    return res;
}

/* ---- passes ------------------------------------------------------------------------------- */

typedef struct pass_ctx {
    vbnl_renderer *r;
    uint32_t tiles_x, tile_x0, tile_y0;
    uint32_t sample_begin, sample_end;
    /* progress */
    vbnl_progress_fn progress;
    void *user;
    double t_pass_start, t_render_start;
    uint64_t tile_count;
    double deadline;                  /* > 0: tiles that would start after it are left out */
    int cut;                          /* a tile was left out (set by workers) */
    int cancelled;
} pass_ctx;

static void run_tile(void *user, uint64_t item, unsigned thread)
{
    pass_ctx *pc = user;
    vbnl_renderer *r = pc->r;
    const vbnl_film *f = r->film;
    if (pc->deadline > 0.0 && vbi_now() >= pc->deadline) {
        __atomic_store_n(&pc->cut, 1, __ATOMIC_RELAXED);
        return;
    }
    uint32_t tx = pc->tile_x0 + (uint32_t)(item % pc->tiles_x);
    uint32_t ty = pc->tile_y0 + (uint32_t)(item / pc->tiles_x);
    vbnl_tile_job job;
    job.scene = r->scene;
    job.film = r->film;
    job.x0 = tx * VBI_FILM_TILE;
    job.y0 = ty * VBI_FILM_TILE;
    job.x1 = job.x0 + VBI_FILM_TILE;
    job.y1 = job.y0 + VBI_FILM_TILE;
    if (job.x0 < f->crop[0])
        job.x0 = f->crop[0];
    if (job.y0 < f->crop[1])
        job.y0 = f->crop[1];
    if (job.x1 > f->crop[2])
        job.x1 = f->crop[2];
    if (job.y1 > f->crop[3])
        job.y1 = f->crop[3];
    job.sample_begin = pc->sample_begin;
    job.sample_end = pc->sample_end;
    job.width = f->width;
    job.height = f->height;
    job.seed = r->settings.seed;
    job.sampler = r->settings.sampler;
    job.thread = thread;
    job.stats = &r->tstats[thread];
    r->cls->render_tile(r->state, &job);
    job.stats->samples += (uint64_t)(job.x1 - job.x0) * (job.y1 - job.y0) * (job.sample_end - job.sample_begin);
}

static int pass_poll(void *user, uint64_t finished, uint64_t count)
{
    pass_ctx *pc = user;
    if (!pc->progress)
        return 0;
    vbnl_renderer *r = pc->r;
    vbnl_progress p;
    p.stage = "render";
    p.unit = "samples/pixel";
    double pass_spp = (double)(pc->sample_end - pc->sample_begin);
    p.done = (double)pc->sample_begin + pass_spp * (double)finished / (double)(count ? count : 1);
    p.elapsed = vbi_now() - pc->t_render_start;
    p.rate = p.elapsed > 0.0 ? (p.done - 0.0) / p.elapsed : 0.0;
    if (r->settings.spp > 0) {
        p.total = r->settings.spp;
        p.eta = p.rate > 0.0 ? (p.total - p.done) / p.rate : -1.0;
    } else {
        p.total = 0.0;
        p.eta = r->settings.time_budget - (vbi_now() - r->t_start);
    }
    if (r->settings.time_budget > 0.0 && r->settings.spp > 0) {
        double left = r->settings.time_budget - (vbi_now() - r->t_start);
        if (left < p.eta || p.eta < 0.0)
            p.eta = left;
    }
    if (pc->progress(pc->user, &p)) {
        pc->cancelled = 1;
        return 1;
    }
    return 0;
}

vbnl_result vbnl_renderer_render(vbnl_renderer *r, vbnl_progress_fn progress, void *user,
                                 vbnl_error *err)
{
    if (!r)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_renderer_render: renderer is NULL");
    if (!r->prepared) {
        vbnl_result pr = vbnl_renderer_prepare(r, progress, user, err);
        if (pr != VBNL_OK)
            return pr;
    }
    const vbnl_film *f = r->film;
    pass_ctx pc;
    memset(&pc, 0, sizeof(pc));
    pc.r = r;
    pc.tile_x0 = f->crop[0] / VBI_FILM_TILE;
    pc.tile_y0 = f->crop[1] / VBI_FILM_TILE;
    pc.tiles_x = (f->crop[2] + VBI_FILM_TILE - 1) / VBI_FILM_TILE - pc.tile_x0;
    uint32_t tiles_y = (f->crop[3] + VBI_FILM_TILE - 1) / VBI_FILM_TILE - pc.tile_y0;
    pc.tile_count = (uint64_t)pc.tiles_x * tiles_y;
    pc.progress = progress;
    pc.user = user;
    pc.t_render_start = vbi_now();
    double interval = r->settings.progress_interval > 0.0f ? r->settings.progress_interval : 0.25;
    const uint32_t target = r->settings.spp;       /* 0 = time budget only */
    const double budget = r->settings.time_budget; /* 0 = none */
    uint32_t pass_spp = 1;
    double sec_per_spp = 0.0;
    while (!pc.cancelled) {
        if (target > 0 && r->spp_done >= target)
            break;
        double now = vbi_now();
        if (budget > 0.0 && r->spp_done > 0 && now - r->t_start >= budget)
            break;
        /* Pass size: grow geometrically for quick previews; under a time budget, aim the pass
         * at the remaining time so the last pass does not overrun by much. */
        if (budget > 0.0 && sec_per_spp > 0.0) {
            double left = budget - (now - r->t_start);
            double fit = floor(left / sec_per_spp);
            if (fit < 1.0)
                fit = 1.0;
            if ((double)pass_spp > fit)
                pass_spp = (uint32_t)fit;
        }
        if (target > 0 && r->spp_done + pass_spp > target)
            pass_spp = target - r->spp_done;
        pc.sample_begin = r->spp_done;
        pc.sample_end = r->spp_done + pass_spp;
        /* The budget's wall clock: after the first pass (an image needs every pixel), a tile that
         * would start after the budget is left out; the tiles in flight finish. */
        pc.deadline = budget > 0.0 && r->spp_done > 0 ? r->t_start + budget : 0.0;
        double t0 = vbi_now();
        uint64_t ran = vbi_pool_run(r->ctx->pool, pc.tile_count, run_tile, &pc, pass_poll, &pc, interval);
        double dt = vbi_now() - t0;
        r->passes++;
        if (ran < pc.tile_count)
            break; /* cancelled mid-pass: finished tiles keep their samples */
        if (__atomic_load_n(&pc.cut, __ATOMIC_RELAXED)) {
            r->budget_cut = 1; /* the rendered tiles keep their samples; spp counts whole passes */
            break;
        }
        r->spp_done = pc.sample_end;
        sec_per_spp = dt / pass_spp;
        if (pass_spp < 64 && dt < 2.0)
            pass_spp *= 2;
    }
    double spent = vbi_now() - pc.t_render_start;
    r->render_seconds += spent;
    record_stage(r, "render", spent, 0.0, NULL);
    if (pc.cancelled) {
        r->cancelled = 1;
        return vbnl_error_set(err, VBNL_ERR_CANCELLED, "rendering was cancelled after %u samples per pixel",
                              r->spp_done);
    }
    return VBNL_OK;
}

vbnl_result vbnl_renderer_get_stats(const vbnl_renderer *r, vbnl_render_stats *out, vbnl_error *err)
{
    if (!r || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_renderer_get_stats: NULL argument");
    memset(out, 0, sizeof(*out));
    out->passes = r->passes;
    out->spp = r->spp_done;
    for (unsigned i = 0; i < r->ctx->threads; ++i) {
        out->rays += r->tstats[i].rays;
        out->samples += r->tstats[i].samples;
        out->camera_rays += r->tstats[i].camera_rays;
        out->shadow_rays += r->tstats[i].shadow_rays;
    }
    out->prepare_seconds = r->prepare_seconds;
    out->render_seconds = r->render_seconds;
    out->stage_count = r->stage_count;
    out->stages = r->stages;
    out->cancelled = r->cancelled;
    out->storage_bytes = r->storage_bytes;
    out->choice_count = r->budget.count;
    out->choices = r->budget.choices;
    out->prepare_limit = vbnl_budget_prepare_limit(&r->budget);
    out->budget_cut = r->budget_cut;
    return VBNL_OK;
}
