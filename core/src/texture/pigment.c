/* Pigments (reference manual, "Pigment", "Color Maps", "Pigment Maps", "Average"): solid colours,
 * a pattern's value through a map of colours and pigments, images, averages; POV-Ray 3.7's
 * Compute_Pigment. Map entries are evaluated at the pattern's warped point. */
#include <string.h>

#include "texture.h"

void vbi_map_search(const float *values, size_t stride, uint32_t count, double v, uint32_t *prev, uint32_t *next,
                     double *w)
{
#define VBI_VAL(i) ((double)*(const float *)((const char *)values + (size_t)(i) * stride))
    uint32_t last = count - 1;
    if (!(v < VBI_VAL(last))) { /* at or above the last entry (NaN too) */
        *prev = *next = last;
        *w = 0.0;
        return;
    }
    uint32_t c = 0, p = 0;
    while (v > VBI_VAL(c)) {
        p = c;
        c++;
    }
    if (v == VBI_VAL(c))
        p = c;
    *prev = p;
    *next = c;
    *w = p == c ? 0.0 : (v - VBI_VAL(p)) / (VBI_VAL(c) - VBI_VAL(p));
#undef VBI_VAL
}

static const float clear[5] = {1.0f, 1.0f, 1.0f, 0.0f, 1.0f};

/* Entry e of a pigment's map at the point w: its colour or its pigment's colour there. */
static int entry_color(const vbi_texture_set *ts, const vbnl_pigment_map_entry *e, dvec3 w,
                       const vbi_shade_point *sp, float out[5])
{
    if (!e->pigment) {
        memcpy(out, e->color, sizeof(float) * 5);
        return 1;
    }
    return vbi_pigment_eval(ts, e->pigment - 1, w, sp, out);
}

int vbi_pigment_eval(const vbi_texture_set *ts, uint32_t id, dvec3 q, const vbi_shade_point *sp, float out[5])
{
    const vbi_pigment *pg = &ts->pigments[id];
    const vbnl_pigment_map_entry *map = ts->pigment_entries + pg->entry_begin;
    switch (pg->kind) {
    case VBNL_PIGMENT_SOLID:
        memcpy(out, pg->color, sizeof(float) * 5);
        return 1;
    case VBNL_PIGMENT_IMAGE: {
        const vbi_pattern *pt = &ts->patterns[pg->pattern - 1];
        int index;
        return vbi_image_color(ts, pt, vbi_pattern_point(ts, pt, q), sp, out, &index);
    }
    case VBNL_PIGMENT_AVERAGE: {
        dvec3 w = pg->pattern ? vbi_pattern_point(ts, &ts->patterns[pg->pattern - 1], q) : q;
        double acc[5] = {0, 0, 0, 0, 0}, total = 0.0;
        for (uint32_t i = 0; i < pg->entry_count; ++i) {
            float c[5];
            entry_color(ts, &map[i], w, sp, c);
            for (int k = 0; k < 5; ++k)
                acc[k] += c[k] * (double)map[i].value;
            total += map[i].value;
        }
        for (int k = 0; k < 5; ++k)
            out[k] = total != 0.0 ? (float)(acc[k] / total) : 0.0f;
        return 1;
    }
    case VBNL_PIGMENT_MAP: {
        dvec3 w;
        double v = vbi_pattern_value(ts, &ts->patterns[pg->pattern - 1], q, sp, &w);
        uint32_t a, b;
        double f;
        vbi_map_search(&map[0].value, sizeof(*map), pg->entry_count, v, &a, &b, &f);
        int found = entry_color(ts, &map[b], w, sp, out);
        if (a != b) {
            float c[5];
            found |= entry_color(ts, &map[a], w, sp, c);
            for (int k = 0; k < 5; ++k)
                out[k] = (float)(c[k] + f * (out[k] - c[k]));
        }
        return found;
    }
    }
    memcpy(out, clear, sizeof(clear));
    return 0;
}

int vbi_pigment_at(const vbi_texture_set *ts, uint32_t id, const vbi_shade_point *sp, float out[5])
{
    dvec3 q = ts->pigments[id].uv ? d3(sp->u, sp->v, 0.0) : sp->p;
    return vbi_pigment_eval(ts, id, q, sp, out);
}
