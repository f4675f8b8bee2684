"""The light as SH coefficients in Blender's frame (+Z up, as the rigs' frame): a rig TOML
file, or the World (a uniform colour, or an equirectangular .hdr/.exr environment texture),
projected by `prt-bake light`, and turned about +Z.

prt-bake's environment maps are oriented as Blender maps an equirectangular environment in
its z-up world (docs/reference/lights.md, "Environment maps"), so a World's image is passed unturned.
"""

import json
import math
import os
import tempfile

import numpy as np

from .errors import PrtError
from .process import run_prt_bake


def _map_rotation(node):
    """Degrees about +Z that a Mapping node (Point, a rotation about Z alone, fed Texture
    Coordinate's Generated) feeding the Environment Texture's Vector turns the map by; 0 with
    no Mapping node. A Point mapping
    turns the lookup direction by R, so the map appears turned by R's inverse."""
    if not node.inputs["Vector"].is_linked:
        return 0.0
    mapping = node.inputs["Vector"].links[0].from_node
    ok = mapping.type == "MAPPING" and mapping.vector_type == "POINT"
    if ok:
        inputs = mapping.inputs
        ok = not any(i.is_linked for i in inputs if i.name != "Vector") \
            and tuple(inputs["Location"].default_value) == (0, 0, 0) \
            and tuple(inputs["Scale"].default_value) == (1, 1, 1) \
            and tuple(inputs["Rotation"].default_value)[:2] == (0, 0)
        link = inputs["Vector"].links[0] if inputs["Vector"].is_linked else None
        ok = ok and link is not None and link.from_node.type == "TEX_COORD" \
            and link.from_socket.name == "Generated"
    if not ok:
        raise PrtError("the World's Environment Texture is mapped by other than a Mapping "
                       "node turning it about Z: turn the light with Light rotation instead")
    return -math.degrees(mapping.inputs["Rotation"].default_value[2])


def _world_image(node, folder):
    """The path of an Environment Texture's image as prt-bake reads it (.hdr or .exr): its
    file, or a packed image written into `folder`."""
    import bpy

    image = node.image
    if node.projection != "EQUIRECTANGULAR":
        raise PrtError("the World's Environment Texture must be equirectangular")
    if image is None:
        raise PrtError("the World's Environment Texture has no image")
    ext = {"OPEN_EXR": ".exr", "HDR": ".hdr"}.get(image.file_format, "")
    if image.packed_file is not None and ext:
        path = os.path.join(folder, "world" + ext)
        with open(path, "wb") as f:
            f.write(image.packed_file.data)
        return path
    path = bpy.path.abspath(image.filepath) if image.filepath else ""
    if not path.lower().endswith((".hdr", ".exr")) or not os.path.isfile(path):
        raise PrtError(f"the World's image {image.name!r} is not an .hdr or .exr file on disk "
                       "(prt-bake reads radiance maps in those formats)")
    return path


def world_rig(world, folder):
    """A rig TOML for the World: its Background colour × strength as a constant sky, or its
    equirectangular environment image × strength."""
    if world is None:
        raise PrtError("the scene has no World to light it with: choose a rig file")
    color, strength = tuple(world.color), 1.0
    if world.use_nodes and world.node_tree is not None:
        backgrounds = [n for n in world.node_tree.nodes if n.type == "BACKGROUND"]
        if backgrounds:
            node = backgrounds[0]
            strength = float(node.inputs["Strength"].default_value)
            if node.inputs["Color"].is_linked:
                source = node.inputs["Color"].links[0].from_node
                if source.type != "TEX_ENVIRONMENT":
                    raise PrtError("the World's colour comes from nodes other than one "
                                   "Environment Texture: use a rig file")
                path, turn = _world_image(source, folder), _map_rotation(source)
                return ("[[light]]\nkind = \"environment\"\n"
                        f"path = {json.dumps(path)}\nintensity = {strength:.9g}\n"
                        f"rotation = [{turn:.9g}, 0, 0]\n")
            color = tuple(node.inputs["Color"].default_value[:3])
    return ("[[light]]\nkind = \"constant\"\n"
            f"color = [{color[0]:.9g}, {color[1]:.9g}, {color[2]:.9g}]\n"
            f"intensity = {strength:.9g}\n")


def project(executable, rig_path, order, outside=False):
    """(3, n²) light coefficients of the rig file at this order, in the z-up frame.
    `outside`: the rig may name a map outside its own folder (the add-on's World rig, in a
    temporary folder, names the World's image where it is)."""
    with tempfile.TemporaryDirectory(prefix="prt-light-") as folder:
        out = os.path.join(folder, "light.json")
        run_prt_bake(executable, ["light", rig_path, "--order", str(order), "--up", "z",
                                  "-o", out] + (["--allow-outside-uris"] if outside else []))
        with open(out) as f:
            document = json.load(f)
    coefficients = np.array(document["coefficients"], np.float64)
    if coefficients.shape != (3, order * order):
        raise PrtError(f"prt-bake light wrote {coefficients.shape} coefficients, "
                       f"expected (3, {order * order})")
    return coefficients


def project_world(executable, world, order):
    with tempfile.TemporaryDirectory(prefix="prt-world-") as folder:
        rig = os.path.join(folder, "world.toml")
        text = world_rig(world, folder)
        with open(rig, "w") as f:
            f.write(text)
        return project(executable, rig, order, outside=True)


def rotate_z(coefficients, angle):
    """The light turned by `angle` radians about +Z (counter-clockwise seen from above).

    Real SH of band l pair cos(mφ) (index m) with sin(mφ) (index −m); the light turned by α
    is L(φ − α), so each pair turns as a 2-D rotation by mα:
    c'_m = c_m cos mα − c_−m sin mα, c'_−m = c_m sin mα + c_−m cos mα.
    """
    c = np.array(coefficients, np.float64)
    out = c.copy()
    n = math.isqrt(c.shape[-1])
    for l in range(1, n):
        for m in range(1, l + 1):
            p, q = l * (l + 1) + m, l * (l + 1) - m
            cos, sin = math.cos(m * angle), math.sin(m * angle)
            out[..., p] = c[..., p] * cos - c[..., q] * sin
            out[..., q] = c[..., p] * sin + c[..., q] * cos
    return out
