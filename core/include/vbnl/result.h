/* vbnl: result codes and error messages.
 *
 * Every fallible function of the vbnl API returns a vbnl_result. When it is not VBNL_OK and the
 * caller passed a vbnl_error, its `message` holds one English sentence describing what went wrong
 * (for scene input: "file:line:col: ..."). The vbnl_error is owned by the caller; the library
 * never keeps a pointer to it and there is no global "last error".
 *
 * Thread-safety: these functions are pure and may be called from any thread. */
#ifndef VBNL_RESULT_H
#define VBNL_RESULT_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vbnl_result {
    VBNL_OK = 0,
    VBNL_ERR_INVALID_ARGUMENT = 1, /* NULL handle, out-of-range value, malformed input */
    VBNL_ERR_OUT_OF_MEMORY = 2,
    VBNL_ERR_IO = 3,               /* a file could not be read or written */
    VBNL_ERR_UNKNOWN_NAME = 4,     /* unknown integrator, parameter, layer ... */
    VBNL_ERR_UNSUPPORTED = 5,      /* valid request this build or module cannot do */
    VBNL_ERR_BACKEND = 6,          /* Embree, OpenEXR, assimp ... reported an error */
    VBNL_ERR_CANCELLED = 7,        /* the progress callback asked to stop */
    VBNL_ERR_STATE = 8,            /* call out of order (render before prepare, ...) */
    VBNL_ERR_PARSE = 9,            /* scene text could not be understood */
    VBNL_ERR_CORRUPT = 10,         /* a file is damaged or from another version */
} vbnl_result;

#define VBNL_ERROR_MESSAGE_SIZE 1024

/* Caller-owned error record. Zero-initialise it (or don't pass one at all: NULL is allowed). */
typedef struct vbnl_error {
    vbnl_result code;
    char message[VBNL_ERROR_MESSAGE_SIZE];
} vbnl_error;

/* Short constant name of a result code ("VBNL_ERR_IO", ...). Never NULL. */
const char *vbnl_result_name(vbnl_result r);

/* Fills `err` (if non-NULL) with `code` and a printf-formatted message; returns `code`. */
vbnl_result vbnl_error_set(vbnl_error *err, vbnl_result code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#ifdef __cplusplus
}
#endif
#endif
