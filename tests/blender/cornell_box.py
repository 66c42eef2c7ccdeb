"""A small Cornell box built in Blender, rendered with Cycles and with Blender's POV-Ray add-on
(render_povray) pointed at vbnl. Run by tests/blender/test_blender.sh:

    blender -b --factory-startup --python cornell_box.py -- VBNL OUTDIR SIZE SWITCHES LAMP [ADDON]

LAMP is "point" or "area". Writes OUTDIR/cycles-LAMP.png, OUTDIR/povray-LAMP.png (the add-on's
render result, saved by Blender through the same Standard view) and OUTDIR/times-LAMP.txt (seconds
from the render call to the image, per engine). The box is 2 units wide with Lambertian walls
(white 0.8, red, green) and the add-on's default phong 0.1 on every material.

With ADDON (the folder holding vbnl_render, plugin/blender), the box is rendered a third time with
vbnl's own Blender engine into OUTDIR/vbnl-LAMP.png, from what a Blender user makes: Principled
BSDF node materials (roughness 1, no specular: Lambertian in both renderers) and a lamp of a
power in watts (40 W point, 15 W area; Blender's defaults, 1000 W and 100 W, saturate this small
box), no calibration.

The exporter writes a lamp's colour only, never its power, and a fade: a point lamp gets
fade_distance sqrt(distance / 2), an area lamp distance / 2, with fade_power 2. vbnl gives such a
light the radiant intensity I = pi * colour * a(D) * D^2, with POV-Ray's fade a(D) = 2 / (1 + (D /
fade_distance)^2) at the distance D from the light to the centre of the geometry, at least 1
(docs/scene-language.md, "Lights"), and makes an area lamp a two-sided Lambertian rectangle of the
point light's power 4 pi I. The lamp's power in Cycles is set to the same light: a point lamp of P
watts has the intensity P / (4 pi) in Cycles, so P = 4 pi I; a one-sided area lamp sends P pi / 4
watts down (measured: on-axis intensity P / 4), the half of vbnl's rectangle that faces down 2 pi I,
so P = 8 I (vbnl's upward half lights the ceiling in addition)."""
import math
import os
import sys
import time

import addon_utils
import bpy

args = sys.argv[sys.argv.index("--") + 1:]
VBNL, OUT = args[0], args[1]
SIZE, SWITCHES, LAMP = int(args[2]), args[3], args[4]
ADDON = args[5] if len(args) > 5 else None

bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("render_povray", default_set=True)
scene = bpy.context.scene


def material(name, rgb):
    m = bpy.data.materials.new(name)
    m.use_nodes = False  # the exporter writes the diffuse colour; Cycles renders it as a diffuse BSDF
    m.diffuse_color = (*rgb, 1.0)
    m.specular_intensity = 0.0
    m.roughness = 1.0
    # the add-on's POV-Ray material settings: its "diffuse" defaults to 0.8, which would darken
    # POV-Ray's surface to 0.8 times the colour that Cycles reflects; its phong 0.1 stays
    m.pov.diffuse_intensity = 1.0
    return m


def quad(name, corners, mat):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(corners, [], [(0, 1, 2, 3)])
    mesh.materials.append(mat)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


