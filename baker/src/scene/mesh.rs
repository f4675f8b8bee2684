//! A loader's output: meshes and their diffuse materials, before [`super::Scene::from_meshes`]
//! joins them into a scene.

use glam::{Vec2, Vec3};

/// Diffuse reflectance of surfaces whose material sets no `Kd` and that have no texture.
pub const DEFAULT_KD: Vec3 = Vec3::splat(0.8);

/// A diffuse material: albedo = `kd` × texture (sRGB-decoded) at the surface's uv.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kd: Vec3,
    /// Index into [`super::Scene::textures`].
    pub texture: Option<usize>,
}

impl Default for Material {
    fn default() -> Material {
        Material {
            name: String::from("default"),
            kd: DEFAULT_KD,
            texture: None,
        }
    }
}

/// One mesh handed to [`super::Scene::from_meshes`]: what a loader (or a test) produces.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Per-vertex normals; computed when `None`.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates; (0, 0) when `None`.
    pub uvs: Option<Vec<Vec2>>,
    pub triangles: Vec<[u32; 3]>,
    pub material: Material,
}

/// Where a glTF scene's objects sat in its node hierarchy. The bake flattens the hierarchy
/// into world space (transfer is baked in world directions); the glTF export writes the
/// nodes back as groups with identity transforms, so names and nesting survive.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hierarchy {
    /// Every node of the scene's trees, parents before their children.
    pub nodes: Vec<HierarchyNode>,
    /// Per object, the node whose mesh it came from.
    pub object_node: Vec<u32>,
}

/// A node of [`Hierarchy`]: its name (or "node N") and its parent's index there.
#[derive(Clone, Debug, PartialEq)]
pub struct HierarchyNode {
    pub name: String,
    pub parent: Option<u32>,
}
