/* The structure of a PLY file, checked against its header before assimp reads it (ply_check.h).
 * PLY: Greg Turk's format as documented by Paul Bourke ("PLY - Polygon File Format"): a header
 * of format / element / property lines, then the elements in header order, each instance one
 * line of numbers (ASCII) or packed scalars (binary), a list property being its count followed
 * by that many values. */
#include "ply_check.h"

#include <ctype.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PLY_MAX_ELEMENTS 64
#define PLY_MAX_PROPS 256

typedef struct ply_prop {
    int list;          /* 1: a list, count of count_size bytes then values of size bytes */
    int size;          /* bytes of a scalar or of each list value */
    int count_size;    /* bytes of a list's count */
    int count_signed;  /* the count's type is signed (a negative count is malformed) */
} ply_prop;

typedef struct ply_element {
    char name[64];
    unsigned long long count;
    int first_prop, prop_count;
} ply_element;

typedef struct ply_header {
    int format; /* 0 ascii, 1 binary little endian, 2 binary big endian */
    ply_element el[PLY_MAX_ELEMENTS];
    int el_count;
    ply_prop prop[PLY_MAX_PROPS];
    int prop_count;
    long body;  /* offset of the first byte after end_header */
    int body_line;
} ply_header;

/* Size in bytes of a PLY scalar type name; 0 if it is none. `integer` tells whether it may count
 * a list, `is_signed` whether it can be negative. */
static int type_size(const char *t, int *integer, int *is_signed)
{
    static const struct {
        const char *name;
        int size, integer, is_signed;
    } types[] = {
        {"char", 1, 1, 1},  {"uchar", 1, 1, 0},  {"int8", 1, 1, 1},    {"uint8", 1, 1, 0},
        {"short", 2, 1, 1}, {"ushort", 2, 1, 0}, {"int16", 2, 1, 1},   {"uint16", 2, 1, 0},
        {"int", 4, 1, 1},   {"uint", 4, 1, 0},   {"int32", 4, 1, 1},   {"uint32", 4, 1, 0},
        {"float", 4, 0, 1}, {"double", 8, 0, 1}, {"float32", 4, 0, 1}, {"float64", 8, 0, 1},
    };
    for (size_t i = 0; i < sizeof(types) / sizeof(types[0]); ++i)
        if (!strcmp(t, types[i].name)) {
            *integer = types[i].integer;
            *is_signed = types[i].is_signed;
            return types[i].size;
        }
    return 0;
}

/* Reads the header. Returns 0 when the file is no PLY file, 1 when the header is well formed,
 * -1 with the reason in why. */
