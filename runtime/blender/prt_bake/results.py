"""The bake's results on the meshes, and relighting them.

Per face corner of each baked mesh: the transfer T (albedo excluded) as FLOAT attributes
`prt_T00` … (grey bakes) or FLOAT_VECTOR ones (RGB bakes: R, G, B of coefficient j), j =
l(l+1)+m in Blender's world frame, and the colour attribute "PRT" = albedo × Σ_j T_j L_j,
linear, unclamped (the relit radiance; prt-bake's glTF COLOR_0 is Σ_j T_j L_j clamped to
[0, 1], which glTF then multiplies by the base colour).
"""

import numpy as np

from .errors import PrtError
from .scene_mesh import corner_albedo

PRT_COLOR = "PRT"
PREFIX = "prt_T"
ALBEDO = "prt_albedo"  # per corner, where the bake read textures


def attribute_name(j):
    return f"{PREFIX}{j:02d}"


def store_transfer(mesh, transfer, albedo=None):
    """transfer: (loops, channels, n²) float32 for this mesh's face corners; albedo: (loops,
    3) prt-bake's albedo (base colour × texture), stored as ALBEDO."""
    from .ldprt import clear

    clear(mesh)  # an LDPRT bake's lobes, if the mesh held one
    loops, channels, count = transfer.shape
    kind = "FLOAT" if channels == 1 else "FLOAT_VECTOR"
    for name in [a.name for a in mesh.attributes
                 if a.name.startswith(PREFIX) or a.name == ALBEDO]:
        mesh.attributes.remove(mesh.attributes[name])
    if albedo is not None:
        mesh.attributes.new(ALBEDO, "FLOAT_VECTOR", "CORNER").data.foreach_set(
            "vector", np.ascontiguousarray(albedo, np.float32).ravel())
    for j in range(count):
        attribute = mesh.attributes.new(attribute_name(j), kind, "CORNER")
        values = transfer[:, :, j] if channels == 3 else transfer[:, 0, j]
        attribute.data.foreach_set("vector" if channels == 3 else "value",
                                   np.ascontiguousarray(values, np.float32).ravel())


def load_transfer(mesh, count):
    """(loops, 3, count) transfer from the mesh's attributes (grey repeated per channel)."""
    loops = len(mesh.loops)
    out = np.zeros((loops, 3, count), np.float32)
    for j in range(count):
        attribute = mesh.attributes.get(attribute_name(j))
        if attribute is None or attribute.domain != "CORNER":
            raise PrtError(f"{mesh.name}: no PRT transfer attribute {attribute_name(j)}: bake first")
        if attribute.data_type == "FLOAT_VECTOR":
            values = np.zeros(loops * 3, np.float32)
            attribute.data.foreach_get("vector", values)
            out[:, :, j] = values.reshape(loops, 3)
        else:
            values = np.zeros(loops, np.float32)
            attribute.data.foreach_get("value", values)
            out[:, :, j] = values[:, None]
    return out


def relit_colors(mesh, light):
    """(loops, 3) albedo × Σ_j T_j L_j for light (3, n²)."""
    transfer = load_transfer(mesh, light.shape[1])
    radiance = np.einsum("lcj,cj->lc", transfer.astype(np.float64), light)
    stored = mesh.attributes.get(ALBEDO)
    if stored is not None and stored.domain == "CORNER":
        albedo = np.zeros(len(mesh.loops) * 3, np.float32)
        stored.data.foreach_get("vector", albedo)
        return albedo.reshape(-1, 3) * radiance
    return corner_albedo(mesh) * radiance


def store_color(mesh, colors):
    attribute = mesh.color_attributes.get(PRT_COLOR)
    if attribute is not None and (attribute.data_type != "FLOAT_COLOR"
                                  or attribute.domain != "CORNER"):
        mesh.color_attributes.remove(attribute)
        attribute = None
    if attribute is None:
        attribute = mesh.color_attributes.new(PRT_COLOR, "FLOAT_COLOR", "CORNER")
    rgba = np.ones((len(colors), 4), np.float32)
    rgba[:, :3] = colors
    attribute.data.foreach_set("color", rgba.ravel())
    mesh.update()


def baked_meshes(scene):
    """The meshes of the scene's objects that hold a bake of the scene's order."""
    order = scene.prt.baked_order
    seen, meshes = set(), []
    for obj in scene.objects:
        if obj.type == "MESH" and obj.data.name not in seen \
                and attribute_name(order * order - 1) in obj.data.attributes:
            seen.add(obj.data.name)
            meshes.append(obj.data)
    return meshes


def clear_transfer(mesh):
    """Removes a vertex bake's attributes (the transfer, its albedo and "PRT") from a mesh:
    True if it had any."""
    names = [a.name for a in mesh.attributes
             if a.name.startswith(PREFIX) or a.name in (ALBEDO, PRT_COLOR)]
    for name in names:
        mesh.attributes.remove(mesh.attributes[name])
    from .ldprt import clear

    return clear(mesh) or bool(names)
