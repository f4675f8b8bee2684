"""Lightmap (texel) bakes as images on each object's lightmap UVs.

Per object two float images, packed into the .blend so they survive saving:

* "PRT transfer <object>": the transfer, RES wide and RES × (B + 1) tall, B =
  ⌈channels·n²/4⌉: rows b·RES … (b+1)·RES − 1 hold lanes 4b … 4b+3 of (channel-major)
  channels × n² coefficients, and the last RES rows the material slot of each texel (red;
  texels no triangle covers take their nearest covered neighbour's); row 0 is v = 0 of the
  lightmap UVs, as Blender stores images.
* "PRT <object>": the relit colour, albedo × Σ_j T_j L_j, linear and unclamped (texels no
  triangle covers are 0), the albedo of each texel's material slot as the materials are now.

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


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _shifted(a, dy, dx):
    """a moved by (dy, dx), −1 where nothing moved in (no wrapping around)."""
    out = np.full_like(a, -1)
    h, w = a.shape
    out[max(dy, 0):h + min(dy, 0), max(dx, 0):w + min(dx, 0)] = \
        a[max(-dy, 0):h + min(-dy, 0), max(-dx, 0):w + min(-dx, 0)]
    return out


def texel_materials(primitives, res):
    """(RES, RES) material slot per texel of an object's own lightmap UVs: the slot of the
    triangle whose UVs cover the texel's centre, then spread to uncovered texels from their
    covered neighbours (so padding and bilinear lookups at island edges keep the colour)."""
    out = np.full((res, res), -1, np.int64)
    for p in primitives:
        for tri in p["uv1"][p["triangles"]] * res:
            lo = np.maximum(np.floor(tri.min(0)), 0).astype(int)
            hi = np.minimum(np.ceil(tri.max(0)), res).astype(int)
            if np.any(hi <= lo):
                continue
            xs, ys = np.meshgrid(np.arange(lo[0], hi[0]) + 0.5, np.arange(lo[1], hi[1]) + 0.5)
            q = np.stack([xs.ravel(), ys.ravel()], 1)
            area = _cross(tri[1] - tri[0], tri[2] - tri[0])
            if area == 0:
                continue
            w = [_cross(tri[(k + 2) % 3] - tri[(k + 1) % 3], q - tri[(k + 1) % 3]) / area
                 for k in range(3)]
            inside = (w[0] >= 0) & (w[1] >= 0) & (w[2] >= 0)
            out[ys.ravel()[inside].astype(int), xs.ravel()[inside].astype(int)] = p["material"]
    for _ in range(8):  # a few texels of padding around each island
        missing = out < 0
        if not missing.any():
            break
        for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0)):
            shifted = _shifted(out, dy, dx)
            fill = missing & (shifted >= 0) & (out < 0)
            out[fill] = shifted[fill]
    return np.where(out < 0, 0, out)


def store_lightmap(obj, transfer, uv_name, materials):
    """transfer: (RES, RES, channels, n²) of this object's tile; materials: (RES, RES) its
    texels' material slots (texel_materials)."""
    res, _, channels, count = transfer.shape
    lanes = channels * count
    blocks = -(-lanes // 4) + 1
    flat = np.zeros((res, res, blocks * 4), np.float32)
    flat[:, :, :lanes] = transfer.reshape(res, res, lanes)
    flat[:, :, (blocks - 1) * 4] = materials
    pixels = flat.reshape(res, res, blocks, 4).transpose(2, 0, 1, 3)
    image = _image(TRANSFER.format(obj.name), res, res * blocks)
    image.pixels.foreach_set(np.ascontiguousarray(pixels).ravel())
    image["prt_object"], image["prt_order"] = obj.name, int(round(count ** 0.5))
    image["prt_channels"], image["prt_uv"] = channels, uv_name
    _pack(image)
    return image


def load_lightmap(image):
    """(RES, RES, 3, n²) transfer from a transfer image (grey repeated per channel), and the
    (RES, RES) material slots."""
    res = image.size[0]
    channels, count = int(image["prt_channels"]), int(image["prt_order"]) ** 2
    blocks = image.size[1] // res
    pixels = np.zeros(image.size[0] * image.size[1] * 4, np.float32)
    image.pixels.foreach_get(pixels)
    flat = pixels.reshape(blocks, res, res, 4).transpose(1, 2, 0, 3).reshape(res, res, -1)
    transfer = flat[:, :, :channels * count].reshape(res, res, channels, count)
    materials = flat[:, :, (blocks - 1) * 4].astype(np.int64)
    if channels == 1:
        transfer = np.broadcast_to(transfer, (res, res, 3, count))
    return transfer, materials


def transfer_images():
    return [i for i in bpy.data.images if "prt_object" in i and i.name.startswith("PRT transfer")]


def relight_lightmap(image, light):
    """Writes "PRT <object>" for this transfer image under light (3, n²)."""
    obj = bpy.data.objects.get(image["prt_object"])
    materials = list(obj.data.materials) if obj is not None and obj.type == "MESH" else []
    albedos = np.array([material_albedo(m) for m in materials] or [material_albedo(None)])
    transfer, slots = load_lightmap(image)
    res = transfer.shape[0]
    albedo = albedos[np.minimum(slots, len(albedos) - 1)]
    rgb = np.einsum("yxcj,cj->yxc", transfer.astype(np.float64), light) * albedo
    rgba = np.ones((res, res, 4), np.float32)
    rgba[:, :, :3] = rgb
    relit = _image(RELIT.format(image["prt_object"]), res, res)
    relit.pixels.foreach_set(rgba.ravel())
    _pack(relit)
    return relit
