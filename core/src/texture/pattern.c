/* The patterns of POV-Ray 3.7 (reference manual, "Patterns"): the value of each kind at its
 * warped point, and the frequency / phase / wave step every pattern ends with. Formulas and
 * constants follow POV-Ray 3.7's pattern.cpp (read, not copied); each function names the
 * definition it implements. The fractals and the tilings live in their own files. */
#include <stdlib.h>

#include "texture.h"

#define VBI_POV_EPSILON 1e-10

/* POV-Ray's CLIP_DENSITY: 1 - v inside [0, 1], 1 below, 0 above. */
static double clip_density(double v) { return v < 0.0 ? 1.0 : (v > 1.0 ? 0.0 : 1.0 - v); }

/* POV-Ray's FLOOR macro: floor for positive values, one less than floor(-x) negated below zero
 * (so that negative integers round one further down). */
static double pov_floor(double x) { return x >= 0.0 ? floor(x) : -floor(-x) - 1.0; }

static double frac(double x) { return x - floor(x); }

/* Turbulence the formula patterns (agate, marble, spiral1/2, wood) use: POV-Ray's
 * Search_For_Turb finds the classic turbulence at the end of the warp list. */
static const vbi_turb *classic_turb(const vbi_pattern *pt) { return pt->has_turb ? &pt->turb : NULL; }

/* agate: 0.5 (sin(2 pi (1.3 agate_turb turbulence(p) + 1.1 z)) + 1), raised to 0.77. */
static double agate(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 p)
{
    static const vbi_turb none = {{0.0, 0.0, 0.0}, 6, 0.5, 2.0};
    const vbi_turb *t = classic_turb(pt);
    double tv = pt->u.agate_turb * vbi_turbulence(ts->noise, p, t ? t : &none, pt->generator);
    double n = 0.5 * (vbi_cycloidal(1.3 * tv + 1.1 * p.z) + 1.0);
    if (n < 0.0)
        return 0.0;
    return pow(n < 1.0 ? n : 1.0, 0.77);
}

/* brick: courses of height size.y along y; head joints every size.x, offset by half a brick on
 * odd courses; joints in z every size.z, offset on even courses. 0 in the mortar, 1 in a brick. */
static double brick(const vbi_pattern *pt, dvec3 p)
{
    const double m = pt->u.brick.mortar, fudge = VBI_POV_EPSILON + m;
    const double w = pt->u.brick.size.x, h = pt->u.brick.size.y, d = pt->u.brick.size.z;
    const double x = p.x + fudge, y = p.y + fudge, z = p.z + fudge;
    if (frac(y / h) <= m / h)
        return 0.0;
    const int odd = frac(y / h * 0.5) > 0.5;
    if (frac(x / w + (odd ? 0.5 : 0.0)) <= m / w)
        return 0.0;
    if (frac(z / d + (odd ? 0.0 : 0.5)) <= m / d)
        return 0.0;
    return 1.0;
}

/* cells: one random value per unit cube. */
static double cells(const vbi_texture_set *ts, dvec3 p)
{
    unsigned h = vbi_noise_hash3(ts->noise, (int)floor(p.x + VBI_PATTERN_CELL_EPS), (int)floor(p.y + VBI_PATTERN_CELL_EPS),
                                  (int)floor(p.z + VBI_PATTERN_CELL_EPS));
    double v = vbi_pattern_rand(ts->noise, h);
    return v < 1.0 ? v : 1.0;
}

static double checker(dvec3 p)
{
    double s = floor(p.x + VBI_PATTERN_CELL_EPS) + floor(p.y + VBI_PATTERN_CELL_EPS) + floor(p.z + VBI_PATTERN_CELL_EPS);
    return fmod(fabs(s), 2.0) != 0.0 ? 1.0 : 0.0;
}

