/* vbnl: mesh files (OBJ/MTL, PLY, glTF, ... anything assimp reads) into a vbnl_scene.
 *
 * Material mapping from Wavefront MTL (and assimp's equivalents for other formats):
 *   Ke > 0                 emission Ke (one-sided, the side of the face normal)
 *   illum 4, 6, 7, 9 or d < 1 (transparent)   smooth dielectric, ior Ni (1.5 when Ni <= 1), tint Tf
 *   illum 3 or 5 with Ks > 0 (ray-traced reflection)   perfect mirror tinted by Ks
 *   Ks > 0 and Kd > 0      rough plastic: base Kd, GGX coat with ior Ni (1.5 when Ni <= 1)
 *   Ks > 0 and Kd = 0      GGX conductor with F0 = Ks
 *   otherwise              Lambertian, albedo Kd
 * Roughness from the Phong exponent Ns: alpha = sqrt(2 / (Ns + 2)) (the Beckmann/Phong
 * equivalence of Walter et al. 2007, used by pbrt and Mitsuba for the same conversion), clamped
 * to [0.001, 1]. Colours are clamped to [0, 1].
 *
 * Thread-safety: one import per scene at a time (scene building is single-threaded). */
#ifndef VBNL_MESH_IMPORT_H
#define VBNL_MESH_IMPORT_H

#include <stdint.h>

#include "vbnl/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vbnl_mesh_import_options {
    const float *transform;      /* optional 4x4 row-major, applied to every vertex */
    int override_material;       /* 1: use `material` for every face instead of the file's */
    uint32_t material;
    uint32_t group;              /* VBNL_GROUP_WORLD or a group id */
    int two_sided_emission;      /* emissive faces emit on both sides */
} vbnl_mesh_import_options;

typedef struct vbnl_mesh_import_stats {
    uint32_t meshes;
    uint64_t triangles;
    uint32_t materials;
    uint32_t emissive_materials;
} vbnl_mesh_import_stats;

/* alpha = sqrt(2 / (Ns + 2)), clamped to [0.001, 1]. */
float vbnl_phong_exponent_to_alpha(float ns);

/* Loads every triangle of `path` into `scene`. Errors name the file and assimp's message. */
vbnl_result vbnl_mesh_import(vbnl_scene *scene, const char *path, const vbnl_mesh_import_options *opt,
                             vbnl_mesh_import_stats *stats, vbnl_error *err);

#ifdef __cplusplus
}
#endif
#endif
