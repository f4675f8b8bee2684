#!/usr/bin/env python3
"""Writes the cut-out card and its geometry twin (scenes/cutout/card.glb, twin.glb).

The layout of tests/alpha_cutouts.rs, as files the viewer's and the browser's tests share: a
5 x 5 floor of 24 x 24 cells at y = 0 (glTF, +y up), and 0.6 above it a 2 x 2 card over
x, z in [-1, 1] whose 8 x 1 RGBA texture is white, alpha 255 in even texels and 0 in odd
ones, so alphaMode MASK (cutoff 0.5) cuts it into 8 stripes along x, 4 kept. The twin models
the 4 kept stripes (x in [-1 + k/2, -0.75 + k/2]) as geometry, opaque, with the same texture
and texture coordinates. Both cards are doubleSided, so a bake gives both a back sheet.

    python3 scripts/gltf/cutout_card.py scenes/cutout

Deterministic: a rerun writes the same bytes.
"""
import json
import struct
import sys
import zlib
from pathlib import Path

CELLS = 24
HEIGHT = 0.6


def png_rgba(width, height, pixels):
    """A PNG of RGBA rows (lists of 4-tuples), without filtering."""
    raw = b"".join(b"\0" + bytes(c for p in row for c in p) for row in pixels)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def floor():
    positions, uvs, indices = [], [], []
    for j in range(CELLS + 1):
        for i in range(CELLS + 1):
            positions.append((-2.5 + 5.0 * i / CELLS, 0.0, 2.5 - 5.0 * j / CELLS))
            uvs.append((i / CELLS, j / CELLS))
    row = CELLS + 1
    for j in range(CELLS):
        for i in range(CELLS):
            a, b, c, d = j * row + i, j * row + i + 1, (j + 1) * row + i + 1, (j + 1) * row + i
            indices += [a, b, c, a, c, d]
    return positions, uvs, indices


def card_part(x0, x1):
    """A rectangle at HEIGHT over x in [x0, x1], z in [-1, 1], facing +y, with the texture
    coordinates of the whole card: u = (x + 1) / 2, v = (z + 1) / 2."""
    corners = [(x0, -1.0), (x1, -1.0), (x1, 1.0), (x0, 1.0)]
    positions = [(x, HEIGHT, z) for x, z in corners]
    uvs = [((x + 1) / 2, (z + 1) / 2) for x, z in corners]
    return positions, uvs, [0, 2, 1, 0, 3, 2]


def glb(parts, materials):
    """parts: (name, (positions, uvs, indices), material); the stripes PNG is image 0."""
    bin_, views, accessors, meshes = bytearray(), [], [], []

    def view(data, target=None):
        while len(bin_) % 4:
            bin_.append(0)
        v = {"buffer": 0, "byteOffset": len(bin_), "byteLength": len(data)}
        if target:
            v["target"] = target
        views.append(v)
        bin_.extend(data)
        return len(views) - 1

    stripes = [[(255, 255, 255, 255 if x % 2 == 0 else 0) for x in range(8)]]
    png = view(png_rgba(8, 1, stripes))
    for name, (positions, uvs, indices), material in parts:
        base = len(accessors)
        flat = [c for p in positions for c in p]
        lo = [min(p[k] for p in positions) for k in range(3)]
        hi = [max(p[k] for p in positions) for k in range(3)]
        accessors.append({"bufferView": view(struct.pack(f"<{len(flat)}f", *flat), 34962),
                          "count": len(positions), "type": "VEC3", "componentType": 5126,
                          "min": lo, "max": hi})
        normals = [0.0, 1.0, 0.0] * len(positions)
        accessors.append({"bufferView": view(struct.pack(f"<{len(normals)}f", *normals), 34962),
                          "count": len(positions), "type": "VEC3", "componentType": 5126})
        flat_uv = [c for uv in uvs for c in uv]
        accessors.append({"bufferView": view(struct.pack(f"<{len(flat_uv)}f", *flat_uv), 34962),
                          "count": len(uvs), "type": "VEC2", "componentType": 5126})
        accessors.append({"bufferView": view(struct.pack(f"<{len(indices)}I", *indices), 34963),
                          "count": len(indices), "type": "SCALAR", "componentType": 5125})
        meshes.append({"name": name, "primitives": [{
            "attributes": {"POSITION": base, "NORMAL": base + 1, "TEXCOORD_0": base + 2},
            "indices": base + 3, "material": material}]})
    while len(bin_) % 4:
        bin_.append(0)
    document = {
        "asset": {"version": "2.0", "generator": "scripts/gltf/cutout_card.py"},
        "scene": 0, "scenes": [{"nodes": list(range(len(meshes)))}],
        "nodes": [{"name": m["name"], "mesh": i} for i, m in enumerate(meshes)],
        "meshes": meshes, "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": len(bin_)}],
        "images": [{"bufferView": png, "mimeType": "image/png"}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987}],
        "textures": [{"source": 0, "sampler": 0}],
        "materials": materials,
    }
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(bin_)
    return (b"glTF" + struct.pack("<II", 2, total) + struct.pack("<I", len(text)) + b"JSON" + text
            + struct.pack("<I", len(bin_)) + b"BIN\0" + bytes(bin_))


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "scenes/cutout")
    out.mkdir(parents=True, exist_ok=True)
    grey = {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}}

    def leaf(mode):
        m = {"name": "stripes", "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}
        if mode == "MASK":
            m.update(alphaMode="MASK", alphaCutoff=0.5)
        return m

    card = glb([("floor", floor(), 0), ("card", card_part(-1.0, 1.0), 1)], [grey, leaf("MASK")])
    stripes = [(f"stripe {k}", card_part(-1.0 + 0.5 * k, -0.75 + 0.5 * k), 1) for k in range(4)]
    twin = glb([("floor", floor(), 0)] + stripes, [grey, leaf("OPAQUE")])
    (out / "card.glb").write_bytes(card)
    (out / "twin.glb").write_bytes(twin)


if __name__ == "__main__":
    main()
