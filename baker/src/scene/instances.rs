//! Occluders traced through instances: a glTF mesh placed at many nodes is kept once, in its
//! own space, with one transform per placement, instead of being copied into world space at
//! every node (a forest of 20,000 nodes of one tree would flatten to 35.8 M
//! triangles). Only objects that do not receive are instanced: they occlude (and nothing
//! else), so they need no vertices, normals or materials in the scene.

use glam::{Affine3A, Mat3, Vec3};

/// One distinct mesh (a glTF primitive) in its own space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InstanceMesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// One placement of an [`InstanceMesh`]: mesh space to world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Index into [`Instances::meshes`].
    pub mesh: u32,
    /// An invertible affine transform (singular placements are flattened instead).
    pub to_world: Affine3A,
}

/// The scene's instanced occluders; empty for scenes loaded flat ([`super::Scene::load`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Instances {
    pub meshes: Vec<InstanceMesh>,
    pub placements: Vec<Placement>,
}

impl Instances {
    pub fn is_empty(&self) -> bool {
        self.placements.is_empty()
    }

    /// The number of triangles the placements would have flattened (what instancing saves).
    pub fn flattened_triangle_count(&self) -> u64 {
        self.placements
            .iter()
            .map(|p| self.meshes[p.mesh as usize].triangles.len() as u64)
            .sum()
    }

    /// World-space bounds `(min, max)` of placement `p`: its mesh's box's eight corners
    /// transformed.
    pub fn bounds(&self, p: usize) -> (Vec3, Vec3) {
        let placement = &self.placements[p];
        let (lo, hi) = mesh_bounds(&self.meshes[placement.mesh as usize]);
        (0..8).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), corner| {
            let pick = |bit: u32, l: f32, h: f32| if corner & bit == 0 { l } else { h };
            let c = Vec3::new(
                pick(1, lo.x, hi.x),
                pick(2, lo.y, hi.y),
                pick(4, lo.z, hi.z),
            );
            let w = placement.to_world.transform_point3(c);
            (a.min(w), b.max(w))
        })
    }
}

/// Axis-aligned bounds of a mesh's vertices.
pub fn mesh_bounds(mesh: &InstanceMesh) -> (Vec3, Vec3) {
    mesh.positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        })
}

/// The world-space geometric normal of a hit on an instance, from the mesh-space one
/// `(v1 − v0) × (v2 − v0)`: the cofactor matrix |det A|·A⁻ᵀ maps it to the normal the
/// flattened triangle has (a mirror's flattened triangles have their winding reversed, which
/// the absolute value accounts for), so front and back faces are told apart as for the flat
/// scene.
pub fn world_normal(to_world: &Affine3A, ng: Vec3) -> Vec3 {
    let linear = Mat3::from(to_world.matrix3);
    let det = linear.determinant();
    linear.inverse().transpose() * ng * det.abs()
}

/// Refuses instance meshes whose positions are not finite or whose triangles index past
/// their vertices (the tracers index with them unchecked), as flat meshes are refused.
pub fn check(instances: &Instances) -> Result<(), String> {
    for mesh in &instances.meshes {
        if mesh.positions.iter().any(|p| !p.is_finite()) {
            return Err(format!("mesh '{}': a non-finite position", mesh.name));
        }
        let count = mesh.positions.len();
        if let Some(t) = mesh
            .triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= count))
        {
            return Err(format!(
                "mesh '{}': triangle {t:?} uses a vertex past its {count}",
                mesh.name
            ));
        }
    }
    Ok(())
}
