/* POV-Ray's `tiling` pattern (reference manual, "Tiling"), types 1 to 24: a periodic tiling of the
 * x-z plane by polygons, each tile type owning one band of [0, 1]. Within a tile of band k of n the
 * value is (k + 1 - d / r) / n, clamped to the band, where d is the distance to the tile's nearest
 * edge and r that edge's normaliser: the value rises from the band's bottom inside the tile to its
 * top at the tile's border.
 *
 * Every tiling is data here (tiling_table.h): a lattice and the convex tiles of one cell. The
 * point is brought into the cell, and of the tiles of the cell and of its eight neighbours the one
 * whose nearest edge is farthest (the tile containing the point) gives the value. POV-Ray's
 * Penrose tilings (types 25 to 27) are not implemented (the core refuses them). */
#include <math.h>

#include "texture.h"

typedef struct tile {
    unsigned char band, count;  /* band index, vertex count */
    unsigned short vertex, radius; /* first vertex (pairs) and first edge normaliser in the pools */
    double lo, shift;           /* least value (0: none) and offset in band units */
} tile;

typedef struct tiling {
    double a[2], b[2];          /* lattice vectors in (x, z) */
    int bands;
    int first, count;           /* tiles */
} tiling;

#include "tiling_table.h"

double vbi_pattern_tiling(int type, dvec3 p)
{
    if (type < 1 || type > 24)
        return 0.0;
    const tiling *t = &tilings[type - 1];
    /* the point in the cell spanned by a and b */
    const double det = t->a[0] * t->b[1] - t->a[1] * t->b[0];
    const double s = (p.x * t->b[1] - p.z * t->b[0]) / det, u = (t->a[0] * p.z - t->a[1] * p.x) / det;
    const double fs = s - floor(s), fu = u - floor(u);
    const double qx = fs * t->a[0] + fu * t->b[0], qz = fs * t->a[1] + fu * t->b[1];
    double best = -INFINITY, best_g = 0.0;
    const tile *found = &tiles[t->first];
    for (int i = -1; i <= 1; ++i)
        for (int j = -1; j <= 1; ++j) {
            const double ox = qx - i * t->a[0] - j * t->b[0], oz = qz - i * t->a[1] - j * t->b[1];
            for (int k = 0; k < t->count; ++k) {
                const tile *tl = &tiles[t->first + k];
                const double *v = &tile_vertices[2 * tl->vertex];
                const double *r = &tile_radii[tl->radius];
                double m = INFINITY, mg = INFINITY;
                for (int e = 0; e < tl->count; ++e) {
                    const int f = e + 1 < tl->count ? e + 1 : 0;
                    const double ex = v[2 * f] - v[2 * e], ez = v[2 * f + 1] - v[2 * e + 1];
                    const double d = (ex * (oz - v[2 * e + 1]) - ez * (ox - v[2 * e])) / sqrt(ex * ex + ez * ez);
                    m = fmin(m, d);
                    mg = fmin(mg, d / r[e]);
                }
                if (m > best) {
                    best = m;
                    best_g = mg;
                    found = tl;
                }
            }
        }
    const double g = fmin(1.0, fmax(0.0, 1.0 - best_g));
    const double value = (found->band + g + found->shift) / t->bands;
    return found->lo > 0.0 ? fmax(value, found->lo) : value;
}
