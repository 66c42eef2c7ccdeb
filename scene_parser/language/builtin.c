/* vbnl scene parser: built-in functions of SDL expressions (maths, vectors, strings, rand, and the
 * object functions answered by the object layer's queries). */
#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "sdl_internal.h"
#include "vbnl/scene.h"

typedef struct builtin {
    int kw;
    int min, max; /* argument counts; max -1: variadic */
} builtin;

static const builtin builtins[] = {
    { VBI_KW_abs, 1, 1 }, { VBI_KW_acos, 1, 1 }, { VBI_KW_acosh, 1, 1 }, { VBI_KW_asc, 1, 1 },
    { VBI_KW_asin, 1, 1 }, { VBI_KW_asinh, 1, 1 }, { VBI_KW_atan, 1, 1 }, { VBI_KW_atan2, 2, 2 },
    { VBI_KW_atanh, 1, 1 }, { VBI_KW_bitwise_and, 2, -1 }, { VBI_KW_bitwise_or, 2, -1 },
    { VBI_KW_bitwise_xor, 2, -1 }, { VBI_KW_ceil, 1, 1 }, { VBI_KW_chr, 1, 1 },
    { VBI_KW_concat, 1, -1 }, { VBI_KW_cos, 1, 1 }, { VBI_KW_cosh, 1, 1 }, { VBI_KW_defined, 1, 1 },
    { VBI_KW_degrees, 1, 1 }, { VBI_KW_dimension_size, 2, 2 }, { VBI_KW_dimensions, 1, 1 },
    { VBI_KW_div, 2, 2 }, { VBI_KW_exp, 1, 1 }, { VBI_KW_file_exists, 1, 1 }, { VBI_KW_floor, 1, 1 },
    { VBI_KW_inside, 2, 2 }, { VBI_KW_int, 1, 1 }, { VBI_KW_ln, 1, 1 }, { VBI_KW_log, 1, 1 },
    { VBI_KW_max, 1, -1 }, { VBI_KW_min, 1, -1 }, { VBI_KW_mod, 2, 2 }, { VBI_KW_pow, 2, 2 },
    { VBI_KW_radians, 1, 1 }, { VBI_KW_rand, 1, 1 }, { VBI_KW_seed, 1, 1 }, { VBI_KW_select, 3, 4 },
    { VBI_KW_sin, 1, 1 }, { VBI_KW_sinh, 1, 1 }, { VBI_KW_sqrt, 1, 1 }, { VBI_KW_sqr, 1, 1 },
    { VBI_KW_str, 3, 3 }, { VBI_KW_strcmp, 2, 2 }, { VBI_KW_strlen, 1, 1 }, { VBI_KW_strlwr, 1, 1 },
    { VBI_KW_strupr, 1, 1 }, { VBI_KW_substr, 3, 3 }, { VBI_KW_tan, 1, 1 }, { VBI_KW_tanh, 1, 1 },
    { VBI_KW_val, 1, 1 }, { VBI_KW_vaxis_rotate, 3, 3 }, { VBI_KW_vcross, 2, 2 }, { VBI_KW_vdot, 2, 2 },
    { VBI_KW_vlength, 1, 1 }, { VBI_KW_vnormalize, 1, 1 }, { VBI_KW_vrotate, 2, 2 },
    { VBI_KW_vstr, 5, 5 }, { VBI_KW_vturbulence, 4, 4 }, { VBI_KW_now, 0, 0 }, { VBI_KW_datetime, 1, 2 },
    { VBI_KW_trace, 3, 4 }, { VBI_KW_min_extent, 1, 1 }, { VBI_KW_max_extent, 1, 1 },
};

static const builtin *find(int kw)
{
    for (size_t i = 0; i < sizeof builtins / sizeof builtins[0]; i++)
        if (builtins[i].kw == kw)
            return &builtins[i];
    return NULL;
}

bool sdl_is_builtin(int kw)
{
    return find(kw) != NULL;
}

/* splitmix64: a deterministic stream per seed() call. */
double sdl_rng_next(sdl_rng *r)
{
    uint64_t z = (r->state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) / 9007199254740991.0; /* [0, 1] */
}

