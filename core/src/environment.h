/* The environment whose radiance varies with direction (private header): POV-Ray's sky_sphere,
 * a stack of pigments evaluated on the unit sphere, and its importance-sampling table.
 *
 * Radiance. For the direction d (unit, pointing from the scene to the sky) the pigments are
 * evaluated at the point q = pattern_from_world (d, 1), the sky_sphere's transforms applied
 * inversely to d taken as a point (POV-Ray 3.7 reference "Sky Sphere"; its renderer maps the ray
 * direction with the inverse transform as a point). The last pigment given is the top layer: each
 * layer adds rgb (1 - filter - transmit) times `emission`, seen through the layers above it, and
 * lets through rgb filter + transmit of what lies below; the background lies below every layer,
 * unscaled by `emission` (POV-Ray 3.7's sky with its background as a last uniform layer). Scenes
 * of an earlier #version compose as POV-Ray does for them (`legacy`, env_compose_legacy).
 * Negative results are clamped to 0 per channel: a light cannot emit a negative radiance.
 *
 * Sampling. At commit the sky is baked into a latitude-longitude table about +y (POV-Ray's up):
 * VBI_ENV_TABLE_ROWS rows of equal polar angle theta in [0, pi], twice as many columns of equal
 * azimuth phi = atan2(z, x). A cell's weight is its solid angle times its mean radiance (the mean
 * of r, g, b, over a 2 x 2 grid of points in it) plus 1% of the sky's mean: every direction keeps
 * a non-zero density, so a pattern feature smaller than a cell is sampled without bias, only less
 * well. An alias table (sampling.h) picks a cell; the direction is uniform in solid angle within
 * it (cos theta uniform between the rows' bounds), so the density is the cell's probability over
 * its solid angle: piecewise constant in solid angle. The table only steers samples; radiance is
 * always the exact pattern (vbi_env_radiance), so the table's resolution affects variance, never
 * the expected value.
 *
 * Threads: after vbi_env_bake, every function here only reads the env; any number of threads may
 * call them at once. */
#ifndef VBI_ENVIRONMENT_H
#define VBI_ENVIRONMENT_H

#include <stdint.h>

#include "sampling.h"
#include "texture/texture.h"
#include "vbnl/scene.h"
#include "vmath.h"

/* Table resolution: 128 rows of 1.41 degrees, 256 columns. Measured bake cost and the reason for
 * the size: docs/environment.md. */
#define VBI_ENV_TABLE_ROWS 128u
#define VBI_ENV_TABLE_COLS 256u

typedef struct vbi_env {
    const vbi_texture_set *tex; /* the scene's texture nodes (outlives the env) */
    uint32_t *pigments;          /* pigment ids, bottom layer first */
    uint32_t count;
    dmat xf;                     /* pattern_from_world */
    vec3 emission, background;
    int legacy;                  /* POV-Ray's composition before 3.7 (environment.c) */
    /* the baked table (vbi_env_bake) */
    int baked;
    int constant;                /* every layer is a solid colour: `mean` everywhere, no table */
    vbi_alias_table table;      /* cells row-major: row (theta) * COLS + column (phi) */
    vec3 mean;                   /* mean radiance over the sphere (the light's power) */
} vbi_env;

/* Makes an env from a validated description (scene.c checks the ids and numbers). Returns NULL
 * when out of memory. The env keeps `tex`, which must outlive it. */
vbi_env *vbi_env_create(const vbnl_environment_desc *d, const vbi_texture_set *tex);
void vbi_env_destroy(vbi_env *e);

/* Builds the sampling table and the mean radiance on the calling thread (idempotent; 0 on
 * success, -1 when out of memory). An env whose radiance is zero everywhere gets no table and a
 * zero mean. */
int vbi_env_bake(vbi_env *e);
/* Drops the table (a failed commit is undone). */
void vbi_env_unbake(vbi_env *e);

/* Radiance arriving from the unit direction d (the exact pattern, not the table). */
vec3 vbi_env_radiance(const vbi_env *e, vec3 d);
/* A direction toward the sky drawn from the table with u in [0,1)^2 and its solid-angle density;
 * returns 0 (and no direction) when the env has no table. */
int vbi_env_sample(const vbi_env *e, vec2 u, vec3 *d, float *pdf);
/* The solid-angle density with which vbi_env_sample draws d (uniform 1/(4 pi) for a constant env). */
float vbi_env_pdf(const vbi_env *e, vec3 d);

#endif
