/* Display quantisation: clamp, position-hashed dither, 8/16 bits; and the plain sRGB transform
 * used where no OpenColorIO view is involved (benchmark images). */
#include <math.h>
#include <stdint.h>

#include "image_io.h"

/* IEC 61966-2-1 encoding function, v in [0,1]. */
static float vbi_srgb_oetf(float v)
{
    if (v >= 1.0f) /* 1.055 - 0.055 is not exactly 1 in float: keep white exact */
        return 1.0f;
    return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
}

/* Triangular noise in (-1, 1) LSB from (x, y, c) alone: the sum of two uniforms from a hash
 * (lowbias32), so a tile rendered on any thread dithers the same way. */
static float vbi_tpdf(uint32_t x, uint32_t y, uint32_t c)
{
    uint32_t h = x * 0x9E3779B1u ^ (y + 0x7F4A7C15u) * 0x85EBCA77u ^ (c + 1u) * 0xC2B2AE3Du;
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    h *= 0x846ca68bu;
    h ^= h >> 16;
    float u1 = (float)(h & 0xffffu) * (1.0f / 65536.0f);
    float u2 = (float)(h >> 16) * (1.0f / 65536.0f);
    return u1 - u2;
}

static uint8_t vbi_quantise(float v01, int dither, uint32_t x, uint32_t y, uint32_t c)
{
    float s = v01 * 255.0f;
    /* no noise at exact black and white: flat backgrounds and clipped highlights stay clean */
    if (dither && s > 0.0f && s < 255.0f)
        s += vbi_tpdf(x, y, c);
    s = floorf(s + 0.5f);
    return (uint8_t)(s < 0.0f ? 0.0f : s > 255.0f ? 255.0f : s);
}

static float vbi_clamp01(float v)
{
    if (!(v > 0.0f)) /* also NaN */
        return 0.0f;
    return v < 1.0f ? v : 1.0f;
}

vbnl_result vbi_linear_to_srgb8(const float *src, uint32_t width, uint32_t height,
                                 uint32_t src_channels, float exposure_stops, int dither,
                                 uint8_t *dst, uint32_t dst_channels, vbnl_error *err)
{
    if (!src || !dst)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "linear_to_srgb8: %s is NULL",
                              !src ? "src" : "dst");
    if ((src_channels != 3 && src_channels != 4) || (dst_channels != 3 && dst_channels != 4))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "linear_to_srgb8: channels %u -> %u (3 or 4 expected)", src_channels,
                              dst_channels);
    if (!isfinite(exposure_stops))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "linear_to_srgb8: exposure is not finite");
    const float scale = exp2f(exposure_stops);
    for (uint32_t y = 0; y < height; y++) {
        for (uint32_t x = 0; x < width; x++) {
            size_t i = (size_t)y * width + x;
            const float *p = src + i * src_channels;
            uint8_t *q = dst + i * dst_channels;
            for (uint32_t c = 0; c < 3; c++)
                q[c] = vbi_quantise(vbi_srgb_oetf(vbi_clamp01(p[c] * scale)), dither, x, y, c);
            if (dst_channels == 4)
                q[3] = src_channels == 4 ? vbi_quantise(vbi_clamp01(p[3]), dither, x, y, 3) : 255;
        }
    }
    return VBNL_OK;
}

vbnl_result vbi_display_quantise(const float *src, uint32_t width, uint32_t height, uint32_t src_channels,
                                  uint32_t bits, int dither, void *dst, uint32_t dst_channels,
                                  vbnl_error *err)
{
    if (!src || !dst)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "display_quantise: %s is NULL", !src ? "src" : "dst");
    if ((src_channels != 3 && src_channels != 4) || (dst_channels != 3 && dst_channels != 4) ||
        (bits != 8 && bits != 16))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "display_quantise: channels %u -> %u, %u bits (3 or 4 channels, 8 or 16 bits)",
                              src_channels, dst_channels, bits);
    const float maxv = bits == 8 ? 255.0f : 65535.0f;
    for (uint32_t y = 0; y < height; y++)
        for (uint32_t x = 0; x < width; x++) {
            size_t i = (size_t)y * width + x;
            const float *p = src + i * src_channels;
            for (uint32_t c = 0; c < dst_channels; c++) {
                float s = c < 3 || src_channels == 4 ? vbi_clamp01(p[c]) * maxv : maxv;
                if (dither && s > 0.0f && s < maxv)
                    s += vbi_tpdf(x, y, c);
                s = floorf(s + 0.5f);
                s = s < 0.0f ? 0.0f : s > maxv ? maxv : s;
                if (bits == 8)
                    ((uint8_t *)dst)[i * dst_channels + c] = (uint8_t)s;
                else
                    ((uint16_t *)dst)[i * dst_channels + c] = (uint16_t)s;
            }
        }
    return VBNL_OK;
}
