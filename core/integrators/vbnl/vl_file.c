/* Saving and loading a prepared virtual-light set: format and rules in vl_file.h. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include "vl_file.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "atomic_file.h"
#include "camera_mesh.h"
#include "read_file.h"

#define BYTE_ORDER_MARK 0x01020304u
#define BYTE_ORDER_SWAPPED 0x04030201u
#define FNV_PRIME 0x100000001b3ull

_Static_assert(sizeof(vec3) == 12, "vec3 must be three packed floats (the file stores them so)");

uint64_t vbi_vl_file_hash(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; ++i)
        h = (h ^ p[i]) * FNV_PRIME;
    return h;
}

static size_t pad8(size_t n) { return (8 - n % 8) % 8; }

/* Bytes of a file of this version with these counts (0 on overflow); a placement (no photon
 * path) stores no incident data. */
static uint64_t file_size(uint64_t count, uint64_t glossy, uint64_t res, uint64_t photons)
{
    if (count > UINT32_MAX || glossy > count || res > 64)
        return 0;
    uint64_t per = 12 + 12 + 4 + 12 + 4 + 4 + 1;
    uint64_t n = VBI_VL_FILE_HEADER_SIZE + count * per;
    n += pad8((size_t)(count % 8));
    if (photons)
        n += count * 24 + glossy * res * res * 24;
    return n + 8;
}

/* ---- header (explicit offsets, no struct padding in the file) ---------------------------------- */

static void put(unsigned char *b, size_t off, const void *v, size_t n) { memcpy(b + off, v, n); }
static void get(const unsigned char *b, size_t off, void *v, size_t n) { memcpy(v, b + off, n); }

static void header_encode(unsigned char b[VBI_VL_FILE_HEADER_SIZE], const vbi_vl_file_header *h, uint32_t count,
                          uint32_t glossy)
{
    memset(b, 0, VBI_VL_FILE_HEADER_SIZE);
    uint32_t version = VBI_VL_FILE_VERSION, mark = BYTE_ORDER_MARK;
    memcpy(b, VBI_VL_FILE_MAGIC, 8);
    put(b, 8, &version, 4);
    put(b, 12, &mark, 4);
    put(b, 16, &h->fingerprint, 8);
    put(b, 24, &count, 4);
    put(b, 28, &h->virtual_lights, 4);
    put(b, 32, &h->profile_resolution, 4);
    put(b, 36, &glossy, 4);
    put(b, 40, &h->photon_paths, 8);
    put(b, 48, &h->photon_first, 8);
    put(b, 56, &h->photon_count, 8);
    put(b, 64, &h->unit, 8);
    put(b, 72, &h->seed, 8);
    put(b, 80, &h->elimination, 4);
    put(b, 84, &h->radius_scale, 4);
    put(b, 88, &h->material_count, 4);
    put(b, 92, &h->flags, 4);
    put(b, 96, &h->width, 4);
    put(b, 100, &h->height, 4);
    put(b, 104, &h->camera, 8);
    put(b, 112, &h->preparation, 8);
    put(b, 120, &h->set, 8);
    put(b, 128, &h->placement_seconds, 8);
    put(b, 136, &h->elimination_seconds, 8);
    put(b, 144, &h->photon_seconds, 8);
    put(b, 152, &h->photon_rays, 8);
}

static void header_decode(const unsigned char *b, vbi_vl_file_header *h, uint32_t *count, uint32_t *glossy)
{
    memset(h, 0, sizeof(*h));
    get(b, 8, &h->version, 4);
    get(b, 16, &h->fingerprint, 8);
    get(b, 24, count, 4);
    get(b, 28, &h->virtual_lights, 4);
    get(b, 32, &h->profile_resolution, 4);
    get(b, 36, glossy, 4);
    get(b, 40, &h->photon_paths, 8);
    get(b, 48, &h->photon_first, 8);
    get(b, 56, &h->photon_count, 8);
    get(b, 64, &h->unit, 8);
    get(b, 72, &h->seed, 8);
    get(b, 80, &h->elimination, 4);
    get(b, 84, &h->radius_scale, 4);
    get(b, 88, &h->material_count, 4);
    get(b, 92, &h->flags, 4);
    get(b, 96, &h->width, 4);
    get(b, 100, &h->height, 4);
    get(b, 104, &h->camera, 8);
    get(b, 112, &h->preparation, 8);
    get(b, 120, &h->set, 8);
    get(b, 128, &h->placement_seconds, 8);
    get(b, 136, &h->elimination_seconds, 8);
    get(b, 144, &h->photon_seconds, 8);
    get(b, 152, &h->photon_rays, 8);
    h->count = *count;
    h->glossy_count = *glossy;
}

