//! Leak detection: texels whose point lies inside or behind other geometry.
//!
//! Where a triangle passes under a wall or into a box, the texels there sample the inside of
//! the other object and would show its darkness (or, with light bleeding, its light) beyond
//! the seam. As Bakery and Godot do, a texel whose rays hit **back faces** in more than
//! [`LEAK_FRACTION`] of [`LEAK_RAYS`] directions is taken to be inside; the bake leaves it
//! out and dilation fills it from its neighbours. This needs consistently wound geometry:
//! a single-sided wall seen from behind looks like the inside of something.

use glam::Vec3;
use rayon::prelude::*;

use super::texels::Texels;
use crate::sampling::{Frame, Pcg32, cosine_hemisphere, vertex_seed};
use crate::trace::{Hit, Tracer};

/// Closest-hit rays per texel for the test (cosine-weighted over its hemisphere).
pub const LEAK_RAYS: usize = 64;
/// A texel is inside something when more than this fraction of its rays hit back faces.
pub const LEAK_FRACTION: f32 = 0.1;

/// Per texel, whether it leaks (only valid texels are tested). Deterministic from `seed`.
pub fn find_leaks(texels: &Texels, tracer: &dyn Tracer, seed: u64) -> Vec<bool> {
    (0..texels.valid.len())
        .into_par_iter()
        .map(|i| {
            if !texels.valid[i] {
                return false;
            }
            let frame = Frame::from_normal(texels.normals[i]);
            // Its own stream, apart from the transfer's samples.
            let mut rng = Pcg32::new(vertex_seed(seed, i as u64), 0x1eaf);
            let dirs: Vec<Vec3> = (0..LEAK_RAYS)
                .map(|_| {
                    let d = cosine_hemisphere(rng.next_f32(), rng.next_f32());
                    frame.tangent * d.x + frame.bitangent * d.y + frame.normal * d.z
                })
                .collect();
            let mut hits: Vec<Option<Hit>> = vec![None; LEAK_RAYS];
            tracer.intersect_from(texels.origins[i], &dirs, &mut hits);
            let back = hits
                .iter()
                .zip(&dirs)
                .filter(|(hit, dir)| hit.as_ref().is_some_and(|h| h.ng.dot(**dir) > 0.0))
                .count();
            back as f32 > LEAK_FRACTION * LEAK_RAYS as f32
        })
        .collect()
}
