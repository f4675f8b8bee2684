//! The memory check a glTF load makes before reading any mesh: flattening copies a mesh into
//! world space at every node that places it.

use std::path::Path;

use glam::Mat4;

use super::instancing::INSTANCE_BYTES;
use crate::support::error::Result;

/// Bytes a flattened vertex and triangle take while a scene loads: position, normal and
/// uv in the primitive read and again in the scene, the computed normals, the material index;
/// a triangle's indices, before and after the world transform.
const FLATTENED_VERTEX_BYTES: u64 = 2 * (12 + 12 + 8) + 12 + 4;
const FLATTENED_TRIANGLE_BYTES: u64 = 2 * 12;

/// Refuses, before any mesh is read, a scene whose flattened geometry would not fit the
/// memory limit: every mesh node is a copy of its mesh in world space, so a file of a few
/// megabytes that places one mesh at a million nodes asks for gigabytes.
pub(super) fn check_flattened_size(
    path: &Path,
    placed: &[(gltf::Node, gltf::Mesh, Mat4)],
    instanced: &[bool],
) -> Result<()> {
    let (mut vertices, mut triangles, mut instances) = (0u64, 0u64, 0u64);
    for ((_, mesh, _), &instance) in placed.iter().zip(instanced) {
        if instance {
            instances += 1;
            continue;
        }
        for primitive in mesh.primitives() {
            let count = primitive
                .get(&gltf::Semantic::Positions)
                .map_or(0, |a| a.count()) as u64;
            let indices = primitive.indices().map_or(count, |a| a.count() as u64);
            vertices = vertices.saturating_add(count);
            triangles = triangles.saturating_add(indices / 3);
        }
    }
    let needed = vertices
        .checked_mul(FLATTENED_VERTEX_BYTES)
        .and_then(|v| v.checked_add(triangles.checked_mul(FLATTENED_TRIANGLE_BYTES)?))
        .and_then(|v| v.checked_add(instances.checked_mul(INSTANCE_BYTES)?));
    crate::support::limits::check(
        path.display().to_string(),
        &format!(
            "flattening {} mesh nodes into {vertices} vertices and {triangles} triangles \
             ({instances} instanced)",
            placed.len()
        ),
        needed,
    )
}
