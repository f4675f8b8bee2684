#!/usr/bin/env python3
"""Writes the large-scene benchmark's scene (scripts/bench-large.sh): a glTF 2.0 terrain of
N×N quads (2·N² triangles; N = 708 gives 1,002,528) with hills and pits, so its texels shadow
and light each other, and its own lightmap UVs (TEXCOORD_1: the terrain's plane, one chart
filling the atlas), so the bake needs no unwrap of a million triangles.

    large_scene.py OUT.gltf [N [RELIEF]]

RELIEF scales the heights (default 4: slopes of several units, so many bounce rays hit).

Writes OUT.gltf and OUT.bin beside it. Standard library only (no NumPy on a fresh machine).
"""
import json
import math
import struct
import sys
from array import array
from pathlib import Path


RELIEF = 4.0


def height(x, y):
    """Hills and pits over [0, 1]²: a few octaves of sines, up to about 0.08 × RELIEF high."""
    return RELIEF * 0.04 * math.sin(11.0 * x) * math.cos(9.0 * y) + 0.025 * math.sin(
        37.0 * x + 3.0 * y
    ) * math.sin(29.0 * y) * RELIEF + RELIEF * 0.012 * math.cos(91.0 * x) * math.sin(83.0 * y)


def main():
    # `--help` is not a file name: asked for, the usage goes to standard output; any other
    # option or a wrong count of arguments is a usage error (exit 2) before anything is written.
    if sys.argv[1:] in (["-h"], ["--help"]):
        print(__doc__)
        sys.exit(0)
    if len(sys.argv) < 2 or len(sys.argv) > 4 or any(a.startswith("-") for a in sys.argv[1:]):
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    out = Path(sys.argv[1])
    global RELIEF
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 708
    RELIEF = float(sys.argv[3]) if len(sys.argv) > 3 else RELIEF
    m = n + 1
    positions, normals, uv0, uv1 = array("f"), array("f"), array("f"), array("f")
    eps = 1.0 / n
    for j in range(m):
        y = j / n
        for i in range(m):
            x = i / n
            z = height(x, y)
            positions.extend((x, z, -y))  # glTF is y-up: the terrain lies in x–z
            dx = (height(x + eps, y) - height(x - eps, y)) / (2 * eps)
            dy = (height(x, y + eps) - height(x, y - eps)) / (2 * eps)
            # Normal of (x, h, -y): the cross product of the two tangents, upwards.
            nx, ny, nz = -dx, 1.0, dy
            length = math.sqrt(nx * nx + ny * ny + nz * nz)
            normals.extend((nx / length, ny / length, nz / length))
            uv0.extend((x, y))
            # TEXCOORD_1 in glTF's convention (v down from the top); prt-bake flips it.
            uv1.extend((x, 1.0 - y))
    indices = array("I")
    for j in range(n):
        for i in range(n):
            a = j * m + i
            b, c, d = a + 1, a + m, a + m + 1
            # Counter-clockwise seen from above (+y).
            indices.extend((a, b, c, b, d, c))
    blobs = [positions.tobytes(), normals.tobytes(), uv0.tobytes(), uv1.tobytes(), indices.tobytes()]
    offsets, at = [], 0
    for blob in blobs:
        offsets.append(at)
        at += len(blob)
    lo = [min(positions[k::3]) for k in range(3)]
    hi = [max(positions[k::3]) for k in range(3)]
    vertex_count, index_count = m * m, len(indices)
    views = [
        {"buffer": 0, "byteOffset": o, "byteLength": len(b), "target": 34962 if k < 4 else 34963}
        for k, (o, b) in enumerate(zip(offsets, blobs))
    ]
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": vertex_count, "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": 5126, "count": vertex_count, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": vertex_count, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5126, "count": vertex_count, "type": "VEC2"},
        {"bufferView": 4, "componentType": 5125, "count": index_count, "type": "SCALAR"},
    ]
    gltf = {
        "asset": {"version": "2.0", "generator": "prt scripts/bench/large_scene.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "TEXCOORD_1": 3},
            "indices": 4,
            "material": 0,
        }]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0]}}],
        "buffers": [{"uri": out.with_suffix(".bin").name, "byteLength": at}],
        "bufferViews": views,
        "accessors": accessors,
    }
    with open(out.with_suffix(".bin"), "wb") as f:
        for blob in blobs:
            f.write(blob)
    out.write_text(json.dumps(gltf))
    print(f"{out}: {vertex_count} vertices, {index_count // 3} triangles")


if __name__ == "__main__":
    main()
