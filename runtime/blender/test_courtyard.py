"""The production courtyard through the add-on against the CLI (make blender-addon).

    BLENDER_USER_RESOURCES=DIR python test_courtyard.py ZIP PRT_BAKE RIG RIG90 OUT_DIR
        [--samples 1024] [--order 3]

Builds the courtyard as scripts/blender/make_production.py does (alpha-clipped foliage
cards, a normal-mapped wall, a crate and four linked duplicates of it), exports it with the
add-on's exporter settings (export.EXPORT_SETTINGS) for the CLI, and bakes it through
bpy.ops.prt.bake. The CLI bakes that export (`prt-bake bake --double-sided off`, the same
seed, samples and order) and its relit radiance per vertex is albedo × Σ T·L, L = `prt-bake
light RIG --up y`. Per object, each CLI vertex is matched to the add-on's face corners of the
same world position and normal, and the add-on's "PRT" (under the rig, and with Light
rotation 90° against RIG90) must be within 2 % of the CLI's at ≥ 99 % of the vertices.

Then each feature is switched off once in the add-on's scene (the exported GLB edited
before the bake: cut-outs opaque, base-colour textures dropped, the linked duplicates left
out as the old add-on did) and the same comparison must fail. (Normal maps: vertex bakes
ignore them, so they are switched off in the lightmap part only.)

Lightmaps: the same, texel by texel, against the CLI's bake of Blender's export whose
lightmap UVs the test moved into the add-on's tiles in Blender (texels(), below).
Writes OUT_DIR/courtyard.json; exits through os._exit (bpy can hang in its exit handlers).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import traceback
from pathlib import Path

import bpy
import numpy as np

from test_addon import corner_frames  # (this folder: the script's own)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
checks = {}


def check(name, ok, detail=""):
    checks[name] = {"ok": bool(ok), "detail": detail}
    print(f"{'ok  ' if ok else 'FAIL'} {name} {detail}", flush=True)


def build():
    """make_production.py's scene (its main() left out)."""
    sys.path.insert(0, str(ROOT / "scripts" / "blender"))
    source = (ROOT / "scripts" / "blender" / "make_production.py").read_text()
    namespace = {"__name__": "make_production"}
    exec(compile(source.rsplit("\nmain()", 1)[0], "make_production.py", "exec"), namespace)
    return namespace["build"]()


def light(bake, rig, order, up):
    out = subprocess.run([bake, "light", rig, "--order", str(order), "--up", up, "-o", "-"],
                         capture_output=True, text=True, check=True).stdout
    return np.array(json.loads(out)["coefficients"], np.float64)


def cli_objects(module, glb_path, npz_path):
    """Per node name of the CLI's bake: (positions, normals, albedo, transfer), Blender's
    frame for positions and normals, every node flattened in prt-bake's order."""
    gltf_scene = sys.modules[module + ".gltf_scene"]
    glb = gltf_scene.Glb(glb_path)
    with np.load(npz_path) as f:
        arrays = {k: np.asarray(f[k], np.float64) for k in
                  ("positions", "normals", "albedo", "transfer")}
    turn = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)
    out, cursor = {}, 0
    for index, _, _ in gltf_scene.walk(glb.json):
        node = glb.json["nodes"][index]
        if "mesh" not in node:
            continue
        count = sum(c for c, _ in gltf_scene.triangle_primitives(glb, index))
        part = {k: v[cursor:cursor + count] for k, v in arrays.items()}
        part["positions"] = part["positions"] @ turn.T
        part["normals"] = part["normals"] @ turn.T
        out[node["name"]] = part
        cursor += count
    # Back sheets (--double-sided auto) follow every node's vertices.
    assert cursor <= len(arrays["positions"]), (cursor, len(arrays["positions"]))
    return out


def corners(obj):
    """Per face corner: world position, world normal, and the mean of "PRT"'s channels."""
    position, normal, prt = corner_frames(obj)
    return position, normal, prt.mean(1)


def match(position, normal, corner_position, corner_normal):
    """Per CLI vertex the add-on's corner at its position with its normal, or -1."""
    tolerance = 1e-4 * (1 + np.abs(corner_position).max())
    out = np.full(len(position), -1)
    for start in range(0, len(position), 256):
        p, n = position[start:start + 256], normal[start:start + 256]
        distance = np.linalg.norm(p[:, None, :] - corner_position[None], axis=2)
        score = np.where(distance <= tolerance, n @ corner_normal.T, -2.0)
        best = score.argmax(1)
        out[start:start + 256] = np.where(score[np.arange(len(p)), best] >= 0.999, best, -1)
    return out


