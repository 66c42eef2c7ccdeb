/* POV-Ray 3.7's noise: tables, the lattice noise of generators 1 to 3, its gradient and
 * turbulence (noise.h for what each computes and where the conventions come from). */
#include "noise.h"

#include <pthread.h>
#include <string.h>

/* The 267 coefficients POV-Ray's value-gradient noise reads at hashed offsets (its RTable, the
 * even entries; data POV-Ray 3.7 fixes, so that every scene keeps its look). */
static const double rtable_values[VBI_NOISE_RTABLE_SIZE] = {
    -1, 0.604974, -0.937102, 0.414115, 0.576226, -0.0161593, 0.432334, 0.103685,
    0.590539, 0.0286412, 0.46981, -0.84622, -0.0734112, -0.304097, -0.40206, -0.210132,
    -0.919127, 0.652033, -0.83151, -0.183948, -0.671107, 0.852476, 0.043595, -0.404532,
    0.75494, -0.335653, 0.618433, 0.605707, 0.708583, -0.477195, 0.899474, 0.490623,
    0.221729, -0.400381, -0.853727, -0.932586, 0.659113, 0.961303, 0.325948, -0.750851,
    0.842466, 0.734401, -0.649866, 0.394491, -0.466056, -0.434073, 0.109026, 0.0847028,
    -0.738857, 0.241505, 0.16228, -0.71426, -0.883665, -0.150408, -0.90396, -0.686549,
    -0.785214, 0.488548, 0.0246433, 0.142473, -0.602136, 0.375845, -0.00779736, 0.498955,
    -0.268147, 0.856382, -0.386007, -0.596094, -0.867735, -0.570977, -0.914366, 0.28896,
    0.672206, -0.233783, 0.94815, 0.895262, 0.343252, -0.173388, -0.767971, -0.314748,
    0.824308, -0.342092, 0.721431, -0.24004, -0.63653, 0.553277, 0.376272, 0.158984,
    -0.452659, 0.396323, -0.420676, -0.454154, 0.122179, 0.295857, 0.0664225, -0.202075,
    -0.724788, 0.453513, 0.224567, -0.908812, 0.176349, -0.320516, -0.697139, 0.742702,
    -0.900786, 0.471489, -0.133532, 0.119127, -0.889769, -0.23183, -0.669673, -0.046891,
    -0.803433, -0.966735, 0.475578, -0.652644, 0.0112459, -0.730007, 0.128283, 0.145647,
    -0.619318, 0.272023, 0.392966, 0.646418, -0.0207675, -0.315908, 0.480797, 0.535668,
    -0.250172, -0.83093, -0.653773, -0.443809, 0.119982, -0.897642, 0.89453, 0.165789,
    0.633875, -0.886839, 0.930877, -0.537194, 0.587732, 0.722011, -0.209461, -0.0424659,
    -0.814267, -0.919432, 0.280262, -0.66302, -0.558099, -0.537469, -0.598779, 0.929656,
    -0.170794, -0.537163, 0.312581, 0.959442, 0.722652, 0.499931, 0.175616, -0.534874,
    -0.685115, 0.444999, 0.17171, 0.108202, -0.768704, -0.463828, 0.254231, 0.546014,
    0.869474, 0.875212, -0.944427, 0.130724, -0.110185, 0.312184, -0.33138, -0.629206,
    0.0606546, 0.722866, -0.0979477, 0.821561, 0.0931258, -0.972808, 0.0318151, -0.867033,
    -0.387228, 0.280995, -0.218189, -0.539178, -0.427359, -0.602075, 0.311971, 0.277974,
    0.773159, 0.592493, -0.0331884, -0.630854, -0.269947, 0.339132, 0.581079, 0.209461,
    -0.317433, -0.284993, 0.181323, 0.341634, 0.804959, -0.229572, -0.758907, -0.336721,
    0.605463, -0.991272, -0.0188754, -0.300191, 0.368307, -0.176135, -0.3832, -0.749569,
    0.62356, -0.573938, 0.278309, -0.971313, 0.839994, -0.830686, 0.439078, 0.66128,
    0.694514, 0.0565042, 0.54342, -0.438804, -0.0228428, -0.687068, 0.857267, 0.301991,
    -0.494255, -0.941039, 0.775509, 0.410575, -0.362081, -0.671534, -0.348379, 0.932433,
    0.886442, 0.868681, -0.225666, -0.062211, -0.0976425, -0.641444, -0.848112, 0.724697,
    0.473503, 0.998749, 0.174701, 0.559625, -0.029099, -0.337392, -0.958129, -0.659785,
    0.236042, -0.246937, 0.659449, -0.027512, 0.821897, -0.226215, 0.0181735, 0.500481,
    -0.420127, -0.427878, 0.566186,
};

