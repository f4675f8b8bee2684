"""The sidebar panel (3D View > Sidebar > PRT)."""

import json

import bpy


class PRT_PT_panel(bpy.types.Panel):
    bl_label = "PRT Bake"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "PRT"

    def draw(self, context):
        s = context.scene.prt
        layout = self.layout
        column = layout.column()
        column.prop(s, "order")
        column.prop(s, "samples")
        column.prop(s, "mode")
        column.prop(s, "seed")
        column.prop(s, "target")
        if s.target == "LIGHTMAP":
            column.prop(s, "lightmap_resolution")
            column.prop(s, "lightmap_uv")
        column.prop(s, "transfer")
        if s.transfer != "SH":
            column.prop(s, "lobes")
            column.prop(s, "ldprt_pose")
        column.prop(s, "double_sided")
        column.prop(s, "denoise")
        column.prop(s, "rig_source")
        if s.rig_source == "FILE":
            column.prop(s, "rig")
        obj = context.object
        if obj is not None and obj.type == "MESH":
            column.prop(obj, "prt_receive", text=f"{obj.name} receives")
        receivers = [o.name for o in context.view_layer.objects
                     if o.type == "MESH" and o.visible_get() and o.prt_receive]
        column.label(text=f"Receivers: {len(receivers)} ({', '.join(receivers[:4])}"
                     f"{', …' if len(receivers) > 4 else ''})")
        layout.operator("prt.bake", icon="RENDER_STILL")
        box = layout.box()
        box.prop(s, "light_rotation")
        row = box.row()
        row.operator("prt.relight").reproject = False
        row.operator("prt.relight", text="Re-read light").reproject = True
        row = box.row()
        row.operator("prt.preview_material", text="Show PRT").show = True
        row.operator("prt.preview_material", text="Hide").show = False
        if s.last_summary or s.last_time:
            last = layout.box()
            last.label(text=f"Last bake: {s.last_time:.1f} s")
            if s.last_summary:
                last.label(text=s.last_summary.split(" -> ")[0])
            warnings = json.loads(s.last_warnings or "[]")
            for warning in warnings:
                last.label(text=warning, icon="ERROR")
            if not warnings:
                last.label(text="No warnings")
        if s.status:
            layout.label(text=s.status, icon="ERROR")


classes = (PRT_PT_panel,)
