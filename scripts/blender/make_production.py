"""Builds the production-style courtyard in Blender the way an artist
would, exports it as a GLB, and bakes Cycles' own ambient occlusion of the ground and the
normal-mapped wall into their lightmap UVs.

    python make_production.py OUT_DIR [--res 128] [--samples 128] [--ao Ground,Wall]
        [--no-bake]

The scene (Blender's z up; the GLB is y up):
* Ground: an 8 x 8 m plane, a 24 x 24 grid (so a vertex bake sees its shadows).
* Foliage cards: two bushes of two crossed vertical cards and one vine card leaning over the
  ground, each a plane with an RGBA leaf texture made here; the material's alpha goes through
  a Math "Round" node (Blender 4.2+'s alpha clip), which the glTF exporter writes as
  alphaMode MASK, alphaCutoff 0.5, and Cycles renders as cut-out (alpha 0 or 1).
* Wall: a 6 x 2.5 m plane facing the courtyard, made 0.3 m thick by Solidify, with a
  tangent-space normal map made here (rows of rounded bricks) through a Normal Map node on its
  faces: exported as normalTexture + TANGENT (mesh "Wall": primitive 0 the faces, 1 the rims).
* Props: a crate mesh (0.6 m cube) and four linked duplicates of it (Alt+D: the objects share
  one mesh datablock), so the GLB has one mesh referenced by five nodes.
Every object has a second UV map, "Lightmap" (Smart UV Project in [0, 1], as make_scene.py),
exported as TEXCOORD_1. Nothing random: a rerun writes the same GLB byte for byte.

Writes OUT_DIR/courtyard.glb and, unless --no-bake, per baked object OUT_DIR/ao_<Name>.f32
(RES x RES little-endian float32, row 0 = v 0 of its Lightmap UVs) and OUT_DIR/cycles.json,
as make_scene.py. Cycles' AO bake (the AO pass) samples cosine-distributed directions about
the diffuse closure's normal (so the Normal Map node turns it), counts a direction below the
geometric surface as occluded, and traces its rays as shadow rays (transparent shadows: a
cut-out texel lets it through): the quantity prt-bake's --aux ao stores with cut-outs and
normal maps honoured.
"""

import argparse
import math
import sys
import time
from pathlib import Path

import bpy
import numpy as np

from cycles_ao import bake_objects, lightmap_uvs


def args():
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--res", type=int, default=128)
    p.add_argument("--samples", type=int, default=128)
    p.add_argument("--ao", default="Ground,Wall")
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--no-bake", action="store_true")
    return p.parse_args(sys.argv[1:])


def image(name, rgba, non_color):
    """A Blender image holding rgba (H, W, 4) in [0, 1], row 0 at the bottom (v = 0)."""
    h, w, _ = rgba.shape
    img = bpy.data.images.new(name, w, h, alpha=True)
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(rgba.astype(np.float32).ravel())
    img.pack()
    return img


def leaf_texture():
    """64 x 64 RGBA: leaves (ellipses in a staggered grid, each turned) on nothing: about
    half the card is cut away."""
    n = 64
    y, x = (np.mgrid[0:n, 0:n] + 0.5) / n
    alpha = np.zeros((n, n))
    for row in range(4):
        for col in range(3):
            cx = (col + 0.5 + 0.5 * (row % 2)) / 3 % 1.0
            cy = (row + 0.5) / 4
            angle = 0.5 + 0.6 * ((row + col) % 3)
            for dx in (-1, 0, 1):  # the texture repeats
                u = x - cx - dx
                v = y - cy
                a = u * math.cos(angle) + v * math.sin(angle)
                b = -u * math.sin(angle) + v * math.cos(angle)
                alpha = np.maximum(alpha, ((a / 0.15) ** 2 + (b / 0.07) ** 2 <= 1).astype(float))
    rgba = np.zeros((n, n, 4))
    rgba[..., 0] = 0.15 + 0.1 * y
    rgba[..., 1] = 0.45 + 0.2 * x
    rgba[..., 2] = 0.12
    rgba[..., 3] = alpha
    return rgba


