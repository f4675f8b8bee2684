#!/usr/bin/env python3
"""Subsurface references from Mitsuba 3's volumetric path tracer.

Writes the held-out translucent objects (tests/data/subsurface/*.obj) and, for each object
and boundary index, the radiance Mitsuba's `volpath` (variant scalar_rgb: llvm_ad_rgb aborted
on volumetric scenes on these machines) sees leaving the surface at one receiver vertex, along
its normal (a radiancemeter just outside, looking in), into tests/data/subsurface/references.json.
tests/subsurface_mitsuba.rs holds the bake's subsurface transfer to it.

Objects (σt per scene unit; single-scattering albedo 0.99, 0.9, 0.5 in R, G, B):
  * box     the cube [-1, 1]³, σt = 1, under a constant sky of radiance 1;
  * sphere  a UV sphere of radius 1 (48 × 24), σt = 1, constant sky;
  * slab    8 × 0.25 × 8 (normal +y on top), σt = 4 (optical thickness 1), lit from below
            only: L(ω) = max(−ω_y, 0); the receiver is the top face's centre.
each with an index-matched boundary (null BSDF, ior 1.0) and a dielectric one (ior 1.3).

What the bake's subsurface transfer holds is the light scattered at least once inside: the
specular reflection at the boundary and the unscattered light straight through are not in it.
Mitsuba's meter sees both, so each reference is the difference of two renders with the same
σt and boundary: the medium's albedo, minus albedo 0 (a purely absorbing medium, whose render
is exactly the reflection plus the unscattered light). The standard error is over batches of
independent seeds, both renders' errors added in quadrature.

Usage: subsurface_reference.py [--spp N] [--batches B] [--out DIR]
"""

import argparse
import json
import math
import os
import time

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
ALBEDO = [0.99, 0.9, 0.5]
IORS = [1.0, 1.3]


def grid_face(origin, a, b, n):
    """(n+1)² vertices origin + s·a + t·b and triangles wound so their normal is a × b."""
    origin, a, b = (np.asarray(x, float) for x in (origin, a, b))
    verts = [origin + (i / n) * a + (j / n) * b for i in range(n + 1) for j in range(n + 1)]
    tris = []
    for i in range(n):
        for j in range(n):
            v00, v10 = i * (n + 1) + j, (i + 1) * (n + 1) + j
            v01, v11 = v00 + 1, v10 + 1
            tris += [(v00, v10, v11), (v00, v11, v01)]
    return verts, tris


def cuboid(half):
    """An axis-aligned box of half-extents `half`, every face a 2 × 2 grid (a vertex at each
    face's centre), flat: its own vertices per face."""
    hx, hy, hz = half
    faces = [
        # origin, a, b with a × b outward
        ((-hx, -hy, hz), (2 * hx, 0, 0), (0, 2 * hy, 0)),  # +z
        ((-hx, hy, -hz), (2 * hx, 0, 0), (0, -2 * hy, 0)),  # -z
        ((hx, -hy, -hz), (0, 2 * hy, 0), (0, 0, 2 * hz)),  # +x
        ((-hx, hy, -hz), (0, -2 * hy, 0), (0, 0, 2 * hz)),  # -x
        ((hx, hy, -hz), (-2 * hx, 0, 0), (0, 0, 2 * hz)),  # +y
        ((-hx, -hy, -hz), (2 * hx, 0, 0), (0, 0, 2 * hz)),  # -y
    ]
    verts, tris, normals = [], [], []
    for origin, a, b in faces:
        v, t = grid_face(origin, a, b, 2)
        n = np.cross(a, b)
        n = n / np.linalg.norm(n)
        base = len(verts)
        verts += v
        normals += [n] * len(v)
        tris += [tuple(i + base for i in tri) for tri in t]
    return np.array(verts), np.array(normals), tris


def uv_sphere(radius, segments, rings):
    verts, tris = [], []
    for r in range(rings + 1):
        theta = math.pi * r / rings
        for s in range(segments):
            phi = 2 * math.pi * s / segments
            verts.append((math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)))
    for r in range(rings):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            c, d = a + segments, b + segments
            if r > 0:
                tris.append((a, c, b))
            if r < rings - 1:
                tris.append((b, c, d))
    verts = np.array(verts)
    # Pole rings are repeated points: keep them (degenerate triangles were skipped above).
    return verts * radius, verts, tris


def write_obj(path, name, verts, normals, tris):
    with open(path, "w") as f:
        f.write(f"# {name}: written by scripts/mitsuba/subsurface_reference.py\n")
        f.write(f"mtllib {name}.mtl\no {name}\n")
        for v in verts:
            f.write("v %.9g %.9g %.9g\n" % tuple(v))
        for n in normals:
            f.write("vn %.9g %.9g %.9g\n" % tuple(n))
        f.write(f"usemtl {name}\n")
        for t in tris:
            f.write("f %d//%d %d//%d %d//%d\n" % tuple(i + 1 for i in t for _ in (0, 1)))
    with open(path[:-4] + ".mtl", "w") as f:
        f.write(f"newmtl {name}\nKd 1 1 1\n")