static int read_header(FILE *f, ply_header *h, char *why, size_t n)
{
    char line[512];
    if (!fgets(line, sizeof(line), f) || strncmp(line, "ply", 3) || (line[3] != '\n' && line[3] != '\r'))
        return 0;
    int have_format = 0;
    for (int k = 2; k < 10000; ++k) {
        if (!fgets(line, sizeof(line), f)) {
            snprintf(why, n, "its PLY header has no end_header");
            return -1;
        }
        if (!strchr(line, '\n')) {
            snprintf(why, n, "its PLY header has a line longer than %zu bytes (line %d)", sizeof(line) - 2, k);
            return -1;
        }
        char a[64], b[64], c[64], d[64];
        unsigned long long count;
        int integer = 0, is_signed = 0, cs, extra;
        if (!strncmp(line, "comment", 7) || !strncmp(line, "obj_info", 8))
            continue;
        if (!strncmp(line, "end_header", 10)) {
            if (!have_format) {
                snprintf(why, n, "its PLY header has no format line");
                return -1;
            }
            h->body = ftell(f);
            h->body_line = k + 1;
            return 1;
        }
        if (sscanf(line, "format %63s %63s %n", a, b, &extra) == 2 && !line[extra]) {
            h->format = !strcmp(a, "ascii") ? 0 : !strcmp(a, "binary_little_endian") ? 1
                      : !strcmp(a, "binary_big_endian") ? 2 : -1;
            if (h->format < 0) {
                snprintf(why, n, "its PLY header names an unknown format '%s' (line %d)", a, k);
                return -1;
            }
            have_format = 1;
        } else if (sscanf(line, "element %63s %llu %n", a, &count, &extra) == 2 && !line[extra]) {
            if (h->el_count == PLY_MAX_ELEMENTS) {
                snprintf(why, n, "its PLY header declares more than %d elements (line %d)", PLY_MAX_ELEMENTS, k);
                return -1;
            }
            ply_element *e = &h->el[h->el_count++];
            snprintf(e->name, sizeof(e->name), "%s", a);
            e->count = count;
            e->first_prop = h->prop_count;
            e->prop_count = 0;
        } else if (!strncmp(line, "property ", 9)) {
            ply_prop p = {0};
            if (sscanf(line, "property list %63s %63s %63s %n", a, b, c, &extra) == 3 && !line[extra]) {
                p.list = 1;
                p.count_size = type_size(a, &integer, &p.count_signed);
                cs = integer;
                p.size = type_size(b, &integer, &is_signed);
                if (!p.count_size || !cs || !p.size) {
                    snprintf(why, n, "its PLY header has a list property with type '%s' (line %d)",
                             !p.count_size || !cs ? a : b, k);
                    return -1;
                }
            } else if (sscanf(line, "property %63s %63s %n", a, d, &extra) == 2 && !line[extra] && strcmp(a, "list")) {
                p.size = type_size(a, &integer, &is_signed);
                if (!p.size) {
                    snprintf(why, n, "its PLY header has a property of unknown type '%s' (line %d)", a, k);
                    return -1;
                }
            } else {
                snprintf(why, n, "its PLY header has a malformed property line (line %d)", k);
                return -1;
            }
            if (!h->el_count || h->prop_count == PLY_MAX_PROPS) {
                snprintf(why, n, "its PLY header has a property %s (line %d)",
                         h->el_count ? "too many" : "before any element", k);
                return -1;
            }
            h->prop[h->prop_count++] = p;
            h->el[h->el_count - 1].prop_count++;
        } else {
            snprintf(why, n, "its PLY header has a line that is no PLY header line (line %d)", k);
            return -1;
        }
    }
    snprintf(why, n, "its PLY header has no end_header");
    return -1;
}

/* ASCII body: each element instance is one line (blank lines between are allowed). */
static const char *check_ascii(FILE *f, const ply_header *h, char *why, size_t n)
{
    char *line = NULL;
    size_t cap = 0;
    long lineno = h->body_line - 1;
    const char *res = NULL;
    for (int e = 0; e < h->el_count && !res; ++e) {
        const ply_element *el = &h->el[e];
        for (unsigned long long i = 0; i < el->count && !res; ++i) {
            ssize_t len;
            char *s = NULL;
            while ((len = getline(&line, &cap, f)) >= 0) {
                ++lineno;
                for (s = line; isspace((unsigned char)*s); ++s)
                    ;
                if (*s)
                    break;
            }
            if (len < 0) {
                snprintf(why, n, "it ends before %s %llu of its %llu", el->name, i, el->count);
                res = why;
                break;
            }
            for (int p = 0; p < el->prop_count && !res; ++p) {
                const ply_prop *pr = &h->prop[el->first_prop + p];
                char *end;
                double v = strtod(s, &end);
                if (end == s) {
                    snprintf(why, n, "%s %llu (line %ld) has fewer numbers than its properties take", el->name, i,
                             lineno);
                    res = why;
                    break;
                }
                s = end;
                unsigned long long items = 1;
                if (pr->list) {
                    if (!(v >= 0.0) || v != (double)(unsigned long long)v) {
                        snprintf(why, n, "%s %llu (line %ld) has a list count that is no count", el->name, i, lineno);
                        res = why;
                        break;
                    }
                    items = (unsigned long long)v;
                    for (unsigned long long k = 0; k < items; ++k) {
                        v = strtod(s, &end);
                        if (end == s) {
                            snprintf(why, n, "%s %llu (line %ld) declares a list of %llu numbers but gives %llu",
                                     el->name, i, lineno, items, k);
                            res = why;
                            break;
                        }
                        s = end;
                    }
                }
            }
            while (!res && isspace((unsigned char)*s))
                ++s;
            if (!res && *s) {
                snprintf(why, n, "%s %llu (line %ld) has more numbers than its properties take", el->name, i,
                         lineno);
                res = why;
            }
        }
    }
    free(line);
    return res;
}

