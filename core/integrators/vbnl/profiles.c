/* Emission profiles of VBNL virtual lights: incident power accumulation (photon splitting,
 * Li et al. 2022, Section 3.3), conversion to the cosine-free intensity J with the VL's BSDF,
 * eager or lazy (Section 5.3), and emitted power for the power-based selection of Eq. 4.
 * Quantities and thread rules: profiles.h. */
#include "profiles.h"

#include <stdlib.h>
#include <string.h>

#define NO_SLOT UINT32_MAX
/* Code of a texel that has not been converted yet: exponent byte 255, never produced by the
 * encoder (which saturates at 254). */
#define TEXEL_UNSET 0xFFFFFFFFu

struct vbnl_profile_kernel {
    const vbnl_hemioct *map;
    vbnl_bsdf bsdf;
    int lambert;
    vec3 rho;          /* Lambert: the colour; otherwise the cosine-weighted average albedo */
    float *albedo;     /* A_i, texels x 3 */
    float *matrix;     /* f(w_t, w_i) RGB, row t (outgoing) major, or NULL */
    uint32_t texels;
};

struct vbnl_profile_set {
    const vbnl_hemioct *map;
    uint32_t count, texels, n_glossy;
    uint32_t *slot;     /* per VL: index of its map, or NO_SLOT (Lambertian) */
    float *phi;         /* per VL: total incident power (RGB) */
    float *incident;    /* n_glossy x texels x 3 floats, NULL after release */
    uint32_t *code;     /* n_glossy x texels RGBE codes (TEXEL_UNSET until converted) */
};

/* ---- RGBE (Ward 1991), rounded to nearest -------------------------------------------------- */

static float nonneg(float v) { return v > 0.0f ? v : 0.0f; } /* also maps NaN to 0 */

static uint32_t rgbe_encode(vec3 c)
{
    /* Saturate below 2^126 so that the exponent byte stays <= 254 (255 is TEXEL_UNSET). */
    const float big = 0x1.fffffep125f;
    float r = fminf(nonneg(c.x), big), g = fminf(nonneg(c.y), big), b = fminf(nonneg(c.z), big);
    float m = fmaxf(r, fmaxf(g, b));
    if (!(m >= 0x1p-128f)) /* below the smallest exponent: stored as zero */
        return 0u;
    int e;
    frexpf(m, &e); /* m = f 2^e, f in [0.5, 1): the largest mantissa lies in [128, 256) */
    uint32_t mr = (uint32_t)(ldexpf(r, 8 - e) + 0.5f);
    uint32_t mg = (uint32_t)(ldexpf(g, 8 - e) + 0.5f);
    uint32_t mb = (uint32_t)(ldexpf(b, 8 - e) + 0.5f);
    if (mr > 255u || mg > 255u || mb > 255u) { /* rounding carried into the next exponent */
        if (e < 126) {
            ++e;
            mr = (uint32_t)(ldexpf(r, 8 - e) + 0.5f);
            mg = (uint32_t)(ldexpf(g, 8 - e) + 0.5f);
            mb = (uint32_t)(ldexpf(b, 8 - e) + 0.5f);
        }
        mr = mr > 255u ? 255u : mr;
        mg = mg > 255u ? 255u : mg;
        mb = mb > 255u ? 255u : mb;
    }
    return mr | (mg << 8) | (mb << 16) | ((uint32_t)(e + 128) << 24);
}

static vec3 rgbe_decode(uint32_t code)
{
    int ex = (int)(code >> 24);
    if (ex == 0)
        return v3s(0.0f);
    int sh = ex - 128 - 8;
    return v3(ldexpf((float)(code & 255u), sh), ldexpf((float)((code >> 8) & 255u), sh),
              ldexpf((float)((code >> 16) & 255u), sh));
}

/* ---- kernel ------------------------------------------------------------------------------ */

/* f(wo, wi) without cosines: vbnl_bsdf_eval returns f |cos theta_i| (bsdf.h); incident texel
 * centres are strictly above the horizon, so the division is safe. */
static vec3 transfer(const vbnl_bsdf *b, vec3 wo, vec3 wi)
{
    return v3_scale(vbnl_bsdf_eval(b, wo, wi), 1.0f / wi.z);
}

