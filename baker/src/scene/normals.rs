//! Angle-weighted vertex normals (Thürmer & Wüthrich 1998): each face adds its unit normal
//! times the angle it makes at the vertex, so the result does not depend on how a surface is
//! split into triangles.

use std::collections::HashMap;

use glam::Vec3;

/// Unit normals for every vertex from the faces that use it.
///
/// With `weld`, vertices at the same position share one normal (faces reaching a position
/// through any of its copies count), so seams in texture coordinates do not crease the
/// shading. Vertices no non-degenerate face touches get +z.
pub fn angle_weighted_normals(positions: &[Vec3], triangles: &[[u32; 3]], weld: bool) -> Vec<Vec3> {
    // Group id per vertex: itself, or the first vertex with the same position bits.
    let group: Vec<usize> = if weld {
        let mut first: HashMap<[u32; 3], usize> = HashMap::with_capacity(positions.len());
        positions
            .iter()
            .enumerate()
            .map(|(i, p)| *first.entry(p.to_array().map(f32::to_bits)).or_insert(i))
            .collect()
    } else {
        (0..positions.len()).collect()
    };
    let mut sum = vec![Vec3::ZERO; positions.len()];
    for tri in triangles {
        let p = tri.map(|i| positions[i as usize]);
        let Some(face_normal) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
            continue; // degenerate: no direction to contribute
        };
        for k in 0..3 {
            let e1 = p[(k + 1) % 3] - p[k];
            let e2 = p[(k + 2) % 3] - p[k];
            let angle = e1.angle_between(e2);
            if angle.is_finite() {
                sum[group[tri[k] as usize]] += face_normal * angle;
            }
        }
    }
    group
        .iter()
        .map(|&g| sum[g].try_normalize().unwrap_or(Vec3::Z))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_corner_normal_is_the_diagonal_whatever_the_split() {
        // Three faces of a cube meet at the origin; one face is split into two triangles,
        // which must not pull the normal towards it (that is what the angle weights are for).
        let p = [
            Vec3::ZERO,
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(-1.0, -1.0, 0.0),
        ];
        // Faces with outward normals +z (split in two), +x, +y at the corner.
        let tris = [[0, 1, 4], [0, 4, 2], [0, 2, 3], [0, 3, 1]];
        let n = angle_weighted_normals(&p, &tris, false)[0];
        let diagonal = Vec3::ONE.normalize();
        assert!((n - diagonal).length() < 1e-6, "{n}");
    }

    #[test]
    fn welding_joins_copies_of_a_position() {
        // A floor (normal +z) meeting a wall (normal +y) along the x axis; the vertices on the
        // fold are duplicated as at a uv seam.
        let p = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let tris = [[0, 1, 2], [3, 5, 4]];
        let welded = angle_weighted_normals(&p, &tris, true);
        let expect = Vec3::new(0.0, 1.0, 1.0).normalize();
        assert!((welded[0] - expect).length() < 1e-6, "{}", welded[0]);
        assert_eq!(welded[0], welded[3]);
        let split = angle_weighted_normals(&p, &tris, false);
        assert!((split[0] - Vec3::Z).length() < 1e-6);
        assert!((split[3] - Vec3::Y).length() < 1e-6);
    }
}
