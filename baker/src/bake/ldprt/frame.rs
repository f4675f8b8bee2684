//! The per-vertex frame LDPRT lobes live in: the vertex's shading normal and a tangent along
//! the first edge of the first triangle that uses the vertex, projected into the tangent
//! plane. It is built from the mesh alone (no UVs needed), so the same function run on the
//! mesh in another pose gives the frame the surface has turned to there, and a rigid turn of
//! the mesh turns every frame with it.

use glam::{DVec3, Vec3};

/// Per vertex, (tangent, bitangent, normal): orthonormal, right-handed, in world space.
pub fn vertex_frames(
    positions: &[Vec3],
    normals: &[Vec3],
    triangles: &[[u32; 3]],
) -> Vec<[DVec3; 3]> {
    let mut edge = vec![None::<u32>; positions.len()];
    for tri in triangles {
        for k in 0..3 {
            let v = tri[k] as usize;
            if edge[v].is_none() && tri[(k + 1) % 3] != tri[k] {
                edge[v] = Some(tri[(k + 1) % 3]);
            }
        }
    }
    (0..positions.len())
        .map(|v| {
            let n = normals[v].as_dvec3().normalize_or(DVec3::Z);
            let along = edge[v].map_or(DVec3::ZERO, |w| {
                (positions[w as usize] - positions[v]).as_dvec3()
            });
            let t = (along - n * along.dot(n))
                .try_normalize()
                .unwrap_or_else(|| n.any_orthonormal_vector());
            [t, n.cross(t), n]
        })
        .collect()
}

/// `local` (tangent, bitangent, normal coordinates) in world space.
pub fn to_world(frame: &[DVec3; 3], local: DVec3) -> DVec3 {
    frame[0] * local.x + frame[1] * local.y + frame[2] * local.z
}

/// `world` in the frame's (tangent, bitangent, normal) coordinates.
pub fn to_local(frame: &[DVec3; 3], world: DVec3) -> DVec3 {
    DVec3::new(
        frame[0].dot(world),
        frame[1].dot(world),
        frame[2].dot(world),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_turn_with_the_mesh() {
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let normals = [Vec3::Z; 3];
        let triangles = [[0, 1, 2]];
        let q = glam::Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let turned: Vec<Vec3> = positions.iter().map(|p| q * *p).collect();
        let turned_normals: Vec<Vec3> = normals.iter().map(|n| q * *n).collect();
        let a = vertex_frames(&positions, &normals, &triangles);
        let b = vertex_frames(&turned, &turned_normals, &triangles);
        for (fa, fb) in a.iter().zip(&b) {
            for k in 0..3 {
                assert!((q.as_dquat() * fa[k] - fb[k]).length() < 1e-6);
            }
        }
        assert!((a[0][0] - DVec3::X).length() < 1e-12);
    }
}
