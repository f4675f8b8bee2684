"""The add-on's test in Blender 4.5 (bpy as a Python module): install from the zip, build
Suzanne, a cube and a floor, export them with Blender's own glTF exporter (for the CLI's
bake, test.sh), bake through bpy.ops.prt.bake, relight at the rig and turned 90°, and check
the errors, the cancel and that nothing but the added attributes changed.

    BLENDER_USER_RESOURCES=DIR python test_addon.py ZIP PRT_BAKE RIG OUT_DIR [--samples N]
        [--legacy]   (only: install the zip as a legacy add-on, into a fresh DIR)

Writes OUT_DIR/scene.glb (Blender's export), OUT_DIR/addon.npz (per object: corner world
positions and normals, albedo, "PRT" at the rig and at 90°) and OUT_DIR/checks.json (every
check's outcome). Exits through os._exit after flushing: bpy can hang in its exit handlers.
"""

import argparse
import json
import math
import os
import stat
import sys
import time
import traceback
from pathlib import Path

import bpy
import numpy as np

checks = {}


def check(name, ok, detail=""):
    checks[name] = {"ok": bool(ok), "detail": str(detail)}
    print(f"{'ok  ' if ok else 'FAIL'} {name} {detail}", flush=True)


def install(zip_path):
    result = bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True)
    check("install from the zip", result == {"FINISHED"} and hasattr(bpy.ops.prt, "bake"))
    module = next(m for m in sys.modules if m.endswith("prt_bake"))
    return module


def install_legacy(zip_path):
    """The same zip as a legacy add-on (Preferences > Add-ons > Install from Disk)."""
    installed = bpy.ops.preferences.addon_install(filepath=zip_path)
    enabled = bpy.ops.preferences.addon_enable(module="prt_bake")
    addon = bpy.context.preferences.addons.get("prt_bake")
    check("install from the zip as a legacy add-on", installed == enabled == {"FINISHED"}
          and addon is not None and addon.preferences.prt_bake == ""
          and hasattr(bpy.ops.prt, "bake") and bpy.context.scene.prt.order == 4)


def material(name, color):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*color, 1)
    return m


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=24, y_subdivisions=24, size=6)
    floor = bpy.context.object
    floor.name = "Floor"
    bpy.ops.mesh.primitive_monkey_add(size=2, location=(-0.6, 0, 1.0), rotation=(0, 0, 0.4))
    suzanne = bpy.context.object
    suzanne.name = "Suzanne"
    bpy.ops.object.modifier_add(type="SUBSURF")
    suzanne.modifiers["Subdivision"].levels = 1
    bpy.ops.object.modifier_apply(modifier="Subdivision")
    bpy.ops.object.shade_smooth()
    bpy.ops.mesh.primitive_cube_add(size=1, location=(1.4, 0.6, 0.5), rotation=(0, 0, 0.3))
    cube = bpy.context.object
    cube.name = "Cube"
    for obj, color in ((floor, (0.7, 0.7, 0.7)), (suzanne, (0.8, 0.45, 0.25)),
                       (cube, (0.25, 0.5, 0.8))):
        obj.data.materials.append(material(obj.name + "Material", color))
    # A second material on the cube's top face: two primitives, two albedos per object.
    cube.data.materials.append(material("CubeTop", (0.9, 0.3, 0.2)))
    top = max(cube.data.polygons, key=lambda p: p.normal.z)
    top.material_index = 1
    return [floor, suzanne, cube]


def snapshot():
    """What the add-on must not change: per object its transform, geometry, materials and
    attributes (less its own), and the selection, active object and mode."""
    out = {"mode": bpy.context.mode,
           "active": getattr(bpy.context.view_layer.objects.active, "name", None),
           "objects": sorted(o.name for o in bpy.data.objects),
           "materials": sorted(m.name for m in bpy.data.materials),
           "images": sorted(i.name for i in bpy.data.images if not i.name.startswith("PRT "))}
    for obj in bpy.data.objects:
        co = np.zeros(len(obj.data.vertices) * 3)
        obj.data.vertices.foreach_get("co", co)
        out[obj.name] = {
            "matrix": [list(r) for r in obj.matrix_world], "select": obj.select_get(),
            "co": float(np.abs(co).sum()), "polygons": len(obj.data.polygons),
            "materials": [m.name if m else None for m in obj.data.materials],
            "slots": [(s.link, s.material.name if s.material else None)
                      for s in obj.material_slots],
            "attributes": sorted(a.name for a in obj.data.attributes
                                 if not a.name.startswith("prt_") and a.name != "PRT")}
    return out


