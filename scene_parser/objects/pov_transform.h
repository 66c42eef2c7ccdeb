/* vbnl object layer: what the object part's transforms (transform.c) and the texture part's
 * (texture/transform.c) share. Each part has its own rows: an object's `scale 0` becomes 1 and
 * its `transform` may name a declared transform; in an appearance both are errors. */
#ifndef VBI_POV_TRANSFORM_H
#define VBI_POV_TRANSFORM_H

#include "pov_block.h"
#include "pov_matrix.h"

/* translate <v>, rotate <v>, scale <v>: rows with arg POV_TRANSLATE, POV_ROTATE, or for scale
 * POV_SCALE (objects: a 0 component becomes 1, with a warning, as in POV-Ray) or
 * POV_SCALE_NONZERO (appearances: a 0 component is an error). */
enum { POV_TRANSLATE = 0, POV_ROTATE, POV_SCALE, POV_SCALE_NONZERO };
vbnl_result pov_transform_vector(const pov_item *it);

/* The target of a transform { } block: its items composed, and whether `inverse` came. */
typedef struct pov_xform {
    double m[16];
    int inverse;
} pov_xform;

extern const pov_row pov_inverse_rows[];                        /* inverse */
void pov_xform_compose(const pov_item *it, const double m[16]); /* the block's transform callback */
/* The block's matrix into out, inverted when `inverse` came (an error when it is singular). */
vbnl_result pov_xform_result(vbnl_sdl_parser *p, const pov_xform *x, double out[16]);

#endif