/* The set fingerprint: the arrays as the file stores them, up to the glossy flags. */
static uint64_t set_fingerprint(const vbi_vl_set *vls, const uint8_t *glossy)
{
    const size_t n = vls->count;
    uint64_t h = VBI_VL_FILE_HASH_INIT;
    h = vbi_vl_file_hash(h, vls->position, sizeof(vec3) * n);
    h = vbi_vl_file_hash(h, vls->normal, sizeof(vec3) * n);
    h = vbi_vl_file_hash(h, vls->material, sizeof(uint32_t) * n);
    h = vbi_vl_file_hash(h, vls->tint, sizeof(vec3) * n);
    h = vbi_vl_file_hash(h, vls->radius, sizeof(float) * n);
    h = vbi_vl_file_hash(h, vls->density, sizeof(float) * n);
    return vbi_vl_file_hash(h, glossy, n);
}

/* ---- writing ------------------------------------------------------------------------------ */

typedef struct writer {
    FILE *f;
    uint64_t hash;
    int failed;
} writer;

static void w_bytes(writer *w, const void *data, size_t n)
{
    if (w->failed || n == 0)
        return;
    w->hash = vbi_vl_file_hash(w->hash, data, n);
    if (fwrite(data, 1, n, w->f) != n)
        w->failed = errno ? errno : EIO;
}

vbnl_result vbi_vl_file_save(const char *path, const vbi_vl_file_header *h, const vbi_vl_set *vls,
                              const vbi_profile_set *profiles, vbnl_error *err)
{
    if (!path || !*path || !h || !vls || !profiles)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_vl_file_save: NULL or empty argument");
    const uint32_t n = vls->count;
    if (vbi_profile_set_count(profiles) != n || vbi_profile_set_unit(profiles) != h->unit)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                              "vbi_vl_file_save: the profiles do not belong to this set (count or unit)");
    uint8_t *glossy = malloc((size_t)n + 8);
    if (!glossy)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot write '%s': out of memory", path);
    uint32_t n_glossy = 0;
    for (uint32_t j = 0; j < n; ++j) {
        glossy[j] = (uint8_t)(vbi_profile_is_glossy(profiles, j) != 0);
        if (glossy[j] && !vbi_profile_incident_map_fixed(profiles, j)) {
            free(glossy);
            return vbnl_error_set(err, VBNL_ERR_STATE, "cannot write '%s': the incident maps were released", path);
        }
        n_glossy += glossy[j];
    }
    memset(glossy + n, 0, 8);
    const uint32_t res = h->profile_resolution;
    const size_t texels = (size_t)res * res;

    /* Through the atomic files (atomic_file.h): a temporary next to `path`, fsync, rename, and
     * listed in the table that a signal handler empties before the process ends (the plugin's
     * abandon_writes), so that an interrupted save leaves no temporary behind. */
    vbi_atomic_file af;
    vbnl_result r = vbi_atomic_file_open(&af, path, err);
    if (r != VBNL_OK) {
        free(glossy);
        return r;
    }
    int fd = dup(af.fd); /* fclose closes this one; the atomic file keeps its own for fsync */
    writer w = {fd >= 0 ? fdopen(fd, "wb") : NULL, VBI_VL_FILE_HASH_INIT, 0};
    if (!w.f) {
        int e = errno;
        if (fd >= 0)
            close(fd);
        vbi_atomic_file_discard(&af);
        free(glossy);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", path, strerror(e));
    }
    vbi_vl_file_header hw = *h;
    hw.set = set_fingerprint(vls, glossy);
    unsigned char hb[VBI_VL_FILE_HEADER_SIZE];
    header_encode(hb, &hw, n, n_glossy);
    w_bytes(&w, hb, sizeof(hb));
    w_bytes(&w, vls->position, sizeof(vec3) * (size_t)n);
    w_bytes(&w, vls->normal, sizeof(vec3) * (size_t)n);
    w_bytes(&w, vls->material, sizeof(uint32_t) * (size_t)n);
    w_bytes(&w, vls->tint, sizeof(vec3) * (size_t)n);
    w_bytes(&w, vls->radius, sizeof(float) * (size_t)n);
    w_bytes(&w, vls->density, sizeof(float) * (size_t)n);
    w_bytes(&w, glossy, (size_t)n + pad8(n));
    for (uint32_t j = 0; h->photon_count && j < n; ++j) /* a placement has none yet */
        w_bytes(&w, vbi_profile_incident_power_fixed(profiles, j), 3 * sizeof(uint64_t));
    for (uint32_t j = 0; h->photon_count && j < n; ++j)
        if (glossy[j])
            w_bytes(&w, vbi_profile_incident_map_fixed(profiles, j), 3 * texels * sizeof(uint64_t));
    uint64_t sum = w.hash;
    w_bytes(&w, &sum, sizeof(sum));
    free(glossy);
    if (!w.failed && fflush(w.f) != 0)
        w.failed = errno ? errno : EIO;
    if (fclose(w.f) != 0 && !w.failed)
        w.failed = errno ? errno : EIO;
    if (w.failed) {
        vbi_atomic_file_discard(&af);
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot write '%s': %s", path, strerror(w.failed));
    }
    return vbi_atomic_file_commit(&af, err); /* fsync, rename */
}

