/* vbnl core: POV-Ray's mesh camera (private header; scene.h, VBNL_CAMERA_MESH). */
#ifndef VBI_CAMERA_MESH_H
#define VBI_CAMERA_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "vbnl/scene.h"
#include "vmath.h"

/* Checks a mesh camera's description and replaces c->meshes by the scene's own copy, with
 * c->mesh_index pointing at it (free it with vbi_camera_mesh_free). Errors as
 * vbnl_scene_set_camera's; c is unchanged on failure. */
vbnl_result vbi_camera_mesh_copy(vbnl_camera_desc *c, vbnl_error *err);
void vbi_camera_mesh_free(void *mesh_index);

/* The ray of image point (px, py) in pixels; `pick` in [0, 1) chooses among the pixel's rays.
 * Returns 0 where there is none. Uses the copy's index when c->mesh_index is set, and works
 * without it (slower for distribution 3). Any thread. */
int vbi_camera_mesh_ray(const vbnl_camera_desc *c, uint32_t width, uint32_t height, float px, float py, float pick,
                        vec3 *o, vec3 *d);

/* Feeds the mesh camera's settings and meshes to `hash` (the light files' camera fingerprint). */
uint64_t vbi_camera_mesh_hash(const vbnl_camera_desc *c, uint64_t h, uint64_t (*hash)(uint64_t, const void *, size_t));

#endif
