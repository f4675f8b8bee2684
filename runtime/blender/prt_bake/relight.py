"""Relighting: the bake's light turned by `scene.prt.light_rotation` about world Z, dotted
with every baked corner's transfer into the "PRT" colour attribute. No re-bake. LDPRT
meshes (ldprt.py) are relit in their current pose, and again at every frame change
(`on_frame_change`, a frame_change_post handler), so their shading follows the armature."""

import json

import bpy
import numpy as np

from . import ldprt
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
    posed = relight_ldprt(scene, light)
    images = [i for i in transfer_images() if int(i["prt_order"]) ** 2 == light.shape[1]]
    for image in images:
        relight_lightmap(image, light)
    return len(meshes) + len(images) + posed


def relight_ldprt(scene, light, depsgraph=None):
    """Recolours every LDPRT mesh in its current pose; returns how many."""
    objects = ldprt.ldprt_objects(scene)
    if objects and depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    editing = [o.name for o in objects if o.data.is_editmode]
    if editing:
        raise PrtError(f"{', '.join(editing)} in Edit Mode: relight in Object Mode")
    for obj in objects:
        store_color(obj.data, ldprt.relit_colors(obj, light, depsgraph))
    return len(objects)


@bpy.app.handlers.persistent
def on_frame_change(scene, depsgraph=None):
    """LDPRT meshes follow the pose: relit after every frame change (playback, scrubbing,
    scene.frame_set). Problems go to the panel's status, as for property updates."""
    if not scene.prt.light_json or not any(ldprt.INFO in o.data for o in scene.objects
                                           if o.type == "MESH"):
        return
    try:
        relight_ldprt(scene, current_light(scene), depsgraph)
    except PrtError as err:
        scene.prt.status = str(err)
    except Exception as err:  # never a traceback in the UI
        scene.prt.status = f"LDPRT relight failed: {err}"


def relight_quietly(scene):
    """For property updates, which cannot report: the problem goes to the panel's status."""
    try:
        relight(scene)
    except PrtError as err:
        scene.prt.status = str(err)
    except Exception as err:  # never a traceback in the UI
        scene.prt.status = f"relight failed: {err}"