static void format_float(char *buf, size_t n, double f, int width, int prec)
{
    if (width > 64) width = 64;
    if (width < -64) width = -64;
    if (prec > 30) prec = 30;
    if (prec < 0) {
        /* POV-Ray: as many digits as needed */
        char tmp[64];
        snprintf(tmp, sizeof tmp, "%.15g", f);
        int pad = (width < 0 ? -width : width) - (int)strlen(tmp);
        size_t o = 0;
        for (int i = 0; i < pad && o + 1 < n; i++)
            buf[o++] = width < 0 ? '0' : ' ';
        snprintf(buf + o, n - o, "%s", tmp);
        return;
    }
    if (width < 0)
        snprintf(buf, n, "%0*.*f", -width, prec, f);
    else
        snprintf(buf, n, "%*.*f", width, prec, f);
}

static bool need(vbnl_sdl_parser *p, const vbnl_sdl_value *a, vbnl_sdl_kind kind, const vbnl_sdl_token *fn, int i,
                 const vbnl_sdl_loc *loc)
{
    if (a->kind == kind)
        return true;
    sdl_errorf(p, loc, "argument %d of %s() must be a %s, found a %s", i + 1, fn->text, vbnl_sdl_kind_name(kind),
               vbnl_sdl_kind_name(a->kind));
    return false;
}

static bool domain(vbnl_sdl_parser *p, bool ok, const vbnl_sdl_token *fn, double x, const vbnl_sdl_loc *loc)
{
    if (!ok)
        sdl_errorf(p, loc, "argument %g is outside the domain of %s()", x, fn->text);
    return ok;
}

static void rotate_xyz(const double *v, const double *deg, double *out)
{
    double a[3] = { v[0], v[1], v[2] };
    for (int axis = 0; axis < 3; axis++) {
        double r = deg[axis] * M_PI / 180.0, c = cos(r), s = sin(r);
        int i = (axis + 1) % 3, j = (axis + 2) % 3;
        double ai = a[i], aj = a[j];
        a[i] = ai * c - aj * s;
        a[j] = ai * s + aj * c;
    }
    memcpy(out, a, sizeof a);
}

