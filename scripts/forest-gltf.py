#!/usr/bin/env python3
"""Writes a glTF of a ground under N instances of one tree-like mesh (a forest):
a 1,792-triangle mesh referenced by N nodes, and a ground quad grid. The bench for
`bake --receivers Ground` (docs/explanation/performance.md, "Receivers"); no file is committed.

    python3 scripts/forest-gltf.py N OUT.gltf [--grid G]
"""
import base64, json, math, struct, sys


def tree():
    """A cone of 32 segments × 28 rings: 32·28·2 = 1,792 triangles."""
    segments, rings = 32, 28
    positions = []
    for r in range(rings + 1):
        y = 0.2 + 2.0 * r / rings
        radius = 0.6 * (1.0 - r / (rings + 1))
        for s in range(segments):
            a = 2 * math.pi * s / segments
            positions.append((radius * math.cos(a), y, radius * math.sin(a)))
    triangles = []
    for r in range(rings):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            c, d = a + segments, b + segments
            triangles += [(a, c, b), (b, c, d)]
    return positions, triangles


def ground(extent, grid):
    positions = [(extent * (2 * i / grid - 1), 0.0, extent * (2 * j / grid - 1))
                 for j in range(grid + 1) for i in range(grid + 1)]
    triangles = []
    for j in range(grid):
        for i in range(grid):
            a = j * (grid + 1) + i
            triangles += [(a, a + grid + 1, a + 1), (a + 1, a + grid + 1, a + grid + 2)]
    return positions, triangles


def main():
    n, out = int(sys.argv[1]), sys.argv[2]
    grid = int(sys.argv[sys.argv.index("--grid") + 1]) if "--grid" in sys.argv else 64
    side = math.ceil(math.sqrt(n))
    extent = side * 1.5 / 2 + 2
    meshes, accessors, views, blob = [], [], [], bytearray()
    for positions, triangles in (ground(extent, grid), tree()):
        lo = [min(p[k] for p in positions) for k in range(3)]
        hi = [max(p[k] for p in positions) for k in range(3)]
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": 12 * len(positions)})
        blob += b"".join(struct.pack("<3f", *p) for p in positions)
        accessors.append({"bufferView": len(views) - 1, "componentType": 5126,
                          "count": len(positions), "type": "VEC3", "min": lo, "max": hi})
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": 12 * len(triangles)})
        blob += b"".join(struct.pack("<3I", *t) for t in triangles)
        accessors.append({"bufferView": len(views) - 1, "componentType": 5125,
                          "count": 3 * len(triangles), "type": "SCALAR"})
        meshes.append({"primitives": [{"attributes": {"POSITION": len(accessors) - 2},
                                       "indices": len(accessors) - 1}]})
    nodes = [{"name": "Ground", "mesh": 0}, {"name": "Forest", "children": list(range(2, n + 2))}]
    for k in range(n):
        x, z = (k % side - side / 2) * 1.5, (k // side - side / 2) * 1.5
        nodes.append({"name": f"tree{k}", "mesh": 1, "translation": [x, 0.0, z]})
    document = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
        "nodes": nodes, "meshes": meshes, "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    with open(out, "w") as f:
        json.dump(document, f)


if __name__ == "__main__":
    main()
