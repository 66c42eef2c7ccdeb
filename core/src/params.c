/* Named parameters: storage, text parsing, validation against an integrator's spec table. */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "vbnl/params.h"

typedef struct param_entry {
    char *name;
    int is_string;
    double number;
    char *string;
    char *where;
} param_entry;

struct vbnl_params {
    param_entry *items;
    uint32_t count, capacity;
};

vbnl_result vbnl_params_create(vbnl_params **out, vbnl_error *err)
{
    if (!out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_params_create: out is NULL");
    *out = calloc(1, sizeof(vbnl_params));
    if (!*out)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    return VBNL_OK;
}

static void entry_free(param_entry *e)
{
    free(e->name);
    free(e->string);
    free(e->where);
}

void vbnl_params_destroy(vbnl_params *p)
{
    if (!p)
        return;
    for (uint32_t i = 0; i < p->count; ++i)
        entry_free(&p->items[i]);
    free(p->items);
    free(p);
}

static char *dup_or_null(const char *s) { return s ? strdup(s) : NULL; }

static vbnl_result params_put(vbnl_params *p, const char *name, int is_string, double number,
                              const char *string, const char *where, vbnl_error *err)
{
    if (!p || !name || !*name || (is_string && !string))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_params: NULL or empty argument");
    param_entry e = {strdup(name), is_string, number, dup_or_null(string), dup_or_null(where)};
    if (!e.name || (string && !e.string) || (where && !e.where)) {
        entry_free(&e);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    for (uint32_t i = 0; i < p->count; ++i) {
        if (strcmp(p->items[i].name, name) == 0) {
            entry_free(&p->items[i]);
            p->items[i] = e;
            return VBNL_OK;
        }
    }
    if (p->count == p->capacity) {
        uint32_t cap = p->capacity ? p->capacity * 2 : 8;
        param_entry *n = realloc(p->items, cap * sizeof(param_entry));
        if (!n) {
            entry_free(&e);
            return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
        }
        p->items = n;
        p->capacity = cap;
    }
    p->items[p->count++] = e;
    return VBNL_OK;
}

vbnl_result vbnl_params_set_number(vbnl_params *p, const char *name, double value, const char *where,
                                   vbnl_error *err)
{
    return params_put(p, name, 0, value, NULL, where, err);
}

vbnl_result vbnl_params_set_string(vbnl_params *p, const char *name, const char *value,
                                   const char *where, vbnl_error *err)
{
    return params_put(p, name, 1, 0.0, value, where, err);
}

vbnl_result vbnl_params_append(vbnl_params *dst, const vbnl_params *src, vbnl_error *err)
{
    if (!dst || !src)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_params_append: NULL argument");
    for (uint32_t i = 0; i < src->count; ++i) {
        const param_entry *e = &src->items[i];
        vbnl_result r = params_put(dst, e->name, e->is_string, e->number, e->string, e->where, err);
        if (r != VBNL_OK)
            return r;
    }
    return VBNL_OK;
}

vbnl_result vbnl_params_set_text(vbnl_params *p, const char *kv, const char *where, vbnl_error *err)
{
    if (!p || !kv)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbnl_params_set_text: NULL argument");
    const char *eq = strchr(kv, '=');
    if (!eq || eq == kv || !eq[1])
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "expected key=value, got '%s'", kv);
    char name[256];
    size_t n = (size_t)(eq - kv);
    if (n >= sizeof(name))
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "parameter name too long in '%s'", kv);
    memcpy(name, kv, n);
    name[n] = '\0';
    const char *value = eq + 1;
    static const char *const truthy[] = {"true", "on", "yes"};
    static const char *const falsy[] = {"false", "off", "no"};
    for (int i = 0; i < 3; ++i) {
        if (strcasecmp(value, truthy[i]) == 0)
            return vbnl_params_set_number(p, name, 1.0, where, err);
        if (strcasecmp(value, falsy[i]) == 0)
            return vbnl_params_set_number(p, name, 0.0, where, err);
    }
    char *end = NULL;
    double d = strtod(value, &end);
    if (end && end != value && *end == '\0' && isfinite(d))
        return vbnl_params_set_number(p, name, d, where, err);
    return vbnl_params_set_string(p, name, value, where, err);
}

uint32_t vbnl_params_count(const vbnl_params *p) { return p ? p->count : 0; }

int vbnl_params_has(const vbnl_params *p, const char *name)
{
    for (uint32_t i = 0; p && name && i < p->count; ++i)
        if (strcmp(p->items[i].name, name) == 0)
            return 1;
    return 0;
}

vbnl_result vbnl_params_get(const vbnl_params *p, uint32_t i, const char **name, int *is_string,
                            double *number, const char **string, const char **where)
{
    if (!p || i >= p->count)
        return VBNL_ERR_INVALID_ARGUMENT;
    const param_entry *e = &p->items[i];
    if (name)
        *name = e->name;
    if (is_string)
        *is_string = e->is_string;
    if (number)
        *number = e->number;
    if (string)
        *string = e->string;
    if (where)
        *where = e->where;
    return VBNL_OK;
}

