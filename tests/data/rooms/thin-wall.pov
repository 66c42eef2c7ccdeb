// A closed all-diffuse room (4 x 2.4 x 3) split by a 0.1 mm wall with a doorway, one floor under
// both halves; a two-sided light panel hung 1 cm below the ceiling of the left half; the camera
// in the right half looks at the wall and through the doorway. A bias test scene
// (tests/vbnl/test_bias.c). Valid POV-Ray 3.7. Written for vbnl; CC0.
#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <1.9, 1.0, -1.3> look_at <0, 0.5, 0.2> right x * image_width / image_height angle 75 }
#default { finish { ambient 0 diffuse 1 } }
#declare White = texture { pigment { rgb 0.7 } }
#declare Light = texture { pigment { rgb <20, 19, 17> } finish { emission 1 diffuse 0 } }
box { <-2, -0.05, -1.5>, <2, 0, 1.5> texture { White } }
box { <-2, 2.4, -1.5>, <2, 2.45, 1.5> texture { White } }
box { <-2.05, 0, -1.5>, <-2, 2.4, 1.5> texture { White } }
box { <2, 0, -1.5>, <2.05, 2.4, 1.5> texture { White } }
box { <-2, 0, -1.55>, <2, 2.4, -1.5> texture { White } }
box { <-2, 0, 1.5>, <2, 2.4, 1.55> texture { White } }
union {
  box { <0, 0, -1.5>, <0.0001, 2.4, -0.3> }
  box { <0, 0, 0.3>, <0.0001, 2.4, 1.5> }
  box { <0, 2.0, -0.3>, <0.0001, 2.4, 0.3> }
  texture { White } }
mesh {
  triangle { <-1.3, 2.39, -0.4>, <-0.7, 2.39, 0.4>, <-1.3, 2.39, 0.4> }
  triangle { <-1.3, 2.39, -0.4>, <-0.7, 2.39, -0.4>, <-0.7, 2.39, 0.4> }
  texture { Light } }
