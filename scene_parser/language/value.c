/* vbnl scene parser: interned names, tracked memory, values, arrays and symbol tables. */
#include <stdlib.h>
#include <string.h>

#include "sdl_internal.h"

/* ---- memory ------------------------------------------------------------------------------ */

void *sdl_alloc(vbnl_sdl_parser *p, size_t n)
{
    if (n > p->limits.max_memory || p->memory > p->limits.max_memory - n) {
        sdl_errorf(p, NULL, "memory limit exceeded (%zu bytes for the scene's strings, arrays and objects)", p->limits.max_memory);
        return NULL;
    }
    void *q = calloc(1, n ? n : 1);
    if (!q) {
        p->fail_code = VBNL_ERR_OUT_OF_MEMORY;
        sdl_errorf(p, NULL, "out of memory");
        return NULL;
    }
    p->memory += n;
    return q;
}

bool sdl_charge(vbnl_sdl_parser *p, size_t n)
{
    if (n > p->limits.max_memory || p->memory > p->limits.max_memory - n) {
        sdl_errorf(p, NULL, "memory limit exceeded (%zu bytes for the scene's strings, arrays and objects)",
                   p->limits.max_memory);
        return false;
    }
    p->memory += n;
    return true;
}

void *sdl_realloc(vbnl_sdl_parser *p, void *ptr, size_t old, size_t n)
{
    if (n > old && (n - old > p->limits.max_memory || p->memory > p->limits.max_memory - (n - old))) {
        sdl_errorf(p, NULL, "memory limit exceeded (%zu bytes for the scene's strings, arrays and objects)", p->limits.max_memory);
        return NULL;
    }
    void *q = realloc(ptr, n ? n : 1);
    if (!q) {
        p->fail_code = VBNL_ERR_OUT_OF_MEMORY;
        sdl_errorf(p, NULL, "out of memory");
        return NULL;
    }
    p->memory = p->memory - old + n;
    return q;
}

void sdl_free(vbnl_sdl_parser *p, void *ptr, size_t n)
{
    if (!ptr)
        return;
    free(ptr);
    p->memory -= n <= p->memory ? n : p->memory;
}

char *sdl_strdup(vbnl_sdl_parser *p, const char *s, size_t len)
{
    char *q = sdl_alloc(p, len + 1);
    if (q && len)
        memcpy(q, s, len);
    return q;
}

/* ---- interned names ---------------------------------------------------------------------- */

static uint64_t hash_bytes(const char *s, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < n; i++)
        h = (h ^ (unsigned char)s[i]) * 1099511628211ull;
    return h;
}

const char *sdl_intern(vbnl_sdl_parser *p, const char *s, size_t len, int *kw)
{
    if (p->names_count * 2 >= p->names_cap) {
        size_t cap = p->names_cap ? p->names_cap * 2 : 1024;
        sdl_name *nt = calloc(cap, sizeof *nt);
        if (!nt) {
            sdl_errorf(p, NULL, "out of memory");
            return NULL;
        }
        for (size_t i = 0; i < p->names_cap; i++) {
            if (!p->names[i].s)
                continue;
            size_t h = hash_bytes(p->names[i].s, p->names[i].len) & (cap - 1);
            while (nt[h].s)
                h = (h + 1) & (cap - 1);
            nt[h] = p->names[i];
        }
        free(p->names);
        p->names = nt;
        p->names_cap = cap;
    }
    size_t h = hash_bytes(s, len) & (p->names_cap - 1);
    while (p->names[h].s) {
        if (p->names[h].len == len && memcmp(p->names[h].s, s, len) == 0) {
            if (kw)
                *kw = p->names[h].kw;
            return p->names[h].s;
        }
        h = (h + 1) & (p->names_cap - 1);
    }
    if (p->name_blocks_count == p->name_blocks_cap) {
        size_t cap = p->name_blocks_cap ? p->name_blocks_cap * 2 : 256;
        char **q = realloc(p->name_blocks, cap * sizeof *q);
        if (!q) {
            sdl_errorf(p, NULL, "out of memory");
            return NULL;
        }
        p->name_blocks = q;
        p->name_blocks_cap = cap;
    }
    char *copy = malloc(len + 1);
    if (!copy) {
        sdl_errorf(p, NULL, "out of memory");
        return NULL;
    }
    memcpy(copy, s, len);
    copy[len] = 0;
    p->name_blocks[p->name_blocks_count++] = copy;
    p->names[h].s = copy;
    p->names[h].len = len;
    p->names[h].kw = 0;
    p->names_count++;
    if (kw)
        *kw = 0;
    return copy;
}

