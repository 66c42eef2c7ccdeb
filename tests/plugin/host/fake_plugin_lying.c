/* A plugin module that answers every host with a table of ABI major 99: hosts must check the
 * table's own version too, not only trust the entry function. */
#include <stddef.h>
#include <stdint.h>

#include "vbnl/vbnl_plugin.h"

__attribute__((visibility("default"))) const vbnl_plugin_api *vbnl_plugin_entry(uint32_t host_abi_major,
                                                                                const char **why);

static const vbnl_plugin_api fake = {.abi_major = 99, .abi_minor = 0, .size = sizeof(vbnl_plugin_api)};

const vbnl_plugin_api *vbnl_plugin_entry(uint32_t host_abi_major, const char **why)
{
    (void)host_abi_major;
    if (why)
        *why = NULL;
    return &fake;
}
