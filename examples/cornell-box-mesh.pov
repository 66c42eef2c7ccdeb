// The Cornell box imported from a mesh file (vbnl's vbnl_mesh extension): cornell-box.obj with
// its MTL materials (Bitterli's reflectances, light radiance 17 12 4), mirrored in z into
// POV-Ray's left-handed coordinates so that it frames like cornell-box.pov. POV-Ray, which
// cannot read OBJ files, renders cornell-box.pov instead. Written for vbnl; CC0.
#version 3.7;

#ifdef (vbnl_version)
global_settings { integrator { "vbnl" } }
camera {
  perspective
  location <0, 0.98195, -3.88317>
  look_at <0, 0.98195, 0>
  right x * image_width / image_height
  angle 39.3
}
// The path is relative to this file; a texture { } here would override the file's materials.
vbnl_mesh { "cornell-box.obj" scale <1, 1, -1> }
#else
#include "cornell-box.pov"
#end