vbnl_result vbnl_profile_kernel_create(const vbnl_hemioct *map, const vbnl_bsdf *bsdf, int cache_matrix,
                                       vbnl_profile_kernel **out)
{
    if (!out)
        return VBNL_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!map || !bsdf)
        return VBNL_ERR_INVALID_ARGUMENT;
    uint32_t n = vbnl_hemioct_texel_count(map);
    vbnl_profile_kernel *k = calloc(1, sizeof(*k));
    if (!k)
        return VBNL_ERR_OUT_OF_MEMORY;
    k->map = map;
    k->bsdf = *bsdf;
    k->texels = n;
    k->lambert = bsdf->type == VBNL_MATERIAL_LAMBERT;
    k->albedo = malloc(3 * (size_t)n * sizeof(float));
    if (!k->albedo) {
        vbnl_profile_kernel_destroy(k);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    if (k->lambert) {
        /* Closed form: f = rho / pi, A_i = rho (sum_t C_t = pi). */
        k->rho = bsdf->color;
        for (uint32_t i = 0; i < n; ++i)
            v3_store(k->albedo + 3 * (size_t)i, bsdf->color);
        *out = k;
        return VBNL_OK;
    }
    if (cache_matrix) {
        k->matrix = malloc(3 * (size_t)n * n * sizeof(float));
        if (!k->matrix) {
            vbnl_profile_kernel_destroy(k);
            return VBNL_ERR_OUT_OF_MEMORY;
        }
    }
    double *acc = calloc(3 * (size_t)n, sizeof(double));
    if (!acc) {
        vbnl_profile_kernel_destroy(k);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    const vec3 *dir = vbnl_hemioct_texel_dirs(map);
    const float *cproj = vbnl_hemioct_bilinear_projected(map);
    for (uint32_t t = 0; t < n; ++t) {
        for (uint32_t i = 0; i < n; ++i) {
            vec3 f = transfer(bsdf, dir[t], dir[i]);
            if (k->matrix)
                v3_store(k->matrix + 3 * ((size_t)t * n + i), f);
            /* A_i = sum_t f(w_t, w_i) C_t: power emitted by the bilinear profile per unit
             * incident power in texel i. */
            acc[3 * i + 0] += (double)f.x * cproj[t];
            acc[3 * i + 1] += (double)f.y * cproj[t];
            acc[3 * i + 2] += (double)f.z * cproj[t];
        }
    }
    double rho[3] = {0.0, 0.0, 0.0};
    for (uint32_t i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) {
            k->albedo[3 * i + c] = (float)acc[3 * i + c];
            rho[c] += acc[3 * i + c] * cproj[i];
        }
    }
    k->rho = v3((float)(rho[0] / M_PI), (float)(rho[1] / M_PI), (float)(rho[2] / M_PI));
    free(acc);
    *out = k;
    return VBNL_OK;
}

void vbnl_profile_kernel_destroy(vbnl_profile_kernel *k)
{
    if (!k)
        return;
    free(k->albedo);
    free(k->matrix);
    free(k);
}

vec3 vbnl_profile_kernel_albedo(const vbnl_profile_kernel *k, uint32_t i)
{
    return v3_load(k->albedo + 3 * (size_t)i);
}

vec3 vbnl_profile_kernel_diffuse_albedo(const vbnl_profile_kernel *k) { return k->rho; }

size_t vbnl_profile_kernel_bytes(const vbnl_profile_kernel *k)
{
    size_t n = k->texels;
    return sizeof(*k) + 3 * n * sizeof(float) + (k->matrix ? 3 * n * n * sizeof(float) : 0);
}

/* ---- set --------------------------------------------------------------------------------- */

vbnl_result vbnl_profile_set_create(const vbnl_hemioct *map, uint32_t count, const uint8_t *glossy,
                                    vbnl_profile_set **out)
{
    if (!out)
        return VBNL_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!map)
        return VBNL_ERR_INVALID_ARGUMENT;
    vbnl_profile_set *s = calloc(1, sizeof(*s));
    if (!s)
        return VBNL_ERR_OUT_OF_MEMORY;
    s->map = map;
    s->count = count;
    s->texels = vbnl_hemioct_texel_count(map);
    s->slot = malloc(((size_t)count + 1) * sizeof(uint32_t));
    s->phi = calloc(3 * (size_t)count + 1, sizeof(float));
    if (!s->slot || !s->phi) {
        vbnl_profile_set_destroy(s);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    for (uint32_t v = 0; v < count; ++v)
        s->slot[v] = glossy && glossy[v] ? s->n_glossy++ : NO_SLOT;
    if (s->n_glossy) {
        size_t cells = (size_t)s->n_glossy * s->texels;
        s->incident = calloc(3 * cells, sizeof(float));
        s->code = malloc(cells * sizeof(uint32_t));
        if (!s->incident || !s->code) {
            vbnl_profile_set_destroy(s);
            return VBNL_ERR_OUT_OF_MEMORY;
        }
        memset(s->code, 0xFF, cells * sizeof(uint32_t)); /* TEXEL_UNSET */
    }
    *out = s;
    return VBNL_OK;
}

