"""The operators: prt.bake (in the background with a progress bar, Esc cancels; run
synchronously when called from a script), prt.relight, prt.preview_material.

Every failure is reported through Blender's report system (self.report), never raised.
"""

import json
import shutil
import tempfile
import time

import bpy

from . import export, ldprt, light, relight
from .bake_job import BakeJob, BakeSettings
from .errors import PrtError
from .lightmap_images import RELIT, store_lightmap, texel_materials, transfer_images
from .process import find_prt_bake
from .properties import preferences
from .results import baked_meshes, clear_transfer, store_transfer
from .scene_mesh import lightmap_layer

PREVIEW_MATERIAL = "PRT Relit"


def _project_light(context, executable, settings, order, rig):
    if settings.rig_source == "WORLD" and not rig:
        return light.project_world(executable, context.scene.world, order)
    path = bpy.path.abspath(rig or settings.rig)
    if not path:
        raise PrtError("no rig file chosen (PRT panel > Rig), and the light is not the World")
    return light.project(executable, path, order)


def _clear_stale(context, job):
    """A vertex bake's earlier results on visible meshes that no longer receive (PRT receive
    off) are removed, so relighting does not show them as if baked with this scene; named."""
    if job.settings.lightmap:
        return []
    baked = {r.obj.data for r in job.plan.receivers}
    out = []
    for obj in context.view_layer.objects:
        if obj.type == "MESH" and obj.visible_get() and obj.data not in baked \
                and clear_transfer(obj.data):
            baked.add(obj.data)
            out.append(f"{obj.name}: not baked this time, its earlier PRT results removed")
    return out


