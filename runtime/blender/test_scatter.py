"""Instances through the add-on (make blender-addon): a ground under a collection instance
(an Empty instancing an excluded collection's rock) and a geometry-nodes scatter of rocks.

    BLENDER_USER_RESOURCES=DIR python test_scatter.py ZIP PRT_BAKE RIG OUT_DIR [--count 1000]

Checks: the bake finishes through bpy.ops.prt.bake with the Scatter object named in a
warning (its evaluated mesh is instances only, so it has no faces of its own to hold a
transfer); the instances cast shadows (the ground under the scatter and under the collection
instance is darker than the same ground baked with the scatter and the instance switched
off, and with instances stripped from the export the test's shadow check fails); Blender's
export holds one rock mesh placed at every instance; and prt-bake's peak memory (its
ru_maxrss, through a wrapper) grows with distinct meshes, not instances: each placement
beyond COUNT (at 4 × COUNT) costs under 5 % of what one flattened instance costs in
prt-bake's flat load of the same file (`--instances off`). Writes OUT_DIR/scatter.json;
exits through os._exit.
"""

import argparse
import json
import os
import subprocess
import sys
import traceback
from pathlib import Path

import bpy
import numpy as np

checks = {}


def check(name, ok, detail=""):
    checks[name] = {"ok": bool(ok), "detail": detail}
    print(f"{'ok  ' if ok else 'FAIL'} {name} {detail}", flush=True)


def build(count):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=40, y_subdivisions=40, size=20)
    ground = bpy.context.object
    ground.name = "Ground"
    rocks = bpy.data.collections.new("Rocks")
    bpy.context.scene.collection.children.link(rocks)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=1.0)
    rock = bpy.context.object
    rock.name = "Rock"
    for c in rock.users_collection:
        c.objects.unlink(rock)
    rocks.objects.link(rock)
    bpy.context.view_layer.layer_collection.children["Rocks"].exclude = True
    empty = bpy.data.objects.new("RockInstance", None)
    empty.instance_type = "COLLECTION"
    empty.instance_collection = rocks
    empty.location = (-6, -6, 1.0)
    empty.scale = (1.5, 1.5, 1.5)
    bpy.context.scene.collection.objects.link(empty)
    bpy.ops.mesh.primitive_plane_add(size=1, location=(4, 4, 0.4))
    scatter = bpy.context.object
    scatter.name = "Scatter"
    tree = bpy.data.node_groups.new("Scatter rocks", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    output = nodes.new("NodeGroupOutput")
    grid = nodes.new("GeometryNodeMeshGrid")  # count points on an 8 × 8 m patch
    side = max(d for d in range(1, int(count ** 0.5) + 1) if count % d == 0)
    grid.inputs["Vertices X"].default_value = side
    grid.inputs["Vertices Y"].default_value = count // side
    grid.inputs["Size X"].default_value = grid.inputs["Size Y"].default_value = 8.0
    points = nodes.new("GeometryNodeMeshToPoints")
    place = nodes.new("GeometryNodeInstanceOnPoints")
    place.inputs["Scale"].default_value = (0.1, 0.1, 0.1)
    info = nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = rock
    links.new(grid.outputs["Mesh"], points.inputs["Mesh"])
    links.new(points.outputs["Points"], place.inputs["Points"])
    links.new(info.outputs["Geometry"], place.inputs["Instance"])
    links.new(place.outputs["Instances"], output.inputs[0])
    scatter.modifiers.new("Scatter", "NODES").node_group = tree
    return ground, scatter, empty, grid


def wrapper(folder, real):
    """A prt-bake that records each `bake`'s peak RSS (KiB) in folder/rss.txt."""
    path = Path(folder) / "prt-bake-rss"
    path.write_text(f"""#!{sys.executable}
import os, sys
pid = os.fork()
if pid == 0:
    os.execv({real!r}, [{real!r}] + sys.argv[1:])
_, status, usage = os.wait4(pid, 0)
if sys.argv[1] == "bake":
    with open({str(Path(folder) / "rss.txt")!r}, "a") as f:
        f.write(f"{{usage.ru_maxrss}}\\n")
sys.exit(os.waitstatus_to_exitcode(status))
""")
    path.chmod(0o755)
    return str(path)


def ground_radiance(ground):
    rgba = np.zeros(len(ground.data.loops) * 4)
    ground.data.color_attributes["PRT"].data.foreach_get("color", rgba)
    vertex = np.zeros(len(ground.data.loops), np.int64)
    ground.data.loops.foreach_get("vertex_index", vertex)
    co = np.zeros(len(ground.data.vertices) * 3)
    ground.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)[vertex], rgba.reshape(-1, 4)[:, :3].mean(1)


