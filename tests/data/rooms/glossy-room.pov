// A room whose floor is a near-mirror plastic (GGX alpha 0.002 over a diffuse base), with a
// mirror-like metal sphere and glossy boxes (alpha 0.14 and 0.30), lit by a two-sided light panel
// hung 1 cm below the ceiling. A bias test scene (tests/vbnl/test_bias.c). Valid POV-Ray 3.7.
// Written for vbnl; CC0.
#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 1.3, -2.7> look_at <0, 0.9, 0> right x*image_width/image_height angle 70 }
#default { finish { ambient 0 diffuse 1 } }
#declare White = texture { pigment { rgb 0.7 } }
#declare Light = texture { pigment { rgb <18, 17, 15> } finish { emission 1 diffuse 0 } }
box { <-2, -0.05, -3>, <2, 0, 2> pigment { rgb <0.5, 0.45, 0.4> } finish { diffuse 1 specular 1 roughness 0.000002 } }
box { <-2, 2.5, -3>, <2, 2.55, 2> texture { White } }
box { <-2.05, 0, -3>, <-2, 2.5, 2> pigment { rgb <0.7, 0.2, 0.15> } }
box { <2, 0, -3>, <2.05, 2.5, 2> pigment { rgb <0.2, 0.6, 0.25> } }
box { <-2, 0, 2>, <2, 2.5, 2.05> texture { White } }
box { <-2, 0, -3.05>, <2, 2.5, -3> texture { White } }
sphere { <-0.7, 0.45, 0.4>, 0.45 pigment { rgb <0.95, 0.93, 0.88> } finish { diffuse 0 specular 1 roughness 0.0001 metallic reflection 1 } }
box { <0.3, 0, -0.2>, <1.1, 0.8, 0.6> rotate y*20 pigment { rgb <0.3, 0.4, 0.7> } finish { diffuse 1 specular 0.8 roughness 0.01 } }
box { <-1.6, 0, 1.0>, <-1.0, 1.4, 1.6> pigment { rgb <0.75, 0.7, 0.5> } finish { diffuse 1 specular 0.6 roughness 0.05 } }
mesh { triangle { <-0.6, 2.49, -0.8>, <0.6, 2.49, 0.2>, <-0.6, 2.49, 0.2> }
       triangle { <-0.6, 2.49, -0.8>, <0.6, 2.49, -0.8>, <0.6, 2.49, 0.2> } texture { Light } }
