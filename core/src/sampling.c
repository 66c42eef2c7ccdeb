#include "sampling.h"

#include <stdlib.h>
#include <string.h>

int vbi_alias_table_build(vbi_alias_table *t, const float *weights, uint32_t n)
{
    memset(t, 0, sizeof(*t));
    if (n == 0)
        return -1;
    double total = 0.0;
    for (uint32_t i = 0; i < n; ++i)
        total += weights[i] > 0.0f ? (double)weights[i] : 0.0;
    if (!(total > 0.0))
        return -1;
    t->prob = malloc(sizeof(float) * n);
    t->alias = malloc(sizeof(uint32_t) * n);
    t->pmf = malloc(sizeof(float) * n);
    double *scaled = malloc(sizeof(double) * n);
    uint32_t *small = malloc(sizeof(uint32_t) * n);
    uint32_t *large = malloc(sizeof(uint32_t) * n);
    if (!t->prob || !t->alias || !t->pmf || !scaled || !small || !large) {
        free(scaled);
        free(small);
        free(large);
        vbi_alias_table_free(t);
        return -1;
    }
    t->n = n;
    t->total = total;
    uint32_t ns = 0, nl = 0;
    for (uint32_t i = 0; i < n; ++i) {
        double w = weights[i] > 0.0f ? (double)weights[i] : 0.0;
        t->pmf[i] = (float)(w / total);
        scaled[i] = w / total * n;
        t->alias[i] = i;
        if (scaled[i] < 1.0)
            small[ns++] = i;
        else
            large[nl++] = i;
    }
    while (ns > 0 && nl > 0) {
        uint32_t s = small[--ns];
        uint32_t l = large[nl - 1];
        t->prob[s] = (float)scaled[s];
        t->alias[s] = l;
        scaled[l] = (scaled[l] + scaled[s]) - 1.0;
        if (scaled[l] < 1.0) {
            --nl;
            small[ns++] = l;
        }
    }
    /* Leftovers are 1 up to rounding. */
    while (nl > 0)
        t->prob[large[--nl]] = 1.0f;
    while (ns > 0)
        t->prob[small[--ns]] = 1.0f;
    free(scaled);
    free(small);
    free(large);
    return 0;
}

void vbi_alias_table_free(vbi_alias_table *t)
{
    if (!t)
        return;
    free(t->prob);
    free(t->alias);
    free(t->pmf);
    memset(t, 0, sizeof(*t));
}