/* The random point of cube (x, y, z) (POV-Ray's PickInCube); returns its hash. */
static unsigned pick_in_cube(const vbi_texture_set *ts, int x, int y, int z, dvec3 *out)
{
    unsigned seed = vbi_noise_hash3(ts->noise, x, y, z);
    *out = d3(x + vbi_pattern_rand(ts->noise, seed), y + vbi_pattern_rand(ts->noise, seed + 1),
              z + vbi_pattern_rand(ts->noise, seed + 2));
    return seed;
}

/* crackle: the distances to the three nearest random points among the 81 cubes within a "3D
 * knight's move" (POV-Ray's neighbourhood), combined by `form`, in `metric`. */
static double crackle(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 p)
{
    const double metric = pt->u.crackle.metric;
    const int square = metric == 2.0, unity = metric == 1.0;
    const int fx = (int)floor(p.x - VBI_POV_EPSILON), fy = (int)floor(p.y - VBI_POV_EPSILON),
              fz = (int)floor(p.z - VBI_POV_EPSILON);
    double d1 = INFINITY, d2 = INFINITY, d3v = INFINITY;
    dvec3 nearest = d3(0.0, 0.0, 0.0);
    for (int ax = -2; ax <= 2; ++ax)
        for (int ay = -2; ay <= 2; ++ay)
            for (int az = -2; az <= 2; ++az) {
                if ((abs(ax) == 2) + (abs(ay) == 2) + (abs(az) == 2) > 1)
                    continue;
                dvec3 c;
                pick_in_cube(ts, fx + ax, fy + ay, fz + az, &c);
                dvec3 dv = d3_sub(c, p);
                double s = square  ? d3_dot(dv, dv)
                           : unity ? fabs(dv.x) + fabs(dv.y) + fabs(dv.z)
                                   : pow(fabs(dv.x), metric) + pow(fabs(dv.y), metric) + pow(fabs(dv.z), metric);
                if (s < d1) {
                    d3v = d2;
                    d2 = d1;
                    d1 = s;
                    nearest = c;
                } else if (s < d2) {
                    d3v = d2;
                    d2 = s;
                } else if (s < d3v) {
                    d3v = s;
                }
            }
    const double off = pt->u.crackle.offset;
    if (off != 0.0) {
        double o = square ? off * off : unity ? off : pow(off, metric);
        d1 += o;
        d2 += o;
        d3v += o;
    }
    double t;
    const dvec3 f = pt->u.crackle.form;
    if (pt->u.crackle.solid)
        t = vbi_noise(ts->noise, nearest, pt->generator);
    else if (square)
        t = f.x * sqrt(d1) + f.y * sqrt(d2) + f.z * sqrt(d3v);
    else if (unity)
        t = f.x * d1 + f.y * d2 + f.z * d3v;
    else
        t = f.x * pow(d1, 1.0 / metric) + f.y * pow(d2, 1.0 / metric) + f.z * pow(d3v, 1.0 / metric);
    return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
}

static double cubic(dvec3 p)
{
    double ax = fabs(p.x), ay = fabs(p.y), az = fabs(p.z);
    if (p.x >= 0 && p.x >= ay && p.x >= az)
        return 0.0;
    if (p.y >= 0 && p.y >= ax && p.y >= az)
        return 1.0;
    if (p.z >= 0 && p.z >= ax && p.z >= ay)
        return 2.0;
    if (p.x < 0 && p.x <= -ay && p.x <= -az)
        return 3.0;
    if (p.y < 0 && p.y <= -ax && p.y <= -az)
        return 4.0;
    return 5.0;
}

/* Catmull-Rom style cubic through four samples (POV-Ray's intp3, single precision). */
static float intp3(float t, float fa, float fb, float fc, float fd)
{
    float b = (fc - fa) * 0.5f, d = (fd - fb) * 0.5f;
    float e = 2.0f * (fb - fc) + b + d, f = -3.0f * (fb - fc) - 2.0f * b - d;
    return ((e * t + f) * t + b) * t + fb;
}

/* density_file: the voxel grid over [0, 1)^3, zero outside; nearest, trilinear or tricubic
 * (both interpolations wrap around the grid's far faces, as POV-Ray's). */
