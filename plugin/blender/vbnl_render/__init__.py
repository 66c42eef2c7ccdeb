# SPDX-License-Identifier: GPL-2.0-or-later
"""vbnl as a Blender render engine.

The engine reuses Blender's own POV-Ray add-on (render_povray, shipped with Blender) for the
export and the hand-over: the add-on writes the scene as POV-Ray SDL and an .ini file, runs the
binary, reads its progress lines and loads the image. vbnl reads POV-Ray's command line
(docs/povray-command-line.md). This engine adds what that exporter drops:

- the lamps' power: the exporter writes a lamp's colour only. Here every lamp is written with
  POV-Ray's fade_power 2 and a fade_distance F far below any distance in the scene, which makes
  the light fall off as I / d^2 with I = 2 pi F^2 times its colour (POV-Ray's colour c lights a
  white diffuse surface as the irradiance pi c does a Lambertian: docs/scene-language.md,
  "Lights"); the colour is chosen so that I is Cycles' radiant
  intensity: P / (4 pi) for point and spot lamps of P watts, P / 8 for area lamps (the on-axis
  intensity of Cycles' one-sided area lamp is P / 4, vbnl's area light is a two-sided rectangle),
  and a sun's strength as the irradiance (pi times the colour) of a parallel light;
- node materials: the exporter writes an empty texture for them. A material whose output is a
  Principled BSDF is written, through the exporter's "replacement text", as its base colour,
  metallic, roughness and emission: Lambertian, GGX plastic or GGX conductor (vbnl's mapping of
  POV-Ray's finishes, roughness alpha = roughness^2);
- vbnl's own settings: the integrator, samples per pixel or a time budget, and any other options
  of `vbnl render`.

Install: copy the folder vbnl_render into Blender's add-on folder (or Preferences > Add-ons >
Install the zipped folder), enable "Render: vbnl", set its "vbnl binary" preference (default: vbnl
on PATH), choose "vbnl" as the render engine."""

import math
import shutil
from contextlib import contextmanager

import addon_utils
import bpy

bl_info = {
    "name": "vbnl",
    "author": "vbnl authors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Render Properties > Render Engine > vbnl",
    "description": "Render with vbnl (Virtual Blue Noise Lighting) through Blender's POV-Ray exporter",
    "category": "Render",
}

# A fade distance far below any distance in a scene: the fade 2 / (1 + (d/F)^2) is then 2 F^2 / d^2
# within 1e-6 for every d of a scene unit or more (vbnl evaluates it at 1 unit at least).
FADE = 1e-3

INTEGRATORS = [
    ("vbnl", "vbnl", "Virtual Blue Noise Lighting (Li et al. 2022)"),
    ("path", "path", "unidirectional path tracing: the unbiased reference"),
    ("vpl", "vpl", "instant radiosity (virtual point lights)"),
    ("vsl", "vsl", "virtual spherical lights"),
    ("richvsl", "richvsl", "Rich-VPLs / Rich-VSLs"),
    ("SCENE", "the scene's", "the integrator the scene names (vbnl by default)"),
]


class VbnlPreferences(bpy.types.AddonPreferences):
    bl_idname = __name__

    binary: bpy.props.StringProperty(
        name="vbnl binary", subtype="FILE_PATH", default="",
        description="The vbnl executable (empty: vbnl on PATH)")

    def draw(self, context):
        self.layout.prop(self, "binary")


class VbnlSettings(bpy.types.PropertyGroup):
    integrator: bpy.props.EnumProperty(name="Integrator", items=INTEGRATORS, default="vbnl")
    use_time: bpy.props.BoolProperty(name="Time budget", default=False,
                                     description="Render for a time budget instead of a sample count")
    spp: bpy.props.IntProperty(name="Samples", default=64, min=1, max=1 << 20,
                               description="Samples per pixel")
    time: bpy.props.FloatProperty(name="Seconds", default=30.0, min=0.1, max=1e6,
                                  description="Preparation and rendering time (vbnl sizes its lights to it)")
    switches: bpy.props.StringProperty(name="Options", default="",
                                       description="Other options of `vbnl render` (e.g. --seed 3 --set clamp=10)")


