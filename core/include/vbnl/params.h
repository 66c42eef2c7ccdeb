/* vbnl: named integrator parameters.
 *
 * A vbnl_params is an ordered list of `name = value` settings, as written in a scene file's
 * integrator block or given on a command line. Each setting may carry the place it came from
 * ("scene.pov:12:40"), which error messages quote. Integrators describe what they accept with a
 * table of vbnl_param_spec; vbnl_params_validate checks a list against such a table.
 *
 * Ownership: a vbnl_params copies every name, value and origin it is given.
 * Thread-safety: a vbnl_params may be read from many threads once it is no longer modified; it is
 * modified by one thread at a time. Errors: a function that fails writes one sentence into `err`
 * (may be NULL) and leaves the list as it was. */
#ifndef VBNL_PARAMS_H
#define VBNL_PARAMS_H

#include <stdint.h>

#include "vbnl/result.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vbnl_param_type {
    VBNL_PARAM_INT = 0,
    VBNL_PARAM_FLOAT = 1,
    VBNL_PARAM_BOOL = 2,
    VBNL_PARAM_ENUM = 3,   /* one string of `choices` */
    VBNL_PARAM_STRING = 4,
} vbnl_param_type;

typedef struct vbnl_param_spec {
    const char *name;
    vbnl_param_type type;
    double default_number;          /* INT, FLOAT, BOOL (0 or 1) */
    const char *default_string;     /* ENUM, STRING */
    double min, max;                /* inclusive range of INT and FLOAT */
    const char *const *choices;     /* ENUM: NULL-terminated list */
    const char *doc;                /* one line */
} vbnl_param_spec;

typedef struct vbnl_params vbnl_params;

/* An empty list into *out. Errors: VBNL_ERR_INVALID_ARGUMENT (NULL out), VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_params_create(vbnl_params **out, vbnl_error *err);
/* Frees the list (accepts NULL). */
void vbnl_params_destroy(vbnl_params *p);
/* Copies every setting of `src` after the settings of `dst` (later settings win). Errors:
 * VBNL_ERR_INVALID_ARGUMENT (NULL arguments), VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_params_append(vbnl_params *dst, const vbnl_params *src, vbnl_error *err);

/* Sets `name` to a number (ints, floats and bools) or a string. `where` may be NULL. A later
 * setting of the same name replaces the earlier one. Errors: VBNL_ERR_INVALID_ARGUMENT (NULL or
 * empty name, NULL string), VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_params_set_number(vbnl_params *p, const char *name, double value,
                                   const char *where, vbnl_error *err);
vbnl_result vbnl_params_set_string(vbnl_params *p, const char *name, const char *value,
                                   const char *where, vbnl_error *err);
/* Parses "key=value": a value that reads fully as a number (or true/false/on/off/yes/no) is a
 * number, anything else a string. Errors: VBNL_ERR_INVALID_ARGUMENT (NULL text, no '=', an empty
 * name or value, a name of 256 bytes or more), VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbnl_params_set_text(vbnl_params *p, const char *key_equals_value, const char *where,
                                 vbnl_error *err);

/* Settings in the list (0 for NULL). */
uint32_t vbnl_params_count(const vbnl_params *p);
/* Whether `name` is set in the list (by a scene's integrator block, a command line's --set or a
 * caller), as opposed to left at its spec's default. p may be NULL (nothing is set). */
int vbnl_params_has(const vbnl_params *p, const char *name);
/* Reads setting i: its name, whether it is a string, its number or string, and its origin (each
 * out-parameter may be NULL; the strings are the list's, valid while it is unchanged). Returns
 * VBNL_ERR_INVALID_ARGUMENT for a NULL list or i >= the count (no message: no err argument). */
vbnl_result vbnl_params_get(const vbnl_params *p, uint32_t i, const char **name, int *is_string,
                            double *number, const char **string, const char **where);

/* Checks every setting against `specs` (p may be NULL: nothing to check): unknown names are
 * refused with the closest valid name and the list of valid ones (VBNL_ERR_UNKNOWN_NAME); ints
 * must be whole, values must lie in range, enums must be one of the choices, bools accept 0/1,
 * numbers and strings go where the spec says (VBNL_ERR_INVALID_ARGUMENT). Messages name `owner`
 * and the setting's origin. */
vbnl_result vbnl_params_validate(const vbnl_params *p, const vbnl_param_spec *specs, uint32_t count,
                                 const char *owner, vbnl_error *err);

/* Value of `name` or the spec's default (p may be NULL); 0 / NULL when the spec lacks `name`. For
 * a list that passed vbnl_params_validate with the same specs. The string is the list's or the
 * spec's. */
double vbnl_params_number(const vbnl_params *p, const vbnl_param_spec *specs, uint32_t count,
                          const char *name);
const char *vbnl_params_string(const vbnl_params *p, const vbnl_param_spec *specs, uint32_t count,
                               const char *name);

#ifdef __cplusplus
}
#endif
#endif