def compare(objects, cli, lights, turns):
    """{object/turn: fraction of its CLI vertices within 2 %} and whether all pass."""
    out, ok = {}, True
    for turn_name, angle in turns:
        bpy.context.scene.prt.light_rotation = angle  # relights
        for obj in objects:
            c = cli[obj.name]
            theirs = (c["albedo"] * np.einsum("vcj,cj->vc", c["transfer"],
                                              lights[turn_name])).mean(1)
            position, normal, ours = corners(obj)
            corner = match(c["positions"], c["normals"], position, normal)
            found = corner >= 0
            difference = np.abs(ours[corner[found]] - theirs[found])
            close = difference <= 0.02 * np.abs(theirs[found]) + 1e-4
            fraction = close.sum() / len(theirs)
            out[f"{obj.name}/{turn_name}"] = {
                "vertices": len(theirs), "matched": int(found.sum()),
                "within_2_percent": float(fraction),
                "worst_ratio": float(np.max(np.abs(ours[corner[found]] + 1e-6) /
                                            (np.abs(theirs[found]) + 1e-6)))}
            ok &= fraction >= 0.99
    bpy.context.scene.prt.light_rotation = 0.0
    return out, ok


def strip(kind):
    """An edit of the add-on's exported GLB that switches one feature off."""
    def edit(document, receivers):
        for m in document.get("materials", []):
            if kind == "cutouts":
                m.pop("alphaMode", None)
                m.pop("alphaCutoff", None)
            if kind == "normalmaps":
                m.pop("normalTexture", None)
            if kind == "textures":
                m.get("pbrMetallicRoughness", {}).pop("baseColorTexture", None)
        if kind == "instances":  # the old add-on: shared meshes' other nodes left out
            keep = {r.node for r in receivers}
            for holder in [*document["scenes"], *document["nodes"]]:
                key = "nodes" if "nodes" in holder and holder in document["scenes"] else "children"
                if key in holder:
                    holder[key] = [i for i in holder[key] if i in keep
                                   or "mesh" not in document["nodes"][i]]
    return edit


