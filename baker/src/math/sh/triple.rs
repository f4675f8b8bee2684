//! The triple product of real SH (the Gaunt tensor Γ_ijk = ∫ y_i y_j y_k dω), truncated to one
//! order: the product of two order-n functions projected back to order n, and the bilinear
//! form ∫ L·T·V that relights a receiver T under light L through a visibility V.
//!
//! Γ is computed once per order by quadrature that is exact for the product of three order-n
//! basis functions (degree 3(n−1) in the direction): Gauss–Legendre in cos θ, equal steps in
//! φ. It is sparse (353 of the 4,096 entries at order 4 are non-zero) and stored as a list.

use super::basis::{Basis, coeff_count, gauss_legendre};

/// The non-zero entries of Γ at one order.
#[derive(Clone, Debug)]
pub struct Gaunt {
    order: usize,
    /// (i, j, k, Γ_ijk) for every non-zero entry, all permutations included.
    entries: Vec<(u16, u16, u16, f64)>,
}

/// Entries smaller than this are quadrature rounding of an exact zero.
const ZERO: f64 = 1e-12;

impl Gaunt {
    /// Γ at `order` (1 ≤ order ≤ [`super::MAX_ORDER`]); order 8 takes about a second.
    pub fn new(order: usize) -> Gaunt {
        let basis = Basis::new(order);
        let n = coeff_count(order);
        let degree = 3 * (order - 1);
        let (nodes, weights) = gauss_legendre(degree / 2 + 1);
        let steps = degree + 1;
        // Per quadrature point: its weight and the n basis values.
        let mut points: Vec<(f64, Vec<f64>)> = Vec::with_capacity(nodes.len() * steps);
        for (&z, &w) in nodes.iter().zip(&weights) {
            let s = (1.0 - z * z).max(0.0).sqrt();
            for k in 0..steps {
                let phi = std::f64::consts::TAU * k as f64 / steps as f64;
                let dir = glam::DVec3::new(s * phi.cos(), s * phi.sin(), z);
                let mut y = vec![0.0; n];
                basis.eval_recurrence(dir, &mut y);
                points.push((w * std::f64::consts::TAU / steps as f64, y));
            }
        }
        let mut entries = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let value: f64 = points.iter().map(|(w, y)| w * y[i] * y[j] * y[k]).sum();
                    if value.abs() > ZERO {
                        entries.push((i as u16, j as u16, k as u16, value));
                    }
                }
            }
        }
        Gaunt { order, entries }
    }

    pub fn order(&self) -> usize {
        self.order
    }

    /// The non-zero entries (i, j, k, Γ_ijk).
    pub fn entries(&self) -> &[(u16, u16, u16, f64)] {
        &self.entries
    }

    /// `out` = the order-n projection of the product of `a` and `b`: out_i = Σ_jk Γ_ijk a_j b_k.
    pub fn product(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        for &(i, j, k, g) in &self.entries {
            out[i as usize] += g * a[j as usize] * b[k as usize];
        }
    }

    /// The n²×n² matrix M_jk = Σ_i Γ_ijk L_i (row-major) of a light `l`: a receiver of
    /// transfer T seen through visibility V then reflects Σ_jk T_j M_jk V_k = ∫ L·T·V.
    pub fn light_matrix(&self, l: &[f64]) -> Vec<f64> {
        let n = coeff_count(self.order);
        let mut m = vec![0.0; n * n];
        for &(i, j, k, g) in &self.entries {
            m[j as usize * n + k as usize] += g * l[i as usize];
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// ∫ f g h by a dense independent quadrature (a Fibonacci sphere is not exact, so a fine
    /// latitude–longitude midpoint rule).
    fn integral(order: usize, f: impl Fn(DVec3) -> f64) -> Vec<f64> {
        let basis = Basis::new(order);
        let n = coeff_count(order);
        let mut out = vec![0.0; n];
        let (rows, cols) = (400, 800);
        for r in 0..rows {
            let theta = std::f64::consts::PI * (r as f64 + 0.5) / rows as f64;
            for c in 0..cols {
                let phi = std::f64::consts::TAU * (c as f64 + 0.5) / cols as f64;
                let d = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let area = theta.sin() * std::f64::consts::PI / rows as f64 * std::f64::consts::TAU
                    / cols as f64;
                let mut y = vec![0.0; n];
                basis.eval_recurrence(d, &mut y);
                for (o, yi) in out.iter_mut().zip(&y) {
                    *o += area * yi * f(d);
                }
            }
        }
        out
    }

    #[test]
    fn product_of_polynomials_matches_the_projection_of_their_product() {
        // f = 1 + x, g = z²: their product is a degree-3 polynomial, inside order 4.
        let order = 4;
        let f = integral(order, |d| 1.0 + d.x);
        let g = integral(order, |d| d.z * d.z);
        let fg = integral(order, |d| (1.0 + d.x) * d.z * d.z);
        let gaunt = Gaunt::new(order);
        let mut out = vec![0.0; 16];
        gaunt.product(&f, &g, &mut out);
        for (a, b) in out.iter().zip(&fg) {
            assert!((a - b).abs() < 1e-4, "{out:?} vs {fg:?}");
        }
    }

    #[test]
    fn constant_one_is_the_identity_and_the_tensor_is_symmetric() {
        let gaunt = Gaunt::new(3);
        let mut one = vec![0.0; 9];
        one[0] = (4.0 * std::f64::consts::PI).sqrt();
        let a: Vec<f64> = (0..9).map(|i| (i as f64 * 0.7).sin()).collect();
        let mut out = vec![0.0; 9];
        gaunt.product(&a, &one, &mut out);
        for (x, y) in out.iter().zip(&a) {
            assert!((x - y).abs() < 1e-12);
        }
        let mut b = vec![0.0; 9];
        gaunt.product(&one, &a, &mut b);
        assert_eq!(out.len(), b.len());
        for (x, y) in out.iter().zip(&b) {
            assert!((x - y).abs() < 1e-12);
        }
    }
}
