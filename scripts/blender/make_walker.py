"""Builds scenes/cornell/walker.glb: a capsule figure skinned to an armature, walking across the
Cornell room (docs/guides/characters.md, "A character walking through the room").

    target/blender/venv/bin/python scripts/blender/make_walker.py OUT.glb

One mesh (torso, head, two arms and two legs as capsules, 12 sides, smooth) in one material,
skinned to eleven bones: root (the pelvis; it carries the walk's translation), spine, head,
thigh/shin and upper arm/forearm per side. Weights are set here, not by Blender's heat
diffusion, so the file is the same on every run: 1 on a part's own bone, blended by a
smoothstep across the knees and elbows and between pelvis and spine. The animation "walk" is
4 s: the root moves 1.4 units along +x (x = -0.7 .. 0.7 at y = -0.82, in front of the short
box), bobbing 1 cm, while the legs and arms swing with a 1 s period (four strides), sampled at
24 frames per second. Coordinates are the room's (z up, metres of the 2 x 2 x 2 room); the
exporter writes glTF's +y up, which prt-bake turns back.

Poses are set in armature space: every bone's transform D_k (a rotation about its rest joint,
composed down the chain) is turned into Blender's pose-bone basis, B_k^-1 D_parent^-1 D_k B_k
with B_k the bone's rest matrix, so no bone roll convention enters.
"""

import json
import math
import struct
import sys

import bpy
from mathutils import Matrix, Quaternion, Vector

SIDES = 12
FPS = 24
SECONDS = 4
START = Vector((-0.7, -0.82, 0.0))
DISTANCE = 1.4

# name: (head, tail, parent)
BONES = {
    "root": ((0, 0, 0.36), (0, 0, 0.44), None),
    "spine": ((0, 0, 0.44), (0, 0, 0.62), "root"),
    "head": ((0, 0, 0.62), (0, 0, 0.78), "spine"),
    "thigh.L": ((0, 0.05, 0.38), (0, 0.05, 0.21), "root"),
    "shin.L": ((0, 0.05, 0.21), (0, 0.05, 0.045), "thigh.L"),
    "thigh.R": ((0, -0.05, 0.38), (0, -0.05, 0.21), "root"),
    "shin.R": ((0, -0.05, 0.21), (0, -0.05, 0.045), "thigh.R"),
    "upperarm.L": ((0, 0.115, 0.60), (0, 0.115, 0.47), "spine"),
    "forearm.L": ((0, 0.115, 0.47), (0, 0.115, 0.34), "upperarm.L"),
    "upperarm.R": ((0, -0.115, 0.60), (0, -0.115, 0.47), "spine"),
    "forearm.R": ((0, -0.115, 0.47), (0, -0.115, 0.34), "upperarm.R"),
}


def smoothstep(a, b, x):
    t = min(max((x - a) / (b - a), 0.0), 1.0)
    return t * t * (3 - 2 * t)


def capsule(a, b, radius, squash=1.0):
    """Vertices, quads/triangles and each vertex's parameter s in [0, 1] from a to b of a
    capsule about the segment a-b (vertical segments only), x scaled by `squash`."""
    a, b = Vector(a), Vector(b)
    length = (b - a).length
    direction = (b - a).normalized()
    rings = []  # (distance along the axis from a, radius)
    cap = 4
    for i in range(cap - 1, 0, -1):  # the cap behind a (its pole is a vertex of its own)
        t = math.pi / 2 * i / cap
        rings.append((-radius * math.sin(t), radius * math.cos(t)))
    body = max(2, round(length / 0.02))
    rings += [(length * j / body, radius) for j in range(body + 1)]
    for i in range(1, cap):  # the cap beyond b
        t = math.pi / 2 * i / cap
        rings.append((length + radius * math.sin(t), radius * math.cos(t)))
    verts, params = [], []
    pole_a = len(verts)
    verts.append(a - direction * radius)
    params.append(0.0)
    ring_start = len(verts)
    for d, r in rings:
        for k in range(SIDES):
            phi = 2 * math.pi * k / SIDES
            offset = Vector((squash * r * math.cos(phi), r * math.sin(phi), 0.0))
            verts.append(a + direction * d + offset)
            params.append(min(max(d / length, 0.0), 1.0))
    pole_b = len(verts)
    verts.append(b + direction * radius)
    params.append(1.0)
    faces = []
    count = len(rings)
    for k in range(SIDES):
        k1 = (k + 1) % SIDES
        faces.append((pole_a, ring_start + k1, ring_start + k))
        for j in range(count - 1):
            r0, r1 = ring_start + j * SIDES, ring_start + (j + 1) * SIDES
            faces.append((r0 + k, r0 + k1, r1 + k1, r1 + k))
        last = ring_start + (count - 1) * SIDES
        faces.append((last + k, last + k1, pole_b))
    # Downward segments were built with the rings running down: keep the faces outward.
    if direction.z < 0:
        faces = [tuple(reversed(f)) for f in faces]
    return verts, faces, params


