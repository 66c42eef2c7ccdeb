#include "vl_set.h"

#include <stdlib.h>
#include <string.h>

vbnl_result vbi_vl_set_alloc(vbi_vl_set *s, uint32_t count, vbnl_error *err)
{
    memset(s, 0, sizeof(*s));
    s->position = malloc(sizeof(vec3) * (size_t)count);
    s->normal = malloc(sizeof(vec3) * (size_t)count);
    s->material = malloc(sizeof(uint32_t) * (size_t)count);
    s->tint = malloc(sizeof(vec3) * (size_t)count);
    s->radius = malloc(sizeof(float) * (size_t)count);
    s->density = malloc(sizeof(float) * (size_t)count);
    if (!s->position || !s->normal || !s->material || !s->tint || !s->radius || !s->density) {
        vbi_vl_set_free(s);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory for %u virtual lights", count);
    }
    s->count = count;
    return VBNL_OK;
}

void vbi_vl_set_free(vbi_vl_set *s)
{
    if (!s)
        return;
    free(s->position);
    free(s->normal);
    free(s->material);
    free(s->tint);
    free(s->radius);
    free(s->density);
    memset(s, 0, sizeof(*s));
}

size_t vbi_vl_set_bytes(const vbi_vl_set *s)
{
    return (size_t)s->count * (3 * sizeof(vec3) + sizeof(uint32_t) + 2 * sizeof(float));
}
