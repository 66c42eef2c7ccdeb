#include "vl_shade.h"

#include <stdlib.h>
#include <string.h>

vbnl_result vbi_vl_shade_build(vbi_vl_shade *out, const vbi_vl_set *set, const vbi_vl_index *index,
                                vbi_profile_set *profiles, vbi_profile_kernel *const *kernels,
                                const float *power, const vbi_vl_support *support)
{
    memset(out, 0, sizeof(*out));
    uint32_t n = set->count;
    if (n == 0)
        return VBNL_OK;
    float *weight = malloc(sizeof(float) * n);
    if (!weight)
        return VBNL_ERR_OUT_OF_MEMORY;
    int any = 0;
    for (uint32_t r = 0; r < n; ++r) {
        weight[r] = power[vbi_vl_index_id(index, r)];
        any |= weight[r] > 0.0f;
    }
    vbi_alias_table table;
    int built = any ? vbi_alias_table_build(&table, weight, n) : -1;
    free(weight);
    if (built != 0)
        return any ? VBNL_ERR_OUT_OF_MEMORY : VBNL_OK; /* no light emits: nothing to sample */
    out->rec = aligned_alloc(64, sizeof(vbi_vl_shade_rec) * (size_t)n);
    out->alias = malloc(sizeof(vbi_vl_alias) * (size_t)n);
    if (!out->rec || !out->alias) {
        vbi_alias_table_free(&table);
        vbi_vl_shade_free(out);
        return VBNL_ERR_OUT_OF_MEMORY;
    }
    for (uint32_t r = 0; r < n; ++r) {
        uint32_t id = vbi_vl_index_id(index, r);
        vbi_vl_shade_rec *e = &out->rec[r];
        float radius = set->radius[id];
        float inv_area = 1.0f / (VBI_PI * radius * radius);
        const vbi_profile_kernel *k = kernels[set->material[id]];
        e->position = set->position[id];
        e->radius = radius;
        e->normal = set->normal[id];
        e->density = set->density[id];
        e->slot = vbi_profile_slot(profiles, id);
        e->material = set->material[id];
        e->support = support ? support[r].tau : 0.0f;
        if (e->slot != VBI_PROFILE_NO_SLOT) {
            e->radiance = v3_scale(set->tint[id], inv_area);
        } else {
            vec3 J = vbi_profile_eval(profiles, id, k, v3(0.0f, 0.0f, 1.0f)); /* any wo above */
            e->radiance = v3_scale(v3_mul(J, set->tint[id]), inv_area);
        }
        e->pmf = table.pmf[r];
        out->alias[r] = (vbi_vl_alias){table.prob[r], table.alias[r]};
    }
    vbi_alias_table_free(&table);
    out->n = n;
    return VBNL_OK;
}

void vbi_vl_shade_free(vbi_vl_shade *t)
{
    if (!t)
        return;
    free(t->rec);
    free(t->alias);
    memset(t, 0, sizeof(*t));
}

size_t vbi_vl_shade_bytes(const vbi_vl_shade *t)
{
    return (size_t)t->n * (sizeof(vbi_vl_shade_rec) + sizeof(vbi_vl_alias));
}
