"""Compares prt-bake's texel AO of the Blender scene with Cycles' own AO bake, and counts
the texels that triangles of two objects share in prt-bake's atlas.

    python compare_ao.py OUT_DIR BAKE.prt [--objects Floor,Suzanne] [--max-mean 0.01]
        [--max-rms-ratio 1.5] [--glb OUT_DIR/scene.glb]

OUT_DIR is make_scene.py's (scene.glb, ao_<Name>.f32, cycles.json). Objects are found in
the GLB (default scene's nodes depth first, as prt-bake orders them); their triangles' atlas
UVs are BAKE.prt's; the texels shared are counted in that atlas and, for the "before"
figure, in the GLB's TEXCOORD_1 used as one atlas, as prt-bake used it before it packed objects' UVs apart. For every baked texel whose centre lies inside a triangle of the object
(so prt-bake's sample point is the centre), the object's own lightmap UV there is
(atlas uv - offset) / scale (the file's per-object placement), and Cycles' image is read
bilinearly at it (Blender's image row 0 is v = 0, as the .prt's UVs). Reported per object:
mean and rms of prt - Cycles over all those texels, and over the "smooth" ones (Cycles' AO
varies by at most 0.1 over the texel's footprint: elsewhere, in contact shadows, a point
sample at the texel's centre and Cycles' area-averaged, interpolated pixels differ by more
than noise) the rms expected from the two estimators' noise alone,
sqrt(mean(a(1-a) * (sum w^2 / spp_cycles + 1 / spp_prt))) (binomial variance of an AO
estimate of a texel with accessibility a; sum w^2 the bilinear weights'); both bakes use
low-discrepancy sequences, so that is an upper bound for their noise. Passes if
|mean| <= --max-mean over all texels and the smooth texels' rms <= --max-rms-ratio x their
expected rms. Exits 1 on a failure.
"""

import argparse
import json
import struct
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python"))
from prt import read_prt  # noqa: E402


def glb_objects(path):
    """(name, triangle count, TEXCOORD_1 per triangle corner with v up) per object, in
    prt-bake's scene order."""
    b = Path(path).read_bytes()
    n = struct.unpack("<I", b[12:16])[0]
    j = json.loads(b[20:20 + n])
    bin_start = 20 + n + 8

    def accessor(i):
        a = j["accessors"][i]
        view = j["bufferViews"][a["bufferView"]]
        start = bin_start + view.get("byteOffset", 0) + a.get("byteOffset", 0)
        dtype = {5121: "<u1", 5123: "<u2", 5125: "<u4", 5126: "<f4"}[a["componentType"]]
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[a["type"]]
        return np.frombuffer(b, dtype, a["count"] * width, start).reshape(a["count"], width)

    out = []
    stack = list(reversed(j["scenes"][j.get("scene", 0)]["nodes"]))
    while stack:
        i = stack.pop()
        node = j["nodes"][i]
        if "mesh" in node:
            mesh = j["meshes"][node["mesh"]]
            prims = mesh["primitives"]
            for k, p in enumerate(prims):
                indices = accessor(p["indices"]).reshape(-1, 3)
                uv = accessor(p["attributes"]["TEXCOORD_1"]).astype(np.float64) * [1, -1] + [0, 1]
                name = node.get("name") or mesh.get("name") or f"node {i}"
                out.append((name if len(prims) == 1 else f"{name}/{k}", len(indices), uv[indices]))
        stack.extend(reversed(node.get("children", [])))
    return out