void vbnl_profile_set_destroy(vbnl_profile_set *s)
{
    if (!s)
        return;
    free(s->slot);
    free(s->phi);
    free(s->incident);
    free(s->code);
    free(s);
}

uint32_t vbnl_profile_set_count(const vbnl_profile_set *s) { return s->count; }
int vbnl_profile_is_glossy(const vbnl_profile_set *s, uint32_t vl) { return s->slot[vl] != NO_SLOT; }

size_t vbnl_profile_set_bytes(const vbnl_profile_set *s)
{
    size_t cells = (size_t)s->n_glossy * s->texels;
    return sizeof(*s) + ((size_t)s->count + 1) * sizeof(uint32_t) + (3 * (size_t)s->count + 1) * sizeof(float) +
           cells * sizeof(uint32_t) + (s->incident ? 3 * cells * sizeof(float) : 0);
}

/* ---- photon splitting -------------------------------------------------------------------- */

static void atomic_add_float(float *p, float v)
{
    if (v == 0.0f)
        return;
    float old, sum;
    __atomic_load(p, &old, __ATOMIC_RELAXED);
    do {
        sum = old + v;
    } while (!__atomic_compare_exchange(p, &old, &sum, 1, __ATOMIC_RELAXED, __ATOMIC_RELAXED));
}

void vbnl_profile_deposit(vbnl_profile_set *s, uint32_t vl, vec3 wi, vec3 power)
{
    float *phi = s->phi + 3 * (size_t)vl;
    atomic_add_float(phi + 0, power.x);
    atomic_add_float(phi + 1, power.y);
    atomic_add_float(phi + 2, power.z);
    uint32_t slot = s->slot[vl];
    if (slot != NO_SLOT && s->incident)
        vbnl_hemioct_splat_atomic(s->map, s->incident + 3 * (size_t)slot * s->texels, wi, power);
}

vec3 vbnl_profile_incident_power(const vbnl_profile_set *s, uint32_t vl)
{
    return v3_load(s->phi + 3 * (size_t)vl);
}

const float *vbnl_profile_incident_map(const vbnl_profile_set *s, uint32_t vl)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT || !s->incident)
        return NULL;
    return s->incident + 3 * (size_t)slot * s->texels;
}

/* ---- conversion -------------------------------------------------------------------------- */

/* J_t = sum_i f(w_t, w_i) Phi_i (profiles.h). Both paths add the same products in the same
 * order, so cached and uncached kernels agree; zero incident texels are skipped (adding an exact
 * zero product would not change the sum). */
static vec3 compute_texel(const vbnl_profile_set *s, uint32_t slot, const vbnl_profile_kernel *k, uint32_t t)
{
    const float *in = s->incident + 3 * (size_t)slot * s->texels;
    uint32_t n = s->texels;
    vec3 acc = v3s(0.0f);
    if (k->matrix) {
        const float *row = k->matrix + 3 * (size_t)t * n;
        for (uint32_t i = 0; i < n; ++i) {
            const float *p = in + 3 * (size_t)i;
            if (p[0] == 0.0f && p[1] == 0.0f && p[2] == 0.0f)
                continue;
            const float *f = row + 3 * (size_t)i;
            acc.x += f[0] * p[0];
            acc.y += f[1] * p[1];
            acc.z += f[2] * p[2];
        }
    } else {
        const vec3 *dir = vbnl_hemioct_texel_dirs(s->map);
        vec3 wo = dir[t];
        for (uint32_t i = 0; i < n; ++i) {
            const float *p = in + 3 * (size_t)i;
            if (p[0] == 0.0f && p[1] == 0.0f && p[2] == 0.0f)
                continue;
            vec3 f = transfer(&k->bsdf, wo, dir[i]);
            acc.x += f.x * p[0];
            acc.y += f.y * p[1];
            acc.z += f.z * p[2];
        }
    }
    return acc;
}

