"""LDPRT on armature-deformed meshes: zonal-harmonic lobes per face corner that turn with the
skin as the armature plays (docs/guides/blender.md, "Armatures: LDPRT").

A bake reads `prt-bake export FILE.ldprt --scene scene.glb --glb` (the export with the
lobes as `_LDPRT_*` attributes in each mesh's bind space, docs/reference/gltf.md) and keeps,
per face corner, the vertex frame of the baked pose taken back to the armature's rest pose
in the armature object's space (a mesh without an armature: its own object space), the lobes'
axes in that frame, their zonal coefficients, and the export's joints and weights. Each
relight (a frame change, the light turned) skins that frame as prt-bake's `relight --pose`
and the glTF runtimes do: n = normalise(N n₀), t = N t₀ made orthogonal to n, b = n × t, each
axis turned with (t, b, n), where N = (armature world) · Σ_k w_k P_k R_k⁻¹ (P_k the bone's
posed matrix, R_k its rest matrix, both in armature space: what Blender's Armature modifier
blends). Then radiance = albedo × Σ_k Σ_l √(4π/(2l+1)) g_kl Σ_m L_lm y_lm(axis_k).

Kept on the mesh (face-corner domain): `prt_ldprt_normal`, `prt_ldprt_tangent`,
`prt_ldprt_axis{k}` (FLOAT_VECTOR), `prt_Z{k}_{l}` (lobe k's coefficient l: FLOAT, or
FLOAT_VECTOR R, G, B for an RGB bake), `prt_ldprt_vertex` (INT: the corner's vertex in the
export; corners sharing one are lit once), `prt_joint{i}` (INT) and `prt_weight{i}` (FLOAT),
i < 4; and `mesh["prt_ldprt"]` (JSON: order, lobes, channels, the bones the joints index,
the baked pose).
"""

import json
import math

import numpy as np

from . import corner_map, gltf_scene
from .errors import PrtError
from .scene_mesh import corner_albedo
from .sh_frame import GLTF_TO_BLENDER, basis

INFO = "prt_ldprt"
NORMAL, TANGENT = "prt_ldprt_normal", "prt_ldprt_tangent"
VERTEX = "prt_ldprt_vertex"  # the corner's vertex in the export: corners sharing one share lobes
INFLUENCES = 4  # JOINTS_0 / WEIGHTS_0: what Blender's exporter writes by default


def axis_name(k):
    return f"prt_ldprt_axis{k}"


def zh_name(k, l):
    return f"prt_Z{k}_{l}"


def armature_of(obj):
    """The armature object deforming `obj` (its first Armature modifier shown in the
    viewport that names one), or None."""
    for modifier in obj.modifiers:
        if modifier.type == "ARMATURE" and modifier.show_viewport and modifier.object:
            return modifier.object
    return None


def _names(mesh):
    return [a.name for a in mesh.attributes if a.name.startswith(("prt_ldprt_", "prt_Z",
                                                                  "prt_joint", "prt_weight"))]


def clear(mesh):
    """Removes an LDPRT bake's attributes from `mesh`; True if it had any."""
    names = _names(mesh)
    for name in names:
        mesh.attributes.remove(mesh.attributes[name])
    had = INFO in mesh
    if had:
        del mesh[INFO]
    return bool(names) or had


def _vertex_matrices(glb, node_index, world, count, joints, weights):
    """(count, 4, 4) per vertex the glTF matrix that placed it in the file's own pose (its
    nodes' transforms): Σ w J·IBM for a skinned node, the node's world matrix otherwise."""
    node = glb.json["nodes"][node_index]
    if "skin" not in node:
        return np.broadcast_to(world[node_index], (count, 4, 4))
    skin = glb.json["skins"][node["skin"]]
    ibm = glb.accessor(skin["inverseBindMatrices"]).astype(np.float64)
    ibm = ibm.reshape(-1, 4, 4).transpose(0, 2, 1)  # column-major
    per_joint = np.stack([world[j] for j in skin["joints"]]) @ ibm
    return np.einsum("vi,vijk->vjk", weights, per_joint[joints])


def _values(glb, index):
    """An accessor's values; normalised integers (weights may be) as fractions."""
    values = glb.accessor(index)
    accessor = glb.json["accessors"][index]
    if accessor.get("normalized") and accessor["componentType"] in (5121, 5123):
        return values / (255.0 if accessor["componentType"] == 5121 else 65535.0)
    return values


