"""Lightmap (texel) bakes as images on each object's lightmap UVs.

Per object two float images, packed into the .blend so they survive saving:

* "PRT transfer <object>": the transfer, RES wide and RES × B tall, B = ⌈channels·n²/4⌉:
  rows b·RES … (b+1)·RES − 1 hold lanes 4b … 4b+3 of (channel-major) channels × n²
  coefficients; row 0 is v = 0 of the lightmap UVs, as Blender stores images.
* "PRT <object>": the relit colour, albedo × Σ_j T_j L_j, linear and unclamped (texels no
  triangle covers are 0). The albedo is the object's first material's (a limit: a
  multi-material object's lightmap uses one colour).

Custom properties on the transfer image (prt_object, prt_order, prt_channels, prt_uv) tie it
to its object for relighting.
"""

import bpy
import numpy as np

from .scene_mesh import material_albedo

TRANSFER = "PRT transfer {}"
RELIT = "PRT {}"


def _image(name, width, height):
    image = bpy.data.images.get(name)
    if image is not None and (image.size[0] != width or image.size[1] != height):
        bpy.data.images.remove(image)
        image = None
    if image is None:
        image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
        image.colorspace_settings.name = "Linear Rec.709"
    return image


def _pack(image):
    image.file_format = "OPEN_EXR"
    image.pack()


def store_lightmap(obj, transfer, uv_name):
    """transfer: (RES, RES, channels, n²) of this object's tile."""
    res, _, channels, count = transfer.shape
    lanes = channels * count
    blocks = -(-lanes // 4)
    flat = np.zeros((res, res, blocks * 4), np.float32)
    flat[:, :, :lanes] = transfer.reshape(res, res, lanes)
    pixels = flat.reshape(res, res, blocks, 4).transpose(2, 0, 1, 3)
    image = _image(TRANSFER.format(obj.name), res, res * blocks)
    image.pixels.foreach_set(np.ascontiguousarray(pixels).ravel())
    image["prt_object"], image["prt_order"] = obj.name, int(round(count ** 0.5))
    image["prt_channels"], image["prt_uv"] = channels, uv_name
    _pack(image)
    return image


def load_lightmap(image):
    """(RES, RES, 3, n²) transfer from a transfer image (grey repeated per channel)."""
    res = image.size[0]
    channels, count = int(image["prt_channels"]), int(image["prt_order"]) ** 2
    blocks = image.size[1] // res
    pixels = np.zeros(image.size[0] * image.size[1] * 4, np.float32)
    image.pixels.foreach_get(pixels)
    flat = pixels.reshape(blocks, res, res, 4).transpose(1, 2, 0, 3).reshape(res, res, -1)
    transfer = flat[:, :, :channels * count].reshape(res, res, channels, count)
    return np.broadcast_to(transfer, (res, res, 3, count)) if channels == 1 else transfer


def transfer_images():
    return [i for i in bpy.data.images if "prt_object" in i and i.name.startswith("PRT transfer")]


def relight_lightmap(image, light):
    """Writes "PRT <object>" for this transfer image under light (3, n²)."""
    obj = bpy.data.objects.get(image["prt_object"])
    materials = obj.data.materials if obj is not None and obj.type == "MESH" else []
    albedo = np.array(material_albedo(materials[0] if len(materials) else None))
    transfer = load_lightmap(image)
    res = transfer.shape[0]
    rgb = np.einsum("yxcj,cj->yxc", transfer.astype(np.float64), light) * albedo
    rgba = np.ones((res, res, 4), np.float32)
    rgba[:, :, :3] = rgb
    relit = _image(RELIT.format(image["prt_object"]), res, res)
    relit.pixels.foreach_set(rgba.ravel())
    _pack(relit)
    return relit