/* Lazy fill of one texel (profiles.h, Threads): idempotent, lock-free. */
static uint32_t texel_code(vbnl_profile_set *s, uint32_t slot, const vbnl_profile_kernel *k, uint32_t t)
{
    uint32_t *cell = s->code + (size_t)slot * s->texels + t;
    uint32_t code = __atomic_load_n(cell, __ATOMIC_ACQUIRE);
    if (code != TEXEL_UNSET)
        return code;
    if (!s->incident) /* released before conversion: a caller error, emit nothing */
        return 0u;
    code = rgbe_encode(compute_texel(s, slot, k, t));
    __atomic_store_n(cell, code, __ATOMIC_RELEASE);
    return code;
}

/* Lambertian VL (no map): J = rho / pi Phi_in; a non-Lambertian kernel contributes its
 * cosine-weighted average albedo (diffuse approximation, profiles.h). */
static vec3 lambert_J(const vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k)
{
    return v3_mul(vbnl_profile_incident_power(s, vl), v3_scale(k->rho, VBNL_INV_PI));
}

void vbnl_profile_convert(vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return;
    for (uint32_t t = 0; t < s->texels; ++t)
        texel_code(s, slot, k, t);
}

vbnl_result vbnl_profile_set_release_incident(vbnl_profile_set *s)
{
    if (!s)
        return VBNL_ERR_INVALID_ARGUMENT;
    size_t cells = (size_t)s->n_glossy * s->texels;
    for (size_t c = 0; c < cells; ++c)
        if (s->code[c] == TEXEL_UNSET)
            return VBNL_ERR_STATE;
    free(s->incident);
    s->incident = NULL;
    return VBNL_OK;
}

vec3 vbnl_profile_texel(vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k, uint32_t t)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return lambert_J(s, vl, k);
    return rgbe_decode(texel_code(s, slot, k, t));
}

vec3 vbnl_profile_eval(vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k, vec3 wo)
{
    if (!(wo.z > 0.0f))
        return v3s(0.0f);
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return lambert_J(s, vl, k);
    uint32_t idx[4];
    float wgt[4];
    vbnl_hemioct_bilinear(s->map, wo, idx, wgt);
    vec3 r = v3s(0.0f);
    for (int c = 0; c < 4; ++c)
        if (wgt[c] > 0.0f)
            r = v3_fma(r, rgbe_decode(texel_code(s, slot, k, idx[c])), wgt[c]);
    return r;
}

vec3 vbnl_profile_intensity(vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k, vec3 wo)
{
    float len = v3_len(wo);
    if (!(wo.z > 0.0f) || !(len > 0.0f))
        return v3s(0.0f);
    return v3_scale(vbnl_profile_eval(s, vl, k, wo), wo.z / len);
}

vec3 vbnl_profile_power(const vbnl_profile_set *s, uint32_t vl, const vbnl_profile_kernel *k)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return v3_mul(vbnl_profile_incident_power(s, vl), k->rho);
    if (!s->incident) {
        /* Maps released: integrate the stored (quantised) profile, sum_t J_t C_t. */
        const float *cproj = vbnl_hemioct_bilinear_projected(s->map);
        const uint32_t *codes = s->code + (size_t)slot * s->texels;
        double p[3] = {0.0, 0.0, 0.0};
        for (uint32_t t = 0; t < s->texels; ++t) {
            vec3 j = rgbe_decode(codes[t]);
            p[0] += (double)j.x * cproj[t];
            p[1] += (double)j.y * cproj[t];
            p[2] += (double)j.z * cproj[t];
        }
        return v3((float)p[0], (float)p[1], (float)p[2]);
    }
    /* P_j = sum_i Phi_i A_i (profiles.h): the power of the unquantised bilinear profile. */
    const float *in = s->incident + 3 * (size_t)slot * s->texels;
    double p[3] = {0.0, 0.0, 0.0};
    for (uint32_t i = 0; i < s->texels; ++i)
        for (int c = 0; c < 3; ++c)
            p[c] += (double)in[3 * i + c] * k->albedo[3 * i + c];
    return v3((float)p[0], (float)p[1], (float)p[2]);
}

int vbnl_profile_texel_converted(const vbnl_profile_set *s, uint32_t vl, uint32_t t)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return 1;
    return __atomic_load_n(s->code + (size_t)slot * s->texels + t, __ATOMIC_ACQUIRE) != TEXEL_UNSET;
}