def _read_node(glb, node_index, lobes, channels):
    """The node's triangle primitives' attributes, concatenated in order."""
    mesh = glb.json["meshes"][glb.json["nodes"][node_index]["mesh"]]
    primitives = [p for p in mesh["primitives"] if p.get("mode", 4) == 4]
    zh = [f"_LDPRT_ZH_{k}" for k in range(lobes)] if channels == 1 else \
        [f"_LDPRT_ZH_{c}_{k}" for k in range(lobes) for c in "RGB"]
    names = ["POSITION", "_LDPRT_NORMAL", "_LDPRT_TANGENT",
             *[f"_LDPRT_AXIS_{k}" for k in range(lobes)], *zh]
    out = {}
    for name in names + ["JOINTS_0", "WEIGHTS_0"]:
        parts = [_values(glb, p["attributes"][name]) for p in primitives
                 if name in p["attributes"]]
        if len(parts) == len(primitives):
            out[name] = np.concatenate(parts).astype(np.float64)
        elif name in names:
            raise PrtError(f"prt-bake's LDPRT export has no {name} on mesh node "
                           f"{glb.json['nodes'][node_index].get('name')}")
    return out


def _bone_matrices(armature, bones):
    """(bones, 3, 3) the linear part of P_k R_k⁻¹ (armature space) of the named bones in the
    armature's evaluated pose, and its world matrix (4, 4)."""
    out = np.zeros((len(bones), 3, 3))
    pose = armature.pose.bones
    for k, name in enumerate(bones):
        bone = pose.get(name)
        if bone is None:
            raise PrtError(f"{armature.name} has no bone {name!r} (baked with it): bake again")
        posed = np.array(bone.matrix, np.float64)[:3, :3]
        rest = np.array(bone.bone.matrix_local, np.float64)[:3, :3]
        out[k] = posed @ np.linalg.inv(rest)
    return out, np.array(armature.matrix_world, np.float64)


def _blend(bone_matrices, joints, weights):
    """(corners, 3, 3) Σ_i w_i B[j_i], as the Armature modifier blends (the export's four
    influences per vertex)."""
    return np.einsum("ci,cijk->cjk", weights, bone_matrices[joints])


def read(glb_path, plan, depsgraph, settings):
    """Per plan receiver, the arrays `store` keeps (see the module's docstring), from prt-bake's
    LDPRT export of the bake. Its frames are in the bind space and its joints at rest (the
    baked pose, rest or not, is undone by the export), so `depsgraph` must show the armatures
    in their rest pose (the caller sets it): the corners are checked there."""
    glb = gltf_scene.Glb(glb_path)
    extras = glb.json.get("extras", {}).get("prt_ldprt", {})
    order, lobes, channels = (int(extras.get(k, 0)) for k in ("order", "lobes", "channels"))
    if order != settings.order or lobes != settings.lobes or channels not in (1, 3):
        raise PrtError(f"prt-bake's LDPRT export is of order {order} with {lobes} lobes, not "
                       f"the bake's {settings.order} and {settings.lobes}")
    world = {index: m for index, _, m in gltf_scene.walk(glb.json)}
    out = []
    for r in plan.receivers:
        a = _read_node(glb, r.node, lobes, channels)
        count = len(a["POSITION"])
        joints = a.get("JOINTS_0", np.zeros((count, INFLUENCES))).astype(np.int64)
        weights = a.get("WEIGHTS_0", np.zeros((count, INFLUENCES)))
        matrices = _vertex_matrices(glb, r.node, world, count, joints, weights)
        linear = matrices[:, :3, :3]
        position = np.einsum("vij,vj->vi", linear, a["POSITION"]) + matrices[:, :3, 3]
        normal = np.einsum("vij,vj->vi", linear, a["_LDPRT_NORMAL"])
        tangent = np.einsum("vij,vj->vi", linear, a["_LDPRT_TANGENT"])
        primitives = gltf_scene.triangle_primitives(glb, r.node)
        corner, corner_position, corner_normal = corner_map.corner_vertices(
            r.obj, depsgraph, primitives, 0)
        unit = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
        corner_map.check(r.obj, position[corner], unit[corner], corner_position,
                         corner_normal)
        # The frame at rest in Blender's world, then in the armature's space (or the
        # object's own, for a mesh no armature deforms).
        normal, tangent = normal[corner] @ GLTF_TO_BLENDER.T, tangent[corner] @ GLTF_TO_BLENDER.T
        armature = armature_of(r.obj)
        skinned = "skin" in glb.json["nodes"][r.node]
        if (armature is not None) != skinned:
            raise PrtError(f"{r.obj.name}: Blender's glTF export wrote "
                           f"{'a skin' if skinned else 'no skin'} for it, but "
                           f"{'no' if armature is None else 'an'} armature deforms it "
                           "(parent the mesh to its armature)")
        bones = []
        if skinned:
            skin = glb.json["skins"][glb.json["nodes"][r.node]["skin"]]
            bones = [glb.json["nodes"][j].get("name", "") for j in skin["joints"]]
            base = np.array(armature.evaluated_get(depsgraph).matrix_world, np.float64)
        else:
            base = np.array(r.obj.evaluated_get(depsgraph).matrix_world, np.float64)
        undo = np.broadcast_to(np.linalg.inv(base[:3, :3]), (len(corner), 3, 3))
        zh = np.zeros((len(corner), lobes, channels, order))
        for k in range(lobes):
            for c in range(channels):
                name = f"_LDPRT_ZH_{k}" if channels == 1 else f"_LDPRT_ZH_{'RGB'[c]}_{k}"
                zh[:, k, c] = a[name][corner][:, :order]
        out.append({
            "normal": np.einsum("cij,cj->ci", undo, normal),
            "tangent": np.einsum("cij,cj->ci", undo, tangent),
            "axes": np.stack([a[f"_LDPRT_AXIS_{k}"][corner] for k in range(lobes)], 1),
            "zh": zh, "vertex": corner, "joints": joints[corner] if skinned else None,
            "weights": weights[corner] if skinned else None,
            "info": {"order": order, "lobes": lobes, "channels": channels, "bones": bones,
                     "pose": extras.get("pose") or "rest"},
        })
    return out