def parts():
    """(capsule, weights(s, z) -> {bone: weight}) of every part."""

    def limb(upper, lower):
        def weights(s, _z):
            w = smoothstep(0.4, 0.6, s)
            return {upper: 1 - w, lower: w}

        return weights

    def torso(_s, z):
        w = smoothstep(0.40, 0.48, z)
        return {"root": 1 - w, "spine": w}

    out = [
        (capsule((0, 0, 0.36), (0, 0, 0.58), 0.085, squash=0.7), torso),
        (capsule((0, 0, 0.70), (0, 0, 0.72), 0.06), lambda s, z: {"head": 1.0}),
    ]
    for side in "LR":
        for upper, lower, radius in (("thigh", "shin", 0.04), ("upperarm", "forearm", 0.028)):
            head = BONES[f"{upper}.{side}"][0]
            tail = BONES[f"{lower}.{side}"][1]
            out.append((capsule(head, tail, radius), limb(f"{upper}.{side}", f"{lower}.{side}")))
    return out


def build_mesh(armature):
    verts, faces, weights = [], [], []
    for (v, f, s), weigh in parts():
        base = len(verts)
        verts += v
        faces += [tuple(base + i for i in face) for face in f]
        weights += [weigh(si, p.z) for si, p in zip(s, v)]
    mesh = bpy.data.meshes.new("Walker")
    mesh.from_pydata([tuple(p) for p in verts], [], faces)
    mesh.shade_smooth()
    material = bpy.data.materials.new("Clay")
    material.use_nodes = True
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.8, 0.72, 0.62, 1)
    mesh.materials.append(material)
    obj = bpy.data.objects.new("Walker", mesh)
    bpy.context.scene.collection.objects.link(obj)
    groups = {name: obj.vertex_groups.new(name=name) for name in BONES}
    for i, w in enumerate(weights):
        for name, value in w.items():
            if value > 0:
                groups[name].add([i], value, "REPLACE")
    obj.parent = armature
    modifier = obj.modifiers.new("Armature", "ARMATURE")
    modifier.object = armature
    return obj


def build_armature():
    data = bpy.data.armatures.new("Rig")
    armature = bpy.data.objects.new("Rig", data)
    armature.location = START
    bpy.context.scene.collection.objects.link(armature)
    bpy.context.view_layer.objects.active = armature
    bpy.ops.object.mode_set(mode="EDIT")
    for name, (head, tail, parent) in BONES.items():
        bone = data.edit_bones.new(name)
        bone.head, bone.tail, bone.roll = head, tail, 0.0
        if parent:
            bone.parent = data.edit_bones[parent]
    bpy.ops.object.mode_set(mode="OBJECT")
    return armature


def about(point, angle):
    """A rotation by `angle` about the +y axis through `point` (armature space)."""
    p = Vector(point)
    return Matrix.Translation(p) @ Matrix.Rotation(angle, 4, "Y") @ Matrix.Translation(-p)