def objects():
    """name → (verts, normals, tris, receiver vertex, σt, light)."""
    box = cuboid((1.0, 1.0, 1.0))
    sphere = uv_sphere(1.0, 48, 24)
    slab = cuboid((4.0, 0.125, 4.0))

    def find(verts, normals, point, normal):
        d = np.linalg.norm(verts - np.asarray(point), axis=1) + np.linalg.norm(normals - np.asarray(normal), axis=1)
        return int(np.argmin(d))

    return {
        "box": (*box, find(box[0], box[1], (0, 0, 1), (0, 0, 1)), 1.0, "sky"),
        "sphere": (*sphere, find(sphere[0], sphere[1], (1, 0, 0), (1, 0, 0)), 1.0, "sky"),
        "slab": (*slab, find(slab[0], slab[1], (0, 0.125, 0), (0, 1, 0)), 4.0, "below"),
    }


def below_envmap(mi):
    """L(ω) = max(−ω_y, 0): Mitsuba's lat-long maps rows to θ from +y (its up axis), so every
    row is constant and the columns' φ convention does not matter."""
    height, width = 512, 8
    theta = (np.arange(height) + 0.5) / height * math.pi
    row = np.maximum(-np.cos(theta), 0.0)
    data = np.repeat(row[:, None], width, axis=1)
    data = np.repeat(data[:, :, None], 3, axis=2).astype(np.float32)
    return {"type": "envmap", "bitmap": mi.Bitmap(data)}


def render(mi, obj_path, point, normal, sigma_t, albedo, ior, light, spp, seed):
    boundary = {"type": "null"} if ior == 1.0 else {"type": "dielectric", "int_ior": ior, "ext_ior": 1.0}
    emitter = {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}} if light == "sky" else below_envmap(mi)
    origin = np.asarray(point) + 1e-3 * np.asarray(normal)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": -1},
        "sensor": {
            "type": "radiancemeter",
            "origin": origin.tolist(),
            "direction": (-np.asarray(normal)).tolist(),
            "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "emitter": emitter,
        "object": {
            "type": "obj",
            "filename": obj_path,
            "face_normals": True,
            "bsdf": boundary,
            "interior": {
                "type": "homogeneous",
                "albedo": {"type": "rgb", "value": albedo},
                "sigma_t": sigma_t,
            },
        },
    })
    image = mi.render(scene, spp=spp, seed=seed)
    return np.array(image).reshape(-1)[:3].astype(float)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--spp", type=int, default=4096, help="paths per batch")
    parser.add_argument("--batches", type=int, default=8)
    parser.add_argument("--out", default=os.path.join(ROOT, "tests", "data", "subsurface"))
    parser.add_argument("--only", help="one object (box, sphere, slab)")
    args = parser.parse_args()

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    os.makedirs(args.out, exist_ok=True)
    references = []
    for name, (verts, normals, tris, receiver, sigma_t, light) in objects().items():
        if args.only and name != args.only:
            continue
        path = os.path.join(args.out, f"{name}.obj")
        write_obj(path, name, verts, normals, tris)
        point, normal = verts[receiver], normals[receiver]
        for ior in IORS:
            started = time.time()
            scattered, absorbed = [], []
            for b in range(args.batches):
                scattered.append(render(mi, path, point, normal, sigma_t, ALBEDO, ior, light, args.spp, 2 * b))
                absorbed.append(render(mi, path, point, normal, sigma_t, [0.0] * 3, ior, light, args.spp, 2 * b + 1))
            scattered, absorbed = np.array(scattered), np.array(absorbed)
            mean = scattered.mean(0) - absorbed.mean(0)
            se = np.sqrt(scattered.var(0, ddof=1) / args.batches + absorbed.var(0, ddof=1) / args.batches)
            references.append({
                "object": name,
                "ior": ior,
                "vertex": receiver,
                "point": [float(x) for x in point],
                "normal": [float(x) for x in normal],
                "sigma_t": sigma_t,
                "albedo": ALBEDO,
                "light": light,
                "radiance": mean.round(6).tolist(),
                "standard_error": se.round(6).tolist(),
                "unscattered_and_reflected": absorbed.mean(0).round(6).tolist(),
                "paths": args.spp * args.batches,
            })
            print(f"{name} ior {ior}: {mean.round(4)} ± {se.round(4)} "
                  f"(absorbing-only {absorbed.mean(0).round(4)}; {time.time() - started:.0f} s)", flush=True)
    if not args.only:
        with open(os.path.join(args.out, "references.json"), "w") as f:
            json.dump({"generator": "scripts/mitsuba/subsurface_reference.py", "mitsuba": mi.__version__,
                       "variant": "scalar_rgb", "references": references}, f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
