#include <stdarg.h>
#include <stdio.h>

#include "vbnl/result.h"

const char *vbnl_result_name(vbnl_result r)
{
    switch (r) {
    case VBNL_OK: return "VBNL_OK";
    case VBNL_ERR_INVALID_ARGUMENT: return "VBNL_ERR_INVALID_ARGUMENT";
    case VBNL_ERR_OUT_OF_MEMORY: return "VBNL_ERR_OUT_OF_MEMORY";
    case VBNL_ERR_IO: return "VBNL_ERR_IO";
    case VBNL_ERR_UNKNOWN_NAME: return "VBNL_ERR_UNKNOWN_NAME";
    case VBNL_ERR_UNSUPPORTED: return "VBNL_ERR_UNSUPPORTED";
    case VBNL_ERR_BACKEND: return "VBNL_ERR_BACKEND";
    case VBNL_ERR_CANCELLED: return "VBNL_ERR_CANCELLED";
    case VBNL_ERR_STATE: return "VBNL_ERR_STATE";
    case VBNL_ERR_PARSE: return "VBNL_ERR_PARSE";
    case VBNL_ERR_CORRUPT: return "VBNL_ERR_CORRUPT";
    }
    return "VBNL_ERR_UNKNOWN";
}

vbnl_result vbnl_error_set(vbnl_error *err, vbnl_result code, const char *fmt, ...)
{
    if (err) {
        err->code = code;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof(err->message), fmt, ap);
        va_end(ap);
    }
    return code;
}