def pose_at(t):
    """Every bone's armature-space transform D_k at time t (seconds)."""
    phase = 2 * math.pi * t  # one stride a second
    d = {"root": Matrix.Translation((DISTANCE * t / SECONDS, 0, 0.012 * abs(math.sin(phase))))}
    d["spine"] = d["root"] @ about(BONES["spine"][0], math.radians(4))
    d["head"] = d["spine"]
    for side, sign in (("L", 1), ("R", -1)):
        swing = sign * math.sin(phase)
        # Legs: a thigh swinging +-25 deg (a negative angle about +y swings the foot to +x,
        # forwards), the knee bending (foot backwards) while the leg comes forward.
        thigh = math.radians(-25) * swing
        knee = math.radians(40) * max(0.0, sign * math.cos(phase))
        d[f"thigh.{side}"] = d["root"] @ about(BONES[f"thigh.{side}"][0], thigh)
        d[f"shin.{side}"] = d[f"thigh.{side}"] @ about(BONES[f"shin.{side}"][0], knee)
        # Arms swing against the legs, elbows bent forward a little.
        arm = math.radians(20) * swing
        d[f"upperarm.{side}"] = d["spine"] @ about(BONES[f"upperarm.{side}"][0], arm)
        d[f"forearm.{side}"] = d[f"upperarm.{side}"] @ about(
            BONES[f"forearm.{side}"][0], math.radians(-20) - math.radians(10) * (1 + swing)
        )
    return d


def animate(armature):
    scene = bpy.context.scene
    scene.render.fps = FPS
    scene.frame_start, scene.frame_end = 0, FPS * SECONDS
    armature.animation_data_create()
    armature.animation_data.action = bpy.data.actions.new("walk")
    for frame in range(FPS * SECONDS + 1):
        d = pose_at(frame / FPS)
        for name, (_h, _t, parent) in BONES.items():
            pb = armature.pose.bones[name]
            rest = pb.bone.matrix_local
            local = d[parent].inverted() @ d[name] if parent else d[name]
            basis = rest.inverted() @ local @ rest
            location, rotation, _scale = basis.decompose()
            pb.rotation_mode = "QUATERNION"
            pb.location, pb.rotation_quaternion = location, rotation
            pb.keyframe_insert("location", frame=frame)
            pb.keyframe_insert("rotation_quaternion", frame=frame)
    scene.frame_set(0)


def main():
    out = sys.argv[1]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    armature = build_armature()
    build_mesh(armature)
    animate(armature)
    bpy.ops.export_scene.gltf(
        filepath=out,
        export_format="GLB",
        export_yup=True,
        export_texcoords=False,
        export_normals=True,
        export_tangents=False,
        export_skins=True,
        export_animations=True,
        export_animation_mode="ACTIONS",
        export_force_sampling=True,
        export_frame_step=1,
        export_optimize_animation_size=True,
        export_def_bones=False,
        export_cameras=False,
        export_lights=False,
        export_extras=False,
    )
    skinned_mesh_at_root(out)


def skinned_mesh_at_root(path):
    """Moves the skinned mesh's node from under the armature's node to the scene's roots:
    Blender parents it, and the glTF specification (and its validator's warning
    NODE_SKINNED_MESH_NON_ROOT) wants skinned meshes at the root, where the ignored parent
    transform cannot mislead. The binary chunk is kept byte for byte."""
    data = open(path, "rb").read()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20 : 20 + length])
    rest = data[20 + length :]
    skinned = [i for i, n in enumerate(doc["nodes"]) if "skin" in n]
    for node in doc["nodes"]:
        node["children"] = [c for c in node.get("children", []) if c not in skinned]
        if not node["children"]:
            del node["children"]
    for i in skinned:
        for key in ("translation", "rotation", "scale", "matrix"):
            doc["nodes"][i].pop(key, None)
    doc["scenes"][0]["nodes"] += skinned
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    chunk = struct.pack("<II", len(text), 0x4E4F534A) + text
    total = 12 + len(chunk) + len(rest)
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, total) + chunk + rest)


if __name__ == "__main__":
    main()