def centres_inside(tri, w, h):
    """Row-major texel indices whose centres lie strictly inside the triangle (in texels)."""
    lo = np.maximum(np.floor(tri.min(0)), 0).astype(int)
    hi = np.minimum(np.ceil(tri.max(0)), [w, h]).astype(int)
    if np.any(hi <= lo):
        return np.zeros(0, int)
    xs, ys = np.meshgrid(np.arange(lo[0], hi[0]) + 0.5, np.arange(lo[1], hi[1]) + 0.5)
    q = np.stack([xs.ravel(), ys.ravel()], 1)
    area = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    if area == 0:
        return np.zeros(0, int)
    inside = np.ones(len(q), bool)
    for k in range(3):
        a, b = tri[k], tri[(k + 1) % 3]
        inside &= np.sign(area) * np.cross(b - a, q - a) > 1e-3
    q = q[inside] - 0.5
    return q[:, 1].astype(int) * w + q[:, 0].astype(int)


def overlaps(tri, w, h):
    """Texels the triangle overlaps with positive area (separating axes), as the bake's
    conservative rasterisation."""
    lo = np.maximum(np.floor(tri.min(0)), 0).astype(int)
    hi = np.minimum(np.ceil(tri.max(0)), [w, h]).astype(int)
    if np.any(hi <= lo) or np.cross(tri[1] - tri[0], tri[2] - tri[0]) == 0:
        return np.zeros(0, int)
    xs, ys = np.meshgrid(np.arange(lo[0], hi[0]), np.arange(lo[1], hi[1]))
    x, y = xs.ravel().astype(float), ys.ravel().astype(float)
    ok = np.ones(len(x), bool)
    squares = np.stack([np.stack([x, y], 1), np.stack([x + 1, y], 1),
                        np.stack([x + 1, y + 1], 1), np.stack([x, y + 1], 1)], 1)
    axes = [np.array([1.0, 0]), np.array([0, 1.0])]
    axes += [np.array([-(tri[(k + 1) % 3] - tri[k])[1], (tri[(k + 1) % 3] - tri[k])[0]]) for k in range(3)]
    for axis in axes:
        t = tri @ axis
        s = squares @ axis
        ok &= np.maximum(t.min(), s.min(1)) < np.minimum(t.max(), s.max(1))
    return (y[ok].astype(int) * w + x[ok].astype(int))


def shared_texels(uv1, w, h, objects):
    """Texels overlapped (positive area) by triangles of two or more objects."""
    owner = np.zeros(w * h, int)
    shared = np.zeros(w * h, bool)
    t = 0
    for k, (_, count, _) in enumerate(objects):
        mine = np.zeros(w * h, bool)
        for tri in uv1[t:t + count]:
            if np.any(tri < 0):
                continue
            mine[overlaps(tri.astype(np.float64) * [w, h], w, h)] = True
        shared |= mine & (owner > 0)
        owner[mine] = k + 1
        t += count
    return int(shared.sum())


