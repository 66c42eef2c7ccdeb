// A closed all-diffuse room (3 x 2.4 x 4, a block inside) lit by a two-sided light panel hung
// 1 cm below the ceiling: the light it sends upward is trapped in the gap. A bias test scene
// (tests/vbnl/test_bias.c): vbnl's image mean must match path tracing. Valid POV-Ray 3.7.
// Written for vbnl; CC0.
#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 1.2, -1.9> look_at <0, 1.0, 0> right x * image_width / image_height angle 75 }
#default { finish { ambient 0 diffuse 1 } }
#declare White = texture { pigment { rgb 0.7 } }
#declare Light = texture { pigment { rgb <20, 19, 17> } finish { emission 1 diffuse 0 } }
box { <-1.5, -0.05, -2>, <1.5, 0, 2> texture { White } }
box { <-1.5, 2.4, -2>, <1.5, 2.45, 2> texture { White } }
box { <-1.55, 0, -2>, <-1.5, 2.4, 2> pigment { rgb <0.7, 0.25, 0.2> } }
box { <1.5, 0, -2>, <1.55, 2.4, 2> pigment { rgb <0.25, 0.6, 0.3> } }
box { <-1.5, 0, 2>, <1.5, 2.4, 2.05> texture { White } }
box { <-1.5, 0, -2.05>, <1.5, 2.4, -2> texture { White } }
box { <-0.2, 0, 0.3>, <0.6, 0.9, 1.1> rotate y * 25 texture { White } }
mesh {
  triangle { <-0.4, 2.39, -0.3>, <0.4, 2.39, 0.3>, <-0.4, 2.39, 0.3> }
  triangle { <-0.4, 2.39, -0.3>, <0.4, 2.39, -0.3>, <0.4, 2.39, 0.3> }
  texture { Light } }
