/* The VL index query by brute force (reference.h). */
#include "reference.h"

uint32_t vbi_vl_query_reference(const vec3 *centers, const float *radii, const vec3 *normals, uint32_t count,
                                 vec3 p, const vbi_vl_filter *f, uint32_t max_out, vbi_vl_found *found)
{
    uint32_t total = 0;
    for (uint32_t j = 0; j < count; ++j) {
        double d2;
        if (!vbi_vl_contains(centers[j], radii[j], p, &d2))
            continue;
        if (f && normals && !vbi_vl_filter_passes(f, normals[j]))
            continue;
        if (total < max_out)
            found[total] = (vbi_vl_found){j, j, (float)d2, radii[j]};
        total++;
    }
    return total;
}
