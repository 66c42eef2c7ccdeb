/* vbnl object layer: 4x4 row-major affine matrices (p' = M p, as in vbnl/scene.h), shared by the
 * object and texture parts (matrix.c). */
#ifndef VBI_POV_MATRIX_H
#define VBI_POV_MATRIX_H

void pov_m4_identity(double m[16]);
void pov_m4_mul(const double a[16], const double b[16], double out[16]); /* out = a b */
void pov_m4_translate(const double v[3], double m[16]);
void pov_m4_scale(const double v[3], double m[16]);
/* POV-Ray rotate <a,b,c>: about x by a, then y by b, then z by c (degrees). */
void pov_m4_rotate(const double deg[3], double m[16]);
/* POV-Ray matrix <12 values>: row-vector convention, p' = p M. */
void pov_m4_from_pov(const double v[12], double m[16]);
int pov_m4_invert(const double m[16], double out[16]); /* 0: singular */
void pov_m4_point(const double m[16], const double p[3], double out[3]);
void pov_m4_dir(const double m[16], const double d[3], double out[3]);
/* 1 when the linear part is a rotation times a uniform scale (returned in *s). */
int pov_m4_is_similarity(const double m[16], double *s);

#endif