class PRT_OT_bake(bpy.types.Operator):
    """Bake the visible meshes' transfer with prt-bake and relight them into "PRT\""""

    bl_idname = "prt.bake"
    bl_label = "Bake PRT"
    bl_options = {"REGISTER", "UNDO"}  # one undo step for what a bake adds

    samples: bpy.props.IntProperty(name="Rays", default=0, min=0,
                                   description="Rays per vertex (0: the scene's setting)")
    order: bpy.props.IntProperty(name="Order", default=0, min=0, max=8,
                                 description="SH order (0: the scene's setting)")
    mode: bpy.props.StringProperty(name="Mode", default="",
                                   description="shadowed or interreflected (empty: the scene's)")
    rig: bpy.props.StringProperty(name="Rig", default="", subtype="FILE_PATH",
                                  description="A rig file (empty: the scene's light)")
    seed: bpy.props.IntProperty(name="Seed", default=-1, min=-1)
    threads: bpy.props.IntProperty(name="Threads", default=0, min=0)
    lightmap: bpy.props.IntProperty(
        name="Lightmap", default=-1, min=-1, description="Texels per side of each object's "
        "lightmap; 0: per vertex; -1: the scene's setting")

    transfer: bpy.props.StringProperty(
        name="Transfer", default="", description="AUTO, SH or LDPRT (empty: the scene's)")
    lobes: bpy.props.IntProperty(name="Lobes", default=0, min=0, max=8,
                                 description="LDPRT lobes per vertex (0: the scene's)")
    pose: bpy.props.StringProperty(name="Pose", default="",
                                   description="LDPRT: REST or CURRENT (empty: the scene's)")

    _job = None
    _timer = None

    def _lightmap(self, s):
        if self.lightmap >= 0:
            return self.lightmap
        return s.lightmap_resolution if s.target == "LIGHTMAP" else 0

    def _prepare(self, context):
        s = context.scene.prt
        settings = BakeSettings(order=self.order or s.order, samples=self.samples or s.samples,
                                mode=self.mode or s.mode,
                                seed=s.seed if self.seed < 0 else self.seed,
                                threads=self.threads,
                                lightmap=self._lightmap(s), lightmap_uv=s.lightmap_uv,
                                double_sided=s.double_sided, denoise=s.denoise)
        if settings.mode not in ("shadowed", "interreflected"):
            raise PrtError(f"unknown mode {settings.mode!r} (shadowed or interreflected)")
        self._ldprt_settings(context, settings)
        executable = find_prt_bake(preferences(context))
        self._light = _project_light(context, executable, s, settings.order, self.rig)
        self._started = time.time()
        if settings.lightmap and settings.double_sided == "auto":
            # A back sheet would need texels of its own beside the object's tile.
            self.report({"WARNING"}, "Double-sided auto applies to vertex bakes: this "
                        "lightmap bake bakes fronts only")
            settings.double_sided = "off"
        folder = tempfile.mkdtemp(prefix="prt-bake-")
        try:
            path = f"{folder}/scene.glb"
            if settings.transfer == "ldprt":
                current = settings.pose == "CURRENT"
                plan = export.export_scene(context, path,
                                           export.ldprt_export_settings(current))
                if not plan.flat:
                    raise PrtError("LDPRT bakes every visible mesh, each of its own: turn PRT "
                                   "receive on (or hide the object) for every visible mesh, "
                                   "and make instances real (they share a mesh)")
                if current:
                    armatures = {ldprt.armature_of(r.obj) for r in plan.receivers} - {None}
                    settings.pose_argument = export.pose_argument(context, plan, armatures)
            else:
                plan = export.export_scene(context, path)
            if settings.lightmap:
                for r in plan.receivers:
                    layers = r.obj.data.uv_layers
                    if len(layers) < 2 or lightmap_layer(r.obj.data, s.lightmap_uv) != layers[1]:
                        raise PrtError(f"{r.obj.name}: the lightmap UV map must be its second "
                                       "UV map (the export's TEXCOORD_1)")
                export.tile_lightmaps(plan, context.evaluated_depsgraph_get())
                plan.glb.write(path)
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        self._warn(context, plan.warnings)
        self._order = settings.order
        return BakeJob(executable, settings, plan, folder)

    def _ldprt_settings(self, context, settings):
        """Transfer: LDPRT where asked, or (Auto) where a receiver is deformed by an
        armature; its lobes and pose. LDPRT is per vertex, front faces only, order ≤ 4."""
        s = context.scene.prt
        transfer = (self.transfer or s.transfer).upper()
        if transfer not in ("AUTO", "SH", "LDPRT"):
            raise PrtError(f"unknown transfer {transfer!r} (AUTO, SH or LDPRT)")
        if transfer == "AUTO":
            deformed = [o for o in context.view_layer.objects if o.type == "MESH"
                        and o.visible_get() and o.prt_receive and ldprt.armature_of(o)]
            transfer = "LDPRT" if deformed and not settings.lightmap else "SH"
        if transfer == "SH":
            return
        settings.transfer, settings.lobes = "ldprt", self.lobes or s.lobes
        settings.pose = (self.pose or s.ldprt_pose).upper()
        if settings.pose not in ("REST", "CURRENT"):
            raise PrtError(f"unknown pose {settings.pose!r} (REST or CURRENT)")
        if settings.lightmap:
            raise PrtError("LDPRT bakes per vertex: choose Bake: Per vertex")
        if settings.order > 4:
            raise PrtError(f"LDPRT keeps order 4 at most (order {settings.order} asked)")
        if settings.double_sided != "off":
            self.report({"WARNING"}, "Double-sided auto applies to SH bakes: this LDPRT bake "
                        "bakes fronts only")
            settings.double_sided = "off"

    def _warn(self, context, warnings):
        """Each warning in Blender's report and in the panel's list of the last bake's."""
        for warning in warnings:
            self.report({"WARNING"}, warning)
        context.scene.prt.last_warnings = json.dumps(warnings)

    def _finish(self, context, job):
        if job.settings.transfer == "ldprt":
            for r, data in zip(job.plan.receivers, job.transfer):
                ldprt.store(r.obj.data, data)
        elif not job.settings.lightmap:
            for r, transfer, albedo in zip(job.plan.receivers, job.transfer, job.albedo):
                store_transfer(r.obj.data, transfer, albedo)
        for r, transfer in zip(job.receivers if job.settings.lightmap else [], job.transfer):
            uv = lightmap_layer(r.obj.data, job.settings.lightmap_uv).name
            slots = texel_materials(r.primitives, job.settings.lightmap)
            store_lightmap(r.obj, transfer, uv, slots)
        s = context.scene.prt
        s.last_time = time.time() - self._started
        s.last_summary = job.summary
        job.warnings += _clear_stale(context, job)
        for warning in job.warnings:
            self.report({"WARNING"}, warning)
        if job.warnings:
            s.last_warnings = json.dumps(json.loads(s.last_warnings) + job.warnings)
        s.baked_order = self._order
        s.light_json = json.dumps(self._light.tolist())
        s.status = ""
        count = relight.relight(context.scene)
        self.report({"INFO"}, f"PRT: baked and relit {count} meshes")

    def execute(self, context):
        job = None
        try:
            job = self._prepare(context)
            job.start()
            job.run()
            self._finish(context, job)
            return {"FINISHED"}
        except PrtError as err:
            self.report({"ERROR"}, str(err))
        except Exception as err:  # never a traceback in the UI
            self.report({"ERROR"}, f"PRT bake failed: {err}")
        finally:
            if job is not None:
                job.close()
        return {"CANCELLED"}

    def invoke(self, context, event):
        try:
            job = self._prepare(context)
            job.start()
        except PrtError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        except Exception as err:
            self.report({"ERROR"}, f"PRT bake failed: {err}")
            return {"CANCELLED"}
        self._job = job
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.2, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        context.workspace.status_text_set("PRT bake: 0 % (Esc to cancel)")
        return {"RUNNING_MODAL"}

    def _end(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        self._job.close()

    def modal(self, context, event):
        if event.type == "ESC":
            self._job.cancel()
            self._end(context)
            self.report({"INFO"}, "PRT bake cancelled: nothing changed")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            if not self._job.poll():
                percent = round(100 * self._job.progress)
                context.window_manager.progress_update(percent)
                context.workspace.status_text_set(f"PRT bake: {percent} % (Esc to cancel)")
                return {"RUNNING_MODAL"}
            self._finish(context, self._job)
            result = {"FINISHED"}
        except PrtError as err:
            self.report({"ERROR"}, str(err))
            result = {"CANCELLED"}
        except Exception as err:
            self.report({"ERROR"}, f"PRT bake failed: {err}")
            result = {"CANCELLED"}
        self._end(context)
        return result


class PRT_OT_relight(bpy.types.Operator):
    """Relight the baked meshes ("PRT") under the light turned by Light rotation"""

    bl_idname = "prt.relight"
    bl_label = "Relight"
    bl_options = {"REGISTER", "UNDO"}

    reproject: bpy.props.BoolProperty(
        name="Re-read the light", default=False,
        description="Project the rig file (or World) again before relighting")

    def execute(self, context):
        try:
            s = context.scene.prt
            if self.reproject:
                if not s.baked_order:
                    raise PrtError("nothing baked yet: bake first")
                executable = find_prt_bake(preferences(context))
                projected = _project_light(context, executable, s, s.baked_order, "")
                s.light_json = json.dumps(projected.tolist())
            count = relight.relight(context.scene)
            s.status = ""
        except PrtError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        except Exception as err:
            self.report({"ERROR"}, f"PRT relight failed: {err}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"PRT: relit {count} meshes")
        return {"FINISHED"}


def _emission_material(name, build_color):
    """An emission material (strength 1) whose colour build_color(nodes) makes."""
    material = bpy.data.materials.get(name)
    if material is None:
        material = bpy.data.materials.new(name)
        material.use_nodes = True
        nodes, links = material.node_tree.nodes, material.node_tree.links
        nodes.clear()
        color = build_color(nodes, links)
        emission = nodes.new("ShaderNodeEmission")
        emission.inputs["Strength"].default_value = 1.0
        output = nodes.new("ShaderNodeOutputMaterial")
        emission.location, output.location = (-150, 0), (100, 0)
        links.new(color, emission.inputs["Color"])
        links.new(emission.outputs["Emission"], output.inputs["Surface"])
    return material


def preview_material():
    """Shows the "PRT" colour attribute as it is (albedo included)."""
    def color(nodes, links):
        node = nodes.new("ShaderNodeVertexColor")
        node.layer_name = "PRT"
        node.location = (-400, 0)
        return node.outputs["Color"]
    return _emission_material(PREVIEW_MATERIAL, color)


def lightmap_material(transfer_image):
    """Shows the object's "PRT <object>" image on its lightmap UVs."""
    name = transfer_image["prt_object"]

    def color(nodes, links):
        uv = nodes.new("ShaderNodeUVMap")
        uv.uv_map = transfer_image["prt_uv"]
        texture = nodes.new("ShaderNodeTexImage")
        texture.image = bpy.data.images[RELIT.format(name)]
        uv.location, texture.location = (-700, 0), (-450, 0)
        links.new(uv.outputs["UV"], texture.inputs["Vector"])
        return texture.outputs["Color"]
    return _emission_material(f"{PREVIEW_MATERIAL} {name}", color)


class PRT_OT_preview_material(bpy.types.Operator):
    """Show "PRT" on the baked objects (Material Preview and renders) through object-linked
    material slots; the meshes' own materials stay as they are"""

    bl_idname = "prt.preview_material"
    bl_label = "Show PRT material"
    bl_options = {"REGISTER", "UNDO"}

    show: bpy.props.BoolProperty(name="Show", default=True)

    def execute(self, context):
        meshes = set(m.name for m in baked_meshes(context.scene))
        meshes |= {o.data.name for o in ldprt.ldprt_objects(context.scene)}
        lightmaps = {i["prt_object"]: i for i in transfer_images()}
        if not meshes and not lightmaps:
            self.report({"ERROR"}, "nothing baked yet: bake first")
            return {"CANCELLED"}
        for obj in context.scene.objects:
            if obj.type != "MESH" or (obj.data.name not in meshes and obj.name not in lightmaps):
                continue
            if not self.show:
                material = None
            elif obj.name in lightmaps:
                material = lightmap_material(lightmaps[obj.name])
            else:
                material = preview_material()
            if self.show and not obj.material_slots:
                obj.data.materials.append(None)
            for slot in obj.material_slots:
                if self.show:
                    slot.link = "OBJECT"
                    slot.material = material
                elif slot.link == "OBJECT":
                    slot.material = None
                    slot.link = "DATA"
        return {"FINISHED"}


classes = (PRT_OT_bake, PRT_OT_relight, PRT_OT_preview_material)
