/* Virtual-light files as the farm commands see them (private core header; never installed).
 *
 * The part of vl_file.h that needs no renderer internals: the header of a file, reading it back
 * (checksum verified), summing the photon ranges of several files into one without the scene, and
 * the fingerprints that tie a file (and a rendered tile) to its scene and camera. The plugin's
 * `vbnl merge-lights`, `vbnl photons --part` and the EXR header of a render that loads lights use
 * it (meson's vbnl_core_vl_file_dep); the format itself is described in vl_file.h.
 *
 * Errors (message in `err`): as vl_file.h: VBNL_ERR_IO, VBNL_ERR_CORRUPT, VBNL_ERR_UNSUPPORTED,
 * VBNL_ERR_INVALID_ARGUMENT (files that do not belong together: another scene, another
 * preparation, overlapping ranges, a range left out), VBNL_ERR_OUT_OF_MEMORY, VBNL_ERR_CANCELLED.
 *
 * Threads: no shared state but the table of atomic files (lock-free); the functions may run
 * concurrently on different data. */
#ifndef VBI_VL_FILE_TOOLS_H
#define VBI_VL_FILE_TOOLS_H

#include <stdint.h>

#include "vbnl/result.h"
#include "vbnl/scene.h"

/* What a file says about itself (vl_file.h gives the byte layout). */
typedef struct vbi_vl_file_header {
    uint32_t version;             /* filled by reads; a save always writes VBI_VL_FILE_VERSION */
    uint64_t fingerprint;         /* of the scene: vbi_vl_file_scene_fingerprint */
    uint32_t virtual_lights;      /* N asked for */
    uint32_t profile_resolution;
    uint64_t photon_paths;        /* N of the flux normalisation (all ranges together) */
    uint64_t photon_first, photon_count; /* the paths whose deposits the file holds; a placement
                                            (no photon traced yet) holds [0, 0) */
    double unit;
    uint64_t seed;
    uint32_t elimination;
    float radius_scale;
    uint32_t material_count;
    uint32_t flags;               /* VBI_VL_FILE_SUPPORT_TEST (vl_file.h) */
    uint32_t width, height;       /* the image the placement was made for */
    uint64_t camera;              /* vbi_vl_file_camera_fingerprint of the scene it was made with */
    uint64_t preparation;         /* FNV-1a of every preparation parameter (vbnl.c) */
    uint64_t set;                 /* FNV-1a of the set's arrays and glossy flags (written by save) */
    double placement_seconds;     /* informative: what preparing it took, */
    double elimination_seconds;   /* the photon figures summed over the ranges it holds */
    double photon_seconds;
    double photon_rays;
    uint32_t count;               /* lights in the set (filled by reads) */
    uint32_t glossy_count;        /* lights with an incident map (filled by reads) */
} vbi_vl_file_header;

/* Reads `path`'s header; the arrays are not decoded. With `verify`, after the checksum over the
 * whole file (a damaged file is named as damaged, not misread); without, only the header is read
 * and checked (magic, byte order, version, size), for a file this process has loaded already. */
vbnl_result vbi_vl_file_read_header(const char *path, int verify, vbi_vl_file_header *out, vbnl_error *err);

/* Sums the photon data of `n` files of one preparation (same scene, parameters and set, bit for
 * bit; their photon ranges disjoint) into `out_path`, written atomically; the sum equals one run
 * over all their paths bit for bit (fixed-point incident power, profiles.h). The ranges must
 * together cover [0, photon_paths) exactly once, or, with `partial`, one contiguous part of it.
 * A placement (a file of no photon) adds nothing and may be among them. `merged` (may be NULL)
 * receives the header written. `out_path` must not be one of the inputs (checked by the caller:
 * it is written only after every input was read). Needs no scene: the files' own fingerprint and
 * material count are compared with each other. */
vbnl_result vbi_vl_file_merge(const char *const *paths, uint32_t n, const char *out_path, int partial,
                               vbi_vl_file_header *merged, vbnl_error *err);

/* The scene fingerprint files are tied to (geometry, materials, textures, lights; not the camera),
 * and the camera's (position and the three frame vectors, by their bits). 0 for NULL or an
 * uncommitted scene. */
uint64_t vbi_vl_file_scene_fingerprint(const vbnl_scene *scene);
uint64_t vbi_vl_file_camera_fingerprint(const vbnl_scene *scene);

#endif