def corner_frames(obj):
    """Per face corner of obj.data: world position, unit world normal, and "PRT" (RGB)."""
    mesh = obj.data
    n = len(mesh.loops)
    vertex = np.zeros(n, np.int64)
    mesh.loops.foreach_get("vertex_index", vertex)
    co = np.zeros(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", co)
    normal = np.zeros(n * 3)
    mesh.corner_normals.foreach_get("vector", normal)
    m = np.array(obj.matrix_world)
    position = co.reshape(-1, 3)[vertex] @ m[:3, :3].T + m[:3, 3]
    normal = normal.reshape(n, 3) @ np.linalg.inv(m[:3, :3])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    rgba = np.zeros(n * 4)
    mesh.color_attributes["PRT"].data.foreach_get("color", rgba)
    return position, normal, rgba.reshape(n, 4)[:, :3]


def corners(obj):
    """Per face corner: world position, world normal, albedo, and "PRT" (RGB)."""
    mesh = obj.data
    n = len(mesh.loops)
    position, normal, prt = corner_frames(obj)
    albedos = np.array([m.node_tree.nodes["Principled BSDF"].inputs["Base Color"]
                        .default_value[:3] for m in mesh.materials])
    corner_polygon = np.zeros(n, np.int64)
    for polygon in mesh.polygons:
        corner_polygon[polygon.loop_start:polygon.loop_start + polygon.loop_total] = \
            polygon.index
    slot = np.array([p.material_index for p in mesh.polygons])[corner_polygon]
    return position, normal, albedos[slot], prt


def prt_colors(obj):
    rgba = np.zeros(len(obj.data.loops) * 4)
    obj.data.color_attributes["PRT"].data.foreach_get("color", rgba)
    return rgba.reshape(-1, 4)[:, :3]


def expect_error(name, call, words):
    """An operator that must fail with an error report (bpy.ops raises it as RuntimeError
    in a script) and change nothing."""
    before = snapshot()
    try:
        result = call()
        check(name, False, f"returned {result}, no error reported")
    except RuntimeError as err:
        message = str(err)
        check(name, words in message and "Traceback" not in message, message.strip())
    check(name + ": nothing changed", snapshot() == before and not any(
        "PRT" in o.data.color_attributes for o in bpy.data.objects if o.type == "MESH"))


def fake_prt_bake(folder, real):
    """A prt-bake whose `bake` fails as a real failure would (exit 3, an error line)."""
    path = Path(folder) / "failing-prt-bake"
    path.write_text("#!/bin/sh\n"
                    f"if [ \"$1\" = bake ]; then echo 'prt-bake: error: scene.glb: boom' >&2; "
                    f"exit 3; fi\nexec '{real}' \"$@\"\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("zip")
    p.add_argument("prt_bake")
    p.add_argument("rig")
    p.add_argument("out")
    p.add_argument("--samples", type=int, default=1024)
    p.add_argument("--legacy", action="store_true", help="only install as a legacy add-on")
    a = p.parse_args()
    out = Path(a.out)
    if a.legacy:
        install_legacy(a.zip)
        return
    objects = build()  # first: factory settings would disable the add-on again
    module = install(a.zip)
    export = sys.modules[module + ".export"]
    bpy.ops.export_scene.gltf(filepath=str(out / "scene.glb"), **export.EXPORT_SETTINGS)
    prefs = bpy.context.preferences.addons[module].preferences

    # Errors: reported, nothing changed.
    prefs.prt_bake = str(out / "no-such-prt-bake")
    expect_error("no prt-bake", lambda: bpy.ops.prt.bake(rig=a.rig), "prt-bake not found")
    prefs.prt_bake = fake_prt_bake(out, a.prt_bake)
    expect_error("a failed bake", lambda: bpy.ops.prt.bake(rig=a.rig, samples=16),
                 "prt-bake bake failed (exit 3): prt-bake: error: scene.glb: boom")
    prefs.prt_bake = a.prt_bake
    expect_error("a bad rig", lambda: bpy.ops.prt.bake(rig=str(out / "none.toml")),
                 "prt-bake light failed")
    expect_error("relight before a bake", lambda: bpy.ops.prt.relight(), "nothing baked yet")
    bpy.context.view_layer.objects.active = objects[2]
    bpy.ops.object.mode_set(mode="EDIT")
    expect_error("Edit Mode", lambda: bpy.ops.prt.bake(rig=a.rig), "in Edit Mode")
    bpy.ops.object.mode_set(mode="OBJECT")
    for obj in objects:
        obj.hide_set(True)
    expect_error("no mesh", lambda: bpy.ops.prt.bake(rig=a.rig), "no visible mesh")
    for obj in objects:
        obj.hide_set(False)

    # A linked duplicate that receives gets a mesh of its own (a mesh holds one transfer),
    # one that does not only occludes, and a mesh without faces is left out: each named.
    twin = bpy.data.objects.new("CubeTwin", objects[2].data)
    shadow = bpy.data.objects.new("CubeShadow", objects[2].data)
    shadow.prt_receive = False
    edges = bpy.data.meshes.new("Edges")
    edges.from_pydata([(0, 0, 0), (1, 0, 0)], [(0, 1)], [])
    wire = bpy.data.objects.new("Wire", edges)
    for obj in (twin, shadow, wire):
        bpy.context.scene.collection.objects.link(obj)
    plan = export.export_scene(bpy.context, str(out / "plan.glb"))
    names = sorted(r.obj.name for r in plan.receivers)
    check("linked duplicates, occluders and meshes without faces",
          names == sorted(["CubeTwin", *[o.name for o in objects]])
          and twin.data != objects[2].data and shadow.data == objects[2].data
          and sorted(plan.warnings[:2]) == [
              f"CubeTwin shared mesh 'Cube' with Cube: given a copy of its own "
              f"({twin.data.name!r}) to hold its own transfer (turn its PRT receive off to "
              "keep it linked: it then only casts shadows)", "Wire has no faces: not baked"]
          and not plan.flat,
          plan.warnings)
    copy = twin.data
    for obj in (twin, shadow, wire):
        bpy.data.objects.remove(obj)
    bpy.data.meshes.remove(edges)
    bpy.data.meshes.remove(copy)

    # Cancel: a bake driven by its job as the modal operator drives it, stopped mid-way.
    bake_job = sys.modules[module + ".bake_job"]
    settings = bake_job.BakeSettings(order=4, samples=1 << 14, mode="shadowed")
    before = snapshot()
    folder = Path(out / "cancel")
    folder.mkdir()
    plan = export.export_scene(bpy.context, str(folder / "scene.glb"))
    job = bake_job.BakeJob(a.prt_bake, settings, plan, str(folder))
    job.start()
    folder, process = job.folder, job.process
    started = time.time()
    while not job.poll() and job.progress == 0 and time.time() - started < 60:
        time.sleep(0.05)
    progress = job.progress
    job.cancel()
    check("cancel", process.poll() is not None and not os.path.exists(folder)
          and snapshot() == before and 0 < progress < 1,
          f"progress {progress:.3f} when cancelled, after {time.time() - started:.1f} s")

    # The bake, through the operator as a script calls it (synchronously).
    before = snapshot()
    started = time.time()
    result = bpy.ops.prt.bake(rig=a.rig, samples=a.samples, order=4)
    seconds = time.time() - started
    check("bake", result == {"FINISHED"} and all("PRT" in o.data.color_attributes
                                                 for o in objects), f"{seconds:.1f} s")
    check("only attributes added", snapshot() == before)
    check("transfer attributes", all(
        all(f"prt_T{j:02d}" in o.data.attributes for j in range(16)) for o in objects))
    arrays = {}
    for obj in objects:
        position, normal, albedo, prt = corners(obj)
        arrays.update({f"{obj.name}/position": position, f"{obj.name}/normal": normal,
                       f"{obj.name}/albedo": albedo, f"{obj.name}/prt0": prt})
    scene = bpy.context.scene
    scene.prt.light_rotation = math.pi / 2  # the update relights
    for obj in objects:
        arrays[f"{obj.name}/prt90"] = prt_colors(obj)
    changed = not np.allclose(arrays["Suzanne/prt0"], arrays["Suzanne/prt90"])
    result = bpy.ops.prt.relight()
    same = all(np.array_equal(prt_colors(o), arrays[f"{o.name}/prt90"]) for o in objects)
    check("light_rotation relights; prt.relight agrees", changed and same and
          result == {"FINISHED"})
    scene.prt.light_rotation = 0.0
    check("turned back", all(np.allclose(prt_colors(o), arrays[f"{o.name}/prt0"], atol=1e-6)
                             for o in objects))

    # The material that shows "PRT", and hiding it again.
    result = bpy.ops.prt.preview_material(show=True)
    shown = all(s.material and s.material.name == "PRT Relit" and s.link == "OBJECT"
                for o in objects for s in o.material_slots)
    nodes = bpy.data.materials["PRT Relit"].node_tree.nodes
    check("preview material", result == {"FINISHED"} and shown and any(
        n.type == "VERTEX_COLOR" and n.layer_name == "PRT" for n in nodes))
    render_preview(objects[0], out)
    bpy.ops.prt.preview_material(show=False)
    check("preview material hidden", all(s.link == "DATA" for o in objects
                                         for s in o.material_slots)
          and all(o.data.materials[0].name == o.name + "Material" for o in objects))
    warnings_and_panel(module, a, objects[2])
    modal(module, objects, a, arrays)
    lightmaps(objects, a, arrays)
    interreflected(objects, a, arrays)
    world_light(module, a)
    np.savez(out / "addon.npz", **arrays)


class FakeWindowManager:
    """What the modal bake calls on the window manager and workspace, recorded (a headless
    Blender has no window for a modal handler)."""

    def __init__(self):
        self.calls = []

    def __getattr__(self, name):
        return lambda *args, **kwargs: self.calls.append((name, *args))


def modal(module, objects, a, arrays):
    """The panel's path: PRT_OT_bake.invoke starts the bake, modal() on TIMER events polls it
    and moves the progress bar, on ESC cancels. Called on a stand-in operator (its settings
    and methods) and context (the real scene, a recording window manager), with the timer
    pumped here. The finished bake must equal the synchronous one bit for bit."""
    from types import SimpleNamespace
    operators = sys.modules[module + ".operators"]
    cls = operators.PRT_OT_bake

    def operator(samples):
        op = SimpleNamespace(samples=samples, order=4, mode="", rig=a.rig, seed=-1, threads=0,
                             lightmap=0, transfer="", lobes=0, pose="", reports=[])
        for name in ("_prepare", "_finish", "_end", "_lightmap", "_warn", "_ldprt_settings"):
            setattr(op, name, getattr(cls, name).__get__(op))
        op.report = lambda kind, message: op.reports.append((set(kind), message))
        return op

    wm = FakeWindowManager()
    c = bpy.context
    context = SimpleNamespace(window_manager=wm, workspace=wm, window=None, scene=c.scene,
                              view_layer=c.view_layer, preferences=c.preferences,
                              evaluated_depsgraph_get=c.evaluated_depsgraph_get)
    timer, escape = SimpleNamespace(type="TIMER"), SimpleNamespace(type="ESC")

    before = snapshot()
    colors_before = [prt_colors(o) for o in objects]
    op = operator(1 << 14)
    started = cls.invoke(op, context, None) == {"RUNNING_MODAL"}
    while cls.modal(op, context, timer) == {"RUNNING_MODAL"} and op._job.progress == 0:
        time.sleep(0.05)
    result = cls.modal(op, context, escape)
    check("modal bake cancelled with Esc", started and result == {"CANCELLED"}
          and op._job.process.poll() is not None and snapshot() == before
          and all(np.array_equal(prt_colors(o), c) for o, c in zip(objects, colors_before))
          and ("progress_end",) in wm.calls, op.reports[-1][1])

    wm.calls.clear()
    for obj in objects:  # so that only the modal bake can bring "PRT" back
        obj.data.color_attributes["PRT"].data.foreach_set(
            "color", np.zeros(len(obj.data.loops) * 4, np.float32))
    op = operator(a.samples)
    started = cls.invoke(op, context, None) == {"RUNNING_MODAL"}
    ticks = 0
    while (result := cls.modal(op, context, timer)) == {"RUNNING_MODAL"}:
        ticks += 1
        time.sleep(0.05)
    updates = [call[1] for call in wm.calls if call[0] == "progress_update"]
    same = all(np.array_equal(prt_colors(o), arrays[f"{o.name}/prt0"].astype(np.float32))
               for o in objects)
    check("modal bake", started and result == {"FINISHED"} and same
          and updates == sorted(updates) and wm.calls[-1] == ("status_text_set", None),
          f"{ticks} timer ticks, progress bar at {sorted(set(updates))} %, "
          f"{op.reports[-1][1] if op.reports else 'no report'}")


def warnings_and_panel(module, a, cube):
    """A material the bake cannot read (a procedural Base Color) is named, with its object,
    in the last bake's warnings; the panel lists them with the bake's time and rays. A
    mirrored cube (scale −1) bakes too: the corner map's check (each corner's baked vertex at
    its position, facing its normal) passes for it."""
    mirror = bpy.data.objects.new("Mirror", cube.data.copy())
    mirror.scale = (-1, 1, 1)
    mirror.location = (-2.5, 2.5, 0.5)
    bpy.context.scene.collection.objects.link(mirror)
    bpy.ops.mesh.primitive_cube_add(size=0.3, location=(2.5, -2.5, 0.15))
    obj = bpy.context.object
    obj.name = "Procedural"
    m = material("Noisy", (0.5, 0.5, 0.5))
    noise = m.node_tree.nodes.new("ShaderNodeTexNoise")
    m.node_tree.links.new(noise.outputs["Color"],
                          m.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    obj.data.materials.append(m)
    text = bpy.data.objects.new("Label", bpy.data.curves.new("Label", "FONT"))
    text.location = (2.5, 2.5, 0.0)
    bpy.context.scene.collection.objects.link(text)
    result = bpy.ops.prt.bake(rig=a.rig, samples=16, order=2)
    warnings = json.loads(bpy.context.scene.prt.last_warnings)
    check("a text object named in a warning", warnings[:1] == [
        "Label is a font, not a mesh: not baked (it casts shadows as far as Blender's glTF "
        "export makes it a mesh; convert it to a mesh to bake it)"], warnings[:1])
    curve = text.data
    bpy.data.objects.remove(text)
    bpy.data.curves.remove(curve)
    warnings = warnings[1:]
    check("a mirrored object", result == {"FINISHED"} and "prt_T03" in mirror.data.attributes)
    mesh = mirror.data
    bpy.data.objects.remove(mirror)
    bpy.data.meshes.remove(mesh)
    check("a procedural material named in a warning", result == {"FINISHED"} and warnings == [
        "Procedural, material Noisy: Base Color from Noise Texture is not exported; baked "
        "with its Base Color value (no texture)"], warnings)

    class Layout:  # records what the panel draws
        def __init__(self, lines):
            self.lines = lines

        def __getattr__(self, name):
            return lambda *args, **kw: (self.lines.append(kw.get("text", "")), self)[1]
    lines = []
    panel = sys.modules[module + ".panel"].PRT_PT_panel
    stand_in = type("Stand-in", (), {"layout": Layout(lines)})()
    panel.draw(stand_in, bpy.context)
    summary = bpy.context.scene.prt.last_summary
    check("the panel shows the last bake's time, rays and warnings",
          any(line.startswith("Last bake: ") for line in lines) and summary.split(" -> ")[0]
          in lines and " rays" in summary and warnings[0] in lines
          and any(line.startswith("Receivers: ") for line in lines), lines)
    bpy.data.objects.remove(obj)
    bpy.data.materials.remove(m)


def interreflected(objects, a, arrays):
    """An interreflected (RGB) bake: FLOAT_VECTOR transfer; compare_cli.py holds its "PRT"
    to the CLI's interreflected bake of Blender's export (albedos from both writers)."""
    result = bpy.ops.prt.bake(rig=a.rig, samples=256, order=4, lightmap=0,
                              mode="interreflected")
    check("interreflected bake", result == {"FINISHED"} and all(
        o.data.attributes["prt_T00"].data_type == "FLOAT_VECTOR" for o in objects))
    for obj in objects:
        arrays[f"{obj.name}/prtir"] = prt_colors(obj)


def world_light(module, a):
    """The World as the light. A uniform colour: a constant sky, c_00 = L·sqrt(4π) per
    channel and nothing else. An equirectangular .exr: a bright patch at u = 0.25 (Blender's
    +Y, docs/reference/lights.md) and 31° above the horizon, whose band-1 coefficients point at it
    (y_1,-1, y_1,0, y_1,1 ∝ -y, z, -x with the Condon–Shortley phase). Other nodes refused."""
    light = sys.modules[module + ".light"]
    errors = sys.modules[module + ".errors"]
    world = bpy.data.worlds.new("PRT test world")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    background = nodes["Background"]
    background.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1)
    background.inputs["Strength"].default_value = 1.5
    c = light.project_world(a.prt_bake, world, 3)
    expected = np.zeros((3, 9))
    expected[:, 0] = np.array([0.2, 0.4, 0.6]) * 1.5 * math.sqrt(4 * math.pi)
    check("World colour as the light", np.allclose(c, expected, atol=1e-6), c[:, 0])
    scene = bpy.context.scene
    scene.world, scene.prt.rig_source = world, "WORLD"
    result = bpy.ops.prt.relight(reproject=True)  # the panel's "Re-read light"
    relit = np.array(json.loads(scene.prt.light_json))
    check("Re-read light from the World", result == {"FINISHED"} and relit.shape == (3, 16)
          and np.allclose(relit[:, 0], expected[:, 0]) and np.allclose(relit[:, 1:], 0, atol=1e-6))

    w, h = 64, 32
    pixels = np.zeros((h, w, 4), np.float32)
    pixels[:, :, 3] = 1
    # Blender's image row 0 is the bottom (−Z): the patch's rows 8..10 from the top.
    pixels[h - 1 - 10:h - 1 - 7, 15:18, :3] = 50.0
    image = bpy.data.images.new("PRT test sky", w, h, float_buffer=True)
    image.pixels.foreach_set(pixels.ravel())
    image.filepath_raw = str(Path(a.out) / "sky.exr")
    image.file_format = "OPEN_EXR"
    image.save()
    texture = nodes.new("ShaderNodeTexEnvironment")
    texture.image = image
    links.new(texture.outputs["Color"], background.inputs["Color"])
    c = light.project_world(a.prt_bake, world, 2)[0]
    direction = np.array([-c[3], -c[1], c[2]]) / np.linalg.norm([c[1], c[2], c[3]])
    # The patch's first moment, ∫ s dΩ over θ ∈ [8, 11]·π/h, u ∈ [15, 18]/w (φ = π − 2πu).
    theta = (np.arange(300) + 0.5) / 300 * 3 * math.pi / h + 8 * math.pi / h
    phi = math.pi - 2 * math.pi * ((np.arange(300) + 0.5) / 300 * 3 + 15) / w
    t, p = np.meshgrid(theta, phi, indexing="ij")
    moment = np.array([(np.sin(t) * np.cos(p) * np.sin(t)).sum(),
                       (np.sin(t) * np.sin(p) * np.sin(t)).sum(), (np.cos(t) * np.sin(t)).sum()])
    angle = math.degrees(math.acos(min(1.0, float(direction @ moment / np.linalg.norm(moment)))))
    check("World environment image as the light", angle < 0.5, f"{angle:.3f}° off the patch")
    seen = (world_seen_by_cycles(world, direction, Path(a.out) / "sky-there.exr"),
            world_seen_by_cycles(world, -direction, Path(a.out) / "sky-opposite.exr"))
    check("Cycles sees the World's patch where the light's coefficients point",
          seen[0] > 25 and seen[1] < 1, f"radiance {seen[0]:.1f} there, {seen[1]:.2f} opposite")
    # A Mapping node turning the map 60° about Z: the light must turn with what Cycles sees.
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0, 0, math.radians(60))
    coordinates = nodes.new("ShaderNodeTexCoord")
    links.new(coordinates.outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], texture.inputs["Vector"])
    c = light.project_world(a.prt_bake, world, 2)[0]
    turned = np.array([-c[3], -c[1], c[2]]) / np.linalg.norm([c[1], c[2], c[3]])
    seen = (world_seen_by_cycles(world, turned, Path(a.out) / "sky-turned.exr"),
            world_seen_by_cycles(world, direction, Path(a.out) / "sky-unturned.exr"))
    angle = math.degrees(math.acos(min(1.0, float(turned @ direction))))
    check("a World image turned by a Mapping node", seen[0] > 25 and seen[1] < 1
          and abs(angle - 60 * math.cos(math.radians(31))) < 20,
          f"light turned {angle:.1f}°; Cycles sees {seen[0]:.1f} there, {seen[1]:.2f} where "
          "the unturned light points")
    noise = nodes.new("ShaderNodeTexNoise")
    links.new(noise.outputs["Color"], background.inputs["Color"])
    try:
        light.project_world(a.prt_bake, world, 3)
        check("a World by other nodes refused", False)
    except errors.PrtError as err:
        check("a World by other nodes refused", "Environment Texture" in str(err), err)
    bpy.data.worlds.remove(world)
    bpy.data.images.remove(image)


