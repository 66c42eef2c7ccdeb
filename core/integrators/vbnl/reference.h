/* Plain references of vbnl's optimised stages (private header; built into the tests, not into
 * the library): the rules of photon splitting (splitting.h) and of the VL index query
 * (vl_index.h) written from the paper, one query or one hit at a time, by brute force over every
 * virtual light, without batches, SIMD, prefetches, pipelines or per-thread sums. The tests
 * hold the optimised code to them bit for bit: the VL index's answers exactly, photon
 * splitting's 64-bit fixed-point sums and maps exactly.
 *
 * Both are slow (every VL is tested at every query) and single-threaded; they are for test
 * scenes of a few thousand VLs. Both are built without contracted multiply-adds, as the stages
 * they check. Threads: each call uses only what it is given. */
#ifndef VBI_REFERENCE_H
#define VBI_REFERENCE_H

#include <stdint.h>

#include "splitting.h"
#include "vl_index.h"

/* The VL index query (vl_index.h, vbi_vl_index_query_found) by brute force over the `count`
 * spheres (centres, radii, normals by id): the spheres that contain p (vbi_vl_contains) and,
 * when f is given (normals must be), pass its filter (vbi_vl_filter_passes), in ascending id;
 * at most max_out of them written to found (id, d^2 as a float, r; rank = id: the reference has
 * no index). Returns how many there are (may exceed max_out). */
uint32_t vbi_vl_query_reference(const vec3 *centers, const float *radii, const vec3 *normals, uint32_t count,
                                 vec3 p, const vbi_vl_filter *f, uint32_t max_out, vbi_vl_found *found);

/* Photon splitting (vbi_split_photons) by the rules of splitting.h, serially: the paths
 * [first_path, first_path + path_count) of `d` through the general photon walk (photon_walk.h;
 * each ray traced alone, with the packet kernel splitting uses: splitting_reference.c), at every
 * hit the VLs of d->index found by brute force (centres and radii read back from the
 * index, ranks from it: the order of the rules), the deposits one at a time with
 * vbi_profile_deposit_fixed. d->chunk, d->atomic_deposits and d->general_walk are ignored (they
 * only choose how vbi_split_photons does the same work). Fills the counters of `stats` that do
 * not describe how the work was done (paths, rays, hits, delta_hits, covered_hits, deposits,
 * overflow, support_tests, support_rejects, covered_power; the rest 0). Errors: those of
 * vbi_split_photons for a bad descriptor, VBNL_ERR_OUT_OF_MEMORY. */
vbnl_result vbi_split_photons_reference(const vbi_split_desc *d, vbi_split_stats *stats);

#endif