static double density(const vbi_pattern *pt, dvec3 p)
{
    const uint32_t sx = pt->u.density.nx, sy = pt->u.density.ny, sz = pt->u.density.nz;
    const float *v = pt->u.density.values;
    if (!(p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0 && p.z >= 0.0 && p.z < 1.0))
        return 0.0;
#define VBI_VOX(i, j, k) ((double)v[((size_t)(k) * sy + (j)) * sx + (i)])
    double r;
    switch (pt->u.density.interpolate % 10) {
    case 0: {
        size_t x = (size_t)(p.x * sx), y = (size_t)(p.y * sy), z = (size_t)(p.z * sz);
        r = x < sx && y < sy && z < sz ? VBI_VOX(x, y, z) : 0.0;
        break;
    }
    case 1: {
        double xx = p.x * sx, yy = p.y * sy, zz = p.z * sz;
        size_t x1 = (size_t)xx, y1 = (size_t)yy, z1 = (size_t)zz;
        size_t x2 = (x1 + 1) % sx, y2 = (y1 + 1) % sy, z2 = (z1 + 1) % sz;
        xx -= floor(xx);
        yy -= floor(yy);
        zz -= floor(zz);
        double xi = 1.0 - xx, yi = 1.0 - yy;
        r = ((VBI_VOX(x1, y1, z1) * xi + VBI_VOX(x2, y1, z1) * xx) * yi +
             (VBI_VOX(x1, y2, z1) * xi + VBI_VOX(x2, y2, z1) * xx) * yy) * (1.0 - zz) +
            ((VBI_VOX(x1, y1, z2) * xi + VBI_VOX(x2, y1, z2) * xx) * yi +
             (VBI_VOX(x1, y2, z2) * xi + VBI_VOX(x2, y2, z2) * xx) * yy) * zz;
        break;
    }
    default: {
        double xx = p.x * sx, yy = p.y * sy, zz = p.z * sz;
        long x1 = (long)xx, y1 = (long)yy, z1 = (long)zz;
        xx -= floor(xx);
        yy -= floor(yy);
        zz -= floor(zz);
        /* index i wrapped into [0, n): negative indices to the last one, as POV-Ray */
#define VBI_WRAP(i, n) ((i) < 0 ? (long)(n) - 1 : (i) % (long)(n))
        long k[4];
        for (int q = 0; q < 4; ++q)
            k[q] = VBI_WRAP(z1 + q - 1, sz);
        float col[4][4], row[4];
        for (int i = 0; i < 4; ++i) {
            long ii = VBI_WRAP(x1 + i - 1, sx);
            for (int j = 0; j < 4; ++j) {
                long jj = VBI_WRAP(y1 + j - 1, sy);
                col[i][j] = intp3((float)zz, (float)VBI_VOX(ii, jj, k[0]), (float)VBI_VOX(ii, jj, k[1]),
                                  (float)VBI_VOX(ii, jj, k[2]), (float)VBI_VOX(ii, jj, k[3]));
            }
        }
#undef VBI_WRAP
        for (int i = 0; i < 4; ++i)
            row[i] = intp3((float)yy, col[i][0], col[i][1], col[i][2], col[i][3]);
        r = intp3((float)xx, row[0], row[1], row[2], row[3]);
        break;
    }
    }
#undef VBI_VOX
    return r < 0.0 ? 0.0 : r;
}

/* granite: six octaves of |1 - 2 noise| (capped at 0.5), at 4 p, 8 p, ... (generator 1: |0.5 -
 * noise|). */
static double granite(const vbi_texture_set *ts, int gen, dvec3 p)
{
    double n = 0.0, freq = 1.0;
    dvec3 q = d3_scale(p, 4.0);
    for (int i = 0; i < 6; ++i, freq *= 2.0) {
        double v = vbi_noise(ts->noise, d3_scale(q, freq), gen), t;
        if (gen == 1) {
            t = fabs(0.5 - v);
        } else {
            t = fabs(1.0 - 2.0 * v);
            if (t > 0.5)
                t = 0.5;
        }
        n += t / freq;
    }
    return n;
}