def main():
    p = argparse.ArgumentParser()
    for name in ("zip", "prt_bake", "rig", "rig90", "out"):
        p.add_argument(name)
    p.add_argument("--samples", type=int, default=1024)
    p.add_argument("--order", type=int, default=3)
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    objects = build()
    bpy.ops.extensions.package_install_files(filepath=a.zip, repo="user_default",
                                             enable_on_install=True)
    module = next(m for m in sys.modules if m.endswith("prt_bake"))
    bpy.context.preferences.addons[module].preferences.prt_bake = a.prt_bake
    export = sys.modules[module + ".export"]
    glb = str(out / "courtyard.glb")
    bpy.ops.export_scene.gltf(filepath=glb, **export.EXPORT_SETTINGS)
    seed = 0
    subprocess.run([a.prt_bake, "bake", glb, "-o", str(out / "cli.prt"), "--double-sided",
                    "off", "--samples", str(a.samples), "--order", str(a.order), "--seed",
                    str(seed), "--quiet"], check=True)
    subprocess.run([a.prt_bake, "export", str(out / "cli.prt"), "--scene", glb, "--npz",
                    str(out / "cli.npz")], check=True, capture_output=True)
    cli = cli_objects(module, glb, str(out / "cli.npz"))
    lights = {"0": light(a.prt_bake, a.rig, a.order, "y"),
              "90": light(a.prt_bake, a.rig90, a.order, "y")}
    turns = [("0", 0.0), ("90", math.pi / 2)]

    def bake():
        return bpy.ops.prt.bake(rig=a.rig, samples=a.samples, order=a.order, seed=seed)

    result = bake()
    warnings = json.loads(bpy.context.scene.prt.last_warnings)
    figures, ok = compare(objects, cli, lights, turns)
    worst = min(figures.items(), key=lambda kv: kv[1]["within_2_percent"])
    check("courtyard: the add-on against the CLI per vertex, every object, at the rig and "
          "turned 90°", result == {"FINISHED"} and ok,
          f"{len(figures)} object/light pairs, the worst {worst[0]}: "
          f"{100 * worst[1]['within_2_percent']:.2f} % within 2 %")
    check("courtyard: linked duplicates baked each with a mesh of its own",
          len({o.data.name for o in objects if o.name.startswith("Crate")}) == 5
          and sum("given a copy of its own" in w for w in warnings) == 4, warnings)
    report = {"addon": figures, "warnings": warnings, "switched_off": {}}

    # Double-sided auto: prt-bake adds back sheets (after every node); the fronts still match.
    subprocess.run([a.prt_bake, "bake", glb, "-o", str(out / "cli-ds.prt"), "--double-sided",
                    "auto", "--samples", str(a.samples), "--order", str(a.order), "--seed",
                    str(seed), "--quiet"], check=True)
    subprocess.run([a.prt_bake, "export", str(out / "cli-ds.prt"), "--scene", glb, "--npz",
                    str(out / "cli-ds.npz")], check=True, capture_output=True)
    bpy.context.scene.prt.double_sided = "auto"
    result = bake()
    bpy.context.scene.prt.double_sided = "off"
    figures_ds, ok = compare(objects, cli_objects(module, glb, str(out / "cli-ds.npz")), lights,
                             turns)
    worst = min(figures_ds.values(), key=lambda v: v["within_2_percent"])["within_2_percent"]
    check("courtyard, double-sided auto: the fronts against the CLI's", result == {"FINISHED"}
          and ok, f"the worst object {100 * worst:.2f} % within 2 %")
    report["double_sided_auto"] = figures_ds

    # Each feature switched off once: the same comparison must fail.
    original = export.export_scene
    # Normal maps are not switched off here: vertex bakes ignore normalTexture (one normal
    # per vertex; docs/guides/lightmaps.md "Normal maps"), so a vertex comparison cannot see them.
    for kind in ("cutouts", "textures", "instances"):
        def patched(context, path, kind=kind):
            if kind == "instances":
                for o in objects[-4:]:
                    o.prt_receive = False
            plan = original(context, path)
            strip(kind)(plan.glb.json, plan.receivers)
            plan.glb.write(path)
            return plan
        export.export_scene = patched
        try:
            result = bake()
        finally:
            export.export_scene = original
            for o in objects:
                o.prt_receive = True
        if kind == "instances":
            stale = json.loads(bpy.context.scene.prt.last_warnings)
            check("courtyard: objects no longer receiving lose their earlier results",
                  all("prt_T00" not in o.data.attributes and "PRT" not in o.data.attributes
                      for o in objects[-4:]) and
                  sum("its earlier PRT results removed" in w for w in stale) == 4,
                  [w for w in stale if "earlier" in w])
        present = [o for o in objects if kind != "instances" or o not in objects[-4:]]
        figures, ok = compare(present, cli, lights, turns)
        failing = {k: round(100 * v["within_2_percent"], 1) for k, v in figures.items()
                   if v["within_2_percent"] < 0.99}
        report["switched_off"][kind] = figures
        check(f"courtyard with {kind} switched off fails", result == {"FINISHED"} and not ok,
              f"below 99 %: {failing}")
    result = bake()  # leaves the scene baked as it should be
    report["texels"] = texels(module, objects, a, out, lights, strip)
    (out / "courtyard.json").write_text(json.dumps(report, indent=1))


