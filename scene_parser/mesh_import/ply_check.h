/* A PLY file checked before assimp reads it (private to mesh_import/). */
#ifndef VBI_PLY_CHECK_H
#define VBI_PLY_CHECK_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* Reads the file open in `f` (from its current position, its start; `size` bytes long) and checks
 * its whole structure against its header, so that assimp's PLY reader only ever sees a file that
 * is exactly what it declares:
 * - every header line is one of PLY's own (format, element, property, comment, obj_info) up to
 *   end_header, with known property types;
 * - the element counts fit in the file (every element takes at least one byte in a binary file
 *   and two, "0\n", in an ASCII one), so a header cannot make assimp reserve memory for data the
 *   file does not hold;
 * - the body holds exactly the declared elements: in an ASCII file each element is one line
 *   with one number per scalar property and, per list, a count followed by that many numbers;
 *   in a binary file the elements, lists read with their counts, end within the file.
 * Returns NULL when the file is not a PLY file (assimp decides what it is) or passes; otherwise
 * `why`, holding the reason (at most n bytes) in words that name the element and its line. */
const char *mesh_ply_check(FILE *f, uint64_t size, char *why, size_t n);

#endif
