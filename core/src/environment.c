/* The directional environment: radiance of a pigment stack on the unit sphere and its
 * importance-sampling table (environment.h). */
#include "environment.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

vbi_env *vbi_env_create(const vbnl_environment_desc *d, const vbi_texture_set *tex)
{
    vbi_env *e = calloc(1, sizeof(*e));
    if (!e)
        return NULL;
    e->pigments = malloc(sizeof(uint32_t) * (d->pigment_count ? d->pigment_count : 1));
    if (!e->pigments) {
        free(e);
        return NULL;
    }
    memcpy(e->pigments, d->pigments, sizeof(uint32_t) * d->pigment_count);
    e->count = d->pigment_count;
    e->tex = tex;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            e->xf.m[r][c] = d->pattern_from_world[4 * r + c];
    e->emission = v3_load(d->emission);
    e->background = v3_load(d->background);
    e->legacy = d->legacy_layers != 0;
    return e;
}

void vbi_env_unbake(vbi_env *e)
{
    if (!e)
        return;
    vbi_alias_table_free(&e->table);
    e->baked = 0;
    e->constant = 0;
    e->mean = v3s(0.0f);
}

void vbi_env_destroy(vbi_env *e)
{
    if (!e)
        return;
    vbi_env_unbake(e);
    free(e->pigments);
    free(e);
}

/* Negative or non-finite components to 0. */
static vec3 env_clamp(const double c[3])
{
    vec3 out = v3((float)fmax(c[0], 0.0), (float)fmax(c[1], 0.0), (float)fmax(c[2], 0.0));
    return v3_is_finite(out) ? out : v3s(0.0f);
}

/* POV-Ray's composition for scenes before #version 3.7 (its renderer keeps the old rule for
 * them): a layer's weight is (1 - filter - transmit) times the product of the filter and
 * transmit sums of the layers above (a scalar, not the colour they let through), the emission
 * scales the layers' sum, and the background shows through the product of the layers' colours
 * times their filters plus their transmits. */
static vec3 env_compose_legacy(const vbi_env *e, dvec3 q, const vbi_shade_point *sp)
{
    double col[3] = {0.0, 0.0, 0.0}, prod[5] = {1.0, 1.0, 1.0, 1.0, 1.0}, trans = 1.0;
    for (uint32_t i = e->count; i-- > 0;) {
        float c[5];
        vbi_pigment_eval(e->tex, e->pigments[i], q, sp, c);
        double att = trans * (1.0 - (double)c[3] - (double)c[4]);
        for (int k = 0; k < 5; ++k) {
            if (k < 3)
                col[k] += (double)c[k] * att;
            prod[k] *= c[k];
        }
        trans = fabs(prod[3]) + fabs(prod[4]);
    }
    const double em[3] = {e->emission.x, e->emission.y, e->emission.z};
    const double bg[3] = {e->background.x, e->background.y, e->background.z};
    for (int k = 0; k < 3; ++k)
        col[k] = col[k] * em[k] + bg[k] * (prod[k] * prod[3] + prod[4]);
    return env_clamp(col);
}

/* The layers composed at pattern point q (environment.h), in double precision as the pigments. */
static vec3 env_compose(const vbi_env *e, dvec3 q, dvec3 d)
{
    /* No surface: the shade point is the sky point itself, its normal faces the viewer at the
     * sphere's centre, and the eye is that centre. */
    vbi_shade_point sp = {.p = q, .n = d3(-d.x, -d.y, -d.z), .u = 0.0, .v = 0.0, .eye = d3(0.0, 0.0, 0.0)};
    if (e->legacy)
        return env_compose_legacy(e, q, &sp);
    double col[3] = {0.0, 0.0, 0.0}, through[3] = {1.0, 1.0, 1.0};
    const float em[3] = {e->emission.x, e->emission.y, e->emission.z};
    const float bg[3] = {e->background.x, e->background.y, e->background.z};
    for (uint32_t i = e->count; i-- > 0;) {
        float c[5];
        vbi_pigment_eval(e->tex, e->pigments[i], q, &sp, c);
        double opacity = 1.0 - (double)c[3] - (double)c[4];
        for (int k = 0; k < 3; ++k) {
            col[k] += (double)c[k] * opacity * through[k] * em[k];
            through[k] *= (double)c[k] * c[3] + c[4];
        }
    }
    for (int k = 0; k < 3; ++k)
        col[k] += bg[k] * through[k];
    return env_clamp(col);
}

