"""The add-on's settings: per scene (`scene.prt`) and in the preferences (prt-bake's path)."""

import bpy

from . import relight


def _rotation_changed(self, context):
    relight.relight_quietly(context.scene)


class PrtSceneSettings(bpy.types.PropertyGroup):
    order: bpy.props.IntProperty(name="Order", description="SH order n: n² coefficients "
                                 "per colour channel", default=4, min=1, max=8)
    samples: bpy.props.IntProperty(name="Rays", description="Rays per vertex",
                                   default=256, min=1, max=1 << 20)
    mode: bpy.props.EnumProperty(name="Mode", items=[
        ("shadowed", "Shadowed", "Direct light with shadows"),
        ("interreflected", "Interreflected", "Shadows and one bounce of coloured light"),
    ], default="shadowed")
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0)
    target: bpy.props.EnumProperty(name="Bake", items=[
        ("VERTEX", "Per vertex", "Transfer per face corner, \"PRT\" a colour attribute"),
        ("LIGHTMAP", "Lightmap", "Transfer per texel of each object's lightmap UVs, "
         "\"PRT <object>\" an image"),
    ], default="VERTEX")
    lightmap_resolution: bpy.props.IntProperty(name="Resolution", default=256, min=8,
                                               max=4096, description="Texels per side of "
                                               "each object's lightmap")
    lightmap_uv: bpy.props.StringProperty(name="UV map", default="", description="The "
                                          "lightmap's UV map (empty: the second, else the "
                                          "only one)")
    double_sided: bpy.props.EnumProperty(name="Double-sided", items=[
        ("off", "Off", "Every face's front only (Blender stores one transfer per corner)"),
        ("auto", "Auto", "Vertex bakes: prt-bake also bakes the back sheet of doubleSided "
         "materials (Backface Culling off); the add-on stores the fronts"),
    ], default="off")
    denoise: bpy.props.EnumProperty(name="Denoise", items=[
        ("auto", "Auto", "prt-bake's choice (off for vertex bakes)"),
        ("on", "On", "Denoise the transfer"), ("off", "Off", "No denoising"),
    ], default="auto")
    transfer: bpy.props.EnumProperty(name="Transfer", items=[
        ("AUTO", "Auto", "LDPRT where a receiver is deformed by an armature, else SH"),
        ("SH", "SH", "Spherical-harmonic transfer in world space (rigid meshes)"),
        ("LDPRT", "LDPRT", "Zonal lobes in each vertex's frame, which follow an armature's "
         "pose (every visible mesh receives; per vertex, order 4 at most)"),
    ], default="AUTO")
    lobes: bpy.props.IntProperty(name="Lobes", description="LDPRT: zonal lobes per vertex",
                                 default=3, min=1, max=8)
    ldprt_pose: bpy.props.EnumProperty(name="Pose", items=[
        ("REST", "Rest", "Bake the armatures' rest pose"),
        ("CURRENT", "Current", "Bake the pose at the current frame"),
    ], default="REST")
    rig_source: bpy.props.EnumProperty(name="Light", items=[
        ("FILE", "Rig file", "A prt-bake rig (TOML; docs/reference/lights.md)"),
        ("WORLD", "World", "The World: its uniform colour as a constant sky, or its "
         "equirectangular .hdr/.exr Environment Texture"),
    ], default="FILE")
    rig: bpy.props.StringProperty(name="Rig", subtype="FILE_PATH",
                                  description="A prt-bake rig file (.toml)")
    light_rotation: bpy.props.FloatProperty(
        name="Light rotation", description="The light turned about world Z (relights "
        "without re-baking)", subtype="ANGLE", unit="ROTATION", default=0.0,
        update=_rotation_changed)
    # Written by a bake: the order baked and the light (3 × n², unturned), as JSON.
    baked_order: bpy.props.IntProperty(default=0, options={"HIDDEN"})
    light_json: bpy.props.StringProperty(default="", options={"HIDDEN"})
    status: bpy.props.StringProperty(default="", options={"HIDDEN"})
    # The last bake: its warnings (a JSON list), wall time and prt-bake's summary (rays).
    last_warnings: bpy.props.StringProperty(default="[]", options={"HIDDEN"})
    last_time: bpy.props.FloatProperty(default=0.0, options={"HIDDEN"})
    last_summary: bpy.props.StringProperty(default="", options={"HIDDEN"})


class PrtPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    prt_bake: bpy.props.StringProperty(
        name="prt-bake", subtype="FILE_PATH",
        description="The prt-bake binary (empty: found on PATH)")

    def draw(self, context):
        self.layout.prop(self, "prt_bake")


def preferences(context):
    addon = context.preferences.addons.get(__package__)
    return addon.preferences.prt_bake if addon is not None else ""