/* ---- values ------------------------------------------------------------------------------ */

void sdl_set_float(vbnl_sdl_value *v, double f)
{
    memset(v, 0, sizeof *v);
    v->kind = VBNL_SDL_FLOAT;
    v->dim = 1;
    v->v[0] = f;
}

void sdl_set_vector(vbnl_sdl_value *v, int dim, const double *c)
{
    memset(v, 0, sizeof *v);
    v->kind = VBNL_SDL_VECTOR;
    v->dim = dim;
    for (int i = 0; i < dim; i++)
        v->v[i] = c[i];
}

bool sdl_set_string(vbnl_sdl_parser *p, vbnl_sdl_value *v, const char *s, size_t len)
{
    memset(v, 0, sizeof *v);
    char *q = sdl_strdup(p, s, len);
    if (!q)
        return false;
    v->kind = VBNL_SDL_STRING;
    v->u.str.s = q;
    v->u.str.len = len;
    return true;
}

static void array_free(vbnl_sdl_parser *p, vbnl_sdl_array *a)
{
    if (a->pins > 0) {
        a->dead = true;
        return;
    }
    for (size_t i = 0; i < a->count; i++)
        vbnl_sdl_value_clear(p, &a->elems[i]);
    sdl_free(p, a->elems, a->count * sizeof *a->elems);
    sdl_free(p, a, sizeof *a);
}

void sdl_array_unpin(vbnl_sdl_parser *p, vbnl_sdl_array *a)
{
    if (--a->pins == 0 && a->dead)
        array_free(p, a);
}

vbnl_sdl_array *sdl_array_new(vbnl_sdl_parser *p, int rank, const size_t *dims)
{
    size_t count = 1;
    for (int i = 0; i < rank; i++) {
        if (dims[i] == 0 || count > SIZE_MAX / sizeof(vbnl_sdl_value) / dims[i]) {
            sdl_errorf(p, NULL, "array too large");
            return NULL;
        }
        count *= dims[i];
    }
    if (count > p->limits.max_memory / sizeof(vbnl_sdl_value)) {
        sdl_errorf(p, NULL, "memory limit exceeded (array of %zu elements)", count);
        return NULL;
    }
    vbnl_sdl_array *a = sdl_alloc(p, sizeof *a);
    if (!a)
        return NULL;
    a->elems = sdl_alloc(p, count * sizeof *a->elems);
    if (!a->elems) {
        sdl_free(p, a, sizeof *a);
        return NULL;
    }
    a->rank = rank;
    memcpy(a->dims, dims, (size_t)rank * sizeof *dims);
    a->count = count;
    return a;
}

void sdl_block_release(vbnl_sdl_parser *p, vbnl_sdl_block *b)
{
    if (b && --b->refs == 0)
        sdl_free(p, b, sizeof *b);
}

void sdl_macro_free(vbnl_sdl_parser *p, vbnl_sdl_macro *m)
{
    if (!m || --m->refs > 0)
        return;
    free(m->params);
    free(m->optional);
    sdl_free(p, m, sizeof *m);
}

void vbnl_sdl_value_clear(vbnl_sdl_parser *p, vbnl_sdl_value *v)
{
    if (!v)
        return;
    switch (v->kind) {
    case VBNL_SDL_STRING: sdl_free(p, v->u.str.s, v->u.str.len + 1); break;
    case VBNL_SDL_ARRAY: if (v->u.array) array_free(p, v->u.array); break;
    case VBNL_SDL_FUNCTION: sdl_function_release(p, v->u.fn); break;
    case VBNL_SDL_BLOCK: sdl_block_release(p, v->u.block); break;
    case VBNL_SDL_MACRO: sdl_macro_free(p, v->u.macro); break;
    case VBNL_SDL_SPLINE: sdl_spline_release(p, v->u.spline); break;
    case VBNL_SDL_OBJECT:
        if (v->u.obj.type && v->u.obj.type->destroy)
            v->u.obj.type->destroy(v->u.obj.ptr, v->u.obj.type->user);
        break;
    default: break;
    }
    memset(v, 0, sizeof *v);
}