def render_preview(floor, out):
    """Cycles renders the preview material as "PRT" itself: an orthographic camera looks
    straight down at a 0.5 m patch of the floor far from the other objects (where "PRT"
    is nearly constant), 16 × 16 pixels, 4 samples, written as linear OpenEXR; the mean pixel
    against the mean "PRT" of the floor's corners in that patch."""
    scene = bpy.context.scene
    camera = bpy.data.objects.new("PRT test camera", bpy.data.cameras.new("PRT test camera"))
    scene.collection.objects.link(camera)
    camera.data.type, camera.data.ortho_scale = "ORTHO", 0.5
    camera.location = (2.5, -2.5, 3.0)
    scene.camera = camera
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples = "CPU", 4
    scene.cycles.use_denoising = False
    scene.render.resolution_x = scene.render.resolution_y = 16
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(out / "preview.exr")
    started = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - started
    image = bpy.data.images.load(str(out / "preview.exr"))
    pixels = np.zeros(16 * 16 * 4, np.float32)
    image.pixels.foreach_get(pixels)
    rendered = pixels.reshape(-1, 4)[:, :3].mean(0)
    position, _, _, prt = corners(floor)
    inside = (np.abs(position[:, 0] - 2.5) <= 0.25) & (np.abs(position[:, 1] + 2.5) <= 0.25)
    expected = prt[inside].mean(0)
    check("Cycles renders the preview material as \"PRT\"",
          inside.any() and np.allclose(rendered, expected, rtol=0.02),
          f"rendered {np.round(rendered, 4)}, PRT {np.round(expected, 4)}, {seconds:.1f} s")
    bpy.data.images.remove(image)
    bpy.data.objects.remove(camera)


