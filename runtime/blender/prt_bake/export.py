"""The scene as prt-bake sees it: Blender's own glTF exporter writes it (cut-outs, normal
maps with tangents, base-colour textures, doubleSided, every UV map, linked duplicates,
collection and geometry-nodes instances as nodes sharing one mesh), then each mesh node is
marked as receiving or not (`extras.prt.receive`, which prt-bake reads).

Receivers are the visible mesh objects whose "PRT receive" is on (Object properties, or
`obj.prt_receive`). A Blender mesh holds one transfer per face corner, so a receiving object
that shares its mesh with an earlier receiver (a linked duplicate) is given a copy of the
mesh of its own (as Object > Relations > Make Single User does) and named in a warning.
Instances (collection, geometry nodes) and non-receivers only occlude: prt-bake traces a mesh
shared by several of them once (`--instances on`).
"""

import math
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import corner_map, gltf_scene, materials
from .errors import PrtError

# Blender's glTF exporter settings for a bake (docs/guides/blender.md says the same).
EXPORT_SETTINGS = dict(
    export_format="GLB", use_selection=False, use_visible=True, use_renderable=False,
    use_active_collection=False, export_apply=True, export_yup=True, export_texcoords=True,
    export_normals=True, export_tangents=True, export_materials="EXPORT",
    export_image_format="AUTO", export_extras=True, export_gn_mesh=True,
    export_cameras=False, export_lights=False, export_animations=False,
)




def ldprt_export_settings(current_pose):
    """An LDPRT bake's export: the skins too, their joints (the nodes' own transforms) at the
    armatures' rest pose; for a bake of the current pose the actions too, which prt-bake
    poses (`--pose ACTION@SECONDS`, `pose_argument`)."""
    return dict(EXPORT_SETTINGS, export_skins=True, export_rest_position_armature=True,
                export_animations=current_pose)


def pose_argument(context, plan, armatures):
    """prt-bake's `--pose` for the current frame: the armatures' one action, as Blender's
    exporter names it, at frame / fps seconds (the exporter's time of a frame)."""
    actions = {a.animation_data.action.name for a in armatures
               if a.animation_data is not None and a.animation_data.action is not None}
    names = [a.get("name") for a in plan.glb.json.get("animations", [])]
    if len(actions) != 1 or next(iter(actions)) not in names:
        raise PrtError("a bake of the current pose needs one action playing on the armatures "
                       f"(found {sorted(actions) or 'none'}; exported animations "
                       f"{names}): bake the rest pose, or give the armatures one action")
    scene = context.scene
    seconds = (scene.frame_current + scene.frame_subframe) * scene.render.fps_base \
        / scene.render.fps
    return f"{next(iter(actions))}@{seconds!r}"


@dataclass
class Receiver:
    obj: object
    node: int  # the glTF node holding it
    primitives: list = field(default_factory=list)  # lightmaps: tile_lightmaps' dicts


@dataclass
class Plan:
    receivers: list
    glb: object
    warnings: list = field(default_factory=list)
    flat: bool = True  # every mesh node receives and no mesh is shared


def _receiving_objects(context, warnings):
    objects, owner = [], {}
    for obj in context.view_layer.objects:
        if obj.type in ("CURVE", "SURFACE", "FONT", "META", "CURVES", "POINTCLOUD") \
                and obj.visible_get():
            warnings.append(f"{obj.name} is a {obj.type.lower()}, not a mesh: not baked (it "
                            "casts shadows as far as Blender's glTF export makes it a mesh; "
                            "convert it to a mesh to bake it)")
        if obj.type != "MESH" or not obj.visible_get():
            continue
        if len(obj.data.polygons) == 0:
            warnings.append(f"{obj.name} has no faces: not baked")
            continue
        if not obj.prt_receive:
            continue
        if obj.data.is_editmode:
            raise PrtError(f"{obj.name} in Edit Mode: PRT bakes in Object Mode (the results "
                           "would be lost on leaving Edit Mode)")
        if obj.data.name in owner:
            shared = obj.data.name
            obj.data = obj.data.copy()
            warnings.append(f"{obj.name} shared mesh {shared!r} with {owner[shared]}: given a "
                            f"copy of its own ({obj.data.name!r}) to hold its own transfer "
                            "(turn its PRT receive off to keep it linked: it then only casts "
                            "shadows)")
        owner[obj.data.name] = obj.name
        objects.append(obj)
    return objects


def _same_topology(obj, depsgraph):
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        return len(mesh.loops) == len(obj.data.loops) and \
            len(mesh.polygons) == len(obj.data.polygons)
    finally:
        evaluated.to_mesh_clear()