vec3 vbi_env_radiance(const vbi_env *e, vec3 d)
{
    if (e->constant)
        return e->mean;
    dvec3 dd = d3(d.x, d.y, d.z);
    return env_compose(e, dmat_point(&e->xf, dd), dd);
}

/* ---- the table --------------------------------------------------------------------------- */

#define ENV_DPHI (2.0 * M_PI / VBI_ENV_TABLE_COLS)
#define ENV_DTHETA (M_PI / VBI_ENV_TABLE_ROWS)
#define ENV_EDGE 1e-4

/* Solid angle of the cells of `row`: dphi (cos theta0 - cos theta1). */
static double env_row_solid_angle(uint32_t row)
{
    return ENV_DPHI * (cos(row * ENV_DTHETA) - cos((row + 1) * ENV_DTHETA));
}

/* 1 when every layer is a solid colour: the sky is then constant. */
static int env_is_constant(const vbi_env *e)
{
    for (uint32_t i = 0; i < e->count; ++i)
        if (e->tex->pigments[e->pigments[i]].kind != VBNL_PIGMENT_SOLID)
            return 0;
    return 1;
}

/* One row of the table: its cells' weights (solid angle times mean radiance) and the row's
 * radiance integral per channel. */
typedef struct env_bake_job {
    const vbi_env *e;
    float *w;          /* ROWS * COLS */
    double *row_sum;   /* ROWS * 3 */
} env_bake_job;

static void env_bake_row(const env_bake_job *job, uint32_t row)
{
    const double omega = env_row_solid_angle(row);
    const double z0 = cos(row * ENV_DTHETA), z1 = cos((row + 1) * ENV_DTHETA);
    double sum[3] = {0.0, 0.0, 0.0};
    for (uint32_t col = 0; col < VBI_ENV_TABLE_COLS; ++col) {
        /* a 2 x 2 grid in the cell (equal steps in cos theta and phi: equal solid angles) */
        double cell[3] = {0.0, 0.0, 0.0};
        for (int k = 0; k < 4; ++k) {
            double z = z0 + (z1 - z0) * (0.25 + 0.5 * (k >> 1));
            double phi = (col + 0.25 + 0.5 * (k & 1)) * ENV_DPHI;
            double r = sqrt(fmax(1.0 - z * z, 0.0));
            dvec3 d = d3(r * cos(phi), z, r * sin(phi));
            vec3 L = env_compose(job->e, dmat_point(&job->e->xf, d), d);
            cell[0] += 0.25 * L.x;
            cell[1] += 0.25 * L.y;
            cell[2] += 0.25 * L.z;
        }
        for (int c = 0; c < 3; ++c)
            sum[c] += cell[c] * omega;
        job->w[row * VBI_ENV_TABLE_COLS + col] = (float)((cell[0] + cell[1] + cell[2]) / 3.0 * omega);
    }
    memcpy(job->row_sum + 3 * row, sum, sizeof(sum));
}