/* ---- reading ------------------------------------------------------------------------------ */

typedef struct reader {
    FILE *f;
    const char *path;
    vbnl_error *err;
} reader;

static vbnl_result r_bytes(reader *r, void *data, size_t n)
{
    if (n && fread(data, 1, n, r->f) != n)
        return vbnl_error_set(r->err, ferror(r->f) ? VBNL_ERR_IO : VBNL_ERR_CORRUPT, "cannot read '%s': %s",
                              r->path, ferror(r->f) ? strerror(errno) : "unexpected end of file");
    return VBNL_OK;
}

/* Pass 1: everything that can be said before the contents are trusted. Checks the magic, the
 * byte order and the checksum, then the version, and decodes the header. */
static vbnl_result check_file(reader *r, uint64_t size, vbi_vl_file_header *h, uint32_t *count, uint32_t *glossy)
{
    unsigned char hb[VBI_VL_FILE_HEADER_SIZE];
    memset(hb, 0, sizeof(hb));
    size_t got = fread(hb, 1, sizeof(hb), r->f);
    if (got < 16 || memcmp(hb, VBI_VL_FILE_MAGIC, 8) != 0)
        return vbnl_error_set(r->err, VBNL_ERR_CORRUPT, "'%s' is not a virtual-light file (%s)", r->path,
                              got < 8 ? "too short" : "bad magic");
    uint32_t mark;
    get(hb, 12, &mark, 4);
    if (mark == BYTE_ORDER_SWAPPED)
        return vbnl_error_set(r->err, VBNL_ERR_UNSUPPORTED,
                              "'%s' was written on a machine of the other byte order; save it again here", r->path);
    if (mark != BYTE_ORDER_MARK || size < 16 + 8)
        return vbnl_error_set(r->err, VBNL_ERR_CORRUPT, "'%s' is damaged (%s)", r->path,
                              mark != BYTE_ORDER_MARK ? "bad byte-order marker" : "too short");
    /* the checksum over everything before the last 8 bytes */
    uint64_t hash = vbi_vl_file_hash(VBI_VL_FILE_HASH_INIT, hb, got);
    uint64_t left = size - 8 - got;
    if (got > size - 8) { /* the header read overlapped the checksum itself */
        hash = vbi_vl_file_hash(VBI_VL_FILE_HASH_INIT, hb, (size_t)(size - 8));
        left = 0;
    }
    unsigned char *buf = malloc(1u << 20);
    if (!buf)
        return vbnl_error_set(r->err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': out of memory", r->path);
    vbnl_result res = VBNL_OK;
    if (got > size - 8) {
        if (fseeko(r->f, (off_t)(size - 8), SEEK_SET) != 0)
            res = vbnl_error_set(r->err, VBNL_ERR_IO, "cannot read '%s': %s", r->path, strerror(errno));
    }
    while (res == VBNL_OK && left > 0) {
        size_t n = left < (1u << 20) ? (size_t)left : (1u << 20);
        res = r_bytes(r, buf, n);
        if (res == VBNL_OK)
            hash = vbi_vl_file_hash(hash, buf, n);
        left -= n;
    }
    uint64_t stored = 0;
    if (res == VBNL_OK)
        res = r_bytes(r, &stored, sizeof(stored));
    free(buf);
    if (res != VBNL_OK)
        return res;
    header_decode(hb, h, count, glossy);
    if (stored != hash) {
        uint64_t want = got == sizeof(hb) && h->version == VBI_VL_FILE_VERSION
                            ? file_size(*count, *glossy, h->profile_resolution, h->photon_count)
                            : 0;
        if (want > size)
            return vbnl_error_set(r->err, VBNL_ERR_CORRUPT, "'%s' is damaged (truncated: %llu of %llu bytes)",
                                  r->path, (unsigned long long)size, (unsigned long long)want);
        return vbnl_error_set(r->err, VBNL_ERR_CORRUPT, "'%s' is damaged (checksum mismatch)", r->path);
    }
    if (h->version != VBI_VL_FILE_VERSION)
        return vbnl_error_set(r->err, VBNL_ERR_CORRUPT, "'%s' was written by format version %u; this build reads version %u",
                              r->path, h->version, VBI_VL_FILE_VERSION);
    int e;
    if (got != sizeof(hb) || file_size(*count, *glossy, h->profile_resolution, h->photon_count) != size ||
        *count == 0 ||
        (h->profile_resolution != 8 && h->profile_resolution != 16 && h->profile_resolution != 32) ||
        !(h->unit > 0.0) || frexp(h->unit, &e) != 0.5 || h->photon_paths == 0 ||
        h->photon_first > h->photon_paths || h->photon_count > h->photon_paths - h->photon_first)
        return vbnl_error_set(r->err, VBNL_ERR_CORRUPT, "'%s' is damaged (inconsistent header)", r->path);
    return VBNL_OK;
}

/* Opens `path` for reading: a regular file (a FIFO is refused without waiting on it,
 * read_file.h), its size in *size. */
static vbnl_result open_file(const char *path, reader *r, uint64_t *size, vbnl_error *err)
{
    struct stat st;
    const char *why;
    *size = 0;
    r->f = vbi_read_fopen(path, &st, &why);
    r->path = path;
    r->err = err;
    if (!r->f)
        return vbnl_error_set(err, VBNL_ERR_IO, "cannot read '%s': %s", path, why);
    *size = (uint64_t)st.st_size;
    return VBNL_OK;
}

vbnl_result vbi_vl_file_read_header(const char *path, int verify, vbi_vl_file_header *out, vbnl_error *err)
{
    if (!path || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_vl_file_read_header: NULL argument");
    memset(out, 0, sizeof(*out));
    reader r;
    uint64_t size;
    vbnl_result res = open_file(path, &r, &size, err);
    if (res != VBNL_OK)
        return res;
    uint32_t n = 0, glossy = 0;
    if (verify) {
        res = check_file(&r, size, out, &n, &glossy);
    } else {
        unsigned char hb[VBI_VL_FILE_HEADER_SIZE];
        uint32_t mark = 0;
        if (fread(hb, 1, sizeof(hb), r.f) != sizeof(hb) || memcmp(hb, VBI_VL_FILE_MAGIC, 8) != 0)
            res = vbnl_error_set(err, VBNL_ERR_CORRUPT, "'%s' is not a virtual-light file", path);
        if (res == VBNL_OK) {
            get(hb, 12, &mark, 4);
            header_decode(hb, out, &n, &glossy);
            if (mark != BYTE_ORDER_MARK || out->version != VBI_VL_FILE_VERSION ||
                file_size(n, glossy, out->profile_resolution, out->photon_count) != size)
                res = vbnl_error_set(err, VBNL_ERR_CORRUPT, "'%s' is damaged or of another version", path);
        }
    }
    fclose(r.f);
    if (res != VBNL_OK)
        memset(out, 0, sizeof(*out));
    return res;
}

/* Reads one file into `d` (creating d->map when NULL, else requiring its resolution). With a
 * scene, the file must belong to it; without one (merging files), its own material count bounds
 * the lights' materials and the callers compare the files with each other. */
static vbnl_result load_one(const char *path, const vbnl_scene *scene, vbi_vl_file_data *d, vbnl_error *err)
{
    reader r;
    uint64_t size;
    vbnl_result res = open_file(path, &r, &size, err);
    if (res != VBNL_OK)
        return res;
    uint32_t n = 0, n_glossy = 0;
    vbi_vl_file_header *h = &d->header;
    res = check_file(&r, size, h, &n, &n_glossy);
    uint64_t fp = scene ? vbi_scene_fingerprint(scene) : h->fingerprint;
    const uint32_t materials = scene ? scene->material_count : h->material_count;
    if (res == VBNL_OK && h->fingerprint != fp)
        res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                             "'%s' was prepared for another scene (fingerprint %016llx, this scene %016llx)", path,
                             (unsigned long long)h->fingerprint, (unsigned long long)fp);
    if (res == VBNL_OK && h->material_count != materials)
        res = vbnl_error_set(err, VBNL_ERR_CORRUPT, "'%s' is damaged (material count %u, the scene has %u)", path,
                             h->material_count, materials);
    if (res == VBNL_OK && fseeko(r.f, VBI_VL_FILE_HEADER_SIZE, SEEK_SET) != 0)
        res = vbnl_error_set(err, VBNL_ERR_IO, "cannot read '%s': %s", path, strerror(errno));
    if (res == VBNL_OK && !d->map && vbi_hemioct_create(h->profile_resolution, &d->map) != VBNL_OK)
        res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': out of memory", path);
    if (res == VBNL_OK && vbi_hemioct_res(d->map) != h->profile_resolution)
        res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "'%s' has profile resolution %u, expected %u", path,
                             h->profile_resolution, vbi_hemioct_res(d->map));
    if (res == VBNL_OK)
        res = vbi_vl_set_alloc(&d->vls, n, err);
    uint8_t *glossy = NULL;
    uint64_t *phi = NULL, *map = NULL;
    const size_t texels = (size_t)h->profile_resolution * h->profile_resolution;
    if (res == VBNL_OK) {
        glossy = malloc((size_t)n + 8);
        phi = malloc(3 * sizeof(uint64_t) * (size_t)n);
        map = malloc(3 * sizeof(uint64_t) * texels);
        if (!glossy || !phi || !map)
            res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': out of memory", path);
    }
    if (res == VBNL_OK && (res = r_bytes(&r, d->vls.position, sizeof(vec3) * (size_t)n)) == VBNL_OK &&
        (res = r_bytes(&r, d->vls.normal, sizeof(vec3) * (size_t)n)) == VBNL_OK &&
        (res = r_bytes(&r, d->vls.material, sizeof(uint32_t) * (size_t)n)) == VBNL_OK &&
        (res = r_bytes(&r, d->vls.tint, sizeof(vec3) * (size_t)n)) == VBNL_OK &&
        (res = r_bytes(&r, d->vls.radius, sizeof(float) * (size_t)n)) == VBNL_OK &&
        (res = r_bytes(&r, d->vls.density, sizeof(float) * (size_t)n)) == VBNL_OK &&
        (res = r_bytes(&r, glossy, (size_t)n + pad8(n))) == VBNL_OK && h->photon_count)
        res = r_bytes(&r, phi, 3 * sizeof(uint64_t) * (size_t)n);
    if (res == VBNL_OK) {
        uint32_t g = 0;
        for (uint32_t j = 0; j < n && res == VBNL_OK; ++j) {
            g += glossy[j] != 0;
            if (d->vls.material[j] >= materials || glossy[j] > 1 || !(d->vls.radius[j] > 0.0f) ||
                !(d->vls.tint[j].x >= 0.0f && d->vls.tint[j].y >= 0.0f && d->vls.tint[j].z >= 0.0f) ||
                !v3_is_finite(d->vls.tint[j]) ||
                !isfinite(d->vls.position[j].x + d->vls.position[j].y + d->vls.position[j].z))
                res = vbnl_error_set(err, VBNL_ERR_CORRUPT, "'%s' is damaged (light %u is invalid)", path, j);
        }
        if (res == VBNL_OK && g != n_glossy)
            res = vbnl_error_set(err, VBNL_ERR_CORRUPT, "'%s' is damaged (glossy count)", path);
        if (res == VBNL_OK && set_fingerprint(&d->vls, glossy) != h->set)
            res = vbnl_error_set(err, VBNL_ERR_CORRUPT, "'%s' is damaged (set fingerprint)", path);
    }
    if (res == VBNL_OK &&
        vbi_profile_set_create_fixed(d->map, n, glossy, h->unit, &d->profiles) != VBNL_OK)
        res = vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "cannot read '%s': out of memory for %u profiles", path, n);
    for (uint32_t j = 0; j < n && res == VBNL_OK && h->photon_count; ++j) { /* a placement: all zero */
        if (glossy[j])
            res = r_bytes(&r, map, 3 * sizeof(uint64_t) * texels);
        if (res == VBNL_OK && vbi_profile_set_import_fixed(d->profiles, j, phi + 3 * (size_t)j,
                                                            glossy[j] ? map : NULL) != VBNL_OK)
            res = vbnl_error_set(err, VBNL_ERR_STATE, "cannot import the profiles of '%s'", path);
    }
    free(glossy);
    free(phi);
    free(map);
    fclose(r.f);
    return res;
}

