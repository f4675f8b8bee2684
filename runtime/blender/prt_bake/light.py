"""The light as SH coefficients in Blender's frame (+Z up, as the rigs' frame): a rig TOML
file, or the World's uniform colour, projected by `prt-bake light`, and turned about +Z.
"""

import json
import math
import os
import tempfile

import numpy as np

from .errors import PrtError
from .process import run_prt_bake


def world_rig(world):
    """A rig TOML for the World: its Background colour × strength as a constant sky."""
    if world is None:
        raise PrtError("the scene has no World to light it with: choose a rig file")
    color, strength = tuple(world.color), 1.0
    if world.use_nodes and world.node_tree is not None:
        backgrounds = [n for n in world.node_tree.nodes if n.type == "BACKGROUND"]
        if backgrounds:
            node = backgrounds[0]
            if node.inputs["Color"].is_linked:
                raise PrtError("the World's colour comes from nodes (an HDRI?): only a uniform "
                               "World colour is read; use a rig file with kind = \"environment\"")
            color = tuple(node.inputs["Color"].default_value[:3])
            strength = float(node.inputs["Strength"].default_value)
    return ("[[light]]\nkind = \"constant\"\n"
            f"color = [{color[0]:.9g}, {color[1]:.9g}, {color[2]:.9g}]\n"
            f"intensity = {strength:.9g}\n")


def project(executable, rig_path, order):
    """(3, n²) light coefficients of the rig file at this order, in the z-up frame."""
    with tempfile.TemporaryDirectory(prefix="prt-light-") as folder:
        out = os.path.join(folder, "light.json")
        run_prt_bake(executable, ["light", rig_path, "--order", str(order), "--up", "z",
                                  "-o", out])
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
        with open(rig, "w") as f:
            f.write(world_rig(world))
        return project(executable, rig, order)


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
