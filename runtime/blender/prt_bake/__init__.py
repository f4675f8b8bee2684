"""PRT Bake: precomputed radiance transfer in Blender, through the project's prt-bake.

Bakes the visible meshes (3D View > Sidebar > PRT, or bpy.ops.prt.bake), stores the
transfer per face corner as mesh attributes, and the relit colour as the colour attribute
"PRT"; scene.prt.light_rotation and bpy.ops.prt.relight turn the light without re-baking.
docs/guides/blender.md in the project describes it. Installs as a Blender 4.2+ extension
(blender_manifest.toml) or as a legacy add-on (bl_info) from the same zip.
"""

bl_info = {
    "name": "PRT Bake",
    "description": "Precomputed radiance transfer: bake with prt-bake, relight in the viewport",
    "author": "prt project",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "3D View > Sidebar > PRT",
    "category": "Lighting",
}

import bpy  # noqa: E402

from . import operators, panel, properties, relight  # noqa: E402

_classes = (properties.PrtSceneSettings, properties.PrtPreferences, *operators.classes,
            *panel.classes)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.prt = bpy.props.PointerProperty(type=properties.PrtSceneSettings)
    bpy.types.Object.prt_receive = bpy.props.BoolProperty(
        name="PRT receive", default=True, description="Bake this object's transfer (off: "
        "it only casts shadows and reflects light)")
    if relight.on_frame_change not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(relight.on_frame_change)


def unregister():
    if relight.on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(relight.on_frame_change)
    del bpy.types.Scene.prt
    del bpy.types.Object.prt_receive
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
