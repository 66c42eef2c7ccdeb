/* The registry of integrators: an immutable table, looked up by name. */
#include <string.h>

#include "vbnl/integrator.h"

extern const vbnl_integrator_class vbi_integrator_path;
extern const vbnl_integrator_class vbi_integrator_vbnl;
extern const vbnl_integrator_class vbi_integrator_vpl;
extern const vbnl_integrator_class vbi_integrator_vsl;
extern const vbnl_integrator_class vbi_integrator_richvsl;

static const vbnl_integrator_class *const registry[] = {
    &vbi_integrator_path,
    &vbi_integrator_vbnl,
    &vbi_integrator_vpl,
    &vbi_integrator_vsl,
    &vbi_integrator_richvsl,
};

uint32_t vbnl_integrator_count(void) { return (uint32_t)(sizeof(registry) / sizeof(registry[0])); }

const vbnl_integrator_class *vbnl_integrator_at(uint32_t index)
{
    return index < vbnl_integrator_count() ? registry[index] : NULL;
}

const vbnl_integrator_class *vbnl_integrator_find(const char *name)
{
    if (!name)
        return NULL;
    for (uint32_t i = 0; i < vbnl_integrator_count(); ++i)
        if (strcmp(registry[i]->name, name) == 0)
            return registry[i];
    return NULL;
}
