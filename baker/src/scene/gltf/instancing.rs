//! Which mesh nodes a glTF load keeps as instances ([`crate::scene::Instances`]) rather than
//! flattening, and reading their meshes once, in mesh space.
//!
//! A node is instanced when none of its objects receives, every primitive of its mesh is an
//! opaque triangle primitive (alpha cut-outs and materials stay on the flat path, where the
//! tracers test them), its transform is invertible, and its mesh is placed at two nodes or
//! more that qualify. All of that only where it keeps at least
//! [`Instancing::min_triangles`] triangles out of the flattened scene.

use std::collections::HashMap;

use glam::{Affine3A, Mat4};
use gltf::material::AlphaMode;
use gltf::mesh::Mode;

use super::names::object_name;
use crate::scene::instances::{InstanceMesh, Instances, Placement};
use crate::scene::mesh::{Hierarchy, Mesh};
use crate::support::error::Result;

/// Which receivers a load keeps flat, and when instancing is worth it.
pub struct Instancing<'a> {
    /// Whether the object named `name`, from hierarchy node `node`, receives (is baked):
    /// receivers are always flattened.
    pub receives: &'a dyn Fn(&Hierarchy, u32, &str) -> bool,
    /// Instance only when that keeps at least this many triangles out of the flattened
    /// scene (0: whenever a mesh is shared).
    pub min_triangles: u64,
}

/// Flattened triangles that instancing must save before `bake --instances auto` (the
/// default) uses it: below this, flattening costs little, and a flat scene's file suits every
/// consumer. Readers of a file try it first ([`crate::formats`]' `load_scene`).
pub const AUTO_MIN_TRIANGLES: u64 = 1_000_000;

/// Bytes an instance costs the tracers (Embree's instance geometry and its BVH leaf, our
/// transforms and top-level BVH node), for the memory check.
pub const INSTANCE_BYTES: u64 = 1024;

/// Per placed node, whether it is instanced.
pub(super) fn choose(
    placed: &[(gltf::Node, gltf::Mesh, Mat4)],
    hierarchy: &Hierarchy,
    at: &[u32],
    instancing: Option<&Instancing>,
) -> Vec<bool> {
    let Some(instancing) = instancing else {
        return vec![false; placed.len()];
    };
    let eligible: Vec<bool> = placed
        .iter()
        .map(|(node, mesh, world)| {
            let count = mesh.primitives().len();
            let occluder_only = mesh.primitives().all(|p| {
                let name = object_name(node, mesh, p.index(), count);
                matches!(
                    p.mode(),
                    Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
                ) && p.material().alpha_mode() == AlphaMode::Opaque
                    && !(instancing.receives)(hierarchy, at[node.index()], &name)
            });
            let det = world.determinant();
            occluder_only && det.is_finite() && det != 0.0 && world.is_finite()
        })
        .collect();
    let mut uses: HashMap<usize, u32> = HashMap::new();
    for ((_, mesh, _), &e) in placed.iter().zip(&eligible) {
        if e {
            *uses.entry(mesh.index()).or_default() += 1;
        }
    }
    let chosen: Vec<bool> = placed
        .iter()
        .zip(&eligible)
        .map(|((_, mesh, _), &e)| e && uses[&mesh.index()] >= 2)
        .collect();
    let saved: u64 = placed
        .iter()
        .zip(&chosen)
        .filter(|&(_, &c)| c)
        .map(|((_, mesh, _), _)| triangle_count(mesh))
        .sum();
    match saved >= instancing.min_triangles.max(1) {
        true => chosen,
        false => vec![false; placed.len()],
    }
}

/// A mesh's triangles as its accessors count them (before reading it).
pub(super) fn triangle_count(mesh: &gltf::Mesh) -> u64 {
    mesh.primitives()
        .map(|p| {
            let count = p.get(&gltf::Semantic::Positions).map_or(0, |a| a.count()) as u64;
            p.indices().map_or(count, |a| a.count() as u64) / 3
        })
        .sum()
}

/// Adds a placement of every triangle primitive of `mesh` at `world` to `instances`,
/// reading each primitive (`read`: in mesh space) the first time it is placed (`seen`:
/// (mesh, primitive) → instance mesh).
pub(super) fn place(
    node: &gltf::Node,
    mesh: &gltf::Mesh,
    world: Mat4,
    read: &mut dyn FnMut(&gltf::Primitive, String) -> Result<Option<Mesh>>,
    seen: &mut HashMap<(usize, usize), u32>,
    instances: &mut Instances,
) -> Result<()> {
    let count = mesh.primitives().len();
    for primitive in mesh.primitives() {
        let key = (mesh.index(), primitive.index());
        let index = match seen.get(&key) {
            Some(&index) => index,
            None => {
                let name = object_name(node, mesh, primitive.index(), count);
                let Some(read) = read(&primitive, name)?.filter(|m| !m.triangles.is_empty()) else {
                    continue;
                };
                let index = instances.meshes.len() as u32;
                instances.meshes.push(InstanceMesh {
                    name: read.name,
                    positions: read.positions,
                    triangles: read.triangles,
                });
                seen.insert(key, index);
                index
            }
        };
        instances.placements.push(Placement {
            mesh: index,
            to_world: Affine3A::from_mat4(world),
        });
    }
    Ok(())
}
