"""The map from prt-bake's baked vertices back to Blender's face corners, exactly.

Blender's glTF exporter (io_scene_gltf2, primitive_extract.py) triangulates the evaluated
mesh with `calc_loop_triangles`, puts each triangle into the primitive of its material
index (primitives in ascending material index), and writes for triangle corner k of that
primitive's list the index of the corner's deduplicated vertex. So corner `loops[k]` of
that list is glTF vertex `indices[k]`. The add-on rebuilds the same list from the same
evaluated mesh and reads the exporter's own index buffer: no matching by position. The
result is then checked: every corner's baked vertex must lie at the corner's world position
and face its normal, else the bake is refused rather than stored on the wrong corners.
"""

import numpy as np

from .errors import PrtError
from .sh_frame import GLTF_TO_BLENDER


def corner_vertices(obj, depsgraph, primitives, start):
    """(loops,) baked vertex of each face corner of obj.data; `primitives` the node's
    [(vertex count, indices)] (gltf_scene.triangle_primitives), `start` its first baked
    vertex. Also returns the corners' world positions and normals, Blender's frame."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        loops = np.zeros(len(mesh.loop_triangles) * 3, np.int64)
        mesh.loop_triangles.foreach_get("loops", loops)
        material = np.zeros(len(mesh.loop_triangles), np.int64)
        mesh.loop_triangles.foreach_get("material_index", material)
        corner_material = np.repeat(material, 3)
        used = np.unique(material)
        if len(used) != len(primitives):
            raise PrtError(f"{obj.name}: {len(used)} materials used, the export has "
                           f"{len(primitives)} primitives")
        out = np.full(len(mesh.loops), -1, np.int64)
        offset = start
        for m, (count, indices) in zip(used, primitives):
            corners = loops[corner_material == m]
            if len(corners) != len(indices):
                raise PrtError(f"{obj.name}: material {m}'s triangles are not the export's")
            out[corners] = offset + indices
            offset += count
        if (out < 0).any():
            raise PrtError(f"{obj.name}: {int((out < 0).sum())} face corners in no triangle")
        vertex = np.zeros(len(mesh.loops), np.int64)
        mesh.loops.foreach_get("vertex_index", vertex)
        co = np.zeros(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", co)
        normal = np.zeros(len(mesh.loops) * 3)
        mesh.corner_normals.foreach_get("vector", normal)
    finally:
        evaluated.to_mesh_clear()
    m = np.array(evaluated.matrix_world, np.float64)
    position = co.reshape(-1, 3)[vertex] @ m[:3, :3].T + m[:3, 3]
    normal = normal.reshape(-1, 3) @ np.linalg.inv(m[:3, :3])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    return out, position, normal


def check(obj, positions, normals, corner_position, corner_normal):
    """Refuses a map whose baked vertices (glTF frame) are not at the corners."""
    p = positions @ GLTF_TO_BLENDER.T
    n = normals @ GLTF_TO_BLENDER.T
    scale = 1 + np.abs(corner_position).max()
    far = np.linalg.norm(p - corner_position, axis=1).max()
    turned = (np.einsum("ij,ij->i", n, corner_normal) < 0.999).sum()
    if far > 1e-4 * scale or turned:
        raise PrtError(f"{obj.name}: prt-bake's vertices are not its face corners "
                       f"({far:.3g} m apart at most, {turned} normals turned)")


def used_materials(obj, depsgraph):
    """The material indices the evaluated mesh's triangles use, ascending: the export's
    triangle primitives, in order."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        material = np.zeros(len(mesh.loop_triangles), np.int64)
        mesh.loop_triangles.foreach_get("material_index", material)
        return np.unique(material)
    finally:
        evaluated.to_mesh_clear()