white, red, green = material("White", (0.8, 0.8, 0.8)), material("Red", (0.7, 0.1, 0.1)), material("Green", (0.1, 0.6, 0.1))
# the box: x in [-1, 1], y in [-1, 1] (the open side at y = -1), z in [0, 2]
quad("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white)
quad("Ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white)
quad("Back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white)
quad("Left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red)
quad("Right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], green)
bpy.ops.mesh.primitive_cube_add(size=0.6, location=(0.35, 0.3, 0.3))
bpy.context.object.data.materials.append(white)
bpy.context.object.rotation_euler = (0, 0, 0.3)

light = bpy.data.lights.new("Lamp", 'POINT' if LAMP == "point" else 'AREA')
light.color = (1.0, 1.0, 1.0)
if LAMP == "point":
    light.shadow_soft_size = 0.0
else:
    light.size = 0.5
lamp = bpy.data.objects.new("Lamp", light)
lamp.location = (0.0, 0.0, 1.8 if LAMP == "point" else 1.95)  # an area lamp faces down (-z)
scene.collection.objects.link(lamp)
fade = math.sqrt(light.distance / 2.0) if LAMP == "point" else light.distance / 2.0  # what the exporter writes
centre = (0.0, 0.0, 1.0)                           # the geometry's bounding box centre
D = max(1.0, math.dist(lamp.location, centre))
intensity = math.pi * 2.0 / (1.0 + (D / fade) ** 2) * D * D  # vbnl's radiant intensity of the exported light
light.energy = 4.0 * math.pi * intensity if LAMP == "point" else 8.0 * intensity

cam = bpy.data.cameras.new("Camera")
cam.lens = 35.0
cam_obj = bpy.data.objects.new("Camera", cam)
cam_obj.location = (0.0, -3.6, 1.0)
cam_obj.rotation_euler = (math.pi / 2, 0.0, 0.0)
scene.collection.objects.link(cam_obj)
scene.camera = cam_obj

r = scene.render
r.resolution_x = r.resolution_y = SIZE
r.resolution_percentage = 100
r.image_settings.file_format = 'PNG'
r.image_settings.color_mode = 'RGBA'
r.image_settings.color_depth = '8'
scene.view_settings.view_transform = 'Standard'
scene.view_settings.look = 'None'
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
# Blender's default world colour (0.05 grey) in both: Cycles' world and the exporter's background
scene.world = bpy.data.worlds.new("World")
scene.world.pov.horizon_color = scene.world.color

times = {}


def render(engine, path):
    r.engine = engine
    r.filepath = path
    start = time.monotonic()
    bpy.ops.render.render(write_still=True)
    times[engine] = time.monotonic() - start


scene.cycles.samples = 256
scene.cycles.use_denoising = False
scene.cycles.device = 'CPU'
# every bounce and no clamping: the converged image vbnl's global illumination is compared with
scene.cycles.max_bounces = scene.cycles.diffuse_bounces = 64
scene.cycles.sample_clamp_direct = scene.cycles.sample_clamp_indirect = 0.0
render('CYCLES', os.path.join(OUT, f"cycles-{LAMP}.png"))

prefs = bpy.context.preferences.addons["render_povray"].preferences
prefs.filepath_povray = VBNL
scene.pov.command_line_switches = SWITCHES
scene.pov.tempfiles_enable = True
render('POVRAY_RENDER', os.path.join(OUT, f"povray-{LAMP}.png"))

if ADDON:
    sys.path.insert(0, ADDON)
    import vbnl_render
    vbnl_render.register()
    bpy.context.preferences.addons.new().module = "vbnl_render"  # its preferences, as when enabled
    bpy.context.preferences.addons["vbnl_render"].preferences.binary = VBNL
    # what a user makes: Principled BSDF materials of the same colours, Blender's default power
    for m in (white, red, green):
        m.use_nodes = True
        bsdf = m.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = m.diffuse_color
        bsdf.inputs["Roughness"].default_value = 1.0
        bsdf.inputs["Specular"].default_value = 0.0
    light.energy = 40.0 if LAMP == "point" else 15.0
    scene.vbnl.integrator = "vbnl"
    scene.vbnl.spp = 32
    scene.vbnl.switches = "--seed 5"
    render('VBNL_RENDER', os.path.join(OUT, f"vbnl-{LAMP}.png"))
    render('CYCLES', os.path.join(OUT, f"cycles-nodes-{LAMP}.png"))

with open(os.path.join(OUT, f"times-{LAMP}.txt"), "w") as f:
    for engine, seconds in times.items():
        f.write(f"{engine} {seconds:.2f}\n")
print("cornell_box.py: light %.2f W, fade_distance %.3f, D %.3f" % (light.energy, fade, D))