/* hexagon: three colours of hexagons of unit side in the x-z plane, on a 6 x 6 grid of half
 * hexagon widths by half heights. */
static double hexagon(dvec3 p)
{
    const double xf = 0.5, zf = 0.866025404; /* half a side; the height of an equilateral triangle */
    double x = fabs(p.x), z = p.z < 0.0 ? 5.196152424 - fabs(p.z) : p.z;
    double xs = x / xf, zs = z / zf;
    xs -= floor(xs / 6.0) * 6.0;
    zs -= floor(zs / 6.0) * 6.0;
    int xm = (int)pov_floor(xs) % 6, zm = (int)pov_floor(zs) % 6;
    static const int easy_a[6] = {0, 1, 1, 2, 2, 0};  /* columns 0 and 5 by row */
    static const int easy_b[6] = {2, 2, 0, 0, 1, 1};  /* columns 2 and 3 */
    static const int below[6] = {0, 2, 1, 0, 2, 1};   /* columns 1 and 4, under the diagonal */
    static const int above[6] = {2, 1, 0, 2, 1, 0};   /* ... above it */
    switch (xm) {
    case 0:
    case 5:
        return easy_a[zm];
    case 2:
    case 3:
        return easy_b[zm];
    default: {
        double xl = xs - xm, zl = zs - zm;
        if ((xm + zm) % 2 == 1)
            xl = 1.0 - xl;
        if (xl == 0.0)
            xl = 0.0001;
        return zl / xl < 1.0 ? below[zm] : above[zm];
    }
    }
}

static double leopard(dvec3 p)
{
    double v = (sin(p.x) + sin(p.y) + sin(p.z)) / 3.0;
    return v * v;
}

static double marble(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 p)
{
    const vbi_turb *t = classic_turb(pt);
    return p.x + (t ? t->amount.x * vbi_turbulence(ts->noise, p, t, pt->generator) : 0.0);
}

/* quilted: POV-Ray's quilt_cubic of the distance to the cell centre, scaling the offset. */
static double quilt_cubic(double t, double p1, double p2)
{
    double it = 1.0 - t;
    return (t * t * t + 3.0 * t * it * it * p1 + 3.0 * t * t * it * p2) * 1.154700538;
}

static dvec3 quilted_offset(const vbi_pattern *pt, dvec3 p)
{
    dvec3 v = d3(p.x - pov_floor(p.x) - 0.5, p.y - pov_floor(p.y) - 0.5, p.z - pov_floor(p.z) - 0.5);
    return d3_scale(v, quilt_cubic(d3_len(v), pt->u.quilted.c0, pt->u.quilted.c1));
}

static double quilted(const vbi_pattern *pt, dvec3 p)
{
    dvec3 v = quilted_offset(pt, p);
    return (fabs(v.x) + fabs(v.y) + fabs(v.z)) / 3.0;
}

static double radial(dvec3 p)
{
    if (fabs(p.x) < 0.001 && fabs(p.z) < 0.001)
        return 0.25;
    return 0.25 + (atan2(p.x, p.z) + M_PI) / (2.0 * M_PI);
}

/* ripples and waves: concentric waves from POV-Ray's fixed centres (noise.c); both use the
 * pattern's frequency and phase inside, and again in the final step, as POV-Ray does. */
static double ripples(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 p, int waves)
{
    double sum = 0.0;
    const int n = pt->u.waves;
    for (int i = 0; i < n; ++i) {
        double len = d3_len(d3_sub(p, ts->noise->wave_source[i]));
        if (len == 0.0)
            len = 1.0;
        if (waves) {
            double f = ts->noise->wave_frequency[i];
            sum += vbi_cycloidal(len * pt->frequency * f + pt->phase) / f;
        } else {
            sum += vbi_cycloidal(len * pt->frequency + pt->phase);
        }
    }
    return waves ? 0.2 * (2.5 + sum / n) : 0.5 * (1.0 + sum / n);
}

