"""A minimal binary glTF 2.0 writer: one node per object, one triangle primitive per
material, float positions and normals, 32-bit indices, baseColorFactor materials.

prt-bake reads a glTF primitive's vertices as they are written (no welding), so the
coefficient file's vertex k of object i is exactly vertex k of the i-th primitive written
here: the add-on maps the transfer back to Blender's face corners by that order alone.
"""

import json
import struct

import numpy as np


def _pad(data, byte):
    return data + byte * (-len(data) % 4)


def write_glb(path, primitives):
    """primitives: a list of dicts {name, positions (V, 3), normals (V, 3), triangles (T, 3),
    albedo (r, g, b), and optionally uv1 (V, 2): lightmap UVs, v up as Blender's, written as
    glTF's TEXCOORD_1 (v down)}, written in order as one node and mesh each."""
    blob = bytearray()
    views, accessors, meshes, nodes, materials = [], [], [], [], []

    def add(array, component, kind, target, bounds=False):
        data = np.ascontiguousarray(array).tobytes()
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data),
                      "target": target})
        blob.extend(_pad(data, b"\0"))
        accessor = {"bufferView": len(views) - 1, "componentType": component,
                    "count": len(array), "type": kind}
        if bounds:
            accessor["min"] = [float(x) for x in array.min(0)]
            accessor["max"] = [float(x) for x in array.max(0)]
        accessors.append(accessor)
        return len(accessors) - 1

    for p in primitives:
        position = add(p["positions"].astype("<f4"), 5126, "VEC3", 34962, bounds=True)
        normal = add(p["normals"].astype("<f4"), 5126, "VEC3", 34962)
        indices = add(p["triangles"].astype("<u4").ravel(), 5125, "SCALAR", 34963)
        attributes = {"POSITION": position, "NORMAL": normal}
        if "uv1" in p:
            flipped = p["uv1"] * [1, -1] + [0, 1]
            attributes["TEXCOORD_1"] = add(flipped.astype("<f4"), 5126, "VEC2", 34962)
        materials.append({"name": p["name"], "pbrMetallicRoughness": {
            "baseColorFactor": [float(c) for c in p["albedo"]] + [1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0}})
        meshes.append({"name": p["name"], "primitives": [{
            "attributes": attributes, "indices": indices,
            "material": len(materials) - 1, "mode": 4}]})
        nodes.append({"name": p["name"], "mesh": len(meshes) - 1})
    document = {
        "asset": {"version": "2.0", "generator": "prt_bake Blender add-on"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes, "meshes": meshes, "materials": materials,
        "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": len(blob)}],
    }
    text = _pad(json.dumps(document).encode(), b" ")
    body = bytes(blob)
    size = 12 + 8 + len(text) + 8 + len(body)
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, size))
        f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
        f.write(struct.pack("<II", len(body), 0x004E4942) + body)
