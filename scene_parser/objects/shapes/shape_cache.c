/* vbnl object layer: shapes made once per load and shared (pov_surface.h). A macro that builds the
 * same isosurface, glyph or CSG three hundred times (POV-Ray's sample scenes do) gets one mesh
 * and one solid, referenced three hundred times; the memory a scene's geometry takes is charged
 * once (load.c counts only meshes nothing else references). Keys are the bytes of everything
 * the result depends on, compared in full. */
#include <stdlib.h>
#include <string.h>

#include "pov_surface.h"

typedef struct cache_entry {
    unsigned char *key;
    size_t len;
    uint64_t hash;
    pov_mesh *mesh;
    pov_solid *solid;
    pov_obj obj; /* CSG results */
    int is_obj;
} cache_entry;

struct pov_shape_cache {
    cache_entry *e;
    size_t n, cap;
};

static uint64_t fnv(const unsigned char *p, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < n; ++i)
        h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

static cache_entry *find(pov_loader *L, const void *key, size_t len, int is_obj)
{
    pov_shape_cache *c = L->shape_cache;
    if (!c)
        return NULL;
    uint64_t h = fnv(key, len);
    for (size_t i = 0; i < c->n; ++i)
        if (c->e[i].hash == h && c->e[i].len == len && c->e[i].is_obj == is_obj && !memcmp(c->e[i].key, key, len))
            return &c->e[i];
    return NULL;
}

static cache_entry *add(pov_loader *L, const void *key, size_t len, int is_obj)
{
    if (!L->shape_cache && !(L->shape_cache = calloc(1, sizeof *L->shape_cache)))
        return NULL;
    pov_shape_cache *c = L->shape_cache;
    if (c->n == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 16;
        cache_entry *n = realloc(c->e, cap * sizeof *n);
        if (!n)
            return NULL;
        c->e = n;
        c->cap = cap;
    }
    cache_entry *e = &c->e[c->n];
    memset(e, 0, sizeof *e);
    if (!(e->key = malloc(len ? len : 1)))
        return NULL;
    memcpy(e->key, key, len);
    e->len = len;
    e->hash = fnv(key, len);
    e->is_obj = is_obj;
    c->n++;
    return e;
}

int pov_shape_cache_get(pov_loader *L, const void *key, size_t len, pov_mesh **mesh, pov_solid **solid)
{
    cache_entry *e = find(L, key, len, 0);
    if (!e)
        return 0;
    *mesh = e->mesh;
    e->mesh->refs++;
    *solid = pov_solid_ref(e->solid);
    return 1;
}

void pov_shape_cache_put(pov_loader *L, const void *key, size_t len, pov_mesh *mesh, pov_solid *solid)
{
    cache_entry *e = find(L, key, len, 0) ? NULL : add(L, key, len, 0);
    if (!e)
        return; /* out of memory: the shape is just not shared */
    e->mesh = mesh;
    mesh->refs++;
    e->solid = pov_solid_ref(solid);
}

int pov_shape_cache_get_obj(pov_loader *L, const void *key, size_t len, pov_obj *out, int *oom)
{
    cache_entry *e = find(L, key, len, 1);
    *oom = 0;
    if (!e)
        return 0;
    *oom = !pov_obj_append_copy(out, &e->obj);
    return 1;
}

void pov_shape_cache_put_obj(pov_loader *L, const void *key, size_t len, const pov_obj *o)
{
    cache_entry *e = find(L, key, len, 1) ? NULL : add(L, key, len, 1);
    if (e && !pov_obj_append_copy(&e->obj, o))
        pov_obj_clear(&e->obj); /* out of memory: an empty result would be wrong; drop it */
    if (e && !e->obj.n && o->n) {
        free(e->key); /* forget the entry */
        L->shape_cache->n--;
    }
}

void pov_shape_cache_free(pov_loader *L)
{
    pov_shape_cache *c = L->shape_cache;
    if (!c)
        return;
    for (size_t i = 0; i < c->n; ++i) {
        free(c->e[i].key);
        pov_mesh_unref(c->e[i].mesh);
        pov_solid_unref(c->e[i].solid);
        pov_obj_clear(&c->e[i].obj);
    }
    free(c->e);
    free(c);
    L->shape_cache = NULL;
}

void pov_key_add(pov_key *k, const void *p, size_t n)
{
    if (k->failed)
        return;
    if (k->n + n > k->cap) {
        size_t cap = (k->n + n) * 2 + 64;
        unsigned char *b = realloc(k->b, cap);
        if (!b) {
            k->failed = 1;
            return;
        }
        k->b = b;
        k->cap = cap;
    }
    memcpy(k->b + k->n, p, n);
    k->n += n;
}

void pov_key_free(pov_key *k)
{
    free(k->b);
    memset(k, 0, sizeof *k);
}

/* The key of a simple shape: its kind and its parameters. */
static void simple_key(pov_key *k, const char *kind, const double *params, int n)
{
    pov_key_add(k, kind, strlen(kind) + 1);
    pov_key_add(k, params, (size_t)n * sizeof *params);
}

int pov_shape_cache_find(pov_loader *L, const char *kind, const double *params, int n, pov_mesh **mesh,
                         pov_solid **solid)
{
    pov_key k = {0};
    simple_key(&k, kind, params, n);
    int found = !k.failed && pov_shape_cache_get(L, k.b, k.n, mesh, solid);
    pov_key_free(&k);
    return found;
}

void pov_shape_cache_keep(pov_loader *L, const char *kind, const double *params, int n, pov_mesh *mesh, pov_solid *solid)
{
    pov_key k = {0};
    simple_key(&k, kind, params, n);
    if (!k.failed)
        pov_shape_cache_put(L, k.b, k.n, mesh, solid);
    pov_key_free(&k);
}
