//! Where rays leave a vertex, so they do not hit the surface they start on.
//!
//! A ray from exactly a vertex may report a hit at t ≈ 0 on the triangles that share the
//! vertex, by rounding alone. The origin is therefore moved off the surface along the vertex's
//! *geometric* normal n_g (the angle-weighted mean of the normals of the triangles that use
//! the vertex, so the origin is above all of them), by
//!
//! ```text
//!     δ(p) = max( 2^-16 · R,  16 · ulp(‖p‖∞) )
//! ```
//!
//! R is half the diagonal of the scene's bounding box: intersection round-off grows with the
//! size of the coordinates involved, and 2^-16 ≈ 1.5e-5 leaves a margin of about two orders
//! of magnitude over single-precision round-off at that scale. The second term covers scenes
//! placed far from the origin, where the spacing of representable coordinates, not the
//! scene's size, limits precision. Both terms scale with the scene: nothing here is an
//! absolute epsilon, so scenes a millimetre or a thousand kilometres across behave the same
//! (tested at 1e-4 and 1e5 units, and translated by 1e4).
//!
//! A ray that genuinely hits a neighbouring triangle (in a concave corner, grazing a rising
//! face) still does: the offset is far below any real feature size.

use glam::Vec3;

use crate::scene::{Scene, angle_weighted_normals};

/// The offset δ(p) for a point of a scene whose bounding-box half-diagonal is `half_diagonal`.
pub fn offset_distance(p: Vec3, half_diagonal: f32) -> f32 {
    let magnitude = p.abs().max_element();
    let ulp = f32::from_bits(magnitude.to_bits() + 1) - magnitude;
    (half_diagonal * (1.0 / 65536.0)).max(16.0 * ulp)
}

/// The origin of every ray cast from each vertex: the vertex moved by δ along n_g.
pub fn ray_origins(scene: &Scene) -> Vec<Vec3> {
    let (lo, hi) = scene.bounds();
    let half_diagonal = 0.5 * (hi - lo).length();
    let geometric = angle_weighted_normals(&scene.positions, &scene.triangles, false);
    scene
        .positions
        .iter()
        .zip(&geometric)
        .map(|(&p, &n)| p + n * offset_distance(p, half_diagonal))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_scales_with_the_scene_and_with_distance_from_the_origin() {
        assert_eq!(offset_distance(Vec3::ZERO, 1.0), 1.0 / 65536.0);
        assert_eq!(offset_distance(Vec3::ZERO, 1e-4), 1e-4 / 65536.0);
        // A 10-unit scene 1e4 away: the spacing of floats near 1e4 (≈ 1e-3) dominates.
        let far = offset_distance(Vec3::new(1e4, 0.0, 0.0), 10.0);
        assert!(far > 1e-2 && far < 2e-2, "{far}");
    }
}