static vbi_noise_tables tables;
static pthread_once_t tables_once = PTHREAD_ONCE_INIT;

/* POV-Ray's table generator: x' = 1812433253 x + 12345 in 32-bit arithmetic, 15 bits out. */
static unsigned lcg15(uint32_t *s)
{
    *s = *s * 1812433253u + 12345u;
    return (*s >> 16) & 0x7fffu;
}

/* MT19937 (Matsumoto & Nishimura 1998) with its reference seeding. */
typedef struct mt19937 {
    uint32_t s[624];
    int i;
} mt19937;

static void mt_seed(mt19937 *m, uint32_t seed)
{
    m->s[0] = seed;
    for (int i = 1; i < 624; ++i)
        m->s[i] = 1812433253u * (m->s[i - 1] ^ (m->s[i - 1] >> 30)) + (uint32_t)i;
    m->i = 624;
}

static uint32_t mt_next(mt19937 *m)
{
    if (m->i >= 624) {
        for (int k = 0; k < 624; ++k) {
            uint32_t y = (m->s[k] & 0x80000000u) | (m->s[(k + 1) % 624] & 0x7fffffffu);
            m->s[k] = m->s[(k + 397) % 624] ^ (y >> 1) ^ ((y & 1u) ? 0x9908b0dfu : 0u);
        }
        m->i = 0;
    }
    uint32_t y = m->s[m->i++];
    y ^= y >> 11;
    y ^= (y << 7) & 0x9d2c5680u;
    y ^= (y << 15) & 0xefc60000u;
    return y ^ (y >> 18);
}

static void build_tables(void)
{
    vbi_noise_tables *t = &tables;
    /* the lattice hash: 0..4095 shuffled from the top down, then repeated */
    uint32_t s = 0;
    for (int i = 0; i < 4096; ++i)
        t->hash[i] = (uint16_t)i;
    for (int i = 4095; i >= 0; --i) {
        unsigned j = lcg15(&s) % 4096u;
        uint16_t tmp = t->hash[i];
        t->hash[i] = t->hash[j];
        t->hash[j] = tmp;
    }
    for (int i = 0; i < 4096; ++i)
        t->hash[4096 + i] = t->hash[i];
    for (int i = 0; i < VBI_NOISE_RTABLE_SIZE; ++i) {
        t->rtable[2 * i] = rtable_values[i];
        t->rtable[2 * i + 1] = 0.5 * rtable_values[i];
    }

    /* generator 3: random unit gradients (rejection from the cube) and a permutation */
    const int n = VBI_NOISE_SOLID_SIZE;
    s = 1;
    for (int i = 0; i < n; ++i) {
        double v[3], len2;
        do {
            for (int k = 0; k < 3; ++k)
                v[k] = (double)((int)(lcg15(&s) % (unsigned)(2 * n)) - n) / (double)n;
            len2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        } while (len2 > 1.0 || len2 < 1.0e-5);
        double inv = 1.0 / sqrt(len2);
        for (int k = 0; k < 3; ++k)
            t->solid_grad[i][k] = v[k] * inv;
    }
    memset(t->solid_perm, 0, sizeof(t->solid_perm));
    for (int i = 0; i < n; ++i)
        t->solid_perm[i] = i;
    for (int i = n; i > 0; i -= 2) { /* every other entry from the top, as POV-Ray's loop */
        int k = t->solid_perm[i];
        int j = (int)(lcg15(&s) % (unsigned)n);
        t->solid_perm[i] = t->solid_perm[j];
        t->solid_perm[j] = k;
    }
    for (int i = 0; i < n + 2; ++i) {
        t->solid_perm[n + i] = t->solid_perm[i];
        memcpy(t->solid_grad[n + i], t->solid_grad[i], sizeof(t->solid_grad[i]));
    }

    mt19937 mt;
    mt_seed(&mt, 5489u);
    for (int i = 0; i < VBI_PATTERN_RANDS; ++i)
        t->rands[i] = (double)mt_next(&mt) / 4294967296.0;

    /* ripples and waves: centre i is the gradient noise at (i, 0, 0), normalised; frequency i
     * from the LCG seeded with -560851967 */
    s = (uint32_t)-560851967;
    for (int i = 0; i < VBI_NOISE_MAX_WAVES; ++i) {
        t->wave_source[i] = d3_norm(vbi_dnoise(t, d3((double)i, 0.0, 0.0)));
        t->wave_frequency[i] = (double)lcg15(&s) * 0.000030518509476 + 0.01;
    }
}

