"""LDPRT on an armature-deformed mesh through the add-on, against the CLI (make blender-addon).

    BLENDER_USER_RESOURCES=DIR python test_ldprt.py ZIP PRT_BAKE RIG RIG90 OUT_DIR
        [--samples 256]

Builds a ribbed tube deformed by a two-bone armature (Root, Tip; smoothstep weights across
the middle) whose action "bend" turns Tip 0° → 45° → 90° over frames 0, 12, 24 (24 fps),
the armature object moved and turned so that its world matrix matters, and a floor (a rigid
receiver of the same LDPRT bake). With the scene at frame 12 (posed), bpy.ops.prt.bake with
Transfer Auto must choose LDPRT and bake the rest pose. The CLI bakes Blender's export of the
scene (the add-on's LDPRT exporter settings, with the animation) with the same settings, and
`prt-bake relight scene.glb cli.ldprt --pose bend@T --lights RIG` is the reference at frames
6, 12 and 24 (T = 0.25, 0.5, 1 s): each CLI vertex is matched to the add-on's face corner at
the same posed world position and normal (Blender's own deformation against prt-bake's
skinning), and the add-on's "PRT", relit by its frame-change handler, must be within 2 % of
the CLI's radiance at ≥ 99 % of the vertices, per object and frame. Then the lobes are made
not to follow the pose (the bones' matrices replaced by identities) and the check must fail;
and a bake of the current pose (frame 12) against the CLI's `bake --pose bend@0.5`.

Writes OUT_DIR/checks-ldprt.json and ldprt.json; exits through os._exit.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time
import traceback
from pathlib import Path

import bpy
import numpy as np

checks = {}
TURN = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)  # glTF -> Blender
FRAMES = (6, 12, 24)
FPS = 24


def check(name, ok, detail=""):
    checks[name] = {"ok": bool(ok), "detail": str(detail)}
    print(f"{'ok  ' if ok else 'FAIL'} {name} {detail}", flush=True)


def material(name, color):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*color, 1)
    return m


def build(rings=33, segments=24):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS

    verts, faces = [], []
    for i in range(rings):
        z = 2 * i / (rings - 1)
        r = 0.2 + 0.04 * math.cos(z * math.pi * 4)  # ribs: self-shadowing to keep
        for j in range(segments):
            a = 2 * math.pi * j / segments
            verts.append((r * math.cos(a), r * math.sin(a), z))
    for i in range(rings - 1):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            faces.append((a, b, b + segments, a + segments))
    faces.append(tuple(reversed(range(segments))))
    faces.append(tuple((rings - 1) * segments + j for j in range(segments)))
    mesh = bpy.data.meshes.new("Tube")
    mesh.from_pydata(verts, [], faces)
    mesh.shade_smooth()
    mesh.materials.append(material("TubeMaterial", (0.9, 0.7, 0.5)))
    tube = bpy.data.objects.new("Tube", mesh)
    scene.collection.objects.link(tube)
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    root = rig.data.edit_bones.new("Root")
    root.head, root.tail = (0, 0, 0), (0, 0, 1)
    tip = rig.data.edit_bones.new("Tip")
    tip.head, tip.tail, tip.parent, tip.use_connect = (0, 0, 1), (0, 0, 2), root, True
    bpy.ops.object.mode_set(mode="OBJECT")
    groups = tube.vertex_groups.new(name="Root"), tube.vertex_groups.new(name="Tip")
    for v in mesh.vertices:
        t = min(max((v.co.z - 0.8) / 0.4, 0), 1)
        w = t * t * (3 - 2 * t)
        if w < 1:
            groups[0].add([v.index], 1 - w, "REPLACE")
        if w > 0:
            groups[1].add([v.index], w, "REPLACE")
    tube.parent = rig
    tube.modifiers.new("Armature", "ARMATURE").object = rig
    rig.location, rig.rotation_euler = (0.3, -0.2, 0.05), (0, 0, math.radians(20))
    bone = rig.pose.bones["Tip"]
    bone.rotation_mode = "XYZ"
    rig.animation_data_create().action = bpy.data.actions.new("bend")
    for frame, angle in ((0, 0), (12, 45), (24, 90)):
        bone.rotation_euler = (math.radians(angle), 0, 0)
        bone.keyframe_insert("rotation_euler", frame=frame)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=12, y_subdivisions=12, size=4,
                                    location=(0.3, -0.2, -0.02))
    floor = bpy.context.object
    floor.name = "Floor"
    floor.data.materials.append(material("FloorMaterial", (0.7, 0.7, 0.7)))
    # Double-sided, as Blender's exporter marks it by default: the add-on bakes it with
    # --double-sided off, and `relight` must read it as the bake saw it.
    return [tube, floor]


def read_ply(path):
    """The vertex element of prt-bake's binary PLY: positions, normals (Blender's frame) and
    radiance (RGB, linear)."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    count = next(int(line.split()[2]) for line in header if line.startswith("element vertex"))
    fields, inside = [], False
    for line in header:
        if line.startswith("element"):
            inside = line.startswith("element vertex")
        elif line.startswith("property") and inside:
            _, kind, name = line.split()
            fields.append((name, {"float": "<f4", "uchar": "u1"}[kind]))
    v = np.frombuffer(data, np.dtype(fields), count, end)
    position = np.stack([v["x"], v["y"], v["z"]], 1).astype(np.float64) @ TURN.T
    normal = np.stack([v["nx"], v["ny"], v["nz"]], 1).astype(np.float64) @ TURN.T
    radiance = np.stack([v["radiance_r"], v["radiance_g"], v["radiance_b"]], 1)
    return position, normal, radiance.astype(np.float64)


