//! The transfer of a texel that nothing occludes, over a normal map: the clamped cosine lobe
//! about its shading normal n over the directions above its surface (normal h) alone,
//! (1/π) ∫_{s·h > 0} max(n·s, 0) y(s) ds. The bake counts the directions below the surface as
//! blocked ([`crate::bake::estimator`]), so where a normal map tilts n away from h, that
//! much of the whole lobe about n is never seen. The whole lobe is Â_l/π · y_lm(n)
//! (Ramamoorthi & Hanrahan 2001); the clipped one has no such closed form in n, so it is
//! tabulated once per bake over the angle θ between n and h and turned to each texel's
//! frame.
//!
//! In a frame where h is z and n = (sin θ, 0, cos θ), the lobe is even in y, so only the
//! real harmonics of cos(mφ) have a part: y_lm(θ′, φ) = y_lm(θ′, 0) cos(mφ) for m ≥ 0. For
//! each θ′ the integral over φ of max(0, a cos φ + b) cos(mφ), a = sin θ sin θ′ and b = cos θ
//! cos θ′, is closed: over |φ| < φ₀ = acos(−b/a), a/2 (S(m − 1) + S(m + 1)) + b S(m), with
//! S(0) = 2φ₀ and S(k) = 2 sin(kφ₀)/k. The integral over θ′ from 0 to π/2 is a midpoint rule.
//! Written here: no SH crate tabulates a clipped lobe.

use glam::{DMat3, Vec3};
use rayon::prelude::*;

use crate::math::sh::{Basis, RotationScratch, ZyzRotator, coeff_count};

/// Angles θ from 0 to π at which the lobe is tabulated; between them it is interpolated
/// linearly. The lobe need not be exact: a texel takes out and puts back the same one.
const BINS: usize = 512;

/// The clipped lobes of one order, tabulated over θ.
pub(super) struct ClippedLobes {
    width: usize,
    /// `BINS + 1` rows of `width` coefficients, in the frame where h is z and n lies in the
    /// xz-plane towards +x.
    table: Vec<f64>,
    rotator: ZyzRotator,
}

/// What [`ClippedLobes::lobe`] works in.
#[derive(Default)]
pub(super) struct LobeScratch {
    local: Vec<f64>,
    world: Vec<f64>,
    rotation: RotationScratch,
}

impl ClippedLobes {
    pub(super) fn new(order: usize) -> ClippedLobes {
        use std::f64::consts::{FRAC_PI_2, PI};
        let width = coeff_count(order);
        // Enough steps for band l's 2l oscillations over the hemisphere.
        let steps = 32 * order.max(8);
        let basis = Basis::new(order);
        let dt = FRAC_PI_2 / steps as f64;
        // Each step's θ′, as its sine and cosine, and its harmonics there.
        let step_angles: Vec<(f64, f64)> = (0..steps)
            .map(|k| ((k as f64 + 0.5) * dt).sin_cos())
            .collect();
        let mut ys = vec![0.0f32; steps * width];
        for (y, &(sin, cos)) in ys.chunks_exact_mut(width).zip(&step_angles) {
            basis.eval(Vec3::new(sin as f32, 0.0, cos as f32), y);
        }
        // Each coefficient's m, and the harmonics of sin(|m|φ) (m < 0) have no part.
        let ms: Vec<i32> = (0..order as i32).flat_map(|l| -l..=l).collect();
        // S(k) for k up to the order, its sines by the recurrence sin(kφ) = 2 cos φ
        // sin((k − 1)φ) − sin((k − 2)φ). The rows are independent: at order 12 the table
        // takes 0.08 CPU-s, which would otherwise hold up the filter.
        let mut table = vec![0.0f64; (BINS + 1) * width];
        let rows = table.par_chunks_exact_mut(width).enumerate();
        rows.for_each_init(
            || vec![0.0f64; order + 1],
            |sines, (bin, row)| {
                let (sin_theta, cos_theta) = (PI * bin as f64 / BINS as f64).sin_cos();
                for (y, &(sin_t, cos_t)) in ys.chunks_exact(width).zip(&step_angles) {
                    let (a, b) = (sin_theta * sin_t, cos_theta * cos_t);
                    let phi0 = match a > 0.0 {
                        true => (-b / a).clamp(-1.0, 1.0).acos(),
                        false if b > 0.0 => PI,
                        false => 0.0,
                    };
                    let (sin, cos) = phi0.sin_cos();
                    sines[1] = sin;
                    for k in 2..=order {
                        sines[k] = 2.0 * cos * sines[k - 1] - sines[k - 2];
                    }
                    let s = |k: i32| match k {
                        0 => 2.0 * phi0,
                        k => 2.0 * sines[k as usize] / f64::from(k),
                    };
                    let step = sin_t * dt / PI;
                    for ((c, &y), &m) in row.iter_mut().zip(y).zip(&ms) {
                        if m >= 0 {
                            let around = 0.5 * a * (s((m - 1).abs()) + s(m + 1)) + b * s(m);
                            *c += f64::from(y) * around * step;
                        }
                    }
                }
            },
        );
        ClippedLobes {
            width,
            table,
            rotator: ZyzRotator::new(order),
        }
    }

