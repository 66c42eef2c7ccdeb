// Mirror and glass: a room with a mirror sphere, a glass sphere and a mirror on the back wall,
// lit by a ceiling panel. Valid POV-Ray 3.7. Written for vbnl; CC0.
#version 3.7;

#ifdef (vbnl_version)
global_settings { integrator { "vbnl" } }
#else
global_settings { assumed_gamma 1.0 max_trace_level 10 radiosity { count 200 recursion_limit 3 } }
#end

camera {
  location <0, 1.5, -4.5>
  look_at <0, 1.0, 0>
  right x * image_width / image_height
  angle 55
}

#default { finish { ambient 0 diffuse 1 } }
#declare White = texture { pigment { rgb 0.75 } }

// Room: x -2.5..2.5, y 0..3, z -5..2.5, open behind the camera.
union {
  box { <-2.5, -0.05, -5>, <2.5, 0, 2.5> }
  box { <-2.5, 3, -5>, <2.5, 3.05, 2.5> }
  box { <-2.55, 0, -5>, <-2.5, 3, 2.5> pigment { rgb <0.6, 0.2, 0.15> } }
  box { <2.5, 0, -5>, <2.55, 3, 2.5> pigment { rgb <0.15, 0.3, 0.6> } }
  box { <-2.5, 0, 2.5>, <2.5, 3, 2.55> }
  texture { White }
}
// Ceiling panel.
// (wound so that its geometric normal faces down, for renderers with one-sided emitters)
mesh {
  triangle { <-0.6, 2.99, -0.6>, <0.6, 2.99, 0.6>, <-0.6, 2.99, 0.6> }
  triangle { <-0.6, 2.99, -0.6>, <0.6, 2.99, -0.6>, <0.6, 2.99, 0.6> }
  pigment { rgb <18, 16, 13> } finish { emission 1 diffuse 0 } }
// A mirror on the back wall.
box { <-1.2, 0.6, 2.45>, <1.2, 2.4, 2.5>
  pigment { rgb 0.95 } finish { diffuse 0 reflection { 1 } } }
// A mirror sphere and a glass sphere.
sphere { <-0.9, 0.6, 0.3>, 0.6
  pigment { rgb 0.95 } finish { diffuse 0 reflection { 1 } } }
sphere { <0.9, 0.6, -0.3>, 0.6
  pigment { rgbf <1, 1, 1, 1> } finish { diffuse 0 reflection { 0.04 } }
  interior { ior 1.5 } }
