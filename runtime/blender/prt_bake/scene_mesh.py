"""Materials' albedo as Blender holds it (lightmaps relight with it per texel), and the
lightmap's UV map."""

import numpy as np

from .errors import PrtError


def material_albedo(material):
    """The material's diffuse albedo, linear RGB: the Principled BSDF's (or Diffuse BSDF's)
    Base Color where the material uses nodes, else its viewport colour; 0.8 grey for none.
    No textures: lightmaps relight each texel with its material's colour (vertex bakes use
    prt-bake's albedo, which reads them: results.ALBEDO)."""
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