def tiled_export(module, objects, path):
    """Blender's export with each receiver's lightmap UVs moved into the tile the add-on
    gives it (its place in prt-bake's object order, g × g): the atlas a user would pack."""
    export = sys.modules[module + ".export"]
    plan = export.export_scene(bpy.context, path)  # the add-on's order
    names = [r.obj.name for r in plan.receivers]
    g = math.ceil(math.sqrt(len(names)))
    saved = {}

    def layer(name):
        # Through the attribute, not uv_layers[1].uv: in Blender 4.5 a write through the
        # latter reaches every copy of the mesh that still shares the array (the crates'
        # copies, made by the add-on), a write through the attribute does not.
        mesh = bpy.data.objects[name].data
        return mesh.attributes[mesh.uv_layers[1].name].data
    for i, name in enumerate(names):
        uv = np.zeros(len(layer(name)) * 2)
        layer(name).foreach_get("vector", uv)
        saved[name] = uv.copy()
        tiled = (uv.reshape(-1, 2) + [i % g, i // g]) / g
        layer(name).foreach_set("vector", tiled.ravel())
    bpy.ops.export_scene.gltf(filepath=path, **export.EXPORT_SETTINGS)
    for name, uv in saved.items():
        layer(name).foreach_set("vector", uv)
    return names, g


def texels(module, objects, a, out, lights, strip, res=32, samples=256):
    """Lightmaps: the add-on's transfer images against the CLI's bake of Blender's export
    with the same tiles, texel by texel (valid texels), at the rig and turned 90°; then with
    each feature switched off (normal maps too: texel bakes turn the lobe by them)."""
    export = sys.modules[module + ".export"]
    images = sys.modules[module + ".lightmap_images"]
    rotate_z = sys.modules[module + ".light"].rotate_z
    glb = str(out / "courtyard-tiled.glb")
    names, g = tiled_export(module, objects, glb)
    subprocess.run([a.prt_bake, "bake", glb, "-o", str(out / "cli-texels.prt"), "--lightmap",
                    str(g * res), "--strict-uvs", "--double-sided", "off", "--samples",
                    str(samples), "--order", str(a.order), "--seed", "0", "--quiet"], check=True)
    subprocess.run([a.prt_bake, "export", str(out / "cli-texels.prt"), "--scene", glb,
                    "--npz", str(out / "cli-texels.npz")], check=True, capture_output=True)
    with np.load(out / "cli-texels.npz") as f:
        transfer, valid = np.asarray(f["transfer"], np.float64), np.asarray(f["texel_valid"])

    def bake():
        return bpy.ops.prt.bake(rig=a.rig, samples=samples, order=a.order, seed=0,
                                lightmap=res)

    def compare(present):
        light_b = np.array(json.loads(bpy.context.scene.prt.light_json))
        out_, ok = {}, True
        for turn, angle in (("0", 0.0), ("90", math.pi / 2)):
            for name in present:
                i = names.index(name)
                x, y = (i % g) * res, (i // g) * res
                mask = valid[y:y + res, x:x + res]
                theirs = np.einsum("hwcj,cj->hwc", transfer[y:y + res, x:x + res],
                                   lights[turn][:1])[..., 0][mask]
                ours_t, _ = images.load_lightmap(bpy.data.images[images.TRANSFER.format(name)])
                ours = np.einsum("hwcj,cj->hwc", ours_t.astype(np.float64),
                                 rotate_z(light_b, angle))[..., 0][mask]
                close = np.abs(ours - theirs) <= 0.02 * np.abs(theirs) + 1e-4
                out_[f"{name}/{turn}"] = {"texels": int(mask.sum()),
                                          "within_2_percent": float(close.mean())}
                ok &= close.mean() >= 0.99
        return out_, ok

    result = bake()
    figures, ok = compare(names)
    worst = min(figures.items(), key=lambda kv: kv[1]["within_2_percent"])
    check("courtyard lightmaps: the add-on against the CLI per texel, every object, at the "
          "rig and turned 90°", result == {"FINISHED"} and ok,
          f"{len(figures)} object/light pairs of {res}² texels, {samples} rays; the worst "
          f"{worst[0]}: {100 * worst[1]['within_2_percent']:.2f} % of "
          f"{worst[1]['texels']} texels within 2 %")
    report = {"addon": figures, "switched_off": {}}
    original = export.export_scene
    crates = [o for o in objects if o.name in ("Crate1", "Crate2", "Crate3", "Crate4")]
    for kind in ("cutouts", "normalmaps", "textures", "instances"):
        def patched(context, path, kind=kind):
            if kind == "instances":
                for o in crates:
                    o.prt_receive = False
            plan = original(context, path)
            strip(kind)(plan.glb.json, plan.receivers)
            plan.glb.write(path)
            return plan
        export.export_scene = patched
        try:
            result = bake()
        finally:
            export.export_scene = original
            for o in objects:
                o.prt_receive = True
        present = [n for n in names if kind != "instances" or n not in [c.name for c in crates]]
        figures, ok = compare(present)
        failing = {k: round(100 * v["within_2_percent"], 1) for k, v in figures.items()
                   if v["within_2_percent"] < 0.99}
        report["switched_off"][kind] = figures
        check(f"courtyard lightmaps with {kind} switched off fail",
              result == {"FINISHED"} and not ok, f"below 99 %: {failing}")
    return report


try:
    main()
except Exception:
    traceback.print_exc()
    check("courtyard test ran", False, "exception")
(Path(sys.argv[5]) / "checks-courtyard.json").write_text(json.dumps(checks, indent=1))
sys.stdout.flush()
os._exit(0)
