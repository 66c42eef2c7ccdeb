/* A plugin module built for another ABI major (99): hosts must refuse it with a clear message. */
#include <stddef.h>
#include <stdint.h>

#include "vbnl/vbnl_plugin.h"

__attribute__((visibility("default"))) const vbnl_plugin_api *vbnl_plugin_entry(uint32_t host_abi_major,
                                                                                const char **why);

static const vbnl_plugin_api fake = {.abi_major = 99, .abi_minor = 0, .size = sizeof(vbnl_plugin_api)};

const vbnl_plugin_api *vbnl_plugin_entry(uint32_t host_abi_major, const char **why)
{
    if (host_abi_major != 99) {
        if (why)
            *why = "fake module built for plugin ABI 99.0";
        return NULL;
    }
    return &fake;
}