/* Arguments already parsed (not for defined/dimension_size/dimensions). */
static bool apply(vbnl_sdl_parser *p, const vbnl_sdl_token *fn, vbnl_sdl_value *a, int n,
                  const vbnl_sdl_loc *al, vbnl_sdl_value *out)
{
    int kw = fn->keyword;
    double x = 0, y = 0, r = 0, v1[3], v2[3];
    /* Float-only functions */
    switch (kw) {
    case VBI_KW_abs: case VBI_KW_acos: case VBI_KW_acosh: case VBI_KW_asin: case VBI_KW_asinh:
    case VBI_KW_atan: case VBI_KW_atan2: case VBI_KW_atanh: case VBI_KW_ceil: case VBI_KW_cos:
    case VBI_KW_cosh: case VBI_KW_degrees: case VBI_KW_div: case VBI_KW_exp: case VBI_KW_floor:
    case VBI_KW_int: case VBI_KW_ln: case VBI_KW_log: case VBI_KW_mod: case VBI_KW_pow:
    case VBI_KW_radians: case VBI_KW_sin: case VBI_KW_sinh: case VBI_KW_sqrt: case VBI_KW_sqr:
    case VBI_KW_tan: case VBI_KW_tanh: case VBI_KW_chr: case VBI_KW_seed: case VBI_KW_rand:
    case VBI_KW_min: case VBI_KW_max: case VBI_KW_bitwise_and: case VBI_KW_bitwise_or:
    case VBI_KW_bitwise_xor:
        for (int i = 0; i < n; i++)
            if (!need(p, &a[i], VBNL_SDL_FLOAT, fn, i, &al[i]))
                return false;
        x = n > 0 ? a[0].v[0] : 0;
        y = n > 1 ? a[1].v[0] : 0;
        break;
    default:
        break;
    }
    switch (kw) {
    case VBI_KW_abs: r = fabs(x); break;
    case VBI_KW_acos: if (!domain(p, x >= -1 && x <= 1, fn, x, &al[0])) return false; r = acos(x); break;
    case VBI_KW_asin: if (!domain(p, x >= -1 && x <= 1, fn, x, &al[0])) return false; r = asin(x); break;
    case VBI_KW_acosh: if (!domain(p, x >= 1, fn, x, &al[0])) return false; r = acosh(x); break;
    case VBI_KW_atanh: if (!domain(p, x > -1 && x < 1, fn, x, &al[0])) return false; r = atanh(x); break;
    case VBI_KW_asinh: r = asinh(x); break;
    case VBI_KW_atan: r = atan(x); break;
    case VBI_KW_atan2: r = atan2(x, y); break;
    case VBI_KW_ceil: r = ceil(x); break;
    case VBI_KW_cos: r = cos(x); break;
    case VBI_KW_cosh: r = cosh(x); break;
    case VBI_KW_degrees: r = x * 180.0 / M_PI; break;
    case VBI_KW_radians: r = x * M_PI / 180.0; break;
    case VBI_KW_div:
        if (y == 0) { sdl_errorf(p, &al[1], "division by zero in div()"); return false; }
        r = trunc(x / y);
        break;
    case VBI_KW_mod:
        if (y == 0) { sdl_errorf(p, &al[1], "division by zero in mod()"); return false; }
        r = fmod(x, y);
        break;
    case VBI_KW_exp: r = exp(x); break;
    case VBI_KW_floor: r = floor(x); break;
    case VBI_KW_int: r = trunc(x); break;
    case VBI_KW_ln: if (!domain(p, x > 0, fn, x, &al[0])) return false; r = log(x); break;
    case VBI_KW_log: if (!domain(p, x > 0, fn, x, &al[0])) return false; r = log10(x); break;
    case VBI_KW_pow: r = pow(x, y); break;
    case VBI_KW_sin: r = sin(x); break;
    case VBI_KW_sinh: r = sinh(x); break;
    case VBI_KW_sqrt: if (!domain(p, x >= 0, fn, x, &al[0])) return false; r = sqrt(x); break;
    case VBI_KW_sqr: r = x * x; break;
    case VBI_KW_tan: r = tan(x); break;
    case VBI_KW_tanh: r = tanh(x); break;
    case VBI_KW_min: case VBI_KW_max:
        r = x;
        for (int i = 1; i < n; i++)
            r = kw == VBI_KW_min ? fmin(r, a[i].v[0]) : fmax(r, a[i].v[0]);
        break;
    case VBI_KW_bitwise_and: case VBI_KW_bitwise_or: case VBI_KW_bitwise_xor: {
        long long acc = (long long)x;
        for (int i = 1; i < n; i++) {
            long long b = fabs(a[i].v[0]) < 9e18 ? (long long)a[i].v[0] : 0;
            acc = kw == VBI_KW_bitwise_and ? (acc & b) : kw == VBI_KW_bitwise_or ? (acc | b) : (acc ^ b);
        }
        r = (double)acc;
        break;
    }
    case VBI_KW_seed: {
        if (p->nrngs == p->caprngs) {
            int cap = p->caprngs ? p->caprngs * 2 : 8;
            if (cap > 1000000) { sdl_errorf(p, &fn->loc, "too many random streams"); return false; }
            sdl_rng *q = realloc(p->rngs, (size_t)cap * sizeof *q);
            if (!q) { sdl_errorf(p, &fn->loc, "out of memory"); return false; }
            p->rngs = q;
            p->caprngs = cap;
        }
        long long s = fabs(x) < 9e18 ? (long long)x : 0;
        p->rngs[p->nrngs].state = (uint64_t)s * 0x9E3779B97F4A7C15ull ^ 0x5DEECE66Dull;
        r = p->nrngs++;
        break;
    }
    case VBI_KW_rand: {
        if (!(x >= 0) || x >= p->nrngs || x != floor(x)) {
            sdl_errorf(p, &al[0], "rand() needs a stream created by seed(), found %g", x);
            return false;
        }
        r = sdl_rng_next(&p->rngs[(int)x]);
        break;
    }
    case VBI_KW_chr: {
        if (!(x >= 1 && x < 0x110000)) { sdl_errorf(p, &al[0], "chr(%g): character code out of range", x); return false; }
        unsigned cp = (unsigned)x;
        char b[4];
        size_t len = 1;
        if (cp < 0x80) { b[0] = (char)cp; }
        else if (cp < 0x800) { b[0] = (char)(0xC0 | (cp >> 6)); b[1] = (char)(0x80 | (cp & 63)); len = 2; }
        else { b[0] = (char)(0xE0 | ((cp >> 12) & 15)); b[1] = (char)(0x80 | ((cp >> 6) & 63)); b[2] = (char)(0x80 | (cp & 63)); len = 3; }
        return sdl_set_string(p, out, b, len);
    }
    /* strings */
    case VBI_KW_asc: case VBI_KW_strlen: case VBI_KW_strlwr: case VBI_KW_strupr: case VBI_KW_val:
    case VBI_KW_file_exists: {
        if (!need(p, &a[0], VBNL_SDL_STRING, fn, 0, &al[0]))
            return false;
        const char *s = a[0].u.str.s;
        size_t len = a[0].u.str.len;
        if (kw == VBI_KW_asc) { r = len ? (unsigned char)s[0] : 0; break; }
        if (kw == VBI_KW_strlen) { r = (double)len; break; }
        if (kw == VBI_KW_val) { r = strtod(s, NULL); break; }
        if (kw == VBI_KW_file_exists) {
            /* only files a scene may read exist for it (sdl_path_readable) */
            struct stat st;
            char path[4096];
            r = stat(s, &st) == 0 && sdl_path_readable(p, s);
            if (!r && s[0] != '/' && p->scene_dir) {
                snprintf(path, sizeof path, "%s/%s", p->scene_dir, s);
                r = stat(path, &st) == 0 && sdl_path_readable(p, path);
            }
            if (!r && s[0] != '/' && p->system_dir) {
                snprintf(path, sizeof path, "%s/%s", p->system_dir, s);
                r = stat(path, &st) == 0 && sdl_path_readable(p, path);
            }
            break;
        }
        if (!sdl_set_string(p, out, s, len))
            return false;
        for (size_t i = 0; i < len; i++)
            out->u.str.s[i] = (char)(kw == VBI_KW_strupr ? toupper((unsigned char)s[i]) : tolower((unsigned char)s[i]));
        return true;
    }
    case VBI_KW_strcmp:
        if (!need(p, &a[0], VBNL_SDL_STRING, fn, 0, &al[0]) || !need(p, &a[1], VBNL_SDL_STRING, fn, 1, &al[1]))
            return false;
        r = strcmp(a[0].u.str.s, a[1].u.str.s);
        r = r < 0 ? -1 : r > 0 ? 1 : 0;
        break;
    case VBI_KW_concat: {
        size_t total = 0;
        for (int i = 0; i < n; i++) {
            if (!need(p, &a[i], VBNL_SDL_STRING, fn, i, &al[i]))
                return false;
            total += a[i].u.str.len;
        }
        char *s = sdl_alloc(p, total + 1);
        if (!s)
            return false;
        size_t o = 0;
        for (int i = 0; i < n; i++) {
            memcpy(s + o, a[i].u.str.s, a[i].u.str.len);
            o += a[i].u.str.len;
        }
        memset(out, 0, sizeof *out);
        out->kind = VBNL_SDL_STRING;
        out->u.str.s = s;
        out->u.str.len = total;
        return true;
    }
    case VBI_KW_substr: {
        if (!need(p, &a[0], VBNL_SDL_STRING, fn, 0, &al[0]) || !need(p, &a[1], VBNL_SDL_FLOAT, fn, 1, &al[1]) ||
            !need(p, &a[2], VBNL_SDL_FLOAT, fn, 2, &al[2]))
            return false;
        double pos = a[1].v[0], len = a[2].v[0];
        size_t sl = a[0].u.str.len;
        if (!(pos >= 1) || !(len >= 0) || pos - 1 + len > (double)sl) {
            sdl_errorf(p, &fn->loc, "substr(\"%.20s\", %g, %g) is out of range (string length %zu)", a[0].u.str.s, pos,
                       len, sl);
            return false;
        }
        return sdl_set_string(p, out, a[0].u.str.s + (size_t)pos - 1, (size_t)len);
    }
    case VBI_KW_str: {
        for (int i = 0; i < 3; i++)
            if (!need(p, &a[i], VBNL_SDL_FLOAT, fn, i, &al[i]))
                return false;
        char b[160];
        format_float(b, sizeof b, a[0].v[0], (int)fmax(-64, fmin(64, a[1].v[0])), (int)fmax(-1, fmin(30, a[2].v[0])));
        return sdl_set_string(p, out, b, strlen(b));
    }
    case VBI_KW_vstr: {
        if (!need(p, &a[0], VBNL_SDL_FLOAT, fn, 0, &al[0]) || !need(p, &a[2], VBNL_SDL_STRING, fn, 2, &al[2]) ||
            !need(p, &a[3], VBNL_SDL_FLOAT, fn, 3, &al[3]) || !need(p, &a[4], VBNL_SDL_FLOAT, fn, 4, &al[4]))
            return false;
        int dims = (int)a[0].v[0];
        double c[5];
        if (dims < 2 || dims > 5) {
            sdl_errorf(p, &al[0], "vstr(): dimensions must be 2 to 5, found %g", a[0].v[0]);
            return false;
        }
        if (!sdl_to_vector(p, &a[1], dims, c, &al[1], "vstr()"))
            return false;
        char b[1024] = "";
        size_t o = 0;
        for (int i = 0; i < dims; i++) {
            char e[160];
            format_float(e, sizeof e, c[i], (int)fmax(-64, fmin(64, a[3].v[0])), (int)fmax(-1, fmin(30, a[4].v[0])));
            o += (size_t)snprintf(b + o, sizeof b - o, "%s%.200s", i ? a[2].u.str.s : "", e);
            if (o >= sizeof b)
                o = sizeof b - 1;
        }
        return sdl_set_string(p, out, b, o);
    }
    /* vectors */
    case VBI_KW_vlength:
        if (!sdl_to_vector(p, &a[0], 3, v1, &al[0], "vlength()"))
            return false;
        r = sqrt(v1[0] * v1[0] + v1[1] * v1[1] + v1[2] * v1[2]);
        break;
    case VBI_KW_vdot:
        if (!sdl_to_vector(p, &a[0], 3, v1, &al[0], "vdot()") || !sdl_to_vector(p, &a[1], 3, v2, &al[1], "vdot()"))
            return false;
        r = v1[0] * v2[0] + v1[1] * v2[1] + v1[2] * v2[2];
        break;
    case VBI_KW_vnormalize: case VBI_KW_vcross: case VBI_KW_vrotate: case VBI_KW_vaxis_rotate: {
        double o[3];
        if (!sdl_to_vector(p, &a[0], 3, v1, &al[0], fn->text))
            return false;
        if (n > 1 && !sdl_to_vector(p, &a[1], 3, v2, &al[1], fn->text))
            return false;
        if (kw == VBI_KW_vnormalize) {
            double l = sqrt(v1[0] * v1[0] + v1[1] * v1[1] + v1[2] * v1[2]);
            if (l == 0) {
                sdl_warnf(p, &al[0], "vnormalize() of a zero-length vector returns <0,0,0>");
                l = 1;
            }
            for (int i = 0; i < 3; i++)
                o[i] = v1[i] / l;
        } else if (kw == VBI_KW_vcross) {
            o[0] = v1[1] * v2[2] - v1[2] * v2[1];
            o[1] = v1[2] * v2[0] - v1[0] * v2[2];
            o[2] = v1[0] * v2[1] - v1[1] * v2[0];
        } else if (kw == VBI_KW_vrotate) {
            rotate_xyz(v1, v2, o);
        } else {
            if (!need(p, &a[2], VBNL_SDL_FLOAT, fn, 2, &al[2]))
                return false;
            double l = sqrt(v2[0] * v2[0] + v2[1] * v2[1] + v2[2] * v2[2]);
            if (l == 0) {
                sdl_errorf(p, &al[1], "vaxis_rotate(): the axis has zero length");
                return false;
            }
            double k[3] = { v2[0] / l, v2[1] / l, v2[2] / l }, th = a[2].v[0] * M_PI / 180.0;
            double c = cos(th), s = sin(th), d = k[0] * v1[0] + k[1] * v1[1] + k[2] * v1[2];
            double kx[3] = { k[1] * v1[2] - k[2] * v1[1], k[2] * v1[0] - k[0] * v1[2], k[0] * v1[1] - k[1] * v1[0] };
            for (int i = 0; i < 3; i++)
                o[i] = v1[i] * c + kx[i] * s + k[i] * d * (1 - c);
        }
        sdl_set_vector(out, 3, o);
        return true;
    }
    case VBI_KW_vturbulence: { /* POV-Ray's DTurbulence, octaves clamped to 1..10 */
        double q[3], o[3];
        if (!sdl_to_vector(p, &a[3], 3, q, &al[3], "vturbulence()"))
            return false;
        vbnl_vturbulence(a[0].v[0], a[1].v[0], (int)fmax(-1e9, fmin(1e9, a[2].v[0])), q, o);
        sdl_set_vector(out, 3, o);
        return true;
    }
    case VBI_KW_select: {
        if (!need(p, &a[0], VBNL_SDL_FLOAT, fn, 0, &al[0]))
            return false;
        double c = a[0].v[0];
        int pick = n == 3 ? (c < 0 ? 1 : 2) : (c < 0 ? 1 : c == 0 ? 2 : 3);
        *out = a[pick];
        memset(&a[pick], 0, sizeof a[pick]);
        return true;
    }
    case VBI_KW_datetime: {
        if (!need(p, &a[0], VBNL_SDL_FLOAT, fn, 0, &al[0]) || (n > 1 && !need(p, &a[1], VBNL_SDL_STRING, fn, 1, &al[1])))
            return false;
        double days = a[0].v[0];
        if (!(fabs(days) < 1e7)) {
            sdl_errorf(p, &al[0], "datetime(): time out of range");
            return false;
        }
        time_t tt = (time_t)(946684800.0 + days * 86400.0);
        struct tm tmv;
        gmtime_r(&tt, &tmv);
        char b[256];
        size_t len = strftime(b, sizeof b, n > 1 ? a[1].u.str.s : "%Y-%m-%d %H:%M:%SZ", &tmv);
        return sdl_set_string(p, out, b, len);
    }
    default:
        sdl_errorf(p, &fn->loc, "internal error: built-in '%s' not implemented", fn->text);
        return false;
    }
    sdl_set_float(out, r);
    return true;
}

