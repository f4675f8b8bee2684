"""Builds the issue-23 scene in Blender (bpy 4.5 LTS as a Python module), exports it as a
GLB and bakes Cycles' own ambient occlusion of chosen objects into their lightmap UVs.

    python make_scene.py OUT_DIR [--res 256] [--samples 256] [--ao Floor,Suzanne]

Writes OUT_DIR/scene.glb (Suzanne, a cube and a floor; each object has a second UV map,
"Lightmap", made by Smart UV Project in [0, 1], exported as TEXCOORD_1) and, per baked
object, OUT_DIR/ao_<Name>.f32 (RES x RES little-endian float32, row 0 = v 0 of the object's
own lightmap UVs, as Blender's images are stored) plus OUT_DIR/cycles.json (resolution,
samples, AO distance, seconds per object).

Cycles' AO bake: the fraction of cosine-weighted hemisphere rays that reach the AO distance
unoccluded, i.e. (1/pi) int V(s) max(n.s, 0) ds as prt-bake's --aux ao stores, when the AO
distance is larger than the scene (set here to 1000 m).
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

import bpy
import numpy as np


def args():
    argv = sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--res", type=int, default=256)
    p.add_argument("--samples", type=int, default=256)
    p.add_argument("--ao", default="Floor,Suzanne")
    p.add_argument("--threads", type=int, default=0)
    return p.parse_args(argv)


def lightmap_uvs(obj, margin):
    """A second UV map, "Lightmap", by Smart UV Project, as a Blender user lays one out."""
    layer = obj.data.uv_layers.new(name="Lightmap")
    obj.data.uv_layers.active = layer
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(angle_limit=math.radians(66), island_margin=margin)
    bpy.ops.object.mode_set(mode="OBJECT")


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 0, 0))
    floor = bpy.context.object
    floor.name = "Floor"
    bpy.ops.mesh.primitive_monkey_add(size=2, location=(-0.6, 0, 1.0), rotation=(0.0, 0, 0.4))
    suzanne = bpy.context.object
    suzanne.name = "Suzanne"
    bpy.ops.object.modifier_add(type="SUBSURF")
    suzanne.modifiers["Subdivision"].levels = 1
    bpy.ops.object.modifier_apply(modifier="Subdivision")
    bpy.ops.object.shade_smooth()
    bpy.ops.mesh.primitive_cube_add(size=1, location=(1.4, 0.6, 0.5), rotation=(0, 0, 0.3))
    cube = bpy.context.object
    cube.name = "Cube"
    for obj in (floor, suzanne, cube):
        lightmap_uvs(obj, margin=0.02)
        mat = bpy.data.materials.new(obj.name + "Material")
        mat.use_nodes = True
        obj.data.materials.append(mat)
    return [floor, suzanne, cube]


def bake_ao(obj, res, path):
    """Cycles AO into an image on the object's Lightmap UVs (the active UV map)."""
    image = bpy.data.images.new("ao_" + obj.name, res, res, float_buffer=True, alpha=False)
    image.colorspace_settings.name = "Non-Color"
    mat = obj.data.materials[0]
    node = mat.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    mat.node_tree.nodes.active = node
    obj.data.uv_layers.active = obj.data.uv_layers["Lightmap"]
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    started = time.time()
    bpy.ops.object.bake(type="AO", margin=4, use_clear=True)
    seconds = time.time() - started
    pixels = np.array(image.pixels[:], dtype=np.float32).reshape(res, res, 4)[:, :, 0]
    pixels.astype("<f4").tofile(path)
    # The bake's image node stays out of the GLB: the export ran before.
    return seconds


def main():
    a = args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    objects = build()
    started = time.time()
    bpy.ops.export_scene.gltf(
        filepath=str(out / "scene.glb"),
        export_format="GLB",
        export_texcoords=True,
        export_normals=True,
        export_materials="EXPORT",
        export_yup=True,
        export_apply=True,
    )
    export_seconds = time.time() - started
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


main()
