//! Files of some of the scene's objects (`bake --receivers`; their section:
//! [`crate::formats::receiver_section`]) at every scene vertex.
//!
//! Consumers that need a value at every scene vertex (the glTF export, relight, the viewer)
//! take [`CoefficientFile::spread_to_scene`]: the receivers' transfer where it was baked, and
//! the unshadowed transfer (the clamped-cosine lobe about the vertex normal) elsewhere.

use std::borrow::Cow;
use std::path::Path;

use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::header::{Header, TransferKind};
use crate::math::sh::Basis;
use crate::scene::Scene;
use crate::support::error::{Error, Result};
use glam::Vec3;

/// The clamped cosine's zonal coefficients per band, divided by π: (1/π)·A_l with
/// A_0 = π, A_1 = 2π/3, A_l = 0 for odd l > 1, and for even l
/// A_l = 2π (−1)^(l/2−1) / ((l+2)(l−1)) · l! / (2^l ((l/2)!)²) (Ramamoorthi & Hanrahan 2001).
fn clamped_cosine_bands(order: usize) -> Vec<f64> {
    (0..order)
        .map(|l| match l {
            0 => 1.0,
            1 => 2.0 / 3.0,
            l if l % 2 == 1 => 0.0,
            l => {
                let half = l / 2;
                // l! / (2^l (l/2)!²) = C(l, l/2) / 2^l, built up without overflow.
                let mut ratio = 1.0f64;
                for k in 1..=half {
                    ratio *= (half + k) as f64 / k as f64 / 4.0;
                }
                let sign = if half % 2 == 1 { 1.0 } else { -1.0 };
                2.0 * sign / ((l + 2) as f64 * (l - 1) as f64) * ratio
            }
        })
        .collect()
}

/// The unshadowed transfer vector of a receiver with unit normal `n`:
/// T_j = (1/π)∫ max(n·s, 0) y_j(s) ds = (A_l/π) y_j(n).
pub fn unshadowed_transfer(basis: &Basis, bands: &[f64], n: Vec3, out: &mut [f32]) {
    basis.eval(n, out);
    for (j, t) in out.iter_mut().enumerate() {
        *t *= bands[crate::math::sh::band_and_m(j).0] as f32;
    }
}

impl CoefficientFile {
    /// The file at every vertex of `scene` (whose fingerprint and receivers were checked
    /// with [`CoefficientFile::check_scene`]): itself where it covers every object; else the
    /// baked rows at the receivers' vertices and, at every other vertex, the unshadowed
    /// transfer about its normal (grey in every channel), accessibility 1 and the normal as
    /// the bent normal. Refuses a matrix file of some objects (`path` names it): no reader
    /// of matrices spreads one yet.
    pub fn spread_to_scene(&self, path: &Path, scene: &Scene) -> Result<Cow<'_, CoefficientFile>> {
        let Some(receivers) = &self.header.receivers else {
            return Ok(Cow::Borrowed(self));
        };
        if self.header.transfer == TransferKind::Matrix {
            return Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message: "a transfer-matrix bake of some objects (--receivers), which only \
                          `inspect` reads so far"
                    .into(),
            });
        }
        let order = self.header.order as usize;
        let channels = self.header.channels as usize;
        let n = order * order;
        let basis = Basis::new(order);
        let bands = clamped_cosine_bands(order);
        let vertex_count = scene.vertex_count();
        let mut coefficients = vec![0.0f32; vertex_count * channels * n];
        let mut lobe = vec![0.0f32; n];
        for (v, row) in coefficients.chunks_exact_mut(channels * n).enumerate() {
            unshadowed_transfer(&basis, &bands, scene.normals[v], &mut lobe);
            for channel in row.chunks_exact_mut(n) {
                channel.copy_from_slice(&lobe);
            }
        }
        let rows = receivers.vertices(scene);
        for (r, &v) in rows.iter().enumerate() {
            let (to, from) = (v as usize * channels * n, r * channels * n);
            coefficients[to..to + channels * n]
                .copy_from_slice(&self.coefficients[from..from + channels * n]);
        }
        let spread = |values: &Option<Vec<f32>>, fill: f32| {
            values.as_ref().map(|values| {
                let mut all = vec![fill; vertex_count];
                for (r, &v) in rows.iter().enumerate() {
                    all[v as usize] = values[r];
                }
                all
            })
        };
        let bent_normal = self.bent_normal.as_ref().map(|values| {
            let mut all = scene.normals.clone();
            for (r, &v) in rows.iter().enumerate() {
                all[v as usize] = values[r];
            }
            all
        });
        Ok(Cow::Owned(CoefficientFile {
            header: Header {
                vertex_count: vertex_count as u64,
                receivers: None,
                // The other vertices cast no rays: no adaptive arrays.
                adaptive: None,
                ..self.header.clone()
            },
            coefficients,
            ao: spread(&self.ao, 1.0),
            bent_normal,
            rays: None,
            error_estimate: None,
            lightmap: None,
            probes: None,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lobe's coefficients against a quadrature of (1/π) max(n·s, 0) y_j(s).
    #[test]
    fn unshadowed_transfer_is_the_clamped_cosine_lobe() {
        let order = 6;
        let basis = Basis::new(order);
        let bands = clamped_cosine_bands(order);
        let normal = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut lobe = vec![0.0; order * order];
        unshadowed_transfer(&basis, &bands, normal, &mut lobe);
        let (steps_t, steps_p) = (400, 800);
        let mut sum = vec![0.0f64; order * order];
        let mut y = vec![0.0f32; order * order];
        for i in 0..steps_t {
            let theta = (i as f64 + 0.5) * std::f64::consts::PI / steps_t as f64;
            for k in 0..steps_p {
                let phi = (k as f64 + 0.5) * std::f64::consts::TAU / steps_p as f64;
                let s = Vec3::new(
                    (theta.sin() * phi.cos()) as f32,
                    (theta.sin() * phi.sin()) as f32,
                    theta.cos() as f32,
                );
                let weight = theta.sin()
                    * (std::f64::consts::PI / steps_t as f64)
                    * (std::f64::consts::TAU / steps_p as f64);
                let cos = f64::from(normal.dot(s)).max(0.0);
                basis.eval(s, &mut y);
                for j in 0..y.len() {
                    sum[j] += weight * cos * f64::from(y[j]) / std::f64::consts::PI;
                }
            }
        }
        for j in 0..lobe.len() {
            assert!(
                (f64::from(lobe[j]) - sum[j]).abs() < 2e-4,
                "coefficient {j}: {} vs quadrature {}",
                lobe[j],
                sum[j]
            );
        }
    }
}