int vbi_env_bake(vbi_env *e)
{
    if (e->baked)
        return 0;
    if (env_is_constant(e)) {
        e->mean = env_compose(e, d3(0.0, 1.0, 0.0), d3(0.0, 1.0, 0.0));
        e->constant = 1;
        e->baked = 1;
        return 0;
    }
    const uint32_t n = VBI_ENV_TABLE_ROWS * VBI_ENV_TABLE_COLS;
    env_bake_job job = {e, malloc(sizeof(float) * n), malloc(sizeof(double) * 3 * VBI_ENV_TABLE_ROWS)};
    if (!job.w || !job.row_sum) {
        free(job.w);
        free(job.row_sum);
        return -1;
    }
    for (uint32_t row = 0; row < VBI_ENV_TABLE_ROWS; ++row)
        env_bake_row(&job, row);
    double sum[3] = {0.0, 0.0, 0.0};
    for (uint32_t row = 0; row < VBI_ENV_TABLE_ROWS; ++row)
        for (int c = 0; c < 3; ++c)
            sum[c] += job.row_sum[3 * row + c];
    free(job.row_sum);
    float *w = job.w;
    e->mean = v3((float)(sum[0] / (4.0 * M_PI)), (float)(sum[1] / (4.0 * M_PI)), (float)(sum[2] / (4.0 * M_PI)));
    double floor_radiance = 0.01 * v3_avg(e->mean);
    int rc = 0;
    if (floor_radiance > 0.0) {
        for (uint32_t row = 0; row < VBI_ENV_TABLE_ROWS; ++row) {
            float add = (float)(floor_radiance * env_row_solid_angle(row));
            for (uint32_t col = 0; col < VBI_ENV_TABLE_COLS; ++col)
                w[row * VBI_ENV_TABLE_COLS + col] += add;
        }
        rc = vbi_alias_table_build(&e->table, w, n);
    }
    free(w);
    if (rc != 0)
        return -1;
    e->baked = 1;
    return 0;
}

int vbi_env_sample(const vbi_env *e, vec2 u, vec3 *d, float *pdf)
{
    if (e->constant || e->table.n == 0) {
        *d = sample_uniform_sphere(u);
        *pdf = pdf_uniform_sphere();
        return e->constant;
    }
    float pmf, rest;
    uint32_t cell = vbi_alias_table_sample_reuse(&e->table, u.x, &pmf, &rest);
    uint32_t row = cell / VBI_ENV_TABLE_COLS, col = cell % VBI_ENV_TABLE_COLS;
    double z0 = cos(row * ENV_DTHETA), z1 = cos((row + 1) * ENV_DTHETA);
    double z = z0 + (z1 - z0) * (ENV_EDGE + (1.0 - 2.0 * ENV_EDGE) * u.y);
    /* The alias table's leftover number has few bits (about 24 - log2(cells)) and may be exactly
     * 0; a margin of 1e-4 of the cell keeps the direction off the cell's edges, where rounding
     * would move it into the neighbour (whose density vbi_env_pdf would report). */
    double phi = (col + ENV_EDGE + (1.0 - 2.0 * ENV_EDGE) * rest) * ENV_DPHI;
    double r = sqrt(fmax(1.0 - z * z, 0.0));
    *d = v3((float)(r * cos(phi)), (float)z, (float)(r * sin(phi)));
    *pdf = (float)(pmf / env_row_solid_angle(row));
    return *pdf > 0.0f;
}

float vbi_env_pdf(const vbi_env *e, vec3 d)
{
    if (e->constant || e->table.n == 0)
        return e->constant ? pdf_uniform_sphere() : 0.0f;
    double theta = acos(fmin(fmax((double)d.y, -1.0), 1.0));
    double phi = atan2((double)d.z, (double)d.x);
    if (phi < 0.0)
        phi += 2.0 * M_PI;
    uint32_t row = (uint32_t)(theta / ENV_DTHETA), col = (uint32_t)(phi / ENV_DPHI);
    if (row >= VBI_ENV_TABLE_ROWS)
        row = VBI_ENV_TABLE_ROWS - 1;
    if (col >= VBI_ENV_TABLE_COLS)
        col = VBI_ENV_TABLE_COLS - 1;
    return (float)(e->table.pmf[row * VBI_ENV_TABLE_COLS + col] / env_row_solid_angle(row));
}
