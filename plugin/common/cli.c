/* The --camera argument of `vbnl render` (the executable) and `vbnl bench` (the module); whether
 * two paths name one file (the farm's commands). */
#include <errno.h>
#include <libgen.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"

int cli_parse_camera(const char *text, float position[3], float target[3], float *fov_y)
{
    float v[7];
    char extra;
    if (sscanf(text, "%f,%f,%f,%f,%f,%f,%f%c", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6], &extra) != 7)
        return -1;
    for (int i = 0; i < 7; ++i)
        if (!isfinite(v[i]))
            return -1;
    memcpy(position, v, sizeof(float) * 3);
    memcpy(target, v + 3, sizeof(float) * 3);
    *fov_y = v[6];
    return 0;
}

/* The file `p` names: its canonical path when it exists, else its folder's and its name. */
static int canonical_path(const char *p, char *out, size_t n)
{
    char buf[PATH_MAX], a[PATH_MAX], b[PATH_MAX];
    if (realpath(p, buf)) {
        snprintf(out, n, "%s", buf);
        return 0;
    }
    snprintf(a, sizeof(a), "%s", p);
    snprintf(b, sizeof(b), "%s", p);
    if (!realpath(dirname(a), buf))
        return -1;
    int len = snprintf(out, n, "%s/%s", buf, basename(b));
    return len < 0 || (size_t)len >= n ? -1 : 0;
}

int cli_same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char ca[PATH_MAX + 256], cb[PATH_MAX + 256];
    return canonical_path(a, ca, sizeof(ca)) == 0 && canonical_path(b, cb, sizeof(cb)) == 0 && !strcmp(ca, cb);
}

int cli_parse_u32(const char *s, uint32_t *out, uint32_t min, uint32_t max)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end || end == s || v < min || v > max || s[0] == '-')
        return -1;
    *out = (uint32_t)v;
    return 0;
}

int cli_parse_double(const char *s, double *out, double min, double max)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || *end || end == s || !isfinite(v) || v < min || v > max)
        return -1;
    *out = v;
    return 0;
}
