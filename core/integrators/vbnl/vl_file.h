/* Saving and loading a prepared VBNL virtual-light set (private header).
 *
 * The set of vl_set.h (stages 1-2) and its incident photon data (stage 3, profiles.h) make a
 * value that can be written to a file and read back for the same scene: preparation and shading
 * can run in different processes, and photon splitting can be split across processes (each
 * traces a disjoint range of the same total photon_paths; splitting.h) and summed exactly with
 * vbi_profile_set_merge, because incident power is 64-bit fixed point. A placement (stages 1-2
 * without photons) is saved once and the processes that load it trace the ranges, and
 * vl_file_tools.h sums their files without the scene: a farm (docs/farm.md).
 *
 * ---- Format, version 4 (byte offsets; numbers in the writer's byte order) -------------------
 *
 *   0   8  magic "VBNLVLS\0"
 *   8   4  u32 format version (VBI_VL_FILE_VERSION)
 *  12   4  u32 byte-order marker 0x01020304 (reads 0x04030201 on a machine of the other order)
 *  16   8  u64 scene fingerprint (vbi_vl_file_scene_fingerprint)
 *  24   4  u32 count: lights in the set
 *  28   4  u32 virtual_lights: N asked for (count may be lower: escaped placement paths)
 *  32   4  u32 profile_resolution R (8, 16 or 32)
 *  36   4  u32 glossy_count: lights with an incident map
 *  40   8  u64 photon_paths: N of the flux normalisation (all ranges together)
 *  48   8  u64 photon_first  } the photon paths whose deposits this file holds:
 *  56   8  u64 photon_count  } [photon_first, photon_first + photon_count); a placement, whose
 *                              photons other processes trace, holds [0, 0)
 *  64   8  f64 unit: W per fixed-point step (a power of two, profiles.h)
 *  72   8  u64 seed of the preparation
 *  80   4  u32 elimination mode (vbi_elim_mode; informative)
 *  84   4  f32 radius_scale alpha_r (informative)
 *  88   4  u32 material_count of the scene
 *  92   4  u32 flags: bit 0 (VBI_VL_FILE_SUPPORT_TEST) when splitting applied the support test
 *          (vl_support.h)
 *  96   4  u32 width  } the image the placement was made for (its camera paths, §3.1)
 * 100   4  u32 height }
 * 104   8  u64 camera fingerprint (vbi_vl_file_camera_fingerprint)
 * 112   8  u64 preparation fingerprint: every parameter that shaped the set and its photons
 * 120   8  u64 set fingerprint: FNV-1a 64 of the arrays below up to the glossy flags (without
 *          their padding): equal sets, equal values
 * 128   8  f64 seconds of placement    } informative: what preparing the file took, the photon
 * 136   8  f64 seconds of elimination  } figures summed over the ranges it holds (reported in
 * 144   8  f64 seconds of photon paths } the EXR header of the renders that load it)
 * 152   8  f64 rays of photon paths    }
 * 160      arrays, each count long unless said otherwise:
 *          positions (3 x f32), normals (3 x f32), materials (u32), texture tints
 *          (3 x f32, vl_set.h), radii (f32),
 *          densities (f32), glossy flags (u8, then 0-bytes up to a multiple of 8),
 *          then, unless the file is a placement (photon_count 0, whose incident data are all
 *          zero and not stored): incident power Phi_in (3 x u64 fixed point),
 *          incident maps of the glossy lights in light order (glossy_count x R^2 x 3 x u64,
 *          texel order of vbi_profile_incident_map_fixed)
 * end-8 8  u64 checksum: FNV-1a 64 of every byte before it
 *
 * Stable across all versions: the magic, the version at offset 8, the marker at offset 12 and
 * the trailing FNV-1a 64 checksum. So a loader verifies the checksum before it trusts anything
 * else, and a damaged version field is reported as damage, not as another version.
 *
 * Writing is atomic, through the atomic files of atomic_file.h: a temporary file in the same
 * folder, fsync, rename; on any failure the temporary is removed and no file is left (an existing
 * file at `path` stays as it was). The temporary is listed in the table that
 * vbi_atomic_file_abandon_all empties from a signal handler (the plugin's abandon_writes), so an
 * interrupted save leaves nothing either; after that call every save fails with
 * VBNL_ERR_CANCELLED.
 *
 * Errors (message in `err`): VBNL_ERR_IO (open/read/write/rename failed), VBNL_ERR_CANCELLED
 * (writes were abandoned: the process is ending), VBNL_ERR_CORRUPT (not a virtual-light file,
 * checksum mismatch, truncation, another format version, inconsistent contents),
 * VBNL_ERR_UNSUPPORTED (other byte order), VBNL_ERR_INVALID_ARGUMENT (another scene; files of a
 * list that do not belong together or whose photon ranges overlap or leave gaps),
 * VBNL_ERR_OUT_OF_MEMORY.
 *
 * Threads: no shared state but the table of atomic files (lock-free); the functions may run
 * concurrently on different data. */
#ifndef VBI_VL_FILE_H
#define VBI_VL_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "octahedral.h"
#include "profiles.h"
#include "scene_internal.h"
#include "vbnl/result.h"
#include "vl_file_tools.h"
#include "vl_set.h"

#define VBI_VL_FILE_VERSION 4u
#define VBI_VL_FILE_MAGIC "VBNLVLS"  /* 8 bytes with its terminating NUL */
#define VBI_VL_FILE_HEADER_SIZE 160u
#define VBI_VL_FILE_SUPPORT_TEST 1u /* flags: photons split with the support test */
#define VBI_VL_FILE_HASH_INIT 0xcbf29ce484222325ull

/* Writes the set (h, vls and the incident data of `profiles`, whose VL count and unit must match)
 * to `path` atomically. profile_resolution and glossy flags come from `profiles`' map and
 * layout, the set fingerprint from the arrays (h->set, count and glossy_count are not read).
 * The incident maps must not have been released (VBNL_ERR_STATE). */
vbnl_result vbi_vl_file_save(const char *path, const vbi_vl_file_header *h, const vbi_vl_set *vls,
                              const vbi_profile_set *profiles, vbnl_error *err);

/* What a load gives: the set, a map of the file's resolution and the profile set holding the
 * (summed) incident data, all owned by the struct. */
typedef struct vbi_vl_file_data {
    vbi_vl_file_header header;   /* after a merge: photon_first 0, photon_count photon_paths */
    vbi_vl_set vls;
    vbi_hemioct *map;
    vbi_profile_set *profiles;
} vbi_vl_file_data;

/* Loads one file, or several separated by ':' holding the same set (same scene, parameters and
 * arrays, bit for bit) with incident data of photon ranges that must together cover
 * [0, photon_paths) exactly once; their incident data are summed (vbi_profile_set_merge), which
 * equals one run over all paths bit for bit. A placement (a file of no photon, header
 * photon_count 0) loads only alone, as it is: its loader traces the photons. `scene` (committed)
 * is checked against the stored fingerprint. On failure `out` is left empty. */
vbnl_result vbi_vl_file_load(const char *paths, const vbnl_scene *scene, vbi_vl_file_data *out,
                              vbnl_error *err);
/* Frees what a load gave (accepts a zeroed or NULL struct). */
void vbi_vl_file_data_free(vbi_vl_file_data *d);

/* FNV-1a 64 of n bytes continuing from h (start with VBI_VL_FILE_HASH_INIT): the checksum. */
uint64_t vbi_vl_file_hash(uint64_t h, const void *data, size_t n);

#endif