static bool array_query(vbnl_sdl_parser *p, const vbnl_sdl_token *fn, vbnl_sdl_value *out)
{
    const vbnl_sdl_token *t = vbnl_sdl_next(p);
    vbnl_sdl_loc loc = t->loc;
    if (t->kind != VBNL_SDL_TOK_IDENT) {
        char b[80];
        sdl_errorf(p, &loc, "%s() needs an array identifier, found %s", fn->text, sdl_token_describe(t, b, sizeof b));
        return false;
    }
    const char *name = t->text;
    sdl_sym *s = sdl_lookup(p, name);
    if (!s || s->val.kind != VBNL_SDL_ARRAY) {
        sdl_errorf(p, &loc, s ? "%s(): '%s' is a %s, not an array" : "%s(): undeclared array '%s'", fn->text, name,
                   s ? vbnl_sdl_kind_name(s->val.kind) : "");
        return false;
    }
    int rank = s->val.u.array->rank;
    size_t dims[5];
    memcpy(dims, s->val.u.array->dims, sizeof dims);
    if (fn->keyword == VBI_KW_dimensions) {
        if (!sdl_expect_op(p, ')', "after dimensions() argument"))
            return false;
        sdl_set_float(out, rank);
        return true;
    }
    double d;
    if (!sdl_expect_op(p, ',', "in dimension_size()"))
        return false;
    vbnl_sdl_loc dl = vbnl_sdl_peek(p)->loc;
    if (!sdl_expr_float(p, &d, "dimension_size()") || !sdl_expect_op(p, ')', "after dimension_size() arguments"))
        return false;
    if (!(d >= 1) || d > rank) {
        sdl_errorf(p, &dl, "dimension_size(): array '%s' has %d dimension%s, asked for %g", name, rank,
                   rank == 1 ? "" : "s", d);
        return false;
    }
    sdl_set_float(out, (double)dims[(int)d - 1]);
    return true;
}