    /// The lobe about shading normal `n` over the hemisphere above surface normal `h` (both
    /// unit), into `out` (n² floats).
    pub(super) fn lobe(&self, n: Vec3, h: Vec3, out: &mut [f32], scratch: &mut LobeScratch) {
        let (n, h) = (n.as_dvec3(), h.as_dvec3());
        let (cos, sin) = (n.dot(h), n.cross(h).length());
        // Untilted, n − cos·h is rounding, in no direction at right angles to h: any will do,
        // as the lobe is then even about h, but the frame must be a rotation.
        let x = match sin > 1e-9 {
            true => (n - cos * h).normalize(),
            false => h.any_orthonormal_vector(),
        };
        let frame = DMat3::from_cols(x, h.cross(x), h);
        // θ from its sine and cosine both: acos alone loses it near 0, where a normal
        // rounded to f32 would read a tilt of 10⁻⁴ in an arbitrary direction.
        let at = sin.atan2(cos) / std::f64::consts::PI * BINS as f64;
        let bin = (at as usize).min(BINS - 1);
        let f = at - bin as f64;
        let (below, above) = self.table[bin * self.width..].split_at(self.width);
        scratch.local.clear();
        (scratch.local).extend(below.iter().zip(above).map(|(a, b)| a + (b - a) * f));
        scratch.world.resize(self.width, 0.0);
        let (local, world) = (&scratch.local, &mut scratch.world);
        self.rotator
            .rotate(frame, local, world, &mut scratch.rotation);
        for (o, &w) in out.iter_mut().zip(world.iter()) {
            *o = w as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::glossy::lobe_bands;
    use std::f64::consts::PI;

    /// The lobe over the surface's hemisphere, summed over a fine grid of the sphere.
    fn summed(basis: &Basis, n: Vec3, h: Vec3) -> Vec<f64> {
        let width = basis.coeff_count();
        let (rows, columns) = (600, 1200);
        let (mut sum, mut y) = (vec![0.0f64; width], vec![0.0f32; width]);
        for i in 0..rows {
            let t = (i as f64 + 0.5) * PI / rows as f64;
            let area = t.sin() * (PI / rows as f64) * (2.0 * PI / columns as f64);
            for j in 0..columns {
                let p = (j as f64 + 0.5) * 2.0 * PI / columns as f64;
                let s = glam::DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos()).as_vec3();
                if s.dot(h) <= 0.0 || s.dot(n) <= 0.0 {
                    continue;
                }
                basis.eval(s, &mut y);
                for (sum, &y) in sum.iter_mut().zip(&y) {
                    *sum += f64::from(y) * f64::from(s.dot(n)) * area / PI;
                }
            }
        }
        sum
    }

    /// The table turned to any frame gives what a sum over the sphere gives, for normals
    /// tilted a little, far, and past the surface's horizon.
    #[test]
    fn the_clipped_lobe_is_the_lobe_over_the_surface_s_hemisphere() {
        let order = 4;
        let (lobes, basis) = (ClippedLobes::new(order), Basis::new(order));
        let mut scratch = LobeScratch::default();
        for (n, h) in [
            (Vec3::new(0.3, -0.5, 0.8), Vec3::new(0.1, 0.2, 0.9)),
            (Vec3::new(0.9, 0.1, 0.2), Vec3::new(-0.2, 0.3, 0.9)),
            (Vec3::new(-0.6, 0.7, -0.3), Vec3::new(0.0, 0.0, 1.0)),
        ] {
            let (n, h) = (n.normalize(), h.normalize());
            let mut got = vec![0.0f32; coeff_count(order)];
            lobes.lobe(n, h, &mut got, &mut scratch);
            for (k, (&got, want)) in got.iter().zip(summed(&basis, n, h)).enumerate() {
                let error = (f64::from(got) - want).abs();
                assert!(
                    error < 2e-3,
                    "n {n}, h {h}, coefficient {k}: {got} against {want}"
                );
            }
        }
    }

    /// Where the shading normal is the surface's, nothing is clipped: the lobe is the clamped
    /// cosine's, Â_l/π · y_lm(n).
    #[test]
    fn an_untilted_lobe_is_the_clamped_cosine() {
        let order = 3;
        let (lobes, basis) = (ClippedLobes::new(order), Basis::new(order));
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let (mut got, mut y) = ([0.0f32; 9], [0.0f32; 9]);
        lobes.lobe(n, n, &mut got, &mut LobeScratch::default());
        basis.eval(n, &mut y);
        let bands = lobe_bands(1.0, order);
        for (j, (&got, &y)) in got.iter().zip(&y).enumerate() {
            let want = bands[(j as f64).sqrt() as usize] * y;
            assert!(
                (got - want).abs() < 1e-5,
                "coefficient {j}: {got} against {want}"
            );
        }
    }
}