vbnl_result vbnl_sdl_value_copy(vbnl_sdl_parser *p, vbnl_sdl_value *dst, const vbnl_sdl_value *src)
{
    *dst = *src;
    switch (src->kind) {
    case VBNL_SDL_STRING:
        if (!sdl_set_string(p, dst, src->u.str.s, src->u.str.len))
            return VBNL_ERR_OUT_OF_MEMORY;
        break;
    case VBNL_SDL_ARRAY: {
        const vbnl_sdl_array *a = src->u.array;
        vbnl_sdl_array *b = sdl_array_new(p, a->rank, a->dims);
        if (!b) {
            memset(dst, 0, sizeof *dst);
            return VBNL_ERR_OUT_OF_MEMORY;
        }
        for (size_t i = 0; i < a->count; i++) {
            if (vbnl_sdl_value_copy(p, &b->elems[i], &a->elems[i]) != VBNL_OK) {
                array_free(p, b);
                memset(dst, 0, sizeof *dst);
                return VBNL_ERR_OUT_OF_MEMORY;
            }
        }
        dst->u.array = b;
        break;
    }
    case VBNL_SDL_FUNCTION: sdl_function_retain(src->u.fn); break;
    case VBNL_SDL_BLOCK: src->u.block->refs++; break;
    case VBNL_SDL_SPLINE: sdl_spline_retain(src->u.spline); break;
    case VBNL_SDL_MACRO: memset(dst, 0, sizeof *dst); break; /* macros are not values */
    case VBNL_SDL_OBJECT:
        if (src->u.obj.type && src->u.obj.type->copy) {
            dst->u.obj.ptr = src->u.obj.type->copy(src->u.obj.ptr, src->u.obj.type->user);
            if (!dst->u.obj.ptr && src->u.obj.ptr) {
                memset(dst, 0, sizeof *dst);
                sdl_errorf(p, NULL, "out of memory copying a %s", src->u.obj.type->name);
                return VBNL_ERR_OUT_OF_MEMORY;
            }
        }
        break;
    default: break;
    }
    return VBNL_OK;
}

void vbnl_sdl_value_object(vbnl_sdl_value *out, void *ptr, const vbnl_sdl_opaque_type *type, int tag)
{
    memset(out, 0, sizeof *out);
    out->kind = VBNL_SDL_OBJECT;
    out->u.obj.ptr = ptr;
    out->u.obj.type = type;
    out->u.obj.tag = tag;
}

const char *vbnl_sdl_kind_name(vbnl_sdl_kind kind)
{
    static const char *const names[] = { "uninitialized value", "float", "vector", "color",
                                         "string", "array", "function", "object", "block",
                                         "macro", "random stream", "spline" };
    return (unsigned)kind < sizeof names / sizeof names[0] ? names[kind] : "?";
}

int vbnl_sdl_array_rank(const vbnl_sdl_array *a) { return a ? a->rank : 0; }
size_t vbnl_sdl_array_size(const vbnl_sdl_array *a, int dim)
{
    return a && dim >= 0 && dim < a->rank ? a->dims[dim] : 0;
}
const vbnl_sdl_value *vbnl_sdl_array_at(const vbnl_sdl_array *a, size_t i)
{
    return a && i < a->count ? &a->elems[i] : NULL;
}
const char *vbnl_sdl_block_keyword(const vbnl_sdl_block *b) { return b ? b->keyword : ""; }
vbnl_sdl_loc vbnl_sdl_block_loc(const vbnl_sdl_block *b)
{
    vbnl_sdl_loc none = { "", 0, 0 };
    return b ? b->loc : none;
}

/* ---- symbol tables (open addressing on interned pointers) -------------------------------- */

#define VBI_SDL_TOMB ((const char *)1)

void sdl_table_init(sdl_table *t)
{
    memset(t, 0, sizeof *t);
}

void sdl_table_free(vbnl_sdl_parser *p, sdl_table *t)
{
    for (size_t i = 0; i < t->cap; i++)
        if (t->slots[i].name && t->slots[i].name != VBI_SDL_TOMB)
            vbnl_sdl_value_clear(p, &t->slots[i].val);
    free(t->slots);
    memset(t, 0, sizeof *t);
}