def posed_corners(obj):
    """Per face corner of the evaluated (posed) mesh: world position, unit normal, "PRT"."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        n = len(mesh.loops)
        vertex = np.zeros(n, np.int64)
        mesh.loops.foreach_get("vertex_index", vertex)
        co = np.zeros(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", co)
        normal = np.zeros(n * 3)
        mesh.corner_normals.foreach_get("vector", normal)
        rgba = np.zeros(n * 4)
        mesh.color_attributes["PRT"].data.foreach_get("color", rgba)
    finally:
        evaluated.to_mesh_clear()
    m = np.array(evaluated.matrix_world)
    position = co.reshape(-1, 3)[vertex] @ m[:3, :3].T + m[:3, 3]
    normal = normal.reshape(n, 3) @ np.linalg.inv(m[:3, :3])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return position, normal, rgba.reshape(n, 4)[:, :3]


def corner_map(module, objects, glb_path):
    """{object: (corners,) the PLY vertex of each face corner}: the add-on's own exact map
    (corner_map.py) on the test's export, whose vertices are prt-bake's (objects in its
    depth-first order)."""
    gltf_scene = sys.modules[module + ".gltf_scene"]
    corner_vertices = sys.modules[module + ".corner_map"].corner_vertices
    glb = gltf_scene.Glb(str(glb_path))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    out, cursor = {}, 0
    for index, _, _ in gltf_scene.walk(glb.json):
        node = glb.json["nodes"][index]
        if "mesh" not in node:
            continue
        primitives = gltf_scene.triangle_primitives(glb, index)
        obj = bpy.data.objects[node["name"]]
        out[obj.name] = corner_vertices(obj, depsgraph, primitives, cursor)[0]
        cursor += sum(c for c, _ in primitives)
    return out


def compare(objects, corners, ply, frame):
    """{object: figures} of the add-on's "PRT" at `frame` against the CLI's PLY, corner by
    corner: the corner's posed world position must be its PLY vertex's (Blender's deformation
    is prt-bake's skinning), and its "PRT" within 2 % of the vertex's radiance. (Normals are
    reported, not required: Blender's come from the posed faces, prt-bake's are skinned, and
    they part where the weights blend and where the 90° bend folds the inner side.)"""
    bpy.context.scene.frame_set(frame)  # the handler relights
    position, normal, radiance = read_ply(ply)
    out = {}
    for obj in objects:
        ours_position, ours_normal, ours = posed_corners(obj)
        vertex = corners[obj.name]
        far = np.linalg.norm(ours_position - position[vertex], axis=1).max()
        cos = np.einsum("ij,ij->i", ours_normal, normal[vertex]).min()
        theirs = radiance[vertex]
        close = (np.abs(ours - theirs) <= 0.02 * np.abs(theirs) + 1e-4).all(1)
        out[obj.name] = {"corners": len(vertex), "within_2_percent": float(close.mean()),
                         "largest_difference": float(np.abs(ours - theirs).max()),
                         "largest_radiance": float(theirs.max()),
                         "position_difference": float(far), "smallest_normal_cos": float(cos),
                         "posed_as_cli": bool(far < 1e-4 * 3)}
    return out


def passes(figures):
    return all(v["within_2_percent"] >= 0.99 and v["posed_as_cli"] for v in figures.values())


def refused(**arguments):
    """The error message of a bake that must fail ('' if it did not)."""
    try:
        result = bpy.ops.prt.bake(**arguments)
    except RuntimeError as err:
        return str(err)
    return "" if result == {"FINISHED"} else str(result)


def cli(prt_bake, *arguments):
    return subprocess.run([prt_bake, *map(str, arguments)], check=True, capture_output=True,
                          text=True).stdout


def main():
    p = argparse.ArgumentParser()
    for name in ("zip", "prt_bake", "rig", "rig90", "out"):
        p.add_argument(name)
    p.add_argument("--samples", type=int, default=256)
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.time()
    objects = build()
    tube, floor = objects
    bpy.ops.extensions.package_install_files(filepath=a.zip, repo="user_default",
                                             enable_on_install=True)
    module = next(m for m in sys.modules if m.endswith("prt_bake"))
    bpy.context.preferences.addons[module].preferences.prt_bake = a.prt_bake
    export, ldprt = sys.modules[module + ".export"], sys.modules[module + ".ldprt"]
    order, lobes, seed = 4, 3, 0
    scene = bpy.context.scene

    # The CLI: Blender's export (the add-on's LDPRT settings, plus the animation).
    glb = out / "tube.glb"
    bpy.ops.export_scene.gltf(filepath=str(glb), **dict(export.ldprt_export_settings(False),
                                                        export_animations=True))
    common = ["--order", order, "--samples", a.samples, "--seed", seed, "--double-sided",
              "off", "--transfer", "ldprt", "--lobes", lobes, "--quiet"]
    cli(a.prt_bake, "bake", glb, "-o", out / "cli.ldprt", *common)
    plys = {}
    for frame in FRAMES:
        plys[frame] = out / f"cli-{frame}.ply"
        cli(a.prt_bake, "relight", glb, out / "cli.ldprt", "--pose", f"bend@{frame / FPS}",
            "--lights", a.rig, "-o", plys[frame])

    scene.frame_set(12)
    result = bpy.ops.prt.bake(rig=a.rig, samples=a.samples, order=order, seed=seed,
                              lobes=lobes)
    baked = time.time()
    info = json.loads(tube.data.get(ldprt.INFO, "{}"))
    check("LDPRT: Transfer Auto bakes the armature-deformed tube with LDPRT (rest pose, "
          "scene left at its pose)", result == {"FINISHED"} and info.get("lobes") == lobes
          and info.get("pose") == "rest" and info.get("bones") == ["Root", "Tip"]
          and ldprt.INFO in floor.data and tube.parent.data.pose_position == "POSE"
          and scene.frame_current == 12, info)
    corners = corner_map(module, objects, glb)
    figures = {frame: compare(objects, corners, plys[frame], frame) for frame in FRAMES}
    worst = min(v["within_2_percent"] for f in figures.values() for v in f.values())
    check("LDPRT: the add-on's shading as the armature plays against prt-bake relight "
          "--pose bend@T (frames 6, 12, 24; tube and floor)",
          all(passes(f) for f in figures.values()),
          f"the worst {100 * worst:.2f} % within 2 %; " + json.dumps(
              {f: {k: round(100 * v["within_2_percent"], 2) for k, v in o.items()}
               for f, o in figures.items()}))
    relit = time.time()

    # Light rotation relights LDPRT meshes too (RIG90: the rig turned 90° about +z).
    cli(a.prt_bake, "relight", glb, out / "cli.ldprt", "--pose", "bend@1", "--lights",
        a.rig90, "-o", out / "cli-24-90.ply")
    scene.prt.light_rotation = math.pi / 2
    turned = compare(objects, corners, out / "cli-24-90.ply", 24)
    scene.prt.light_rotation = 0.0
    check("LDPRT: Light rotation 90° at frame 24 against the CLI's rig turned 90°",
          passes(turned), {k: round(100 * v["within_2_percent"], 2) for k, v in turned.items()})
    bpy.ops.prt.preview_material(show=True)
    shown = [(s.link, s.material.name if s.material else None) for s in tube.material_slots]
    bpy.ops.prt.preview_material(show=False)
    check("LDPRT: Show PRT puts the PRT Relit material on the deformed tube", shown ==
          [("OBJECT", "PRT Relit")] and tube.material_slots[0].link == "DATA", shown)
    report = {"addon": figures, "seconds": {"scene, CLI bake and relight, add-on bake":
                                            baked - started, "three frames": relit - baked}}

    # Broken on purpose: the lobes left in their rest frames (every bone's P R⁻¹ = I).
    blend = ldprt._blend
    ldprt._blend = lambda bones, joints, weights: blend(
        np.broadcast_to(np.eye(3), bones.shape), joints, weights)
    try:
        broken = {frame: compare(objects, corners, plys[frame], frame) for frame in (12, 24)}
    finally:
        ldprt._blend = blend
    fraction = {f: round(100 * o["Tube"]["within_2_percent"], 2) for f, o in broken.items()}
    check("LDPRT: fails with the lobes not following the pose", min(
        o["Tube"]["within_2_percent"] for o in broken.values()) < 0.99,
        f"tube within 2 % at frames 12, 24: {fraction}")
    report["broken"] = broken

    # The current pose: baked at frame 12, against the CLI's bake of bend@0.5.
    cli(a.prt_bake, "bake", glb, "-o", out / "cli-pose.ldprt", "--pose", "bend@0.5", *common)
    cli(a.prt_bake, "relight", glb, out / "cli-pose.ldprt", "--pose", "bend@1", "--lights",
        a.rig, "-o", out / "cli-pose-24.ply")
    scene.frame_set(12)
    result = bpy.ops.prt.bake(rig=a.rig, samples=a.samples, order=order, seed=seed,
                              lobes=lobes, pose="CURRENT")
    posed = compare(objects, corners, out / "cli-pose-24.ply", 24)
    check("LDPRT: a bake of the current pose (frame 12) relit at frame 24 against prt-bake "
          "bake --pose bend@0.5, relight --pose bend@1", result == {"FINISHED"}
          and json.loads(tube.data[ldprt.INFO])["pose"] == "bend@0.5" and passes(posed),
          {k: round(100 * v["within_2_percent"], 2) for k, v in posed.items()})
    report["current_pose"] = posed

    # Interreflected (RGB lobes: one FLOAT_VECTOR per lobe and band), rest pose, frame 24.
    cli(a.prt_bake, "bake", glb, "-o", out / "cli-ir.ldprt", *common[:3], 64,
        *common[4:], "--mode", "interreflected")
    cli(a.prt_bake, "relight", glb, out / "cli-ir.ldprt", "--pose", "bend@1", "--lights",
        a.rig, "-o", out / "cli-ir-24.ply")
    scene.frame_set(0)
    result = bpy.ops.prt.bake(rig=a.rig, samples=64, order=order, seed=seed, lobes=lobes,
                              mode="interreflected", pose="REST")
    rgb = compare(objects, corners, out / "cli-ir-24.ply", 24)
    check("LDPRT: interreflected (RGB lobes) at frame 24 against the CLI",
          result == {"FINISHED"} and json.loads(tube.data[ldprt.INFO])["channels"] == 3
          and passes(rgb), {k: round(100 * v["within_2_percent"], 2) for k, v in rgb.items()})
    report["interreflected"] = rgb
    step = time.time()
    for frame in range(25):
        scene.frame_set(frame)
    report["seconds"]["frame_change"] = (time.time() - step) / 25
    refusals = {}
    floor.prt_receive = False
    refusals["a visible mesh not receiving"] = refused(transfer="LDPRT", rig=a.rig,
                                                      samples=16)
    floor.prt_receive = True
    refusals["order 5"] = refused(transfer="LDPRT", rig=a.rig, samples=16, order=5)
    check("LDPRT: refuses a visible mesh that does not receive, and order 5, scene unchanged",
          "every visible mesh" in refusals["a visible mesh not receiving"]
          and "order 4 at most" in refusals["order 5"]
          and json.loads(tube.data[ldprt.INFO])["channels"] == 3, refusals)
    report["seconds"]["total"] = time.time() - started
    (out / "ldprt.json").write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    code = 0
    try:
        main()
    except Exception:
        traceback.print_exc()
        check("test_ldprt.py ran to its end", False)
        code = 1
    out = Path(sys.argv[5]) if len(sys.argv) > 5 else Path(".")
    out.mkdir(parents=True, exist_ok=True)
    (out / "checks-ldprt.json").write_text(json.dumps(checks, indent=1))
    sys.stdout.flush()
    os._exit(code)