def vbnl_binary():
    prefs = bpy.context.preferences.addons[__name__].preferences
    return bpy.path.abspath(prefs.binary) if prefs.binary else (shutil.which("vbnl") or "")


def switches(settings):
    s = []
    if settings.integrator != "SCENE":
        s += ["--integrator", settings.integrator]
    s += ["--time", "%g" % settings.time] if settings.use_time else ["--spp", str(settings.spp)]
    if settings.switches.strip():
        s.append(settings.switches.strip())
    return " ".join(s)


# ---- lamps -------------------------------------------------------------------------------------

def lamp_intensity(light):
    """The lamp's light in the exported SDL: radiant intensity per colour channel (W/sr), or the
    irradiance (W/m^2) of a sun."""
    if light.type == "SUN":
        scale = light.energy
    elif light.type == "AREA":
        scale = light.energy / 8.0
    else:
        scale = light.energy / (4.0 * math.pi)
    return [c * scale for c in light.color]


def export_lights(lamps, file, scene, global_matrix, tab_write):
    """Replaces the exporter's export_lights (same arguments): lamps with their power."""
    from render_povray.render import write_matrix
    for ob in lamps:
        light = ob.data
        values = lamp_intensity(light)
        tab_write(file, "light_source {\n")
        tab_write(file, "< 0,0,0 >\n")
        if light.type == "SUN":
            tab_write(file, "color rgb<%.6g, %.6g, %.6g>\n" % tuple(v / math.pi for v in values))
            tab_write(file, "parallel\npoint_at <0, 0, -1>\n")
        else:
            c = [v / (2.0 * math.pi * FADE * FADE) for v in values]
            tab_write(file, "color rgb<%.6g, %.6g, %.6g>\n" % tuple(c))
            tab_write(file, "fade_distance %g\nfade_power 2\n" % FADE)
            if light.type == "SPOT":
                half = math.degrees(light.spot_size) / 2.0
                tab_write(file, "spotlight\nfalloff %.4f\nradius %.4f\ntightness 0\npoint_at <0, 0, -1>\n"
                          % (half, half * (1.0 - light.spot_blend)))
            elif light.type == "AREA":
                sx = light.size
                sy = light.size if light.shape in {"SQUARE", "DISK"} else light.size_y
                tab_write(file, "area_light <%.6f, 0, 0>, <0, %.6f, 0>, 2, 2\n" % (sx, sy))
        if not light.use_shadow:
            tab_write(file, "shadowless\n")
        write_matrix(file, global_matrix @ ob.matrix_world)
        tab_write(file, "}\n")


# ---- materials ---------------------------------------------------------------------------------

def principled(material):
    """The Principled BSDF that feeds the material's output, or None."""
    if not material.use_nodes or not material.node_tree:
        return None
    out = next((n for n in material.node_tree.nodes
                if n.bl_idname == "ShaderNodeOutputMaterial" and n.is_active_output), None)
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    node = out.inputs["Surface"].links[0].from_node
    return node if node.bl_idname == "ShaderNodeBsdfPrincipled" else None


def pov_roughness(alpha):
    """POV-Ray's `roughness` that vbnl turns into the GGX alpha given: vbnl takes the exponent
    1/roughness to alpha = sqrt(2 / (n + 2)) (docs/scene-language.md, finishes)."""
    n = 2.0 / (alpha * alpha) - 2.0
    return 1.0 / n if n > 0 else None


