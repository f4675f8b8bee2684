//! Which transfer probes lie inside geometry (DDGI's probe classification, Majercik et al.
//! 2019): a probe inside a closed object, under a floor or behind a wall sees mostly back
//! faces, and its matrix describes light that no point in the open space beside it receives.
//! Interpolating it in would darken (or, in a lit cavity, brighten) everything near it, so
//! the probe readers ([`crate::formats::probe_block::ProbeBlock::valid`]) leave such probes
//! out.
//!
//! Per probe, [`CLASSIFY_RAYS`] rays over the whole sphere (a spherical Fibonacci lattice,
//! the same for every probe, turned by the probe's own random rotation about z from the
//! seed) are traced for their closest hits; the stored value is the fraction that hit a back
//! face (the geometric normal facing away from the probe). A deterministic function of the
//! seed, the probe's index and its position.

use glam::Vec3;
use rayon::prelude::*;

use crate::math::sampling::{to_unit_float, vertex_seed};
use crate::trace::Tracer;

/// Rays per probe of the classification.
pub const CLASSIFY_RAYS: usize = 256;

/// The spherical Fibonacci lattice of `count` points (uniform over the sphere).
fn fibonacci_sphere(count: usize) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..count)
        .map(|i| {
            let z = 1.0 - (2 * i + 1) as f32 / count as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// Per probe, the fraction of its classification rays that hit a back face (0 with no
/// tracer: an unshadowed bake knows nothing of the geometry). `positions` are the bake's
/// probes from index `first` (a shard's or a checkpoint block's), whose rotations they take.
pub fn backface_fractions(
    tracer: Option<&dyn Tracer>,
    seed: u64,
    positions: &[Vec3],
    first: usize,
) -> Vec<f32> {
    let Some(tracer) = tracer else {
        return vec![0.0; positions.len()];
    };
    let lattice = fibonacci_sphere(CLASSIFY_RAYS);
    positions
        .par_iter()
        .enumerate()
        .map_init(
            || (Vec::with_capacity(CLASSIFY_RAYS), vec![None; CLASSIFY_RAYS]),
            |(dirs, hits), (p, &origin)| {
                let angle = std::f32::consts::TAU
                    * to_unit_float(vertex_seed(seed ^ 0x0bac_face, (first + p) as u64) as u32);
                let turn = glam::Quat::from_rotation_z(angle);
                dirs.clear();
                dirs.extend(lattice.iter().map(|d| turn * *d));
                tracer.intersect_from(origin, dirs, hits);
                let back = hits
                    .iter()
                    .zip(dirs.iter())
                    .filter(|(h, d)| h.is_some_and(|h| h.ng.dot(**d) > 0.0))
                    .count();
                back as f32 / CLASSIFY_RAYS as f32
            },
        )
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lattice_is_uniform() {
        let points = fibonacci_sphere(CLASSIFY_RAYS);
        let mean: Vec3 = points.iter().sum::<Vec3>() / CLASSIFY_RAYS as f32;
        assert!(mean.length() < 1e-3, "{mean}");
        let upper = points.iter().filter(|p| p.z > 0.0).count();
        assert_eq!(upper, CLASSIFY_RAYS / 2);
    }
}
