"""Relighting: the bake's light turned by `scene.prt.light_rotation` about world Z, dotted
with every baked corner's transfer into the "PRT" colour attribute. No re-bake."""

import json

import numpy as np

from .errors import PrtError
from .light import rotate_z
from .lightmap_images import relight_lightmap, transfer_images
from .results import baked_meshes, relit_colors, store_color


def current_light(scene):
    settings = scene.prt
    if not settings.light_json:
        raise PrtError("nothing baked yet: bake first")
    light = np.array(json.loads(settings.light_json), np.float64)
    return rotate_z(light, settings.light_rotation)


def relight(scene):
    """Recolours every baked mesh and lightmap; returns how many."""
    light = current_light(scene)
    meshes = baked_meshes(scene)
    editing = [m.name for m in meshes if m.is_editmode]
    if editing:
        raise PrtError(f"{', '.join(editing)} in Edit Mode: relight in Object Mode")
    for mesh in meshes:
        store_color(mesh, relit_colors(mesh, light))
    images = [i for i in transfer_images() if int(i["prt_order"]) ** 2 == light.shape[1]]
    for image in images:
        relight_lightmap(image, light)
    return len(meshes) + len(images)


def relight_quietly(scene):
    """For property updates, which cannot report: the problem goes to the panel's status."""
    try:
        relight(scene)
    except PrtError as err:
        scene.prt.status = str(err)
    except Exception as err:  # never a traceback in the UI
        scene.prt.status = f"relight failed: {err}"
