//! A loader's output: meshes and their diffuse materials, before [`super::Scene::from_meshes`]
//! joins them into a scene.

use glam::{Vec2, Vec3};

use super::alpha::{Alpha, Sampling};
use super::normal_map::NormalMap;

/// Diffuse reflectance of surfaces whose material sets no `Kd` and that have no texture.
pub const DEFAULT_KD: Vec3 = Vec3::splat(0.8);

/// A material: albedo = `kd` × texture (sRGB-decoded) at the surface's uv, and an optional
/// glossy layer.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kd: Vec3,
    /// Index into [`super::Scene::textures`].
    pub texture: Option<usize>,
    /// The base colour texture's wrap modes and texture transform, for renderers and the
    /// glTF export (the baker's own albedo lookups repeat, untransformed).
    pub sampling: Sampling,
    /// The glossy layer, if the material has one. Bakes never read it (vector transfer is
    /// diffuse, and matrix transfer is the incident radiance, whatever the BRDF); renderers of
    /// matrix bakes apply it (`crate::math::glossy`).
    pub glossy: Option<Glossy>,
    /// Alpha-tested occlusion (glTF `alphaMode` MASK or BLEND, OBJ `map_d`); `None` is opaque.
    pub alpha: Option<Alpha>,
    /// A tangent-space normal map (glTF `normalTexture`): texel bakes turn each texel's lobe
    /// by it; vertex bakes cannot resolve it and keep the surface normal.
    pub normal_map: Option<NormalMap>,
    /// glTF `doubleSided`: the loaded scene gets a back sheet of receivers for the objects
    /// that use it ([`super::BackSheets`]; docs/guides/production-assets.md, "Two-sided surfaces").
    pub double_sided: bool,
}

/// A glossy layer over the diffuse one: a normalised Phong lobe about the mirror direction
/// ([`crate::math::glossy`] has the formula and the exponent mappings).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Glossy {
    /// The fraction of light the lobe reflects, per channel: MTL `Ks`; for glTF the
    /// reflectance at normal incidence, mix(0.04, base colour, metallic).
    pub ks: Vec3,
    /// The Phong exponent: MTL `Ns`, or mapped from glTF's roughness.
    pub exponent: f32,
    /// The factor on the diffuse term when the layer is rendered: 1 for MTL, and
    /// 1 − metallic for glTF (a metal has no diffuse reflection). A diffuse render (vector
    /// bakes) ignores it, so existing bakes do not change.
    pub diffuse_weight: f32,
}

impl Default for Material {
    fn default() -> Material {
        Material {
            name: String::from("default"),
            kd: DEFAULT_KD,
            texture: None,
            sampling: Sampling::default(),
            glossy: None,
            alpha: None,
            normal_map: None,
            double_sided: false,
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
    /// The node's `extras.prt.receive` where it sets one: whether a bake without
    /// `--receivers` bakes transfer for the objects at and below it (the nearest node that
    /// says decides).
    pub receive: Option<bool>,
}
