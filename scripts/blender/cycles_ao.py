"""What make_scene.py and make_production.py share: a second UV map laid out as a Blender
user lays one out, and Cycles' own AO bake of chosen objects into it.

Cycles' AO bake: the fraction of cosine-weighted hemisphere rays that reach the AO distance
unoccluded, i.e. (1/pi) int V(s) max(n.s, 0) ds as prt-bake's --aux ao stores, when the AO
distance is larger than the scene (set here to 1000 m).
"""

import json
import math
import time

import bpy
import numpy as np


def lightmap_uvs(obj, margin=0.02, correct_aspect=True, texture_uvs_active=False):
    """A second UV map, "Lightmap", by Smart UV Project. correct_aspect=False keeps an island's
    proportions where the object's texture is not square; texture_uvs_active leaves the first
    UV map (TEXCOORD_0) the one the materials read."""
    layer = obj.data.uv_layers.new(name="Lightmap")
    obj.data.uv_layers.active = layer
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(angle_limit=math.radians(66), island_margin=margin,
                             correct_aspect=correct_aspect)
    bpy.ops.object.mode_set(mode="OBJECT")
    if texture_uvs_active:
        obj.data.uv_layers.active = obj.data.uv_layers[0]


def bake_ao(obj, res, path):
    """Cycles AO into an image on the object's Lightmap UVs (the bake's target is the active
    UV map; textures keep reading the UV map named in their nodes), written to path as RES x
    RES little-endian float32, row 0 = v 0. Returns the seconds it took."""
    img = bpy.data.images.new("ao_" + obj.name, res, res, float_buffer=True, alpha=False)
    img.colorspace_settings.name = "Non-Color"
    mat = obj.data.materials[0]
    node = mat.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = img
    mat.node_tree.nodes.active = node
    obj.data.uv_layers.active = obj.data.uv_layers["Lightmap"]
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    started = time.time()
    bpy.ops.object.bake(type="AO", margin=4, use_clear=True)
    seconds = time.time() - started
    pixels = np.array(img.pixels[:], dtype=np.float32).reshape(res, res, 4)[:, :, 0]
    pixels.astype("<f4").tofile(path)
    # The bake's image node stays out of the GLB: the export ran before.
    return seconds


def bake_objects(objects, a, out, export_seconds):
    """Cycles on the CPU, a.samples per pixel, no denoising; AO of the objects named in a.ao
    into out/ao_<Name>.f32 at a.res; out/cycles.json (also printed) says what ran."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = a.samples
    scene.cycles.use_denoising = False
    if a.threads:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = a.threads
    world = bpy.data.worlds.new("World")
    scene.world = world
    world.light_settings.distance = 1000.0
    seconds = {}
    wanted = [n for n in a.ao.split(",") if n]
    for obj in objects:
        if obj.name in wanted:
            seconds[obj.name] = bake_ao(obj, a.res, out / f"ao_{obj.name}.f32")
    info = {
        "blender": bpy.app.version_string,
        "resolution": a.res,
        "samples": a.samples,
        "ao_distance": world.light_settings.distance,
        "export_seconds": export_seconds,
        "bake_seconds": seconds,
        "objects": {o.name: len(o.data.polygons) for o in objects},
    }
    (out / "cycles.json").write_text(json.dumps(info, indent=1))
    print(json.dumps(info))