def brick_normals():
    """128 x 64 tangent-space normal map (OpenGL, y up): 4 rows of rounded bricks, each row
    tilting the normal up at its top and down at its bottom by up to about 40 degrees, and
    each brick left and right at its ends."""
    w, h = 128, 64
    y, x = np.mgrid[0:h, 0:w] + 0.5
    y, x = y / h, x / w
    rows = 4
    t = (y * rows) % 1.0
    shift = 0.5 * (np.floor(y * rows) % 2)
    s = (x * 4 + shift) % 1.0
    ny = 0.85 * np.sin(math.pi * (t - 0.5))
    nx = 0.5 * np.sin(math.pi * (s - 0.5)) ** 3
    n = np.stack([nx, ny, np.ones_like(nx)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    rgba = np.ones((h, w, 4))
    rgba[..., :3] = n * 0.5 + 0.5
    return rgba


def principled(name, color):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.9
    return mat, bsdf


def leaf_material(img):
    mat, bsdf = principled("Leaves", (1, 1, 1))
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = img
    tex.interpolation = "Linear"
    clip = nodes.new("ShaderNodeMath")
    clip.operation = "ROUND"  # alpha clip at 0.5: the exporter's MASK, Cycles' cut-out
    links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(tex.outputs["Alpha"], clip.inputs[0])
    links.new(clip.outputs["Value"], bsdf.inputs["Alpha"])
    return mat


def wall_material(img):
    mat, bsdf = principled("Plaster", (0.75, 0.7, 0.62))
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = img
    tex.interpolation = "Linear"
    nmap = nodes.new("ShaderNodeNormalMap")
    nmap.space = "TANGENT"
    nmap.uv_map = "UVMap"
    links.new(tex.outputs["Color"], nmap.inputs["Color"])
    links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


def plane(name, size, location, rotation, cuts=0):
    bpy.ops.mesh.primitive_plane_add(size=1, location=location, rotation=rotation)
    obj = bpy.context.object
    obj.name = name
    obj.data.name = name
    obj.scale = (size[0], size[1], 1)
    bpy.ops.object.transform_apply(location=False, rotation=True, scale=True)
    if cuts:
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.mesh.subdivide(number_cuts=cuts)
        bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    ground = plane("Ground", (8, 8), (0, 0, 0), (0, 0, 0), cuts=23)
    ground.data.materials.append(principled("Paving", (0.5, 0.48, 0.45))[0])
    # The wall faces -y (the courtyard) from the ground's far edge (nothing behind it, so no
    # ground texel sees its back); its UVMap spans its 6 x 2.5 m face once.
    wall = plane("Wall", (6, 2.5), (0, 4.0, 1.25), (math.radians(90), 0, 0))
    wall.data.materials.append(wall_material(image("bricks_normal", brick_normals(), True)))
    # A solid wall, 0.3 m thick behind its face (Solidify, applied): directions of a tilted
    # normal's lobe below the face run into the wall itself, in Cycles as in prt-bake (whose
    # horizon rule blocks them; Cycles' AO bake traces them). The rims (top and ends, whose
    # UVMap is degenerate) take a material without the normal map.
    wall.data.materials.append(principled("PlasterRim", (0.75, 0.7, 0.62))[0])
    solid = wall.modifiers.new("Solidify", "SOLIDIFY")
    solid.thickness = 0.3
    solid.offset = -1.0
    solid.material_offset_rim = 1
    bpy.ops.object.modifier_apply(modifier=solid.name)
    leaves = leaf_material(image("leaves", leaf_texture(), False))
    cards = []
    for k, (x, y) in enumerate([(-2.2, -0.4), (2.4, 0.9)]):
        for j, turn in enumerate((0.3, 0.3 + math.pi / 2)):
            card = plane(f"Bush{k}Card{j}", (1.6, 1.4), (x, y, 0.7), (math.radians(90), 0, turn))
            card.data.materials.append(leaves)
            cards.append(card)
    vine = plane("Vine", (2.4, 1.6), (0.2, 3.0, 1.6), (math.radians(-25), 0, 0))
    vine.data.materials.append(leaves)
    cards.append(vine)
    bpy.ops.mesh.primitive_cube_add(size=0.6, location=(-0.9, -1.9, 0.3), rotation=(0, 0, 0.2))
    crate = bpy.context.object
    crate.name = "Crate0"
    crate.data.name = "Crate"
    crate.data.materials.append(principled("Wood", (0.55, 0.38, 0.2))[0])
    objects = [ground, wall, *cards, crate]
    for obj in objects:
        lightmap_uvs(obj, correct_aspect=False, texture_uvs_active=True)
    # Linked duplicates (Alt+D): new objects on the crate's mesh datablock.
    for k, (x, y, turn) in enumerate([(0.9, -2.3, 0.9), (1.6, -1.2, -0.4), (-2.8, 1.9, 0.5),
                                      (0.4, 0.2, 1.3)], start=1):
        dup = bpy.data.objects.new(f"Crate{k}", crate.data)
        dup.location = (x, y, 0.3)
        dup.rotation_euler = (0, 0, turn)
        bpy.context.scene.collection.objects.link(dup)
        objects.append(dup)
    return objects


def main():
    a = args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    objects = build()
    started = time.time()
    bpy.ops.export_scene.gltf(
        filepath=str(out / "courtyard.glb"),
        export_format="GLB",
        export_texcoords=True,
        export_normals=True,
        export_tangents=True,
        export_materials="EXPORT",
        export_image_format="AUTO",
        export_yup=True,
        export_apply=True,
    )
    export_seconds = time.time() - started
    if a.no_bake:
        return
    bake_objects(objects, a, out, export_seconds)


main()