/* The normal a view-dependent pattern sees: the shading normal turned towards the camera (POV-Ray
 * turns it towards the ray, which is the camera's for what the camera sees). */
static dvec3 facing_normal(const vbi_shade_point *sp)
{
    dvec3 to = d3_sub(sp->p, sp->eye);
    return d3_dot(sp->n, to) > 0.0 ? d3_scale(sp->n, -1.0) : sp->n;
}

static double wrap01(double v) { return v < 0.0 ? 1.0 + fmod(v, 1.0) : fmod(v, 1.0); }

/* slope: the normal's elevation along the slope direction, asin(n.d) mapped to [0, 1], optionally
 * rescaled to [low, high] and mixed with the altitude of the point along another direction. */
static double slope(const vbi_pattern *pt, dvec3 p, const vbi_shade_point *sp)
{
    dvec3 n = facing_normal(sp);
    double v1;
    if (pt->u.slope.point_at)
        v1 = d3_dot(n, d3_norm(d3_sub(pt->u.slope.dir, sp->p)));
    else
        v1 = d3_dot(n, pt->u.slope.dir);
    v1 = v1 > 1.0 ? 1.0 : (v1 < -1.0 ? -1.0 : v1);
    v1 = (asin(v1) / M_PI * 2.0 + 1.0) * 0.5;
    if (pt->u.slope.span != 0.0)
        v1 = (v1 - pt->u.slope.low) / pt->u.slope.span;
    if (pt->u.slope.w_alt == 0.0)
        return v1 == 1.0 ? v1 - VBI_POV_EPSILON : wrap01(v1);
    double v2 = d3_dot(p, pt->u.slope.alt);
    if (pt->u.slope.alt_span != 0.0)
        v2 = (v2 - pt->u.slope.alt_low) / pt->u.slope.alt_span;
    double v = pt->u.slope.w_slope * v1 + pt->u.slope.w_alt * v2;
    if (v - 1.0 < VBI_POV_EPSILON && v >= 1.0)
        return v - VBI_POV_EPSILON; /* keep an exact 1 off the bottom of the map */
    return wrap01(v);
}

static double aoi(const vbi_shade_point *sp)
{
    dvec3 d = d3_norm(d3_sub(sp->p, sp->eye));
    double c = d3_dot(d3_norm(facing_normal(sp)), d);
    c = c > 1.0 ? 1.0 : (c < -1.0 ? -1.0 : c);
    return acos(c) / M_PI;
}

/* spiral1/2: arms winding around z, the angle from -y through +x (POV-Ray's asin form). */
static double spiral(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 p, int two)
{
    const vbi_turb *t = classic_turb(pt);
    double turb = t ? t->amount.x * vbi_turbulence(ts->noise, p, t, pt->generator) : 0.0;
    double rad = sqrt(p.x * p.x + p.y * p.y), phi = 0.0;
    if (rad != 0.0)
        phi = p.x < 0.0 ? 3.0 * M_PI_2 - asin(p.y / rad) : M_PI_2 + asin(p.y / rad);
    double v = p.z + rad + (double)pt->u.arms * phi / (2.0 * M_PI) + turb;
    return two ? vbi_triangle_wave(rad) + vbi_triangle_wave(v) : v;
}

static double square(dvec3 p)
{
    int x = (int)floor(p.x) & 1, z = (int)floor(p.z) & 1;
    return x ? (z ? 2.0 : 3.0) : (z ? 1.0 : 0.0);
}

