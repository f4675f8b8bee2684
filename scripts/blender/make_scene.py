"""Builds the per-object lightmap UV scene in Blender (bpy 4.5 LTS as a Python module), exports it as a
GLB and bakes Cycles' own ambient occlusion of chosen objects into their lightmap UVs.

    python make_scene.py OUT_DIR [--res 256] [--samples 256] [--ao Floor,Suzanne]

Writes OUT_DIR/scene.glb (Suzanne, a cube and a floor; each object has a second UV map,
"Lightmap", made by Smart UV Project in [0, 1], exported as TEXCOORD_1) and, per baked
object, OUT_DIR/ao_<Name>.f32 (RES x RES little-endian float32, row 0 = v 0 of the object's
own lightmap UVs, as Blender's images are stored) plus OUT_DIR/cycles.json (resolution,
samples, AO distance, seconds per object).

Cycles' AO bake and the lightmap UVs: cycles_ao.py.
"""

import argparse
import sys
import time
from pathlib import Path

import bpy

from cycles_ao import bake_objects, lightmap_uvs


def args():
    argv = sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--res", type=int, default=256)
    p.add_argument("--samples", type=int, default=256)
    p.add_argument("--ao", default="Floor,Suzanne")
    p.add_argument("--threads", type=int, default=0)
    return p.parse_args(argv)


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
    bake_objects(objects, a, out, export_seconds)


main()