def _set(mesh, name, kind, values):
    field = {"FLOAT_VECTOR": "vector", "FLOAT": "value", "INT": "value"}[kind]
    dtype = np.int32 if kind == "INT" else np.float32
    mesh.attributes.new(name, kind, "CORNER").data.foreach_set(
        field, np.ascontiguousarray(values, dtype).ravel())


def store(mesh, data):
    """Keeps `read`'s arrays for one mesh on its face corners (replacing any bake's)."""
    from .results import clear_transfer

    clear_transfer(mesh)
    info = data["info"]
    _set(mesh, NORMAL, "FLOAT_VECTOR", data["normal"])
    _set(mesh, TANGENT, "FLOAT_VECTOR", data["tangent"])
    _set(mesh, VERTEX, "INT", data["vertex"])
    for k in range(info["lobes"]):
        _set(mesh, axis_name(k), "FLOAT_VECTOR", data["axes"][:, k])
        for l in range(info["order"]):
            g = data["zh"][:, k, :, l]
            _set(mesh, zh_name(k, l), "FLOAT_VECTOR" if info["channels"] == 3 else "FLOAT",
                 g if info["channels"] == 3 else g[:, 0])
    if data["joints"] is not None:
        for i in range(INFLUENCES):
            _set(mesh, f"prt_joint{i}", "INT", data["joints"][:, i])
            _set(mesh, f"prt_weight{i}", "FLOAT", data["weights"][:, i])
    mesh[INFO] = json.dumps(info)


def _get(mesh, name, width):
    attribute = mesh.attributes.get(name)
    if attribute is None or attribute.domain != "CORNER":
        raise PrtError(f"{mesh.name}: no LDPRT attribute {name}: bake again")
    loops = len(mesh.loops)
    integer = attribute.data_type == "INT"
    values = np.zeros(loops * width, np.int32 if integer else np.float32)
    attribute.data.foreach_get("vector" if width == 3 else "value", values)
    values = values.astype(np.int64 if integer else np.float64)
    return values.reshape(loops, width) if width > 1 else values