def bilinear(image, q):
    """Image (rows = v) read bilinearly at uv q (N, 2); returns values and sum of w^2."""
    n = image.shape[0]
    p = q * n - 0.5
    p0 = np.clip(np.floor(p).astype(int), 0, n - 2)
    t = np.clip(p - p0, 0, 1)
    wts = [(1 - t[:, 0]) * (1 - t[:, 1]), t[:, 0] * (1 - t[:, 1]), (1 - t[:, 0]) * t[:, 1], t[:, 0] * t[:, 1]]
    vals = (wts[0] * image[p0[:, 1], p0[:, 0]] + wts[1] * image[p0[:, 1], p0[:, 0] + 1]
            + wts[2] * image[p0[:, 1] + 1, p0[:, 0]] + wts[3] * image[p0[:, 1] + 1, p0[:, 0] + 1])
    return vals, sum(wi * wi for wi in wts)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("bake")
    p.add_argument("--objects", default="Floor,Suzanne")
    p.add_argument("--max-mean", type=float, default=0.01)
    p.add_argument("--max-rms-ratio", type=float, default=1.5)
    p.add_argument("--glb", help="the baked scene (default OUT_DIR/scene.glb)")
    a = p.parse_args()
    out = Path(a.out)
    info = json.loads((out / "cycles.json").read_text())
    objects = glb_objects(a.glb or out / "scene.glb")
    f = read_prt(a.bake)
    lm = f.lightmap
    assert sum(c for _, c, _ in objects) == lm.scene_triangle_count, "the GLB's triangles are not the bake's"
    own = np.concatenate([uv for _, _, uv in objects])
    report = {"objects": [n for n, _, _ in objects], "atlas": lm.source,
              "resolution": lm.width, "samples_prt": f.header["samples_per_vertex"],
              "samples_cycles": info["samples"], "cycles_resolution": info["resolution"],
              "shared_texels_as_one_atlas": shared_texels(own, lm.width, lm.height, objects),
              "shared_texels": shared_texels(lm.uv1, lm.width, lm.height, objects)}
    ok = report["shared_texels"] == 0
    w, h = lm.width, lm.height
    ao = f.ao.ravel()
    valid = lm.valid.ravel()
    starts = np.cumsum([0] + [c for _, c, _ in objects])
    for k, (name, count, _) in enumerate(objects):
        if name not in a.objects.split(","):
            continue
        cycles_path = out / f"ao_{name.split('/')[0]}.f32"  # a primitive of the object
        if not cycles_path.exists():
            continue
        n = info["resolution"]
        cycles = np.fromfile(cycles_path, "<f4").reshape(n, n)
        texels = set()
        for tri in lm.uv1[starts[k]:starts[k + 1]]:
            if np.any(tri < 0):
                continue
            texels.update(centres_inside(tri.astype(np.float64) * [w, h], w, h).tolist())
        texels = np.array(sorted(i for i in texels if valid[i]))
        centre = np.stack([(texels % w + 0.5) / w, (texels // w + 0.5) / h], 1)
        if lm.objects:
            place = lm.objects[k]
            own = (centre - np.array(place["offset"])) / np.array(place["scale"])
        else:
            own = centre
        theirs, w2 = bilinear(cycles, own)
        # How much Cycles' AO varies over the texel's footprint (its corners and centre):
        # where it changes steeply (contact shadows), a point at the texel's centre and
        # Cycles' pixels (averaged over their area, then interpolated) differ by more than
        # noise, so the noise criterion is judged on the texels where it varies by <= 0.1.
        scale = np.array(lm.objects[k]["scale"]) if lm.objects else np.ones(2)
        corners = [bilinear(cycles, own + np.array(c) / w / scale)[0]
                   for c in ((-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5))]
        spread = np.ptp(np.stack(corners + [theirs]), axis=0)
        smooth = spread <= 0.1
        mine = ao[texels]
        d = mine - theirs
        a_mean = np.clip((mine + theirs) / 2, 0, 1)
        noise = a_mean * (1 - a_mean) * (w2 / info["samples"] + 1 / report["samples_prt"])
        expected = float(np.sqrt(np.mean(noise[smooth])))
        stats = {"texels": int(len(texels)), "mean_prt": float(mine.mean()), "mean_cycles": float(theirs.mean()),
                 "mean_diff": float(d.mean()), "rms_diff": float(np.sqrt(np.mean(d * d))),
                 "p99_abs_diff": float(np.percentile(np.abs(d), 99)),
                 "smooth_texels": int(smooth.sum()), "smooth_mean_diff": float(d[smooth].mean()),
                 "smooth_rms_diff": float(np.sqrt(np.mean(d[smooth] ** 2))), "smooth_expected_rms_noise": expected,
                 "steep_rms_diff": float(np.sqrt(np.mean(d[~smooth] ** 2))) if (~smooth).any() else 0.0,
                 "cycles_seconds": info["bake_seconds"].get(name)}
        stats["pass"] = bool(abs(stats["mean_diff"]) <= a.max_mean
                             and stats["smooth_rms_diff"] <= a.max_rms_ratio * expected)
        ok &= stats["pass"]
        report[name] = stats
    print(json.dumps(report, indent=1))
    if not ok:
        print("compare_ao: FAILED (shared texels, or AO outside Cycles' noise)", file=sys.stderr)
        sys.exit(1)


main()