void vbi_vl_file_data_free(vbi_vl_file_data *d)
{
    if (!d)
        return;
    vbi_profile_set_destroy(d->profiles);
    vbi_vl_set_free(&d->vls);
    vbi_hemioct_destroy(d->map);
    memset(d, 0, sizeof(*d));
}

/* Why two files cannot be summed, or NULL when they hold the same set: the same scene,
 * preparation and arrays, bit for bit. */
static const char *set_difference(const vbi_vl_file_data *a, const vbi_vl_file_data *b)
{
    const vbi_vl_file_header *x = &a->header, *y = &b->header;
    size_t n = a->vls.count;
    if (x->fingerprint != y->fingerprint || x->material_count != y->material_count)
        return "another scene";
    if (x->width != y->width || x->height != y->height || x->camera != y->camera)
        return "another image size or camera";
    if (x->seed != y->seed)
        return "another seed";
    if (x->preparation != y->preparation || x->virtual_lights != y->virtual_lights ||
        x->profile_resolution != y->profile_resolution || x->photon_paths != y->photon_paths ||
        x->unit != y->unit || x->flags != y->flags)
        return "other preparation parameters";
    if (a->vls.count != b->vls.count || x->set != y->set ||
        memcmp(a->vls.position, b->vls.position, sizeof(vec3) * n) ||
        memcmp(a->vls.normal, b->vls.normal, sizeof(vec3) * n) ||
        memcmp(a->vls.material, b->vls.material, sizeof(uint32_t) * n) ||
        memcmp(a->vls.tint, b->vls.tint, sizeof(vec3) * n) || memcmp(a->vls.radius, b->vls.radius, sizeof(float) * n) ||
        memcmp(a->vls.density, b->vls.density, sizeof(float) * n))
        return "other lights from the same parameters";
    return NULL;
}