def world_seen_by_cycles(world, direction, path):
    """The mean radiance Cycles renders of the World in a 10° view along `direction`
    (8 × 8 pixels, linear EXR): Blender's own reading of the equirectangular image."""
    import mathutils
    scene = bpy.context.scene
    camera = bpy.data.objects.new("PRT sky camera", bpy.data.cameras.new("PRT sky camera"))
    scene.collection.objects.link(camera)
    camera.data.angle = math.radians(10)
    camera.rotation_euler = mathutils.Vector(direction).to_track_quat("-Z", "Y").to_euler()
    hidden = [o for o in scene.objects if o.type == "MESH" and not o.hide_render]
    for obj in hidden:
        obj.hide_render = True
    scene.camera, scene.world = camera, world
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples = "CPU", 4
    scene.render.resolution_x = scene.render.resolution_y = 8
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))
    pixels = np.zeros(8 * 8 * 4, np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    bpy.data.objects.remove(camera)
    for obj in hidden:
        obj.hide_render = False
    return float(pixels.reshape(-1, 4)[:, :3].mean())


def lightmap_uvs(obj):
    """A second UV map, "Lightmap", by Smart UV Project, as a Blender user lays one out."""
    obj.data.uv_layers.active = obj.data.uv_layers.new(name="Lightmap")
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(angle_limit=math.radians(66), island_margin=0.05)
    bpy.ops.object.mode_set(mode="OBJECT")


def sample(image, uv):
    """Bilinear lookup of an image's RGB at UVs (v up; texel centres at (i + 0.5) / RES)."""
    w, h = image.size
    pixels = np.zeros(w * h * 4, np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(h, w, 4)[:, :, :3]
    x = np.clip(uv[:, 0] * w - 0.5, 0, w - 1)
    y = np.clip(uv[:, 1] * h - 0.5, 0, h - 1)
    x0, y0 = np.minimum(x.astype(int), w - 2), np.minimum(y.astype(int), h - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    return ((1 - fx) * (1 - fy) * pixels[y0, x0] + fx * (1 - fy) * pixels[y0, x0 + 1]
            + (1 - fx) * fy * pixels[y0 + 1, x0] + fx * fy * pixels[y0 + 1, x0 + 1])


def lightmaps(objects, a, arrays):
    """A lightmap bake through the operator: its images, sampled at each face corner's
    lightmap UV, against the vertex bake's "PRT": two estimates of the same radiance, texel
    points inside the faces against vertices on their edges (the cube's bottom vertices sit
    on the floor, darker than the texels beside them), so close, not equal: means within 8 %
    (measured +0.6 to +4.6 %), correlation at least 0.9 (measured 0.93 to 0.99)."""
    for obj in objects:
        lightmap_uvs(obj)
    before = snapshot()
    started = time.time()
    result = bpy.ops.prt.bake(rig=a.rig, samples=256, order=4, lightmap=128)
    seconds = time.time() - started
    images = [bpy.data.images.get(f"PRT {o.name}") for o in objects]
    check("lightmap bake", result == {"FINISHED"} and all(
        i is not None and tuple(i.size) == (128, 128) and i.packed_file is not None
        for i in images), f"{seconds:.1f} s")
    check("lightmap: only images added", snapshot() == before)
    stats = {}
    for turn in ("0", "90"):
        bpy.context.scene.prt.light_rotation = math.radians(float(turn))
        for obj in objects:
            uv = np.zeros(len(obj.data.loops) * 2)
            obj.data.uv_layers["Lightmap"].uv.foreach_get("vector", uv)
            texel = sample(bpy.data.images[f"PRT {obj.name}"], uv.reshape(-1, 2)).mean(1)
            vertex = arrays[f"{obj.name}/prt{turn}"].mean(1)
            stats[f"{obj.name}/{turn}"] = (float(texel.mean() / vertex.mean() - 1),
                                           float(np.corrcoef(texel, vertex)[0, 1]))
    bpy.context.scene.prt.light_rotation = 0.0
    # Each texel's own material: the cube's top face (its second material, red) in the
    # image at the face's centre against its corners' "PRT", per channel.
    cube = objects[2]
    top = max(cube.data.polygons, key=lambda p: p.normal.z)
    corners_of_top = list(range(top.loop_start, top.loop_start + top.loop_total))
    uv = np.array([cube.data.uv_layers["Lightmap"].uv[i].vector for i in corners_of_top])
    texel = sample(bpy.data.images["PRT Cube"], uv.mean(0, keepdims=True))[0]
    vertex = arrays["Cube/prt0"][corners_of_top].mean(0)
    check("lightmap: each texel's material", np.allclose(texel, vertex, rtol=0.1),
          f"top face {np.round(texel, 4)} against its corners {np.round(vertex, 4)}")
    detail = ", ".join(f"{k} {100 * d:+.1f} % r {c:.3f}" for k, (d, c) in stats.items())
    check("lightmap images against the vertex bake",
          all(abs(d) <= 0.08 and c >= 0.9 for d, c in stats.values()), detail)
    result = bpy.ops.prt.preview_material(show=True)
    material = bpy.data.materials.get("PRT Relit Suzanne")
    check("lightmap preview material", result == {"FINISHED"} and material is not None and any(
        n.type == "TEX_IMAGE" and n.image.name == "PRT Suzanne"
        for n in material.node_tree.nodes))
    bpy.ops.prt.preview_material(show=False)


if __name__ == "__main__":
    code = 0
    try:
        main()
    except BaseException:
        traceback.print_exc()
        checks["test ran"] = {"ok": False, "detail": traceback.format_exc()}
        code = 1
    name = "checks-legacy.json" if "--legacy" in sys.argv else "checks.json"
    Path(sys.argv[4], name).write_text(json.dumps(checks, indent=1))
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
