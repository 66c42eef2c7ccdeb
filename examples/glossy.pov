// Glossy scene: a glossy floor, metal spheres of increasing roughness (front row) and plastic
// spheres of increasing roughness (back row), lit by a rectangular area light and a dim sky.
// The finishes use POV-Ray's specular, roughness, metallic and reflection so that the texture
// layer's physically based mapping applies. Valid POV-Ray 3.7. Written for vbnl; CC0.
#version 3.7;

#ifdef (vbnl_version)
global_settings { integrator { "vbnl" } }
#else
global_settings { assumed_gamma 1.0 radiosity { count 200 recursion_limit 2 } }
#end

camera {
  location <0, 2.2, -6.5>
  look_at <0, 0.6, 0>
  right x * image_width / image_height
  angle 50
}

background { rgb <0.05, 0.06, 0.08> }
// fade_power 2: POV-Ray's fade; vbnl falls off as 1/d^2 with POV-Ray's brightness at the scene's centre
light_source { <-2, 6, -3>, rgb 1 fade_distance 4 fade_power 2
  area_light <2, 0, 0>, <0, 0, 2>, 5, 5 adaptive 1 jitter }

#default { finish { ambient 0 diffuse 1 } }

// Glossy floor (dark plastic with a sharp coat).
plane { y, 0
  pigment { rgb <0.3, 0.3, 0.32> }
  finish { diffuse 0.8 specular 0.6 roughness 0.002 reflection { 0.1 } } }

// Front row: gold-coloured metal, roughness from mirror-like to rough.
#declare Roughness = array[4] { 0.0005, 0.005, 0.02, 0.08 }
#for (I, 0, 3)
  sphere { <-2.4 + 1.6 * I, 0.6, -0.8>, 0.6
    pigment { rgb <1.0, 0.78, 0.34> }
    finish { diffuse 0 specular 1 roughness Roughness[I] metallic 1 reflection { 0.8 metallic } } }
#end
// Back row: red plastic with the same roughness steps.
#for (I, 0, 3)
  sphere { <-2.4 + 1.6 * I, 0.6, 1.0>, 0.6
    pigment { rgb <0.7, 0.08, 0.06> }
    finish { diffuse 0.9 specular 0.5 roughness Roughness[I] } }
#end