const vbi_noise_tables *vbi_noise_tables_get(void)
{
    pthread_once(&tables_once, build_tables);
    return &tables;
}

/* ---- generators 1 and 2 ------------------------------------------------------------------- */

/* The integer cell of x (POV-Ray's floor with its 1e-10 allowance below zero) mapped into
 * 0..4095, and the offset of x from the cell's low corner. */
static int lattice(double x, double *frac)
{
    if (!(fabs(x) < 2.0e9)) { /* beyond int range (and NaN): the same cell index by floating mod */
        double c = isfinite(x) ? floor(x) : 0.0;
        *frac = isfinite(x) ? x - c : 0.0;
        double m = fmod(c + 10000.0, 4096.0);
        return (int)(m < 0.0 ? m + 4096.0 : m);
    }
    int c = x >= 0.0 ? (int)x : (int)(x - (1.0 - 1e-10));
    *frac = x - c;
    return (c + 10000) & 0xfff;
}

static double scurve(double a) { return a * a * (3.0 - 2.0 * a); }

/* The eight corners: offsets of x, y, z and the order POV-Ray sums them in. */
typedef struct corner_set {
    int ix, iy, iz;
    double fx, fy, fz;          /* offsets from the low corner */
    double sx, sy, sz;          /* s-curves of the offsets */
    unsigned h00, h10, h01, h11; /* Hash2d of the four (x, y) columns */
} corner_set;

static void corners(const vbi_noise_tables *t, dvec3 p, corner_set *c)
{
    c->ix = lattice(p.x, &c->fx);
    c->iy = lattice(p.y, &c->fy);
    c->iz = lattice(p.z, &c->fz);
    c->sx = scurve(c->fx);
    c->sy = scurve(c->fy);
    c->sz = scurve(c->fz);
    c->h00 = t->hash[t->hash[c->ix] ^ c->iy];
    c->h10 = t->hash[t->hash[c->ix + 1] ^ c->iy];
    c->h01 = t->hash[t->hash[c->ix] ^ (c->iy + 1)];
    c->h11 = t->hash[t->hash[c->ix + 1] ^ (c->iy + 1)];
}

/* One corner's linear function a + b dx + c dy + d dz, the coefficients at an offset of the table
 * hashed from the corner; `k` selects the x, y or z component of the gradient (0 for the
 * scalar noise, which reads the x one). */
static double corner_term(const vbi_noise_tables *t, unsigned col, int iz, int k, double dx, double dy, double dz)
{
    const double *mp = &t->rtable[(t->hash[col ^ (unsigned)iz] & 0xffu) * 2u + 8u * (unsigned)k];
    return mp[1] + mp[2] * dx + mp[4] * dy + mp[6] * dz;
}