void vbnl_sdl_set_object_queries(vbnl_sdl_parser *p, const vbnl_sdl_object_queries *q)
{
    if (!p)
        return;
    if (q)
        p->object_queries = *q;
    else
        memset(&p->object_queries, 0, sizeof p->object_queries);
}

/* inside, trace, min_extent, max_extent: the object layer answers through its queries. The
 * normal of trace() goes to the identifier `normal_name` (NULL: none); <0,0,0> on a miss. */
static bool object_query(vbnl_sdl_parser *p, const vbnl_sdl_token *fn, vbnl_sdl_value *a, int n,
                         const vbnl_sdl_loc *al, const char *normal_name, const vbnl_sdl_loc *normal_loc,
                         vbnl_sdl_value *out)
{
    int kw = fn->keyword;
    const vbnl_sdl_object_queries *q = &p->object_queries;
    double v1[3], v2[3], res[3] = { 0, 0, 0 }, nrm[3] = { 0, 0, 0 };
    int r = 0, flag = 0;
    if (n > 1 && !sdl_to_vector(p, &a[1], 3, v1, &al[1], fn->text))
        return false;
    if (n > 2 && !sdl_to_vector(p, &a[2], 3, v2, &al[2], fn->text))
        return false;
    if (kw == VBI_KW_trace) {
        double l = sqrt(v2[0] * v2[0] + v2[1] * v2[1] + v2[2] * v2[2]);
        if (!(l > 0) || !isfinite(l)) {
            sdl_errorf(p, &al[2], "trace(): the direction must be a finite vector of non-zero length");
            return false;
        }
        for (int i = 0; i < 3; i++)
            v2[i] /= l;
    }
    bool have = kw == VBI_KW_inside ? q->inside != NULL : kw == VBI_KW_trace ? q->trace != NULL : q->extent != NULL;
    if (have && a[0].kind == VBNL_SDL_OBJECT) {
        double lo[3], hi[3];
        if (kw == VBI_KW_inside)
            r = q->inside(p, &a[0], v1, &flag, q->user);
        else if (kw == VBI_KW_trace)
            r = q->trace(p, &a[0], v1, v2, res, nrm, &flag, q->user);
        else if ((r = q->extent(p, &a[0], lo, hi, q->user)) == 1)
            memcpy(res, kw == VBI_KW_min_extent ? lo : hi, sizeof res);
        if (r < 0)
            return false;
    }
    if (r == 0 && have) {
        const char *found = a[0].kind == VBNL_SDL_OBJECT && a[0].u.obj.type ? a[0].u.obj.type->name
                                                                             : vbnl_sdl_kind_name(a[0].kind);
        sdl_errorf(p, &al[0], "argument 1 of %s() must be an object, found a %s", fn->text, found);
        return false;
    }
    if (!have) {
        unsigned bit = kw == VBI_KW_inside ? 1u : kw == VBI_KW_trace ? 2u : 4u;
        if (!(p->warned & bit)) {
            p->warned |= bit;
            sdl_warnf(p, &fn->loc, "%s() needs the object layer; returning %s (reported once)", fn->text,
                      kw == VBI_KW_inside ? "0" : "<0,0,0>");
        }
    }
    if (kw == VBI_KW_trace && !flag) {
        memset(res, 0, sizeof res);
        memset(nrm, 0, sizeof nrm);
    }
    if (normal_name) {
        vbnl_sdl_value nv;
        sdl_set_vector(&nv, 3, nrm);
        sdl_declare(p, normal_name, -1, &nv, normal_loc);
    }
    if (kw == VBI_KW_inside)
        sdl_set_float(out, flag ? 1.0 : 0.0);
    else
        sdl_set_vector(out, 3, res);
    return !p->failed;
}

