"""The sidebar panel (3D View > Sidebar > PRT)."""

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
        column.prop(s, "rig_source")
        if s.rig_source == "FILE":
            column.prop(s, "rig")
        layout.operator("prt.bake", icon="RENDER_STILL")
        box = layout.box()
        box.prop(s, "light_rotation")
        row = box.row()
        row.operator("prt.relight").reproject = False
        row.operator("prt.relight", text="Re-read light").reproject = True
        row = box.row()
        row.operator("prt.preview_material", text="Show PRT").show = True
        row.operator("prt.preview_material", text="Hide").show = False
        if s.status:
            layout.label(text=s.status, icon="ERROR")


classes = (PRT_PT_panel,)
