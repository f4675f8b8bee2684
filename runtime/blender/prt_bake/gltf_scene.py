"""Blender's own glTF export of the scene, as prt-bake reads it: its nodes in prt-bake's
order, the "receive" mark of each node, and each primitive's triangles (the map back to
Blender's face corners, corner_map.py).

prt-bake walks the default scene's nodes depth first, parents before children, in the
file's order, and makes one object per triangle primitive of each mesh node; the coefficient
file's vertices are those objects' vertices in that order (receivers only where some nodes do
not receive: `receives` in the exported .npz says which vertices were baked).
"""

import json
import struct

import numpy as np

_COMPONENTS = {5121: "<u1", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


class Glb:
    def __init__(self, path):
        data = open(path, "rb").read()
        length = struct.unpack("<I", data[12:16])[0]
        self.json = json.loads(data[20:20 + length])
        start = 20 + length
        self.binary = data[start + 8:] if len(data) > start else b""

    def accessor(self, index):
        a = self.json["accessors"][index]
        view = self.json["bufferViews"][a["bufferView"]]
        width = _WIDTH[a["type"]]
        offset = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        values = np.frombuffer(self.binary, _COMPONENTS[a["componentType"]],
                               a["count"] * width, offset)
        return values.reshape(a["count"], width) if width > 1 else values

    def write(self, path):
        text = json.dumps(self.json, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        body = self.binary + b"\0" * (-len(self.binary) % 4)
        with open(path, "wb") as f:
            size = 12 + 8 + len(text) + (8 + len(body) if body else 0)
            f.write(struct.pack("<III", 0x46546C67, 2, size))
            f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
            if body:
                f.write(struct.pack("<II", len(body), 0x004E4942) + body)


def _local(node):
    if "matrix" in node:
        return np.array(node["matrix"], np.float64).reshape(4, 4).T
    t = np.array(node.get("translation", [0, 0, 0]), np.float64)
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * np.array(node.get("scale", [1, 1, 1]), np.float64)
    m[:3, 3] = t
    return m


def walk(document):
    """[(node index, parent index or None, world matrix)] in prt-bake's order."""
    scene = document["scenes"][document.get("scene", 0)]
    out = []

    def visit(index, parent, world):
        node = document["nodes"][index]
        world = world @ _local(node)
        out.append((index, parent, world))
        for child in node.get("children", []):
            visit(child, index, world)

    for root in scene["nodes"]:
        visit(root, None, np.eye(4))
    return out


def mark_receivers(glb, receiving):
    """Every mesh node's extras.prt.receive: True for the node indices in `receiving`,
    False for the others (instances, occluders)."""
    for i, node in enumerate(glb.json["nodes"]):
        if "mesh" not in node:
            continue
        extras = node.setdefault("extras", {})
        if not isinstance(extras, dict):
            extras = node["extras"] = {}
        prt = extras.get("prt") if isinstance(extras.get("prt"), dict) else {}
        extras["prt"] = dict(prt, receive=i in receiving)


def triangle_primitives(glb, node_index):
    """The node's mesh's triangle primitives: [(vertex count, indices (T·3,))]."""
    mesh = glb.json["meshes"][glb.json["nodes"][node_index]["mesh"]]
    out = []
    for p in mesh["primitives"]:
        if p.get("mode", 4) != 4:
            continue
        count = glb.json["accessors"][p["attributes"]["POSITION"]]["count"]
        indices = glb.accessor(p["indices"]).astype(np.int64) if "indices" in p \
            else np.arange(count)
        out.append((count, indices))
    return out