/* Solid noise of generator 3, about [-1, 1]. */
static double solid_noise(const vbi_noise_tables *t, dvec3 p)
{
    const int mask = VBI_NOISE_SOLID_SIZE - 1;
    int b0[3], b1[3];
    double r0[3], r1[3];
    const double pc[3] = {p.x, p.y, p.z};
    for (int i = 0; i < 3; ++i) {
        double v = pc[i] + 10000000.023157213; /* POV-Ray's roll-over offset */
        if (!isfinite(v))
            v = 0.0;
        double fl = floor(v);
        /* the cell index mod 2048 (by floating mod beyond int range) */
        b0[i] = fabs(fl) < 2.0e9 ? (int)fl & mask : (int)(fl - 2048.0 * floor(fl / 2048.0)) & mask;
        b1[i] = (b0[i] + 1) & mask;
        r0[i] = v - fl;
        r1[i] = r0[i] - 1.0;
    }
    const int *perm = t->solid_perm;
    int i = perm[b0[0]], j = perm[b1[0]];
    int b00 = perm[i + b0[1]], b10 = perm[j + b0[1]], b01 = perm[i + b1[1]], b11 = perm[j + b1[1]];
    double sx = scurve(r0[0]), sy = scurve(r0[1]), sz = scurve(r0[2]);
#define VBI_GDOT(idx, rx, ry, rz) (t->solid_grad[idx][0] * (rx) + t->solid_grad[idx][1] * (ry) + t->solid_grad[idx][2] * (rz))
    double u = VBI_GDOT(b00 + b0[2], r0[0], r0[1], r0[2]), v = VBI_GDOT(b10 + b0[2], r1[0], r0[1], r0[2]);
    double a = u + sx * (v - u);
    u = VBI_GDOT(b01 + b0[2], r0[0], r1[1], r0[2]);
    v = VBI_GDOT(b11 + b0[2], r1[0], r1[1], r0[2]);
    double b = u + sx * (v - u);
    double c = a + sy * (b - a);
    u = VBI_GDOT(b00 + b1[2], r0[0], r0[1], r1[2]);
    v = VBI_GDOT(b10 + b1[2], r1[0], r0[1], r1[2]);
    a = u + sx * (v - u);
    u = VBI_GDOT(b01 + b1[2], r0[0], r1[1], r1[2]);
    v = VBI_GDOT(b11 + b1[2], r1[0], r1[1], r1[2]);
    b = u + sx * (v - u);
    double d = a + sy * (b - a);
#undef VBI_GDOT
    return c + sz * (d - c);
}

static double clamp01(double v) { return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v); }

double vbi_noise(const vbi_noise_tables *t, dvec3 p, int generator)
{
    if (generator == 3)
        return clamp01(0.5 * (1.59 * solid_noise(t, p) + 0.985));
    corner_set c;
    corners(t, p, &c);
    const double tx = 1.0 - c.sx, ty = 1.0 - c.sy, tz = 1.0 - c.sz;
    const double gx = c.fx - 1.0, gy = c.fy - 1.0, gz = c.fz - 1.0;
    double sum = tx * ty * tz * corner_term(t, c.h00, c.iz, 0, c.fx, c.fy, c.fz);
    sum += c.sx * ty * tz * corner_term(t, c.h10, c.iz, 0, gx, c.fy, c.fz);
    sum += tx * c.sy * tz * corner_term(t, c.h01, c.iz, 0, c.fx, gy, c.fz);
    sum += c.sx * c.sy * tz * corner_term(t, c.h11, c.iz, 0, gx, gy, c.fz);
    sum += tx * ty * c.sz * corner_term(t, c.h00, c.iz + 1, 0, c.fx, c.fy, gz);
    sum += c.sx * ty * c.sz * corner_term(t, c.h10, c.iz + 1, 0, gx, c.fy, gz);
    sum += tx * c.sy * c.sz * corner_term(t, c.h01, c.iz + 1, 0, c.fx, gy, gz);
    sum += c.sx * c.sy * c.sz * corner_term(t, c.h11, c.iz + 1, 0, gx, gy, gz);
    if (generator == 1)
        return clamp01(sum + 0.5);
    /* generator 2: the measured range [-1.05242, 0.988997] stretched onto [0, 1] */
    return clamp01((sum + 1.05242) * 0.48985582);
}

