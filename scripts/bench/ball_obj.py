#!/usr/bin/env python3
"""A UV sphere about the origin as OBJ on stdout: the ball whose occluder file
(`prt-bake bake ball.obj --occluder`) `make bench-view` moves over the Cornell lightmap.

usage: ball_obj.py RADIUS [RINGS SEGMENTS]
"""
import math
import sys

radius = float(sys.argv[1])
rings = int(sys.argv[2]) if len(sys.argv) > 2 else 12
segments = int(sys.argv[3]) if len(sys.argv) > 3 else 24
print("o ball")
print(f"v 0 0 {radius}")
for r in range(1, rings):
    theta = math.pi * r / rings
    for s in range(segments):
        phi = 2 * math.pi * s / segments
        x, y, z = math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)
        print(f"v {radius * x:.6f} {radius * y:.6f} {radius * z:.6f}")
print(f"v 0 0 {-radius}")
bottom = 2 + (rings - 1) * segments


def ring(r, s):
    """OBJ index of ring r (1..rings-1), segment s."""
    return 2 + (r - 1) * segments + s % segments


for s in range(segments):
    print(f"f 1 {ring(1, s)} {ring(1, s + 1)}")
    print(f"f {bottom} {ring(rings - 1, s + 1)} {ring(rings - 1, s)}")
for r in range(1, rings - 1):
    for s in range(segments):
        a, b = ring(r, s), ring(r, s + 1)
        c, d = ring(r + 1, s + 1), ring(r + 1, s)
        print(f"f {a} {d} {c}")
        print(f"f {a} {c} {b}")
