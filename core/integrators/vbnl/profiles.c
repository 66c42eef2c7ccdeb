/* Emission profiles of VBNL virtual lights: incident power accumulation (photon splitting,
 * Li et al. 2022, Section 3.3), conversion to the cosine-free intensity J with the VL's BSDF,
 * eager or lazy (Section 5.3), and emitted power for the power-based selection of Eq. 4.
 * Quantities and thread rules: profiles.h. */
#include "bigalloc.h"
#include "profiles.h"

#include <stdlib.h>
#include <string.h>

#define NO_SLOT VBI_PROFILE_NO_SLOT
/* Code of a texel that has not been converted yet: exponent byte 255, never produced by the
 * encoder (which saturates at 254). */
#define TEXEL_UNSET 0xFFFFFFFFu

struct vbi_profile_kernel {
    const vbi_hemioct *map;
    vbi_bsdf bsdf;
    int lambert;
    vec3 rho;          /* Lambert: the colour; otherwise the cosine-weighted average albedo */
    float *albedo;     /* A_i, texels x 3 */
    float *matrix;     /* f(w_t, w_i) RGB, row t (outgoing) major, or NULL */
    uint32_t texels;
};

struct vbi_profile_set {
    const vbi_hemioct *map;
    uint32_t count, texels, n_glossy;
    double unit, inv_unit; /* W per fixed-point step (a power of two) and its inverse */
    uint32_t *slot;     /* per VL: index of its map, or NO_SLOT (Lambertian) */
    uint64_t *phi;      /* per VL: total incident power (RGB, fixed point) */
    uint64_t *incident; /* n_glossy x texels x 3 fixed-point values, NULL after release */
    uint32_t *code;     /* n_glossy x texels RGBE codes (TEXEL_UNSET until converted) */
};

/* A fixed-point value in W (exact in double below 2^53 steps, then rounded once to float). */
static inline float fixed_to_float(const vbi_profile_set *s, uint64_t q) { return (float)((double)q * s->unit); }

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
    uint32_t mr, mg, mb;
    if (m >= 0x1p-100f) {
        /* m normal: e from its exponent bits, and 2^(8-e) (a normal float for these e) built
         * from its bits; a product with a power of two is rounded as ldexpf rounds, so the
         * codes are those of the library path below, at a fraction of its cost (conversion
         * encodes every texel) */
        union {
            float f;
            uint32_t u;
        } bits = {m}, scale;
        e = (int)((bits.u >> 23) & 255u) - 126; /* m = f 2^e, f in [0.5, 1) */
        scale.u = (uint32_t)(127 + 8 - e) << 23;
        mr = (uint32_t)(r * scale.f + 0.5f);
        mg = (uint32_t)(g * scale.f + 0.5f);
        mb = (uint32_t)(b * scale.f + 0.5f);
    } else {
        frexpf(m, &e); /* m = f 2^e, f in [0.5, 1): the largest mantissa lies in [128, 256) */
        mr = (uint32_t)(ldexpf(r, 8 - e) + 0.5f);
        mg = (uint32_t)(ldexpf(g, 8 - e) + 0.5f);
        mb = (uint32_t)(ldexpf(b, 8 - e) + 0.5f);
    }
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
    if (sh < -126) /* a subnormal scale: rare, the library call */
        return v3(ldexpf((float)(code & 255u), sh), ldexpf((float)((code >> 8) & 255u), sh),
                  ldexpf((float)((code >> 16) & 255u), sh));
    /* 2^sh built from its bits; an 8-bit integer times a power of two is exact, as ldexpf */
    union {
        uint32_t u;
        float f;
    } scale = {(uint32_t)(sh + 127) << 23};
    return v3((float)(code & 255u) * scale.f, (float)((code >> 8) & 255u) * scale.f,
              (float)((code >> 16) & 255u) * scale.f);
}

/* ---- kernel ------------------------------------------------------------------------------ */

/* f(wo, wi) without cosines: vbi_bsdf_eval returns f |cos theta_i| (bsdf.h); incident texel
 * centres are strictly above the horizon, so the division is safe. */
static vec3 transfer(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    return v3_scale(vbi_bsdf_eval(b, wo, wi), 1.0f / wi.z);
}

static vec3 transfer_microfacet(const vbi_bsdf *b, vec3 wo, vec3 wi)
{
    return v3_scale(vbi_bsdf_eval_microfacet(b, wo, wi), 1.0f / wi.z);
}