def sh4(d, order):
    """(N, n²) real SH of unit directions up to order 4 as polynomials in x, y, z (the
    project's convention: Condon–Shortley phase, index l(l+1)+m; equal to sh_frame.basis to
    float rounding, about 10 times faster: relighting runs it per lobe at every frame)."""
    if order > 4:
        return basis(d, order)
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    zz = z * z
    columns = [np.full_like(x, 0.28209479177387814),
               -0.4886025119029199 * y, 0.4886025119029199 * z, -0.4886025119029199 * x,
               1.0925484305920792 * x * y, -1.0925484305920792 * y * z,
               0.31539156525252005 * (3 * zz - 1), -1.0925484305920792 * x * z,
               0.5462742152960396 * (x * x - y * y),
               -0.5900435899266435 * y * (3 * x * x - y * y), 2.890611442640554 * x * y * z,
               -0.4570457994644658 * y * (5 * zz - 1), 0.3731763325901154 * z * (5 * zz - 3),
               -0.4570457994644658 * x * (5 * zz - 1), 1.445305721320277 * z * (x * x - y * y),
               -0.5900435899266435 * x * (x * x - 3 * y * y)]
    return np.stack(columns[:order * order], 1)


def ldprt_objects(scene):
    """The scene's mesh objects that hold an LDPRT bake of the scene's order."""
    return [obj for obj in scene.objects if obj.type == "MESH" and INFO in obj.data
            and json.loads(obj.data[INFO])["order"] == scene.prt.baked_order]


def posed_frames(obj, depsgraph=None, rows=slice(None)):
    """(corners, 3, 3) the frames (t, b, n as rows) of obj's corners (those of `rows`) in the
    current pose."""
    mesh = obj.data
    info = json.loads(mesh[INFO])
    normal, tangent = _get(mesh, NORMAL, 3)[rows], _get(mesh, TANGENT, 3)[rows]
    armature = armature_of(obj) if info["bones"] else None
    if armature is not None:
        if depsgraph is not None:
            armature = armature.evaluated_get(depsgraph)
        bone_matrices, base = _bone_matrices(armature, info["bones"])
        joints = np.stack([_get(mesh, f"prt_joint{i}", 1)[rows] for i in range(INFLUENCES)], 1)
        weights = np.stack([_get(mesh, f"prt_weight{i}", 1)[rows]
                            for i in range(INFLUENCES)], 1)
        skin = base[:3, :3] @ _blend(bone_matrices, joints, weights)
    else:
        source = obj.evaluated_get(depsgraph) if depsgraph is not None else obj
        skin = np.broadcast_to(np.array(source.matrix_world, np.float64)[:3, :3],
                               (len(normal), 3, 3))
    return skin_frames(skin, normal, tangent)


def skin_frames(skin, normal, tangent):
    """The rigid-frame rule (prt-bake's `skinned_frames`): n = normalise(N n₀), t = N t₀ made
    orthogonal to n, b = n × t. Returns (corners, 3, 3) rows t, b, n."""
    n = np.einsum("cij,cj->ci", skin, normal)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    t = np.einsum("cij,cj->ci", skin, tangent)
    t -= n * np.einsum("ci,ci->c", n, t)[:, None]
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)
    return np.stack([t, np.cross(n, t), n], 1)


def radiance(obj, light, depsgraph=None):
    """(corners, 3) Σ_k Σ_l √(4π/(2l+1)) g_kl Σ_m L_lm y_lm(axis_k) (albedo excluded) for
    light (3, n²) in Blender's frame, in the current pose. Evaluated once per exported vertex
    (the face corners around a smooth vertex share it: a quarter of the work on quads)."""
    mesh = obj.data
    info = json.loads(mesh[INFO])
    order, lobes, channels = info["order"], info["lobes"], info["channels"]
    _, rows, spread = np.unique(_get(mesh, VERTEX, 1), return_index=True,
                                return_inverse=True)
    frames = posed_frames(obj, depsgraph, rows)
    out = np.zeros((len(rows), 3))
    for k in range(lobes):
        axis = np.einsum("cj,cji->ci", _get(mesh, axis_name(k), 3)[rows], frames)
        axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-30)
        y = sh4(axis, order)
        for l in range(order):
            band = slice(l * l, (l + 1) * (l + 1))
            lit = y[:, band] @ light[:, band].T  # (corners, 3)
            g = _get(mesh, zh_name(k, l), 3 if channels == 3 else 1)[rows]
            g = g if channels == 3 else g[:, None]
            out += math.sqrt(4 * math.pi / (2 * l + 1)) * g * lit
    return out[spread]


def relit_colors(obj, light, depsgraph=None):
    """(corners, 3) albedo × radiance: the "PRT" colour (albedo: the materials' Base Color
    values, as the export writes baseColorFactor)."""
    return corner_albedo(obj.data) * radiance(obj, light, depsgraph)