typedef struct range {
    uint64_t first, count;
    const char *path;
} range;

static int range_cmp(const void *pa, const void *pb)
{
    const range *a = pa, *b = pb;
    return a->first < b->first ? -1 : a->first > b->first;
}

/* How the photon ranges of a list must fit together. */
typedef enum cover_mode {
    COVER_RENDER,    /* [0, photon_paths) exactly once; a placement only alone (it is returned as is) */
    COVER_ALL,       /* [0, photon_paths) exactly once; placements add nothing */
    COVER_CONTIGUOUS /* one contiguous part of it, at least one path; placements add nothing */
} cover_mode;

/* Loads and sums `n` files (a scene checks each against itself; without one they are compared with
 * the first). On success out->header holds the union range and the photon figures summed. */
static vbnl_result load_list(const char *const *paths, uint32_t n, const vbnl_scene *scene, cover_mode mode,
                             vbi_vl_file_data *out, vbnl_error *err)
{
    memset(out, 0, sizeof(*out));
    if (n == 0)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "no virtual-light file given");
    range *ranges = malloc(sizeof(range) * n);
    if (!ranges)
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    vbnl_result res = load_one(paths[0], scene, out, err);
    size_t files = 0;
    if (res == VBNL_OK)
        ranges[files++] = (range){out->header.photon_first, out->header.photon_count, paths[0]};
    if (res == VBNL_OK && mode == COVER_RENDER && n == 1 && out->header.photon_count == 0) {
        free(ranges); /* a placement, loaded as it is: its loader traces the photons */
        return VBNL_OK;
    }
    for (uint32_t i = 1; i < n && res == VBNL_OK; ++i) {
        vbi_vl_file_data more;
        memset(&more, 0, sizeof(more));
        more.map = out->map; /* borrowed: the same resolution is required */
        res = load_one(paths[i], scene, &more, err);
        const char *why = res == VBNL_OK ? set_difference(out, &more) : NULL;
        if (why && !strcmp(why, "another scene"))
            res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                 "'%s' was prepared for another scene than '%s' (scene fingerprint %016llx, not "
                                 "%016llx): files to sum must come from one preparation",
                                 paths[i], paths[0], (unsigned long long)more.header.fingerprint,
                                 (unsigned long long)out->header.fingerprint);
        else if (why)
            res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                 "'%s' holds another virtual-light set than '%s' (%s): files to sum must come from "
                                 "one preparation (same scene, parameters, seed, image size and camera)",
                                 paths[i], paths[0], why);
        if (res == VBNL_OK) {
            vbnl_result m = vbi_profile_set_merge(out->profiles, more.profiles);
            if (m != VBNL_OK)
                res = vbnl_error_set(err, m, "cannot sum the photons of '%s' and '%s' (%s)", paths[0], paths[i],
                                     vbnl_result_name(m));
        }
        if (res == VBNL_OK) {
            ranges[files++] = (range){more.header.photon_first, more.header.photon_count, paths[i]};
            out->header.photon_seconds += more.header.photon_seconds;
            out->header.photon_rays += more.header.photon_rays;
        }
        more.map = NULL;
        vbi_vl_file_data_free(&more);
    }
    /* The fluxes were divided by photon_paths (all ranges together, splitting.h): only ranges
     * that cover [0, photon_paths) exactly once give the right normalisation. Placements (empty
     * ranges) add nothing. */
    uint64_t begin = 0, end = 0, total = out->header.photon_paths, gap_end = total;
    int any = 0;
    if (res == VBNL_OK) {
        qsort(ranges, files, sizeof(range), range_cmp);
        const char *last = NULL;
        for (size_t k = 0; k < files && res == VBNL_OK; ++k) {
            if (ranges[k].count == 0) {
                if (mode == COVER_RENDER)
                    res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                         "'%s' is a placement without photons: it loads alone (its photons are then "
                                         "traced), not in a list of photon ranges",
                                         ranges[k].path);
                continue;
            }
            if (!any && mode == COVER_CONTIGUOUS)
                begin = end = ranges[k].first;
            any = 1;
            if (ranges[k].first < end) {
                res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                     "'%s' and '%s' both hold photon paths from %llu on: summing them would count "
                                     "those photons twice",
                                     last, ranges[k].path, (unsigned long long)ranges[k].first);
            } else if (ranges[k].first > end) {
                if (mode != COVER_CONTIGUOUS) {
                    gap_end = ranges[k].first;
                    break;
                }
                res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                                     "the photon ranges leave [%llu, %llu) out between '%s' and '%s': a file of that "
                                     "range is missing",
                                     (unsigned long long)end, (unsigned long long)ranges[k].first, last,
                                     ranges[k].path);
            } else {
                end = ranges[k].first + ranges[k].count;
                last = ranges[k].path;
            }
        }
    }
    if (res == VBNL_OK && !any)
        res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                             "'%s'%s a placement without photons: trace photon ranges on it first (`vbnl photons`)",
                             paths[0], n > 1 ? " and the other files are" : " is");
    if (res == VBNL_OK && mode != COVER_CONTIGUOUS && end != total) {
        res = vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT,
                             "the photon paths of these files leave [%llu, %llu) of the %llu paths of the "
                             "normalisation untraced: give the files of all photon ranges together",
                             (unsigned long long)end, (unsigned long long)gap_end, (unsigned long long)total);
    }
    if (res == VBNL_OK) {
        out->header.photon_first = begin;
        out->header.photon_count = end - begin;
    }
    free(ranges);
    if (res != VBNL_OK)
        vbi_vl_file_data_free(out);
    return res;
}

