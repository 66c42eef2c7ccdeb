// Cornell box: the Cornell University measurements scaled to about 2 units (floor at y = 0,
// open side toward -z, red wall on the left), with Bitterli's published reflectances (red
// 0.63 0.065 0.05, green 0.14 0.45 0.091, white 0.725 0.71 0.68) and light radiance 17 12 4.
// Same geometry as cornell-box.obj, mirrored in z into POV-Ray's left-handed coordinates.
// Valid POV-Ray 3.7: the integrator block is guarded. Written for vbnl; CC0.
#version 3.7;

#ifdef (vbnl_version)
global_settings { integrator { "vbnl" } }
#else
global_settings { assumed_gamma 1.0 radiosity { count 200 recursion_limit 3 nearest_count 10 error_bound 0.5 } }
#end

// The classic camera: 800 mm in front of the box, 39.3 degree field of view (square image).
camera {
  perspective
  location <0, 0.98195, -3.88317>
  look_at <0, 0.98195, 0>
  right x * image_width / image_height
  angle 39.3
}

#default { finish { ambient 0 diffuse 1 } }
#declare White = texture { pigment { rgb <0.725, 0.71, 0.68> } }
#declare Red = texture { pigment { rgb <0.63, 0.065, 0.05> } }
#declare Green = texture { pigment { rgb <0.14, 0.45, 0.091> } }
#declare Light = texture { pigment { rgb <17, 12, 4> } finish { emission 1 diffuse 0 } }

// floor
mesh { triangle { <-0.98849, 0.00000, -1.00576>, <1.00000, 0.00000, -1.00576>, <1.00000, 0.00000, 1.00576> } triangle { <-0.98849, 0.00000, -1.00576>, <1.00000, 0.00000, 1.00576>, <-0.97698, 0.00000, 1.00576> } texture { White } }
// ceiling
mesh { triangle { <-1.00000, 1.97410, -1.00576>, <-1.00000, 1.97410, 1.00576>, <1.00000, 1.97410, 1.00576> } triangle { <-1.00000, 1.97410, -1.00576>, <1.00000, 1.97410, 1.00576>, <1.00000, 1.97410, -1.00576> } texture { White } }
// back wall
mesh { triangle { <-0.97698, 0.00000, 1.00576>, <1.00000, 0.00000, 1.00576>, <1.00000, 1.97410, 1.00576> } triangle { <-0.97698, 0.00000, 1.00576>, <1.00000, 1.97410, 1.00576>, <-1.00000, 1.97410, 1.00576> } texture { White } }
// right wall (green)
mesh { triangle { <1.00000, 0.00000, 1.00576>, <1.00000, 0.00000, -1.00576>, <1.00000, 1.97410, -1.00576> } triangle { <1.00000, 0.00000, 1.00576>, <1.00000, 1.97410, -1.00576>, <1.00000, 1.97410, 1.00576> } texture { Green } }
// left wall (red)
mesh { triangle { <-0.98849, 0.00000, -1.00576>, <-0.97698, 0.00000, 1.00576>, <-1.00000, 1.97410, 1.00576> } triangle { <-0.98849, 0.00000, -1.00576>, <-1.00000, 1.97410, 1.00576>, <-1.00000, 1.97410, -1.00576> } texture { Red } }
// light
// (wound so that its geometric normal faces down, for renderers with one-sided emitters)
mesh { triangle { <-0.23381, 1.97374, -0.18921>, <0.23381, 1.97374, 0.18849>, <-0.23381, 1.97374, 0.18849> } triangle { <-0.23381, 1.97374, -0.18921>, <0.23381, 1.97374, -0.18921>, <0.23381, 1.97374, 0.18849> } texture { Light } }
// short block
mesh { triangle { <0.53237, 0.59353, -0.77194>, <0.70504, 0.59353, -0.19640>, <0.13669, 0.59353, -0.02734> } triangle { <0.53237, 0.59353, -0.77194>, <0.13669, 0.59353, -0.02734>, <-0.04317, 0.59353, -0.59568> } texture { White } }
mesh { triangle { <0.53237, 0.00000, -0.77194>, <0.70504, 0.00000, -0.19640>, <0.70504, 0.59353, -0.19640> } triangle { <0.53237, 0.00000, -0.77194>, <0.70504, 0.59353, -0.19640>, <0.53237, 0.59353, -0.77194> } texture { White } }
mesh { triangle { <0.70504, 0.00000, -0.19640>, <0.13669, 0.00000, -0.02734>, <0.13669, 0.59353, -0.02734> } triangle { <0.70504, 0.00000, -0.19640>, <0.13669, 0.59353, -0.02734>, <0.70504, 0.59353, -0.19640> } texture { White } }
mesh { triangle { <0.13669, 0.00000, -0.02734>, <-0.04317, 0.00000, -0.59568>, <-0.04317, 0.59353, -0.59568> } triangle { <0.13669, 0.00000, -0.02734>, <-0.04317, 0.59353, -0.59568>, <0.13669, 0.59353, -0.02734> } texture { White } }
mesh { triangle { <-0.04317, 0.00000, -0.59568>, <0.53237, 0.00000, -0.77194>, <0.53237, 0.59353, -0.77194> } triangle { <-0.04317, 0.00000, -0.59568>, <0.53237, 0.59353, -0.77194>, <-0.04317, 0.59353, -0.59568> } texture { White } }
// tall block
mesh { triangle { <-0.52158, 1.18705, -0.11727>, <0.04676, 1.18705, 0.05899>, <-0.12950, 1.18705, 0.63453> } triangle { <-0.52158, 1.18705, -0.11727>, <-0.12950, 1.18705, 0.63453>, <-0.69784, 1.18705, 0.45468> } texture { White } }
mesh { triangle { <-0.52158, 0.00000, -0.11727>, <0.04676, 0.00000, 0.05899>, <0.04676, 1.18705, 0.05899> } triangle { <-0.52158, 0.00000, -0.11727>, <0.04676, 1.18705, 0.05899>, <-0.52158, 1.18705, -0.11727> } texture { White } }
mesh { triangle { <0.04676, 0.00000, 0.05899>, <-0.12950, 0.00000, 0.63453>, <-0.12950, 1.18705, 0.63453> } triangle { <0.04676, 0.00000, 0.05899>, <-0.12950, 1.18705, 0.63453>, <0.04676, 1.18705, 0.05899> } texture { White } }
mesh { triangle { <-0.12950, 0.00000, 0.63453>, <-0.69784, 0.00000, 0.45468>, <-0.69784, 1.18705, 0.45468> } triangle { <-0.12950, 0.00000, 0.63453>, <-0.69784, 1.18705, 0.45468>, <-0.12950, 1.18705, 0.63453> } texture { White } }
mesh { triangle { <-0.69784, 0.00000, 0.45468>, <-0.52158, 0.00000, -0.11727>, <-0.52158, 1.18705, -0.11727> } triangle { <-0.69784, 0.00000, 0.45468>, <-0.52158, 1.18705, -0.11727>, <-0.69784, 1.18705, 0.45468> } texture { White } }