/* Narrow lobes. f point-sampled at texel-centre pairs is right for lobes several texels wide,
 * but a GGX lobe narrower than a texel is missed or hit at its peak: at 16 x 16 the kernel's
 * albedo sum_t f(w_t, w_i) C_t, weighted over the incident texels, is 1.12 x the true albedo
 * for a conductor of alpha 0.1, 1.58 x at 0.063 and 46 x at 0.01 (and 1.002 x at 0.3). So
 * where alpha R < MF_POINT_RA the microfacet lobe (bsdf.h) is projected onto the texels
 * instead: J_t gets (1 / C_t) int f(w, w_i) cos theta b_t(w) dw, b_t the bilinear weight of
 * texel t, which keeps the lobe's energy exactly (sum_t b_t = 1) and blurs it over a texel. The
 * integral is a MF_QUAD^2 midpoint rule over the lobe's visible-normal sampling, each sample
 * splatted bilinearly. Between MF_PROJ_RA and MF_POINT_RA both forms are blended linearly in
 * alpha R, so profiles change continuously with roughness. */
#define MF_POINT_RA 4.8f
#define MF_PROJ_RA 2.4f
#define MF_QUAD 32u

/* The projected share of a BSDF's microfacet lobe at resolution res (0: point sampling only). */
static float microfacet_share(const vbi_bsdf *b, uint32_t res)
{
    if (b->type != VBNL_MATERIAL_CONDUCTOR && b->type != VBNL_MATERIAL_PLASTIC)
        return 0.0f;
    float ra = b->alpha * (float)res;
    return ra >= MF_POINT_RA ? 0.0f : ra <= MF_PROJ_RA ? 1.0f : (MF_POINT_RA - ra) / (MF_POINT_RA - MF_PROJ_RA);
}

/* k->matrix = share x the projected microfacet lobe (above). */
static void project_microfacet(vbi_profile_kernel *k, float share)
{
    const uint32_t n = k->texels, res = vbi_hemioct_res(k->map);
    const vec3 *dir = vbi_hemioct_texel_dirs(k->map);
    const float *cproj = vbi_hemioct_bilinear_projected(k->map);
    memset(k->matrix, 0, 3 * (size_t)n * n * sizeof(float));
    const float scale = share / (float)(MF_QUAD * MF_QUAD);
    for (uint32_t i = 0; i < n; ++i) {
        for (uint32_t a = 0; a < MF_QUAD; ++a)
            for (uint32_t c = 0; c < MF_QUAD; ++c) {
                vec2 u = {((float)a + 0.5f) / (float)MF_QUAD, ((float)c + 0.5f) / (float)MF_QUAD};
                vec3 w;
                float pdf;
                if (!vbi_bsdf_sample_microfacet(&k->bsdf, dir[i], u, &w, &pdf))
                    continue;
                /* f(w, w_i) cos theta_w / pdf: the lobe is reciprocal, so eval from w_i */
                vec3 wt = v3_scale(vbi_bsdf_eval_microfacet(&k->bsdf, dir[i], w), scale / pdf);
                uint32_t idx[4];
                float wgt[4];
                vbi_hemioct_footprint(res, w, idx, wgt);
                for (int q = 0; q < 4; ++q) {
                    float *m = k->matrix + 3 * ((size_t)idx[q] * n + i);
                    m[0] += wt.x * wgt[q];
                    m[1] += wt.y * wgt[q];
                    m[2] += wt.z * wgt[q];
                }
            }
    }
    for (uint32_t t = 0; t < n; ++t) {
        float inv = 1.0f / cproj[t];
        for (uint32_t i = 0; i < 3 * n; ++i)
            k->matrix[3 * (size_t)t * n + i] *= inv;
    }
}