def export_scene(context, path, settings=None):
    """Writes the scene to `path` (GLB) with every mesh node's receive mark; returns the
    Plan. Raises PrtError when nothing can be baked. `settings`: the exporter's (default
    EXPORT_SETTINGS)."""
    warnings = []
    objects = _receiving_objects(context, warnings)
    depsgraph = context.evaluated_depsgraph_get()
    receivers = []
    for obj in objects:
        if _same_topology(obj, depsgraph):
            receivers.append(obj)
        else:
            warnings.append(f"{obj.name}: its modifiers change its topology, so its transfer "
                            "cannot be stored on its faces: it casts shadows as modified, not "
                            "baked (apply the modifiers to bake it)")
    if not receivers:
        raise PrtError("no visible mesh to bake (or none with PRT receive on)")
    result = bpy.ops.export_scene.gltf(filepath=path, **(settings or EXPORT_SETTINGS))
    if result != {"FINISHED"}:
        raise PrtError(f"Blender's glTF export failed ({result})")
    glb = gltf_scene.Glb(path)
    nodes = glb.json.get("nodes", [])
    order = gltf_scene.walk(glb.json)
    parent = {index: p for index, p, _ in order}
    by_name = {}
    for index, _, _ in order:
        by_name.setdefault(nodes[index].get("name"), []).append(index)
    plan = Plan([], glb, warnings)
    for obj in receivers:
        want = obj.parent.name if obj.parent is not None else None
        found = [i for i in by_name.get(obj.name, []) if "mesh" in nodes[i] and
                 (nodes[parent[i]].get("name") if parent[i] is not None else None) == want]
        if not found:
            raise PrtError(f"{obj.name}: not found in Blender's glTF export")
        plan.receivers.append(Receiver(obj, found[0]))
    rank = {index: k for k, (index, _, _) in enumerate(order)}
    plan.receivers.sort(key=lambda r: rank[r.node])  # prt-bake's object order
    receiving = {r.node for r in plan.receivers}
    gltf_scene.mark_receivers(glb, receiving)
    glb.write(path)
    mesh_nodes = [i for i, n in enumerate(nodes) if "mesh" in n]
    plan.flat = len(receiving) == len(mesh_nodes) and \
        len({nodes[i]["mesh"] for i in mesh_nodes}) == len(mesh_nodes)
    warnings += materials.warnings(receivers, depsgraph)
    return plan


def tile_lightmaps(plan, depsgraph):
    """Lightmap bakes: each receiver's own lightmap UVs (TEXCOORD_1: the second UV map, in
    [0, 1]) moved into its tile of a g × g grid in the export itself, so prt-bake's atlas
    is the tiles and each object's image is its tile (bake_job). Sets each receiver's
    `primitives` ({uv1 own, atlas_uv, triangles, material}, v up as Blender's) and returns g."""
    g = math.ceil(math.sqrt(len(plan.receivers)))
    glb, document = plan.glb, plan.glb.json
    binary = bytearray(glb.binary)
    views = [a.get("bufferView") for a in document["accessors"]]
    done = set()
    for i, r in enumerate(plan.receivers):
        mesh = document["meshes"][document["nodes"][r.node]["mesh"]]
        used = corner_map.used_materials(r.obj, depsgraph)
        triangles = [p for p in mesh["primitives"] if p.get("mode", 4) == 4]
        r.primitives = []
        for m, p in zip(used, triangles):
            index = p["attributes"].get("TEXCOORD_1")
            if index is None:
                raise PrtError(f"{r.obj.name}: no second UV map for the lightmap (TEXCOORD_1): "
                               "add one (UV > Smart UV Project into a second UV map)")
            own = glb.accessor(index).astype(np.float64) * [1, -1] + [0, 1]
            if own.min() < -1e-6 or own.max() > 1 + 1e-6:
                raise PrtError(f"{r.obj.name}: lightmap UVs outside [0, 1]: pack them "
                               "(UV > Pack Islands)")
            atlas = (np.clip(own, 0, 1) + [i % g, i // g]) / g
            accessor = document["accessors"][index]
            if views.count(accessor["bufferView"]) != 1 or accessor["componentType"] != 5126:
                raise PrtError(f"{r.obj.name}: the export's lightmap UVs are not a float array "
                               "of their own")
            if index not in done:  # a mesh shared with occluders is tiled once
                view = document["bufferViews"][accessor["bufferView"]]
                start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
                data = (atlas * [1, -1] + [0, 1]).astype("<f4").tobytes()
                binary[start:start + len(data)] = data
                done.add(index)
            r.primitives.append({"uv1": own, "atlas_uv": atlas, "material": int(m),
                                 "triangles": glb.accessor(p["indices"]).astype(np.int64)
                                 .reshape(-1, 3)})
    glb.binary = bytes(binary)
    return g