def main():
    p = argparse.ArgumentParser()
    for name in ("zip", "prt_bake", "rig", "out"):
        p.add_argument(name)
    p.add_argument("--count", type=int, default=1000)
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    ground, scatter, empty, grid = build(a.count)
    bpy.ops.extensions.package_install_files(filepath=a.zip, repo="user_default",
                                             enable_on_install=True)
    module = next(m for m in sys.modules if m.endswith("prt_bake"))
    rss = out / "rss.txt"
    rss.unlink(missing_ok=True)
    bpy.context.preferences.addons[module].preferences.prt_bake = wrapper(out, a.prt_bake)
    export = sys.modules[module + ".export"]
    gltf_scene = sys.modules[module + ".gltf_scene"]
    s = bpy.context.scene.prt

    def bake():
        return bpy.ops.prt.bake(rig=a.rig, samples=256, order=3)

    result = bake()
    warnings = json.loads(s.last_warnings)
    position, lit = ground_radiance(ground)
    under_scatter = (np.abs(position[:, 0] - 4) < 3.5) & (np.abs(position[:, 1] - 4) < 3.5)
    under_rock = np.linalg.norm(position[:, :2] - [-6, -6], axis=1) < 1.6
    glb_path = str(out / "scatter.glb")
    export.export_scene(bpy.context, glb_path)
    document = gltf_scene.Glb(glb_path).json
    placed = [n for n in document["nodes"] if "mesh" in n]
    meshes = {n["mesh"] for n in placed}
    check("scatter: baked through the add-on, the Scatter object named",
          result == {"FINISHED"} and any(w.startswith("Scatter:") for w in warnings),
          f"{s.last_summary}; warnings {warnings}")
    check("scatter: Blender's export places one rock mesh at every instance",
          len(placed) == a.count + 2 and len(meshes) <= 3,
          f"{len(placed)} mesh nodes, {len(meshes)} meshes")
    # The same ground with the instances switched off.
    scatter.modifiers["Scatter"].show_viewport = False
    empty.hide_set(True)
    bake()
    _, bare = ground_radiance(ground)
    scatter.modifiers["Scatter"].show_viewport = True
    empty.hide_set(False)
    ratio_scatter = lit[under_scatter].mean() / bare[under_scatter].mean()
    ratio_rock = lit[under_rock].mean() / bare[under_rock].mean()
    shadows = ratio_scatter < 0.9 and ratio_rock < 0.7
    check("scatter: the instances cast shadows", shadows,
          f"ground under the scatter {ratio_scatter:.3f}, under the collection instance "
          f"{ratio_rock:.3f} of the bare ground's")
    # The check fails with the instances stripped from the export (the old add-on's scene).
    original = export.export_scene

    def stripped(context, path):
        plan = original(context, path)
        keep = {r.node for r in plan.receivers}
        for holder in plan.glb.json["scenes"] + plan.glb.json["nodes"]:
            for key in ("nodes", "children"):
                if key in holder:
                    holder[key] = [i for i in holder[key] if i in keep
                                   or "mesh" not in plan.glb.json["nodes"][i]]
        plan.glb.write(path)
        return plan
    export.export_scene = stripped
    try:
        bake()
    finally:
        export.export_scene = original
    _, broken = ground_radiance(ground)
    r = broken[under_scatter].mean() / bare[under_scatter].mean()
    check("scatter: with the instances stripped the shadow check fails",
          not (r < 0.9), f"ground under the scatter {r:.3f} of the bare ground's")
    # Memory: COUNT and 4 × COUNT instances, against the flat load.
    rss.unlink(missing_ok=True)
    bake()
    grid.inputs["Vertices X"].default_value *= 2
    grid.inputs["Vertices Y"].default_value *= 2
    bake()
    grid.inputs["Vertices X"].default_value //= 2
    grid.inputs["Vertices Y"].default_value //= 2
    small, large = [int(x) for x in rss.read_text().split()]
    rss.unlink()
    flat_out = str(out / "flat.prt")
    bake_args = [a.prt_bake, "bake", glb_path, "-o", flat_out, "--samples", "256", "--order",
                 "3", "--quiet"]
    subprocess.run([str(out / "prt-bake-rss"), *bake_args[1:], "--instances", "off"],
                   check=True, capture_output=True)
    flat = int(rss.read_text().split()[0])
    # A placement costs its transform and Embree's instance geometry (bytes); a flattened
    # instance its 1,280 triangles (hundreds of KiB): the first must be under 5 % of the second.
    per_placement = (large - small) / (3 * a.count)
    per_flat = (flat - small) / a.count
    check("scatter: prt-bake's memory grows with meshes, not instances",
          per_placement < 0.05 * per_flat,
          f"peak RSS {small / 1024:.0f} MiB at {a.count} instances, {large / 1024:.0f} MiB at "
          f"{4 * a.count} ({per_placement:.1f} KiB per placement), {flat / 1024:.0f} MiB "
          f"flat at {a.count} ({per_flat:.0f} KiB per instance)")
    (out / "scatter.json").write_text(json.dumps({
        "warnings": warnings, "summary": s.last_summary, "shadow_ratio_scatter": ratio_scatter,
        "shadow_ratio_collection_instance": ratio_rock, "stripped_ratio": r,
        "mesh_nodes": len(placed), "meshes": len(meshes),
        "peak_rss_kib": {"instanced": small, "instanced_4x": large, "flat": flat}}, indent=1))


try:
    main()
except Exception:
    traceback.print_exc()
    check("scatter test ran", False, "exception")
(Path(sys.argv[4]) / "checks-scatter.json").write_text(json.dumps(checks, indent=1))
sys.stdout.flush()
os._exit(0)