dvec3 vbi_dnoise(const vbi_noise_tables *t, dvec3 p)
{
    corner_set c;
    corners(t, p, &c);
    const double tx = 1.0 - c.sx, ty = 1.0 - c.sy, tz = 1.0 - c.sz;
    const double gx = c.fx - 1.0, gy = c.fy - 1.0, gz = c.fz - 1.0;
    /* the corners in POV-Ray's order for the gradient, each with its weight and offsets */
    const struct {
        unsigned col;
        int dz;
        double w, dx, dy, ddz;
    } k[8] = {
        {c.h00, 0, tx * ty * tz, c.fx, c.fy, c.fz},      {c.h10, 0, c.sx * ty * tz, gx, c.fy, c.fz},
        {c.h11, 0, c.sx * c.sy * tz, gx, gy, c.fz},      {c.h01, 0, tx * c.sy * tz, c.fx, gy, c.fz},
        {c.h01, 1, tx * c.sy * c.sz, c.fx, gy, gz},      {c.h11, 1, c.sx * c.sy * c.sz, gx, gy, gz},
        {c.h10, 1, c.sx * ty * c.sz, gx, c.fy, gz},      {c.h00, 1, tx * ty * c.sz, c.fx, c.fy, gz},
    };
    dvec3 r = d3(0.0, 0.0, 0.0);
    for (int i = 0; i < 8; ++i) {
        int iz = c.iz + k[i].dz;
        r.x += k[i].w * corner_term(t, k[i].col, iz, 0, k[i].dx, k[i].dy, k[i].ddz);
        r.y += k[i].w * corner_term(t, k[i].col, iz, 1, k[i].dx, k[i].dy, k[i].ddz);
        r.z += k[i].w * corner_term(t, k[i].col, iz, 2, k[i].dx, k[i].dy, k[i].ddz);
    }
    return r;
}

/* ---- turbulence --------------------------------------------------------------------------- */

double vbi_turbulence(const vbi_noise_tables *t, dvec3 p, const vbi_turb *turb, int generator)
{
    const int stretched = generator > 1;
    double value = vbi_noise(t, p, generator);
    if (stretched)
        value = clamp01(2.0 * value - 0.5);
    double l = turb->lambda, o = turb->omega;
    for (int i = 2; i <= turb->octaves; ++i) {
        double n = vbi_noise(t, d3_scale(p, l), generator);
        value += o * (stretched ? 2.0 * n - 0.5 : n);
        if (i < turb->octaves) {
            l *= turb->lambda;
            o *= turb->omega;
        }
    }
    return value;
}

dvec3 vbi_dturbulence(const vbi_noise_tables *t, dvec3 p, const vbi_turb *turb)
{
    dvec3 r = vbi_dnoise(t, p);
    double l = turb->lambda, o = turb->omega;
    for (int i = 2; i <= turb->octaves; ++i) {
        r = d3_fma(r, vbi_dnoise(t, d3_scale(p, l)), o);
        if (i < turb->octaves) {
            l *= turb->lambda;
            o *= turb->omega;
        }
    }
    return r;
}

/* ---- waves -------------------------------------------------------------------------------- */

double vbi_cycloidal(double v)
{
    if (v >= 0.0)
        return sin((v - floor(v)) * (2.0 * M_PI));
    return -sin((-v - floor(-v)) * (2.0 * M_PI));
}

double vbi_triangle_wave(double v)
{
    double f = v - floor(v);
    return f >= 0.5 ? 2.0 * (1.0 - f) : 2.0 * f;
}
