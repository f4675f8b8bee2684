//! Which files are scenes: the formats read, and the extensions refused as something else.

/// The scene formats [`super::Scene::load`] reads, for the error about any other.
pub const FORMATS: &str =
    "scene files (.scene or .txt), Wavefront OBJ (.obj), glTF 2.0 (.gltf, .glb)";

/// Extensions of formats that are recognisably something else than a scene file (which has no
/// fixed extension), refused with the list of [`FORMATS`].
pub(super) const OTHER_FORMATS: &[&str] = &[
    "ply", "stl", "fbx", "dae", "3ds", "blend", "usd", "usda", "usdc", "usdz", "abc", "x3d", "wrl",
    "off", "prt", "npz", "png", "jpg", "jpeg", "tga", "hdr", "exr", "toml",
];
