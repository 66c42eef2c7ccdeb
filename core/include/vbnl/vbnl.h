/* vbnl: Virtual Blue Noise Lighting renderer core. Umbrella header.
 *
 *   result.h      result codes and caller-owned error messages
 *   scene.h       building a scene: meshes, spheres, instances, materials, lights, camera
 *   params.h      named integrator parameters and their validation
 *   render.h      context (threads, Embree), renderer, film, progress and cancellation
 *   integrator.h  the versioned integrator ABI and the registry of integrators */
#ifndef VBNL_VBNL_H
#define VBNL_VBNL_H

#include "vbnl/integrator.h"
#include "vbnl/params.h"
#include "vbnl/render.h"
#include "vbnl/result.h"
#include "vbnl/scene.h"

#define VBNL_VERSION_MAJOR 0
#define VBNL_VERSION_MINOR 1
#define VBNL_VERSION_PATCH 0
#define VBNL_VERSION_STRING "0.1.0"

#endif