def texture_text(node):
    """A POV-Ray texture body for a Principled BSDF's constant inputs."""
    base = list(node.inputs["Base Color"].default_value)[:3]
    metallic = node.inputs["Metallic"].default_value
    alpha = max(node.inputs["Roughness"].default_value, 0.0) ** 2
    specular = node.inputs["Specular"].default_value
    strength = node.inputs["Emission Strength"].default_value
    emission = [e * strength for e in list(node.inputs["Emission"].default_value)[:3]]
    finish = []
    rough = pov_roughness(max(alpha, 1e-3))
    if metallic >= 0.5 and rough is not None:
        finish += ["diffuse 0", "specular 1", "roughness %.6g" % rough, "metallic"]
    elif specular > 0.0 and rough is not None and alpha < 0.9:
        finish += ["diffuse 1", "specular %.4g" % specular, "roughness %.6g" % rough]
    else:
        finish += ["diffuse 1"]
    if any(e > 0.0 for e in emission):
        # POV-Ray's emission is multiplied by the pigment
        finish.append("emission rgb <%s>" % ", ".join("%.6g" % (e / max(b, 1e-4)) for e, b in zip(emission, base)))
    return "pigment { rgb <%.6g, %.6g, %.6g> } finish { %s }" % (*base, " ".join(finish))


@contextmanager
def exported_as_vbnl(scene):
    """The exporter's inputs for the time of one render: node materials as replacement text, the
    lamps with their power, vbnl as the binary with its options. Everything is restored."""
    import render_povray.scenography as scenography
    saved = []
    for m in bpy.data.materials:
        node = principled(m)
        if node is not None:
            saved.append((m, m.use_nodes, m.pov.replacement_text))
            m.pov.replacement_text = texture_text(node)
            m.use_nodes = False
    prefs = bpy.context.preferences.addons["render_povray"].preferences
    old_binary, old_switches = prefs.filepath_povray, scene.pov.command_line_switches
    old_lights = scenography.export_lights
    prefs.filepath_povray = vbnl_binary()
    scene.pov.command_line_switches = switches(scene.vbnl)
    scenography.export_lights = export_lights
    try:
        yield
    finally:
        scenography.export_lights = old_lights
        prefs.filepath_povray = old_binary
        scene.pov.command_line_switches = old_switches
        for m, use_nodes, text in saved:
            m.use_nodes = use_nodes
            m.pov.replacement_text = text


def engine_class():
    from render_povray.render_core import PovRender

    class VbnlRender(PovRender):
        """vbnl through Blender's POV-Ray exporter."""
        bl_idname = "VBNL_RENDER"
        bl_label = "vbnl"

        def render(self, depsgraph):
            if not vbnl_binary():
                self.report({"ERROR"}, "vbnl: set the add-on's 'vbnl binary' preference (no vbnl on PATH)")
                return
            with exported_as_vbnl(bpy.context.scene):
                super().render(depsgraph)

    return VbnlRender


class VBNL_PT_render(bpy.types.Panel):
    bl_label = "vbnl"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    @classmethod
    def poll(cls, context):
        return context.engine == "VBNL_RENDER"

    def draw(self, context):
        s = context.scene.vbnl
        layout = self.layout
        layout.prop(s, "integrator")
        layout.prop(s, "use_time")
        layout.prop(s, "time" if s.use_time else "spp")
        layout.prop(s, "switches")


_classes = []


def _panels_with(engine):
    """Blender's and the POV-Ray add-on's panels that show for `engine`."""
    for name in dir(bpy.types):
        cls = getattr(bpy.types, name, None)
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if isinstance(engines, set) and engine in engines:
            yield cls


def register():
    addon_utils.enable("render_povray", default_set=True)
    engine = engine_class()
    for cls in (VbnlPreferences, VbnlSettings, engine, VBNL_PT_render):
        bpy.utils.register_class(cls)
        _classes.append(cls)
    bpy.types.Scene.vbnl = bpy.props.PointerProperty(type=VbnlSettings)
    for panel in _panels_with("POVRAY_RENDER"):
        panel.COMPAT_ENGINES.add("VBNL_RENDER")


def unregister():
    for panel in _panels_with("VBNL_RENDER"):
        panel.COMPAT_ENGINES.discard("VBNL_RENDER")
    del bpy.types.Scene.vbnl
    while _classes:
        bpy.utils.unregister_class(_classes.pop())
