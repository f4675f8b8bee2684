"""Compares the add-on's "PRT" with the CLI's export of the same scene (make blender-addon's check).

    python compare_cli.py OUT_DIR [--max-mean 0.03] [--min-correlation 0.98]

OUT_DIR holds test_addon.py's addon.npz and the CLI's cli0.glb, cli90.glb and cliir.glb:
`prt-bake export --gltf --lights RIG` of Blender's own glTF export of the scene, lit by the
rig and by the rig turned 90° about +Z, and an interreflected bake's lit by the rig ("ir"). The CLI's relit radiance is baseColorFactor ×
COLOR_0 (COLOR_0 = Σ T·L clamped to [0, 1]); the add-on's is "PRT" = albedo × Σ T·L,
clamped the same way. Each CLI vertex is matched to the add-on's face corners of the same
world position and normal (the glTF is +Y up: Blender's (x, y, z) is the file's (x, −z, y)).
Per object and light: the mean over the matched vertices of the grey radiance (mean of R,
G, B) must agree within --max-mean (relative), and the per-vertex correlation be at least
--min-correlation. Prints a table and writes OUT_DIR/compare.json; exits 1 on a failure.
"""

import argparse
import json
import struct
import sys
from pathlib import Path

import numpy as np


def read_glb(path):
    """Per object name: (positions, normals, COLOR_0, baseColorFactor rgb) of its
    primitives."""
    b = Path(path).read_bytes()
    n = struct.unpack("<I", b[12:16])[0]
    j = json.loads(b[20:20 + n])
    binary = 20 + n + 8

    def accessor(i):
        a = j["accessors"][i]
        view = j["bufferViews"][a["bufferView"]]
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a["type"]]
        dtype = {5121: "<u1", 5123: "<u2", 5125: "<u4", 5126: "<f4"}[a["componentType"]]
        start = binary + view.get("byteOffset", 0) + a.get("byteOffset", 0)
        return np.frombuffer(b, dtype, a["count"] * width, start).reshape(a["count"], width)

    out = {}
    for node in j["nodes"]:
        if "mesh" not in node:
            continue
        for p in j["meshes"][node["mesh"]]["primitives"]:
            attributes = p["attributes"]
            factor = j["materials"][p["material"]]["pbrMetallicRoughness"].get(
                "baseColorFactor", [1, 1, 1, 1])
            part = (accessor(attributes["POSITION"]).astype(np.float64),
                    accessor(attributes["NORMAL"]).astype(np.float64),
                    accessor(attributes["COLOR_0"])[:, :3].astype(np.float64),
                    np.array(factor[:3]))
            # prt-bake exports a mesh of several primitives as objects "name/0", "name/1", …
            out.setdefault(node["name"].split("/")[0], []).append(part)
    return out


def match(position, normal, corner_position, corner_normal):
    """Per CLI vertex, the add-on's corner at the same position (within 1e-4 of the scene's
    size) with the closest normal (within 2.6°), or -1."""
    tolerance = 1e-4 * (1 + np.abs(corner_position).max())
    out = np.full(len(position), -1)
    for start in range(0, len(position), 256):
        p, n = position[start:start + 256], normal[start:start + 256]
        distance = np.linalg.norm(p[:, None, :] - corner_position[None], axis=2)
        cosine = n @ corner_normal.T
        score = np.where(distance <= tolerance, cosine, -2.0)
        best = score.argmax(1)
        found = score[np.arange(len(p)), best] >= 0.999
        out[start:start + 256] = np.where(found, best, -1)
    return out


def main():
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--max-mean", type=float, default=0.03)
    p.add_argument("--min-correlation", type=float, default=0.98)
    a = p.parse_args()
    out = Path(a.out)
    addon = np.load(out / "addon.npz")
    names = sorted({k.split("/")[0] for k in addon.files})
    results, failed, matches = {}, False, {}
    print(f"{'object':<9} {'light':<5} {'vertices':>8} {'matched':>8} {'CLI mean':>9} "
          f"{'add-on':>9} {'diff':>7} {'corr':>7}")
    for turn in ("0", "90", "ir"):
        cli = read_glb(out / f"cli{turn}.glb")
        for name in names:
            ours_all = np.clip(addon[f"{name}/prt{turn}"] / addon[f"{name}/albedo"], 0, 1) \
                * addon[f"{name}/albedo"]
            theirs, ours, total = [], [], 0
            for k, (position, normal, color, factor) in enumerate(cli[name]):
                blender_position = position[:, [0, 2, 1]] * [1, -1, 1]
                blender_normal = normal[:, [0, 2, 1]] * [1, -1, 1]
                # The three files export the same scene.glb: the same vertices, matched once.
                if (name, k) not in matches:
                    matches[name, k] = match(blender_position, blender_normal,
                                             addon[f"{name}/position"], addon[f"{name}/normal"])
                corner = matches[name, k]
                total += len(corner)
                theirs.extend(color[corner >= 0] * factor)
                ours.extend(ours_all[corner[corner >= 0]])
            theirs, ours = np.array(theirs).mean(1), np.array(ours).mean(1)
            diff = ours.mean() / theirs.mean() - 1
            corr = float(np.corrcoef(theirs, ours)[0, 1])
            ok = (len(theirs) >= 0.99 * total and abs(diff) <= a.max_mean
                  and corr >= a.min_correlation)
            failed |= not ok
            results[f"{name}/{turn}"] = {"vertices": total, "matched": len(theirs),
                                         "cli_mean": float(theirs.mean()),
                                         "addon_mean": float(ours.mean()),
                                         "relative_difference": float(diff),
                                         "correlation": corr, "ok": bool(ok)}
            print(f"{name:<9} {turn + ('' if turn == 'ir' else '°'):<5} {total:>8} {len(theirs):>8} {theirs.mean():>9.4f} "
                  f"{ours.mean():>9.4f} {100 * diff:>6.2f}% {corr:>7.4f}"
                  f"{'' if ok else '  FAIL'}")
    (out / "compare.json").write_text(json.dumps(results, indent=1))
    sys.exit(1 if failed else 0)


main()