static size_t ptr_hash(const char *s)
{
    uintptr_t x = (uintptr_t)s;
    x ^= x >> 17;
    x *= 0x9E3779B97F4A7C15ull;
    return (size_t)(x >> 20);
}

sdl_sym *sdl_table_find(const sdl_table *t, const char *name)
{
    if (!t->cap)
        return NULL;
    size_t h = ptr_hash(name) & (t->cap - 1);
    while (t->slots[h].name) {
        if (t->slots[h].name == name)
            return &t->slots[h];
        h = (h + 1) & (t->cap - 1);
    }
    return NULL;
}

sdl_sym *sdl_table_insert(vbnl_sdl_parser *p, sdl_table *t, const char *name)
{
    sdl_sym *s = sdl_table_find(t, name);
    if (s)
        return s;
    if ((t->used + 1) * 4 >= t->cap * 3) {
        size_t cap = t->cap ? (t->count * 2 >= t->cap / 2 ? t->cap * 2 : t->cap) : 16;
        sdl_sym *ns = calloc(cap, sizeof *ns);
        if (!ns) {
            sdl_errorf(p, NULL, "out of memory");
            return NULL;
        }
        for (size_t i = 0; i < t->cap; i++) {
            if (!t->slots[i].name || t->slots[i].name == VBI_SDL_TOMB)
                continue;
            size_t h = ptr_hash(t->slots[i].name) & (cap - 1);
            while (ns[h].name)
                h = (h + 1) & (cap - 1);
            ns[h] = t->slots[i];
        }
        free(t->slots);
        t->slots = ns;
        t->cap = cap;
        t->used = t->count;
    }
    size_t h = ptr_hash(name) & (t->cap - 1);
    while (t->slots[h].name && t->slots[h].name != VBI_SDL_TOMB)
        h = (h + 1) & (t->cap - 1);
    if (!t->slots[h].name)
        t->used++;
    t->slots[h].name = name;
    t->slots[h].ref = NULL;
    memset(&t->slots[h].val, 0, sizeof t->slots[h].val);
    t->count++;
    return &t->slots[h];
}

bool sdl_table_remove(vbnl_sdl_parser *p, sdl_table *t, const char *name)
{
    sdl_sym *s = sdl_table_find(t, name);
    if (!s)
        return false;
    vbnl_sdl_value_clear(p, &s->val);
    s->name = VBI_SDL_TOMB;
    t->count--;
    return true;
}

static sdl_sym *lookup_from(vbnl_sdl_parser *p, const char *name, int top, int *frame)
{
    for (int i = top; i >= 0; i--) {
        sdl_sym *s = sdl_table_find(&p->frames[i].locals, name);
        if (s) {
            if (frame)
                *frame = i;
            return s;
        }
    }
    if (frame)
        *frame = -1;
    return sdl_table_find(&p->globals, name);
}

/* Innermost binding, without following parameter aliases. */
sdl_sym *sdl_lookup_binding(vbnl_sdl_parser *p, const char *name, int *frame)
{
    return lookup_from(p, name, p->nframes - 1, frame);
}

/* Follows parameter aliases (bounded: each alias points to a lower frame). */
sdl_sym *sdl_resolve(vbnl_sdl_parser *p, sdl_sym *s)
{
    for (int guard = 0; s && s->ref && guard < 100000; guard++) {
        int top = s->ref_frame < p->nframes ? s->ref_frame : p->nframes - 1;
        s = lookup_from(p, s->ref, top, NULL);
    }
    return s && s->ref ? NULL : s;
}

/* Innermost visible symbol: POV-Ray scopes are dynamic (macro and include locals stack). */
sdl_sym *sdl_lookup(vbnl_sdl_parser *p, const char *name)
{
    return sdl_resolve(p, lookup_from(p, name, p->nframes - 1, NULL));
}

/* Interns `s` and marks it as keyword `kw` (parser creation). */
const char *sdl_intern_keyword(vbnl_sdl_parser *p, const char *s, int kw)
{
    size_t len = strlen(s);
    const char *name = sdl_intern(p, s, len, NULL);
    if (!name)
        return NULL;
    size_t h = hash_bytes(s, len) & (p->names_cap - 1);
    while (p->names[h].s != name)
        h = (h + 1) & (p->names_cap - 1);
    p->names[h].kw = kw;
    return name;
}
