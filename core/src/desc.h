/* The size check of the public descriptors (vbnl/scene.h, "Descriptors"; vbnl/render.h) (private
 * header). */
#ifndef VBI_DESC_H
#define VBI_DESC_H

#include <stddef.h>
#include <stdint.h>

#include "vbnl/result.h"

/* VBNL_OK when a descriptor `what` declares the size this build knows (`known`): a larger one
 * comes from a newer vbnl (VBNL_ERR_UNSUPPORTED), a smaller one was not filled by its init
 * function (VBNL_ERR_INVALID_ARGUMENT, naming it). */
static inline vbnl_result vbi_desc_check(uint32_t size, size_t known, const char *what, const char *init,
                                          vbnl_error *err)
{
    if (size == known)
        return VBNL_OK;
    if (size > known)
        return vbnl_error_set(err, VBNL_ERR_UNSUPPORTED, "%s of %u bytes comes from a newer vbnl (this one knows %zu)",
                              what, size, known);
    return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "%s has size %u, not %zu: fill it with %s first", what,
                          size, known, init);
}

/* vbi_desc_check of descriptor pointer d of public type `type` (whose init is type##_init). */
#define VBI_DESC_CHECK(d, type, err) vbi_desc_check((d)->size, sizeof(*(d)), #type, #type "_init", (err))

#endif
