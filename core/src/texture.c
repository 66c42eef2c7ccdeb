/* Textures: image lookup (bilinear / nearest, repeat / clamp, UV or projected coordinates) and
 * the procedural 3D patterns checker, gradient and brick through a colour map. Conventions and
 * formulas are documented with vbnl_texture_desc in vbnl/scene.h. */
#include "texture.h"

#include <math.h>

static float fracf(float x) { return x - floorf(x); }

vec3 vbnl_color_map_eval(const vbnl_color_map_entry *map, uint32_t count, float v)
{
    if (count == 0)
        return v3s(0.0f);
    if (!(v > map[0].value)) /* also NaN */
        return v3_load(map[0].color);
    for (uint32_t i = 1; i < count; ++i) {
        if (v <= map[i].value) {
            float span = map[i].value - map[i - 1].value;
            float f = span > 0.0f ? (v - map[i - 1].value) / span : 1.0f;
            return v3_lerp(v3_load(map[i - 1].color), v3_load(map[i].color), f);
        }
    }
    return v3_load(map[count - 1].color);
}

static float wave_shape(const vbnl_texture *t, float v)
{
    v = fracf(v * t->frequency + t->phase);
    switch (t->wave) {
    case VBNL_WAVE_TRIANGLE:
        return 1.0f - fabsf(2.0f * v - 1.0f);
    case VBNL_WAVE_SINE:
        return 0.5f * (1.0f + sinf(2.0f * VBNL_PI * v));
    case VBNL_WAVE_SCALLOP:
        return fabsf(sinf(VBNL_PI * v));
    case VBNL_WAVE_RAMP:
    default:
        return v;
    }
}

static double fracd(double x) { return x - floor(x); }

/* POV-Ray's brick (its BrickPattern, re-derived): the point is shifted by the mortar width (plus
 * 1e-10) so joints sit just below / left of the multiples of the brick size; bed joints every
 * course (height size.y); courses alternate, the head joints in x on odd courses and the joints
 * in z on even courses being offset by half a brick. Double precision, as POV-Ray. */
static float brick_value(const vbnl_texture *t, vec3 q)
{
    const double m = t->mortar, f = 1e-10 + m;
    const double w = t->brick_size.x, h = t->brick_size.y, d = t->brick_size.z;
    const double x = (double)q.x + f, y = (double)q.y + f, z = (double)q.z + f;
    if (fracd(y / h) <= m / h)
        return 0.0f;
    const int odd = fracd(y / (2.0 * h)) > 0.5;
    if (fracd(x / w + (odd ? 0.5 : 0.0)) <= m / w)
        return 0.0f;
    if (fracd(z / d + (odd ? 0.0 : 0.5)) <= m / d)
        return 0.0f;
    return 1.0f;
}

float vbnl_texture_pattern(const vbnl_texture *t, vec3 q)
{
    switch (t->kind) {
    case VBNL_TEXTURE_CHECKER: {
        /* a tiny offset keeps faces lying exactly on integer planes (e.g. a plane at y = 0)
         * on one side, as POV-Ray does */
        const float e = 1e-4f;
        double sum = floor((double)q.x + e) + floor((double)q.y + e) + floor((double)q.z + e);
        return fmod(fabs(sum), 2.0) != 0.0 ? 1.0f : 0.0f;
    }
    case VBNL_TEXTURE_GRADIENT:
        return v3_dot(q, t->gradient);
    case VBNL_TEXTURE_BRICK:
        return brick_value(t, q);
    case VBNL_TEXTURE_IMAGE:
    default:
        return 0.0f;
    }
}

static int texel_index(const vbnl_texture *t, int i, int n)
{
    if (t->wrap == VBNL_WRAP_CLAMP)
        return i < 0 ? 0 : (i >= n ? n - 1 : i);
    i %= n;
    return i < 0 ? i + n : i;
}

static vec3 texel(const vbnl_texture *t, int x, int y)
{
    x = texel_index(t, x, (int)t->width);
    y = texel_index(t, y, (int)t->height);
    return v3_load(t->texels + 3 * ((size_t)y * t->width + (size_t)x));
}

vec3 vbnl_texture_image(const vbnl_texture *t, float u, float v)
{
    if (!isfinite(u) || !isfinite(v))
        return v3s(0.0f);
    if (t->wrap == VBNL_WRAP_REPEAT) {
        u = fracf(u);
        v = fracf(v);
    } else {
        u = clampf(u, 0.0f, 1.0f);
        v = clampf(v, 0.0f, 1.0f);
    }
    /* continuous texel coordinates: texel (i, j) has its centre at (i + 0.5, j + 0.5) with
     * j counted from the top (v = 1) */
    float x = u * (float)t->width, y = (1.0f - v) * (float)t->height;
    if (!t->interpolate) {
        int ix = (int)floorf(x), iy = (int)floorf(y);
        if (ix >= (int)t->width)
            ix = (int)t->width - 1;
        if (iy >= (int)t->height)
            iy = (int)t->height - 1;
        return texel(t, ix, iy);
    }
    x -= 0.5f;
    y -= 0.5f;
    float fx0 = floorf(x), fy0 = floorf(y);
    int x0 = (int)fx0, y0 = (int)fy0;
    float fx = x - fx0, fy = y - fy0;
    vec3 a = v3_lerp(texel(t, x0, y0), texel(t, x0 + 1, y0), fx);
    vec3 b = v3_lerp(texel(t, x0, y0 + 1), texel(t, x0 + 1, y0 + 1), fx);
    return v3_lerp(a, b, fy);
}

vec3 vbnl_texture_eval(const vbnl_texture *t, vec3 p, vec2 uv)
{
    if (t->kind == VBNL_TEXTURE_IMAGE) {
        if (t->projection == VBNL_PROJECTION_UV)
            return vbnl_texture_image(t, uv.x, uv.y);
        vec3 q = mat4_point(&t->xf, p);
        float u, v;
        switch (t->projection) {
        case VBNL_PROJECTION_SPHERICAL: {
            float r = v3_len(q);
            u = fracf(atan2f(q.z, q.x) * (0.5f / VBNL_PI));
            v = r > 0.0f ? acosf(clampf(-q.y / r, -1.0f, 1.0f)) * (1.0f / VBNL_PI) : 0.5f;
            break;
        }
        case VBNL_PROJECTION_CYLINDRICAL:
            u = fracf(atan2f(q.z, q.x) * (0.5f / VBNL_PI));
            v = q.y;
            break;
        case VBNL_PROJECTION_PLANAR:
        default:
            u = q.x;
            v = q.y;
            break;
        }
        return vbnl_texture_image(t, u, v);
    }
    vec3 q = mat4_point(&t->xf, p);
    float v = vbnl_texture_pattern(t, q);
    if (t->kind == VBNL_TEXTURE_GRADIENT)
        v = wave_shape(t, v);
    return vbnl_color_map_eval(t->map, t->map_count, v);
}