/* Levenshtein distance, for "did you mean" suggestions. */
static int edit_distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 63 || lb > 63)
        return 64;
    int row[64];
    for (size_t j = 0; j <= lb; ++j)
        row[j] = (int)j;
    for (size_t i = 1; i <= la; ++i) {
        int prev = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= lb; ++j) {
            int cur = row[j];
            int cost = a[i - 1] == b[j - 1] ? 0 : 1;
            int best = prev + cost;
            if (row[j] + 1 < best)
                best = row[j] + 1;
            if (row[j - 1] + 1 < best)
                best = row[j - 1] + 1;
            row[j] = best;
            prev = cur;
        }
    }
    return row[lb];
}

static const vbnl_param_spec *find_spec(const vbnl_param_spec *specs, uint32_t count, const char *name)
{
    for (uint32_t i = 0; i < count; ++i)
        if (strcmp(specs[i].name, name) == 0)
            return &specs[i];
    return NULL;
}

static const char *type_name(vbnl_param_type t)
{
    switch (t) {
    case VBNL_PARAM_INT: return "an integer";
    case VBNL_PARAM_FLOAT: return "a number";
    case VBNL_PARAM_BOOL: return "a boolean (on/off)";
    case VBNL_PARAM_ENUM: return "one of the listed words";
    case VBNL_PARAM_STRING: return "a string";
    }
    return "a value";
}

static void choices_text(const vbnl_param_spec *s, char *buf, size_t size)
{
    buf[0] = '\0';
    for (const char *const *c = s->choices; c && *c; ++c) {
        size_t len = strlen(buf);
        snprintf(buf + len, size - len, "%s%s", len ? ", " : "", *c);
    }
}

vbnl_result vbnl_params_validate(const vbnl_params *p, const vbnl_param_spec *specs, uint32_t count,
                                 const char *owner, vbnl_error *err)
{
    if (!p)
        return VBNL_OK;
    if (!owner)
        owner = "integrator";
    for (uint32_t i = 0; i < p->count; ++i) {
        const param_entry *e = &p->items[i];
        const char *at = e->where ? e->where : "";
        const char *sep = e->where ? ": " : "";
        const vbnl_param_spec *s = find_spec(specs, count, e->name);
        if (!s) {
            char list[768] = "";
            const char *closest = NULL;
            int best = 1 << 30;
            for (uint32_t k = 0; k < count; ++k) {
                size_t len = strlen(list);
                snprintf(list + len, sizeof(list) - len, "%s%s", k ? ", " : "", specs[k].name);
                int d = edit_distance(e->name, specs[k].name);
                if (d < best) {
                    best = d;
                    closest = specs[k].name;
                }
            }
            if (closest && best <= (int)(strlen(e->name) / 2 + 2))
                return vbnl_error_set(err, VBNL_ERR_UNKNOWN_NAME,
                                      "%s%sunknown parameter '%s' for %s; did you mean '%s'? (valid: %s)",
                                      at, sep, e->name, owner, closest, count ? list : "none");
            return vbnl_error_set(err, VBNL_ERR_UNKNOWN_NAME,
                                  "%s%sunknown parameter '%s' for %s (valid: %s)", at, sep, e->name,
                                  owner, count ? list : "none");
        }
        int want_string = s->type == VBNL_PARAM_ENUM || s->type == VBNL_PARAM_STRING;
        if (want_string != e->is_string)
            return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                  "%s%sparameter '%s' of %s takes %s", at, sep, e->name, owner,
                                  type_name(s->type));
        switch (s->type) {
        case VBNL_PARAM_INT:
            if (e->number != floor(e->number))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "%s%sparameter '%s' of %s takes an integer, got %g", at, sep,
                                      e->name, owner, e->number);
            /* fall through */
        case VBNL_PARAM_FLOAT:
            if (!(e->number >= s->min && e->number <= s->max))
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "%s%sparameter '%s' of %s must lie in [%g, %g], got %g", at,
                                      sep, e->name, owner, s->min, s->max, e->number);
            break;
        case VBNL_PARAM_BOOL:
            if (e->number != 0.0 && e->number != 1.0)
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "%s%sparameter '%s' of %s is on/off (1/0), got %g", at, sep,
                                      e->name, owner, e->number);
            break;
        case VBNL_PARAM_ENUM: {
            int ok = 0;
            for (const char *const *c = s->choices; c && *c; ++c)
                ok |= strcmp(*c, e->string) == 0;
            if (!ok) {
                char list[512];
                choices_text(s, list, sizeof(list));
                return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                      "%s%sparameter '%s' of %s must be one of %s, got '%s'", at, sep,
                                      e->name, owner, list, e->string);
            }
            break;
        }
        case VBNL_PARAM_STRING:
            break;
        }
    }
    return VBNL_OK;
}

static const param_entry *find_entry(const vbnl_params *p, const char *name)
{
    if (!p)
        return NULL;
    for (uint32_t i = 0; i < p->count; ++i)
        if (strcmp(p->items[i].name, name) == 0)
            return &p->items[i];
    return NULL;
}

double vbnl_params_number(const vbnl_params *p, const vbnl_param_spec *specs, uint32_t count,
                          const char *name)
{
    const param_entry *e = find_entry(p, name);
    if (e && !e->is_string)
        return e->number;
    const vbnl_param_spec *s = find_spec(specs, count, name);
    return s ? s->default_number : 0.0;
}

const char *vbnl_params_string(const vbnl_params *p, const vbnl_param_spec *specs, uint32_t count,
                               const char *name)
{
    const param_entry *e = find_entry(p, name);
    if (e && e->is_string)
        return e->string;
    const vbnl_param_spec *s = find_spec(specs, count, name);
    return s ? s->default_string : NULL;
}