/* triangular: six colours of unit-side triangles in the x-z plane. */
static double triangular(dvec3 p)
{
    const double sqrt3 = 1.7320508075688772935, sqrt3_2 = 0.86602540378443864676;
    double xs = p.x - 3.0 * floor(p.x / 3.0), zs = p.z - sqrt3 * floor(p.z / sqrt3);
    int a = (int)floor(xs);
    xs -= a;
    int b = zs < sqrt3_2 ? 0 : 1;
    if (b)
        zs = sqrt3 - zs;
    double k = 1.0 - xs, ans = 1.0;
    if (xs != 0.0 && k != 0.0) {
        int s = (zs / xs < sqrt3 ? 1 : 0) + (zs / k < sqrt3 ? 2 : 0);
        ans = s == 3 ? 0.0 : (s == 2 ? 1.0 : 3.0);
    }
    int mask = (int)ans;
    ans = (mask & 1) ? fmod(ans + 2.0 * a, 6.0) : fmod(6.0 + ans - 2.0 * a, 6.0);
    return b ? 5.0 - ans : ans;
}

/* wood: rings around z; turbulence bends them through the vector noise. */
static double wood(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 p)
{
    double x = p.x, y = p.y;
    const vbi_turb *t = classic_turb(pt);
    if (t) {
        dvec3 wt = vbi_dturbulence(ts->noise, p, t);
        x += vbi_cycloidal((p.x + wt.x) * t->amount.x);
        y += vbi_cycloidal((p.y + wt.y) * t->amount.y);
    }
    return sqrt(x * x + y * y);
}

/* wrinkles: ten octaves of noise (each 2 n - 0.5 clamped for generators 2 and 3), halved. */
static double wrinkles(const vbi_texture_set *ts, int gen, dvec3 p)
{
    double lambda = 2.0, omega = 0.5, v;
    double n = vbi_noise(ts->noise, p, gen);
    v = gen > 1 ? fmin(fmax(2.0 * n - 0.5, 0.0), 1.0) : n;
    for (int i = 1; i < 10; ++i) {
        n = vbi_noise(ts->noise, d3_scale(p, lambda), gen);
        v += omega * (gen > 1 ? fmin(fmax(2.0 * n - 0.5, 0.0), 1.0) : n);
        lambda *= 2.0;
        omega *= 0.5;
    }
    return v / 2.0;
}