typedef struct ply_reader {
    FILE *f;
    unsigned char buf[1 << 16];
    size_t pos, len;
} ply_reader;

/* Copies (out != NULL) or skips `bytes` bytes; 0 when the file ends first. */
static int reader_take(ply_reader *r, unsigned char *out, unsigned long long bytes)
{
    while (bytes) {
        if (r->pos == r->len) {
            r->len = fread(r->buf, 1, sizeof(r->buf), r->f);
            r->pos = 0;
            if (!r->len)
                return 0;
        }
        size_t k = r->len - r->pos < bytes ? r->len - r->pos : (size_t)bytes;
        if (out) {
            memcpy(out, r->buf + r->pos, k);
            out += k;
        }
        r->pos += k;
        bytes -= k;
    }
    return 1;
}

/* Binary body: lists read with their counts; the elements must end within the file. */
static const char *check_binary(FILE *f, const ply_header *h, char *why, size_t n)
{
    ply_reader *r = malloc(sizeof(*r));
    if (!r) {
        snprintf(why, n, "out of memory checking it");
        return why;
    }
    r->f = f;
    r->pos = r->len = 0;
    const char *res = NULL;
    for (int e = 0; e < h->el_count && !res; ++e) {
        const ply_element *el = &h->el[e];
        for (unsigned long long i = 0; i < el->count && !res; ++i)
            for (int p = 0; p < el->prop_count; ++p) {
                const ply_prop *pr = &h->prop[el->first_prop + p];
                unsigned char c[8];
                unsigned long long bytes = (unsigned long long)pr->size;
                int ok = 1;
                if (pr->list && (ok = reader_take(r, c, (unsigned long long)pr->count_size))) {
                    uint64_t v = 0;
                    for (int b = 0; b < pr->count_size; ++b)
                        v |= (uint64_t)c[h->format == 1 ? b : pr->count_size - 1 - b] << (8 * b);
                    if (pr->count_signed && (v >> (8 * pr->count_size - 1)) & 1) {
                        snprintf(why, n, "%s %llu has a negative list count", el->name, i);
                        res = why;
                        break;
                    }
                    bytes = v * (uint64_t)pr->size;
                }
                if (!ok || !reader_take(r, NULL, bytes)) {
                    snprintf(why, n, "it ends inside %s %llu of its %llu", el->name, i, el->count);
                    res = why;
                    break;
                }
            }
    }
    free(r);
    return res;
}

const char *mesh_ply_check(FILE *f, uint64_t size, char *why, size_t n)
{
    ply_header *h = calloc(1, sizeof(*h));
    const char *res = NULL;
    int kind = !h ? -1 : read_header(f, h, why, n);
    if (!h)
        snprintf(why, n, "out of memory checking it");
    if (kind < 0) {
        res = why;
    } else if (kind > 0) {
        unsigned long long total = 0;
        for (int e = 0; e < h->el_count; ++e)
            total = total + h->el[e].count < total ? ~0ull : total + h->el[e].count;
        if (total > (unsigned long long)size / (h->format == 0 ? 2u : 1u)) {
            snprintf(why, n, "its header declares %llu elements, more than its %llu bytes hold", total,
                     (unsigned long long)size);
            res = why;
        } else {
            res = h->format == 0 ? check_ascii(f, h, why, n) : check_binary(f, h, why, n);
        }
    }
    free(h);
    return res;
}