vbnl_result vbi_vl_file_load(const char *paths, const vbnl_scene *scene, vbi_vl_file_data *out, vbnl_error *err)
{
    if (out)
        memset(out, 0, sizeof(*out));
    if (!paths || !*paths || !scene || !scene->committed || !out)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_vl_file_load: NULL, empty or uncommitted argument");
    char *list = strdup(paths);
    size_t cap = 1;
    for (const char *c = paths; *c; ++c)
        cap += *c == ':';
    const char **names = malloc(sizeof(*names) * cap);
    if (!list || !names) {
        free(list);
        free(names);
        return vbnl_error_set(err, VBNL_ERR_OUT_OF_MEMORY, "out of memory");
    }
    uint32_t n = 0;
    char *save = NULL;
    for (char *path = strtok_r(list, ":", &save); path; path = strtok_r(NULL, ":", &save))
        names[n++] = path;
    vbnl_result res = n ? load_list(names, n, scene, COVER_RENDER, out, err)
                        : vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "load_lights: no file in '%s'", paths);
    free(names);
    free(list);
    return res;
}

vbnl_result vbi_vl_file_merge(const char *const *paths, uint32_t n, const char *out_path, int partial,
                               vbi_vl_file_header *merged, vbnl_error *err)
{
    if (merged)
        memset(merged, 0, sizeof(*merged));
    if (!paths || !out_path || !*out_path)
        return vbnl_error_set(err, VBNL_ERR_INVALID_ARGUMENT, "vbi_vl_file_merge: NULL argument");
    vbi_vl_file_data d;
    vbnl_result res = load_list(paths, n, NULL, partial ? COVER_CONTIGUOUS : COVER_ALL, &d, err);
    if (res != VBNL_OK)
        return res;
    res = vbi_vl_file_save(out_path, &d.header, &d.vls, d.profiles, err);
    if (res == VBNL_OK && merged)
        *merged = d.header;
    vbi_vl_file_data_free(&d);
    return res;
}

/* ---- fingerprints ----------------------------------------------------------------------------- */

uint64_t vbi_vl_file_scene_fingerprint(const vbnl_scene *scene) { return vbi_scene_fingerprint(scene); }

uint64_t vbi_vl_file_camera_fingerprint(const vbnl_scene *scene)
{
    if (!scene || !scene->committed)
        return 0;
    const vbnl_camera_desc *c = &scene->camera;
    uint64_t h = VBI_VL_FILE_HASH_INIT;
    h = vbi_vl_file_hash(h, c->position, sizeof(c->position));
    h = vbi_vl_file_hash(h, c->forward, sizeof(c->forward));
    h = vbi_vl_file_hash(h, c->right, sizeof(c->right));
    h = vbi_vl_file_hash(h, c->up, sizeof(c->up));
    return c->projection == VBNL_CAMERA_MESH ? vbi_camera_mesh_hash(c, h, vbi_vl_file_hash) : h;
}