double vbi_pattern_raw(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 p, const vbi_shade_point *sp)
{
    const int gen = pt->generator;
    switch (pt->kind) {
    case VBNL_PATTERN_AGATE:
        return agate(ts, pt, p);
    case VBNL_PATTERN_AOI:
        return sp ? aoi(sp) : 0.0;
    case VBNL_PATTERN_BOXED:
        return clip_density(fmax(fabs(p.x), fmax(fabs(p.y), fabs(p.z))));
    case VBNL_PATTERN_BOZO:
    case VBNL_PATTERN_BUMPS:
    case VBNL_PATTERN_SPOTTED:
        return vbi_noise(ts->noise, p, gen);
    case VBNL_PATTERN_BRICK:
        return brick(pt, p);
    case VBNL_PATTERN_CELLS:
        return cells(ts, p);
    case VBNL_PATTERN_CHECKER:
        return checker(p);
    case VBNL_PATTERN_CRACKLE:
        return crackle(ts, pt, p);
    case VBNL_PATTERN_CUBIC:
        return cubic(p);
    case VBNL_PATTERN_CYLINDRICAL:
        return clip_density(sqrt(p.x * p.x + p.z * p.z));
    case VBNL_PATTERN_DENSITY:
        return density(pt, p);
    case VBNL_PATTERN_DENTS: {
        double n = vbi_noise(ts->noise, p, gen);
        return n * n * n;
    }
    case VBNL_PATTERN_FACETS:
        return 0.0; /* a normal pattern only */
    case VBNL_PATTERN_FUNCTION: {
        const double q[3] = {p.x, p.y, p.z};
        double v = pt->u.function.fn(pt->u.function.user, q);
        return v > 1.0 ? fmod(v, 1.0) : v;
    }
    case VBNL_PATTERN_GRADIENT: {
        double v = d3_dot(p, pt->u.gradient);
        return v > 1.0 ? fmod(v, 1.0) : v;
    }
    case VBNL_PATTERN_GRANITE:
        return granite(ts, gen, p);
    case VBNL_PATTERN_HEXAGON:
        return hexagon(p);
    case VBNL_PATTERN_IMAGE:
        return vbi_image_value(ts, pt, p, sp);
    case VBNL_PATTERN_JULIA:
    case VBNL_PATTERN_MAGNET:
    case VBNL_PATTERN_MANDEL:
        return vbi_pattern_fractal(pt, p);
    case VBNL_PATTERN_LEOPARD:
        return leopard(p);
    case VBNL_PATTERN_MARBLE:
        return marble(ts, pt, p);
    case VBNL_PATTERN_OBJECT: {
        const double q[3] = {p.x, p.y, p.z};
        return pt->u.function.fn(pt->u.function.user, q) != 0.0 ? 1.0 : 0.0;
    }
    case VBNL_PATTERN_ONION:
        return fmod(d3_len(p), 1.0);
    case VBNL_PATTERN_PIGMENT: {
        float c[5];
        if (!sp || !vbi_pigment_eval(ts, pt->u.pigment, p, sp, c))
            return 0.0;
        return vbi_greyscale(c);
    }
    case VBNL_PATTERN_PLANAR:
        return clip_density(fabs(p.y));
    case VBNL_PATTERN_QUILTED:
        return quilted(pt, p);
    case VBNL_PATTERN_RADIAL:
        return radial(p);
    case VBNL_PATTERN_RIPPLES:
        return ripples(ts, pt, p, 0);
    case VBNL_PATTERN_SLOPE:
        return sp ? slope(pt, p, sp) : 0.0;
    case VBNL_PATTERN_SPHERICAL:
        return clip_density(d3_len(p));
    case VBNL_PATTERN_SPIRAL1:
        return spiral(ts, pt, p, 0);
    case VBNL_PATTERN_SPIRAL2:
        return spiral(ts, pt, p, 1);
    case VBNL_PATTERN_SQUARE:
        return square(p);
    case VBNL_PATTERN_TILING:
        return vbi_pattern_tiling(pt->u.tiling, p);
    case VBNL_PATTERN_PAVEMENT: /* refused by vbnl_scene_add_pattern */
        return 0.0;
    case VBNL_PATTERN_TRIANGULAR:
        return triangular(p);
    case VBNL_PATTERN_WAVES:
        return ripples(ts, pt, p, 1);
    case VBNL_PATTERN_WOOD:
        return wood(ts, pt, p);
    case VBNL_PATTERN_WRINKLES:
        return wrinkles(ts, gen, p);
    case VBNL_PATTERN_KIND_COUNT:
        break;
    }
    return 0.0;
}

double vbi_pattern_shape(const vbi_pattern *pt, double v)
{
    if (pt->frequency != 0.0)
        v = fmod(v * pt->frequency + pt->phase, 1.00001); /* POV-Ray's modulus */
    if (v < 0.0)
        v -= floor(v);
    switch (pt->wave) {
    case VBNL_WAVE_RAMP:
        return v;
    case VBNL_WAVE_TRIANGLE:
        return vbi_triangle_wave(v);
    case VBNL_WAVE_SINE:
        return (1.0 + vbi_cycloidal(v)) * 0.5;
    case VBNL_WAVE_SCALLOP:
        return fabs(vbi_cycloidal(v * 0.5));
    case VBNL_WAVE_CUBIC:
        return v * v * (3.0 - 2.0 * v);
    case VBNL_WAVE_POLY:
        return pow(v, pt->exponent);
    }
    return v;
}

double vbi_pattern_value(const vbi_texture_set *ts, const vbi_pattern *pt, dvec3 q, const vbi_shade_point *sp,
                          dvec3 *warped)
{
    dvec3 w = vbi_pattern_point(ts, pt, q);
    if (warped)
        *warped = w;
    return vbi_pattern_shape(pt, vbi_pattern_raw(ts, pt, w, sp));
}

/* The facets offset and the quilted perturbation are normal patterns: normal.c uses these. */
dvec3 vbi_pattern_quilted_offset(const vbi_pattern *pt, dvec3 p) { return quilted_offset(pt, p); }