vbnl_result vbi_profile_kernel_create(const vbi_hemioct *map, const vbi_bsdf *bsdf, int cache_matrix,
                                       vbi_profile_kernel **out)
{
    if (!out)
        return VBNL_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!map || !bsdf)
        return VBNL_ERR_INVALID_ARGUMENT;
    uint32_t n = vbi_hemioct_texel_count(map);
    vbi_profile_kernel *k = calloc(1, sizeof(*k));
    if (!k)
        return VBNL_ERR_OUT_OF_MEMORY;
    k->map = map;
    k->bsdf = *bsdf;
    k->texels = n;
    k->lambert = bsdf->type == VBNL_MATERIAL_LAMBERT;
    k->albedo = malloc(3 * (size_t)n * sizeof(float));
    if (!k->albedo) {
        vbi_profile_kernel_destroy(k);
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
    const float proj = microfacet_share(bsdf, vbi_hemioct_res(map));
    if (cache_matrix || proj > 0.0f) {
        k->matrix = malloc(3 * (size_t)n * n * sizeof(float));
        if (!k->matrix) {
            vbi_profile_kernel_destroy(k);
            return VBNL_ERR_OUT_OF_MEMORY;
        }
    }
    double *acc = calloc(3 * (size_t)n, sizeof(double));
    if (!acc) {
        vbi_profile_kernel_destroy(k);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    const vec3 *dir = vbi_hemioct_texel_dirs(map);
    const float *cproj = vbi_hemioct_bilinear_projected(map);
    if (proj > 0.0f)
        project_microfacet(k, proj);
    for (uint32_t t = 0; t < n; ++t) {
        for (uint32_t i = 0; i < n; ++i) {
            vec3 f;
            if (proj > 0.0f) /* the smooth part and the point-sampled share of the lobe, then the
                              * projected share (already in the matrix) */
                f = v3_add(v3_sub(transfer(bsdf, dir[t], dir[i]),
                                  v3_scale(transfer_microfacet(bsdf, dir[t], dir[i]), proj)),
                           v3_load(k->matrix + 3 * ((size_t)t * n + i)));
            else
                f = transfer(bsdf, dir[t], dir[i]);
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

void vbi_profile_kernel_destroy(vbi_profile_kernel *k)
{
    if (!k)
        return;
    free(k->albedo);
    free(k->matrix);
    free(k);
}

vec3 vbi_profile_kernel_albedo(const vbi_profile_kernel *k, uint32_t i)
{
    return v3_load(k->albedo + 3 * (size_t)i);
}

vec3 vbi_profile_kernel_diffuse_albedo(const vbi_profile_kernel *k) { return k->rho; }

size_t vbi_profile_kernel_bytes(const vbi_profile_kernel *k)
{
    size_t n = k->texels;
    return sizeof(*k) + 3 * n * sizeof(float) + (k->matrix ? 3 * n * n * sizeof(float) : 0);
}

/* ---- set --------------------------------------------------------------------------------- */

double vbi_profile_unit_for_power(double typical_power)
{
    double u = typical_power * 0x1p-24;
    if (!(u > 0x1p-200) || !isfinite(u)) /* nothing sensible: the default */
        return VBI_PROFILE_DEFAULT_UNIT;
    int e;
    frexp(u, &e); /* u = f 2^e, f in [0.5, 1): 2^(e-1) <= u */
    return ldexp(1.0, e - 1);
}

vbnl_result vbi_profile_set_create(const vbi_hemioct *map, uint32_t count, const uint8_t *glossy,
                                    vbi_profile_set **out)
{
    return vbi_profile_set_create_fixed(map, count, glossy, VBI_PROFILE_DEFAULT_UNIT, out);
}

vbnl_result vbi_profile_set_create_fixed(const vbi_hemioct *map, uint32_t count, const uint8_t *glossy,
                                          double unit, vbi_profile_set **out)
{
    if (!out)
        return VBNL_ERR_INVALID_ARGUMENT;
    *out = NULL;
    int e;
    if (!map || !(unit > 0.0) || !isfinite(unit) || frexp(unit, &e) != 0.5)
        return VBNL_ERR_INVALID_ARGUMENT; /* the unit must be a power of two */
    vbi_profile_set *s = calloc(1, sizeof(*s));
    if (!s)
        return VBNL_ERR_OUT_OF_MEMORY;
    s->map = map;
    s->count = count;
    s->texels = vbi_hemioct_texel_count(map);
    s->unit = unit;
    s->inv_unit = 1.0 / unit; /* exact: a power of two */
    s->slot = malloc(((size_t)count + 1) * sizeof(uint32_t));
    s->phi = calloc(3 * (size_t)count + 1, sizeof(uint64_t));
    if (!s->slot || !s->phi) {
        vbi_profile_set_destroy(s);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    for (uint32_t v = 0; v < count; ++v)
        s->slot[v] = glossy && glossy[v] ? s->n_glossy++ : NO_SLOT;
    if (s->n_glossy) {
        size_t cells = (size_t)s->n_glossy * s->texels;
        s->incident = vbi_big_calloc(3 * cells, sizeof(uint64_t));
        /* 64-byte aligned: a light's map then starts a line and a texel row of 16 is one line */
        s->code = aligned_alloc(64, (cells * sizeof(uint32_t) + 63) & ~(size_t)63);
        if (!s->incident || !s->code) {
            vbi_profile_set_destroy(s);
            return VBNL_ERR_OUT_OF_MEMORY;
        }
        memset(s->code, 0xFF, cells * sizeof(uint32_t)); /* TEXEL_UNSET */
    }
    *out = s;
    return VBNL_OK;
}

void vbi_profile_set_destroy(vbi_profile_set *s)
{
    if (!s)
        return;
    free(s->slot);
    free(s->phi);
    free(s->incident);
    free(s->code);
    free(s);
}

uint32_t vbi_profile_set_count(const vbi_profile_set *s) { return s->count; }
int vbi_profile_is_glossy(const vbi_profile_set *s, uint32_t vl) { return s->slot[vl] != NO_SLOT; }

size_t vbi_profile_set_bytes(const vbi_profile_set *s)
{
    size_t cells = (size_t)s->n_glossy * s->texels;
    return sizeof(*s) + ((size_t)s->count + 1) * sizeof(uint32_t) + (3 * (size_t)s->count + 1) * sizeof(uint64_t) +
           cells * sizeof(uint32_t) + (s->incident ? 3 * cells * sizeof(uint64_t) : 0);
}

/* ---- photon splitting: 64-bit fixed point (profiles.h, "Fixed point") --------------------- */

double vbi_profile_set_unit(const vbi_profile_set *s) { return s->unit; }

void vbi_profile_quantize(const vbi_profile_set *s, vec3 power, uint64_t q[3])
{
    for (int c = 0; c < 3; ++c) {
        double x = (double)v3_comp(power, c) * s->inv_unit;
        if (!(x > 0.0)) /* also NaN */
            q[c] = 0;
        else
            q[c] = x < VBI_PROFILE_MAX_DEPOSIT ? (uint64_t)(x + 0.5) : (uint64_t)VBI_PROFILE_MAX_DEPOSIT;
    }
}

void vbi_profile_split_fixed(uint64_t q, uint32_t n, const float *w, uint64_t *out)
{
    /* floor(q w_k) never adds up to more than q when sum w <= 1; float weights may sum to
     * 1 + a few ulp, hence the clamp to what is left. The residue (at most n steps) goes to the
     * largest weight (first one on ties), so sum out == q exactly. */
    uint64_t left = q;
    uint32_t big = 0;
    for (uint32_t k = 0; k < n; ++k) {
        double x = (double)q * (double)(w[k] > 0.0f ? w[k] : 0.0f);
        uint64_t v = x < (double)left ? (uint64_t)x : left;
        out[k] = v;
        left -= v;
        if (w[k] > w[big])
            big = k;
    }
    out[big] += left;
}

static inline void atomic_add_u64(uint64_t *p, uint64_t v)
{
    if (v)
        __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
}

int vbi_profile_splat_prepare(vbi_profile_set *s, uint32_t vl, vec3 wi, const uint64_t q[3],
                               vbi_profile_splat *sp)
{
    return vbi_profile_splat_prepare_slot(s, s->slot[vl], wi, q, sp);
}

/* The bilinear splat of q at direction wi (octahedral.h footprint) in integers: the texels
 * idx[k] of the map receive exactly q, vbi_profile_split_fixed(q[c], 4, wgt) for the three
 * channels at once (same bits: q is below 2^53, so the conversions through int64 equal the
 * unsigned ones, and x < left ? trunc(x) : left is min(trunc(x), left)). */
static inline void splat_parts(const vbi_profile_set *s, vec3 wi, const uint64_t q[3], uint32_t idx[4],
                               uint64_t part[4][3])
{
    float wgt[4];
    vbi_hemioct_bilinear(s->map, wi, idx, wgt);
    uint64_t left[3] = {q[0], q[1], q[2]};
    double dq[3] = {(double)(int64_t)q[0], (double)(int64_t)q[1], (double)(int64_t)q[2]};
    uint32_t big = 0;
    for (int k = 0; k < 4; ++k) {
        double wk = (double)(wgt[k] > 0.0f ? wgt[k] : 0.0f);
        for (int c = 0; c < 3; ++c) {
            uint64_t v = (uint64_t)(int64_t)(dq[c] * wk);
            v = v < left[c] ? v : left[c];
            left[c] -= v;
            part[k][c] = v;
        }
        if (wgt[k] > wgt[big])
            big = (uint32_t)k;
    }
    for (int c = 0; c < 3; ++c)
        part[big][c] += left[c];
}

int vbi_profile_splat_prepare_slot(vbi_profile_set *s, uint32_t slot, vec3 wi, const uint64_t q[3],
                                    vbi_profile_splat *sp)
{
    if (slot == NO_SLOT || !s->incident)
        return 0;
    uint32_t idx[4];
    splat_parts(s, wi, q, idx, sp->part);
    uint64_t *map = s->incident + 3 * (size_t)slot * s->texels;
    for (int k = 0; k < 4; ++k) {
        sp->texel[k] = map + 3 * (size_t)idx[k];
        __builtin_prefetch(sp->texel[k], 1);
    }
    return 1;
}

int vbi_profile_splat_prepare_lo32(vbi_profile_set *s, uint32_t *lo, uint32_t slot, vec3 wi, const uint64_t q[3],
                                    vbi_profile_splat32 *sp)
{
    if (slot == NO_SLOT || !s->incident || !lo)
        return 0;
    uint32_t idx[4];
    splat_parts(s, wi, q, idx, sp->part);
    const size_t base = 3 * (size_t)slot * s->texels;
    for (int k = 0; k < 4; ++k) {
        const size_t at = base + 3 * (size_t)idx[k];
        sp->texel[k] = lo + at;
        sp->carry[k] = s->incident + at;
        __builtin_prefetch(sp->texel[k], 1);
    }
    return 1;
}

void vbi_profile_splat_apply(const vbi_profile_splat *sp)
{
    for (int k = 0; k < 4; ++k)
        for (int c = 0; c < 3; ++c)
            atomic_add_u64(sp->texel[k] + c, sp->part[k][c]);
}

void vbi_profile_splat_apply_lo32(const vbi_profile_splat32 *sp)
{
    for (int k = 0; k < 4; ++k)
        for (int c = 0; c < 3; ++c) {
            /* the 32-bit sum keeps the low half; what passes 2^32 goes to the set (rare: a texel
             * channel takes 2^7..2^8 typical photon shares before it wraps) */
            const uint64_t sum = (uint64_t)sp->texel[k][c] + sp->part[k][c];
            sp->texel[k][c] = (uint32_t)sum;
            if (sum >> 32)
                atomic_add_u64(sp->carry[k] + c, sum & ~(uint64_t)UINT32_MAX);
        }
}

size_t vbi_profile_incident_bytes(const vbi_profile_set *s)
{
    return s && s->incident ? 3 * (size_t)s->n_glossy * s->texels * sizeof(uint64_t) : 0;
}

uint64_t *vbi_profile_incident_maps(vbi_profile_set *s) { return s ? s->incident : NULL; }

vbi_profile_maps_view vbi_profile_maps_view_of(vbi_profile_set *s)
{
    if (!s)
        return (vbi_profile_maps_view){0, 0, NULL};
    return (vbi_profile_maps_view){vbi_hemioct_res(s->map), s->texels, s->incident};
}

vbnl_result vbi_profile_add_incident_lo32(vbi_profile_set *s, const uint32_t *lo)
{
    if (!s || !lo)
        return VBNL_ERR_INVALID_ARGUMENT;
    if (!s->incident)
        return VBNL_ERR_STATE; /* released */
    size_t cells = (size_t)s->n_glossy * s->texels;
    for (size_t i = 0; i < 3 * cells; ++i)
        s->incident[i] += lo[i];
    if (cells) /* converted texels came from the old data: convert again on demand */
        memset(s->code, 0xFF, cells * sizeof(uint32_t));
    return VBNL_OK;
}

void vbi_profile_deposit_map_fixed(vbi_profile_set *s, uint32_t vl, vec3 wi, const uint64_t q[3])
{
    vbi_profile_splat sp;
    if (vbi_profile_splat_prepare(s, vl, wi, q, &sp))
        vbi_profile_splat_apply(&sp);
}

void vbi_profile_add_power_fixed(vbi_profile_set *s, uint32_t vl, const uint64_t q[3])
{
    uint64_t *phi = s->phi + 3 * (size_t)vl;
    phi[0] += q[0];
    phi[1] += q[1];
    phi[2] += q[2];
}

void vbi_profile_deposit_fixed(vbi_profile_set *s, uint32_t vl, vec3 wi, const uint64_t q[3])
{
    uint64_t *phi = s->phi + 3 * (size_t)vl;
    atomic_add_u64(phi + 0, q[0]);
    atomic_add_u64(phi + 1, q[1]);
    atomic_add_u64(phi + 2, q[2]);
    vbi_profile_deposit_map_fixed(s, vl, wi, q);
}

void vbi_profile_deposit(vbi_profile_set *s, uint32_t vl, vec3 wi, vec3 power)
{
    uint64_t q[3];
    vbi_profile_quantize(s, power, q);
    vbi_profile_deposit_fixed(s, vl, wi, q);
}

vec3 vbi_profile_incident_power(const vbi_profile_set *s, uint32_t vl)
{
    const uint64_t *q = s->phi + 3 * (size_t)vl;
    return v3(fixed_to_float(s, q[0]), fixed_to_float(s, q[1]), fixed_to_float(s, q[2]));
}

const uint64_t *vbi_profile_incident_power_fixed(const vbi_profile_set *s, uint32_t vl)
{
    return s->phi + 3 * (size_t)vl;
}

const uint64_t *vbi_profile_incident_map_fixed(const vbi_profile_set *s, uint32_t vl)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT || !s->incident)
        return NULL;
    return s->incident + 3 * (size_t)slot * s->texels;
}

vec3 vbi_profile_incident_texel(const vbi_profile_set *s, uint32_t vl, uint32_t t)
{
    const uint64_t *m = vbi_profile_incident_map_fixed(s, vl);
    if (!m)
        return v3s(0.0f);
    m += 3 * (size_t)t;
    return v3(fixed_to_float(s, m[0]), fixed_to_float(s, m[1]), fixed_to_float(s, m[2]));
}

vbnl_result vbi_profile_set_merge(vbi_profile_set *dst, const vbi_profile_set *src)
{
    if (!dst || !src || dst == src)
        return VBNL_ERR_INVALID_ARGUMENT;
    if (dst->count != src->count || dst->texels != src->texels || dst->n_glossy != src->n_glossy ||
        dst->unit != src->unit)
        return VBNL_ERR_INVALID_ARGUMENT;
    for (uint32_t v = 0; v < dst->count; ++v)
        if (dst->slot[v] != src->slot[v])
            return VBNL_ERR_INVALID_ARGUMENT;
    if (dst->n_glossy && (!dst->incident || !src->incident))
        return VBNL_ERR_STATE; /* incident maps released */
    for (size_t i = 0; i < 3 * (size_t)dst->count; ++i)
        dst->phi[i] += src->phi[i];
    size_t cells = (size_t)dst->n_glossy * dst->texels;
    for (size_t i = 0; i < 3 * cells; ++i)
        dst->incident[i] += src->incident[i];
    /* Converted texels came from the old data: convert again on demand. */
    if (cells)
        memset(dst->code, 0xFF, cells * sizeof(uint32_t));
    return VBNL_OK;
}

vbnl_result vbi_profile_set_import_fixed(vbi_profile_set *s, uint32_t vl, const uint64_t phi[3],
                                          const uint64_t *map)
{
    if (!s || !phi || vl >= s->count)
        return VBNL_ERR_INVALID_ARGUMENT;
    uint32_t slot = s->slot[vl];
    if (slot != NO_SLOT) {
        if (!map)
            return VBNL_ERR_INVALID_ARGUMENT;
        if (!s->incident)
            return VBNL_ERR_STATE;
        memcpy(s->incident + 3 * (size_t)slot * s->texels, map, 3 * (size_t)s->texels * sizeof(uint64_t));
        memset(s->code + (size_t)slot * s->texels, 0xFF, s->texels * sizeof(uint32_t)); /* TEXEL_UNSET */
    }
    memcpy(s->phi + 3 * (size_t)vl, phi, 3 * sizeof(uint64_t));
    return VBNL_OK;
}

/* ---- conversion -------------------------------------------------------------------------- */

/* J_t = sum_i f(w_t, w_i) Phi_i (profiles.h). The 3n products of a texel (RGB interleaved, as
 * in the matrix rows and the incident maps) are summed in 24 fixed lanes, lane l holding channel
 * l mod 3, so the compiler vectorises the loop; every conversion path (eager, lazy, cached or
 * uncached kernel) goes through this sum, so they agree bit for bit. */
#define DOT_LANES 24

typedef float lanes8 __attribute__((vector_size(32))); /* GCC vectors: AVX, SSE or scalar */
/* Eight floats at any address, read as one vector (no function returns a vector: without AVX
 * that would change the calling convention). */
typedef float lanes8_unaligned __attribute__((vector_size(32), aligned(4), may_alias));
#define LOAD8(p) (*(const lanes8_unaligned *)(p))

static vec3 dot_lanes(const float *row, const float *phi, uint32_t m3)
{
    lanes8 a0 = {0}, a1 = {0}, a2 = {0};
    uint32_t i = 0;
    for (; i + DOT_LANES <= m3; i += DOT_LANES) {
        a0 += LOAD8(row + i) * LOAD8(phi + i);
        a1 += LOAD8(row + i + 8) * LOAD8(phi + i + 8);
        a2 += LOAD8(row + i + 16) * LOAD8(phi + i + 16);
    }
    float acc[DOT_LANES];
    memcpy(acc, &a0, sizeof a0);
    memcpy(acc + 8, &a1, sizeof a1);
    memcpy(acc + 16, &a2, sizeof a2);
    for (; i < m3; ++i) /* R^2 not a multiple of 8: 24 is a multiple of 3, channels stay apart */
        acc[i % DOT_LANES] += row[i] * phi[i];
    float c[3] = {0.0f, 0.0f, 0.0f};
    for (uint32_t l = 0; l < DOT_LANES; ++l)
        c[l % 3] += acc[l];
    return v3(c[0], c[1], c[2]);
}

/* The incident map of a slot as floats (exactly fixed_to_float of each value). */
static void incident_floats(const vbi_profile_set *s, uint32_t slot, float *phi)
{
    const uint32_t m3 = 3 * s->texels;
    const uint64_t *in = s->incident + (size_t)m3 * slot;
    for (uint32_t i = 0; i < m3; ++i)
        phi[i] = fixed_to_float(s, in[i]);
}

/* Scratch of 3 R^2 floats: on the stack up to 32 x 32 (the largest resolution the integrator
 * offers), else on the heap; NULL when that fails. */
#define STACK_TEXELS 1024u
static float *scratch(uint32_t m3, float *stack_buf)
{
    return m3 <= 3 * STACK_TEXELS ? stack_buf : malloc(sizeof(float) * m3);
}

static void scratch_free(float *p, const float *stack_buf)
{
    if (p != stack_buf)
        free(p);
}

/* One texel without a cached matrix: the row of f is evaluated (zero incident texels get a zero
 * entry without an evaluation: the product would be an exact zero either way). */
static vec3 compute_texel(const vbi_profile_set *s, uint32_t slot, const vbi_profile_kernel *k, uint32_t t)
{
    const uint32_t n = s->texels, m3 = 3 * n;
    float buf_phi[3 * STACK_TEXELS], buf_row[3 * STACK_TEXELS];
    float *phi = scratch(m3, buf_phi), *row = scratch(m3, buf_row);
    vec3 acc = v3s(0.0f);
    if (phi && row) {
        incident_floats(s, slot, phi);
        const vec3 *dir = vbi_hemioct_texel_dirs(s->map);
        vec3 wo = dir[t];
        for (uint32_t i = 0; i < n; ++i) {
            float *f = row + 3 * (size_t)i;
            if (phi[3 * i] == 0.0f && phi[3 * i + 1] == 0.0f && phi[3 * i + 2] == 0.0f)
                f[0] = f[1] = f[2] = 0.0f;
            else if (k->matrix)
                memcpy(f, k->matrix + 3 * ((size_t)t * n + i), 3 * sizeof(float));
            else
                v3_store(f, transfer(&k->bsdf, wo, dir[i]));
        }
        acc = dot_lanes(row, phi, m3);
    }
    scratch_free(row, buf_row);
    scratch_free(phi, buf_phi);
    return acc;
}

/* Every still unset texel of a slot with a cached matrix: the incident map is converted to floats
 * once, then one matrix row per texel (this is what makes conversion cheap: R^2 products of
 * 3 R^2 floats instead of 3 R^2 fixed-point conversions per texel). Idempotent and lock-free like
 * texel_code: racing threads store the same bits. Returns 0 when the scratch cannot be had. */
static int convert_slot(vbi_profile_set *s, uint32_t slot, const vbi_profile_kernel *k)
{
    const uint32_t n = s->texels, m3 = 3 * n;
    float buf[3 * STACK_TEXELS];
    float *phi = scratch(m3, buf);
    if (!phi)
        return 0;
    incident_floats(s, slot, phi);
    uint32_t *codes = s->code + (size_t)slot * n;
    for (uint32_t t = 0; t < n; ++t)
        if (__atomic_load_n(&codes[t], __ATOMIC_ACQUIRE) == TEXEL_UNSET)
            __atomic_store_n(&codes[t], rgbe_encode(dot_lanes(k->matrix + (size_t)m3 * t, phi, m3)),
                             __ATOMIC_RELEASE);
    scratch_free(phi, buf);
    return 1;
}

/* Lazy fill (profiles.h, Threads): idempotent, lock-free. With a cached matrix, the first read of
 * any unset texel converts the whole light (its other texels are read soon after: bilinear
 * lookups and nearby directions); without one, only the texel read. */
static uint32_t texel_code(vbi_profile_set *s, uint32_t slot, const vbi_profile_kernel *k, uint32_t t)
{
    uint32_t *cell = s->code + (size_t)slot * s->texels + t;
    uint32_t code = __atomic_load_n(cell, __ATOMIC_ACQUIRE);
    if (code != TEXEL_UNSET)
        return code;
    if (!s->incident) /* released before conversion: a caller error, emit nothing */
        return 0u;
    if (k->matrix && convert_slot(s, slot, k))
        return __atomic_load_n(cell, __ATOMIC_ACQUIRE);
    code = rgbe_encode(compute_texel(s, slot, k, t));
    __atomic_store_n(cell, code, __ATOMIC_RELEASE);
    return code;
}

/* Lambertian VL (no map): J = rho / pi Phi_in; a non-Lambertian kernel contributes its
 * cosine-weighted average albedo (diffuse approximation, profiles.h). */
static vec3 lambert_J(const vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k)
{
    return v3_mul(vbi_profile_incident_power(s, vl), v3_scale(k->rho, VBI_INV_PI));
}

void vbi_profile_convert(vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT || !s->incident)
        return;
    if (k->matrix && convert_slot(s, slot, k))
        return;
    for (uint32_t t = 0; t < s->texels; ++t)
        texel_code(s, slot, k, t);
}

vbnl_result vbi_profile_set_release_incident(vbi_profile_set *s)
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

vec3 vbi_profile_texel(vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k, uint32_t t)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return lambert_J(s, vl, k);
    return rgbe_decode(texel_code(s, slot, k, t));
}

uint32_t vbi_profile_slot(const vbi_profile_set *s, uint32_t vl) { return s->slot[vl]; }

void vbi_profile_lookup_begin(const vbi_profile_set *s, uint32_t slot, vec3 wo, vbi_profile_lookup *l)
{
    vbi_hemioct_bilinear(s->map, wo, l->idx, l->wgt);
    const uint32_t *codes = s->code + (size_t)slot * s->texels;
    /* rows y0 and y1 of the footprint: at most two lines at R = 16 (a row is 64 bytes) */
    __builtin_prefetch(codes + l->idx[0]);
    __builtin_prefetch(codes + l->idx[3]);
}

vec3 vbi_profile_lookup_end(vbi_profile_set *s, uint32_t slot, const vbi_profile_kernel *k,
                             const vbi_profile_lookup *l)
{
    vec3 r = v3s(0.0f);
    for (int c = 0; c < 4; ++c)
        if (l->wgt[c] > 0.0f)
            r = v3_fma(r, rgbe_decode(texel_code(s, slot, k, l->idx[c])), l->wgt[c]);
    return r;
}

vec3 vbi_profile_eval(vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k, vec3 wo)
{
    if (!(wo.z > 0.0f))
        return v3s(0.0f);
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return lambert_J(s, vl, k);
    vbi_profile_lookup l;
    vbi_profile_lookup_begin(s, slot, wo, &l);
    return vbi_profile_lookup_end(s, slot, k, &l);
}

vec3 vbi_profile_intensity(vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k, vec3 wo)
{
    float len = v3_len(wo);
    if (!(wo.z > 0.0f) || !(len > 0.0f))
        return v3s(0.0f);
    return v3_scale(vbi_profile_eval(s, vl, k, wo), wo.z / len);
}

vec3 vbi_profile_power(const vbi_profile_set *s, uint32_t vl, const vbi_profile_kernel *k)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return v3_mul(vbi_profile_incident_power(s, vl), k->rho);
    if (!s->incident) {
        /* Maps released: integrate the stored (quantised) profile, sum_t J_t C_t. */
        const float *cproj = vbi_hemioct_bilinear_projected(s->map);
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
    const uint64_t *in = s->incident + 3 * (size_t)slot * s->texels;
    double p[3] = {0.0, 0.0, 0.0};
    for (uint32_t i = 0; i < s->texels; ++i)
        for (int c = 0; c < 3; ++c)
            p[c] += (double)in[3 * i + c] * s->unit * k->albedo[3 * i + c];
    return v3((float)p[0], (float)p[1], (float)p[2]);
}

int vbi_profile_texel_converted(const vbi_profile_set *s, uint32_t vl, uint32_t t)
{
    uint32_t slot = s->slot[vl];
    if (slot == NO_SLOT)
        return 1;
    return __atomic_load_n(s->code + (size_t)slot * s->texels + t, __ATOMIC_ACQUIRE) != TEXEL_UNSET;
}
