"""The visible meshes as prt-bake receives them: one baked vertex per distinct (vertex,
split normal, material) of each mesh's face corners, in world space (Blender's +Z up).

Flat faces and sharp edges split vertices, as Blender's own glTF exporter splits them, so a
cube's corner is baked once per face it belongs to. `Receivers.corner_vertex[i]` is the
baked vertex of face corner (loop) i of object i's mesh: the map back for the results.
"""

from dataclasses import dataclass, field

import numpy as np

from .errors import PrtError


@dataclass
class Receivers:
    """One baked mesh: the object, and per face corner its baked vertex."""

    obj: object
    corner_vertex: np.ndarray  # (loops,) int: index into this object's baked vertices
    vertex_count: int
    primitives: list = field(default_factory=list)  # glb.write_glb's dicts, by material


def material_albedo(material):
    """The material's diffuse albedo, linear RGB: the Principled BSDF's (or Diffuse BSDF's)
    Base Color where the material uses nodes, else its viewport colour; 0.8 grey for none.
    Textures are not read (the add-on's documented limit)."""
    if material is None:
        return (0.8, 0.8, 0.8)
    if material.use_nodes and material.node_tree is not None:
        for node in material.node_tree.nodes:
            if node.type in ("BSDF_PRINCIPLED", "BSDF_DIFFUSE"):
                return tuple(node.inputs["Base Color" if node.type == "BSDF_PRINCIPLED"
                                         else "Color"].default_value[:3])
    return tuple(material.diffuse_color[:3])


def corner_albedo(mesh):
    """(loops, 3) albedo of each face corner, from the mesh's own material slots."""
    albedos = np.array([material_albedo(m) for m in mesh.materials] or [material_albedo(None)])
    polygon_material = np.zeros(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("material_index", polygon_material)
    polygon_material = np.minimum(polygon_material, len(albedos) - 1)
    loop_polygon = np.repeat(np.arange(len(mesh.polygons)), _loop_totals(mesh))
    return albedos[polygon_material[loop_polygon]]


def _loop_totals(mesh):
    totals = np.zeros(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("loop_total", totals)
    return totals


def visible_meshes(context):
    """The view layer's visible mesh objects with faces, each mesh data once (an instance
    that shares another's mesh, or a mesh of loose edges, is left out and named in the
    returned warnings)."""
    objects, seen, warnings = [], {}, []
    for obj in context.view_layer.objects:
        if obj.type != "MESH" or not obj.visible_get():
            continue
        if len(obj.data.polygons) == 0:
            warnings.append(f"{obj.name} has no faces: not baked")
            continue
        if obj.data.name in seen:
            warnings.append(f"{obj.name} shares its mesh with {seen[obj.data.name]}: not baked")
            continue
        seen[obj.data.name] = obj.name
        objects.append(obj)
    if not objects:
        raise PrtError("no visible mesh to bake")
    editing = [o.name for o in objects if o.data.is_editmode]
    if editing:
        raise PrtError(f"{', '.join(editing)} in Edit Mode: PRT bakes in Object Mode (the "
                       "results would be lost on leaving Edit Mode)")
    return objects, warnings


def lightmap_layer(mesh, name):
    """The UV map a lightmap bake uses: the one named, else the second, else the only one."""
    layers = mesh.uv_layers
    if name:
        if name not in layers:
            raise PrtError(f"{mesh.name}: no UV map named {name!r} for the lightmap")
        return layers[name]
    if len(layers) == 0:
        raise PrtError(f"{mesh.name}: no UV map for the lightmap: add one (UV > Smart UV "
                       "Project into a second UV map)")
    return layers[1] if len(layers) > 1 else layers[0]


def receivers_of(obj, depsgraph, lightmap_uv=None):
    """The object's baked vertices and triangles, one glTF primitive per material used.
    With `lightmap_uv` (a UV map's name, or "" for the default), the vertices are split by
    that map's UVs too and the primitives carry them as "uv1"."""
    mesh = obj.data
    warnings = []
    evaluated = obj.evaluated_get(depsgraph)
    shaped = evaluated.to_mesh()
    try:
        if len(shaped.loops) != len(mesh.loops) or len(shaped.polygons) != len(mesh.polygons):
            warnings.append(f"{obj.name}: modifiers change its topology; baked without them")
            return _receivers(obj, mesh, obj.matrix_world, lightmap_uv), warnings
        return _receivers(obj, shaped, evaluated.matrix_world, lightmap_uv), warnings
    finally:
        evaluated.to_mesh_clear()


def _receivers(obj, mesh, matrix, lightmap_uv):
    loops = len(mesh.loops)
    if loops == 0 or len(mesh.polygons) == 0:
        raise PrtError(f"{obj.name}: the mesh has no faces")
    corner_vertex = np.zeros(loops, np.int64)
    mesh.loops.foreach_get("vertex_index", corner_vertex)
    normals = np.zeros(loops * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", normals)
    normals = normals.reshape(loops, 3)
    polygon_material = np.zeros(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("material_index", polygon_material)
    corner_material = np.repeat(polygon_material, _loop_totals(mesh))
    # A baked vertex per distinct (material, vertex, normal bits): materials first, so each
    # material's vertices are one run and become one primitive.
    columns = [corner_material, corner_vertex, normals.view(np.int32).astype(np.int64)]
    if lightmap_uv is not None:
        uv = np.zeros(loops * 2, np.float32)
        lightmap_layer(mesh, lightmap_uv).uv.foreach_get("vector", uv)
        uv = uv.reshape(loops, 2)
        if uv.min() < 0 or uv.max() > 1:
            raise PrtError(f"{obj.name}: lightmap UVs outside [0, 1]: pack them "
                           "(UV > Pack Islands)")
        columns.append(uv.view(np.int32).astype(np.int64))
    key = np.column_stack(columns)
    unique, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()

    co = np.zeros(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    m = np.array(matrix, np.float64)
    positions = co.reshape(-1, 3)[unique[:, 1]] @ m[:3, :3].T + m[:3, 3]
    normal_matrix = np.linalg.inv(m[:3, :3]).T
    world_normals = normals[first].astype(np.float64) @ normal_matrix.T
    lengths = np.linalg.norm(world_normals, axis=1, keepdims=True)
    world_normals /= np.where(lengths > 0, lengths, 1)

    mesh.calc_loop_triangles()
    triangles = np.zeros(len(mesh.loop_triangles) * 3, np.int64)
    mesh.loop_triangles.foreach_get("loops", triangles)
    triangles = inverse[triangles].reshape(-1, 3)
    if np.linalg.det(m[:3, :3]) < 0:  # a mirror: keep the faces' winding outwards
        triangles = triangles[:, ::-1]
    triangle_material = unique[triangles[:, 0], 0]

    albedos = corner_albedo(mesh)
    primitives = []
    for material in np.unique(unique[:, 0]):
        run = np.flatnonzero(unique[:, 0] == material)
        start = run[0]
        primitive = {
            "name": obj.name if len(primitives) == 0 else f"{obj.name}.{material}",
            "positions": positions[run],
            "normals": world_normals[run],
            "triangles": triangles[triangle_material == material] - start,
            "albedo": albedos[first[start]],
            "material": int(material),
        }
        if lightmap_uv is not None:
            primitive["uv1"] = uv[first[run]].astype(np.float64)
        primitives.append(primitive)
    return Receivers(obj, inverse, len(unique), primitives)