bool sdl_builtin_call(vbnl_sdl_parser *p, int kw, const vbnl_sdl_token *fn, vbnl_sdl_value *out)
{
    const builtin *b = find(kw);
    memset(out, 0, sizeof *out);
    if (kw == VBI_KW_now) {
        sdl_set_float(out, ((double)time(NULL) - 946684800.0) / 86400.0);
        return true;
    }
    if (!sdl_expect_op(p, '(', kw == VBI_KW_defined ? "after 'defined'" : "after function name"))
        return false;
    if (kw == VBI_KW_defined) {
        p->no_expand = true;
        const vbnl_sdl_token *t = vbnl_sdl_next(p);
        p->no_expand = false;
        if (t->kind != VBNL_SDL_TOK_IDENT) {
            char d[80];
            sdl_errorf(p, &t->loc, "defined() needs an identifier, found %s", sdl_token_describe(t, d, sizeof d));
            return false;
        }
        sdl_sym *s = sdl_lookup(p, t->text);
        bool def = (s && s->val.kind != VBNL_SDL_NONE) || t->keyword;
        if (!sdl_expect_op(p, ')', "after defined() argument"))
            return false;
        sdl_set_float(out, def);
        return true;
    }
    if (kw == VBI_KW_dimension_size || kw == VBI_KW_dimensions)
        return array_query(p, fn, out);
    vbnl_sdl_value args[8];
    vbnl_sdl_loc al[8];
    vbnl_sdl_value *a = args;
    vbnl_sdl_loc *l = al;
    int n = 0, cap = 8;
    bool ok = true;
    const char *normal_name = NULL; /* trace()'s 4th argument */
    vbnl_sdl_loc normal_loc = fn->loc;
    if (!vbnl_sdl_accept(p, ')')) {
        for (;;) {
            if (n == cap) {
                int nc = cap * 2;
                vbnl_sdl_value *na = malloc((size_t)nc * sizeof *na);
                vbnl_sdl_loc *nl = malloc((size_t)nc * sizeof *nl);
                if (!na || !nl || nc > 100000) {
                    free(na);
                    free(nl);
                    sdl_errorf(p, &fn->loc, "too many arguments to %s()", fn->text);
                    ok = false;
                    break;
                }
                memcpy(na, a, (size_t)n * sizeof *na);
                memcpy(nl, l, (size_t)n * sizeof *nl);
                if (a != args) {
                    free(a);
                    free(l);
                }
                a = na;
                l = nl;
                cap = nc;
            }
            l[n] = vbnl_sdl_peek(p)->loc;
            if (kw == VBI_KW_trace && n == 3) {
                /* trace(Object, Start, Direction, Normal): Normal is an output identifier */
                p->no_expand = true;
                const vbnl_sdl_token *t = vbnl_sdl_next(p);
                p->no_expand = false;
                if (t->kind != VBNL_SDL_TOK_IDENT || t->keyword) {
                    char d[80];
                    sdl_errorf(p, &t->loc, "trace(): the 4th argument must be an identifier, found %s",
                               sdl_token_describe(t, d, sizeof d));
                    ok = false;
                    break;
                }
                normal_loc = t->loc;
                normal_name = t->text; /* interned: outlives the token */
                ok = sdl_expect_op(p, ')', "after trace() arguments");
                break;
            }
            if ((kw == VBI_KW_inside || kw == VBI_KW_trace || kw == VBI_KW_min_extent ||
                 kw == VBI_KW_max_extent) && n == 0)
                ok = sdl_parse_rvalue(p, &a[n]);
            else
                ok = sdl_expr(p, &a[n]);
            if (!ok)
                break;
            n++;
            if (vbnl_sdl_accept(p, ','))
                continue;
            ok = sdl_expect_op(p, ')', "or ',' in function arguments");
            break;
        }
    }
    if (ok && (n < b->min || (b->max >= 0 && n > b->max))) {
        if (b->min == b->max)
            sdl_errorf(p, &fn->loc, "%s() expects %d argument%s, got %d", fn->text, b->min, b->min == 1 ? "" : "s", n);
        else if (b->max < 0)
            sdl_errorf(p, &fn->loc, "%s() expects at least %d arguments, got %d", fn->text, b->min, n);
        else
            sdl_errorf(p, &fn->loc, "%s() expects %d to %d arguments, got %d", fn->text, b->min, b->max, n);
        ok = false;
    }
    if (ok && (kw == VBI_KW_inside || kw == VBI_KW_trace || kw == VBI_KW_min_extent || kw == VBI_KW_max_extent))
        ok = object_query(p, fn, a, n, l, normal_name, &normal_loc, out);
    else if (ok)
        ok = apply(p, fn, a, n, l, out);
    for (int i = 0; i < n; i++)
        vbnl_sdl_value_clear(p, &a[i]);
    if (a != args) {
        free(a);
        free(l);
    }
    return ok && !p->failed;
}
