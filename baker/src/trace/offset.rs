//! Where rays leave a vertex, so they do not hit the surface they start on.
//!
//! A ray from exactly a vertex may report a hit at t ≈ 0 on the triangles that share the
//! vertex, by rounding alone. The origin is therefore moved off the surface along the vertex's
//! *geometric* normal n_g (the angle-weighted mean of the normals of the triangles that use
//! the vertex, so the origin is above all of them), by
//!
//! ```text
//!     δ(p) = max( 8 · ulp(‖p‖∞),  2^-20 · e(p) )
//! ```
//!
//! where e(p) is the longest edge of the triangles around the vertex. Those triangles are the
//! only ones rounding can make the ray hit: the error of a ray–triangle test grows with how
//! coarsely floats are spaced at the vertex's position (the first term) and with the size of
//! the triangles involved (the second). Both terms are local: nothing here is an absolute
//! epsilon, nor tied to the size of the whole scene — a floor point beside a 2,000-unit wall
//! must stay at the wall's foot, not be lifted by a thousandth of the scene (a bug the wall
//! oracle caught, pinned by `tests/ray_offset.rs`). The constants are margins over measured
//! failure: convex spheres and flat grids at scales 1e-4 to 1e5 and up to 2e6 from the origin
//! stop seeing themselves at 1 ulp and at 2^-24·e, so 8 ulp and 2^-20·e leave 8× and 16×.
//!
//! A ray that genuinely hits a neighbouring triangle (in a concave corner, grazing a rising
//! face) still does: the offset is far below any feature the mesh resolves.
//!
//! # Vertices on another surface
//!
//! Where meshes meet edge to edge (a floor against a wall, both modelled separately), a floor
//! vertex lies *on* the wall's plane, and its rays towards the wall would start exactly on it:
//! hits at t = 0 are not reported, so the corner would be fully lit. The origin is therefore
//! also nudged along the tangent plane towards the centroid c̄ of its adjacent triangles, by
//! δ·|c̄ − p|_tangent / e(p). On the boundary of a mesh that is about δ/3 into the mesh's own
//! side; for interior vertices c̄ ≈ p and the nudge vanishes.
//!
//! # Vertices on an open edge
//!
//! On an *open* boundary (an edge of one triangle only, positions welded, so texture seams and
//! boards meeting edge to edge do not count) that nudge is too small: at the rim of an open
//! box, where two walls end, a wall's corner origin sits δ/3 — a few ulps — below the other
//! wall's top edge, so every ray towards that wall crosses its plane within rounding of the
//! rim, and whether it is blocked is a coin toss that Embree and obvhs toss differently
//! (3–6 of 1,024 rays per rim corner, all judged *ambiguous* by the f64 referee of
//! `tests/agreement.rs`, so neither backend is wrong; the origin is). There the nudge is at
//! least [`OPEN_EDGE_NUDGE`] of the longest edge: about 700 ulps at unit size, so crossings
//! land clear of the rim, and still 2⁻¹² of a triangle, far below anything the mesh resolves.

use std::collections::HashMap;

use glam::Vec3;

use crate::scene::{Scene, angle_weighted_normals};

/// The least tangential nudge of a vertex on an open edge, as a fraction of its longest edge.
pub const OPEN_EDGE_NUDGE: f32 = 1.0 / 4096.0;

/// The offset δ(p) for a vertex at `p` whose adjacent triangles' longest edge is
/// `longest_edge`.
pub fn offset_distance(p: Vec3, longest_edge: f32) -> f32 {
    let magnitude = p.abs().max_element();
    let ulp = f32::from_bits(magnitude.to_bits() + 1) - magnitude;
    (longest_edge * (1.0 / 1_048_576.0)).max(8.0 * ulp)
}

/// The origin of every ray cast from each vertex: the vertex moved by δ along n_g, and on
/// mesh boundaries nudged into its own triangles.
pub fn ray_origins(scene: &Scene) -> Vec<Vec3> {
    let count = scene.vertex_count();
    let mut longest_edge = vec![0.0f32; count];
    let mut centroid_sum = vec![Vec3::ZERO; count];
    let mut adjacent = vec![0u32; count];
    for t in &scene.triangles {
        let p = t.map(|i| scene.positions[i as usize]);
        let longest = p[0]
            .distance(p[1])
            .max(p[1].distance(p[2]))
            .max(p[2].distance(p[0]));
        let centroid = (p[0] + p[1] + p[2]) / 3.0;
        for &i in t {
            let i = i as usize;
            longest_edge[i] = longest_edge[i].max(longest);
            centroid_sum[i] += centroid;
            adjacent[i] += 1;
        }
    }
    let geometric = angle_weighted_normals(&scene.positions, &scene.triangles, false);
    let open = open_edge_vertices(scene);
    (0..count)
        .map(|v| {
            let (p, n, edge) = (scene.positions[v], geometric[v], longest_edge[v]);
            if adjacent[v] == 0 || edge == 0.0 {
                return p;
            }
            let delta = offset_distance(p, edge);
            let towards = centroid_sum[v] / adjacent[v] as f32 - p;
            let tangential = towards - n * towards.dot(n);
            let nudge = if open[v] {
                delta.max(edge * OPEN_EDGE_NUDGE)
            } else {
                delta
            };
            p + n * delta + tangential * (nudge / edge)
        })
        .collect()
}

/// `open[v]`: whether vertex `v` ends an edge that only one triangle uses, with vertices
/// welded by position (a UV seam or two boards sharing an edge is not open).
fn open_edge_vertices(scene: &Scene) -> Vec<bool> {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(scene.vertex_count());
    let welded: Vec<u32> = scene
        .positions
        .iter()
        .map(|p| {
            let next = ids.len() as u32;
            *ids.entry(p.to_array().map(f32::to_bits)).or_insert(next)
        })
        .collect();
    let mut uses: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * scene.triangles.len());
    for t in &scene.triangles {
        for k in 0..3 {
            let (a, b) = (welded[t[k] as usize], welded[t[(k + 1) % 3] as usize]);
            if a != b {
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
    }
    let mut open_position = vec![false; ids.len()];
    for (&(a, b), &n) in &uses {
        if n == 1 {
            open_position[a as usize] = true;
            open_position[b as usize] = true;
        }
    }
    welded.iter().map(|&w| open_position[w as usize]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_scales_with_the_local_triangles_and_with_distance_from_the_origin() {
        assert_eq!(offset_distance(Vec3::ZERO, 1.0), 1.0 / 1_048_576.0);
        assert_eq!(offset_distance(Vec3::ZERO, 1e-4), 1e-4 / 1_048_576.0);
        assert_eq!(offset_distance(Vec3::splat(0.5), 1.0), 1.0 / 1_048_576.0);
        // Unit triangles 1e4 from the origin: floats there are spaced 2^-10 apart.
        let far = offset_distance(Vec3::new(1e4, 0.0, 0.0), 1.0);
        assert_eq!(far, 8.0 / 1024.0);
    }
}
