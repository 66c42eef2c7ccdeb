/* Small vector maths for the renderer core (private header).
 *
 * Names are short on purpose (pbrt's Vector3f style): this header is private to core and every
 * function is static inline, so nothing here is exported. Colours use the same type as vectors
 * (x, y, z = r, g, b). */
#ifndef VBI_VMATH_H
#define VBI_VMATH_H

#include <math.h>
#include <stdint.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#define VBI_PI 3.14159265358979323846f
#define VBI_INV_PI 0.31830988618379067154f
#define VBI_INV_2PI 0.15915494309189533577f
#define VBI_INV_4PI 0.07957747154594766788f
/* Largest float below 1: the upper end of [0, 1) random numbers. */
#define VBI_ONE_MINUS_EPS 0x1.fffffep-1f

typedef struct vec3 {
    float x, y, z;
} vec3;

typedef struct vec2 {
    float x, y;
} vec2;

/* fmaxf / fminf with the same results (the non-NaN operand wins; NaN only when both are), as
 * two compares and a blend: GCC calls libm for fmaxf unless NaNs are ruled out, and these sit
 * in every shading step. */
static inline float maxf(float a, float b) { return (a > b || b != b) ? a : b; }
static inline float minf(float a, float b) { return (a < b || b != b) ? a : b; }

static inline vec3 v3(float x, float y, float z) { return (vec3){x, y, z}; }
static inline vec3 v3s(float s) { return (vec3){s, s, s}; }
static inline vec3 v3_load(const float *p) { return (vec3){p[0], p[1], p[2]}; }
static inline void v3_store(float *p, vec3 a) { p[0] = a.x; p[1] = a.y; p[2] = a.z; }
static inline vec3 v3_add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline vec3 v3_sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline vec3 v3_mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline vec3 v3_div(vec3 a, vec3 b) { return v3(a.x / b.x, a.y / b.y, a.z / b.z); }
static inline vec3 v3_scale(vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline vec3 v3_neg(vec3 a) { return v3(-a.x, -a.y, -a.z); }
/* a + b * s */
static inline vec3 v3_fma(vec3 a, vec3 b, float s) { return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
static inline float v3_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline float v3_absdot(vec3 a, vec3 b) { return fabsf(v3_dot(a, b)); }
static inline vec3 v3_cross(vec3 a, vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float v3_len2(vec3 a) { return v3_dot(a, a); }
static inline float v3_len(vec3 a) { return sqrtf(v3_dot(a, a)); }
static inline vec3 v3_norm(vec3 a)
{
    float l = v3_len(a);
    return l > 0.0f ? v3_scale(a, 1.0f / l) : a;
}
static inline float v3_max_comp(vec3 a) { return maxf(a.x, maxf(a.y, a.z)); }
static inline float v3_min_comp(vec3 a) { return minf(a.x, minf(a.y, a.z)); }
static inline vec3 v3_min(vec3 a, vec3 b) { return v3(minf(a.x, b.x), minf(a.y, b.y), minf(a.z, b.z)); }
static inline vec3 v3_max(vec3 a, vec3 b) { return v3(maxf(a.x, b.x), maxf(a.y, b.y), maxf(a.z, b.z)); }
static inline float v3_avg(vec3 a) { return (a.x + a.y + a.z) * (1.0f / 3.0f); }
/* Rec. 709 luminance of a linear RGB colour. */
static inline float v3_luminance(vec3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
static inline int v3_is_black(vec3 a) { return a.x == 0.0f && a.y == 0.0f && a.z == 0.0f; }
static inline int v3_is_finite(vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
static inline vec3 v3_lerp(vec3 a, vec3 b, float t) { return v3_add(v3_scale(a, 1.0f - t), v3_scale(b, t)); }
static inline float v3_comp(vec3 a, int i) { return i == 0 ? a.x : (i == 1 ? a.y : a.z); }

static inline float clampf(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }
static inline float sqr(float v) { return v * v; }
static inline float safe_sqrtf(float v) { return sqrtf(maxf(v, 0.0f)); }

/* Orthonormal frame with z as the given unit normal (Duff et al. 2017, branchless ONB). */
typedef struct frame {
    vec3 s, t, n;
} frame;

static inline frame frame_from_normal(vec3 n)
{
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float b = n.x * n.y * a;
    frame f;
    f.s = v3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    f.t = v3(b, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
static inline vec3 frame_to_local(const frame *f, vec3 v)
{
    return v3(v3_dot(v, f->s), v3_dot(v, f->t), v3_dot(v, f->n));
}
static inline vec3 frame_to_world(const frame *f, vec3 v)
{
    return v3_add(v3_add(v3_scale(f->s, v.x), v3_scale(f->t, v.y)), v3_scale(f->n, v.z));
}

/* Local shading-frame helpers (z is the normal). */
static inline float cos_theta(vec3 w) { return w.z; }
static inline float abs_cos_theta(vec3 w) { return fabsf(w.z); }
static inline int same_hemisphere(vec3 a, vec3 b) { return a.z * b.z > 0.0f; }
static inline vec3 reflect_z(vec3 w) { return v3(-w.x, -w.y, w.z); }

/* Row-major 4x4 affine transform: p' = M p. */
typedef struct mat4 {
    float m[4][4];
} mat4;

static inline mat4 mat4_identity(void)
{
    mat4 r = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}};
    return r;
}
static inline vec3 mat4_point(const mat4 *a, vec3 p)
{
    return v3(a->m[0][0] * p.x + a->m[0][1] * p.y + a->m[0][2] * p.z + a->m[0][3],
              a->m[1][0] * p.x + a->m[1][1] * p.y + a->m[1][2] * p.z + a->m[1][3],
              a->m[2][0] * p.x + a->m[2][1] * p.y + a->m[2][2] * p.z + a->m[2][3]);
}
static inline vec3 mat4_vector(const mat4 *a, vec3 v)
{
    return v3(a->m[0][0] * v.x + a->m[0][1] * v.y + a->m[0][2] * v.z,
              a->m[1][0] * v.x + a->m[1][1] * v.y + a->m[1][2] * v.z,
              a->m[2][0] * v.x + a->m[2][1] * v.y + a->m[2][2] * v.z);
}
/* Transforms a normal with the inverse transpose of the upper 3x3 (the cofactor matrix, which
 * differs from it only by the determinant's scale; the caller normalises). */
static inline vec3 mat4_normal(const mat4 *a, vec3 n)
{
    const float(*m)[4] = a->m;
    vec3 c0 = v3(m[1][1] * m[2][2] - m[1][2] * m[2][1], m[1][2] * m[2][0] - m[1][0] * m[2][2],
                 m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    vec3 c1 = v3(m[0][2] * m[2][1] - m[0][1] * m[2][2], m[0][0] * m[2][2] - m[0][2] * m[2][0],
                 m[0][1] * m[2][0] - m[0][0] * m[2][1]);
    vec3 c2 = v3(m[0][1] * m[1][2] - m[0][2] * m[1][1], m[0][2] * m[1][0] - m[0][0] * m[1][2],
                 m[0][0] * m[1][1] - m[0][1] * m[1][0]);
    /* c0, c1, c2 are the rows of the cofactor matrix C = det(M) M^-T, so n' = C n is a dot
     * product with each row (C^T n would be the inverse, which turns rotations backwards). */
    return v3(v3_dot(c0, n), v3_dot(c1, n), v3_dot(c2, n));
}
static inline float mat4_det3(const mat4 *a)
{
    const float(*m)[4] = a->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

#endif
