"""What Blender's glTF exporter cannot carry into the bake, named per object and material.

prt-bake reads what the exporter writes: a Principled BSDF's Base Color (a colour, or an
Image Texture, optionally through a Mix/Multiply by a colour), its Alpha (a value, or an
image's alpha, optionally through Math Round/Greater Than: a clip), its Normal (a Normal Map
node fed an image). Anything else there (procedural textures, Bump, Color Ramps, other
shaders) the exporter drops or bakes to a constant: the bake uses that fallback and says so.
"""

SUPPORTED = {
    "Base Color": {"TEX_IMAGE", "MIX", "MIX_RGB", "SEPARATE_COLOR", "UVMAP", "MAPPING",
                   "TEX_COORD", "VERTEX_COLOR"},
    "Alpha": {"TEX_IMAGE", "MATH", "UVMAP", "MAPPING", "TEX_COORD", "SEPARATE_COLOR"},
    "Normal": {"NORMAL_MAP", "TEX_IMAGE", "UVMAP", "MAPPING", "TEX_COORD"},
}
FALLBACK = {"Base Color": "its Base Color value (no texture)",
            "Alpha": "opaque (its Alpha value)", "Normal": "the mesh's own normals"}


def _upstream(socket):
    """Every node feeding `socket`, transitively."""
    seen, stack = [], [link.from_node for link in socket.links]
    while stack:
        node = stack.pop()
        if node in seen:
            continue
        seen.append(node)
        for s in node.inputs:
            stack.extend(link.from_node for link in s.links)
    return seen


def problems(material):
    """[(what, fallback)] the bake approximates in this material."""
    if material is None or not material.use_nodes or material.node_tree is None:
        return []
    tree = material.node_tree
    output = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and
                   n.is_active_output), None)
    if output is None or not output.inputs["Surface"].is_linked:
        return [("no surface shader", "0.8 grey, opaque")]
    shader = output.inputs["Surface"].links[0].from_node
    if shader.type != "BSDF_PRINCIPLED":
        return [(f"a {shader.bl_label} shader (not a Principled BSDF)",
                 "the exporter's guess at a base colour")]
    out = []
    for name, allowed in SUPPORTED.items():
        other = sorted({n.bl_label for n in _upstream(shader.inputs[name])
                        if n.type not in allowed and n.type != "REROUTE"})
        if other:
            out.append((f"{name} from {', '.join(other)}", FALLBACK[name]))
    return out


def warnings(receivers, depsgraph):
    """One warning per object and material the bake approximates: the receivers', and the
    materials of every instance in the scene (named by the instanced object)."""
    out, seen = [], set()
    objects = list(receivers)
    for instance in depsgraph.object_instances:
        obj = instance.instance_object if instance.is_instance else instance.object
        if obj is not None and obj.type == "MESH":
            objects.append(obj.original)
    for obj in objects:
        for slot in obj.material_slots:
            key = (obj.name, slot.material.name if slot.material else None)
            if key in seen:
                continue
            seen.add(key)
            for what, fallback in problems(slot.material):
                out.append(f"{obj.name}, material {key[1]}: {what} is not exported; "
                           f"baked with {fallback}")
    return out
