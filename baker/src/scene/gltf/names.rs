//! The names a glTF load gives its objects.

/// An object's name: its node's, as DCC tools and engines name objects (Blender's object
/// name; its mesh datablock may be called something else, "Plane" for a floor), else its
/// mesh's, else "node N"; a primitive's index is appended where the mesh has several.
pub(super) fn object_name(
    node: &gltf::Node,
    mesh: &gltf::Mesh,
    primitive: usize,
    primitives: usize,
) -> String {
    let base = node
        .name()
        .or(mesh.name())
        .map(str::to_string)
        .unwrap_or_else(|| format!("node {}", node.index()));
    match primitives {
        1 => base,
        _ => format!("{base}/{primitive}"),
    }
}
