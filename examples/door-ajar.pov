// Two rooms joined by a door left ajar (Veach's door): the light is in the far room and reaches
// the camera's room only through the gap, the case where virtual lights placed from the light
// sources fail. Same geometry as door-ajar.obj (tools/gen_door_ajar.py), mirrored in z into
// POV-Ray's left-handed coordinates. Valid POV-Ray 3.7. Written for vbnl; CC0.
#version 3.7;

#ifdef (vbnl_version)
global_settings { integrator { "vbnl" } }
#else
global_settings { assumed_gamma 1.0 radiosity { count 400 recursion_limit 4 error_bound 0.5 } }
#end

#declare H = 2.5;       // room height
#declare Open = 20;     // door opening, degrees

// Vertical field of view 60 degrees, whatever the image's aspect ratio.
camera {
  location <3.6, 1.3, -1.6>
  look_at <0, 1, 0.2>
  right x * image_width / image_height
  angle 2 * degrees(atan(tan(radians(30)) * image_width / image_height))
}

#default { finish { ambient 0 diffuse 1 } }
// Walls and door reflect 0.42 and (0.27, 0.18, 0.12) of the light: the scene the measurements
// in docs/performance.md and tests/vbnl/test_bias.c were made with.
#declare White = texture { pigment { rgb 0.7 } finish { diffuse 0.6 } }
#declare Floor = texture { pigment { rgb <0.55, 0.45, 0.35> } finish { diffuse 1 specular 0.3 roughness 0.005 } }
#declare Door = texture { pigment { rgb <0.45, 0.3, 0.2> } finish { diffuse 0.6 } }
#declare Light = texture { pigment { rgb <40, 38, 34> } finish { emission 1 diffuse 0 } }

// The shell: floor, ceiling and four walls (thin boxes outside x -3..4, z -2..2).
box { <-3, -0.05, -2>, <4, 0, 2> texture { Floor } }
union {
  box { <-3, H, -2>, <4, H + 0.05, 2> }
  box { <-3, 0, -2.05>, <4, H, -2> }
  box { <-3, 0, 2>, <4, H, 2.05> }
  box { <-3.05, 0, -2>, <-3, H, 2> }
  box { <4, 0, -2>, <4.05, H, 2> }
  // the wall between the rooms with its doorway (z -0.5..0.5, height 2)
  box { <0, 0, -2>, <0.1, H, -0.5> }
  box { <0, 0, 0.5>, <0.1, H, 2> }
  box { <0, 2, -0.5>, <0.1, H, 0.5> }
  texture { White }
}
// The door, hinged at the doorway's edge z = 0.5.
box { <-0.05, 0, -0.49>, <0, 1.98, 0.5>
  translate -0.5 * z rotate -Open * y translate 0.5 * z
  texture { Door } }
// The light: a panel just below the far room's ceiling.
// (wound so that its geometric normal faces down, for renderers with one-sided emitters)
mesh {
  triangle { <-2.2, H - 0.01, -0.6>, <-0.8, H - 0.01, 0.6>, <-2.2, H - 0.01, 0.6> }
  triangle { <-2.2, H - 0.01, -0.6>, <-0.8, H - 0.01, -0.6>, <-0.8, H - 0.01, 0.6> }
  texture { Light } }
